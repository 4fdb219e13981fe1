// Metadata keys and the JSON form of profiles (docs/vdb.md, "Metadata").
#include "vdb_format.hpp"

#include <cstdio>

#ifndef AIRMASS_VERSION
#define AIRMASS_VERSION "unknown"
#endif

namespace airmass::detail {

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

namespace {
openvdb::Vec3d vec3(const std::array<double, 3>& a) { return openvdb::Vec3d(a[0], a[1], a[2]); }
}  // namespace

void add_common_metadata(openvdb::MetaMap& m, const VdbLayout& layout) {
    m.insertMeta("airmass:version", openvdb::StringMetadata(AIRMASS_VERSION));
    m.insertMeta("airmass:format_version", openvdb::Int32Metadata(kVdbFormatVersion));
    m.insertMeta("airmass:length_unit", openvdb::StringMetadata(std::string(length_unit_name(layout.options.unit))));
    m.insertMeta("airmass:planet_radius", openvdb::DoubleMetadata(layout.planet_radius));
    m.insertMeta("airmass:planet_center", openvdb::Vec3DMetadata(layout.planet_center));
    m.insertMeta("airmass:atmosphere_top", openvdb::DoubleMetadata(layout.atmosphere_top));
    m.insertMeta("airmass:voxel_size", openvdb::DoubleMetadata(layout.voxel_size));
    m.insertMeta("airmass:spectral_basis", openvdb::StringMetadata(layout.spectral_basis));
    m.insertMeta("airmass:rgb_wavelengths_nm", openvdb::Vec3DMetadata(vec3(layout.rgb_wavelengths_nm)));
    m.insertMeta("airmass:region", openvdb::StringMetadata(std::string(region_name(layout.options.region))));
    m.insertMeta("airmass:scene_name", openvdb::StringMetadata(layout.scene_name));
}

void add_grid_metadata(openvdb::MetaMap& m, const VdbLayout& layout, const VdbConstituent& c, std::size_t tile,
                       std::size_t tile_count) {
    add_common_metadata(m, layout);
    m.insertMeta("airmass:constituent", openvdb::StringMetadata(c.name));
    m.insertMeta("airmass:profile",
                 openvdb::StringMetadata(profile_json(c.source->profile, layout.metres_per_unit).dump()));
    m.insertMeta("airmass:scattering_rgb", openvdb::Vec3DMetadata(vec3(c.scattering_rgb)));
    m.insertMeta("airmass:absorption_rgb", openvdb::Vec3DMetadata(vec3(c.absorption_rgb)));
    m.insertMeta("airmass:phase", openvdb::StringMetadata(phase_name(c.source->phase.kind)));
    m.insertMeta("airmass:g", openvdb::DoubleMetadata(c.source->phase.g));
    m.insertMeta("airmass:density_threshold", openvdb::DoubleMetadata(c.density_threshold));
    m.insertMeta("airmass:density_max", openvdb::DoubleMetadata(c.density_max));
    m.insertMeta("airmass:tile", openvdb::Int32Metadata(int(tile)));
    m.insertMeta("airmass:tile_count", openvdb::Int32Metadata(int(tile_count)));
}

openvdb::MetaMap::Ptr file_metadata(const VdbLayout& layout, std::size_t tile, std::size_t tile_count) {
    auto m = std::make_shared<openvdb::MetaMap>();
    add_common_metadata(*m, layout);
    m->insertMeta("airmass:scene", openvdb::StringMetadata(layout.scene_json));
    m->insertMeta("airmass:tile", openvdb::Int32Metadata(int(tile)));
    m->insertMeta("airmass:tile_count", openvdb::Int32Metadata(int(tile_count)));
    return m;
}

}  // namespace airmass::detail
