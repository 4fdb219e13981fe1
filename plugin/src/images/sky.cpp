// Sky textures: equirectangular mapping, the parallel per-row render (single scattering
// plus the multiple-scattering tables' radiance), the box-filtered sun disc and the EXR
// metadata (see sky.hpp for the conventions).
#include "airmass/sky.hpp"

#include "airmass/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <new>
#include <numbers>
#include <optional>
#include <vector>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "airmass/atmosphere.hpp"
#include "airmass/color.hpp"
#include "airmass/evaluator.hpp"
#include "airmass/geometry.hpp"
#include "airmass/multiple_scattering.hpp"
#include "airmass/optical_depth.hpp"
#include "airmass/phase.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/single_scattering.hpp"
#include "airmass/sky_grid.hpp"
#include "airmass/table_store.hpp"
#include "airmass/version.hpp"


namespace airmass {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kTwoPi = 2.0 * std::numbers::pi;

// cos and sin of an angle in degrees, exact at multiples of 90° (cos 90° = 0, not 6e-17),
// so a sun at elevation 90° is exactly (0, 0, 1) and at 0° exactly on the horizon.
void cos_sin_deg(double deg, double& c, double& s) {
    double r = std::fmod(deg, 360.0);
    if (r < 0) r += 360.0;
    const int quadrant = static_cast<int>(std::lround(r / 90.0)) % 4;
    const double d = (r - 90.0 * std::lround(r / 90.0)) * (kPi / 180.0);  // in [−45°, 45°], exact subtraction
    const double cd = std::cos(d), sd = std::sin(d);
    switch (quadrant) {
        case 0: c = cd, s = sd; break;
        case 1: c = -sd, s = cd; break;
        case 2: c = -cd, s = -sd; break;
        default: c = sd, s = -cd; break;
    }
}

}  // namespace

// ---- mapping -------------------------------------------------------------------------

glm::dvec2 equirect_uv_from_direction(const glm::dvec3& d) {
    // Cycles (kernel/geom/... direction_to_equirectangular_range with the default range
    // (−2π, π, −π, π/2)): u = (atan2(y, x) − π)/(−2π), v = (acos(z/|d|) − π)/(−π).
    const double len = glm::length(d);
    const double z = std::clamp(d.z / len, -1.0, 1.0);
    return {(std::atan2(d.y, d.x) - kPi) / (-kTwoPi), (std::acos(z) - kPi) / (-kPi)};
}

glm::dvec3 equirect_direction_from_uv(const glm::dvec2& uv) {
    const double phi = kPi - kTwoPi * uv.x;  // atan2(y, x)
    const double theta = kPi - kPi * uv.y;   // acos(z): 0 at the top (v = 1)
    const double st = std::sin(theta);
    return {st * std::cos(phi), st * std::sin(phi), std::cos(theta)};
}

glm::dvec3 equirect_pixel_direction(int x, int y, int width, int height) {
    // Row y = 0 is the top of the image, i.e. v = 1 − (y + ½)/H.
    return equirect_direction_from_uv({(x + 0.5) / width, 1.0 - (y + 0.5) / height});
}

glm::dvec2 equirect_pixel_from_direction(const glm::dvec3& d, int width, int height) {
    const glm::dvec2 uv = equirect_uv_from_direction(d);
    return {uv.x * width, (1.0 - uv.y) * height};
}

double equirect_pixel_solid_angle(int y, int width, int height) {
    const double theta0 = kPi * y / height, theta1 = kPi * (y + 1) / height;
    // cos θ0 − cos θ1 = 2 sin((θ0+θ1)/2) sin((θ1−θ0)/2), without cancellation near the poles.
    return (kTwoPi / width) * 2.0 * std::sin(0.5 * (theta0 + theta1)) * std::sin(0.5 * (theta1 - theta0));
}

glm::dvec3 sun_direction(double elevation_deg, double rotation_deg) {
    // Blender's kernel: geographical_to_direction(e, 2π − r + π/2) = (cos e sin r, cos e cos r, sin e).
    double ce, se, cr, sr;
    cos_sin_deg(elevation_deg, ce, se);
    cos_sin_deg(rotation_deg, cr, sr);
    return {ce * sr, ce * cr, se};
}

// ---- settings ------------------------------------------------------------------------

void validate(const SkySettings& s) {
    auto range = [](const char* field, long long v, long long lo, long long hi) {
        if (v < lo || v > hi)
            throw SkyError(std::string(field) + " = " + std::to_string(v) + ": must be in [" + std::to_string(lo) +
                           ", " + std::to_string(hi) + "]");
    };
    range("width", s.width, 4, kSkyMaxDimension);
    range("height", s.height, 2, kSkyMaxDimension);
    range("samples", s.view.view_samples, 1, kSkyMaxViewSamples);
    range("threads", s.threads, 0, 4096);
    range("grid", s.grid, -1, kSkyMaxGrid);
    if (s.grid > 0 && s.grid < 4) throw SkyError("grid = " + std::to_string(s.grid) + ": must be -1 (auto), 0 (off) or in [4, " + std::to_string(kSkyMaxGrid) + "]");
    range("multiple_samples", s.multiple.view_samples, 1, kSkyMaxMultipleSamples);
    range("multiple_grid", s.multiple_grid, 0, kSkyMaxGrid);
    if (s.multiple_grid == 1) throw SkyError("multiple_grid = 1: must be 0 (every ray) or in [2, " + std::to_string(kSkyMaxGrid) + "]");
    if (s.multiple.enabled) {
        try {
            validate(s.multiple.tables);
        } catch (const std::invalid_argument& e) {
            // "multiple scattering: max_order = 1: …" → "multiple.max_order = 1: …" (the field's name here).
            std::string what = e.what();
            const std::string prefix = "multiple scattering: ";
            if (what.rfind(prefix, 0) == 0) what.erase(0, prefix.size());
            throw SkyError("multiple." + what);
        }
    }
    if (double(s.width) * s.height > 1.0e9)
        throw SkyError("width x height = " + std::to_string(s.width) + " x " + std::to_string(s.height) +
                       ": must be at most 1e9 pixels");
}

