// Multiple scattering: orders of scattering on a 4-D grid and Hillaire's isotropic table
// (multiple_scattering.hpp states the equations; docs/multiple_scattering.md the numerics).
//
// Stages, each TBB-parallel:
//   1. Ray quadratures (order- and sun-independent): for every grid ray (altitude a, view
//      zenith b) the intervals along it, the per-interval weights
//          W_k,i(λ) = σs_i(λ) ∫_interval ρ_i T(x, y) dt = σs_i Δm_i T(x, t_k) (1 − e^{−Δτ_k})/Δτ_k
//      (exact when ρ_i/σt is constant inside the interval: the optical depth is handled
//      analytically, the quadrature only has to resolve the slowly varying source), and
//      the node coordinates of every sample for every sun node (c, d).
//   2. Order 1: J¹ evaluated exactly at the samples (phase × sun transmittance from a
//      Chapman-mass table), plus the directly lit ground.
//   3. Gather: per (altitude, sun) node, the radiance over the sphere of directions is
//      convolved with each phase function: a circular convolution in azimuth, done per
//      Fourier mode with (view × view) phase matrices integrated over the grid cells.
//   4. Transport of order k: J^k = Σ_i σs_i ρ_i G_i^k interpolated at the samples
//      ((altitude, view) corners once per sample, then (sun, azimuth) per node).
#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <glm/geometric.hpp>

#include "airmass/multiple_scattering.hpp"
#include "airmass/optical_depth.hpp"
#include "airmass/phase.hpp"

namespace airmass {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kInf = std::numeric_limits<double>::infinity();

// e^x in float, vectorisable: x log2 e rounded to an integer n by the 1.5·2^23 shift,
// Cody–Waite reduction, degree-6 Taylor on |r| ≤ ln2/2 (relative error ≤ 3e-7 on
// [−87, 88]); 2^n from integer bits with integer clamps (0 below e^−87.3). No float
// compares: under the default -ftrapping-math they would keep the loops scalar.
inline float fast_exp(float x) {
    const float shifted = x * 1.44269504088896341f + 12582912.0f;
    const float n = shifted - 12582912.0f;
    const float r = (x - n * 0.693145751953125f) - n * 1.42860682030941723e-6f;
    float p = 1.0f / 720.0f;
    p = p * r + 1.0f / 120.0f;
    p = p * r + 1.0f / 24.0f;
    p = p * r + 1.0f / 6.0f;
    p = p * r + 0.5f;
    p = p * r + 1.0f;
    p = p * r + 1.0f;
    std::int32_t ni = std::bit_cast<std::int32_t>(shifted) - 0x4B400000;
    ni = ni < -127 ? -127 : ni;
    ni = ni > 127 ? 127 : ni;
    return p * std::bit_cast<float>((ni + 127) << 23);
}

// ln x in float for x ≥ 1e-30 (smaller values, 0 and negatives give ln 1e-30 = −69.08),
// vectorisable: x = m 2^e with m ∈ [√½, √2), ln m = 2 atanh((m − 1)/(m + 1)) by its series
// (absolute error ≤ 5e-6 over the float range).
inline float fast_log(float x) {
    std::int32_t bits = std::bit_cast<std::int32_t>(x);
    bits = bits < 0x0DA24260 ? 0x0DA24260 : bits;  // 1e-30f; negative floats are negative ints
    const std::int32_t mant = bits & 0x007fffff;
    const std::int32_t big = ((0x003504F3 - mant) >> 31) & 1;  // mantissa above √2
    const float e = std::bit_cast<float>(0x4B000000 | ((bits >> 23) + big)) - (8388608.0f + 127.0f);
    const float m = std::bit_cast<float>(mant | ((127 - big) << 23));
    const float t = (m - 1.0f) / (m + 1.0f), t2 = t * t;
    const float series = 1.0f + t2 * (1.0f / 3.0f + t2 * (1.0f / 5.0f + t2 * (1.0f / 7.0f + t2 * (1.0f / 9.0f))));
    return e * 0.693147180559945309f + 2.0f * t * series;
}

// The G and Ψ tables hold ln G: interpolating the logarithm follows the exponential fall of
// the source with the sun's depression at twilight (linear interpolation between sun nodes
// overestimates it several-fold there; docs/multiple_scattering.md).
inline float encode(float g) { return fast_log(g); }
inline float decode(float v) { return fast_exp(v); }

// (1 − e^{−x})/x, → 1 at 0 without cancellation.
inline double one_minus_exp_over(double x) { return std::abs(x) < 1e-8 ? 1.0 - 0.5 * x : -std::expm1(-x) / x; }

double rho_of(double r, double R) { return std::sqrt(std::max((r - R) * (r + R), 0.0)); }

// Integer part and fraction of a continuous node coordinate on [lo, hi] (hi > lo nodes).
struct Lerp {
    int i0;
    float f;
};
inline Lerp lerp_of(double s, int lo, int hi) {
    if (hi <= lo) return {lo, 0.0f};
    s = std::clamp(s, double(lo), double(hi));
    int i = std::min(int(std::floor(s)), hi - 1);
    return {i, float(s - i)};
}

void check_cancel(const MsSettings& s) {
    if (s.cancel && s.cancel->requested()) throw Cancelled("multiple scattering precompute cancelled");
}

// ---- the atmosphere as the stages see it ------------------------------------------------------

struct Problem {
    const Atmosphere& atm;
    const MsSettings& set;
    std::size_t nw = 0, nc = 0, ns = 0;
    std::vector<int> slot;                      // per constituent
    std::vector<std::size_t> slot_constituent;  // per slot
    std::vector<float> extinction;              // [constituent][λ]
    std::vector<double> placement_weight;       // per slot: mean σs (node placement)

    Problem(const Atmosphere& a, const MsSettings& s) : atm(a), set(s) {
        nw = a.wavelength_count();
        nc = a.constituents.size();
        slot.assign(nc, -1);
        for (std::size_t i = 0; i < nc; ++i) {
            const auto& c = a.constituents[i];
            for (std::size_t w = 0; w < nw; ++w) extinction.push_back(float(c.extinction_per_m[w]));
            if (!c.scatters) continue;
            slot[i] = int(ns++);
            slot_constituent.push_back(i);
            double mean = 0.0;
            for (double v : c.scattering_per_m) mean += v;
            placement_weight.push_back(mean / double(nw));
        }
    }
    const AtmosphereConstituent& scatterer(std::size_t i) const { return atm.constituents[slot_constituent[i]]; }
};

// ---- sun transmittance table (order 1) -----------------------------------------------------
//
// Masses of every constituent from a point to the top along the sun, on (ρ, distance to the
// top) nodes — Bruneton's transmittance parameterisation, which ends exactly at the local
// horizon (below it the point is in the planet's shadow). Exponential profiles interpolate
// ln m (exact for the exponential part), piecewise-linear ones m itself.

struct SunTable {
    int na = 0, nm = 0;
    double R = 0, top = 0, H = 0;
    std::size_t nc = 0;
    std::vector<double> value;  // [a][m][constituent]
    std::vector<char> is_log;   // per constituent

    void build(const Problem& P, int n_alt, int n_mu) {
        const Atmosphere& atm = P.atm;
        na = n_alt;
        nm = n_mu;
        R = atm.planet_radius_m;
        top = R + atm.top_altitude_m;
        H = rho_of(top, R);
        nc = P.nc;
        value.assign(std::size_t(na) * nm * nc, 0.0);
        is_log.resize(nc);
        for (std::size_t j = 0; j < nc; ++j)
            is_log[j] = atm.constituents[j].profile.kind == CompiledProfile::Kind::exponential;
        tbb::parallel_for(0, na, [&](int a) {
            const double rho = H * a / (na - 1);
            const double r = std::sqrt(R * R + rho * rho);
            const double h = rho * rho / (r + R);
            for (int m = 0; m < nm; ++m) {
                const double x = double(m) / (nm - 1);
                const double d_min = top - r, d_max = rho + H;
                const double d = d_min + x * (d_max - d_min);
                const double mu_h = r > R ? -rho / r : 0.0;
                const double mu = d == 0.0 ? 1.0 : std::clamp((H * H - rho * rho - d * d) / (2.0 * r * d), mu_h, 1.0);
                const PlanetRay<double> ray{R, h, ZenithAngle<double>::from_cos(mu)};
                double* out = &value[(std::size_t(a) * nm + m) * nc];
                for (std::size_t j = 0; j < nc; ++j) {
                    const double mass = std::max(profile_segment_mass(atm.constituents[j].profile, atm.settings.chapman,
                                                                      ray, atm.top_altitude_m, 0.0, kInf),
                                                 0.0);
                    out[j] = is_log[j] ? std::log(std::max(mass, 1e-300)) : mass;
                }
            }
        });
    }

