// Native camera renders (render.hpp): per pixel a view ray, single scattering (and optionally
// multiple scattering) per wavelength, then the colour model; and the integral of a medium
// cut to a box, for comparisons with a VDB export of a box region.
#include "airmass/render.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <vector>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "airmass/color.hpp"
#include "airmass/geometry.hpp"
#include "airmass/optical_depth.hpp"
#include "airmass/parallel.hpp"
#include "airmass/phase.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/evaluator.hpp"
#include "airmass/single_scattering.hpp"
#include "airmass/spectrum.hpp"
#include "airmass/sky.hpp"
#include "airmass/version.hpp"

#include "math/quadrature.hpp"
#include "support/message_format.hpp"

namespace airmass {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

using detail::all_finite;
using detail::message_number;

}  // namespace

// ---- settings ----------------------------------------------------------------------------

void validate(const RenderSettings& s) {
    auto range = [](const char* field, double v, double lo, double hi) {
        if (!(v >= lo && v <= hi))
            throw RenderError(std::string(field) + " = " + message_number(v) + ": must be in [" + message_number(lo) + ", " + message_number(hi) + "]");
    };
    range("samples", s.view.view_samples, 1, 65536);
    range("threads", s.threads, 0, 4096);
    range("multiple_samples", s.multiple.view_samples, 1, 65536);
    if (s.camera) validate(*s.camera);
    if (s.color == ColorModel::renderer_rgb)
        for (int c = 0; c < 3; ++c) range("rgb_wavelengths_nm", s.rgb_wavelengths_nm[c], 360.0, 830.0);
    if (s.medium_box) {
        const MediumBox& b = *s.medium_box;
        if (!all_finite(b.min_m) || !all_finite(b.max_m) || !(b.min_m.x < b.max_m.x && b.min_m.y < b.max_m.y &&
                                                       b.min_m.z < b.max_m.z))
            throw RenderError("medium_box: must be finite with min < max on every axis");
        if (s.multiple.enabled)
            throw RenderError("multiple_scattering: not available with medium_box (the tables assume the whole shell)");
    }
    if (s.multiple.enabled) validate(s.multiple.tables);
}

Scene renderer_matched_scene(const Scene& scene, MatchedRenderer renderer) {
    Scene out = scene;
    for (Constituent& c : out.constituents) {
        if (renderer == MatchedRenderer::povray && c.phase.kind == PhaseFunction::Kind::rayleigh) continue;
        c.phase.g = henyey_greenstein_g(c.phase);  // the one rule (phase.hpp)
        c.phase.kind = PhaseFunction::Kind::henyey_greenstein;
    }
    return out;
}

std::array<double, 3> sun_irradiance_rgb(const Scene& scene) {
    const SpectrumToRgb to_rgb = spectrum_to_rgb(scene.basis);
    std::vector<double> e(to_rgb.size());
    for (std::size_t i = 0; i < e.size(); ++i) e[i] = scene.sun.irradiance_at(to_rgb.wavelengths_nm[i]);
    const Vec3d rgb = to_rgb.apply(e);
    return {std::max(rgb[0], 0.0), std::max(rgb[1], 0.0), std::max(rgb[2], 0.0)};
}

ObserverFrame observer_frame(double R, const glm::dvec3& p) {
    ObserverFrame f;
    const glm::dvec3 q(p.x, p.y, p.z + R);  // planet-centred
    const double r = glm::length(q);
    // |q|² − R² = x² + y² + z (z + 2R): no cancellation for a camera near the surface.
    f.altitude_m = (p.x * p.x + p.y * p.y + p.z * (p.z + 2.0 * R)) / (r + R);
    if (!(r > 0.0)) return f;
    const glm::dvec3 u = q / r;
    // Rotation taking u to +Z about the axis u × Z (Rodrigues); identity on the axis.
    const glm::dvec3 axis = glm::cross(u, glm::dvec3(0, 0, 1));
    const double s = glm::length(axis), c = u.z;
    if (s < 1e-15) {
        if (c < 0.0) f.rotation = {glm::dvec3(1, 0, 0), glm::dvec3(0, -1, 0), glm::dvec3(0, 0, -1)};
        return f;
    }
    const glm::dvec3 k = axis / s;
    const double v = 1.0 - c;
    f.rotation = {glm::dvec3(c + k.x * k.x * v, k.x * k.y * v - k.z * s, k.x * k.z * v + k.y * s),
                  glm::dvec3(k.y * k.x * v + k.z * s, c + k.y * k.y * v, k.y * k.z * v - k.x * s),
                  glm::dvec3(k.z * k.x * v - k.y * s, k.z * k.y * v + k.x * s, c + k.z * k.z * v)};
    return f;
}

