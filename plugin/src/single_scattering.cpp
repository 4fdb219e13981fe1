// Single scattering along view rays and aerial perspective (single_scattering.hpp has
// the equation and the sampling scheme), plus the brute-force nested-quadrature
// reference.
#include "airmass/single_scattering.hpp"

#include <algorithm>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <glm/geometric.hpp>

#include "airmass/optical_depth.hpp"
#include "airmass/phase.hpp"

namespace airmass {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// ---- interval lists (fixed capacity, no allocation) ---------------------------------

struct Interval {
    double a, b;
};

template <int N>
struct Intervals {
    Interval v[N];
    int n = 0;
    void add(double a, double b) {
        if (b > a && n < N) v[n++] = {a, b};
    }
};

// {t ∈ [a, b]} minus the open interval (c0, c1).
Intervals<2> subtract(double a, double b, double c0, double c1) {
    Intervals<2> out;
    if (!(c1 > c0) || c1 <= a || c0 >= b) {
        out.add(a, b);
        return out;
    }
    out.add(a, std::min(c0, b));
    out.add(std::max(c1, a), b);
    return out;
}

template <int N, int M>
Intervals<N * M> intersect(const Intervals<N>& x, const Intervals<M>& y) {
    Intervals<N * M> out;
    for (int i = 0; i < x.n; ++i)
        for (int j = 0; j < y.n; ++j) out.add(std::max(x.v[i].a, y.v[j].a), std::min(x.v[i].b, y.v[j].b));
    return out;
}

// ---- the geometry of one view segment ----------------------------------------------

// Earth's shadow: the sun ray dips more than 1 µm below the ground. A sun ray within
// rounding of tangent to the ground counts as lit (the grazing limit), here and in the
// shadow interval below, so the two agree and exactly tangent geometries are decided
// the same way every time (seed: observer on the ground, sun on the horizon, looking
// away from it, where the whole view ray lies on the shadow's edge).
constexpr double kShadowTolerance_m = 1e-6;

bool in_shadow(const PlanetRay<double>& sun_ray) {
    return sun_ray.zenith.cos_chi < 0.0 && sun_ray.periapsis_altitude_m() < -kShadowTolerance_m;
}

// A view ray with the sun: o_s = dot(origin, sun) (metres), v_s = dot(view, sun).
struct SunGeometry {
    double o_s;
    double v_s;
};

// The part of the line in Earth's shadow: behind the planet (dot(P, sun) < 0) and
// within R of the shadow axis, |P × sun|² = |P|² − dot(P, sun)² < R². With
// P = O + t v: A t² + 2 B t + C < 0, A = 1 − v_s², B = r0 mu − o_s v_s,
// C = r0² − o_s² − R² = h0 (2R + h0) − o_s². Returns (c0, c1), empty when c1 ≤ c0.
Interval shadow_interval(const PlanetRay<double>& ray, SunGeometry sun) {
    const double R = ray.planet_radius_m, h0 = ray.altitude_m;
    const double A = (1.0 - sun.v_s) * (1.0 + sun.v_s);
    const double B = ray.periapsis_offset_m() - sun.o_s * sun.v_s;
    const double C = h0 * (2.0 * R + h0) - sun.o_s * sun.o_s + 2.0 * R * kShadowTolerance_m;  // radius R − tol
    double c0, c1;
    if (A < 1e-15) {  // looking along the shadow axis: the distance to it is constant
        if (!(C < 0.0)) return {0.0, 0.0};
        c0 = -kInf;
        c1 = kInf;
    } else {
        const double disc = B * B - A * C;
        if (!(disc > 0.0)) return {0.0, 0.0};
        const double q = -(B + std::copysign(std::sqrt(disc), B));
        const double x0 = q / A, x1 = q != 0.0 ? C / q : -x0;
        c0 = std::min(x0, x1);
        c1 = std::max(x0, x1);
    }
    // half-space behind the planet: o_s + t v_s < 0
    if (sun.v_s > 0.0) c1 = std::min(c1, -sun.o_s / sun.v_s);
    else if (sun.v_s < 0.0) c0 = std::max(c0, -sun.o_s / sun.v_s);
    else if (!(sun.o_s < 0.0)) return {0.0, 0.0};
    return {c0, c1};
}

// {t ∈ [a, b] : lo ≤ h(t) ≤ hi}: the ray inside a shell of altitudes.
Intervals<2> altitude_band(const PlanetRay<double>& ray, double lo, double hi, double a, double b) {
    const auto outer = intersect_sphere(ray, hi);
    if (!outer.hit) return {};
    const double oa = std::max(a, outer.t_near), ob = std::min(b, outer.t_far);
    if (!(ob > oa)) return {};
    const auto inner = intersect_sphere(ray, lo);
    if (!inner.hit) {
        Intervals<2> one;
        one.add(oa, ob);
        return one;
    }
    return subtract(oa, ob, inner.t_near, inner.t_far);
}

// ---- the sampling variable (single_scattering.hpp) ------------------------------------

// (e^x − 1)/x and log1p(y)/y, both → 1 at 0 without cancellation.
inline double exp_minus_one_over(double x) { return std::abs(x) < 1e-8 ? 1.0 + 0.5 * x : std::expm1(x) / x; }
inline double log1p_over(double y) { return std::abs(y) < 1e-8 ? 1.0 - 0.5 * y : std::log1p(y) / y; }

// One side of the sampling density, at distance Δ ≥ 0 from the centre t_d:
//     q(Δ) = w e^{κ (1 − w)},   w = e^{−Δ/ℓ}      (q = 1 at the centre, on both sides).
// w is the constituent's density relative to t_d (exponential model with decay length ℓ);
// e^{κ(1 − w)} models the optical depths, which also scale with that density: the sun's
// (τ_sun ∝ w) and the view ray's (τ_view = τ_view(t_d) ∓ τ_ℓ (1 − w)). So q is a
// Chapman layer: κ = τ_sun(t_d) ∓ τ_ℓ > 0 (twilight: the light comes from where the sun
// ray thins out) puts the samples up where w ≈ 1/κ, κ < 0 (optically thick view) near
// t_d, κ = 0 is the density alone. Its tail is always ∝ w, never thinner than the
// density, so the integrand over q stays bounded.
// Integral from the centre: G(Δ) = ℓ (e^{κ(1 − w)} − 1)/κ.
struct SamplingSide {
    double ell, kappa;