    // Masses toward the sun from radius r with sun zenith cosine mu_s; false in the shadow.
    bool masses(double r, double mu_s, double* m) const {
        r = std::clamp(r, R, top);
        const double rho = rho_of(r, R);
        const double mu_h = r > R ? -rho / r : 0.0;
        if (mu_s < mu_h) return false;
        const double d_min = top - r, d_max = rho + H;
        const double d = -r * mu_s + std::sqrt(std::max(r * r * (mu_s * mu_s - 1.0) + top * top, 0.0));
        const double xm = d_max > d_min ? std::clamp((d - d_min) / (d_max - d_min), 0.0, 1.0) : 0.0;
        const Lerp la = lerp_of(rho / H * (na - 1), 0, na - 1);
        const Lerp lm = lerp_of(xm * (nm - 1), 0, nm - 1);
        const double* v00 = &value[(std::size_t(la.i0) * nm + lm.i0) * nc];
        const double* v01 = v00 + nc;
        const double* v10 = v00 + std::size_t(nm) * nc;
        const double* v11 = v10 + nc;
        const double fa = la.f, fm = lm.f;
        for (std::size_t j = 0; j < nc; ++j) {
            const double v = (1 - fa) * ((1 - fm) * v00[j] + fm * v01[j]) + fa * ((1 - fm) * v10[j] + fm * v11[j]);
            m[j] = is_log[j] ? std::exp(v) : std::max(v, 0.0);
        }
        return true;
    }
};

// ---- ray quadrature ----------------------------------------------------------------------------

struct RayQuadrature {
    int n = 0;  // intervals (0: empty segment)
    bool ground = false;
    double t_ground = 0.0;
    std::vector<double> t, r, mu, h;          // evaluation point of each interval
    std::vector<float> weight;                // [k][slot][λ]
    std::vector<float> ground_transmittance;  // [λ] (ground rays)
};

// Intervals on [t_begin, t_end] of `ray`: uniform in u(t) = ½ M(t)/M_tot + ½ (t − t_b)/L, M the
// scattering-weighted mass from t_begin (dense where the scatterers are, never sparse along
// long rays), and their exponential-integration weights.
void build_quadrature(const Problem& P, const PlanetRay<double>& ray, double t_begin, double t_end, bool ground,
                      int N, RayQuadrature& q) {
    const Atmosphere& atm = P.atm;
    const std::size_t nw = P.nw, nc = P.nc, ns = P.ns;
    const double top = atm.top_altitude_m;
    const ChapmanMethod method = atm.settings.chapman;
    q.ground = ground;
    q.t_ground = t_end;
    q.ground_transmittance.assign(nw, 1.0f);
    const double L = t_end - t_begin;
    if (!(L > 0.0) || ns == 0) {
        q.n = 0;
        q.t.clear();
        q.r.clear();
        q.mu.clear();
        q.h.clear();
        q.weight.clear();
        if (!(L > 0.0) || !ground) return;
        // no scatterer: the ground is still seen through the absorbers
        double tau_g[kMaxConstituents];
        for (std::size_t j = 0; j < nc; ++j)
            tau_g[j] = profile_segment_mass(atm.constituents[j].profile, method, ray, top, t_begin, t_end);
        for (std::size_t w = 0; w < nw; ++w) {
            double tau = 0.0;
            for (std::size_t j = 0; j < nc; ++j) tau += atm.constituents[j].extinction_per_m[w] * tau_g[j];
            q.ground_transmittance[w] = float(std::exp(-tau));
        }
        return;
    }
    // The placement only has to be reasonable — the weights below are exact for whatever
    // intervals result — so u(t) is tabulated by the trapezoid rule of the density on a fine
    // uniform grid (cheap: no Chapman evaluations) and inverted by linear interpolation.
    const int fine = std::max(8 * N, 128);
    std::vector<double> u(std::size_t(fine) + 1, 0.0);
    double previous = 0.0;
    for (int j = 0; j <= fine; ++j) {
        const double t = t_begin + L * j / fine;
        const double h = ray.altitude_at(t);
        double d = 0.0;
        if (h <= top)
            for (std::size_t i = 0; i < ns; ++i) d += P.placement_weight[i] * P.scatterer(i).profile.at(h);
        if (j > 0) u[j] = u[j - 1] + 0.5 * (previous + d);
        previous = d;
    }
    const double M_tot = u[fine];
    const bool use_mass = M_tot > 0.0 && std::isfinite(M_tot);
    for (int j = 0; j <= fine; ++j) u[j] = (use_mass ? 0.5 * u[j] / M_tot : 0.0) + (use_mass ? 0.5 : 1.0) * j / fine;
    // 2N + 1 points: interval ends (even j) and evaluation points (odd j).
    std::vector<double> pts(2 * std::size_t(N) + 1);
    pts.front() = t_begin;
    pts.back() = t_end;
    int cell = 0;
    for (int j = 1; j < 2 * N; ++j) {
        const double target = double(j) / (2.0 * N);
        while (cell + 1 < fine && u[cell + 1] < target) ++cell;
        const double du = u[cell + 1] - u[cell];
        const double f = du > 0.0 ? std::clamp((target - u[cell]) / du, 0.0, 1.0) : 0.5;
        pts[j] = std::clamp(t_begin + L * (cell + f) / fine, pts[j - 1], t_end);
    }

    q.n = N;
    q.t.resize(N);
    q.r.resize(N);
    q.mu.resize(N);
    q.h.resize(N);
    q.weight.assign(std::size_t(N) * ns * nw, 0.0f);
    std::vector<double> tau(nw, 0.0);
    double dm[kMaxConstituents];
    for (int k = 0; k < N; ++k) {
        const double t0 = pts[2 * k], tm = pts[2 * k + 1], t1 = pts[2 * k + 2];
        q.t[k] = tm;
        q.r[k] = ray.radius_at(tm);
        q.mu[k] = ray.zenith_at(tm).cos_chi;
        q.h[k] = ray.altitude_at(tm);
        for (std::size_t j = 0; j < nc; ++j)
            dm[j] = std::max(profile_segment_mass(atm.constituents[j].profile, method, ray, top, t0, t1), 0.0);
        for (std::size_t w = 0; w < nw; ++w) {
            double dtau = 0.0;
            for (std::size_t j = 0; j < nc; ++j) dtau += atm.constituents[j].extinction_per_m[w] * dm[j];
            const double factor = std::exp(-tau[w]) * one_minus_exp_over(dtau);
            for (std::size_t i = 0; i < ns; ++i) {
                const std::size_t c = P.slot_constituent[i];
                q.weight[(std::size_t(k) * ns + i) * nw + w] =
                    float(atm.constituents[c].scattering_per_m[w] * dm[c] * factor);
            }
            tau[w] += dtau;
        }
    }
    if (ground)
        for (std::size_t w = 0; w < nw; ++w) q.ground_transmittance[w] = float(std::exp(-tau[w]));
}

// A grid ray: from altitude node a along view node b (the half decides ground or sky).
void build_grid_ray(const Problem& P, const MsGrid& g, int a, int b, int N, RayQuadrature& q, double& r0,
                    double& mu0) {
    const double R = g.planet_radius_m;
    const double h = g.altitude_node_m(a);
    const double r = R + h;
    const double mu = g.view_node_mu(a, b);
    const bool ground = g.split_view() ? b < g.size.view_zenith / 2 : mu < g.horizon_mu(r);
    const PlanetRay<double> ray{R, h, ZenithAngle<double>::from_cos(mu)};
    double t_end;
    const double rmu = r * mu;
    if (ground) {
        // near root of t² + 2 r mu t + h(2R + h) = 0, stable form; tangent at mu = mu_h
        const double c = h * (2.0 * R + h);
        const double D = std::max(rmu * rmu - c, 0.0);
        t_end = c > 0.0 ? c / (-rmu + std::sqrt(D)) : 0.0;
        if (!std::isfinite(t_end)) t_end = 0.0;
    } else {
        const double top = g.top_radius_m;
        const double c = (top - r) * (top + r);
        const double D = rmu * rmu + c;
        t_end = rmu >= 0.0 ? (c > 0.0 ? c / (rmu + std::sqrt(D)) : 0.0) : -rmu + std::sqrt(D);
    }
    build_quadrature(P, ray, 0.0, std::max(t_end, 0.0), ground, N, q);
    r0 = r;
    mu0 = mu;
}

// ---- per grid ray: the sun geometry of every sample for every (sun, azimuth) node ------------

struct SampleSun {
    std::uint16_t c0, d0;
    float fc, fd;
};

struct GridRay {
    RayQuadrature q;
    double r0 = 0, mu0 = 0;
    std::vector<Lerp> alt, view;       // per sample: altitude and view coordinates
    std::vector<SampleSun> sun;        // [(c * Nφ + d) * n + k]
    std::vector<float> ground_sun;     // [(c, d)]: sun coordinate at the ground, −1 when not lit/used
    std::vector<double> nu;            // [(c, d)]
};

// ν of node (b at radius r, c, d).
inline double node_nu(double mu, double mu_s, double phi) {
    return std::clamp(mu * mu_s + std::sqrt(std::max(0.0, (1.0 - mu) * (1.0 + mu))) *
                                      std::sqrt(std::max(0.0, (1.0 - mu_s) * (1.0 + mu_s))) * std::cos(phi),
                      -1.0, 1.0);
}

// Azimuth between the horizontal projections of view and sun at a point, from the cosines.
inline double azimuth_of(double mu, double mu_s, double nu) {
    const double den = std::sqrt(std::max(0.0, (1.0 - mu) * (1.0 + mu)) * std::max(0.0, (1.0 - mu_s) * (1.0 + mu_s)));
    if (!(den > 1e-12)) return 0.0;
    return std::acos(std::clamp((nu - mu * mu_s) / den, -1.0, 1.0));
}

// Half of the view axis a coordinate belongs to: [lo, hi] node range.
inline void view_half(const MsGrid& g, bool ground, int& lo, int& hi) {
    const int n = g.size.view_zenith;
    if (!g.split_view()) {
        lo = 0;
        hi = n - 1;
    } else if (ground) {
        lo = 0;
        hi = n / 2 - 1;
    } else {
        lo = n / 2;
        hi = n - 1;
    }
}

void build_grid_ray_geometry(const Problem& P, const MsGrid& g, int a, int b, GridRay& gr) {
    build_grid_ray(P, g, a, b, P.set.ray_samples, gr.q, gr.r0, gr.mu0);
    const RayQuadrature& q = gr.q;
    const int n = q.n, Nc = g.size.sun_zenith, Nd = g.size.azimuth;
    int vlo, vhi;
    view_half(g, q.ground, vlo, vhi);
    gr.alt.resize(n);
    gr.view.resize(n);
    for (int k = 0; k < n; ++k) {
        gr.alt[k] = lerp_of(g.altitude_coord(q.h[k]), 0, g.size.altitude - 1);
        gr.view[k] = lerp_of(g.view_coord(q.r[k], q.mu[k], q.ground), vlo, vhi);
    }
    gr.sun.resize(std::size_t(Nc) * Nd * n);
    gr.ground_sun.assign(std::size_t(Nc) * Nd, -1.0f);
    gr.nu.resize(std::size_t(Nc) * Nd);
    for (int c = 0; c < Nc; ++c) {
        const double mu_s = g.sun_node_mu(c);
        for (int d = 0; d < Nd; ++d) {
            const std::size_t cd = std::size_t(c) * Nd + d;
            const double nu = node_nu(gr.mu0, mu_s, g.azimuth_node_rad(d));
            gr.nu[cd] = nu;
            for (int k = 0; k < n; ++k) {
                const double mus_k = std::clamp((gr.r0 * mu_s + q.t[k] * nu) / q.r[k], -1.0, 1.0);
                const Lerp lc = lerp_of(g.sun_coord(mus_k), 0, Nc - 1);
                const Lerp ld = lerp_of(g.azimuth_coord(azimuth_of(q.mu[k], mus_k, nu)), 0, Nd - 1);
                gr.sun[cd * n + k] = {std::uint16_t(lc.i0), std::uint16_t(ld.i0), lc.f, ld.f};
            }
            if (q.ground) {
                const double mus_g = std::clamp((gr.r0 * mu_s + q.t_ground * nu) / g.planet_radius_m, -1.0, 1.0);
                gr.ground_sun[cd] = float(g.sun_coord(mus_g));
            }
        }
    }
}

// ---- phase kernels of the gather ------------------------------------------------------------

struct Fourier {
    int Nd = 1, Nfull = 1, M = 1;
    std::vector<float> F;  // [m][d]: L̂_m = Σ_d F[m][d] L_d
    std::vector<float> B;  // [d][m]: L_d = Σ_m B[d][m] L̂_m

