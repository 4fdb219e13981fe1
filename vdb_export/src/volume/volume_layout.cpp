// Resolving a volume request: units, constituents and their activity thresholds,
// voxel size, the region's geometry and index bounds. Every rejected input names the
// option or scene field, its value and what is allowed.
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "airmass/scene_io.hpp"
#include "airmass/volume.hpp"
#include "volume_format.hpp"

namespace airmass {

using Vec3d = Vec3<double>;

bool VoxelBox::contains(const VoxelCoord& c) const {
    for (int a = 0; a < 3; ++a)
        if (c[a] < min[a] || c[a] > max[a]) return false;
    return true;
}

bool VoxelBox::contains(const VoxelBox& b) const {
    if (b.empty()) return true;
    for (int a = 0; a < 3; ++a)
        if (b.min[a] < min[a] || b.max[a] > max[a]) return false;
    return true;
}

bool VoxelBox::intersects(const VoxelBox& b) const {
    if (empty() || b.empty()) return false;
    for (int a = 0; a < 3; ++a)
        if (b.max[a] < min[a] || b.min[a] > max[a]) return false;
    return true;
}

void VoxelBox::expand(const VoxelCoord& c) {
    if (empty()) {
        min = max = c;
        return;
    }
    for (int a = 0; a < 3; ++a) {
        min[a] = std::min(min[a], c[a]);
        max[a] = std::max(max[a], c[a]);
    }
}

void VoxelBox::expand(const VoxelBox& b) {
    if (b.empty()) return;
    expand(b.min);
    expand(b.max);
}

std::string_view length_unit_name(LengthUnit u) { return u == LengthUnit::km ? "km" : "m"; }
double metres_per_unit(LengthUnit u) { return u == LengthUnit::km ? 1000.0 : 1.0; }
std::string_view region_name(VdbRegion r) {
    switch (r) {
        case VdbRegion::planet: return "planet";
        case VdbRegion::view: return "view";
        case VdbRegion::box: return "box";
    }
    return "?";
}
std::string_view voxel_values_name(VoxelValues v) {
    switch (v) {
        case VoxelValues::automatic: return "auto";
        case VoxelValues::average: return "average";
        case VoxelValues::point: return "point";
    }
    return "?";
}
std::optional<VoxelValues> voxel_values_from_name(std::string_view name) {
    for (VoxelValues v : {VoxelValues::automatic, VoxelValues::average, VoxelValues::point})
        if (name == voxel_values_name(v)) return v;
    return std::nullopt;
}

namespace {

using detail::fmt;

// The voxels per thinnest layer of the automatic voxel size (docs/vdb.md, the trade
// table: two voxels per Mie scale height keep Earth's transmittance errors ≲ 1e-2).
constexpr double kVoxelsPerLayer = 2.0;
// Budget factors of the automatic voxel size: dense boxes vs the volume the region
// occupies, and bytes per active voxel in an OpenVDB float tree. A whole shell, even
// tiled (≤ 256 axis-aligned tiles), has boxes ~30× its volume: measured for Earth at
// 10, 20 and 50 km (docs/vdb.md); views and boxes stay within ~2×.
constexpr double kDenseWastePlanet = 40.0;
constexpr double kDenseWasteLocal = 4.0;
constexpr double kBytesPerActiveVoxel = 4.5;

// Longest chord through the shell that misses the ground: the grazing ray, from top
// to top, 2·sqrt(top² − R²). Inactive cells along any ray lie on at most this length.
double longest_chord(double radius, double top) { return 2.0 * std::sqrt(std::max(0.0, top * top - radius * radius)); }

// Altitudes (metres) where a profile has a kink or an end; its maximum over an
// interval is at one of these or at the interval's ends (every profile kind is
// monotone between them).
std::vector<double> profile_breakpoints(const DensityProfile& p) {
    switch (p.kind) {
        case DensityProfile::Kind::exponential: return {};
        case DensityProfile::Kind::tent: return {p.bottom_m, p.peak_m, p.top_m};
        case DensityProfile::Kind::piecewise_linear: {
            std::vector<double> h;
            for (const auto& k : p.knots) h.push_back(k.first);
            return h;
        }
        case DensityProfile::Kind::constant: return {p.bottom_m, p.top_m};
    }
    return {};
}

// Where a constituent's layer ends (metres): 5 scale heights above an exponential's reference
// (e⁻⁵ of it), a tent's or a constant's top, the last knot; at most the atmosphere's top.
double layer_top_m(const DensityProfile& p, double thickness_m) {
    switch (p.kind) {
        case DensityProfile::Kind::exponential: return std::min(thickness_m, p.reference_altitude_m + 5 * p.scale_height_m);
        case DensityProfile::Kind::tent: return std::min(thickness_m, p.top_m);
        case DensityProfile::Kind::piecewise_linear: return p.knots.empty() ? 0.0 : std::min(thickness_m, p.knots.back().first);
        case DensityProfile::Kind::constant: return p.top_m > p.bottom_m ? std::min(thickness_m, p.top_m) : thickness_m;
    }
    return thickness_m;
}

double profile_max(const DensityProfile& p, double h_lo, double h_hi) {
    double m = std::max(p.at(h_lo), p.at(h_hi));
    for (double h : profile_breakpoints(p))
        if (h >= h_lo && h <= h_hi) m = std::max(m, p.at(h));
    return m;
}

}  // namespace

// volume.hpp
double profile_feature_m(const DensityProfile& p, double thickness_m) {
    switch (p.kind) {
        case DensityProfile::Kind::exponential: return p.scale_height_m;
        case DensityProfile::Kind::tent: {
            double f = thickness_m;
            if (p.peak_m > p.bottom_m) f = std::min(f, p.peak_m - p.bottom_m);
            if (p.top_m > p.peak_m) f = std::min(f, p.top_m - p.peak_m);
            return f;
        }
        case DensityProfile::Kind::piecewise_linear: {
            double f = thickness_m;
            for (std::size_t i = 1; i < p.knots.size(); ++i) {
                const double d = p.knots[i].first - p.knots[i - 1].first;
                if (d > 0) f = std::min(f, d);
            }
            return f;
        }
        case DensityProfile::Kind::constant: {
            const double top = p.top_m > p.bottom_m ? p.top_m : thickness_m;
            return std::max(1.0, std::min(thickness_m, top - p.bottom_m));
        }
    }
    return thickness_m;
}

namespace {

// Altitude band (metres) outside which rho < threshold, clipped to
// [−ground_margin, thickness]; empty (min > max) when the constituent has no active cell.
std::pair<double, double> active_band(const DensityProfile& p, double threshold, double ground_margin_m,
                                      double thickness_m) {
    double lo = -ground_margin_m, hi = thickness_m;
    switch (p.kind) {
        case DensityProfile::Kind::exponential:
            // exp(−(h − h0)/H) ≥ t  ⇔  h ≤ h0 + H·ln(1/t)
            if (threshold > 0) hi = std::min(hi, p.reference_altitude_m + p.scale_height_m * std::log(1.0 / threshold));
            break;
        case DensityProfile::Kind::tent:
            lo = std::max(lo, p.bottom_m);
            hi = std::min(hi, p.top_m);
            break;
        case DensityProfile::Kind::piecewise_linear:
            if (p.knots.empty()) return {1, 0};
            lo = std::max(lo, p.knots.front().first);
            hi = std::min(hi, p.knots.back().first);
            break;
        case DensityProfile::Kind::constant:
            if (!(p.value > 0) || p.value < threshold) return {1, 0};
            lo = std::max(lo, p.bottom_m);
            if (p.top_m > p.bottom_m) hi = std::min(hi, p.top_m);
            break;
    }
    return {lo, hi};
}

std::array<double, 3> rgb_wavelengths(RgbWavelengths w, const Scene& scene, std::string& basis_name) {
    if (w == RgbWavelengths::automatic)
        w = scene.basis.kind == SpectralBasis::Kind::rgb_schuler ? RgbWavelengths::schuler : RgbWavelengths::bruneton;
    if (w == RgbWavelengths::schuler) {
        basis_name = "rgb_schuler_615_535_445";
        return {615.0, 535.0, 445.0};
    }
    basis_name = "rgb_bruneton_680_550_440";
    return {680.0, 550.0, 440.0};
}

void check_options(const VdbOptions& o) {
    if (o.voxel_size && !(std::isfinite(*o.voxel_size) && *o.voxel_size > 0))
        throw VdbError("--voxel-size = " + fmt(*o.voxel_size) + " " + std::string(length_unit_name(o.unit)) +
                       ": must be a finite length > 0");
    if (!(std::isfinite(o.tolerance) && o.tolerance >= 0))
        throw VdbError("--tolerance = " + fmt(o.tolerance) + ": must be a finite optical depth >= 0");
    if (!(std::isfinite(o.max_dense_mb) && o.max_dense_mb > 0))
        throw VdbError("--max-dense-mb = " + fmt(o.max_dense_mb) + ": must be > 0");
    if (!(std::isfinite(o.max_memory_mb) && o.max_memory_mb > 0))
        throw VdbError("--max-memory-mb = " + fmt(o.max_memory_mb) + ": must be > 0");
    if (o.tile_voxels < -1 || (o.tile_voxels > 0 && o.tile_voxels % 8 != 0))
        throw VdbError("--tile-voxels = " + std::to_string(o.tile_voxels) +
                       ": must be 0 (automatic), -1 (one tile) or a positive multiple of 8");
    if (o.max_tiles < 1) throw VdbError("--max-tiles = " + std::to_string(o.max_tiles) + ": must be >= 1");
    if (o.region == VdbRegion::box) {
        const char* axes = "xyz";
        for (int a = 0; a < 3; ++a) {
            if (!(std::isfinite(o.box[a]) && std::isfinite(o.box[a + 3])))
                throw VdbError(std::string("--box: ") + axes[a] + " bounds must be finite");
            if (!(o.box[a] < o.box[a + 3]))
                throw VdbError(std::string("--box: ") + axes[a] + "min = " + fmt(o.box[a]) + " must be < " + axes[a] +
                               "max = " + fmt(o.box[a + 3]));
        }
    }
}

Vec3d to_vec(const double (&a)[3]) { return Vec3d(a[0], a[1], a[2]); }
double length(const Vec3d& v) { return glm::length(v); }

VdbViewCone resolve_camera(const Scene& scene, const Vec3d& center, double radius_u, double L) {
    if (!scene.camera)
        throw VdbError("--region view: the scene has no [camera] (position, direction, fov, max distance); "
                       "add one to the scene file or use --region planet or --region box");
    const Camera& cam = *scene.camera;
    // The scene frame has its origin on the surface; the world frame puts the planet
    // centre at `center`, i.e. world = scene/L + (center + (0, 0, R)).
    const Vec3d shift = center + Vec3d(0, 0, radius_u);
    VdbViewCone v;
    v.position = to_vec(cam.position_m) / L + shift;
    for (double x : cam.position_m)
        if (!std::isfinite(x)) throw VdbError("camera.position_m: must be finite");
    const double altitude_m = length(v.position - center) * L - radius_u * L;
    if (altitude_m < 0)
        throw VdbError("camera inside the planet: camera.position_m = (" + fmt(cam.position_m[0]) + ", " +
                       fmt(cam.position_m[1]) + ", " + fmt(cam.position_m[2]) + ") is " + fmt(-altitude_m) +
                       " m below the surface; the view region needs a camera at altitude >= 0");
    Vec3d f = to_vec(cam.direction), up = to_vec(cam.up);
    if (!(length(f) > 0) || !std::isfinite(length(f)))
        throw VdbError("camera.direction: must be a finite nonzero vector");
    f = f / length(f);
    Vec3d r = glm::cross(f, up);
    if (!(length(r) > 1e-9 * std::max(1.0, length(up))) || !std::isfinite(length(r)))
        throw VdbError("camera.up: must be finite and not parallel to camera.direction");
    r = r / length(r);
    v.forward = f;
    v.right = r;
    v.up = glm::cross(r, f);
    if (!(cam.fov_deg > 0 && cam.fov_deg < 180))
        throw VdbError("camera.fov_deg = " + fmt(cam.fov_deg) + ": must be in (0, 180)");
    if (cam.width < 1 || cam.height < 1)
        throw VdbError("camera.width x height = " + std::to_string(cam.width) + " x " + std::to_string(cam.height) +
                       ": must be >= 1 pixel each");
    if (!(cam.max_distance_m > 0) || !std::isfinite(cam.max_distance_m))
        throw VdbError("camera.max_distance_m = " + fmt(cam.max_distance_m) + ": must be a finite distance > 0");
    // Blender's sensor fit AUTO: the field of view spans the larger image dimension.
    const double t = std::tan(cam.fov_deg * std::numbers::pi / 360.0);
    const double aspect = double(std::min(cam.width, cam.height)) / double(std::max(cam.width, cam.height));
    v.tan_half_h = cam.width >= cam.height ? t : t * aspect;
    v.tan_half_v = cam.width >= cam.height ? t * aspect : t;
    v.max_distance = cam.max_distance_m / L;
    v.footprint_per_distance = 2.0 * t / double(std::max(cam.width, cam.height));
    return v;
}

struct Resolved {
    double L;
    Vec3d center;
    double radius, top;  // unit
    std::array<double, 3> wavelengths;
    std::string basis;
    std::vector<VdbConstituent> constituents;
    std::optional<VdbViewCone> view;
};

// Everything that does not depend on the voxel size (the bands' ground margin does:
// it is applied afterwards).
Resolved resolve_common(const Scene& scene, const VdbOptions& options) {
    check_options(options);
    validate(scene);
    Resolved r;
    r.L = metres_per_unit(options.unit);
    r.radius = scene.planet.radius_m / r.L;
    r.top = scene.planet.atmosphere_top_m / r.L;
    r.center = options.origin == PlanetOrigin::surface ? Vec3d(0, 0, -r.radius) : Vec3d(0, 0, 0);
    r.wavelengths = rgb_wavelengths(options.rgb, scene, r.basis);
    const double chord = longest_chord(r.radius, r.top);
    for (const Constituent& c : scene.constituents) {
        if (c.scattering.is_zero() && c.absorption.is_zero()) continue;  // contributes nothing: no grid
        VdbConstituent v;
        v.source = &c;
        v.name = c.name;
        double ext_max = 0;
        for (int i = 0; i < 3; ++i) {
            v.scattering_rgb[i] = c.scattering.at(r.wavelengths[i]) * r.L;
            v.absorption_rgb[i] = c.absorption.at(r.wavelengths[i]) * r.L;
            ext_max = std::max(ext_max, v.scattering_rgb[i] + v.absorption_rgb[i]);
        }
        // Inactive cells hold rho < threshold; along any ray they span at most the
        // longest chord, so they remove at most threshold · ext_max · chord = tolerance.
        v.density_threshold = ext_max > 0 && chord > 0 ? options.tolerance / (ext_max * chord) : 0.0;
        v.density_max = profile_max(c.profile, 0.0, scene.planet.atmosphere_top_m - scene.planet.radius_m);
        r.constituents.push_back(std::move(v));
    }
    if (r.constituents.empty())
        throw VdbError("the scene has no constituent with a nonzero scattering or absorption coefficient: nothing to export");
    if (options.region == VdbRegion::view) r.view = resolve_camera(scene, r.center, r.radius, r.L);
    return r;
}

// Volume (unit³) the grids of one constituent can occupy: its altitude band's shell,
// cut to what the view or the box can hold.
double occupied_volume(const Scene& scene, const VdbOptions& options, const Resolved& r, const VdbConstituent& c) {
    const double thickness_m = scene.planet.atmosphere_top_m - scene.planet.radius_m;
    const auto [lo_m, hi_m] = active_band(c.source->profile, c.density_threshold, 0.0, thickness_m);
    if (lo_m > hi_m) return 0.0;
    const double r0 = r.radius + lo_m / r.L, r1 = r.radius + hi_m / r.L;
    double v = 4.0 / 3.0 * std::numbers::pi * (r1 * r1 * r1 - r0 * r0 * r0);
    if (r.view) {
        // Solid angle of the rectangular frustum times D³/3.
        const double th = r.view->tan_half_h, tv = r.view->tan_half_v, D = r.view->max_distance;
        const double omega = 4.0 * std::asin(th * tv / std::sqrt((1 + th * th) * (1 + tv * tv)));
        v = std::min(v, omega * D * D * D / 3.0);
    }
    if (options.region == VdbRegion::box) {
        const auto& b = options.box;
        v = std::min(v, (b[3] - b[0]) * (b[4] - b[1]) * (b[5] - b[2]));
    }
    return v;
}

double auto_voxel_size_resolved(const Scene& scene, const VdbOptions& options, const Resolved& r) {
    const double thickness_m = scene.planet.atmosphere_top_m - scene.planet.radius_m;
    double feature_m = thickness_m;
    for (const auto& c : r.constituents) feature_m = std::min(feature_m, profile_feature_m(c.source->profile, thickness_m));
    double v = feature_m / kVoxelsPerLayer / r.L;
    if (r.view) {
        // Finer than a pixel at the nearest atmosphere the camera can see is wasted.
        const double nearest = std::max(0.0, length(r.view->position - r.center) - r.top);
        v = std::max(v, nearest * r.view->footprint_per_distance);
    }
    // Coarse enough that the limits can hold the grids.
    double volume = 0;
    for (const auto& c : r.constituents) volume += occupied_volume(scene, options, r, c);
    const double waste = options.region == VdbRegion::planet ? kDenseWastePlanet : kDenseWasteLocal;
    const double dense_budget = options.max_dense_mb * 1024.0 * 1024.0 / (waste * sizeof(float));
    const double memory_budget = options.max_memory_mb * 1024.0 * 1024.0 / kBytesPerActiveVoxel;
    v = std::max(v, std::cbrt(volume / std::min(dense_budget, memory_budget)));
    if (options.region == VdbRegion::planet) {
        // A whole shell: a little coarser, so that the planet's centre lies on the lattice on
        // every axis (2c/v an even number; with the origin on the surface, c_z = −R, the others
        // 0). Then the lattice is symmetric under the centre's 48 reflections and axis swaps, and
        // the voxels' means are computed once per 48 voxels, not per 8 (voxel_average.hpp,
        // SymmetricAverages; an odd 2c/v would put the centre halfway between nodes along z,
        // which no swap with x or y maps onto the lattice: 16). v grows by the factor k/(k − 2)
        // at most, k = 2c/v (Earth: 19.92 → 19.94 km) — and not at all where that would change
        // what a constituent's voxels hold (auto: a voxel coarser than half its thinnest layer).
        const double thickness_m = scene.planet.atmosphere_top_m - scene.planet.radius_m;
        for (int a = 0; a < 3; ++a) {
            const double twice = 2.0 * std::abs(r.center[a]);
            if (!(twice > 0.0 && twice / v < double(1 << 20))) continue;
            const double k = 2.0 * std::floor(twice / (2.0 * v));
            if (k < 2.0) continue;
            const double rounded = twice / k;
            bool same = true;
            for (const auto& c : r.constituents) {
                const double half_layer = 0.5 * profile_feature_m(c.source->profile, thickness_m) / r.L;
                same = same && (v > half_layer * (1.0 + 1e-9)) == (rounded > half_layer * (1.0 + 1e-9));
            }
            if (same) v = rounded;
        }
    }
    return v;
}

VoxelCoord floor_coord(const Vec3d& p, double v) {
    return {int(std::floor(p[0] / v)), int(std::floor(p[1] / v)), int(std::floor(p[2] / v))};
}
VoxelCoord ceil_coord(const Vec3d& p, double v) {
    return {int(std::ceil(p[0] / v)), int(std::ceil(p[1] / v)), int(std::ceil(p[2] / v))};
}

}  // namespace

double auto_voxel_size(const Scene& scene, const VdbOptions& options) {
    return auto_voxel_size_resolved(scene, options, resolve_common(scene, options));
}

VdbLayout resolve_vdb_layout(const Scene& scene, const VdbOptions& options) {
    Resolved r = resolve_common(scene, options);
    VdbLayout layout;
    layout.options = options;
    layout.metres_per_unit = r.L;
    layout.voxel_size_automatic = !options.voxel_size.has_value();
    layout.voxel_size = options.voxel_size ? *options.voxel_size : auto_voxel_size_resolved(scene, options, r);
    layout.planet_center = r.center;
    layout.planet_radius = r.radius;
    layout.atmosphere_top = r.top;
    layout.rgb_wavelengths_nm = r.wavelengths;
    layout.spectral_basis = r.basis;
    layout.view = r.view;
    layout.scene_name = scene.name;
    layout.scene_json = scene_to_json(scene);
    const std::string unit(length_unit_name(options.unit));
    const double v = layout.voxel_size;

    // Altitude bands; the ground margin lets trilinear interpolation reach the surface.
    const double ground_margin_m = std::sqrt(3.0) * v * r.L;
    const double thickness_m = scene.planet.atmosphere_top_m - scene.planet.radius_m;
    for (auto& c : r.constituents) {
        // What its voxels hold: automatic — the mean where a voxel spans more than half the
        // constituent's thinnest layer (there point values' chords and the continuation below the
        // ground put percents too much into every ray across the layer: docs/vdb.md, Voxel
        // values) and the rays cross it: a view's camera above the layer, or the whole planet and
        // boxes (seen from outside); points otherwise — a camera inside the layer looks along it,
        // where the means lose the density at the ground (horizon rays: 2 % against 3e-6 at
        // 1-km voxels). The automatic voxel size itself (half a layer, to rounding) keeps points.
        const double half_layer_m = 0.5 * profile_feature_m(c.source->profile, thickness_m);
        const bool coarse = v * r.L > half_layer_m * (1.0 + 1e-9);
        const bool crossed = !r.view || (glm::length(r.view->position - r.center) - r.radius) * r.L >
                                            layer_top_m(c.source->profile, thickness_m);
        c.values = options.voxel_values != VoxelValues::automatic ? options.voxel_values
                   : coarse && crossed                         ? VoxelValues::average
                                                               : VoxelValues::point;
        const bool average = c.values == VoxelValues::average;
        if (average && c.density_threshold > 0.0) {
            // The means' nodes reach √3 voxels past the top and their interpolant one voxel more:
            // a ray that misses the ground crosses inactive cells over the longest chord of that
            // sphere, not of the top's — the threshold that keeps the tolerance is smaller by the
            // ratio of the two chords (Earth at 19.94-km voxels: 1750 → 2426 km).
            const double reach = r.top + (1.0 + std::sqrt(3.0)) * v;
            c.density_threshold *= longest_chord(r.radius, r.top) / longest_chord(r.radius, reach);
        }
        auto [lo, hi] = active_band(c.source->profile, c.density_threshold, ground_margin_m, thickness_m);
        if (average && lo <= hi) {
            // A voxel's mean reaches as far as its hat (≤ √3 voxels along the vertical): a cell
            // that far outside the band can hold a mean above the threshold — above the top too,
            // where a node's hat still covers air below it: without those nodes the reconstruction
            // falls to 0 a voxel early and loses up to half a voxel of the density at the top.
            lo = std::max(lo - ground_margin_m, -ground_margin_m);
            hi = hi + ground_margin_m;
        }
        c.band_min_m = lo;
        c.band_max_m = hi;
        if (!(lo <= hi)) continue;
        // The grids hold floats. With point values the profile is extrapolated below the
        // ground over the margin (trilinear interpolation at the surface reads it); a voxel many
        // scale heights across extrapolates it past the float range, which would store +inf:
        // refuse, naming why. A mean is at most the profile's largest value in the air.
        const double peak =
            profile_max(c.source->profile, average ? std::max(lo, 0.0) : lo, average ? std::min(hi, thickness_m) : hi);
        if (!(peak <= double(std::numeric_limits<float>::max())))
            throw VdbError("--voxel-size = " + fmt(v) + " " + unit + (layout.voxel_size_automatic ? " (automatic)" : "") +
                           " is too coarse for constituent '" + c.name + "': its density extrapolated one voxel diagonal (" +
                           fmt(ground_margin_m / r.L) + " " + unit + ") below the ground reaches " + fmt(peak) +
                           ", beyond a float grid's range (3.4e38); use a smaller --voxel-size" +
                           (layout.voxel_size_automatic ? " or larger --max-dense-mb / --max-memory-mb" : ""));
        layout.constituents.push_back(c);
    }
    if (layout.constituents.empty())
        throw VdbError("every constituent is below the activity threshold everywhere (--tolerance = " +
                       fmt(options.tolerance) + "): nothing to export; lower --tolerance");

    // Index bounds: the shell's box (out to the means' nodes above the top), cut by the box or
    // the camera's reach.
    double outer = r.top;
    for (const auto& c : layout.constituents) outer = std::max(outer, r.radius + c.band_max_m / r.L);
    Vec3d lo = r.center - Vec3d(outer), hi = r.center + Vec3d(outer);
    if (options.region == VdbRegion::box) {
        const auto& b = options.box;
        const Vec3d blo = Vec3d(b[0], b[1], b[2]) - Vec3d(v), bhi = Vec3d(b[3], b[4], b[5]) + Vec3d(v);
        // Does the box meet the shell at all? (nearest point inside the top, farthest outside the ground)
        double dmin = 0, dmax = 0;
        for (int a = 0; a < 3; ++a) {
            const double c = r.center[a];
            const double dn = c < b[a] ? b[a] - c : (c > b[a + 3] ? c - b[a + 3] : 0.0);
            const double df = std::max(std::abs(c - b[a]), std::abs(c - b[a + 3]));
            dmin += dn * dn;
            dmax += df * df;
        }
        if (std::sqrt(dmin) > r.top || std::sqrt(dmax) < r.radius)
            throw VdbError("region outside the atmosphere: --box (" + fmt(b[0]) + ", " + fmt(b[1]) + ", " + fmt(b[2]) +
                           ") to (" + fmt(b[3]) + ", " + fmt(b[4]) + ", " + fmt(b[5]) + ") " + unit +
                           " does not meet the shell between radius " + fmt(r.radius) + " and " + fmt(r.top) + " " +
                           unit + " around the planet centre (" + fmt(r.center[0]) + ", " + fmt(r.center[1]) + ", " +
                           fmt(r.center[2]) + ")");
        lo = glm::max(lo, blo);
        hi = glm::min(hi, bhi);
    }
    if (layout.view) {
        const double reach = layout.view->max_distance + std::sqrt(3.0) * v;
        const double d_center = length(layout.view->position - r.center);
        if (d_center - r.top > reach)
            throw VdbError("region outside the atmosphere: the camera is " + fmt(d_center - r.top) + " " + unit +
                           " from the top of the atmosphere but sees only " + fmt(layout.view->max_distance) + " " +
                           unit + " (camera.max_distance_m); raise it or move the camera");
        lo = glm::max(lo, layout.view->position - Vec3d(reach));
        hi = glm::min(hi, layout.view->position + Vec3d(reach));
    }
    // Index coordinates are int32 and the build enumerates 8³ blocks: keep the extent sane.
    const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    if (extent / v > 1.0e8)
        throw VdbError("--voxel-size = " + fmt(v) + " " + unit + " is too small for a region " + fmt(extent) + " " +
                       unit + " across (more than 1e8 voxels per axis); use a larger voxel size or a smaller region");
    layout.index_bounds = VoxelBox{floor_coord(lo, v), ceil_coord(hi, v)};
    return layout;
}

double vdb_density_at(const VdbLayout& layout, const VdbConstituent& c, const Vec3d& p) {
    const double r = glm::length(p - layout.planet_center);
    if (r > layout.atmosphere_top) return 0.0;  // the model ends at the top
    return c.source->profile.at((r - layout.planet_radius) * layout.metres_per_unit);
}

}  // namespace airmass