    double G(double delta) const {
        const double one_minus_w = -std::expm1(-delta / ell);
        return ell * one_minus_w * exp_minus_one_over(kappa * one_minus_w);
    }
    // Δ(G) and dΔ/dG = 1/q: 1 − w = log1p(κ G/ℓ)/κ.
    double inverse(double g, double& jacobian) const {
        const double x = g / ell;
        const double one_minus_w = std::min(x * log1p_over(kappa * x), 1.0 - 1e-16);
        const double w = 1.0 - one_minus_w;
        jacobian = std::exp(-kappa * one_minus_w) / w;
        return -ell * std::log1p(-one_minus_w);
    }
};

// The two-sided map around t_d: G(t) < 0 toward the observer, > 0 beyond.
struct SamplingMap {
    double t_d;
    SamplingSide left, right;

    double G(double t) const { return t < t_d ? -left.G(t_d - t) : right.G(t - t_d); }
    double inverse(double g, double& jacobian) const {
        return g < 0.0 ? t_d - left.inverse(-g, jacobian) : t_d + right.inverse(g, jacobian);
    }
};

// Everything about one view segment that does not depend on the sample.
struct SegmentContext {
    const Atmosphere& atm;
    PlanetRay<double> ray;
    SunGeometry sun;
    double t_begin, t_end;
    Intervals<2> lit;
    // Exponential constituents: upward masses at t_begin and at the periapsis (when it
    // lies inside the segment) — the fixed terms of every view mass (optical_depth.hpp).
    double up_begin[kMaxConstituents];
    double up_periapsis[kMaxConstituents];