namespace {

// What a sky needs before its evaluator: the compiled atmosphere at the image's
// wavelengths, the map to RGB, the sun and the observer.
struct SkyInputs {
    Atmosphere atmosphere;
    SpectrumToRgb to_rgb;  // restricted to the wavelengths the atmosphere evaluates
    glm::dvec3 sun;
    double altitude_m;
};

// Everything a render needs, prepared once: the evaluator (with the tables when multiple
// scattering is on) and the rest of SkyInputs.
struct SkyContext {
    Evaluator evaluator;
    SpectrumToRgb to_rgb;
    glm::dvec3 sun;
    double altitude_m;
    const Atmosphere& atmosphere() const { return evaluator.atmosphere(); }
};

// What one image needs: an evaluator (a session's, or a SkyContext's), the map to RGB, the
// sun and the observer.
struct FrameContext {
    const Evaluator& evaluator;
    const SpectrumToRgb& to_rgb;
    glm::dvec3 sun;
    double altitude_m;
    const Atmosphere& atmosphere() const { return evaluator.atmosphere(); }
};

SkyInputs prepare(const Scene& scene, const SkySettings& settings) {
    validate(scene);
    validate(settings);
    SkyInputs in;
    SpectrumToRgb full = spectrum_to_rgb(scene.basis);
    if (full.size() == 0) throw SkyError("spectrum: the basis has no wavelengths");
    // A scene pays only for what it uses: wavelengths whose colour weights are all zero
    // (outside the CMF table) cannot change the image, so they are not evaluated.
    for (std::size_t i = 0; i < full.size(); ++i) {
        if (full.matrix[0][i] == 0.0 && full.matrix[1][i] == 0.0 && full.matrix[2][i] == 0.0) continue;
        in.to_rgb.wavelengths_nm.push_back(full.wavelengths_nm[i]);
        for (int c = 0; c < 3; ++c) in.to_rgb.matrix[c].push_back(full.matrix[c][i]);
    }
    if (in.to_rgb.size() == 0) throw SkyError("spectrum: no wavelength of the basis lies inside 360-830 nm");
    EvalSettings eval = settings.view;
    eval.sun_disc = false;  // added below, box-filtered into pixels
    in.atmosphere = compile_atmosphere(scene, in.to_rgb.wavelengths_nm, eval);
    in.sun = sun_direction(scene.sun.elevation_deg, scene.sun.azimuth_deg);
    in.altitude_m = scene.observer.altitude_m;
    return in;
}

// The context of a sky: the evaluator over the caller's tables (checked: SkyError names
// them) or over tables computed now, reported as `units` of `total` through the hooks.
SkyContext make_context(SkyInputs in, const SkySettings& settings, const RenderHooks& hooks,
                        std::shared_ptr<const MultipleScattering> tables, std::size_t units, std::size_t total) {
    std::shared_ptr<const MultipleScattering> shared;
    if (tables && settings.multiple.enabled) shared = std::move(tables);
    try {
        return {make_evaluator(std::move(in.atmosphere), settings.multiple, settings.threads, hooks, shared, units,
                               total),
                std::move(in.to_rgb), in.sun, in.altitude_m};
    } catch (const std::invalid_argument& e) {
        if (!shared) throw;
        throw SkyError(std::string(e.what()) + "; use sky_multiple_scattering with the same scene and settings");
    }
}

// Linear Rec.709 from a spectrum, clamped at 0 like Cycles' xyz_to_rgb_clamped: saturated
// twilight blues fall outside the Rec.709 gamut, and a negative radiance is not an image.
void store_rgb(const SpectrumToRgb& to_rgb, std::span<const double> radiance, float* px) {
    const Vec3d rgb = to_rgb.apply(radiance);
    for (int c = 0; c < 3; ++c) px[c] = static_cast<float>(std::max(rgb[c], 0.0));
}

// The sky is mirror-symmetric about the vertical plane through the sun (the observer is on
// the symmetry axis of a spherically symmetric atmosphere). When that plane maps pixel
// centres onto pixel centres — the sun's u·W is a multiple of ½, e.g. rotation 0° or 90°
// with W divisible by 4 — column x equals column (k − 1 − x) mod W, k = 2·u_sun·W, and only
// half the columns are computed. Returns k, or −1 when the grid is not symmetric.
long mirror_key(const glm::dvec3& sun, int width) {
    if (std::hypot(sun.x, sun.y) < 1e-12) return -1;  // sun at the zenith/nadir: every column is
                                                      // a mirror plane, but keep it simple
    const double k = 2.0 * equirect_uv_from_direction(sun).x * width;
    const double kr = std::round(k);
    if (std::abs(k - kr) > 1e-9 * width) return -1;
    long key = static_cast<long>(kr) % width;
    return key < 0 ? key + width : key;
}

// Adds the sun disc (uniform radiance E_sun/Ω_sun times the view transmittance) to `image`,
// box-filtered: N points spread uniformly over the disc's solid angle (a sunflower spiral)
// each carry E·T/N of irradiance into the pixel they fall in, divided by that pixel's solid
// angle. The total Σ L·Ω_pixel equals the disc's transmitted irradiance at any resolution.
void add_sun_disc(const FrameContext& ctx, const SkySettings& settings, FloatImage& image) {
    const Atmosphere& atm = ctx.atmosphere();
    const double alpha = atm.sun_angular_radius_rad;
    if (!(alpha > 0.0)) return;
    const std::size_t nw = atm.wavelength_count();
    const double cos_alpha = std::cos(alpha);
    const double one_minus_cos = 2.0 * std::sin(0.5 * alpha) * std::sin(0.5 * alpha);  // 1 − cos α
    const double disc_solid_angle = kTwoPi * one_minus_cos;
    // Enough points for ≥ 64 per covered pixel, and at least 4096.
    const double pixel_solid_angle_est = (kTwoPi / settings.width) * (kPi / settings.height);
    const std::size_t n_points =
        std::clamp<std::size_t>(std::size_t(64.0 * disc_solid_angle / pixel_solid_angle_est), 4096, 1u << 22);

    // The view transmittance depends only on the zenith angle of the direction (spherical
    // symmetry about the observer's vertical): tabulate it across the disc and interpolate.
    const glm::dvec3 s = ctx.sun;
    const double theta_sun = std::acos(std::clamp(s.z, -1.0, 1.0));
    const double th_lo = std::max(0.0, theta_sun - alpha), th_hi = std::min(kPi, theta_sun + alpha);
    constexpr int kTable = 257;
    std::vector<double> t_table(kTable * nw);
    for (int k = 0; k < kTable; ++k) {
        const double th = th_lo + (th_hi - th_lo) * k / (kTable - 1);
        // The view ray toward the disc is a sun ray from the observer (0 behind the planet).
        sun_transmittance(atm, ctx.altitude_m, ZenithAngle<double>{std::cos(th), std::sin(th)},
                          std::span<double>(t_table.data() + k * nw, nw));
    }

    // Orthonormal frame around the sun direction.
    const glm::dvec3 helper = std::abs(s.z) < 0.9 ? glm::dvec3(0, 0, 1) : glm::dvec3(1, 0, 0);
    const glm::dvec3 e1 = glm::normalize(glm::cross(helper, s));
    const glm::dvec3 e2 = glm::cross(s, e1);
    const double golden = kPi * (3.0 - std::sqrt(5.0));
    std::vector<double> radiance(nw);
    std::map<std::size_t, Vec3d> disc;  // pixel index → the disc's RGB in it
    for (std::size_t k = 0; k < n_points; ++k) {
        // Uniform in solid angle over the cap: 1 − cos r is uniform in [0, 1 − cos α].
        const double omc = one_minus_cos * (k + 0.5) / n_points;
        const double cos_r = 1.0 - omc, sin_r = std::sqrt(std::max(0.0, omc * (2.0 - omc)));
        const double az = golden * k;
        const glm::dvec3 d = cos_r * s + sin_r * (std::cos(az) * e1 + std::sin(az) * e2);
        if (glm::dot(d, s) < cos_alpha - 1e-15) continue;
        const double th = std::acos(std::clamp(d.z, -1.0, 1.0));
        // The ground blocks the disc exactly where the geometry says, not where the table's
        // interpolation would fade it.
        const auto ray = PlanetRay<double>::from_vectors(
            atm.planet_radius_m, Vec3<double>(0.0, 0.0, atm.planet_radius_m + ctx.altitude_m), Vec3<double>(d));
        if (hits_ground(ray)) continue;
        const glm::dvec2 p = equirect_pixel_from_direction(d, settings.width, settings.height);
        int px = static_cast<int>(std::floor(p.x)), py = static_cast<int>(std::floor(p.y));
        px = ((px % settings.width) + settings.width) % settings.width;
        py = std::clamp(py, 0, settings.height - 1);
        if (settings.region == SkyRegion::upper && 2 * py + 1 > settings.height) continue;
        const double f = th_hi > th_lo ? std::clamp((th - th_lo) / (th_hi - th_lo), 0.0, 1.0) * (kTable - 1) : 0.0;
        const int k0 = std::min(static_cast<int>(f), kTable - 2);
        const double w = f - k0;
        const double scale = 1.0 / (double(n_points) * equirect_pixel_solid_angle(py, settings.width, settings.height));
        for (std::size_t i = 0; i < nw; ++i) {
            const double t = (1.0 - w) * t_table[k0 * nw + i] + w * t_table[(k0 + 1) * nw + i];
            radiance[i] = atm.sun_irradiance[i] * t * scale;
        }
        const Vec3d rgb = ctx.to_rgb.apply(radiance);
        Vec3d& acc = disc[std::size_t(py) * settings.width + px];
        for (int c = 0; c < 3; ++c) acc[c] += rgb[c];
    }
    // Added, then clamped once per pixel (a reddened disc may lie outside Rec.709, like the sky).
    for (const auto& [index, rgb] : disc) {
        float* out = image.pixels.data() + index * 3;
        for (int c = 0; c < 3; ++c) out[c] = static_cast<float>(std::max(0.0, double(out[c]) + rgb[c]));
    }
}

// The column that mirrors column x (mirror_key's k ≥ 0): (k − 1 − x) mod W.
int mirror_column(long key, int x, int W) { return static_cast<int>(((key - 1 - x) % W + W) % W); }

// The image columns a per-pixel render evaluates: every column, or with the mirror (key ≥ 0)
// one of each mirrored pair.
std::vector<int> evaluated_columns(long key, int W) {
    std::vector<int> columns;
    for (int x = 0; x < W; ++x) {
        const long m = key >= 0 ? mirror_column(key, x, W) : x;
        if (x <= m) columns.push_back(x);
    }
    return columns;
}

// Rays a per-pixel render evaluates: the evaluated columns of every row of the region.
double pixel_rays(const glm::dvec3& sun, const SkySettings& settings) {
    const int image_rows = settings.region == SkyRegion::upper ? (settings.height + 1) / 2 : settings.height;
    return double(evaluated_columns(mirror_key(sun, settings.width), settings.width).size()) * image_rows;
}

// Rays of the image's grid of G intervals and of the multiple-scattering view of M for the
// observer of `hz` (sky_grid.hpp SkyGridLayout::rays: its pieces, the sky only for an
// upper-hemisphere image).
double grid_rays(int G, bool sky_only, const Horizon& hz) { return SkyGridLayout::image(G).rays(hz, sky_only); }
double view_rays(int M, const Horizon& hz) { return SkyGridLayout::view(M).rays(hz, false); }

// settings.grid resolved for a sun (sky.hpp SkySettings::grid): a grid is used only when it
// evaluates fewer rays than the pixels would (the mirror halves the rays of a per-pixel
// image); otherwise every pixel is evaluated, the grid's own limit, exact and cheaper.
int grid_for(const glm::dvec3& sun, const SkySettings& settings, const Horizon& hz) {
    const int G = settings.grid >= 0 ? settings.grid : kSkyDefaultGrid;
    if (G == 0) return 0;
    return grid_rays(G, settings.region == SkyRegion::upper, hz) < pixel_rays(sun, settings) ? G : 0;
}

// settings.multiple_grid resolved likewise (SkySettings::multiple_grid): the view is built only
// when it integrates fewer rays than the render evaluates (the grid's nodes, or the pixels),
// else the tables are integrated along every evaluated ray.
int ms_grid_for(const glm::dvec3& sun, const SkySettings& settings, const Horizon& hz) {
    const int M = settings.multiple.enabled ? settings.multiple_grid : 0;
    if (M == 0) return 0;
    const int G = grid_for(sun, settings, hz);
    const double evaluated =
        G > 0 ? grid_rays(G, settings.region == SkyRegion::upper, hz) : pixel_rays(sun, settings);
    return view_rays(M, hz) < evaluated ? M : 0;
}

// The observer's horizon in a scene (its altitude, the knots of its profiles).
Horizon scene_horizon(const Scene& scene) {
    return Horizon::of(scene.planet.radius_m, scene.planet.atmosphere_top_m - scene.planet.radius_m,
                       scene.observer.altitude_m, profile_knots_m(scene));
}

// The progress units of one image (render_frame reports exactly these): a unit per grid row
// and per image row.
std::size_t frame_work(const SkySettings& settings, int G, const Horizon& hz) {
    if (G <= 0) return std::size_t(settings.height);
    return std::size_t(SkyGridLayout::image(G).rows(hz, settings.region == SkyRegion::upper)) +
           std::size_t(settings.height);
}

}  // namespace