// ---- medium cut to a box -----------------------------------------------------------------

namespace {

// The parameter interval [t0, t1] where the line o + t d is inside the box (slab method);
// empty (t0 > t1) when it misses.
struct Interval {
    double t0 = kInf, t1 = -kInf;
    bool empty() const { return !(t0 < t1); }
};

Interval intersect_box(const MediumBox& b, const glm::dvec3& o, const glm::dvec3& d) {
    Interval r{-kInf, kInf};
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0.0) {
            if (o[a] < b.min_m[a] || o[a] > b.max_m[a]) return {};
            continue;
        }
        double ta = (b.min_m[a] - o[a]) / d[a], tb = (b.max_m[a] - o[a]) / d[a];
        if (ta > tb) std::swap(ta, tb);
        r.t0 = std::max(r.t0, ta);
        r.t1 = std::min(r.t1, tb);
    }
    return r;
}

struct BoxContext {
    const Atmosphere& atm;
    const MediumBox& box;
    glm::dvec3 centre;  // planet centre in the scene frame
    glm::dvec3 sun;
    std::size_t nc, nw;
    double layer_m;  // thinnest layer (scale height / knot spacing) of the scattering constituents

    BoxContext(const Atmosphere& a, const MediumBox& b, const glm::dvec3& s)
        : atm(a), box(b), centre(0.0, 0.0, -a.planet_radius_m), sun(s), nc(a.constituents.size()),
          nw(a.wavelength_count()), layer_m(kInf) {
        for (const auto& c : atm.constituents) {
            if (!c.scatters) continue;
            if (c.profile.kind == CompiledProfile::Kind::exponential) layer_m = std::min(layer_m, c.profile.scale_height_m);
            else
                for (std::size_t k = 1; k < c.profile.altitude_m.size(); ++k) {
                    const double d = c.profile.altitude_m[k] - c.profile.altitude_m[k - 1];
                    if (d > 0.0) layer_m = std::min(layer_m, d);
                }
        }
        layer_m = std::max(layer_m, 10.0);
    }

    // The sun ray from scene point x at altitude h: false in Earth's shadow; otherwise the
    // constituent masses along it inside the box.
    bool sun_masses(const glm::dvec3& x, double h, double* m) const {
        const glm::dvec3 q = x - centre;
        const double mu = std::clamp(glm::dot(q, sun) / glm::length(q), -1.0, 1.0);
        const PlanetRay<double> ray{atm.planet_radius_m, std::max(h, 0.0), ZenithAngle<double>::from_cos(mu)};
        if (in_planet_shadow(ray)) return false;  // the shadow test of every sun ray (optical_depth.hpp)
        const Interval in = intersect_box(box, x, sun);
        const double a = std::max(in.t0, 0.0);
        if (in.empty() || !(in.t1 > a)) {
            std::fill(m, m + nc, 0.0);
            return true;
        }
        constituent_masses(atm, ray, a, in.t1, std::span<double>(m, nc));
        return true;
    }

    // Largest extinction over wavelengths at altitude h (m⁻¹).
    double max_extinction(double h) const {
        if (h > atm.top_altitude_m) return 0.0;
        double best = 0.0;
        for (std::size_t w = 0; w < nw; ++w) {
            double s = 0.0;
            for (std::size_t i = 0; i < nc; ++i) s += atm.extinction_matrix[w * nc + i] * atm.constituents[i].profile.at(h);
            best = std::max(best, s);
        }
        return best;
    }
};

// 4-point Gauss–Legendre on [0, 1] (math/quadrature.hpp).
constexpr double kGlX[4] = {0.5 - 0.5 * kGauss4Node[1], 0.5 - 0.5 * kGauss4Node[0], 0.5 + 0.5 * kGauss4Node[0],
                            0.5 + 0.5 * kGauss4Node[1]};
constexpr double kGlW[4] = {0.5 * kGauss4Weight[1], 0.5 * kGauss4Weight[0], 0.5 * kGauss4Weight[0],
                            0.5 * kGauss4Weight[1]};

#include "../transport/view_march.inc"

// A node of the box's march: its parameter along the view ray and its altitude.
struct BoxPoint {
    double t, h;
};