    SegmentContext(const Atmosphere& a, const PlanetRay<double>& r, SunGeometry s, double tb, double te)
        : atm(a), ray(r), sun(s), t_begin(tb), t_end(te) {
        const Interval sh = shadow_interval(ray, sun);
        const auto l = subtract(t_begin, t_end, sh.a, sh.b);
        lit = l;
        const double s0 = ray.periapsis_offset_m();
        const double tp = -s0;
        for (std::size_t i = 0; i < atm.constituents.size(); ++i) {
            const auto& p = atm.constituents[i].profile;
            if (p.kind != CompiledProfile::Kind::exponential) continue;
            up_begin[i] = upward(i, t_begin);
            up_periapsis[i] = (s0 + t_begin < 0.0 && s0 + t_end > 0.0) ? upward(i, tp) : 0.0;
        }
    }

    double upward(std::size_t i, double t) const { return upward(i, point(t)); }

    // Geometry of the point at parameter t, computed once for all constituents.
    struct Point {
        double t, r, h, s;
    };
    Point point(double t) const {
        const double s0 = ray.periapsis_offset_m();
        const double r = ray.radius_at(t);
        // h(t) = h0 + t (2 s0 + t)/(r0 + r(t)) (geometry.hpp)
        return {t, r, ray.altitude_m + t * (2.0 * s0 + t) / (ray.radius_m() + r), s0 + t};
    }

    // U: mass of the ray leaving the point away from the periapsis (optical_depth.hpp).
    double upward(std::size_t i, const Point& x) const {
        const auto& p = atm.constituents[i].profile;
        const ZenithAngle<double> chi{std::min(std::abs(x.s) / x.r, 1.0), std::min(ray.periapsis_radius_m() / x.r, 1.0)};
        return exponential_ray_mass(atm.settings.chapman, ray.planet_radius_m, p.scale_height_m,
                                    p.reference_altitude_m, x.h, chi);
    }

    // Masses from t_begin to the point (Eq. 37 with upper-hemisphere terms only).
    void view_masses(const Point& x, std::span<double> mass) const {
        const double s_begin = ray.periapsis_offset_m() + t_begin;
        for (std::size_t i = 0; i < atm.constituents.size(); ++i) {
            const auto& p = atm.constituents[i].profile;
            if (p.kind != CompiledProfile::Kind::exponential) {
                mass[i] = profile_segment_mass(p, atm.settings.chapman, ray, atm.top_altitude_m, t_begin, x.t);
                continue;
            }
            if (!(x.t > t_begin)) {
                mass[i] = 0.0;
                continue;
            }
            double m;
            if (s_begin >= 0.0) m = up_begin[i] - upward(i, x);
            else if (x.s <= 0.0) m = upward(i, x) - up_begin[i];
            else m = 2.0 * up_periapsis[i] - up_begin[i] - upward(i, x);
            mass[i] = std::max(m, 0.0);
        }
    }