int effective_sky_grid(const Scene& scene, const SkySettings& settings) {
    return grid_for(sun_direction(scene.sun.elevation_deg, scene.sun.azimuth_deg), settings, scene_horizon(scene));
}

int effective_sky_multiple_grid(const Scene& scene, const SkySettings& settings) {
    return ms_grid_for(sun_direction(scene.sun.elevation_deg, scene.sun.azimuth_deg), settings, scene_horizon(scene));
}

MultipleScattering sky_multiple_scattering(const Scene& scene, const SkySettings& settings, const RenderHooks& hooks) {
    const SkyInputs in = prepare(scene, settings);
    return *compute_tables(in.atmosphere, settings.multiple, settings.threads, hooks, 1000, 1000);
}

namespace {

// View samples for the grid's short ground rays (short_ground_ray).
constexpr int kShortRaySamples = 4;

// A ray from altitude h0 that meets the ground after L metres is short when nothing its
// single-scattering integrand ρ_c(h) T_view T_sun depends on changes by more than 5 % along
// it: every profile's density between the ground and h0 (ln ρ by h0/H ≤ 0.05 for an
// exponential one, a piecewise-linear one within one piece and within 5 % of its larger end),
// and the view's optical depth over L at most 0.05 at every wavelength (the sun's path moves
// by L/R in angle: negligible at these lengths). A Gauss–Legendre rule of kShortRaySamples
// nodes per constituent then integrates it as well as the default 16 do: the in-scatter of
// the presets' ground rays from 1–30 m, down to 0.2° below the horizon, changes by ≤ 2e-8
// relative (the blender-nishita and earth images at their defaults: the same floats). Ground
// rows of an observer near the ground are such rays (from 1 m: every ground row but the one
// next to the horizon). Not while Earth's shadow could cut the ray: with the sun's elevation
// (sin = sun_z) within the horizon's dip at h0 plus L/R (the ray's points' verticals turn by
// at most that) and 1 mrad of margin of the horizon, T_sun may jump along it.
bool short_ground_ray(const Atmosphere& atm, double h0, double L, double sun_z) {
    if (!(L >= 0.0) || !(h0 >= 0.0)) return false;
    const double R = atm.planet_radius_m;
    const double dip = std::acos(std::clamp(R / (R + h0), -1.0, 1.0)), turn = L / R + 1e-3;
    const double sun_elevation = std::asin(std::clamp(sun_z, -1.0, 1.0));
    if (sun_elevation > -(dip + turn) && sun_elevation < turn) return false;
    double tau = 0.0;
    for (const AtmosphereConstituent& c : atm.constituents) {
        const CompiledProfile& p = c.profile;
        if (p.kind == CompiledProfile::Kind::exponential) {
            if (!(h0 <= 0.05 * p.scale_height_m)) return false;
        } else {
            const auto knot = std::upper_bound(p.altitude_m.begin(), p.altitude_m.end(), 0.0);
            if (knot != p.altitude_m.end() && *knot < h0) return false;  // a knot inside (0, h0)
            const double a = p.at(0.0), b = p.at(h0);
            if (std::abs(a - b) > 0.05 * std::max(a, b)) return false;
        }
        const double rho = std::max(p.at(0.0), p.at(h0));  // the larger end: ρ is monotone on [0, h0]
        double ext = 0.0;
        for (double e : c.extinction_per_m) ext = std::max(ext, e);
        tau += ext * rho * L;
    }
    return tau <= 0.05;
}

// The image grid's channels: RGB per node of the Rayleigh-like single scattering over its
// phase function, the other constituents' over theirs, the multiple scattering (each over
// 1 − T̄), and the ground's light (over T̄).
constexpr int kGridChannels = 12;
// SkyGrid::rough_cells' thresholds, for the image's grid and the multiple-scattering view: a cell
// is rough where the quadratic estimates of its middle disagree by more than 5 % of its corners'
// value plus 1e-3 of the grid's largest (docs/sky.md "Rough cells": 2 % doubled the pixels
// evaluated from orbit for max 4.5 → 0.9 %; 10 % missed the band from 50 km at twilight).
// The image's grid is also judged in its pixels (SkyGrid::Shown), down to 1e-5 of the
// brightest node: faint light the channels' floor left interpolated — the Earth's shadow
// rising in the antisolar sky at sun −4° (earth, ground, 512 × 256 single scattering against
// every pixel: max 21 → 0.6 %), the horizon through haze at sunrise (docs/sky.md "Faint light
// and exponential rows in the image's grid").
constexpr double kRoughTolerance = 0.05;
constexpr double kRoughFloor = 1e-3;
constexpr double kShownRoughFloor = 1e-5;

// The image grid holds each radiance column's single scattering (the evaluator's
// Rayleigh-like and other constituents) over a phase function of that column, which each
// pixel multiplies back at its own ν: exact for any positive function, and the quotient is
// smooth when the function is the column's own mix — its constituents' phase functions
// weighted by their scattering optical depths (a vertical column from the ground to the top,
// summed over the wavelengths). With one phase per column (the presets) the quotient has none of the phase's
// shape left, and the aureole's forward peak is not interpolated.
struct ColumnPhases {
    struct Part {
        PhaseFunction phase;
        double weight;
    };
    std::vector<Part> r, m;
    static ColumnPhases of(const Atmosphere& atm) {
        ColumnPhases p;
        for (const AtmosphereConstituent& c : atm.constituents) {
            if (!c.scatters) continue;
            double sigma = 0.0;
            for (double v : c.scattering_per_m) sigma += v;
            const double w = vertical_column(c.profile, atm.top_altitude_m) * sigma;
            if (std::isfinite(w) && w > 0.0) (c.rayleigh_like ? p.r : p.m).push_back({c.phase, w});
        }
        return p;
    }
    // ∫ ρ dh over [0, top], exactly: the exponential in closed form, the piecewise-linear
    // profile by its knots clipped to [0, top] (a thin layer between any samples still counts).
    static double vertical_column(const CompiledProfile& p, double top) {
        if (!(top > 0.0)) return 0.0;
        if (p.kind == CompiledProfile::Kind::exponential) {
            const double H = p.scale_height_m;
            return -H * std::expm1(-top / H) * std::exp(p.reference_altitude_m / H);
        }
        double sum = 0.0;
        for (std::size_t i = 0; i + 1 < p.altitude_m.size(); ++i) {
            const double x0 = p.altitude_m[i], x1 = p.altitude_m[i + 1], y0 = p.density[i], y1 = p.density[i + 1];
            const double a = std::max(x0, 0.0), b = std::min(x1, top);
            if (!(b > a) || !(x1 > x0)) continue;
            const auto y = [&](double x) { return y0 + (y1 - y0) * (x - x0) / (x1 - x0); };
            sum += 0.5 * (b - a) * (y(a) + y(b));
        }
        return sum;
    }
    static double mix(const std::vector<Part>& parts, double nu) {
        if (parts.empty()) return 1.0;
        nu = std::clamp(nu, -1.0, 1.0);
        double num = 0.0, den = 0.0;
        for (const Part& q : parts) num += q.weight * phase(q.phase, nu), den += q.weight;
        return num / den;
    }
    double rayleigh(double nu) const { return mix(r, nu); }
    double mie(double nu) const { return mix(m, nu); }
};

// One image of a prepared sky (FrameContext: evaluator, colour map, sun, observer), with
// progress reported as frame_work(settings, G, hz) units.
FloatImage render_frame(const FrameContext& ctx, const SkySettings& settings, const RenderHooks& hooks) {
    const int W = settings.width, H = settings.height;
    const std::size_t nw = ctx.atmosphere().wavelength_count();
    FloatImage image;
    try {
        image = FloatImage(W, H, 3);
    } catch (const std::bad_alloc&) {
        throw SkyError("width x height = " + std::to_string(W) + " x " + std::to_string(H) + ": the image needs " +
                       std::to_string(double(W) * H * 12 / 1e9) + " GB, more memory than is available");
    }
    const bool upper = settings.region == SkyRegion::upper;
    const int image_rows = upper ? (H + 1) / 2 : H;  // rows whose centre is at or above the horizon
    const long key = mirror_key(ctx.sun, W);

    // Per pixel or through the grid?
    const Horizon hz = ctx.evaluator.horizon(ctx.altitude_m);
    const int G = grid_for(ctx.sun, settings, hz);
    SkyGrid grid;
    // A grid or view too large for the memory: SkyError naming the setting (not std::bad_alloc).
    const auto too_large = [](const char* field, int n, double values) {
        return SkyError(std::string(field) + " = " + std::to_string(n) + ": the grid needs " +
                        std::to_string(values * 8.0 / 1e9) + " GB, more memory than is available; use a smaller " +
                        field);
    };
    if (G > 0) {
        try {
            grid = SkyGrid::make(SkyGridLayout::image(G), hz, Vec3<double>(ctx.sun), kGridChannels, upper);
        } catch (const std::bad_alloc&) {
            throw too_large("grid", G, grid_rays(G, upper, hz) * kGridChannels);
        }
    }
    const int grid_rows = grid.rows();
    const std::size_t total_work = frame_work(settings, G, hz);
    auto report = [&](std::size_t n) {
        if (hooks.work_done) hooks.work_done(n, total_work);
    };
    auto cancelled = [&] { return hooks.cancel && hooks.cancel->requested(); };

    const int threads = settings.threads > 0 ? settings.threads : hardware_threads();

    // Scratch per thread for one batch of rays.
    struct Scratch {
        std::vector<Vec3<double>> dirs;
        std::vector<double> transmittance, rayleigh, mie, radiance, multiple_inscatter;
        void resize(std::size_t n, std::size_t nw) {
            dirs.resize(n);
            for (auto* v : {&transmittance, &rayleigh, &mie, &radiance, &multiple_inscatter}) v->resize(n * nw);
        }
        RadianceOut out(std::size_t n, std::size_t nw) {
            return {{transmittance.data(), n * nw}, {rayleigh.data(), n * nw}, {mie.data(), n * nw},
                    {radiance.data(), n * nw}};
        }
    };
    std::vector<Scratch> scratch(static_cast<std::size_t>(threads));
    // Multiple scattering interpolated from the observer's view (MsView) unless asked per ray.
    std::optional<MsView> view;
    if (const int M = ms_grid_for(ctx.sun, settings, hz); ctx.evaluator.tables() && M > 0)
        try {
            view = ctx.evaluator.ms_view(ctx.altitude_m, Vec3<double>(ctx.sun), M, threads, hooks);
        } catch (const std::bad_alloc&) {
            throw too_large("multiple_grid", M, view_rays(M, hz) * 2.0 * double(nw));
        }
    // The radiance of a batch of directions (single and multiple scattering: the evaluator).
    auto evaluate_with = [&](const Evaluator& ev, Scratch& s, std::size_t n) {
        ev.radiance(ctx.altitude_m, Vec3<double>(ctx.sun), std::span<const Vec3<double>>(s.dirs.data(), n),
                    s.out(n, nw), view ? &*view : nullptr, {s.multiple_inscatter.data(), n * nw});
    };
    // Pixels (x, y) evaluated along their own rays, the multiple scattering from `ms` (nullptr:
    // integrated along each ray), each stored and copied to its mirror column.
    auto evaluate_pixels = [&](Scratch& s, std::span<const std::pair<int, int>> pixels, const MsView* ms) {
        const std::size_t n = pixels.size();
        s.resize(n, nw);
        for (std::size_t k = 0; k < n; ++k)
            s.dirs[k] = Vec3<double>(equirect_pixel_direction(pixels[k].first, pixels[k].second, W, H));
        ctx.evaluator.radiance(ctx.altitude_m, Vec3<double>(ctx.sun), std::span<const Vec3<double>>(s.dirs.data(), n),
                               s.out(n, nw), ms);
        for (std::size_t k = 0; k < n; ++k) {
            const int x = pixels[k].first, y = pixels[k].second;
            float* px = image.at(x, y);
            store_rgb(ctx.to_rgb, std::span<const double>(s.radiance.data() + k * nw, nw), px);
            if (key >= 0) std::copy(px, px + 3, image.at(mirror_column(key, x, W), y));
        }
    };
    // The grid's short ground rows (short_ground_ray) through an evaluator of
    // kShortRaySamples view samples: the same single scattering, about a third of the work
    // per ray (for an observer near the ground: half the grid's rays).
    std::vector<unsigned char> short_row(std::size_t(grid_rows), 0);
    std::optional<Evaluator> short_evaluator;
    if (G > 0 && ctx.atmosphere().settings.view_samples > kShortRaySamples) {
        const Atmosphere& atm = ctx.atmosphere();
        bool any = false;
        for (int k = grid.rows_sky; k < grid_rows; ++k) {
            const PlanetRay<double> ray{atm.planet_radius_m, ctx.altitude_m,
                                        ZenithAngle<double>::from_cos(std::cos(grid.row_theta(k)))};
            if (ctx.altitude_m <= atm.top_altitude_m && hits_ground(ray) &&
                short_ground_ray(atm, ctx.altitude_m, ground_distance_m(ray), ctx.sun.z)) {
                short_row[std::size_t(k)] = 1;
                any = true;
            }
        }
        if (any) {
            Atmosphere short_atm = atm;
            set_view_samples(short_atm, kShortRaySamples);
            short_evaluator.emplace(ctx.evaluator.tables()
                                        ? Evaluator(std::move(short_atm), ctx.evaluator.shared_tables(),
                                                    ctx.evaluator.ms_view_samples())
                                        : Evaluator(std::move(short_atm)));
        }
    }
    const ColumnPhases phases = ColumnPhases::of(ctx.atmosphere());
    // The grid holds each node's light normalised by its view transmittance (as MsView does):
    // what is scattered along the ray over (1 − T̄), what comes from the ground over T̄, T̄ the
    // luminance-weighted mean of T(λ). A ray just below the horizon meets the ground hundreds
    // of kilometres away, one a pixel lower a few hundred metres away; its light follows
    // (1 − T) and T, the ratios stay smooth. Each pixel multiplies back by its own row's T̄
    // (T depends only on the zenith angle), computed exactly below.
    std::vector<double> luminance_weight(nw);
    {
        double sum = 0.0;
        for (std::size_t w = 0; w < nw; ++w) {
            luminance_weight[w] = std::max(0.0, 0.2126 * ctx.to_rgb.matrix[0][w] + 0.7152 * ctx.to_rgb.matrix[1][w] +
                                                    0.0722 * ctx.to_rgb.matrix[2][w]);
            sum += luminance_weight[w];
        }
        for (double& v : luminance_weight) v = sum > 0.0 ? v / sum : 1.0 / double(nw);
    }
    auto mean_transmittance = [&](const double* T) {
        double t = 0.0;
        for (std::size_t w = 0; w < nw; ++w) t += luminance_weight[w] * T[w];
        return std::clamp(t, 0.0, 1.0);
    };

    // The cells of the multiple-scattering view its cubics cannot follow (SkyGrid::rough_cells:
    // from orbit at twilight, the shadow's edge across the limb): their pixels' multiple
    // scattering is integrated along each pixel's own ray, whether the image interpolates its
    // grid or evaluates every pixel. view_rough_row[y]: the view's cell row that holds image
    // row y where that row has a rough cell, else −1; view_c0[x]: the view's cell column of x.
    const auto rows_with = [](const std::vector<unsigned char>& flags, int intervals) {
        std::vector<unsigned char> any(flags.size() / std::size_t(std::max(intervals, 1)) + 1, 0);
        for (std::size_t i = 0; i < flags.size(); ++i) any[i / std::size_t(intervals)] |= flags[i];
        return any;
    };
    // the row of a cell that holds θ, or −1 (none, or not rough anywhere)
    const auto rough_row = [](const SkyGrid& g, const std::vector<unsigned char>& has, double theta) {
        SkyGrid::Cell cell;
        if (!g.cell(theta, g.sun_phi, cell) || cell.r1 == cell.r0 || !has[std::size_t(cell.r0)]) return -1;
        return cell.r0;
    };
    std::vector<unsigned char> view_rough;
    std::vector<int> view_rough_row(std::size_t(image_rows), -1), view_c0;
    if (view && settings.refine_rough_cells) {
        view_rough = view->grid.rough_cells(kRoughTolerance, kRoughFloor);
        const std::vector<unsigned char> view_row_has = rows_with(view_rough, view->grid.intervals);
        for (int y = 0; y < image_rows; ++y)
            view_rough_row[std::size_t(y)] = rough_row(view->grid, view_row_has, kPi * (y + 0.5) / H);
        view_c0.resize(std::size_t(W));
        for (std::size_t x = 0; x < view_c0.size(); ++x) {
            double wc;
            view->grid.column(kPi - kTwoPi * (double(x) + 0.5) / W, view_c0[x], wc);
        }
    }
    const auto view_rough_at = [&](int x, int y) {
        const int rv = view_rough_row[std::size_t(y)];
        return rv >= 0 && view_rough[std::size_t(rv) * view->grid.intervals + view_c0[std::size_t(x)]];
    };

    if (G > 0) {
        // ---- the grid, then every pixel interpolated from it ----
        const int cols = grid.columns();
        SkyGrid::Shown shown;  // the parts' weights in each node's pixel (rough cells)
        shown.parts = 4;
        shown.floor = kShownRoughFloor;
        shown.weight.resize(std::size_t(grid_rows) * std::size_t(cols) * 4);
        shown.luminance.resize(std::size_t(grid_rows) * std::size_t(cols));
        {
            parallel_for(0, std::size_t(grid_rows), 1, threads, [&](std::size_t rb, std::size_t re, int worker) {
                Scratch& s = scratch[std::size_t(worker)];
                s.resize(cols, nw);
                for (int k = int(rb); k < int(re); ++k) {
                    if (cancelled()) return;
                    // A row at the zenith or the nadir is one direction in every column (to
                    // 1e-16 at the nadir, whose sin θ rounds to 1.2e-16): evaluated once.
                    const int evaluated = std::abs(std::sin(grid.row_theta(k))) < 1e-12 ? 1 : cols;
                    for (int j = 0; j < evaluated; ++j) s.dirs[j] = grid.node_direction(k, j);
                    evaluate_with(short_row[std::size_t(k)] ? *short_evaluator : ctx.evaluator, s,
                                  std::size_t(evaluated));
                    std::vector<double> ground(nw);
                    for (int j = 0; j < cols; ++j) {
                        const std::size_t o = std::size_t(evaluated == 1 ? 0 : j) * nw;
                        for (std::size_t w = 0; w < nw; ++w)
                            ground[w] = s.radiance[o + w] - (s.rayleigh[o + w] + s.mie[o + w] + s.multiple_inscatter[o + w]);
                        const double T = mean_transmittance(s.transmittance.data() + o);
                        const double nu = glm::dot(glm::dvec3(s.dirs[std::size_t(evaluated == 1 ? 0 : j)]), ctx.sun);
                        const double scatter_norm = 1.0 - T > 1e-12 ? 1.0 / (1.0 - T) : 0.0;
                        const Vec3d parts[4] = {
                            ctx.to_rgb.apply(std::span<const double>(s.rayleigh.data() + o, nw)),
                            ctx.to_rgb.apply(std::span<const double>(s.mie.data() + o, nw)),
                            ctx.to_rgb.apply(std::span<const double>(s.multiple_inscatter.data() + o, nw)),
                            ctx.to_rgb.apply(ground)};
                        const double pr = phases.rayleigh(nu), pm = phases.mie(nu);
                        const double scale[4] = {scatter_norm / pr, scatter_norm / pm,
                                                 scatter_norm, T > 1e-300 ? 1.0 / T : 0.0};
                        double* out = grid.at(k, j);
                        for (int p = 0; p < 4; ++p)
                            for (int c = 0; c < 3; ++c) out[3 * p + c] = parts[p][c] * scale[p];
                        // what the node's pixel is made of, for the rough cells
                        const std::size_t node = std::size_t(k) * std::size_t(cols) + std::size_t(j);
                        const double shown_weight[4] = {pr * (1.0 - T), pm * (1.0 - T), 1.0 - T, T};
                        std::copy(shown_weight, shown_weight + 4, shown.weight.begin() + std::ptrdiff_t(4 * node));
                        double y = 0.0;
                        for (const Vec3d& part : parts) y += 0.2126 * part[0] + 0.7152 * part[1] + 0.0722 * part[2];
                        shown.luminance[node] = std::max(y, 0.0);
                    }
                    report(1);
                }
            });
        }
        if (cancelled()) throw Cancelled("sky: cancelled");
        grid.take_logs();  // rows blended in the value or its logarithm (SkyGrid::blend_row)
        // T̄ of every image row (one ray per row, toward the sun's azimuth).
        std::vector<double> row_transmittance(std::size_t(image_rows), 1.0);
        // Only T is needed here: view_transmittance_batch gives single scattering's T without
        // integrating the in-scatter and the multiple scattering of the row's ray.
        parallel_for(0, std::size_t(image_rows), 64, threads, [&](std::size_t rb, std::size_t re, int worker) {
            Scratch& s = scratch[std::size_t(worker)];
            s.resize(re - rb, nw);
            for (std::size_t y = rb; y < re; ++y) {
                const double theta = kPi * (double(y) + 0.5) / H, st = std::sin(theta);
                s.dirs[y - rb] = Vec3<double>(st * std::cos(grid.sun_phi), st * std::sin(grid.sun_phi), std::cos(theta));
            }
            view_transmittance_batch(ctx.atmosphere(), ctx.altitude_m,
                                     std::span<const Vec3<double>>(s.dirs.data(), re - rb),
                                     std::span<double>(s.transmittance.data(), (re - rb) * nw));
            for (std::size_t y = rb; y < re; ++y)
                row_transmittance[y] = mean_transmittance(s.transmittance.data() + (y - rb) * nw);
        });
        // Every image column's column stencil (the same in every row).
        struct ColumnStencil {
            int cols[4];
            double w[4];
            int c0;  // the grid column the pixel lies after (its cell)
        };
        std::vector<ColumnStencil> stencils(static_cast<std::size_t>(W));
        std::vector<double> column_sun(static_cast<std::size_t>(W));  // sin θ · this, + cos θ s_z: ν of a pixel
        for (int x = 0; x < W; ++x) {
            int c0;
            double wc;
            const double phi = kPi - kTwoPi * (x + 0.5) / W;
            column_sun[std::size_t(x)] = std::cos(phi) * ctx.sun.x + std::sin(phi) * ctx.sun.y;
            grid.column(phi, c0, wc);
            grid.column_stencil(c0, wc, stencils[std::size_t(x)].cols, stencils[std::size_t(x)].w);
            stencils[std::size_t(x)].c0 = c0;
        }
        // With the mirror (key ≥ 0) one pixel of each mirrored pair is interpolated and copied to
        // the other, as the per-pixel render does: the image is exactly symmetric, and the
        // interpolation and phase functions cost half.
        const std::vector<int> columns = evaluated_columns(key, W);
        {
            parallel_for(0, std::size_t(H), 4, threads, [&](std::size_t rb, std::size_t re, int) {
                std::vector<double> line(std::size_t(grid.columns()) * kGridChannels);
                for (int y = int(rb); y < int(re); ++y) {
                    if (cancelled()) return;
                    if (y < image_rows) {
                        const double theta = kPi * (y + 0.5) / H;
                        const double T = row_transmittance[std::size_t(y)];
                        const double st = std::sin(theta), ct = std::cos(theta);
                        SkyGrid::Cell cell;
                        double v[kGridChannels];
                        // The row part blended once per image row, then each pixel's column stencil.
                        if (grid.cell(theta, grid.sun_phi, cell)) {
                            grid.blend_row(cell, line);
                            for (const int x : columns) {
                                const ColumnStencil& cs = stencils[std::size_t(x)];
                                grid.interpolate_line(line, cs.cols, cs.w, v);
                                const double nu = st * column_sun[std::size_t(x)] + ct * ctx.sun.z;
                                const double pr = phases.rayleigh(nu), pm = phases.mie(nu);
                                float* px = image.at(x, y);
                                // a cubic's overshoot is no light
                                for (int ch = 0; ch < 3; ++ch)
                                    px[ch] = static_cast<float>(
                                        std::max(v[ch] * pr + v[3 + ch] * pm + v[6 + ch], 0.0) * (1.0 - T) +
                                        std::max(v[9 + ch], 0.0) * T);
                                if (key >= 0)
                                    std::copy(px, px + 3, image.at(mirror_column(key, x, W), y));
                            }
                        }
                    }
                    report(1);
                }
            });
        }
        if (cancelled()) throw Cancelled("sky: cancelled");
        // ---- the pixels of the cells the cubics cannot follow, evaluated ----
        // (SkyGrid::rough_cells: a shadow's edge across the limb seen from orbit, a band next
        // to the horizontal at twilight.) A pixel in a rough cell of the image's grid is
        // evaluated along its own ray, its multiple scattering interpolated from the view; one
        // in a rough cell of the view's grid has that integrated along its ray too.
        if (settings.refine_rough_cells) {
            const std::vector<unsigned char> rough = grid.rough_cells(kRoughTolerance, kRoughFloor, &shown);
            std::vector<std::pair<int, int>> exact[2];  // (x, y): [0] the view's multiple scattering, [1] per ray
            {
                const std::vector<unsigned char> row_has = rows_with(rough, grid.intervals);
                for (int y = 0; y < image_rows; ++y) {
                    const int r = rough_row(grid, row_has, kPi * (y + 0.5) / H);
                    if (r < 0 && view_rough_row[std::size_t(y)] < 0) continue;
                    for (const int x : columns) {
                        const bool per_ray = view_rough_at(x, y);
                        if (per_ray || (r >= 0 && rough[std::size_t(r) * grid.intervals + stencils[std::size_t(x)].c0]))
                            exact[per_ray].emplace_back(x, y);
                    }
                }
            }
            for (const bool per_ray : {false, true}) {
                const std::vector<std::pair<int, int>>& list = exact[per_ray];
                if (list.empty()) continue;
                constexpr std::size_t kBatch = 32;
                parallel_for(0, list.size(), kBatch, threads, [&](std::size_t b, std::size_t e, int worker) {
                    for (std::size_t k0 = b; k0 < e; k0 += kBatch) {
                        if (cancelled()) return;
                        evaluate_pixels(scratch[std::size_t(worker)],
                                        std::span<const std::pair<int, int>>(list).subspan(k0, std::min(kBatch, e - k0)),
                                        view && !per_ray ? &*view : nullptr);
                    }
                });
            }
        }
    } else {
        // ---- every pixel evaluated (half of them when the mirror applies) ----
        const std::vector<int> columns = evaluated_columns(key, W);
        report(std::size_t(grid_rows));
        parallel_for(0, std::size_t(H), 1, threads, [&](std::size_t rb, std::size_t re, int worker) {
            std::vector<std::pair<int, int>> pixels, per_ray;  // the view's multiple scattering / along the ray
            for (int y = int(rb); y < int(re); ++y) {
                if (cancelled()) return;
                if (y < image_rows) {
                    pixels.clear();
                    per_ray.clear();
                    for (const int x : columns) (view_rough_at(x, y) ? per_ray : pixels).emplace_back(x, y);
                    if (!pixels.empty()) evaluate_pixels(scratch[std::size_t(worker)], pixels, view ? &*view : nullptr);
                    if (!per_ray.empty()) evaluate_pixels(scratch[std::size_t(worker)], per_ray, nullptr);
                }
                report(1);
            }
        });
    }
    if (cancelled()) throw Cancelled("sky: cancelled");

    if (settings.view.sun_disc) add_sun_disc(ctx, settings, image);
    return image;
}

}  // namespace