    explicit Fourier(int nd) : Nd(nd) {
        Nfull = nd == 1 ? 1 : 2 * (nd - 1);
        M = nd;
        F.assign(std::size_t(M) * Nd, 0.0f);
        B.assign(std::size_t(Nd) * M, 0.0f);
        for (int m = 0; m < M; ++m)
            for (int d = 0; d < Nd; ++d) {
                const double phi = Nd == 1 ? 0.0 : kPi * d / (Nd - 1);
                const double cd = (d == 0 || d == Nd - 1) ? 1.0 : 2.0;
                const double cm = (m == 0 || m == Nfull / 2) ? 1.0 : 2.0;
                F[std::size_t(m) * Nd + d] = float((Nd == 1 ? 1.0 : cd) * std::cos(m * phi));
                B[std::size_t(d) * M + m] = float((Nd == 1 ? 1.0 : cm) / Nfull * std::cos(m * phi));
            }
    }
};

// Per altitude node: the view-direction weights q_b = ∫ hat_b dμ and qμ_b = ∫ hat_b max(μ,0) dμ,
// and per scattering slot the phase matrices K̂[m][b][b'].
struct Kernels {
    int Na = 0, Nb = 0, M = 0;
    std::size_t ns = 0;
    std::vector<double> q, qmu;  // [a][b]
    std::vector<float> khat;     // [a][slot][m][b][b']
    std::vector<char> active;    // [a][slot][m]: the mode has a non-negligible kernel
};

// Visit the cells of the view axis at radius r: for every sub-sample, call
// f(node_lo, node_hi, frac, mu, dmu).
template <class F>
void for_view_subsamples(const MsGrid& g, double r, int S, F&& f) {
    const int n = g.size.view_zenith;
    const auto cells = [&](int lo, int hi) {
        for (int j = lo; j < hi; ++j)
            for (int p = 0; p < S; ++p) {
                const double x = (p + 0.5) / S;
                const double mu = g.view_mu(r, j + x);
                const double dmu = std::abs(g.view_mu(r, j + (p + 1.0) / S) - g.view_mu(r, j + double(p) / S));
                f(j, j + 1, x, mu, dmu);
            }
    };
    if (g.split_view()) {
        cells(0, n / 2 - 1);
        cells(n / 2, n - 1);
    } else {
        cells(0, n - 1);
    }
}

Kernels build_kernels(const Problem& P, const MsGrid& g, const Fourier& fo) {
    Kernels K;
    K.Na = g.size.altitude;
    K.Nb = g.size.view_zenith;
    K.M = fo.M;
    K.ns = P.ns;
    const int Nb = K.Nb, Nf = fo.Nfull, M = fo.M;
    K.q.assign(std::size_t(K.Na) * Nb, 0.0);
    K.qmu.assign(std::size_t(K.Na) * Nb, 0.0);
    K.khat.assign(std::size_t(K.Na) * P.ns * M * Nb * Nb, 0.0f);
    K.active.assign(std::size_t(K.Na) * P.ns * M, 1);
    tbb::parallel_for(0, K.Na, [&](int a) {
        const double r = g.planet_radius_m + g.altitude_node_m(a);
        for_view_subsamples(g, r, 8, [&](int j0, int j1, double x, double mu, double dmu) {
            K.q[std::size_t(a) * Nb + j0] += (1 - x) * dmu;
            K.q[std::size_t(a) * Nb + j1] += x * dmu;
            K.qmu[std::size_t(a) * Nb + j0] += (1 - x) * dmu * std::max(mu, 0.0);
            K.qmu[std::size_t(a) * Nb + j1] += x * dmu * std::max(mu, 0.0);
        });
        std::vector<double> k(std::size_t(Nb) * Nf);  // [b'][e] for one target
        struct Sub {
            int j0, j1;
            double x, mu, sin_mu, dmu;
        };
        std::vector<double> cos_m(std::size_t(M) * Nf);
        for (int m = 0; m < M; ++m)
            for (int e = 0; e < Nf; ++e) cos_m[std::size_t(m) * Nf + e] = std::cos(2.0 * kPi * m * e / Nf);
        for (std::size_t i = 0; i < P.ns; ++i) {
            const PhaseFunction& pf = P.scatterer(i).phase;
            const bool peaked = (pf.kind == PhaseFunction::Kind::cornette_shanks ||
                                 pf.kind == PhaseFunction::Kind::henyey_greenstein) &&
                                std::abs(pf.g) > 0.3;
            const int S = peaked ? P.set.phase_subsamples : 2;
            const int Sphi = Nf == 1 ? 32 * S : S;
            const double dphi = 2.0 * kPi / Nf / Sphi;
            std::vector<Sub> subs;
            for_view_subsamples(g, r, S, [&](int j0, int j1, double x, double mu, double dmu) {
                subs.push_back({j0, j1, x, mu, std::sqrt(std::max(0.0, (1 - mu) * (1 + mu))), dmu});
            });
            std::vector<double> cos_phi(std::size_t(Nf) * Sphi);
            for (int e = 0; e < Nf; ++e)
                for (int p = 0; p < Sphi; ++p) cos_phi[std::size_t(e) * Sphi + p] = std::cos(2.0 * kPi * (e + (p + 0.5) / Sphi) / Nf);
            for (int b = 0; b < Nb; ++b) {
                std::fill(k.begin(), k.end(), 0.0);
                const double mu_b = g.view_node_mu(a, b);
                const double sin_b = std::sqrt(std::max(0.0, (1 - mu_b) * (1 + mu_b)));
                double total = 0.0;
                for (const Sub& sb : subs) {
                    for (int e = 0; e < Nf; ++e) {
                        const int e1 = (e + 1) % Nf;
                        for (int p = 0; p < Sphi; ++p) {
                            const double y = (p + 0.5) / Sphi;
                            const double w = phase(pf, mu_b * sb.mu + sin_b * sb.sin_mu * cos_phi[std::size_t(e) * Sphi + p]) *
                                             sb.dmu * dphi;
                            k[std::size_t(sb.j0) * Nf + e] += (1 - sb.x) * (1 - y) * w;
                            k[std::size_t(sb.j0) * Nf + e1] += (1 - sb.x) * y * w;
                            k[std::size_t(sb.j1) * Nf + e] += sb.x * (1 - y) * w;
                            k[std::size_t(sb.j1) * Nf + e1] += sb.x * y * w;
                            total += w;
                        }
                    }
                }
                // The phase function integrates to 1: remove the quadrature's residue so that
                // every scattering event conserves energy exactly on the grid.
                const double norm = total > 0.0 ? 1.0 / total : 0.0;
                for (int m = 0; m < M; ++m)
                    for (int bp = 0; bp < Nb; ++bp) {
                        double sum = 0.0;
                        for (int e = 0; e < Nf; ++e) sum += k[std::size_t(bp) * Nf + e] * cos_m[std::size_t(m) * Nf + e];
                        K.khat[(((std::size_t(a) * P.ns + i) * M + m) * Nb + b) * Nb + bp] = float(sum * norm);
                    }
            }
            // A mode whose kernel is below 1e-6 of mode 0's everywhere is skipped by the gather
            // (Rayleigh and isotropic phases have only m ≤ 2 in azimuth).
            float max0 = 0.0f;
            for (int x = 0; x < Nb * Nb; ++x)
                max0 = std::max(max0, std::abs(K.khat[((std::size_t(a) * P.ns + i) * M) * Nb * Nb + x]));
            for (int m = 0; m < M; ++m) {
                float mx = 0.0f;
                for (int x = 0; x < Nb * Nb; ++x)
                    mx = std::max(mx, std::abs(K.khat[((std::size_t(a) * P.ns + i) * M + m) * Nb * Nb + x]));
                K.active[(std::size_t(a) * P.ns + i) * M + m] = mx > 1e-6f * max0;
            }
        }
    });
    return K;
}

// ---- the precompute ----------------------------------------------------------------------------

struct Tables {
    const MsGrid& g;
    std::size_t nw, ns;
    std::size_t cd_count() const { return std::size_t(g.size.sun_zenith) * g.size.azimuth; }
    std::size_t ray_count() const { return std::size_t(g.size.altitude) * g.size.view_zenith; }
    // L: [a][b][c][d][λ]; G: [a][b][c][d][slot][λ]
    std::size_t L_size() const { return ray_count() * cd_count() * nw; }
    std::size_t G_size() const { return ray_count() * cd_count() * ns * nw; }
};

template <class Body>
void parallel_rays(const MsSettings& set, std::size_t n, Body&& body) {
    std::atomic<bool> stop{false};
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
            if (stop.load(std::memory_order_relaxed)) return;
            if (set.cancel && set.cancel->requested()) {
                stop = true;
                return;
            }
            body(i);
        }
    });
    check_cancel(set);
}

