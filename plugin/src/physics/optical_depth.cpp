// Optical depth along straight rays: Chapman differences (Golubev Eq. 37) for
// exponential profiles, closed forms for piecewise-linear ones, and a brute-force
// quadrature reference. optical_depth.hpp states the equations and the conventions.
#include "airmass/optical_depth.hpp"

#include <algorithm>
#include <boost/math/quadrature/gauss.hpp>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>

namespace airmass {

namespace {

template <class T>
constexpr T kInf = std::numeric_limits<T>::infinity();

// Mass of the semi-infinite ray from the point at parameter t that moves *away* from
// the periapsis (cos chi = |s|/r ≥ 0): the only Chapman values the segment formulas
// subtract. By the line's mirror symmetry about the periapsis, the point at s < 0
// reversed is the point at −s going forward.
template <class T>
T upward_mass(ChapmanMethod method, const PlanetRay<T>& ray, T H, T h_ref, T t) {
    const T s = ray.periapsis_offset_m() + t;
    const T r = ray.radius_at(t);
    const ZenithAngle<T> chi{std::min(std::abs(s) / r, T(1)), std::min(ray.periapsis_radius_m() / r, T(1))};
    return exponential_ray_mass(method, ray.planet_radius_m, H, h_ref, ray.altitude_at(t), chi);
}

// 16-point Gauss–Legendre of the density over [t0, t1] (a short segment: the density
// changes by < 30 % along it, so the rule is exact to rounding).
template <class T>
T exponential_mass_quadrature(const PlanetRay<T>& ray, T H, T h_ref, T t0, T t1) {
    const auto rho = [&](T t) { return std::exp(-(ray.altitude_at(t) - h_ref) / H); };
    return boost::math::quadrature::gauss<T, 16>::integrate(rho, t0, t1);
}

// ∫_{s0}^{s1} sqrt(p² + s²) ds for 0 ≤ s0 ≤ s1 with the radii r0 = sqrt(p² + s0²) and
// r1 = sqrt(p² + s1²) known: ½ [s r + p² asinh(s/p)] from s0 to s1, with both differences
// rewritten so nothing cancels: s1 r1 − s0 r0 = Δ (r1 + r0)/2 + Σ (r1 − r0)/2, r1 − r0 = ΔΣ/(r1 + r0),
// asinh(s1/p) − asinh(s0/p) = asinh(z), z = ΔΣ/(s1 r0 + s0 r1). For z < 0.03 (pieces short against
// the radius) asinh by its Taylor series to z⁹ (relative error < 1e-17); else as
// ln((s1 + r1)/(s0 + r0)) = log1p((Δ + r1 − r0)/(s0 + r0)), every term ≥ 0 for s ≥ 0: one log1p,
// cheaper than std::asinh (which takes a square root and a division more).
inline double integral_of_radius_known(double p, double s0, double s1, double r0, double r1) {
    if (!(s1 > s0)) return 0.0;
    // The sums s1 + s0 and r1 + r0 are halved before adding where they could overflow (from 2^1000
    // m), else taken whole (half the smallest subnormal is 0), and every product and quotient
    // below is formed at the size of the integral: a number whenever the integral is, from
    // subnormal lengths to the largest double. (r ≥ s, so ks = ½ implies kr = ½.)
    const double ks = s1 > 0x1p1000 ? 0.5 : 1.0, kr = r1 > 0x1p1000 ? 0.5 : 1.0;
    const double d = s1 - s0, sum = ks * s0 + ks * s1, rsum = kr * r0 + kr * r1;  // ks (s1 + s0), kr (r1 + r0)
    const double dr = d * (sum / rsum) * (kr / ks);  // r1 − r0; the quotient is ≤ 1
    const double half_term1 = (0.25 / kr) * (d * rsum) + (0.25 / ks) * (sum * dr);  // ½ (s1 r1 − s0 r0)
    const double den = s1 * r0 + s0 * r1;
    // ½ p² asinh z = (p/2) · (p asinh z), each factor of its own size: for s ≪ p, z ≈ Δ/p underflows
    // where p z ≈ Δ does not (and p² overflows where p z does not). Skipped when p² is below the
    // smallest double: then p² asinh(s/p) ≤ p² ln(2 s/p) is too.
    double half_term2 = 0.0;
    if (p * p > 0.0 && den > 0.0) {
        const double ratio = sum / den / ks;  // (s1 + s0)/den ≤ 2/p
        const double z = d * ratio;
        double p_asinh_z;
        if (z < 0.03) {
            const double z2 = z * z;
            p_asinh_z = d * (p * ratio) *
                        (1.0 + z2 * (-1.0 / 6.0 + z2 * (3.0 / 40.0 + z2 * (-15.0 / 336.0 + z2 * (105.0 / 3456.0)))));
        } else {
            const double a = d + dr, b = s0 + r0, q = a / b;
            p_asinh_z = p * (q <= std::numeric_limits<double>::max() ? std::log1p(q) : std::log(a) - std::log(b));
        }
        half_term2 = (0.5 * p) * p_asinh_z;
    }
    return half_term1 + half_term2;
}

// ∫ over s' ∈ [s_lo, s_hi] (0 ≤ s_lo ≤ s_hi ≤ +inf) of a piecewise-linear density of
// altitude, on the line with periapsis radius p and periapsis altitude h_p (altitude
// increases with s' there). The knot spheres cut [s_lo, s_hi] into pieces on which the
// density is a linear function of r = sqrt(p² + s'²), integrated in closed form.
double piecewise_mass_upward(const CompiledProfile& prof, double R, double p, double h_p, double s_lo,
                             double s_hi) {
    if (!(s_hi > s_lo)) return 0.0;
    const auto& A = prof.altitude_m;
    const auto& D = prof.density;
    const std::size_t n = A.size();
    // altitude at s' ≥ 0, without subtracting radii: h = (h_p (2R + h_p) + s'²)/(r + R)
    const auto altitude = [&](double s) { return (h_p * (2.0 * R + h_p) + s * s) / (std::sqrt(p * p + s * s) + R); };
    // s' ≥ 0 where the line reaches altitude a ≥ h_p
    const auto crossing = [&](double a) { return std::sqrt(std::max((a - h_p) * (2.0 * R + a + h_p), 0.0)); };
    const double h_lo = altitude(s_lo), h_hi = std::isinf(s_hi) ? s_hi : altitude(s_hi);
    std::size_t k = std::size_t(std::upper_bound(A.begin(), A.end(), h_lo) - A.begin());  // first knot above h_lo
    // The radius at s, carried along: at a knot's crossing it is R + A[k] (no square root).
    const auto radius = [&](double s) { return std::sqrt(p * p + s * s); };
    double mass = 0.0, s = s_lo, r = radius(s_lo);
    while (s < s_hi && k < n) {
        double s_next = s_hi, r_next = 0.0;
        bool crossed = false;
        if (!(A[k] >= h_hi)) {  // h_hi NaN (s_hi² overflowed): cross the knots, as for s_hi = inf
            const double c = crossing(A[k]);
            s_next = std::clamp(c, s, s_hi);
            crossed = s_next == c;
        }
        if (k >= 1 && s_next > s && A[k] > A[k - 1]) {
            // rho = D[k−1] + slope (h − A[k−1]),  ∫ h ds' = ∫ r ds' − R L
            const double L = s_next - s;
            const double slope = (D[k] - D[k - 1]) / (A[k] - A[k - 1]);
            double piece = D[k - 1] * L;
            if (slope != 0.0) {
                r_next = crossed ? R + A[k] : radius(s_next);
                piece += slope * (integral_of_radius_known(p, s, s_next, r, r_next) - (R + A[k - 1]) * L);
            }
            // The density on the piece lies between its knots' values, and so does its mean. The
            // bound also catches the rounding of ∫r ds − (R + A)L times the slope of knots closer
            // than rounding (a denormal tent peak_km: ∞·0 = NaN; issue 17, extremes).
            const double lo = std::min(D[k - 1], D[k]) * L, hi = std::max(D[k - 1], D[k]) * L;
            mass += piece >= lo ? std::min(piece, hi) : lo;
        }
        if (s_next > s) r = r_next > 0.0 ? r_next : (crossed ? R + A[k] : radius(s_next));
        s = s_next;
        ++k;
    }
    return mass;
}

// A segment (t1 may be +inf) as upward pieces on either side of the periapsis.
double piecewise_segment_mass(const CompiledProfile& prof, const PlanetRay<double>& ray, double a, double b) {
    const double R = ray.planet_radius_m, p = ray.periapsis_radius_m(), h_p = ray.periapsis_altitude_m();
    const double s0 = ray.periapsis_offset_m();
    const double sa = s0 + a, sb = s0 + b;
    if (sa >= 0.0) return piecewise_mass_upward(prof, R, p, h_p, sa, sb);
    if (sb <= 0.0) return piecewise_mass_upward(prof, R, p, h_p, -sb, -sa);
    return piecewise_mass_upward(prof, R, p, h_p, 0.0, -sa) + piecewise_mass_upward(prof, R, p, h_p, 0.0, sb);
}

}  // namespace

template <class T>
T exponential_ray_mass(ChapmanMethod method, T planet_radius_m, T scale_height_m, T reference_altitude_m,
                       T altitude_m, ZenithAngle<T> chi) {
    // Schüler's Ch_h (§2.5.1) = Golubev's C_r (Eq. 36): H · Ch(X + h, chi) · exp(−h)
    const T X = (planet_radius_m + reference_altitude_m) / scale_height_m;
    const T h = (altitude_m - reference_altitude_m) / scale_height_m;
    return scale_height_m * chapman_rescaled(method, X, h, chi);
}

template <class T>
T exponential_segment_mass(ChapmanMethod method, const PlanetRay<T>& ray, T H, T h_ref, T t0, T t1) {
    if (!(t1 > t0)) return T(0);
    const T s0 = ray.periapsis_offset_m();
    const T sa = s0 + t0, sb = s0 + t1;
    const auto up = [&](T t) { return std::isinf(t) ? T(0) : upward_mass(method, ray, H, h_ref, t); };
    T first, mass;
    if (sa >= T(0)) {  // all of it above the periapsis: moving up
        first = up(t0);
        mass = first - up(t1);
    } else if (sb <= T(0)) {  // all of it below: evaluate reversed, τ(a→b) = τ(b→a)
        first = up(t1);
        mass = first - up(t0);
    } else {  // contains the periapsis: split there
        if (!(ray.periapsis_radius_m() > T(0))) return kInf<T>;  // through the planet's centre
        const T tp = -s0;
        first = T(2) * up(tp);
        mass = first - up(t0) - up(t1);
    }
    if (mass >= T(0.25) * first) return mass;  // includes +inf
    // The difference cancels: integrate the short segment directly.
    if (sa < T(0) && sb > T(0)) {
        const T tp = -s0;
        return exponential_mass_quadrature(ray, H, h_ref, t0, tp) + exponential_mass_quadrature(ray, H, h_ref, tp, t1);
    }
    return exponential_mass_quadrature(ray, H, h_ref, t0, t1);
}

double integral_of_radius(double p, double s0, double s1) {
    // ∫ sqrt(p² + s²) ds = ½ [s r + p² asinh(s/p)] (integral_of_radius_known)
    if (!(s1 > s0)) return 0.0;
    // hypot: p² + s² neither underflows to a zero radius nor overflows for lengths a double holds
    return integral_of_radius_known(p, s0, s1, std::hypot(p, s0), std::hypot(p, s1));
}

double profile_segment_mass(const CompiledProfile& prof, ChapmanMethod method, const PlanetRay<double>& ray,
                            double top_altitude_m, double t0, double t1) {
    if (!(t1 > t0)) return 0.0;
    if (prof.kind == CompiledProfile::Kind::piecewise_linear && prof.altitude_m.back() <= top_altitude_m)
        return piecewise_segment_mass(prof, ray, t0, t1);  // the top cuts nothing off
    const auto top = intersect_sphere(ray, top_altitude_m);
    if (!top.hit) return 0.0;
    double a = std::max(t0, top.t_near), b = std::min(t1, top.t_far);
    if (!(b > a)) return 0.0;
    if (prof.kind == CompiledProfile::Kind::exponential) {
        // Where the medium above the top is negligible (CompiledProfile::truncate_at_top)
        // a ray leaving through the top is taken to infinity: one Chapman value less.
        if (!prof.truncate_at_top && t1 >= top.t_far) b = kInf<double>;
        return exponential_segment_mass(method, ray, prof.scale_height_m, prof.reference_altitude_m, a, b);
    }
    return piecewise_segment_mass(prof, ray, a, b);
}

bool constituent_masses(const Atmosphere& atm, const PlanetRay<double>& ray, double t0, double t1,
                        std::span<double> mass) {
    // The ground is opaque: blocked when [t0, t1] overlaps the part of the line inside the planet.
    const auto ground = intersect_sphere(ray, 0.0);
    if (ground.hit && ground.t_near < ground.t_far && t1 > ground.t_near && t0 < ground.t_far) {
        std::fill(mass.begin(), mass.end(), kInf<double>);
        return false;
    }
    for (std::size_t i = 0; i < atm.constituents.size(); ++i)
        mass[i] = profile_segment_mass(atm.constituents[i].profile, atm.settings.chapman, ray, atm.top_altitude_m, t0,
                                       t1);
    return true;
}

void optical_depth(const Atmosphere& atm, const PlanetRay<double>& ray, double t0, double t1,
                   std::span<double> tau) {
    double mass[kMaxConstituents];
    const std::size_t nc = atm.constituents.size();
    const bool open = constituent_masses(atm, ray, t0, t1, std::span<double>(mass, nc));
    for (std::size_t w = 0; w < atm.wavelength_count(); ++w) {
        if (!open) {
            tau[w] = kInf<double>;
            continue;
        }
        double sum = 0.0;
        for (std::size_t i = 0; i < nc; ++i) sum += atm.constituents[i].extinction_per_m[w] * mass[i];
        tau[w] = sum;
    }
}

void transmittance(const Atmosphere& atm, const PlanetRay<double>& ray, double t0, double t1,
                   std::span<double> out) {
    optical_depth(atm, ray, t0, t1, out);
    for (double& v : out) v = std::exp(-v);
}

void transmittance_between(const Atmosphere& atm, Vec3<double> from_m, Vec3<double> to_m, std::span<double> out) {
    const double length = glm::length(to_m - from_m);
    if (!(length > 0.0)) {
        std::fill(out.begin(), out.end(), 1.0);
        return;
    }
    transmittance(atm, PlanetRay<double>::from_vectors(atm.planet_radius_m, from_m, to_m - from_m), 0.0, length, out);
}

namespace {

// sun_masses_batch for at most kSunBlock points (stack scratch, no allocation).
constexpr std::size_t kSunBlock = 64;

void sun_masses_block(const Atmosphere& atm, const double* h, const ZenithAngle<double>* chi, std::size_t n,
                      double* mass, unsigned char* lit) {
    const std::size_t nc = atm.constituents.size();
    const double R = atm.planet_radius_m, top = atm.top_altitude_m, r_top = R + top;
    const ChapmanMethod method = atm.settings.chapman;
    // Per point: shadow, the ray's exit through the top sphere (s at the exit = √D of the top
    // sphere, geometry.hpp) for the top's Chapman term.
    double cos_chi[kSunBlock], sin_chi[kSunBlock], exit_cos[kSunBlock], exit_sin[kSunBlock], x[kSunBlock],
        out[kSunBlock];
    bool above[kSunBlock];
    for (std::size_t k = 0; k < n; ++k) {
        lit[k] = !in_planet_shadow(PlanetRay<double>{R, h[k], chi[k]});
        above[k] = !(h[k] < top);
        cos_chi[k] = chi[k].cos_chi;
        sin_chi[k] = chi[k].sin_chi;
        const double r = R + h[k], s0 = r * chi[k].cos_chi;
        const double D = (top - h[k]) * (2.0 * R + top + h[k]) + s0 * s0;
        exit_cos[k] = std::min(std::sqrt(std::max(D, 0.0)) / r_top, 1.0);
        exit_sin[k] = std::min(r * chi[k].sin_chi / r_top, 1.0);
    }
    double m[kSunBlock];
    for (std::size_t i = 0; i < nc; ++i) {
        const CompiledProfile& p = atm.constituents[i].profile;
        if (p.kind != CompiledProfile::Kind::exponential) {
            for (std::size_t k = 0; k < n; ++k)
                if (lit[k] && !above[k])
                    mass[k * nc + i] =
                        profile_segment_mass(p, method, PlanetRay<double>{R, h[k], chi[k]}, top, 0.0, kInf<double>);
            continue;
        }
        // H·Ch(X + h, χ)·e^(−h) at the point (Schüler's Ch_h = Golubev's C_r, exponential_ray_mass)
        // less, where the top matters, the same at the ray's exit.
        const double H = p.scale_height_m, X = (R + p.reference_altitude_m) / H;
        for (std::size_t k = 0; k < n; ++k) x[k] = (h[k] - p.reference_altitude_m) / H;
        chapman_rescaled_batch<double>(method, X, {x, n}, {cos_chi, n}, {sin_chi, n}, {out, n});
        for (std::size_t k = 0; k < n; ++k) m[k] = H * out[k];
        if (!p.truncate_at_top) {
            for (std::size_t k = 0; k < n; ++k)
                if (lit[k] && !above[k]) mass[k * nc + i] = std::max(m[k], 0.0);
            continue;
        }
        std::fill(x, x + n, (top - p.reference_altitude_m) / H);
        chapman_rescaled_batch<double>(method, X, {x, n}, {exit_cos, n}, {exit_sin, n}, {out, n});
        for (std::size_t k = 0; k < n; ++k) {
            if (!lit[k] || above[k]) continue;
            const double to_top = m[k] - H * out[k];
            // Close below the top the two terms are nearly equal and their difference is rounding
            // (and the Chapman method's error) magnified: there the segment to the top, short
            // against the scale height, by quadrature (exponential_segment_mass's same rule).
            mass[k * nc + i] =
                to_top >= 0.25 * m[k]
                    ? to_top
                    : profile_segment_mass(p, method, PlanetRay<double>{R, h[k], chi[k]}, top, 0.0, kInf<double>);
        }
    }
    // From above the top (a camera or lamp in space): the closed forms clip at the top.
    for (std::size_t k = 0; k < n; ++k)
        if (lit[k] && above[k])
            for (std::size_t i = 0; i < nc; ++i)
                mass[k * nc + i] = profile_segment_mass(atm.constituents[i].profile, method,
                                                        PlanetRay<double>{R, h[k], chi[k]}, top, 0.0, kInf<double>);
}

}  // namespace

void sun_masses_batch(const Atmosphere& atm, std::span<const double> altitude_m,
                      std::span<const ZenithAngle<double>> sun_zenith, std::span<double> mass,
                      std::span<unsigned char> lit) {
    const std::size_t n = altitude_m.size(), nc = atm.constituents.size();
    if (sun_zenith.size() != n || lit.size() != n || mass.size() != n * nc)
        throw std::invalid_argument("sun_masses_batch: spans of " + std::to_string(n) + " points (masses: " +
                                    std::to_string(n * nc) + ")");
    for (std::size_t b = 0; b < n; b += kSunBlock) {
        const std::size_t m = std::min(kSunBlock, n - b);
        sun_masses_block(atm, altitude_m.data() + b, sun_zenith.data() + b, m, mass.data() + b * nc, lit.data() + b);
    }
}

bool sun_masses(const Atmosphere& atm, double h, ZenithAngle<double> chi, std::span<double> mass) {
    unsigned char lit = 0;
    sun_masses_block(atm, &h, &chi, 1, mass.data(), &lit);
    return lit != 0;
}

bool sun_transmittance(const Atmosphere& atm, double h, ZenithAngle<double> chi, std::span<double> out) {
    const std::size_t nc = atm.constituents.size();
    double mass[kMaxConstituents];
    if (!sun_masses(atm, h, chi, std::span<double>(mass, nc))) {
        std::fill(out.begin(), out.end(), 0.0);
        return false;
    }
    for (std::size_t w = 0; w < atm.wavelength_count(); ++w) {
        double tau = 0.0;
        for (std::size_t i = 0; i < nc; ++i) tau += atm.extinction_matrix[w * nc + i] * mass[i];
        out[w] = std::exp(-tau);
    }
    return true;
}

namespace {

// The profile's vertical column from the ground to the top, ∫ ρ dh (metres at density 1): the
// scale of every mass of it, for the reference's absolute tolerance below. 0 when it does not
// fit a double (an exponential referenced far above its scale heights): then no floor.
double vertical_column_m(const DensityProfile& p, double top_altitude_m) {
    double column = 0.0;
    switch (p.kind) {
        case DensityProfile::Kind::exponential:
            column = p.scale_height_m * std::exp(p.reference_altitude_m / p.scale_height_m) *
                     -std::expm1(-top_altitude_m / p.scale_height_m);
            break;
        case DensityProfile::Kind::tent: column = 0.5 * (p.top_m - p.bottom_m); break;
        case DensityProfile::Kind::constant:
            column = p.value * ((p.top_m > p.bottom_m ? std::min(p.top_m, top_altitude_m) : top_altitude_m) - p.bottom_m);
            break;
        case DensityProfile::Kind::piecewise_linear:
            for (std::size_t k = 0; k + 1 < p.knots.size(); ++k)
                column += 0.5 * (p.knots[k].second + p.knots[k + 1].second) * (p.knots[k + 1].first - p.knots[k].first);
            break;
    }
    return std::isfinite(column) && column > 0.0 ? column : 0.0;
}

// Gauss–Kronrod 61 on [a, b], bisected while its error estimate exceeds both rel_tol of the
// piece's own estimate and an absolute tolerance halved with the piece: at the top the larger of
// rel_tol of the whole estimate (Boost's own recursion has only these two) and the caller's
// abs_tol. Without that floor an integrand whose rounding is near rel_tol of its value never
// passes: ρ of a tent a few millimetres below its top, (top − h) of an altitude rounded to a
// double, is noisy at 1e-9 of itself, and a sun ray from there took 2²⁵ pieces (58 s; `earth`
// 400 km, tangent 40 km, sun 85°, in single_scattering_reference).
template <class F>
double adaptive_gk61(const F& f, double a, double b, double rel_tol, double abs_tol, int depth, bool top = true) {
    double error = 0.0;
    const double estimate = boost::math::quadrature::gauss_kronrod<double, 61>::integrate(f, a, b, 0, 0.0, &error);
    if (top) abs_tol = std::max(abs_tol, rel_tol * std::abs(estimate));
    if (depth == 0 || error <= std::max(rel_tol * std::abs(estimate), abs_tol)) return estimate;
    const double mid = 0.5 * (a + b);
    return adaptive_gk61(f, a, mid, rel_tol, 0.5 * abs_tol, depth - 1, false) +
           adaptive_gk61(f, mid, b, rel_tol, 0.5 * abs_tol, depth - 1, false);
}

}  // namespace

double profile_segment_mass_reference(const DensityProfile& profile, const PlanetRay<double>& ray,
                                      double top_altitude_m, double t0, double t1, double rel_tol) {
    // Independent of the geometry helpers: r(t)² = r0² + 2 r0 mu t + t² in long double.
    using LD = long double;
    const LD R = ray.planet_radius_m, r0 = LD(ray.planet_radius_m) + LD(ray.altitude_m);
    const LD mu = ray.zenith.cos_chi;
    const auto altitude = [&](LD t) { return std::sqrt(r0 * r0 + 2 * r0 * mu * t + t * t) - R; };
    // where the line reaches radius rr (the larger root), or nothing
    const auto roots = [&](LD rr, LD& lo, LD& hi) {
        const LD b = r0 * mu, c = (r0 - rr) * (r0 + rr), D = b * b - c;
        if (D < 0) return false;
        lo = -b - std::sqrt(D);
        hi = -b + std::sqrt(D);
        return true;
    };
    LD lo, hi;
    if (!roots(R + top_altitude_m, lo, hi)) return 0.0;
    const double a = std::max<double>(t0, double(lo)), b = std::min<double>(t1, double(hi));
    if (!(b > a)) return 0.0;
    std::vector<double> cuts{a, b};
    const auto add = [&](LD t) {
        if (t > a && t < b) cuts.push_back(double(t));
    };
    add(-r0 * mu);  // periapsis
    std::vector<double> knot_altitudes;
    switch (profile.kind) {
        case DensityProfile::Kind::tent: knot_altitudes = {profile.bottom_m, profile.peak_m, profile.top_m}; break;
        case DensityProfile::Kind::constant: knot_altitudes = {profile.bottom_m, profile.top_m}; break;
        case DensityProfile::Kind::piecewise_linear:
            for (const auto& k : profile.knots) knot_altitudes.push_back(k.first);
            break;
        case DensityProfile::Kind::exponential: break;
    }
    for (double ka : knot_altitudes)
        if (roots(R + ka, lo, hi)) {
            add(lo);
            add(hi);
        }
    std::sort(cuts.begin(), cuts.end());
    const auto rho = [&](double t) {
        const LD h = altitude(t);
        return h > LD(top_altitude_m) ? 0.0 : profile.at(double(h));
    };
    // Absolute tolerance: rel_tol × 1e-3 of the vertical column, a mass that changes no optical
    // depth the reference is asked for (its τ by 1e-3 rel_tol of the vertical τ).
    const double abs_tol = 1e-3 * rel_tol * vertical_column_m(profile, top_altitude_m);
    double total = 0.0;
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k)
        if (cuts[k + 1] > cuts[k]) total += adaptive_gk61(rho, cuts[k], cuts[k + 1], rel_tol, abs_tol, 25);
    return total;
}

#define AIRMASS_INSTANTIATE(T)                                                                                 \
    template T exponential_ray_mass<T>(ChapmanMethod, T, T, T, T, ZenithAngle<T>);                             \
    template T exponential_segment_mass<T>(ChapmanMethod, const PlanetRay<T>&, T, T, T, T);
AIRMASS_INSTANTIATE(float)
AIRMASS_INSTANTIATE(double)
#undef AIRMASS_INSTANTIATE

}  // namespace airmass