struct SkySession::Impl {
    Scene scene;
    SkySettings settings;
    Atmosphere atmosphere;  // compiled at the image's wavelengths with settings.view
    SpectrumToRgb to_rgb;
    std::shared_ptr<const MultipleScattering> tables;
    std::string table_key;  // ms_table_key of the tables (empty without multiple scattering)
};

SkySession::SkySession(const Scene& scene, const SkySettings& settings, const RenderHooks& hooks,
                       std::shared_ptr<const MultipleScattering> tables, std::size_t units, std::size_t total) {
    SkyInputs in = prepare(scene, settings);
    auto impl = std::make_shared<Impl>();
    impl->scene = scene;
    impl->settings = settings;
    impl->to_rgb = std::move(in.to_rgb);
    if (settings.multiple.enabled) {
        // The evaluator's checks of given tables (SkyError names them), then the tables alone.
        SkyContext ctx = make_context(SkyInputs{in.atmosphere, impl->to_rgb, in.sun, in.altitude_m}, settings, hooks,
                                      std::move(tables), units, total);
        impl->tables = ctx.evaluator.shared_tables();
        impl->table_key = ms_table_key(in.atmosphere, settings.multiple.tables);
    } else if (units > 0 && hooks.work_done) {
        hooks.work_done(units, total);
    }
    impl->atmosphere = std::move(in.atmosphere);
    impl_ = std::move(impl);
}