    // The sampling map of scattering constituent c over one lit interval, and F, the
    // integrand's estimated value at its centre (ρ_c · T_view · T_sun, mean over the
    // wavelengths) — with the map's integral Q, F·Q estimates the interval's share.
    SamplingMap interval_map(std::size_t c, Interval iv, double& F) const {
        const auto& prof = atm.constituents[c].profile;
        const double cap = 1e6 * std::max(t_end - t_begin, 1e-3);
        const double tp = -ray.periapsis_offset_m();
        // centre: the densest point (nearest the periapsis) for exponential profiles
        const bool expo = prof.kind == CompiledProfile::Kind::exponential;
        const double t_d = expo ? std::clamp(tp, iv.a, iv.b) : iv.a;
        double ell = cap;
        if (expo) {
            // ℓ: distance along the ray over which it climbs one scale height from t_d
            const double H = prof.scale_height_m;
            const double r_d = ray.radius_at(t_d), s_d = std::abs(ray.periapsis_offset_m() + t_d);
            const double k = H * (2.0 * r_d + H);
            ell = std::min(k / (std::sqrt(s_d * s_d + k) + s_d), cap);
        }
        // optical depths at the centre; on a shadow boundary the sun ray grazes the
        // ground (rounding may call it blocked): use a point just inside the interval
        const std::size_t nc = atm.constituents.size(), nw = atm.wavelength_count();
        double m_sun[kMaxConstituents], m_view[kMaxConstituents], rho[kMaxConstituents];
        Point x = point(t_d);
        bool lit = sun_masses_at(x, std::span<double>(m_sun, nc));
        if (!lit) {
            const double nudge = 1e-6 * (iv.b - iv.a);
            x = point(t_d - iv.a < iv.b - t_d ? t_d + nudge : t_d - nudge);
            lit = sun_masses_at(x, std::span<double>(m_sun, nc));
        }
        view_masses(x, std::span<double>(m_view, nc));
        for (std::size_t i = 0; i < nc; ++i) rho[i] = atm.constituents[i].profile.at(x.h);
        // κ per wavelength: τ_sun at t_d and τ_ℓ = σt(t_d) ℓ, the view optical depth of one ℓ;
        // the map takes, per side, the κ nearest 0 over the wavelengths (the broadest
        // layer: the other wavelengths' integrands are then narrower, never cut off).
        double k_left = kInf, k_right = kInf, mean_t = 0.0;
        for (std::size_t w = 0; w < nw; ++w) {
            const double* ext = &atm.extinction_matrix[w * nc];
            double tau_sun = 0.0, tau_view = 0.0, sigma = 0.0;
            for (std::size_t i = 0; i < nc; ++i) {
                tau_sun += ext[i] * m_sun[i];
                tau_view += ext[i] * m_view[i];
                sigma += ext[i] * rho[i];
            }
            if (!lit) tau_sun = 0.0;
            mean_t += lit ? std::exp(-tau_view - tau_sun) / double(nw) : 0.0;
            const double kl = tau_sun + sigma * ell, kr = tau_sun - sigma * ell;
            if (std::abs(kl) < std::abs(k_left)) k_left = kl;
            if (std::abs(kr) < std::abs(k_right)) k_right = kr;
        }
        F = rho[c] * mean_t;
        if (!expo) return {t_d, {cap, 0.0}, {cap, 0.0}};
        const auto clamp_kappa = [](double k) { return std::clamp(k, -60.0, 600.0); };
        return {t_d, {ell, clamp_kappa(k_left)}, {ell, clamp_kappa(k_right)}};
    }