// The box's sun policy for the march (view_march.inc): the sun masses cut to the box, at a
// node of the view ray o + t v and from a ground point.
struct BoxSun {
    const BoxContext& ctx;
    const glm::dvec3& o;
    const glm::dvec3& v;
    bool operator()(const BoxPoint& x, double* mass) const { return ctx.sun_masses(o + x.t * v, x.h, mass); }
    void ground(const glm::dvec3& g, double mu_g, double* mass) const {
        const PlanetRay<double> sun_ray{ctx.atm.planet_radius_m, 0.0, ZenithAngle<double>::from_cos(mu_g)};
        const Interval in = intersect_box(ctx.box, g, ctx.sun);
        const double a = std::max(in.t0, 0.0);
        if (in.empty() || !(in.t1 > a)) std::fill(mass, mass + ctx.nc, 0.0);
        else constituent_masses(ctx.atm, sun_ray, a, in.t1, std::span<double>(mass, ctx.nc));
    }
};

// The box's node rule for the march (view_march.inc): adaptive panels over [a, b] (one
// layer of altitude change, linear and curvature terms, or 0.3 of optical depth), each split
// exactly at Earth's shadow boundary, 4-point Gauss–Legendre in each. The view masses are
// accumulated from a node to the next; `acc` holds them up to b on return. Nodes above the
// top of the atmosphere are not passed on. node(x, weight, 0, nc, view_masses) per node.
template <class Node>
void box_panels(const BoxContext& ctx, const PlanetRay<double>& ray, const glm::dvec3& o, const glm::dvec3& v,
                double a, double b, double* acc, Node&& node) {
    const Atmosphere& atm = ctx.atm;
    const std::size_t nc = ctx.nc;
    double dm[kMaxConstituents];
    double prev = a, t = a;
    const ShadowSpan shadow = earth_shadow_span(ray, glm::dot(o - ctx.centre, ctx.sun), glm::dot(v, ctx.sun));
    while (t < b) {
        const double h = ray.altitude_at(t);
        const double mu = std::abs(ray.zenith_at(t).cos_chi);
        const double r = atm.planet_radius_m + std::max(h, 0.0);
        double step = std::min(ctx.layer_m / std::max(mu, 1e-12), std::sqrt(2.0 * r * ctx.layer_m));
        const double sigma = ctx.max_extinction(h);
        if (sigma > 0.0) step = std::min(step, 0.3 / sigma);
        step = std::clamp(step, 1.0, 100e3);
        double end = std::min(t + step, b);
        // Earth's shadow (earth_shadow_span, the shadow of every sun ray): split the panel
        // exactly at a boundary inside it.
        for (const double edge : {shadow.t0, shadow.t1})
            if (shadow.t1 > shadow.t0 && edge > t + 1e-9 * (1.0 + t) && edge < end) end = edge;
        const double len = end - t;
        for (int k = 0; k < 4; ++k) {
            const double tk = t + len * kGlX[k];
            constituent_masses(atm, ray, prev, tk, std::span<double>(dm, nc));
            for (std::size_t i = 0; i < nc; ++i) acc[i] += dm[i];
            prev = tk;
            const BoxPoint x{tk, ray.altitude_at(tk)};
            if (x.h > atm.top_altitude_m) continue;
            node(x, len * kGlW[k], std::size_t(0), nc, [&](double* m_view) { std::copy(acc, acc + nc, m_view); });
        }
        t = end;
    }
    constituent_masses(atm, ray, prev, b, std::span<double>(dm, nc));
    for (std::size_t i = 0; i < nc; ++i) acc[i] += dm[i];
}