const Scene& SkySession::scene() const { return impl_->scene; }
const SkySettings& SkySession::settings() const { return impl_->settings; }
const std::shared_ptr<const MultipleScattering>& SkySession::tables() const { return impl_->tables; }

FloatImage SkySession::render(const glm::dvec3& sun, double altitude_m, const RenderHooks& hooks) const {
    return render(sun, altitude_m, impl_->settings, hooks);
}

FloatImage SkySession::render(const glm::dvec3& sun, double altitude_m, const SkySettings& settings,
                              const RenderHooks& hooks) const {
    const Impl& s = *impl_;
    validate(settings);
    if (!(std::isfinite(sun.x) && std::isfinite(sun.y) && std::isfinite(sun.z)) ||
        std::abs(glm::length(sun) - 1.0) > 1e-6)
        throw SkyError("sun direction = (" + std::to_string(sun.x) + ", " + std::to_string(sun.y) + ", " +
                       std::to_string(sun.z) + "): must be a unit vector");
    if (!(std::isfinite(altitude_m) && altitude_m >= 0.0 && altitude_m <= 1e9))
        throw SkyError("observer.altitude_m = " + std::to_string(altitude_m) + ": must be in [0, 1e9]");
    if (settings.view.chapman != s.settings.view.chapman)
        throw SkyError(std::string("chapman = ") + std::string(chapman_method_name(settings.view.chapman)) +
                       ": the session was made with " + std::string(chapman_method_name(s.settings.view.chapman)) +
                       " (its atmosphere and tables depend on it); make another session");
    if (settings.view.ground != s.settings.view.ground)
        throw SkyError(std::string("ground = ") + (settings.view.ground ? "true" : "false") +
                       ": the session was made with " + (s.settings.view.ground ? "true" : "false") +
                       " (its atmosphere and tables depend on it); make another session");
    if (settings.multiple.enabled != s.settings.multiple.enabled)
        throw SkyError(std::string("multiple_scattering = ") + (settings.multiple.enabled ? "true" : "false") +
                       ": the session was made with " + (s.settings.multiple.enabled ? "true" : "false") +
                       "; make another session");
    if (settings.multiple.enabled && ms_table_key(s.atmosphere, settings.multiple.tables) != s.table_key)
        throw SkyError("multiple: the table settings differ from the session's (the tables depend on them); make "
                       "another session");
    // The per-render evaluator: the session's atmosphere with this render's view samples, the
    // session's tables shared (no copy, no precompute).
    Atmosphere atm = s.atmosphere;
    set_view_samples(atm, settings.view.view_samples);
    const Evaluator evaluator = s.tables ? Evaluator(std::move(atm), s.tables, settings.multiple.view_samples)
                                         : Evaluator(std::move(atm));
    return render_frame(FrameContext{evaluator, s.to_rgb, sun, altitude_m}, settings, hooks);
}