    // Sun masses at the point (to the top of the atmosphere); false in Earth's shadow.
    // Exponential: H·Ch_h at the point minus, where the top matters, the same at the
    // ray's exit through the top; piecewise linear: the closed form.
    bool sun_masses_at(const Point& x, std::span<double> mass) const {
        const double mu = std::clamp((sun.o_s + x.t * sun.v_s) / x.r, -1.0, 1.0);
        const ZenithAngle<double> chi = ZenithAngle<double>::from_cos(mu);
        const PlanetRay<double> sun_ray{ray.planet_radius_m, x.h, chi};
        if (in_shadow(sun_ray)) return false;
        const double R = ray.planet_radius_m, top = atm.top_altitude_m;
        ZenithAngle<double> exit{1.0, 0.0};
        bool have_exit = false;
        for (std::size_t i = 0; i < atm.constituents.size(); ++i) {
            const auto& p = atm.constituents[i].profile;
            if (p.kind != CompiledProfile::Kind::exponential) {
                mass[i] = profile_segment_mass(p, atm.settings.chapman, sun_ray, top, 0.0, kInf);
                continue;
            }
            double m = exponential_ray_mass(atm.settings.chapman, R, p.scale_height_m, p.reference_altitude_m, x.h, chi);
            if (p.truncate_at_top) {
                if (!have_exit) {  // s at the exit = √D of the top sphere (geometry.hpp)
                    const double s0 = x.r * mu;
                    const double D = (top - x.h) * (2.0 * R + top + x.h) + s0 * s0;
                    const double r_top = R + top;
                    exit = {std::min(std::sqrt(std::max(D, 0.0)) / r_top, 1.0), std::min(x.r * chi.sin_chi / r_top, 1.0)};
                    have_exit = true;
                }
                m -= exponential_ray_mass(atm.settings.chapman, R, p.scale_height_m, p.reference_altitude_m, top, exit);
            }
            mass[i] = std::max(m, 0.0);
        }
        return true;
    }
};

// In-scatter and transmittance of [t_begin, t_end] (E_sun applied), no ground or disc.
// L_mie may be the same span as L_rayleigh.
void integrate_segment(const SegmentContext& ctx, std::span<double> T_out, std::span<double> L_rayleigh,
                       std::span<double> L_mie) {
    const Atmosphere& atm = ctx.atm;
    const std::size_t nc = atm.constituents.size(), nw = atm.wavelength_count();
    std::fill(L_rayleigh.begin(), L_rayleigh.end(), 0.0);
    std::fill(L_mie.begin(), L_mie.end(), 0.0);  // may alias L_rayleigh (aerial perspective: one sum)
    const int N = atm.settings.view_samples;
    double m_view[kMaxConstituents], m_sun[kMaxConstituents];

    for (std::size_t c = 0; c < nc; ++c) {
        const AtmosphereConstituent& con = atm.constituents[c];
        if (!con.scatters) continue;
        // sample set: lit part of the segment where this constituent has density
        Intervals<2> support;
        if (con.profile.kind == CompiledProfile::Kind::exponential) support.add(ctx.t_begin, ctx.t_end);
        else support = altitude_band(ctx.ray, con.profile.altitude_m.front(), con.profile.altitude_m.back(),
                                     ctx.t_begin, ctx.t_end);
        const auto set = intersect(support, ctx.lit);
        if (set.n == 0) continue;
        // One map per lit interval (each around its own densest point); the N midpoints
        // are shared out by the estimated share of each interval, α_j = 0.8 F_jQ_j/ΣFQ +
        // 0.2 Q_j/ΣQ (the floor keeps a poorly estimated interval sampled), through a
        // concatenated variable so that samples move continuously with the geometry.
        SamplingMap map[4];
        double g0[4], Q[4], alpha[4], FQ = 0.0, QQ = 0.0;
        for (int j = 0; j < set.n; ++j) {
            double F;
            map[j] = ctx.interval_map(c, set.v[j], F);
            g0[j] = map[j].G(set.v[j].a);
            Q[j] = std::max(map[j].G(set.v[j].b) - g0[j], 0.0);
            alpha[j] = F * Q[j];
            FQ += alpha[j];
            QQ += Q[j];
        }
        if (!(QQ > 0.0)) continue;
        for (int j = 0; j < set.n; ++j) alpha[j] = (FQ > 0.0 ? 0.8 * alpha[j] / FQ : 0.8 * Q[j] / QQ) + 0.2 * Q[j] / QQ;
        const double phase_value = phase(con.phase, ctx.sun.v_s);
        std::span<double> L = con.rayleigh_like ? L_rayleigh : L_mie;
        int j = 0;
        double cum = 0.0;  // α of the intervals before j
        for (int k = 0; k < N; ++k) {
            const double u = (k + 0.5) / N;  // midpoint in the concatenated variable
            while (j + 1 < set.n && u > cum + alpha[j]) cum += alpha[j++];
            if (!(alpha[j] > 0.0)) continue;
            double jac;
            const double g = g0[j] + std::min((u - cum) / alpha[j], 1.0) * Q[j];
            const double t = std::clamp(map[j].inverse(g, jac), set.v[j].a, set.v[j].b);
            const double dg = Q[j] / (N * alpha[j]);
            const auto x = ctx.point(t);
            const double rho = con.profile.at(x.h);
            if (!(rho > 0.0)) continue;
            if (!ctx.sun_masses_at(x, std::span<double>(m_sun, nc))) continue;
            ctx.view_masses(x, std::span<double>(m_view, nc));
            for (std::size_t i = 0; i < nc; ++i) m_view[i] += m_sun[i];
            const double weight = dg * jac * rho * phase_value;
            for (std::size_t w = 0; w < nw; ++w) {
                const double* ext = &atm.extinction_matrix[w * nc];
                double tau = 0.0;
                for (std::size_t i = 0; i < nc; ++i) tau += ext[i] * m_view[i];
                L[w] += weight * con.scattering_per_m[w] * std::exp(-tau);
            }
        }
    }
    ctx.view_masses(ctx.point(ctx.t_end), std::span<double>(m_view, nc));
    for (std::size_t w = 0; w < nw; ++w) {
        const double* ext = &atm.extinction_matrix[w * nc];
        double tau = 0.0;
        for (std::size_t i = 0; i < nc; ++i) tau += ext[i] * m_view[i];
        T_out[w] = std::exp(-tau);
        L_rayleigh[w] *= atm.sun_irradiance[w];
        if (L_mie.data() != L_rayleigh.data()) L_mie[w] *= atm.sun_irradiance[w];
    }
}

void check_out(const Atmosphere& atm, const RadianceOut& out, std::size_t n) {
    const std::size_t need = n * atm.wavelength_count();
    if (out.transmittance.size() < need || out.radiance_rayleigh.size() < need || out.radiance_mie.size() < need ||
        out.radiance.size() < need)
        throw std::invalid_argument("single_scattering: output spans need " + std::to_string(need) + " elements");
}

// One view ray; `out` spans have exactly wavelength_count() elements.
void single_scattering_one(const Atmosphere& atm, double altitude_m, Vec3<double> v, Vec3<double> sun,
                           const RadianceOut& out) {
    const std::size_t nw = atm.wavelength_count();
    const double R = atm.planet_radius_m;
    const double len = glm::length(v);
    v /= len;
    // observer on the +Z axis: zenith cos = v.z, sin = |v.xy| (exact near the horizon)
    const PlanetRay<double> ray{R, altitude_m, {std::clamp(v.z, -1.0, 1.0), std::min(std::hypot(v.x, v.y), 1.0)}};
    const SunGeometry sg{(R + altitude_m) * sun.z, glm::dot(v, sun)};
    const auto seg = atmosphere_segment(ray, atm.top_altitude_m);
    if (!seg.valid) {
        std::fill_n(out.transmittance.begin(), nw, 1.0);
        std::fill_n(out.radiance_rayleigh.begin(), nw, 0.0);
        std::fill_n(out.radiance_mie.begin(), nw, 0.0);
    } else {
        const SegmentContext ctx(atm, ray, sg, seg.t_begin, seg.t_end);
        integrate_segment(ctx, out.transmittance, out.radiance_rayleigh, out.radiance_mie);
    }
    for (std::size_t w = 0; w < nw; ++w) out.radiance[w] = out.radiance_rayleigh[w] + out.radiance_mie[w];

    if (seg.valid && seg.hits_ground) {
        if (atm.settings.ground && atm.ground_albedo > 0.0) {
            // Lambert: a/π · E cos θ_sun · T_sun(ground) · T(view), θ_sun at the hit point
            const double mu_g = std::clamp((sg.o_s + seg.t_end * sg.v_s) / ray.radius_at(seg.t_end), -1.0, 1.0);
            if (mu_g > 0.0) {
                const PlanetRay<double> sun_ray{R, 0.0, ZenithAngle<double>::from_cos(mu_g)};
                double m[kMaxConstituents];
                const std::size_t nc = atm.constituents.size();
                constituent_masses(atm, sun_ray, 0.0, kInf, std::span<double>(m, nc));
                for (std::size_t w = 0; w < nw; ++w) {
                    double tau = 0.0;
                    for (std::size_t i = 0; i < nc; ++i) tau += atm.extinction_matrix[w * nc + i] * m[i];
                    out.radiance[w] += atm.ground_albedo / std::numbers::pi * atm.sun_irradiance[w] * mu_g *
                                       std::exp(-tau) * out.transmittance[w];
                }
            }
        }
        return;
    }
    if (atm.settings.sun_disc && atm.sun_angular_radius_rad > 0.0 &&
        glm::dot(v, sun) >= std::cos(atm.sun_angular_radius_rad)) {
        const double solid_angle = 2.0 * std::numbers::pi * (1.0 - std::cos(atm.sun_angular_radius_rad));
        for (std::size_t w = 0; w < nw; ++w)
            out.radiance[w] += atm.sun_irradiance[w] / solid_angle * out.transmittance[w];
    }
}

}  // namespace