void box_radiance(const BoxContext& ctx, const PlanetRay<double>& ray, const glm::dvec3& o, const glm::dvec3& v,
                  std::span<double> out) {
    const Atmosphere& atm = ctx.atm;
    const std::size_t nc = ctx.nc, nw = ctx.nw;
    std::fill(out.begin(), out.end(), 0.0);
    const auto seg = atmosphere_segment(ray, atm.top_altitude_m);
    if (!seg.valid) return;
    const Interval in = intersect_box(ctx.box, o, v);
    const double a = std::max({seg.t_begin, in.t0, 0.0});
    const double b = std::min(seg.t_end, in.t1);

    double phase_value[kMaxConstituents];
    const double nu = std::clamp(glm::dot(v, ctx.sun), -1.0, 1.0);
    for (std::size_t i = 0; i < nc; ++i) phase_value[i] = phase(atm.constituents[i].phase, nu);

    double acc[kMaxConstituents] = {};  // view masses from a
    if (!in.empty() && b > a)
        march_view_ray(atm, [&](auto&& node) { box_panels(ctx, ray, o, v, a, b, acc, node); }, BoxSun{ctx, o, v},
                       phase_value, [&](std::size_t) { return SpectrumView<double>(out.first(nw)); });
    SpectrumView<double>(out.first(nw)) *= atm.sun_irradiance;

    // The ground (the whole planet, not cut to the box), seen through the box's medium.
    if (seg.hits_ground && atm.settings.ground && atm.ground_albedo > 0.0) {
        const glm::dvec3 g = o + seg.t_end * v;
        const glm::dvec3 n = glm::normalize(g - ctx.centre);
        const double mu_g = std::clamp(glm::dot(n, ctx.sun), -1.0, 1.0);
        if (mu_g > 0.0) {
            double ms[kMaxConstituents];
            BoxSun{ctx, o, v}.ground(g, mu_g, ms);
            SpectrumScratch<double> T_view(nw);
            optical_depth_of(atm, acc, T_view);
            exp_neg(T_view);
            add_ground(atm, mu_g, ms, T_view.view(), out.first(nw));
        }
    }
}

// The view ray from a camera at altitude h whose planet-centred unit position is `up`.
PlanetRay<double> view_ray(double R, double h, const glm::dvec3& up, const glm::dvec3& v) {
    const double c = std::clamp(glm::dot(up, v), -1.0, 1.0);
    const double s = std::min(glm::length(glm::cross(up, v)), 1.0);
    return {R, h, {c, s}};
}


// One integration node of a pixel: the scene-frame ray direction and its weight (a pixel's
// weights sum to 1).
struct PixelNode {
    glm::dvec3 direction;
    double weight;
};

// The box pixel filter (what Cycles 3.4's Box filter does: the mean over the pixel's square)
// as a product of the 4-point Gauss–Legendre rule above (kGlX, kGlW), 4 columns × 4 rows.
// The image is smooth inside a pixel except where the ground meets the sky (a jump in
// radiance); a column whose ends fall on different sides is split at the crossing, found by
// bisection to 1e-6 px, and each side is integrated separately, so the horizon row is
// integrated as accurately as the sky around it.
// A column holding two crossings with the same class at both ends (a planet smaller than a
// pixel) is not split: such pixels are a sampling question, not a radiance one.
template <class SeesGround>
void box_filter_nodes(const CameraModel& cam, int i, int j, const SeesGround& sees_ground, std::vector<PixelNode>& out) {
    for (int a = 0; a < 4; ++a) {
        const double x = i + kGlX[a];
        auto ground_at = [&](double y) { return sees_ground(camera_ray_direction(cam, x, y)); };
        double lo = j, hi = j + 1.0;
        const bool g_lo = ground_at(lo), g_hi = ground_at(hi);
        double split = hi;
        if (g_lo != g_hi) {
            for (int it = 0; it < 24; ++it) {
                const double mid = 0.5 * (lo + hi);
                (ground_at(mid) == g_lo ? lo : hi) = mid;
            }
            split = 0.5 * (lo + hi);
        }
        for (const auto& [y0, y1] : {std::pair{double(j), split}, std::pair{split, j + 1.0}}) {
            if (!(y1 > y0)) continue;
            for (int b = 0; b < 4; ++b)
                out.push_back({camera_ray_direction(cam, x, y0 + (y1 - y0) * kGlX[b]), kGlW[a] * kGlW[b] * (y1 - y0)});
        }
    }
}

}  // namespace

void box_limited_radiance(const Atmosphere& atmosphere, const MediumBox& box, const glm::dvec3& origin_m,
                          const glm::dvec3& direction, const glm::dvec3& sun_direction, std::span<double> out) {
    if (out.size() != atmosphere.wavelength_count())
        throw std::invalid_argument("box_limited_radiance: out needs " + std::to_string(atmosphere.wavelength_count()) +
                                    " elements");
    const double R = atmosphere.planet_radius_m;
    const ObserverFrame f = observer_frame(R, origin_m);
    const glm::dvec3 up = glm::normalize(origin_m - glm::dvec3(0, 0, -R));
    const glm::dvec3 v = glm::normalize(direction);
    const BoxContext ctx(atmosphere, box, glm::normalize(sun_direction));
    box_radiance(ctx, view_ray(R, f.altitude_m, up, v), origin_m, v, out);
}

// ---- the camera render ---------------------------------------------------------------------

