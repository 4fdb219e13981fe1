// The voxel-size trade's tables as text (airmass/vdb_trade.hpp): CSV and Markdown of a
// VdbTradeResult, and the run's list of tolerances and progress steps. OpenVDB-free (library
// airmass_vdb_files): `airmass report vdb` formats here what the OpenVDB module measured.
#include <algorithm>
#include <cstdio>
#include <sstream>
#include <string>
#include <utility>

#include "airmass/vdb_trade.hpp"

namespace airmass {

namespace {

std::string g4(double x) {
    char b[32];
    std::snprintf(b, sizeof b, "%.4g", x);
    return b;
}
std::string e2(double x) {
    char b[32];
    std::snprintf(b, sizeof b, "%.2e", x);
    return b;
}

// A Markdown table of rows × rays over `records` (each with .ray): one row per value of
// key(x), one column per ray, both in the order they first appear. `head` opens the header
// row and is followed by `head_columns` right-aligned columns; row_head(k) opens row k,
// cell(x) is record x's cell.
template <class Record, class Key, class RowHead, class Cell>
void rows_by_rays(std::ostringstream& o, const std::vector<Record>& records, Key key, const std::string& head,
                  int head_columns, RowHead row_head, Cell cell) {
    std::vector<std::string> rays;
    std::vector<decltype(key(records.front()))> keys;
    for (const auto& x : records) {
        if (std::find(rays.begin(), rays.end(), x.ray) == rays.end()) rays.push_back(x.ray);
        if (std::find(keys.begin(), keys.end(), key(x)) == keys.end()) keys.push_back(key(x));
    }
    o << head;
    for (const auto& n : rays) o << " " << n << " |";
    o << "\n|";
    for (int i = 0; i < head_columns; ++i) o << "---:|";
    for (std::size_t i = 0; i < rays.size(); ++i) o << "---:|";
    o << "\n";
    for (const auto& k : keys) {
        o << row_head(k);
        for (const auto& n : rays)
            for (const auto& x : records)
                if (key(x) == k && x.ray == n) o << " " << cell(x) << " |";
        o << "\n";
    }
}

}  // namespace

std::vector<double> vdb_trade_tolerances(const VdbTradeOptions& options) {
    if (options.tolerances.empty()) return {};
    std::vector<double> t = options.tolerances;
    t.push_back(0.0);
    std::sort(t.begin(), t.end());
    t.erase(std::unique(t.begin(), t.end()), t.end());
    return t;
}

std::size_t vdb_trade_steps(const VdbTradeOptions& options) {
    return options.voxel_sizes.size() * options.voxel_values.size() + vdb_trade_tolerances(options).size();
}

std::string vdb_trade_rays_csv(const VdbTradeResult& r) {
    std::ostringstream o;
    o << "voxel_size_km,voxel_values,ray,tau_ref_r,tau_ref_g,tau_ref_b,tau_vdb_r,tau_vdb_g,tau_vdb_b,tau_rel_error_max,"
         "transmittance_abs_error_max\n";
    char b[512];
    for (const auto& x : r.rays) {
        std::snprintf(b, sizeof b, "%.17g,%s,%s,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", x.voxel_size,
                      std::string(voxel_values_name(x.voxel_values)).c_str(), x.ray.c_str(), x.tau_ref[0],
                      x.tau_ref[1], x.tau_ref[2], x.tau_vdb[0], x.tau_vdb[1], x.tau_vdb[2],
                      x.tau_rel_error_max, x.transmittance_abs_error_max);
        o << b;
    }
    return o.str();
}

namespace {

std::string costs_csv(const std::vector<VdbTradeCostRow>& rows, bool with_tolerance) {
    std::ostringstream o;
    o << (with_tolerance ? "tolerance," : "")
      << "voxel_size_km,voxel_values,region,refused,active_voxels,memory_bytes,dense_bytes,file_bytes,tiles,build_s,write_s,"
         "voxels_per_s\n";
    char b[512];
    for (const auto& c : rows) {
        if (with_tolerance) {
            std::snprintf(b, sizeof b, "%.17g,", c.tolerance);
            o << b;
        }
        const double rate = c.refused ? 0.0 : double(c.active_voxels) / (c.build_seconds + c.write_seconds);
        std::snprintf(b, sizeof b, "%.17g,%s,%s,%d,%llu,%llu,%llu,%llu,%zu,%.6f,%.6f,%.6g\n", c.voxel_size,
                      std::string(voxel_values_name(c.voxel_values)).c_str(), c.region.c_str(),
                      int(c.refused), (unsigned long long)c.active_voxels, (unsigned long long)c.memory_bytes,
                      (unsigned long long)c.dense_bytes, (unsigned long long)c.file_bytes, c.tiles, c.build_seconds,
                      c.write_seconds, rate);
        o << b;
    }
    return o.str();
}

}  // namespace

std::string vdb_trade_costs_csv(const VdbTradeResult& r) { return costs_csv(r.costs, false); }

std::string vdb_tolerance_costs_csv(const VdbTradeResult& r) { return costs_csv(r.tolerance_costs, true); }

std::string vdb_tolerance_rays_csv(const VdbTradeResult& r) {
    std::ostringstream o;
    o << "tolerance,voxel_size_km,ray,tau_vdb_r,tau_vdb_g,tau_vdb_b,tau_removed_max,tau_rel_error_max\n";
    char b[512];
    for (const auto& x : r.tolerance_rays) {
        std::snprintf(b, sizeof b, "%.17g,%.17g,%s,%.17g,%.17g,%.17g,%.17g,%.17g\n", x.tolerance, r.tolerance_voxel_size,
                      x.ray.c_str(), x.tau_vdb[0], x.tau_vdb[1], x.tau_vdb[2], x.tau_removed_max, x.tau_rel_error_max);
        o << b;
    }
    return o.str();
}

std::string vdb_tolerance_markdown(const VdbTradeResult& r, const std::string& scene_name) {
    if (r.tolerance_rays.empty()) return {};
    std::ostringstream o;
    o << "Scene `" << scene_name << "`, " << g4(r.tolerance_voxel_size) << "-km voxels. Optical depth the inactive "
      << "cells remove, τ(0) − τ(tolerance), the largest over R, G, B, through grids on the same lattice (the voxel "
      << "size's own error cancels); bound: the tolerance per constituent (" << r.constituents
      << " here). In brackets the error against the analytic value, voxel size included.\n\n";
    rows_by_rays(
        o, r.tolerance_rays, [](const VdbToleranceRayRow& x) { return x.tolerance; }, "| tolerance | bound |", 2,
        [&](double t) {
            return "| " + (t == 0 ? std::string("0 (all)") : g4(t)) + " | " + e2(t * double(r.constituents)) + " |";
        },
        [](const VdbToleranceRayRow& x) { return e2(x.tau_removed_max) + " (" + e2(x.tau_rel_error_max) + ")"; });
    o << "\nWhat each tolerance costs at " << g4(r.tolerance_voxel_size)
      << "-km voxels (regions as in the voxel-size table).\n\n"
      << "| tolerance | region | active voxels | memory (MiB) | dense (MiB) | file (MiB) | build (s) | write (s) |\n"
      << "|---:|---|---:|---:|---:|---:|---:|---:|\n";
    const double M = 1024.0 * 1024.0;
    for (const auto& c : r.tolerance_costs) {
        o << "| " << (c.tolerance == 0 ? std::string("0 (all)") : g4(c.tolerance)) << " | " << c.region << " | ";
        if (c.refused) {
            o << "refused: " << c.note << " ||||||\n";
            continue;
        }
        o << c.active_voxels << " | " << g4(double(c.memory_bytes) / M) << " | " << g4(double(c.dense_bytes) / M) << " | "
          << g4(double(c.file_bytes) / M) << " | " << g4(c.build_seconds) << " | " << g4(c.write_seconds) << " |\n";
    }
    return o.str();
}

std::string vdb_trade_markdown(const VdbTradeResult& r, const std::string& scene_name) {
    std::ostringstream o;
    o << "Scene `" << scene_name << "`. Largest error over R, G, B of the optical depth through the grids "
      << "(trilinear) against the analytic value; in brackets the transmittance error |ΔT|. Values (`--voxel-values`): "
      << "`average` = each voxel the density's mean over its trilinear footprint in the air, `point` = the density "
      << "at its centre, `auto` (the default) = average for a constituent whose thinnest layer is under two voxels "
      << "(Earth's aerosol, 1.2 km, above 0.6-km voxels) where rays cross the layer — here the slab, a box —, "
      << "point for the others and in views from inside the layer (the `view-200km` costs: a ground camera).\n\n";
    rows_by_rays(
        o, r.rays, [](const VdbTradeRayRow& x) { return std::pair(x.voxel_size, x.voxel_values); },
        "| voxel (km) | values |", 2,
        [](const std::pair<double, VoxelValues>& k) {
            return "| " + g4(k.first) + " | " + std::string(voxel_values_name(k.second)) + " |";
        },
        [](const VdbTradeRayRow& x) { return e2(x.tau_rel_error_max) + " (" + e2(x.transmittance_abs_error_max) + ")"; });
    o << "\nWhat each voxel size costs: `view-200km` is the Earth view region of a ground camera (60°, 640×360, "
         "200 km), `slab` the box holding the rays above. Dense = what Blender 3.4 allocates (Σ tile boxes × 4 B).\n\n"
      << "| voxel (km) | values | region | active voxels | memory (MiB) | dense (MiB) | file (MiB) | tiles | "
         "build (s) | write (s) | voxels/s |\n|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const auto& c : r.costs) {
        const std::string values(voxel_values_name(c.voxel_values));
        if (c.refused) {
            o << "| " << g4(c.voxel_size) << " | " << values << " | " << c.region << " | refused: " << c.note
              << " ||||||||\n";
            continue;
        }
        const double M = 1024.0 * 1024.0;
        o << "| " << g4(c.voxel_size) << " | " << values << " | " << c.region << " | " << c.active_voxels << " | "
          << g4(double(c.memory_bytes) / M) << " | " << g4(double(c.dense_bytes) / M) << " | "
          << g4(double(c.file_bytes) / M) << " | " << c.tiles << " | " << g4(c.build_seconds) << " | "
          << g4(c.write_seconds) << " | " << g4(double(c.active_voxels) / (c.build_seconds + c.write_seconds))
          << " |\n";
    }
    return o.str();
}

}  // namespace airmass