// Order 1 on the grid: L¹ (in-scatter of sunlight + the directly lit ground).
void transport_order1(const Problem& P, const MsGrid& g, const std::vector<GridRay>& rays, const SunTable& sun,
                      std::vector<float>& L) {
    const std::size_t nw = P.nw, ns = P.ns, nc = P.nc;
    const int Nc = g.size.sun_zenith, Nd = g.size.azimuth;
    const double albedo_over_pi = P.atm.ground_albedo / kPi;
    parallel_rays(P.set, rays.size(), [&](std::size_t ray) {
        const GridRay& gr = rays[ray];
        const RayQuadrature& q = gr.q;
        std::vector<float> sumW(nw), tsun(nw);
        double m[kMaxConstituents];
        float pv[kMaxConstituents];
        for (int c = 0; c < Nc; ++c) {
            const double mu_s = g.sun_node_mu(c);
            for (int d = 0; d < Nd; ++d) {
                const std::size_t cd = std::size_t(c) * Nd + d;
                float* acc = &L[(ray * (std::size_t(Nc) * Nd) + cd) * nw];
                std::fill(acc, acc + nw, 0.0f);
                const double nu = gr.nu[cd];
                for (std::size_t i = 0; i < ns; ++i) pv[i] = float(phase(P.scatterer(i).phase, nu));
                for (int k = 0; k < q.n; ++k) {
                    const double mus_k = std::clamp((gr.r0 * mu_s + q.t[k] * nu) / q.r[k], -1.0, 1.0);
                    if (!sun.masses(q.r[k], mus_k, m)) continue;
                    const float* W = &q.weight[std::size_t(k) * ns * nw];
                    for (std::size_t w = 0; w < nw; ++w) {
                        float tau = 0.0f;
                        for (std::size_t j = 0; j < nc; ++j) tau += P.extinction[j * nw + w] * float(m[j]);
                        float s = 0.0f;
                        for (std::size_t i = 0; i < ns; ++i) s += pv[i] * W[i * nw + w];
                        acc[w] += s * fast_exp(-tau);
                    }
                }
                if (q.ground && albedo_over_pi > 0.0) {
                    const double mus_g = std::clamp((gr.r0 * mu_s + q.t_ground * nu) / g.planet_radius_m, -1.0, 1.0);
                    if (mus_g > 0.0 && sun.masses(g.planet_radius_m, mus_g, m)) {
                        for (std::size_t w = 0; w < nw; ++w) {
                            float tau = 0.0f;
                            for (std::size_t j = 0; j < nc; ++j) tau += P.extinction[j * nw + w] * float(m[j]);
                            acc[w] += float(albedo_over_pi * mus_g) * q.ground_transmittance[w] * fast_exp(-tau);
                        }
                    }
                }
            }
        }
    });
}