FloatImage render_camera(const Scene& scene_in, const RenderSettings& settings, const RenderHooks& hooks) {
    validate(scene_in);
    validate(settings);
    const Scene scene = settings.renderer_matched ? renderer_matched_scene(scene_in, settings.matched_renderer) : scene_in;
    const CameraModel cam = settings.camera ? *settings.camera : camera_from_scene(scene, settings.projection);
    validate(cam);

    // Wavelengths and the map to RGB.
    SpectrumToRgb to_rgb;
    if (settings.color == ColorModel::spectral) {
        // Only wavelengths with a colour weight can change the image (as in sky.cpp).
        const SpectrumToRgb full = spectrum_to_rgb(scene.basis);
        for (std::size_t i = 0; i < full.size(); ++i) {
            if (full.matrix[0][i] == 0.0 && full.matrix[1][i] == 0.0 && full.matrix[2][i] == 0.0) continue;
            to_rgb.wavelengths_nm.push_back(full.wavelengths_nm[i]);
            for (int c = 0; c < 3; ++c) to_rgb.matrix[c].push_back(full.matrix[c][i]);
        }
        if (to_rgb.size() == 0) throw RenderError("spectrum: no wavelength of the basis lies inside 360-830 nm");
    } else {
        to_rgb.wavelengths_nm.assign(settings.rgb_wavelengths_nm.begin(), settings.rgb_wavelengths_nm.end());
        for (int c = 0; c < 3; ++c) {
            to_rgb.matrix[c].assign(3, 0.0);
            to_rgb.matrix[c][c] = 1.0;
        }
    }
    EvalSettings eval = settings.view;
    eval.sun_disc = settings.view.sun_disc && !settings.medium_box;
    std::vector<double> wavelengths = to_rgb.wavelengths_nm;
    // Wavelengths in any order (e.g. 680, 550, 440 nm for R, G, B): channel c is wavelength c.
    Atmosphere compiled = compile_atmosphere(scene, wavelengths, eval);
    if (settings.color == ColorModel::renderer_rgb) {
        const std::array<double, 3> e = sun_irradiance_rgb(scene);
        for (int c = 0; c < 3; ++c) compiled.sun_irradiance[c] = e[c];
    }
    const std::size_t nw = compiled.wavelength_count();
    const double R = compiled.planet_radius_m;

    const ObserverFrame frame = observer_frame(R, cam.pose.position_m);
    if (!(frame.altitude_m >= 0.0))
        throw RenderError("camera.position_km = (" + message_number(cam.pose.position_m.x / 1000.0) + ", " +
                          message_number(cam.pose.position_m.y / 1000.0) + ", " +
                          message_number(cam.pose.position_m.z / 1000.0) + "): " +
                          message_number(-frame.altitude_m / 1000.0) +
                          " km below the planet surface; it must be at or above it");
    const glm::dvec3 sun = sun_direction(scene.sun.elevation_deg, scene.sun.azimuth_deg);
    const glm::dvec3 sun_obs = frame.to_observer(sun);
    const glm::dvec3 up = glm::normalize(cam.pose.position_m - glm::dvec3(0, 0, -R));

    // The evaluator (with the tables when multiple scattering is on) answers every ray of
    // the whole shell; a medium cut to a box is integrated by box_radiance below.
    const Evaluator evaluator =
        make_evaluator(std::move(compiled), settings.multiple, settings.threads, RenderHooks{hooks.cancel, {}});
    const Atmosphere& atm = evaluator.atmosphere();
    std::optional<BoxContext> box;
    if (settings.medium_box) box.emplace(atm, *settings.medium_box, sun);

    const int W = cam.width, H = cam.height;
    // Does the ray through a raster point end on the planet? (Splits box-filtered pixels at the horizon.)
    auto sees_ground = [&](const glm::dvec3& d) { return hits_ground(view_ray(R, frame.altitude_m, up, d)); };
    FloatImage image(W, H, 3);
    std::atomic<bool> non_finite{false};
    auto cancelled = [&] { return hooks.cancel && hooks.cancel->requested(); };
    const int threads = settings.threads > 0 ? settings.threads : hardware_threads();
    {
        parallel_for(0, std::size_t(H), 1, threads, [&](std::size_t row_begin, std::size_t row_end, int) {
            std::vector<PixelNode> nodes;
            std::vector<std::size_t> first(W + 1);
            std::vector<Vec3<double>> dirs;
            std::vector<double> T, Lr, Lm, L;
            for (int y = int(row_begin); y < int(row_end); ++y) {
                if (cancelled()) return;
                // The row's integration nodes: one per pixel centre, or the box filter's.
                nodes.clear();
                for (int x = 0; x < W; ++x) {
                    first[x] = nodes.size();
                    if (settings.pixel_filter == PixelFilter::centre)
                        nodes.push_back({camera_pixel_direction(cam, x, y), 1.0});
                    else
                        box_filter_nodes(cam, x, y, sees_ground, nodes);
                }
                first[W] = nodes.size();
                const std::size_t n = nodes.size();
                dirs.resize(n);
                T.resize(n * nw), Lr.resize(n * nw), Lm.resize(n * nw), L.resize(n * nw);
                for (std::size_t k = 0; k < n; ++k) dirs[k] = Vec3<double>(box ? nodes[k].direction : frame.to_observer(nodes[k].direction));
                if (box) {
                    for (std::size_t k = 0; k < n; ++k) {
                        const glm::dvec3 d(dirs[k]);
                        box_radiance(*box, view_ray(R, frame.altitude_m, up, d), cam.pose.position_m, d,
                                     std::span<double>(L.data() + k * nw, nw));
                    }
                } else {
                    evaluator.radiance(frame.altitude_m, Vec3<double>(sun_obs), dirs, {T, Lr, Lm, L});
                }
                float* row = image.row(y);
                for (int x = 0; x < W; ++x) {
                    Vec3d rgb{0.0, 0.0, 0.0};
                    for (std::size_t k = first[x]; k < first[x + 1]; ++k) {
                        const Vec3d v = to_rgb.apply(std::span<const double>(L.data() + k * nw, nw));
                        // Clamp each ray's colour (as Cycles' xyz_to_rgb_clamped does per sample), then filter.
                        for (int c = 0; c < 3; ++c) rgb[c] += nodes[k].weight * std::max(v[c], 0.0);
                        for (int c = 0; c < 3; ++c)
                            if (!std::isfinite(v[c])) non_finite.store(true, std::memory_order_relaxed);
                    }
                    for (int c = 0; c < 3; ++c) row[x * 3 + c] = static_cast<float>(rgb[c]);
                }
                if (hooks.work_done) hooks.work_done(1, std::size_t(H));
            }
        });
    }
    if (cancelled()) throw Cancelled("render: cancelled");
    if (non_finite.load()) throw RenderError("render: a pixel evaluated to a non-finite value (a bug; please report it)");
    return image;
}

