// What a volume carries besides its voxels, in one place: metadata keys and values, file
// names, the tiles manifest, the statistics report (docs/vdb.md, "Metadata", "Tiling").
#include "volume_format.hpp"

#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#ifndef AIRMASS_VERSION
#define AIRMASS_VERSION "unknown"
#endif

namespace airmass {

namespace detail {

std::string fmt(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", x);
    return buf;
}

std::string mib(double bytes) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f MiB", bytes / (1024.0 * 1024.0));
    return buf;
}

nlohmann::json profile_json(const DensityProfile& p, double L) {
    using nlohmann::json;
    switch (p.kind) {
        case DensityProfile::Kind::exponential:
            return json{{"type", "exponential"}, {"scale_height", p.scale_height_m / L},
                        {"reference_altitude", p.reference_altitude_m / L}};
        case DensityProfile::Kind::tent:
            return json{{"type", "tent"}, {"bottom", p.bottom_m / L}, {"peak", p.peak_m / L}, {"top", p.top_m / L}};
        case DensityProfile::Kind::piecewise_linear: {
            json knots = json::array();
            for (const auto& k : p.knots) knots.push_back(json::array({k.first / L, k.second}));
            return json{{"type", "piecewise_linear"}, {"knots", knots}};
        }
        case DensityProfile::Kind::constant:
            return json{{"type", "constant"},
                        {"value", p.value},
                        {"bottom", p.bottom_m / L},
                        {"top", p.top_m > p.bottom_m ? json(p.top_m / L) : json(nullptr)}};
    }
    return json::object();
}

std::string phase_name(PhaseFunction::Kind k) {
    switch (k) {
        case PhaseFunction::Kind::rayleigh: return "rayleigh";
        case PhaseFunction::Kind::rayleigh_modified: return "rayleigh_modified";
        case PhaseFunction::Kind::cornette_shanks: return "cornette_shanks";
        case PhaseFunction::Kind::henyey_greenstein: return "henyey_greenstein";
        case PhaseFunction::Kind::isotropic: return "isotropic";
    }
    return "?";
}

std::string suggest_voxel(const VdbLayout& layout, double ratio, double exponent) {
    return fmt(layout.voxel_size * std::pow(std::max(1.0, ratio), 1.0 / exponent) * 1.05) + " " +
           std::string(length_unit_name(layout.options.unit));
}

}  // namespace detail

using detail::fmt;
using detail::mib;

std::string_view volume_meta_type(const VolumeMetaValue& v) {
    switch (v.index()) {
        case 0: return "string";
        case 1: return "double";
        case 2: return "int32";
        case 3: return "vec3d";
        default: return "vec3i";
    }
}

namespace {

std::array<double, 3> vec3(const Vec3<double>& v) { return {v.x, v.y, v.z}; }

void add_common(std::vector<VolumeMetadatum>& m, const VdbLayout& layout) {
    m.push_back({"airmass:version", std::string(AIRMASS_VERSION)});
    m.push_back({"airmass:format_version", std::int32_t(kVdbFormatVersion)});
    m.push_back({"airmass:length_unit", std::string(length_unit_name(layout.options.unit))});
    m.push_back({"airmass:planet_radius", layout.planet_radius});
    m.push_back({"airmass:planet_center", vec3(layout.planet_center)});
    m.push_back({"airmass:atmosphere_top", layout.atmosphere_top});
    m.push_back({"airmass:voxel_size", layout.voxel_size});
    m.push_back({"airmass:spectral_basis", layout.spectral_basis});
    m.push_back({"airmass:rgb_wavelengths_nm", layout.rgb_wavelengths_nm});
    m.push_back({"airmass:region", std::string(region_name(layout.options.region))});
    m.push_back({"airmass:scene_name", layout.scene_name});
}

}  // namespace

std::vector<VolumeMetadatum> volume_grid_metadata(const VdbLayout& layout, std::size_t constituent, std::size_t tile,
                                                  std::size_t tile_count, const VoxelCoord& index_offset) {
    const VdbConstituent& c = layout.constituents.at(constituent);
    std::vector<VolumeMetadatum> m;
    add_common(m, layout);
    m.push_back({"airmass:constituent", c.name});
    m.push_back({"airmass:profile", detail::profile_json(c.source->profile, layout.metres_per_unit).dump()});
    m.push_back({"airmass:scattering_rgb", c.scattering_rgb});
    m.push_back({"airmass:absorption_rgb", c.absorption_rgb});
    m.push_back({"airmass:phase", detail::phase_name(c.source->phase.kind)});
    m.push_back({"airmass:g", c.source->phase.g});
    m.push_back({"airmass:density_threshold", c.density_threshold});
    m.push_back({"airmass:density_max", c.density_max});
    m.push_back({"airmass:voxel_values", std::string(voxel_values_name(c.values))});
    m.push_back({"airmass:tile", std::int32_t(tile)});
    m.push_back({"airmass:tile_count", std::int32_t(tile_count)});
    // Several tiles: this grid's voxel (i, j, k) is voxel (i, j, k) + airmass:index_offset of the
    // common lattice (the manifest's bboxes); its transform already includes the shift.
    if (tile_count > 1) m.push_back({"airmass:index_offset", index_offset});
    return m;
}