// Order k ≥ 2 on the grid: L^k from G^k (and the ground lit by E^{k−1}). G^k is given as
// ln G (see gather): interpolating the logarithm is exact for the exponential fall of the
// source with the sun's depression at twilight, where linear interpolation between sun
// nodes overestimates badly (docs/multiple_scattering.md).
void transport_order(const Problem& P, const MsGrid& g, const std::vector<GridRay>& rays,
                     const std::vector<float>& logG, const std::vector<float>& E_prev, std::vector<float>& L) {
    const std::size_t nw = P.nw, ns = P.ns;
    const int Nb = g.size.view_zenith, Nc = g.size.sun_zenith, Nd = g.size.azimuth;
    const std::size_t ncd = std::size_t(Nc) * Nd;
    const std::size_t block = ncd * ns * nw;  // G for one (a, b)
    const std::size_t row = ns * nw;
    const std::size_t dstep = Nd > 1 ? row : 0, cstep = std::size_t(Nd) * row;
    const float albedo_over_pi = float(P.atm.ground_albedo / kPi);
    parallel_rays(P.set, rays.size(), [&](std::size_t ray) {
        const GridRay& gr = rays[ray];
        const RayQuadrature& q = gr.q;
        float* out = &L[ray * ncd * nw];
        std::fill(out, out + ncd * nw, 0.0f);
        std::vector<float> slab(block);
        for (int k = 0; k < q.n; ++k) {
            // (altitude, view) corners once per sample: the slab over all (sun, azimuth) nodes
            const Lerp la = gr.alt[k], lb = gr.view[k];
            const int a1 = std::min(la.i0 + 1, g.size.altitude - 1);
            const float w00 = (1 - la.f) * (1 - lb.f), w01 = (1 - la.f) * lb.f, w10 = la.f * (1 - lb.f),
                        w11 = la.f * lb.f;
            const float* g00 = &logG[(std::size_t(la.i0) * Nb + lb.i0) * block];
            const float* g01 = g00 + block;
            const float* g10 = &logG[(std::size_t(a1) * Nb + lb.i0) * block];
            const float* g11 = g10 + block;
            for (std::size_t x = 0; x < block; ++x) slab[x] = w00 * g00[x] + w01 * g01[x] + w10 * g10[x] + w11 * g11[x];
            const float* W = &q.weight[std::size_t(k) * row];
            for (std::size_t cd = 0; cd < ncd; ++cd) {
                const SampleSun s = gr.sun[cd * q.n + k];
                const float* p00 = &slab[std::size_t(s.c0) * cstep + std::size_t(s.d0) * row];
                const float* p01 = p00 + dstep;
                const float* p10 = p00 + cstep;
                const float* p11 = p10 + dstep;
                const float v00 = (1 - s.fc) * (1 - s.fd), v01 = (1 - s.fc) * s.fd, v10 = s.fc * (1 - s.fd),
                            v11 = s.fc * s.fd;
                float* acc = out + cd * nw;
                for (std::size_t i = 0; i < ns; ++i) {
                    const float* Wi = W + i * nw;
                    const std::size_t o = i * nw;
                    for (std::size_t w = 0; w < nw; ++w)
                        acc[w] += Wi[w] * decode(v00 * p00[o + w] + v01 * p01[o + w] + v10 * p10[o + w] +
                                                   v11 * p11[o + w]);
                }
            }
        }
        if (q.ground && albedo_over_pi > 0.0f) {
            for (std::size_t cd = 0; cd < ncd; ++cd) {
                const Lerp lc = lerp_of(gr.ground_sun[cd], 0, Nc - 1);
                const float* e0 = &E_prev[std::size_t(lc.i0) * nw];
                const float* e1 = e0 + nw;
                float* acc = out + cd * nw;
                for (std::size_t w = 0; w < nw; ++w)
                    acc[w] += albedo_over_pi * q.ground_transmittance[w] * ((1 - lc.f) * e0[w] + lc.f * e1[w]);
            }
        }
    });
}

// Gather: G^{k+1} = ∫ P_i L^k dω on every node (written as ln G for the next transport,
// and added linearly to `sum`), and E^k on the ground.
void gather(const Problem& P, const MsGrid& g, const Fourier& fo, const Kernels& K, const std::vector<float>& L,
            std::vector<float>& logG, std::vector<float>& sum, std::vector<float>& E) {
    const std::size_t nw = P.nw, ns = P.ns;
    const int Na = g.size.altitude, Nb = g.size.view_zenith, Nc = g.size.sun_zenith, Nd = g.size.azimuth, M = fo.M;
    const std::size_t ncd = std::size_t(Nc) * Nd;
    E.assign(std::size_t(Nc) * nw, 0.0f);
    parallel_rays(P.set, std::size_t(Na) * Nc, [&](std::size_t ac) {
        const int a = int(ac / Nc), c = int(ac % Nc);
        std::vector<float> Lhat(std::size_t(M) * Nb * nw, 0.0f), Ghat(std::size_t(M) * Nb * nw), gl(nw);
        for (int b = 0; b < Nb; ++b)
            for (int d = 0; d < Nd; ++d) {
                const float* l = &L[((std::size_t(a) * Nb + b) * ncd + std::size_t(c) * Nd + d) * nw];
                for (int m = 0; m < M; ++m) {
                    const float f = fo.F[std::size_t(m) * Nd + d];
                    float* lh = &Lhat[(std::size_t(m) * Nb + b) * nw];
                    for (std::size_t w = 0; w < nw; ++w) lh[w] += f * l[w];
                }
            }
        for (std::size_t i = 0; i < ns; ++i) {
            std::fill(Ghat.begin(), Ghat.end(), 0.0f);
            for (int m = 0; m < M; ++m) {
                if (!K.active[(std::size_t(a) * ns + i) * M + m]) continue;  // e.g. Rayleigh: only m ≤ 2
                for (int b = 0; b < Nb; ++b) {
                    const float* krow = &K.khat[(((std::size_t(a) * ns + i) * M + m) * Nb + b) * Nb];
                    float* gh = &Ghat[(std::size_t(m) * Nb + b) * nw];
                    for (int bp = 0; bp < Nb; ++bp) {
                        const float kv = krow[bp];
                        if (kv == 0.0f) continue;
                        const float* lh = &Lhat[(std::size_t(m) * Nb + bp) * nw];
                        for (std::size_t w = 0; w < nw; ++w) gh[w] += kv * lh[w];
                    }
                }
            }
            for (int b = 0; b < Nb; ++b)
                for (int d = 0; d < Nd; ++d) {
                    std::fill(gl.begin(), gl.end(), 0.0f);
                    for (int m = 0; m < M; ++m) {
                        const float bm = fo.B[std::size_t(d) * M + m];
                        const float* gh = &Ghat[(std::size_t(m) * Nb + b) * nw];
                        for (std::size_t w = 0; w < nw; ++w) gl[w] += bm * gh[w];
                    }
                    const std::size_t o = (((std::size_t(a) * Nb + b) * ncd + std::size_t(c) * Nd + d) * ns + i) * nw;
                    for (std::size_t w = 0; w < nw; ++w) {
                        const float v = 0.5f * (gl[w] + std::fabs(gl[w]));  // max(·, 0) without a compare
                        sum[o + w] += v;
                        logG[o + w] = encode(v);
                    }
                }
        }
        if (a == 0) {
            float* e = &E[std::size_t(c) * nw];
            const double scale = 2.0 * kPi / fo.Nfull;
            for (int b = 0; b < Nb; ++b) {
                const float wq = float(K.qmu[b] * scale);
                if (wq == 0.0f) continue;
                const float* lh = &Lhat[std::size_t(b) * nw];  // m = 0
                for (std::size_t w = 0; w < nw; ++w) e[w] += wq * lh[w];
            }
        }
    });
}

std::vector<double> grid_sum(const std::vector<float>& L, std::size_t nw) {
    std::vector<double> s(nw, 0.0);
    for (std::size_t x = 0; x < L.size(); x += nw)
        for (std::size_t w = 0; w < nw; ++w) s[w] += L[x + w];
    return s;
}

void to_log(std::vector<float>& v) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, v.size(), 1 << 16), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t x = r.begin(); x != r.end(); ++x) v[x] = encode(v[x]);
    });
}

void build_rays(const Problem& P, const MsGrid& g, std::vector<GridRay>& rays) {
    const int Na = g.size.altitude, Nb = g.size.view_zenith;
    rays.resize(std::size_t(Na) * Nb);
    parallel_rays(P.set, rays.size(), [&](std::size_t i) {
        build_grid_ray_geometry(P, g, int(i / Nb), int(i % Nb), rays[i]);
    });
}

void report(const MsSettings& s, double fraction, int order) {
    if (s.progress) s.progress(std::clamp(fraction, 0.0, 1.0), order);
}