void single_scattering(const Atmosphere& atm, const ViewRay& ray, RadianceOut out) {
    check_out(atm, out, 1);
    single_scattering_one(atm, ray.altitude_m, ray.view_direction, ray.sun_direction, out);
}

void single_scattering_batch(const Atmosphere& atm, double altitude_m, Vec3<double> sun,
                             std::span<const Vec3<double>> dirs, RadianceOut out) {
    check_out(atm, out, dirs.size());
    const std::size_t nw = atm.wavelength_count();
    for (std::size_t k = 0; k < dirs.size(); ++k) {
        const RadianceOut one{out.transmittance.subspan(k * nw, nw), out.radiance_rayleigh.subspan(k * nw, nw),
                              out.radiance_mie.subspan(k * nw, nw), out.radiance.subspan(k * nw, nw)};
        single_scattering_one(atm, altitude_m, dirs[k], sun, one);
    }
}

void aerial_perspective(const Atmosphere& atm, Vec3<double> from, Vec3<double> to, Vec3<double> sun,
                        bool to_infinity, std::span<double> T_out, std::span<double> S_out) {
    const std::size_t nw = atm.wavelength_count();
    if (T_out.size() < nw || S_out.size() < nw)
        throw std::invalid_argument("aerial_perspective: output spans need " + std::to_string(nw) + " elements");
    std::fill_n(T_out.begin(), nw, 1.0);
    std::fill_n(S_out.begin(), nw, 0.0);
    const Vec3<double> d = to - from;
    const double length = glm::length(d);
    if (!(length > 0.0)) return;
    const auto ray = PlanetRay<double>::from_vectors(atm.planet_radius_m, from, d);
    const auto seg = atmosphere_segment(ray, atm.top_altitude_m);
    if (!seg.valid) return;
    double t_end = seg.t_end;
    bool blocked = false;
    if (!to_infinity) {
        // the ground stops the segment only when it is hit clearly before `to`
        if (seg.hits_ground && seg.t_end < length * (1.0 - 1e-9) - 1e-6) blocked = true;
        else t_end = std::min(length, seg.hits_ground ? std::max(seg.t_end, length) : seg.t_end);
    }
    if (!(t_end > seg.t_begin)) return;
    const SunGeometry sg{glm::dot(from, sun), glm::dot(d / length, sun)};
    const SegmentContext ctx(atm, ray, sg, seg.t_begin, t_end);
    integrate_segment(ctx, T_out.first(nw), S_out.first(nw), S_out.first(nw));
    if (blocked) std::fill_n(T_out.begin(), nw, 0.0);
}

