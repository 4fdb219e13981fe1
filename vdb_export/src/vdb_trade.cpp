// The voxel-size trade (see vdb_trade.hpp).
#include "airmass/vdb_trade.hpp"

#include <openvdb/tools/Interpolation.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>

#include "airmass/geometry.hpp"
#include "airmass/optical_depth.hpp"
#include "airmass/progress.hpp"
#include "airmass/vdb_grids.hpp"
#include "volume/volume_format.hpp"

namespace airmass {

namespace fs = std::filesystem;
using openvdb::Vec3d;

namespace {

// The rays lie in the plane y = kRayPlaneY, off the lattice planes of every listed
// voxel size; the limb and the raised horizon sit between voxel layers too. The ground
// rays start on the layer z = 0 (the surface at the origin always is one): a horizontal
// ray there samples exact values — the "horizon" row shows that lucky case.
constexpr double kRayPlaneY = 0.1234;
constexpr double kLimbTangentAltitudeKm = 10.37;
constexpr double kHillAltitudeKm = 1.3;
constexpr double kSlantZenithDeg = 75.0;

Vec3d vec(const std::array<double, 3>& a) { return Vec3d(a[0], a[1], a[2]); }

// Parameters t where the line o + t·d (|d| = 1) crosses the sphere |p − c| = r.
bool sphere_roots(const Vec3d& o, const Vec3d& d, const Vec3d& c, double r, double& t0, double& t1) {
    const Vec3d f = o - c;
    const double b = f.dot(d), q = f.dot(f) - r * r, D = b * b - q;
    if (D < 0) return false;
    const double s = std::sqrt(D);
    t0 = -b - s;
    t1 = -b + s;
    return true;
}

// The part of the ray (t ≥ 0) inside the top sphere: [t_begin, t_end].
std::pair<double, double> in_atmosphere(const VdbTradeRay& ray, const VdbLayout& L) {
    double t0, t1;
    if (!sphere_roots(vec(ray.origin_km), vec(ray.direction), to_openvdb(L.planet_center), L.atmosphere_top, t0, t1)) return {0, 0};
    return {std::max(0.0, t0), std::max(0.0, t1)};
}

// ∫ of the trilinear interpolant of `grid` along o + t d, t ∈ [a, b], exactly: the
// interpolant is a cubic in t between crossings of the lattice planes, and 3-point
// Gauss–Legendre integrates degree 5 exactly.
double grid_column(const openvdb::FloatGrid& grid, const Vec3d& o, const Vec3d& d, double a, double b) {
    const double v = grid.voxelSize()[0];
    std::vector<double> cuts{a, b};
    for (int ax = 0; ax < 3; ++ax) {
        if (d[ax] == 0.0) continue;
        const double pa = (o[ax] + a * d[ax]) / v, pb = (o[ax] + b * d[ax]) / v;
        for (double k = std::ceil(std::min(pa, pb)); k <= std::floor(std::max(pa, pb)); k += 1.0) {
            const double t = (k * v - o[ax]) / d[ax];
            if (t > a && t < b) cuts.push_back(t);
        }
    }
    std::sort(cuts.begin(), cuts.end());
    auto acc = grid.getConstAccessor();
    const double x[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)}, w[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
    double sum = 0;
    for (std::size_t i = 1; i < cuts.size(); ++i) {
        const double lo = cuts[i - 1], hi = cuts[i];
        if (!(hi > lo)) continue;
        const double mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
        for (int q = 0; q < 3; ++q) {
            const Vec3d p = grid.worldToIndex(o + d * (mid + half * x[q]));
            sum += w[q] * half * double(openvdb::tools::BoxSampler::sample(acc, p));
        }
    }
    return sum;
}

// Constituents with a grid in a one-tile volume.
std::size_t grid_count(const VdbVolume& vol) {
    return std::size_t(
        std::count_if(vol.tiles[0].grids.begin(), vol.tiles[0].grids.end(), [](const auto& g) { return bool(g); }));
}

// Builds and writes `o` to `scratch` (timed by export_vdb), then removes the files.
VdbStats timed_write(const Scene& scene, const VdbOptions& o, const fs::path& scratch, const CancelFlag* cancel) {
    VdbRunOptions run;
    run.cancel = cancel;
    const VdbStats s = export_vdb(scene, o, scratch, run);
    for (const auto& f : s.files) fs::remove(f);
    return s;
}

}  // namespace

std::vector<VdbTradeRay> vdb_trade_rays(const Scene& scene) {
    const double R = scene.planet.radius_m / 1000.0, top = scene.planet.atmosphere_top_m / 1000.0;
    const double s = std::sin(kSlantZenithDeg * M_PI / 180.0), c = std::cos(kSlantZenithDeg * M_PI / 180.0);
    // The limb ray starts well outside the atmosphere, behind its entry point.
    const double h = kLimbTangentAltitudeKm;
    const double half_chord = std::sqrt(std::max(0.0, top * top - (R + h) * (R + h)));
    const double y = kRayPlaneY;
    return {
        {"zenith", {0, y, 0}, {0, 0, 1}},
        {"slant-75", {0, y, 0}, {s, 0, c}},
        {"horizon", {0, y, 0}, {1, 0, 0}},
        {"horizon-1.3km", {0, y, kHillAltitudeKm}, {1, 0, 0}},
        {"limb-10km", {-(half_chord + 1000.0), y, h}, {1, 0, 0}},
    };
}

VdbTradeResult run_vdb_trade(const Scene& scene, const VdbTradeOptions& options) {
    for (double v : options.voxel_sizes)
        if (!(std::isfinite(v) && v > 0))
            throw VdbError("report vdb: --voxel-sizes: " + detail::fmt(v) + " km: every size must be > 0");
    // The tolerances: 0 (the baseline) first, then the listed ones ascending, each once.
    std::vector<double> tolerances;
    if (!options.tolerances.empty()) {
        if (!(std::isfinite(options.tolerance_voxel_size) && options.tolerance_voxel_size > 0))
            throw VdbError("report vdb: --tolerance-voxel-size: " + detail::fmt(options.tolerance_voxel_size) +
                           " km: must be > 0");
        for (double t : options.tolerances)
            if (!(std::isfinite(t) && t >= 0))
                throw VdbError("report vdb: --tolerances: " + detail::fmt(t) + ": every tolerance must be a finite optical depth >= 0");
        tolerances = vdb_trade_tolerances(options);
    }
    const auto rays = vdb_trade_rays(scene);
    const fs::path scratch_dir = options.scratch_dir.empty() ? fs::temp_directory_path() : options.scratch_dir;
    const fs::path scratch = scratch_dir / ("airmass-vdb-trade-" + std::to_string(::getpid()) + ".vdb");
    VdbTradeResult result;

    // The slab: the rays' in-atmosphere segments' bounding box (all in y = 0).
    VdbOptions slab;
    slab.region = VdbRegion::box;
    slab.tolerance = options.tolerance;
    slab.tile_voxels = -1;
    slab.max_dense_mb = 1e9;  // measure, do not refuse
    slab.max_memory_mb = 1e9;
    {
        slab.voxel_size = 1.0;
        slab.box = {-1, -1, 0, 1, 1, 1};  // placeholder: only the planet's frame is needed here
        const VdbLayout L = resolve_vdb_layout(scene, slab);
        Vec3d lo(1e300), hi(-1e300);
        for (const auto& r : rays) {
            const auto [a, b] = in_atmosphere(r, L);
            for (double t : {a, b}) {
                const Vec3d p = vec(r.origin_km) + vec(r.direction) * t;
                lo = openvdb::math::minComponent(lo, p);
                hi = openvdb::math::maxComponent(hi, p);
            }
        }
        slab.box = {lo[0], kRayPlaneY - 1e-3, lo[2], hi[0], kRayPlaneY + 1e-3, hi[2]};
    }

    // Reference optical depths (independent of the voxel size).
    const VdbLayout ref_layout = [&] {
        slab.voxel_size = 1.0;
        return resolve_vdb_layout(scene, slab);
    }();
    const double L_m = ref_layout.metres_per_unit;
    const double top_alt_m = scene.planet.atmosphere_top_m - scene.planet.radius_m;
    std::vector<std::array<double, 3>> tau_ref(rays.size(), {0, 0, 0});
    for (std::size_t i = 0; i < rays.size(); ++i) {
        const auto [a, b] = in_atmosphere(rays[i], ref_layout);
        const Vec3d o_m = (vec(rays[i].origin_km) - to_openvdb(ref_layout.planet_center)) * L_m;
        const auto pr = PlanetRay<double>::from_vectors(scene.planet.radius_m, Vec3<double>(o_m[0], o_m[1], o_m[2]),
                                                        Vec3<double>(rays[i].direction[0], rays[i].direction[1],
                                                                     rays[i].direction[2]));
        for (const auto& c : ref_layout.constituents) {
            const double mass_unit =
                profile_segment_mass_reference(c.source->profile, pr, top_alt_m, a * L_m, b * L_m) / L_m;
            for (int k = 0; k < 3; ++k) tau_ref[i][k] += (c.scattering_rgb[k] + c.absorption_rgb[k]) * mass_unit;
        }
    }

    // The slab at voxel size v, tolerance tol: for means the box also holds the nodes above the
    // top whose footprints reach the rays' air, (1 + √3) voxels more on the slab's plane (x, z).
    auto slab_at = [&](double v, double tol, VoxelValues values) {
        VdbOptions o = slab;
        o.voxel_size = v;
        o.tolerance = tol;
        o.voxel_values = values;
        if (values != VoxelValues::point) {
            const double m = (1.0 + std::sqrt(3.0)) * v;
            o.box = {slab.box[0] - m, slab.box[1], slab.box[2] - m, slab.box[3] + m, slab.box[4], slab.box[5] + m};
        }
        return o;
    };

    // RGB optical depth along every ray through a built slab of voxel size v.
    auto slab_tau = [&](const VdbVolume& vol, double v) {
        const VdbLayout& L = vol.layout;
        std::vector<std::array<double, 3>> tau(rays.size(), {0, 0, 0});
        for (std::size_t i = 0; i < rays.size(); ++i) {
            auto [a, b] = in_atmosphere(rays[i], L);
            // The interpolant reaches one voxel past the last active voxel, and the means' nodes
            // lie up to √3 voxels above the top: the ray inside the sphere of radius
            // top + (2 + √3) voxels (point values' grids are 0 in the extra part).
            const Vec3d o = vec(rays[i].origin_km), d = vec(rays[i].direction);
            double a_ext = a > 0 ? std::max(0.0, a - 2 * v) : 0.0, b_ext = b + 2 * v, t0, t1;
            if (sphere_roots(o, d, to_openvdb(L.planet_center), L.atmosphere_top + (2.0 + std::sqrt(3.0)) * v, t0, t1)) {
                if (a > 0) a_ext = std::min(a_ext, std::max(0.0, t0));
                b_ext = std::max(b_ext, t1);
            }
            for (std::size_t c = 0; c < L.constituents.size(); ++c) {
                const auto& g = vol.tiles[0].grids[c];
                if (!g) continue;
                const double col = grid_column(*g, o, d, a_ext, b_ext);
                for (int k = 0; k < 3; ++k)
                    tau[i][k] += (L.constituents[c].scattering_rgb[k] + L.constituents[c].absorption_rgb[k]) * col;
            }
        }
        return tau;
    };
    auto rel_error = [](const std::array<double, 3>& got, const std::array<double, 3>& ref) {
        double e = 0;
        for (int k = 0; k < 3; ++k)
            if (ref[k] > 0) e = std::max(e, std::abs(got[k] - ref[k]) / ref[k]);
        return e;
    };
    // Costs: the slab as built and written, then the Earth view region, at voxel v and tolerance tol.
    auto costs_of = [&](double v, double tol, VoxelValues values, std::vector<VdbTradeCostRow>& out) {
        auto cost_of = [&](const std::string& region, const VdbOptions& o, const Scene& s) {
            VdbTradeCostRow c;
            c.voxel_size = v;
            c.voxel_values = values;
            c.tolerance = tol;
            c.region = region;
            try {
                const VdbStats st = timed_write(s, o, scratch, options.cancel);
                c.active_voxels = st.active_voxels;
                c.memory_bytes = st.memory_bytes;
                c.dense_bytes = st.dense_bytes;
                c.file_bytes = st.file_bytes;
                c.tiles = st.tiles;
                c.build_seconds = st.build_seconds;
                c.write_seconds = st.write_seconds;
            } catch (const VdbError& e) {
                c.refused = true;
                c.note = e.what();
            }
            out.push_back(c);
        };
        cost_of("slab", slab_at(v, tol, values), scene);
        if (options.measure_view_region) {
            Scene s = scene;
            s.camera = Camera{};
            VdbOptions view;
            view.region = VdbRegion::view;
            view.voxel_size = v;
            view.tolerance = tol;
            view.voxel_values = values;
            view.max_dense_mb = 1e9;
            view.max_memory_mb = 8192;
            cost_of("view-200km", view, s);
        }
    };
    const std::size_t steps = vdb_trade_steps(options);
    std::size_t done = 0;
    auto step_done = [&] {
        if (options.progress) options.progress(double(++done) / double(steps));
    };
    VdbRunOptions run;
    run.cancel = options.cancel;
    // The slab the voxel-size part builds at the tolerance trade's voxel size and its own
    // tolerance is the one the tolerance part would build again: its optical depths (and grid
    // count) are kept and used there.
    std::optional<std::vector<std::array<double, 3>>> shared_tau;
    std::size_t shared_grids = 0;

    // the tolerance part's values: VdbOptions' default (shared with a voxel-size row of the same values)
    const VoxelValues default_values = VdbOptions{}.voxel_values;
    for (const double v : options.voxel_sizes) {
        for (const VoxelValues values : options.voxel_values) {
            if (options.cancel && options.cancel->requested()) throw Cancelled("report vdb cancelled");
            const VdbVolume vol = build_vdb_volume(scene, slab_at(v, options.tolerance, values), run);
            const auto tau = slab_tau(vol, v);
            if (!tolerances.empty() && v == options.tolerance_voxel_size && values == default_values && !shared_tau) {
                shared_tau = tau;
                shared_grids = grid_count(vol);
            }
            for (std::size_t i = 0; i < rays.size(); ++i) {
                VdbTradeRayRow row;
                row.voxel_size = v;
                row.voxel_values = values;
                row.ray = rays[i].name;
                row.tau_vdb = tau[i];
                row.tau_ref = tau_ref[i];
                row.tau_rel_error_max = rel_error(row.tau_vdb, row.tau_ref);
                for (int k = 0; k < 3; ++k)
                    row.transmittance_abs_error_max = std::max(row.transmittance_abs_error_max,
                                                               std::abs(std::exp(-row.tau_vdb[k]) - std::exp(-row.tau_ref[k])));
                result.rays.push_back(row);
            }
            costs_of(v, options.tolerance, values, result.costs);
            step_done();
        }
    }

    // The threshold's trade: the same slab on one lattice for each tolerance, 0 first.
    if (!tolerances.empty()) {
        const double v = options.tolerance_voxel_size;
        result.tolerance_voxel_size = v;
        std::vector<std::array<double, 3>> keep_all;
        for (const double tol : tolerances) {
            if (options.cancel && options.cancel->requested()) throw Cancelled("report vdb cancelled");
            std::vector<std::array<double, 3>> tau;
            std::size_t grids = 0;
            if (shared_tau && tol == options.tolerance) {
                tau = *shared_tau;
                grids = shared_grids;
            } else {
                const VdbVolume vol = build_vdb_volume(scene, slab_at(v, tol, default_values), run);
                tau = slab_tau(vol, v);
                grids = grid_count(vol);
            }
            if (tol == 0.0) {
                keep_all = tau;
                result.constituents = grids;
            }
            for (std::size_t i = 0; i < rays.size(); ++i) {
                VdbToleranceRayRow row;
                row.tolerance = tol;
                row.ray = rays[i].name;
                row.tau_vdb = tau[i];
                row.tau_removed_max = -std::numeric_limits<double>::infinity();
                for (int k = 0; k < 3; ++k) row.tau_removed_max = std::max(row.tau_removed_max, keep_all[i][k] - tau[i][k]);
                row.tau_rel_error_max = rel_error(tau[i], tau_ref[i]);
                result.tolerance_rays.push_back(row);
            }
            costs_of(v, tol, default_values, result.tolerance_costs);
            step_done();
        }
    }
    return result;
}

}  // namespace airmass