void precompute_orders(const Problem& P, MultipleScattering& ms) {
    const MsSettings& set = P.set;
    const MsGrid& g = ms.grid;
    const std::size_t nw = P.nw, ns = P.ns;
    const Tables tb{g, nw, ns};
    SunTable sun;
    sun.build(P, set.transmittance_altitude, set.transmittance_sun);
    std::vector<GridRay> rays;
    build_rays(P, g, rays);
    const Fourier fo(g.size.azimuth);
    const Kernels K = build_kernels(P, g, fo);
    report(set, 0.1, 1);

    std::vector<float> L(tb.L_size()), logG(tb.G_size()), E;
    ms.phase_radiance.assign(tb.G_size(), 0.0f);  // Σ_k G^k, linear until the end
    transport_order1(P, g, rays, sun, L);
    if (set.keep_radiance) ms.radiance = L;
    std::vector<double> cum = grid_sum(L, nw);
    std::vector<std::vector<double>> norms{cum};
    gather(P, g, fo, K, L, logG, ms.phase_radiance, E);  // G², E¹
    ms.ground_irradiance = E;
    int order = 2;
    const int K_max = set.max_order > 0 ? set.max_order : set.max_auto_order;
    const int expected = set.max_order > 0 ? set.max_order : 8;
    report(set, 0.1 + 0.9 / expected, order);
    std::vector<float> last_E = E;
    while (order < K_max) {
        // L^order from G^order and E^{order−1}
        transport_order(P, g, rays, logG, E, L);
        if (set.keep_radiance)
            for (std::size_t x = 0; x < L.size(); ++x) ms.radiance[x] += L[x];
        const std::vector<double> n = grid_sum(L, nw);
        MsOrderInfo info;
        info.order = order;
        for (std::size_t w = 0; w < nw; ++w) {
            cum[w] += n[w];
            info.relative.push_back(cum[w] > 0.0 ? n[w] / cum[w] : 0.0);
            info.max_relative = std::max(info.max_relative, info.relative.back());
        }
        ms.orders.push_back(info);
        norms.push_back(n);
        if (set.max_order == 0 && info.max_relative < set.tolerance) break;
        gather(P, g, fo, K, L, logG, ms.phase_radiance, E);  // G^{order+1}, E^{order}
        for (std::size_t x = 0; x < E.size(); ++x) ms.ground_irradiance[x] += E[x];
        last_E = E;
        ++order;
        report(set, 0.1 + 0.9 * std::min(double(order) / std::max(expected, order + 1), 0.99), order);
    }
    ms.highest_order = order;
    // Geometric remainder Σ_{k>K} G^k ≈ G^K q/(1 − q), q from the last two orders' radiance.
    if (set.geometric_tail && norms.size() >= 3) {
        const auto& n1 = norms[norms.size() - 1];
        const auto& n0 = norms[norms.size() - 2];
        ms.tail_ratio.resize(nw);
        std::vector<float> factor(nw);
        for (std::size_t w = 0; w < nw; ++w) {
            const double qv = n0[w] > 0.0 ? std::clamp(n1[w] / n0[w], 0.0, 0.95) : 0.0;
            ms.tail_ratio[w] = qv;
            factor[w] = float(qv / (1.0 - qv));
        }
        for (std::size_t x = 0; x < logG.size(); x += nw)
            for (std::size_t w = 0; w < nw; ++w) ms.phase_radiance[x + w] += decode(logG[x + w]) * factor[w];
        for (std::size_t x = 0; x < last_E.size(); x += nw)
            for (std::size_t w = 0; w < nw; ++w) ms.ground_irradiance[x + w] += last_E[x + w] * factor[w];
        if (set.keep_radiance)  // the last transport is L^order: its remainder likewise
            for (std::size_t x = 0; x < L.size(); x += nw)
                for (std::size_t w = 0; w < nw; ++w) ms.radiance[x + w] += L[x + w] * factor[w];
        ms.tail_added = true;
    }
    to_log(ms.phase_radiance);
    report(set, 1.0, order);
}

// Ψ(a, c) lookup by (altitude, sun) coordinates.
inline void psi_lookup(const MultipleScattering& ms, double altitude_m, double mu_s, float* out) {
    const MsGrid& g = ms.grid;
    const std::size_t nw = ms.wavelength_count;
    const Lerp la = lerp_of(g.altitude_coord(altitude_m), 0, g.size.altitude - 1);
    const Lerp lc = lerp_of(g.sun_coord(mu_s), 0, g.size.sun_zenith - 1);
    const int a1 = std::min(la.i0 + 1, g.size.altitude - 1), c1 = std::min(lc.i0 + 1, g.size.sun_zenith - 1);
    const std::size_t Nc = g.size.sun_zenith;
    const float* p00 = &ms.phase_radiance[(la.i0 * Nc + lc.i0) * nw];
    const float* p01 = &ms.phase_radiance[(la.i0 * Nc + c1) * nw];
    const float* p10 = &ms.phase_radiance[(a1 * Nc + lc.i0) * nw];
    const float* p11 = &ms.phase_radiance[(a1 * Nc + c1) * nw];
    for (std::size_t w = 0; w < nw; ++w)
        out[w] = decode((1 - la.f) * ((1 - lc.f) * p00[w] + lc.f * p01[w]) +
                          la.f * ((1 - lc.f) * p10[w] + lc.f * p11[w]));
}

void precompute_isotropic(const Problem& P, MultipleScattering& ms) {
    const MsSettings& set = P.set;
    const MsGrid& g = ms.grid;
    const std::size_t nw = P.nw, ns = P.ns;
    const int Na = g.size.altitude, Nb = g.size.view_zenith, Nc = g.size.sun_zenith, Nd = g.size.azimuth;
    const std::size_t ncd = std::size_t(Nc) * Nd;
    const Tables tb{g, nw, ns};
    SunTable sun;
    sun.build(P, set.transmittance_altitude, set.transmittance_sun);
    std::vector<GridRay> rays;
    build_rays(P, g, rays);
    const Fourier fo(Nd);
    // isotropic phase: only the view weights are needed
    Kernels K;
    K.q.assign(std::size_t(Na) * Nb, 0.0);
    K.qmu.assign(std::size_t(Na) * Nb, 0.0);
    for (int a = 0; a < Na; ++a)
        for_view_subsamples(g, g.planet_radius_m + g.altitude_node_m(a), 8,
                            [&](int j0, int j1, double x, double mu, double dmu) {
                                K.q[std::size_t(a) * Nb + j0] += (1 - x) * dmu;
                                K.q[std::size_t(a) * Nb + j1] += x * dmu;
                                K.qmu[std::size_t(a) * Nb + j0] += (1 - x) * dmu * std::max(mu, 0.0);
                                K.qmu[std::size_t(a) * Nb + j1] += x * dmu * std::max(mu, 0.0);
                            });
    report(set, 0.2, 1);
    std::vector<float> L(tb.L_size());
    transport_order1(P, g, rays, sun, L);
    report(set, 0.7, 1);

    // f_ms(a) = (1/4π) ∫ dω ∫ σs T dt (Hillaire Eq. 7–8), per wavelength.
    std::vector<double> fms(std::size_t(Na) * nw, 0.0);
    for (int a = 0; a < Na; ++a) {
        double qsum = 0.0;
        for (int b = 0; b < Nb; ++b) qsum += K.q[std::size_t(a) * Nb + b];
        for (int b = 0; b < Nb; ++b) {
            const RayQuadrature& q = rays[std::size_t(a) * Nb + b].q;
            const double wb = K.q[std::size_t(a) * Nb + b] / qsum;  // = q_b / 2 with Σ q = 2
            for (int k = 0; k < q.n; ++k)
                for (std::size_t i = 0; i < ns; ++i)
                    for (std::size_t w = 0; w < nw; ++w)
                        fms[std::size_t(a) * nw + w] += wb * q.weight[(std::size_t(k) * ns + i) * nw + w];
        }
    }
    // Ψ = L₂ / (1 − f_ms), L₂ = (1/4π) ∫ L¹ dω (Hillaire Eq. 5, 9).
    ms.phase_radiance.assign(std::size_t(Na) * Nc * nw, 0.0f);
    for (int a = 0; a < Na; ++a) {
        double qsum = 0.0;
        for (int b = 0; b < Nb; ++b) qsum += K.q[std::size_t(a) * Nb + b];
        for (int c = 0; c < Nc; ++c)
            for (std::size_t w = 0; w < nw; ++w) {
                double l2 = 0.0;
                for (int b = 0; b < Nb; ++b) {
                    double lhat = 0.0;
                    for (int d = 0; d < Nd; ++d)
                        lhat += fo.F[d] * L[((std::size_t(a) * Nb + b) * ncd + std::size_t(c) * Nd + d) * nw + w];
                    l2 += K.q[std::size_t(a) * Nb + b] / qsum * lhat / fo.Nfull;
                }
                const double f = std::min(fms[std::size_t(a) * nw + w], 0.999);
                ms.phase_radiance[(std::size_t(a) * Nc + c) * nw + w] = encode(float(l2 / (1.0 - f)));
            }
    }
    // Ground: E¹ from L¹, plus the sky light of the Ψ source seen from the ground.
    ms.ground_irradiance.assign(std::size_t(Nc) * nw, 0.0f);
    std::vector<float> lx(nw);
    for (int b = 0; b < Nb; ++b) {
        const double wq = K.qmu[b] * 2.0 * kPi / fo.Nfull;
        if (wq == 0.0) continue;
        const GridRay& gr = rays[b];  // altitude node 0
        const RayQuadrature& q = gr.q;
        for (int c = 0; c < Nc; ++c) {
            const double mu_s = g.sun_node_mu(c);
            for (int d = 0; d < Nd; ++d) {
                const std::size_t cd = std::size_t(c) * Nd + d;
                const double nu = gr.nu[cd];
                const float* l1 = &L[(std::size_t(b) * ncd + cd) * nw];
                std::fill(lx.begin(), lx.end(), 0.0f);
                for (int k = 0; k < q.n; ++k) {
                    const double mus_k = std::clamp((gr.r0 * mu_s + q.t[k] * nu) / q.r[k], -1.0, 1.0);
                    float psi[1024];
                    std::vector<float> psi_big;
                    float* ps = psi;
                    if (nw > 1024) {
                        psi_big.resize(nw);
                        ps = psi_big.data();
                    }
                    psi_lookup(ms, q.h[k], mus_k, ps);
                    for (std::size_t i = 0; i < ns; ++i)
                        for (std::size_t w = 0; w < nw; ++w) lx[w] += q.weight[(std::size_t(k) * ns + i) * nw + w] * ps[w];
                }
                const double fw = wq * fo.F[d];
                for (std::size_t w = 0; w < nw; ++w)
                    ms.ground_irradiance[std::size_t(c) * nw + w] += float(fw * (l1[w] + lx[w]));
            }
        }
    }
    ms.highest_order = 0;  // infinite (geometric series)
    report(set, 1.0, 0);
}

}  // namespace