std::vector<VolumeMetadatum> volume_file_metadata(const VdbLayout& layout, std::size_t tile, std::size_t tile_count) {
    std::vector<VolumeMetadatum> m;
    add_common(m, layout);
    m.push_back({"airmass:scene", layout.scene_json});
    m.push_back({"airmass:tile", std::int32_t(tile)});
    m.push_back({"airmass:tile_count", std::int32_t(tile_count)});
    return m;
}

std::vector<std::string> volume_file_names(std::string_view stem, std::size_t tiles) {
    const std::string s(stem);
    if (tiles <= 1) return {s + ".vdb"};
    // "<stem>.003.tile.vdb". Blender 3.4's importer (File > Import > OpenVDB) turns any
    // multi-file selection of numbered names into one animated sequence unless "Detect
    // Sequences" is off (use_sequence_detection=False); docs/vdb.md says so.
    std::vector<std::string> out;
    for (std::size_t t = 0; t < tiles; ++t) {
        char idx[32];
        std::snprintf(idx, sizeof idx, "%03zu", t);
        out.push_back(s + "." + idx + ".tile.vdb");
    }
    out.push_back(s + ".tiles.json");
    return out;
}

std::string volume_tiles_manifest(const VdbLayout& L, const VdbStats& stats, const std::vector<std::string>& names) {
    using nlohmann::json;
    json tiles = json::array();
    for (std::size_t t = 0; t < stats.tiles; ++t) {
        json grids = json::object();
        for (const auto& g : stats.grids) {
            if (g.tile != t) continue;
            grids[g.name] = json{{"active_voxels", g.active_voxels},
                                 {"bbox_min", {g.bbox[0], g.bbox[1], g.bbox[2]}},
                                 {"bbox_max", {g.bbox[3], g.bbox[4], g.bbox[5]}}};
        }
        const VoxelCoord o = t < stats.index_offsets.size() ? stats.index_offsets[t] : VoxelCoord{0, 0, 0};
        tiles.push_back(json{{"file", t < names.size() ? names[t] : std::string()},
                             {"index_offset", {o[0], o[1], o[2]}},
                             {"grids", grids}});
    }
    json j{{"format", "airmass-vdb-tiles"},
           {"format_version", kVdbTilesManifestVersion},
           {"index_space",
            "bbox_min/bbox_max (inclusive) are in the common lattice, world = voxel_size * (i, j, k); a tile's "
            "grids hold voxel (i, j, k) of it at (i, j, k) - index_offset, with the translation "
            "voxel_size * index_offset in their transforms"},
           {"length_unit", std::string(length_unit_name(L.options.unit))},
           {"voxel_size", L.voxel_size},
           {"planet_center", {L.planet_center.x, L.planet_center.y, L.planet_center.z}},
           {"planet_radius", L.planet_radius},
           {"atmosphere_top", L.atmosphere_top},
           {"tiles", tiles}};
    return j.dump(2) + "\n";
}

std::string VdbStats::summary() const {
    std::ostringstream o;
    const std::string u(length_unit_name(unit));
    o << "voxel size " << fmt(voxel_size) << " " << u << ", " << tiles << " tile(s)\n";
    char line[256];
    std::snprintf(line, sizeof line, "  %-12s %5s %14s %22s %12s %12s\n", "grid", "tile", "active voxels",
                  "dense box (voxels)", "dense", "memory");
    o << line;
    // Per tile when there are few; per grid (summed over tiles) otherwise.
    const bool per_tile = tiles <= 4;
    std::map<std::string, VdbGridStats> sums;
    std::vector<std::string> order;
    for (const auto& g : grids) {
        if (per_tile) {
            const std::string box = std::to_string(g.bbox[3] - g.bbox[0] + 1) + "x" +
                                    std::to_string(g.bbox[4] - g.bbox[1] + 1) + "x" +
                                    std::to_string(g.bbox[5] - g.bbox[2] + 1);
            std::snprintf(line, sizeof line, "  %-12s %5zu %14llu %22s %12s %12s\n", g.name.c_str(), g.tile,
                          (unsigned long long)g.active_voxels, box.c_str(), mib(double(g.dense_voxels) * 4).c_str(),
                          mib(double(g.memory_bytes)).c_str());
            o << line;
        } else {
            if (!sums.count(g.name)) order.push_back(g.name);
            auto& s = sums[g.name];
            s.active_voxels += g.active_voxels;
            s.dense_voxels += g.dense_voxels;
            s.memory_bytes += g.memory_bytes;
        }
    }
    for (const auto& name : order) {
        const auto& s = sums[name];
        std::snprintf(line, sizeof line, "  %-12s %5s %14llu %22s %12s %12s\n", name.c_str(), "all",
                      (unsigned long long)s.active_voxels, "-", mib(double(s.dense_voxels) * 4).c_str(),
                      mib(double(s.memory_bytes)).c_str());
        o << line;
    }
    o << "  total: " << active_voxels << " active voxels, " << mib(double(memory_bytes)) << " in memory, dense boxes "
      << mib(double(dense_bytes)) << " (as one tile: " << mib(double(dense_bytes_untiled)) << "), built in "
      << fmt(build_seconds) << " s";
    if (!files.empty()) o << ", written in " << fmt(write_seconds) << " s, " << mib(double(file_bytes)) << " on disk";
    o << "\n";
    return o.str();
}

}  // namespace airmass