// ---- brute-force reference ---------------------------------------------------------------

void single_scattering_reference(const Scene& scene, const Atmosphere& atm, const ViewRay& vr, RadianceOut out,
                                 double rel_tol) {
    check_out(atm, out, 1);
    using boost::math::quadrature::gauss_kronrod;
    const std::size_t nw = atm.wavelength_count(), nc = atm.constituents.size();
    const double R = atm.planet_radius_m, top = atm.top_altitude_m;
    const Vec3<double> v = glm::normalize(vr.view_direction), sun = vr.sun_direction;
    const Vec3<double> O(0.0, 0.0, R + vr.altitude_m);
    const auto ray = PlanetRay<double>::from_vectors(R, O, v);
    const auto seg = atmosphere_segment(ray, top);
    const double inner_tol = std::max(rel_tol * 1e-2, 1e-12);

    const auto mass = [&](std::size_t i, const PlanetRay<double>& r, double t0, double t1) {
        return profile_segment_mass_reference(scene.constituents[atm.constituents[i].scene_index].profile, r, top, t0,
                                              t1, inner_tol);
    };
    // sun optical depth at a point, +inf in the shadow (independent 3-D test)
    const auto sun_tau = [&](const Vec3<double>& P, std::size_t w) {
        const double along = glm::dot(P, sun);
        const double off_axis = glm::length(glm::cross(P, sun));
        if (along < 0.0 && off_axis < R - kShadowTolerance_m) return kInf;
        const auto sr = PlanetRay<double>::from_vectors(R, P, sun);
        double tau = 0.0;
        for (std::size_t i = 0; i < nc; ++i) tau += atm.constituents[i].extinction_per_m[w] * mass(i, sr, 0.0, kInf);
        return tau;
    };
    const auto view_tau = [&](double t, std::size_t w) {
        double tau = 0.0;
        for (std::size_t i = 0; i < nc; ++i)
            tau += atm.constituents[i].extinction_per_m[w] * mass(i, ray, seg.valid ? seg.t_begin : 0.0, t);
        return tau;
    };

    for (std::size_t w = 0; w < nw; ++w) {
        out.radiance_rayleigh[w] = out.radiance_mie[w] = 0.0;
        out.transmittance[w] = seg.valid ? std::exp(-view_tau(seg.t_end, w)) : 1.0;
    }
    if (seg.valid && seg.t_end > seg.t_begin) {
        // split points: periapsis, shadow boundary, every knot sphere
        std::vector<double> cuts{seg.t_begin, seg.t_end};
        const auto add = [&](double t) {
            if (t > seg.t_begin && t < seg.t_end) cuts.push_back(t);
        };
        add(-ray.periapsis_offset_m());
        const Interval sh = shadow_interval(ray, {glm::dot(O, sun), glm::dot(v, sun)});
        add(sh.a);
        add(sh.b);
        for (const auto& c : atm.constituents)
            for (double a : c.profile.altitude_m) {
                const auto x = intersect_sphere(ray, a);
                if (x.hit) {
                    add(x.t_near);
                    add(x.t_far);
                }
            }
        std::sort(cuts.begin(), cuts.end());
        for (std::size_t c = 0; c < nc; ++c) {
            const auto& con = atm.constituents[c];
            if (!con.scatters) continue;
            const DensityProfile& prof = scene.constituents[con.scene_index].profile;
            const double P = phase(con.phase, glm::dot(v, sun));
            for (std::size_t w = 0; w < nw; ++w) {
                const auto f = [&](double t) {
                    const Vec3<double> X = O + t * v;
                    const double h = glm::length(X) - R;
                    const double rho = h > top ? 0.0 : prof.at(h);
                    if (!(rho > 0.0)) return 0.0;
                    const double ts = sun_tau(X, w);
                    if (std::isinf(ts)) return 0.0;
                    return rho * std::exp(-view_tau(t, w) - ts);
                };
                double integral = 0.0;
                for (std::size_t k = 0; k + 1 < cuts.size(); ++k)
                    if (cuts[k + 1] > cuts[k])
                        integral += gauss_kronrod<double, 31>::integrate(f, cuts[k], cuts[k + 1], 15, rel_tol);
                const double L = atm.sun_irradiance[w] * con.scattering_per_m[w] * P * integral;
                (con.rayleigh_like ? out.radiance_rayleigh : out.radiance_mie)[w] += L;
            }
        }
    }
    for (std::size_t w = 0; w < nw; ++w) {
        out.radiance[w] = out.radiance_rayleigh[w] + out.radiance_mie[w];
        if (seg.valid && seg.hits_ground) {
            const Vec3<double> G = O + seg.t_end * v;
            const double mu_g = glm::dot(glm::normalize(G), sun);
            if (atm.settings.ground && mu_g > 0.0)
                out.radiance[w] += atm.ground_albedo / std::numbers::pi * atm.sun_irradiance[w] * mu_g *
                                   std::exp(-sun_tau(G * (1.0 + 1e-15), w)) * out.transmittance[w];
        } else if (atm.settings.sun_disc && atm.sun_angular_radius_rad > 0.0 &&
                   glm::dot(v, sun) >= std::cos(atm.sun_angular_radius_rad)) {
            out.radiance[w] += atm.sun_irradiance[w] /
                               (2.0 * std::numbers::pi * (1.0 - std::cos(atm.sun_angular_radius_rad))) *
                               out.transmittance[w];
        }
    }
}

}  // namespace airmass