MultipleScattering precompute_multiple_scattering(const Atmosphere& atm, const MsSettings& requested) {
    validate(requested);
    const auto start = std::chrono::steady_clock::now();
    MsSettings settings = requested;
    if (settings.table.azimuth == 0) settings.table.azimuth = ms_automatic_azimuth_nodes(atm);
    const Problem P(atm, settings);
    MultipleScattering ms;
    ms.mode = settings.mode;
    ms.grid = MsGrid::make(atm, settings.parameterisation, settings.table);
    ms.wavelength_count = P.nw;
    ms.ground_albedo = atm.ground_albedo;
    ms.slot = P.slot;
    ms.slot_count = settings.mode == MsMode::orders ? P.ns : (P.ns > 0 ? 1 : 0);
    if (P.ns > 0) {
        tbb::task_arena arena(settings.threads > 0 ? settings.threads : tbb::task_arena::automatic);
        arena.execute([&] {
            if (settings.mode == MsMode::orders) precompute_orders(P, ms);
            else precompute_isotropic(P, ms);
        });
    } else {
        ms.phase_radiance.assign(1, 0.0f);  // nothing scatters: an all-zero table
        ms.ground_irradiance.assign(std::size_t(ms.grid.size.sun_zenith) * P.nw, 0.0f);
    }
    ms.precompute_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return ms;
}

std::vector<double> ms_energy_balance(const MultipleScattering& ms, const Atmosphere* atm_for_direct) {
    const MsGrid& g = ms.grid;
    const std::size_t nw = ms.wavelength_count;
    const int Na = g.size.altitude, Nb = g.size.view_zenith, Nc = g.size.sun_zenith, Nd = g.size.azimuth;
    if (ms.mode != MsMode::orders || ms.radiance.size() != g.node_count() * nw)
        throw std::invalid_argument("ms_energy_balance: needs MsMode::orders tables precomputed with keep_radiance");
    // outward flux at the top node: F(c) = ∫_{μ<0} L |μ| dω
    const int a = Na - 1;
    std::vector<double> q(Nb, 0.0);
    for_view_subsamples(g, g.top_radius_m, 16, [&](int j0, int j1, double x, double mu, double dmu) {
        q[j0] += (1 - x) * dmu * std::max(-mu, 0.0);
        q[j1] += x * dmu * std::max(-mu, 0.0);
    });
    const Fourier fo(Nd);
    std::vector<double> F(std::size_t(Nc) * nw, 0.0);
    for (int c = 0; c < Nc; ++c)
        for (int b = 0; b < Nb; ++b)
            for (int d = 0; d < Nd; ++d) {
                const double w = q[b] * 2.0 * kPi / fo.Nfull * fo.F[d];
                const float* l = &ms.radiance[(((std::size_t(a) * Nb + b) * Nc + c) * Nd + d) * nw];
                for (std::size_t x = 0; x < nw; ++x) F[std::size_t(c) * nw + x] += w * l[x];
            }
    // (2/E) ∫ F dμs, trapezoid over the sun nodes (no light below mu_s_min), E = 1, plus the
    // sunlight that crosses the shell without an event (impact parameters R < p < r_top):
    // (2/r_top²) ∫ T_line(p) p dp, by the midpoint rule in u = sqrt((p − R)/(r_top − R)).
    std::vector<double> ratio(nw, 0.0);
    if (atm_for_direct != nullptr) {
        const Atmosphere& atm = *atm_for_direct;
        const double R = atm.planet_radius_m, H = atm.top_altitude_m, rt = R + H;
        const int n = 2000;
        std::vector<double> tau(nw);
        for (int k = 0; k < n; ++k) {
            const double u = (k + 0.5) / n, hp = u * u * H, p = R + hp;
            const PlanetRay<double> line{R, hp, {0.0, 1.0}};
            optical_depth(atm, line, -kInf, kInf, tau);
            for (std::size_t x = 0; x < nw; ++x)
                ratio[x] += 2.0 / (rt * rt) * std::exp(-tau[x]) * p * 2.0 * u * H / n;
        }
    }
    for (int c = 0; c + 1 < Nc; ++c) {
        const double dmu = g.sun_node_mu(c + 1) - g.sun_node_mu(c);
        for (std::size_t x = 0; x < nw; ++x)
            ratio[x] += dmu * (F[std::size_t(c) * nw + x] + F[std::size_t(c + 1) * nw + x]);  // 2 · ½ (…)
    }
    return ratio;
}

// ---- lookups -------------------------------------------------------------------------------