FloatImage render_sky(const Scene& scene, const SkySettings& settings, const RenderHooks& hooks,
                      const MultipleScattering* tables) {
    validate(scene);
    validate(settings);
    const glm::dvec3 sun = sun_direction(scene.sun.elevation_deg, scene.sun.azimuth_deg);
    // One bar for both parts: the table precompute, when it runs here, counts as much as the
    // image (it takes about as long as a default 2048 × 1024 image's grid; docs/sky.md).
    const Horizon hz = scene_horizon(scene);
    const std::size_t image_work = frame_work(settings, grid_for(sun, settings, hz), hz);
    const std::size_t ms_work = settings.multiple.enabled && !tables ? image_work : 0;
    const std::size_t total_work = ms_work + image_work;
    const SkySession session(scene, settings, hooks, {std::shared_ptr<void>(), tables} /* not owned */, ms_work,
                             total_work);
    RenderHooks frame_hooks;
    frame_hooks.cancel = hooks.cancel;
    if (hooks.work_done)
        frame_hooks.work_done = [&](std::size_t n, std::size_t) { hooks.work_done(n, total_work); };
    return session.render(sun, scene.observer.altitude_m, settings, frame_hooks);
}

std::vector<glm::dvec3> sky_radiance_rgb(const Scene& scene, const SkySettings& settings,
                                         std::span<const glm::dvec3> directions, const MultipleScattering* tables) {
    SkyInputs in = prepare(scene, settings);
    in.atmosphere.settings.sun_disc = settings.view.sun_disc;  // point-sampled here
    const SkyContext ctx = make_context(std::move(in), settings, {},
                                        {std::shared_ptr<void>(), tables} /* not owned */, 0, 0);
    const std::size_t nw = ctx.atmosphere().wavelength_count();
    std::vector<glm::dvec3> out(directions.size());
    parallel_for(0, directions.size(), 16, settings.threads,
                      [&](std::size_t kb, std::size_t ke, int) {
                          std::vector<double> t(nw), ray(nw), mie(nw), radiance(nw);
                          for (std::size_t k = kb; k < ke; ++k) {
                              const glm::dvec3 d = glm::normalize(directions[k]);
                              ctx.evaluator.radiance(ViewRay{ctx.altitude_m, Vec3<double>(d), Vec3<double>(ctx.sun)},
                                                     RadianceOut{t, ray, mie, radiance});
                              float px[3];
                              store_rgb(ctx.to_rgb, radiance, px);
                              out[k] = {px[0], px[1], px[2]};
                          }
                      });
    return out;
}