ImageMetadata render_metadata(const Scene& scene, const RenderSettings& settings) {
    const CameraModel cam = settings.camera ? *settings.camera : camera_from_scene(scene, settings.projection);
    nlohmann::json j;
    j["camera"] = nlohmann::json::parse(camera_to_json(cam, 1.0));
    j["view_samples"] = settings.view.view_samples;
    j["chapman"] = std::string(chapman_method_name(settings.view.chapman));
    j["sun_disc"] = settings.view.sun_disc;
    j["ground"] = settings.view.ground;
    j["renderer_matched"] = settings.renderer_matched;
    if (settings.renderer_matched)
        j["matched_renderer"] = settings.matched_renderer == MatchedRenderer::povray ? "povray" : "blender";
    j["color_model"] = settings.color == ColorModel::spectral ? "spectral" : "renderer_rgb";
    j["pixel_filter"] = settings.pixel_filter == PixelFilter::box ? "box" : "centre";
    if (settings.color == ColorModel::renderer_rgb) {
        j["rgb_wavelengths_nm"] = settings.rgb_wavelengths_nm;
        j["sun_irradiance_rgb"] = sun_irradiance_rgb(scene);
    }
    if (settings.medium_box) {
        const auto& b = *settings.medium_box;
        j["medium_box_m"] = {b.min_m.x, b.min_m.y, b.min_m.z, b.max_m.x, b.max_m.y, b.max_m.z};
    }
    j["multiple_scattering"] = settings.multiple.enabled;
    j["sun_direction"] = [&] {
        const glm::dvec3 s = sun_direction(scene.sun.elevation_deg, scene.sun.azimuth_deg);
        return std::array<double, 3>{s.x, s.y, s.z};
    }();
    j["units"] = settings.color == ColorModel::spectral
                     ? "linear Rec.709 of spectral radiance W m^-2 sr^-1 nm^-1: XYZ = sum L CMF dlambda (no 683 lm/W)"
                     : "radiance per RGB channel for the sun lamp's RGB irradiance (renderer RGB model)";
    return {{"airmass:scene", scene_to_json(scene)}, {"airmass:render", j.dump()},
            {"airmass:version", version_string()}};
}

}  // namespace airmass