void ms_phase_radiance(const MultipleScattering& ms, std::size_t constituent, const MsPoint& pt,
                       std::span<double> out) {
    const std::size_t nw = ms.wavelength_count;
    if (out.size() < nw) throw std::invalid_argument("ms_phase_radiance: output span needs " + std::to_string(nw) + " elements");
    std::fill_n(out.begin(), nw, 0.0);
    if (constituent >= ms.slot.size() || ms.slot[constituent] < 0 || ms.phase_radiance.size() <= 1) return;
    const MsGrid& g = ms.grid;
    const double mu = std::isfinite(pt.mu) ? std::clamp(pt.mu, -1.0, 1.0) : 1.0;
    const double mu_s = std::isfinite(pt.mu_s) ? std::clamp(pt.mu_s, -1.0, 1.0) : 1.0;
    const double nu = std::isfinite(pt.nu) ? std::clamp(pt.nu, -1.0, 1.0) : 1.0;
    const double h = std::isfinite(pt.altitude_m) ? pt.altitude_m : 0.0;
    if (mu_s < g.mu_s_min) return;  // beyond the reach of secondary light
    float buf[1024];
    std::vector<float> big;
    float* v = buf;
    if (nw > 1024) {
        big.resize(nw);
        v = big.data();
    }
    if (ms.mode == MsMode::isotropic_lut) {
        psi_lookup(ms, h, mu_s, v);
        for (std::size_t w = 0; w < nw; ++w) out[w] = double(v[w]);
        return;
    }
    const int Na = g.size.altitude, Nb = g.size.view_zenith, Nc = g.size.sun_zenith, Nd = g.size.azimuth;
    const double r = g.planet_radius_m + std::clamp(h, 0.0, g.top_radius_m - g.planet_radius_m);
    const bool ground = mu < g.horizon_mu(r);
    int vlo, vhi;
    view_half(g, ground, vlo, vhi);
    const Lerp la = lerp_of(g.altitude_coord(h), 0, Na - 1);
    const Lerp lb = lerp_of(g.view_coord(r, mu, ground), vlo, vhi);
    const Lerp lc = lerp_of(g.sun_coord(mu_s), 0, Nc - 1);
    const Lerp ld = lerp_of(g.azimuth_coord(azimuth_of(mu, mu_s, nu)), 0, Nd - 1);
    const std::size_t ns = ms.slot_count, sl = std::size_t(ms.slot[constituent]);
    std::fill_n(v, nw, 0.0f);
    for (int ia = 0; ia < 2; ++ia) {
        const float wa = ia ? la.f : 1 - la.f;
        if (wa == 0.0f) continue;
        for (int ib = 0; ib < 2; ++ib) {
            const float wb = wa * (ib ? lb.f : 1 - lb.f);
            if (wb == 0.0f) continue;
            for (int ic = 0; ic < 2; ++ic) {
                const float wc = wb * (ic ? lc.f : 1 - lc.f);
                if (wc == 0.0f) continue;
                for (int id = 0; id < 2; ++id) {
                    const float wd = wc * (id ? ld.f : 1 - ld.f);
                    if (wd == 0.0f) continue;
                    const std::size_t node =
                        ((std::size_t(std::min(la.i0 + ia, Na - 1)) * Nb + std::min(lb.i0 + ib, vhi)) * Nc +
                         std::min(lc.i0 + ic, Nc - 1)) * Nd + std::min(ld.i0 + id, Nd - 1);
                    const float* p = &ms.phase_radiance[(node * ns + sl) * nw];
                    for (std::size_t w = 0; w < nw; ++w) v[w] += wd * p[w];
                }
            }
        }
    }
    for (std::size_t w = 0; w < nw; ++w) out[w] = double(decode(v[w]));
}

void ms_ground_irradiance(const MultipleScattering& ms, double mu_s, std::span<double> out) {
    const std::size_t nw = ms.wavelength_count;
    if (out.size() < nw) throw std::invalid_argument("ms_ground_irradiance: output span needs " + std::to_string(nw) + " elements");
    std::fill_n(out.begin(), nw, 0.0);
    if (!std::isfinite(mu_s) || mu_s < ms.grid.mu_s_min || ms.ground_irradiance.empty()) return;
    const Lerp lc = lerp_of(ms.grid.sun_coord(mu_s), 0, ms.grid.size.sun_zenith - 1);
    const int c1 = std::min(lc.i0 + 1, ms.grid.size.sun_zenith - 1);
    for (std::size_t w = 0; w < nw; ++w)
        out[w] = std::max(0.0, double((1 - lc.f) * ms.ground_irradiance[std::size_t(lc.i0) * nw + w] +
                                      lc.f * ms.ground_irradiance[std::size_t(c1) * nw + w]));
}

// ---- along a view ray ------------------------------------------------------------------------

void multiple_scattering_radiance(const Atmosphere& atm, const MultipleScattering& ms, const ViewRay& vr,
                                  MsRadianceOut out, int samples) {
    const std::size_t nw = atm.wavelength_count();
    if (ms.wavelength_count != nw)
        throw std::invalid_argument("multiple_scattering_radiance: the tables have " +
                                    std::to_string(ms.wavelength_count) + " wavelengths, the atmosphere " +
                                    std::to_string(nw));
    if (out.multiple_rayleigh.size() < nw || out.multiple_mie.size() < nw || out.multiple.size() < nw ||
        (!out.single.empty() && out.single.size() < nw))
        throw std::invalid_argument("multiple_scattering_radiance: output spans need " + std::to_string(nw) +
                                    " elements");
    if (samples < 1 || samples > 100000)
        throw std::invalid_argument("multiple_scattering_radiance: samples = " + std::to_string(samples) +
                                    ": must be in [1, 100000]");
    std::fill_n(out.multiple_rayleigh.begin(), nw, 0.0);
    std::fill_n(out.multiple_mie.begin(), nw, 0.0);
    std::fill_n(out.multiple.begin(), nw, 0.0);
    if (!out.single.empty()) std::fill_n(out.single.begin(), nw, 0.0);
    const double len = glm::length(vr.view_direction), slen = glm::length(vr.sun_direction);
    if (!(len > 0.0) || !(slen > 0.0) || !std::isfinite(vr.altitude_m)) return;
    const Vec3<double> v = vr.view_direction / len, s = vr.sun_direction / slen;
    const double R = atm.planet_radius_m;
    const PlanetRay<double> ray{R, vr.altitude_m, {std::clamp(v.z, -1.0, 1.0), std::min(std::hypot(v.x, v.y), 1.0)}};
    const auto seg = atmosphere_segment(ray, atm.top_altitude_m);
    if (!seg.valid) return;
    MsSettings dummy;
    const Problem P(atm, dummy);
    RayQuadrature q;
    build_quadrature(P, ray, seg.t_begin, seg.t_end, seg.hits_ground, samples, q);
    const double r0 = R + vr.altitude_m, nu = std::clamp(glm::dot(v, s), -1.0, 1.0), mu_s0 = s.z;
    std::vector<double> G(nw);
    double m[kMaxConstituents];
    const std::size_t nc = P.nc, ns = P.ns;
    const auto sun_masses = [&](double h, double mu_s) {
        const PlanetRay<double> sr{R, h, ZenithAngle<double>::from_cos(std::clamp(mu_s, -1.0, 1.0))};
        if (hits_ground(sr)) return false;
        for (std::size_t j = 0; j < nc; ++j)
            m[j] = std::max(profile_segment_mass(atm.constituents[j].profile, atm.settings.chapman, sr,
                                                 atm.top_altitude_m, 0.0, kInf),
                            0.0);
        return true;
    };
    for (int k = 0; k < q.n; ++k) {
        const double mus_k = std::clamp((r0 * mu_s0 + q.t[k] * nu) / q.r[k], -1.0, 1.0);
        const MsPoint pt{q.h[k], q.mu[k], mus_k, nu};
        for (std::size_t i = 0; i < ns; ++i) {
            const std::size_t c = P.slot_constituent[i];
            ms_phase_radiance(ms, c, pt, G);
            std::span<double> dst = atm.constituents[c].rayleigh_like ? out.multiple_rayleigh : out.multiple_mie;
            for (std::size_t w = 0; w < nw; ++w)
                dst[w] += atm.sun_irradiance[w] * double(q.weight[(std::size_t(k) * ns + i) * nw + w]) * G[w];
        }
        if (!out.single.empty() && sun_masses(q.h[k], mus_k)) {
            for (std::size_t w = 0; w < nw; ++w) {
                double tau = 0.0;
                for (std::size_t j = 0; j < nc; ++j) tau += atm.constituents[j].extinction_per_m[w] * m[j];
                double sum = 0.0;
                for (std::size_t i = 0; i < ns; ++i)
                    sum += phase(P.scatterer(i).phase, nu) * double(q.weight[(std::size_t(k) * ns + i) * nw + w]);
                out.single[w] += atm.sun_irradiance[w] * sum * std::exp(-tau);
            }
        }
    }
    for (std::size_t w = 0; w < nw; ++w) out.multiple[w] = out.multiple_rayleigh[w] + out.multiple_mie[w];
    if (q.ground && atm.settings.ground && atm.ground_albedo > 0.0) {
        const double mus_g = std::clamp((r0 * mu_s0 + q.t_ground * nu) / R, -1.0, 1.0);
        ms_ground_irradiance(ms, mus_g, G);
        for (std::size_t w = 0; w < nw; ++w)
            out.multiple[w] += atm.sun_irradiance[w] * atm.ground_albedo / kPi * q.ground_transmittance[w] * G[w];
        if (!out.single.empty() && mus_g > 0.0 && sun_masses(0.0, mus_g)) {
            for (std::size_t w = 0; w < nw; ++w) {
                double tau = 0.0;
                for (std::size_t j = 0; j < nc; ++j) tau += atm.constituents[j].extinction_per_m[w] * m[j];
                out.single[w] += atm.sun_irradiance[w] * atm.ground_albedo / kPi * mus_g * std::exp(-tau) *
                                 q.ground_transmittance[w];
            }
        }
    }
}

}  // namespace airmass