glm::dvec3 sky_radiance_rgb(const Scene& scene, const SkySettings& settings, const glm::dvec3& direction) {
    return sky_radiance_rgb(scene, settings, std::span<const glm::dvec3>(&direction, 1)).front();
}

std::string sky_settings_to_json(const Scene& scene, const SkySettings& settings) {
    nlohmann::ordered_json j;
    j["width"] = settings.width;
    j["height"] = settings.height;
    j["region"] = settings.region == SkyRegion::full ? "full" : "upper";
    j["view_samples"] = settings.view.view_samples;
    j["chapman"] = std::string(chapman_method_name(settings.view.chapman));
    j["sun_disc"] = settings.view.sun_disc;
    j["ground"] = settings.view.ground;
    j["grid"] = settings.grid;
    j["grid_used"] = effective_sky_grid(scene, settings);
    j["refine_rough_cells"] = settings.refine_rough_cells;
    j["multiple_scattering"] = settings.multiple.enabled;
    if (settings.multiple.enabled) {
        const MsSettings& m = settings.multiple.tables;
        nlohmann::ordered_json ms;
        ms["mode"] = std::string(ms_mode_name(m.mode));
        ms["parameterisation"] = std::string(ms_parameterisation_name(m.parameterisation));
        // The table as built: azimuth 0 resolved for this atmosphere.
        int azimuth = m.table.azimuth;
        if (azimuth == 0) {
            try {
                azimuth = ms_automatic_azimuth_nodes(prepare(scene, settings).atmosphere);
            } catch (const std::exception&) {
                azimuth = 0;  // an invalid scene: render_sky reports it
            }
        }
        ms["table"] = {{"altitude", m.table.altitude},
                       {"view_zenith", m.table.view_zenith},
                       {"sun_zenith", m.table.sun_zenith},
                       {"azimuth", azimuth}};
        ms["max_order"] = m.max_order;  // 0: automatic (until an order adds < tolerance)
        ms["tolerance"] = m.tolerance;
        ms["max_auto_order"] = m.max_auto_order;
        ms["geometric_tail"] = m.geometric_tail;
        ms["ray_samples"] = m.ray_samples;
        ms["order1_ray_samples"] = m.order1_ray_samples;
        ms["view_ray_samples"] = settings.multiple.view_samples;
        ms["view_grid"] = settings.multiple_grid;  // 0: integrated along every ray
        ms["view_grid_used"] = effective_sky_multiple_grid(scene, settings);
        j["multiple"] = ms;
    }
    j["basis"] = scene.basis.kind == SpectralBasis::Kind::rgb_schuler ? "rgb-schuler" : "spectral";
    j["wavelengths_nm"] = basis_wavelengths_nm(scene.basis);
    j["sun_elevation_deg"] = scene.sun.elevation_deg;
    j["sun_rotation_deg"] = scene.sun.azimuth_deg;
    const glm::dvec3 s = sun_direction(scene.sun.elevation_deg, scene.sun.azimuth_deg);
    j["sun_direction"] = {s.x, s.y, s.z};
    j["observer_altitude_m"] = scene.observer.altitude_m;
    j["mapping"] = "equirectangular, Blender/Cycles: Z up, centre +X, quarter from left +Y, top row zenith";
    j["units"] = "linear Rec.709 from XYZ = sum L(lambda) CMF(lambda) dlambda (CIE 1931 2 deg, no 683 lm/W), "
                 "L in W m^-2 sr^-1 nm^-1; as Blender's Nishita sky texture";
    return j.dump();
}

ImageMetadata sky_metadata(const Scene& scene, const SkySettings& settings) {
    return {
        {"airmass:version", version_string()},
        {"airmass:scene", scene_to_json(scene)},
        {"airmass:settings", sky_settings_to_json(scene, settings)},
        {"airmass:convention", "blender-equirectangular"},
        {"airmass:units", "linear-rec709-blender-nishita"},
        {"Software", std::string("airmass ") + version_string()},
    };
}

}  // namespace airmass
