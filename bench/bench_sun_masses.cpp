// Issue 14: "a transmittance table against Chapman per sample (measure both, keep the faster at
// equal error)". The sun's masses per constituent at a sample (optical_depth.hpp sun_masses_batch:
// Chapman differences for exponential profiles, closed forms for piecewise-linear ones) against a
// table over (altitude, cos sun zenith) in Bruneton's transmittance parametrisation, bilinear:
//   x_r = rho / H, rho = sqrt(r² − R²), H = sqrt(Rt² − R²);
//   x_mu = (d − d_min) / (d_max − d_min), d the distance to the top along the sun ray,
//   d_min = Rt − r (straight up), d_max = rho + H (grazing the ground: the horizon).
// Nodes at both ends (x = i / (n − 1)); only lit rays are tabulated, and both paths decide "not
// lit" by the same in_planet_shadow test. Interpolated: the mass, log(mass + 1 m), log(mass) for
// exponential profiles and the mass for piecewise-linear ones ("hybrid", as the multiple-scattering
// precompute's own sun table), or the transmittance per wavelength. This file measures; the library is not changed.
//
// Atmospheres: presets `earth` and `blender-nishita` at the wavelengths a sky evaluates (sky.cpp
// prepare: the basis's wavelengths with a nonzero colour weight).
//
// Printed before the timings (not timed): relative error of T = exp(−Σ ext_i(λ) m_i) per point
// and wavelength, p50/p95/p99/max, over all points and over those with T_exact > 1e-3; relative
// error of each constituent's mass. Points: altitude uniform in [0, top] and h = top·u², cos sun
// zenith uniform in [horizon, 1], and a band 1e-4..1e-1 rad (log-uniform) above the horizon; and
// the nodes of view rays (below).
//
// Timed (Google Benchmark, one thread, CPU time; ns per point): the exact sun_masses_batch in
// batches of 64 (and 32, the single-scattering kernel's kNodeChunk) against the table lookups of
// all constituents per point, over the nodes of sky-like view rays (observer at 1 m, view
// elevations −5°..90°, sun elevations −4°..60°, 64 nodes per ray in ray order, so neighbours are
// coherent as in the kernel). After the runs a plain table prints each lookup's time as a ratio to
// the exact batch of 64 measured in the same run, beside the errors and the memory per atmosphere.
//   build/bench/bench_sun_masses [--benchmark_filter=...] [--benchmark_repetitions=3]
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "airmass/atmosphere.hpp"
#include "airmass/color.hpp"
#include "airmass/optical_depth.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/sky.hpp"
#include "run_times.hpp"

namespace {

using namespace airmass;

constexpr std::array<const char*, 2> kPresets = {"earth", "blender-nishita"};
constexpr std::array<std::array<int, 2>, 4> kSizes = {{{64, 16}, {128, 32}, {256, 64}, {512, 128}}};  // mu x r
constexpr double kLogOffset_m = 1.0;  // log-mass: log(m + 1 m), so zero masses (looking up from the top) are finite

// hybrid: log(mass) for exponential profiles, the mass for piecewise-linear ones (ozone) — the
// multiple-scattering precompute's own sun table (multiple_scattering_kernels.inc SunTable).
enum class Interp { mass, log_mass, hybrid, transmittance };
const char* interp_name(Interp i) {
    switch (i) {
        case Interp::mass:
            return "mass";
        case Interp::log_mass:
            return "log-mass";
        case Interp::hybrid:
            return "hybrid";
        case Interp::transmittance:
            return "T";
    }
    return "?";
}

// The atmosphere a sky compiles (sky.cpp prepare): wavelengths with a nonzero colour weight.
Atmosphere sky_atmosphere(const std::string& preset) {
    const Scene scene = load_preset(preset);
    const SpectrumToRgb full = spectrum_to_rgb(scene.basis);
    std::vector<double> wl;
    for (std::size_t i = 0; i < full.size(); ++i)
        if (full.matrix[0][i] != 0.0 || full.matrix[1][i] != 0.0 || full.matrix[2][i] != 0.0)
            wl.push_back(full.wavelengths_nm[i]);
    EvalSettings eval = SkySettings{}.view;
    eval.sun_disc = false;
    return compile_atmosphere(scene, wl, eval);
}

const Atmosphere& atmosphere(int a) {
    static const std::array<Atmosphere, 2> atm = {sky_atmosphere(kPresets[0]), sky_atmosphere(kPresets[1])};
    return atm[std::size_t(a)];
}

// Sun masses over (x_mu, x_r), nodes at both ends.
struct SunTable {
    int n_mu = 0, n_r = 0;
    std::size_t nc = 0, nw = 0;
    double R = 0, top = 0, H = 0;
    std::vector<double> mass;      // [(j n_mu + i) nc + c]
    std::vector<double> log_mass;  // log(mass + kLogOffset_m), same layout
    std::vector<double> hybrid;    // log(max(mass, 1e-300)) for exponential profiles, else mass; same layout
    std::vector<char> is_log;      // per constituent: exponential (hybrid)
    std::vector<double> trans;     // [(j n_mu + i) nw + w]
    std::size_t bytes(Interp k) const {
        return (k == Interp::transmittance ? trans.size() : mass.size()) * sizeof(double);
    }
};

SunTable build_table(const Atmosphere& atm, int n_mu, int n_r) {
    SunTable t;
    t.n_mu = n_mu;
    t.n_r = n_r;
    t.nc = atm.constituents.size();
    t.nw = atm.wavelength_count();
    t.R = atm.planet_radius_m;
    t.top = atm.top_altitude_m;
    const double R = t.R, Rt = R + t.top;
    t.H = std::sqrt(t.top * (2.0 * R + t.top));
    t.mass.resize(std::size_t(n_mu) * n_r * t.nc);
    t.log_mass.resize(t.mass.size());
    t.hybrid.resize(t.mass.size());
    for (const auto& c : atm.constituents) t.is_log.push_back(c.profile.kind == CompiledProfile::Kind::exponential);
    t.trans.resize(std::size_t(n_mu) * n_r * t.nw);
    std::vector<double> m(t.nc);
    for (int j = 0; j < n_r; ++j) {
        const double rho = t.H * double(j) / (n_r - 1);
        const double r = std::sqrt(rho * rho + R * R), h = rho * rho / (r + R);
        const double d_min = Rt - r, d_max = rho + t.H;
        for (int i = 0; i < n_mu; ++i) {
            const double d = d_min + (d_max - d_min) * double(i) / (n_mu - 1);
            // cos of the ray reaching the top at distance d; the last node is the horizon exactly
            double mu = d <= 0.0 ? 1.0 : std::clamp((t.H * t.H - rho * rho - d * d) / (2.0 * r * d), -1.0, 1.0);
            if (i == n_mu - 1) mu = -rho / r;
            bool lit = sun_masses(atm, h, ZenithAngle<double>::from_cos(mu), m);
            for (int k = 0; !lit && k < 8; ++k) {  // rounding at the grazing node: nudge up until lit
                mu = std::min(1.0, mu + 1e-12 * std::pow(10.0, k));
                lit = sun_masses(atm, h, ZenithAngle<double>::from_cos(mu), m);
            }
            if (!lit) throw std::logic_error("sun table: a node above the horizon is not lit");
            const std::size_t node = std::size_t(j) * n_mu + i;
            for (std::size_t c = 0; c < t.nc; ++c) {
                t.mass[node * t.nc + c] = m[c];
                t.log_mass[node * t.nc + c] = std::log(m[c] + kLogOffset_m);
                t.hybrid[node * t.nc + c] = t.is_log[c] ? std::log(std::max(m[c], 1e-300)) : m[c];
            }
            for (std::size_t w = 0; w < t.nw; ++w) {
                double tau = 0.0;
                for (std::size_t c = 0; c < t.nc; ++c) tau += atm.extinction_matrix[w * t.nc + c] * m[c];
                t.trans[node * t.nw + w] = std::exp(-tau);
            }
        }
    }
    return t;
}

// The bilinear cell and weights of a lit point; false (nothing written) in the planet's shadow.
struct Cell {
    std::size_t n00, n01, n10, n11;  // node indices: (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)
    double w00, w01, w10, w11;
};

inline bool table_cell(const SunTable& t, double h, ZenithAngle<double> chi, Cell& cell) {
    const double R = t.R, top = t.top;
    if (in_planet_shadow(PlanetRay<double>{R, h, chi})) return false;
    const double r = R + h, mu = chi.cos_chi;
    const double rho2 = std::max(h * (2.0 * R + h), 0.0), rho = std::sqrt(rho2);
    // distance to the top, d = −r mu + sqrt(Rt² − r² + r² mu²), without cancellation for mu > 0
    const double dr2 = (top - h) * (2.0 * R + top + h);  // Rt² − r²
    const double q = std::sqrt(std::max(dr2 + r * r * mu * mu, 0.0));
    const double d = mu > 0.0 ? dr2 / (r * mu + q) : q - r * mu;
    const double d_min = top - h, d_max = rho + t.H;
    const double x_mu = std::clamp((d - d_min) / (d_max - d_min), 0.0, 1.0);
    const double x_r = std::min(rho / t.H, 1.0);
    const double u = x_mu * (t.n_mu - 1), v = x_r * (t.n_r - 1);
    const int i = std::min(int(u), t.n_mu - 2), j = std::min(int(v), t.n_r - 2);
    const double fu = u - i, fv = v - j;
    cell.n00 = std::size_t(j) * t.n_mu + i;
    cell.n01 = cell.n00 + 1;
    cell.n10 = cell.n00 + t.n_mu;
    cell.n11 = cell.n10 + 1;
    cell.w00 = (1 - fu) * (1 - fv);
    cell.w01 = fu * (1 - fv);
    cell.w10 = (1 - fu) * fv;
    cell.w11 = fu * fv;
    return true;
}

inline double bilinear(const double* v, std::size_t stride, std::size_t k, const Cell& c) {
    return c.w00 * v[c.n00 * stride + k] + c.w01 * v[c.n01 * stride + k] + c.w10 * v[c.n10 * stride + k] +
           c.w11 * v[c.n11 * stride + k];
}

// Masses of all constituents (mass or log-mass table): as sun_masses_batch.
template <Interp kind>
inline void table_masses(const SunTable& t, const double* h, const ZenithAngle<double>* chi, std::size_t n,
                         double* mass, unsigned char* lit) {
    const double* src = kind == Interp::mass       ? t.mass.data()
                        : kind == Interp::log_mass ? t.log_mass.data()
                                                   : t.hybrid.data();
    const std::size_t nc = t.nc;
    for (std::size_t k = 0; k < n; ++k) {
        Cell c;
        lit[k] = table_cell(t, h[k], chi[k], c);
        if (!lit[k]) continue;
        for (std::size_t i = 0; i < nc; ++i) {
            const double v = bilinear(src, nc, i, c);
            if constexpr (kind == Interp::mass)
                mass[k * nc + i] = v;
            else if constexpr (kind == Interp::log_mass)
                mass[k * nc + i] = std::max(std::exp(v) - kLogOffset_m, 0.0);
            else
                mass[k * nc + i] = t.is_log[i] ? std::exp(v) : std::max(v, 0.0);
        }
    }
}

// Transmittance per wavelength from the T table (0 in the shadow).
inline void table_transmittance(const SunTable& t, double h, ZenithAngle<double> chi, double* T) {
    Cell c;
    if (!table_cell(t, h, chi, c)) {
        std::fill(T, T + t.nw, 0.0);
        return;
    }
    for (std::size_t w = 0; w < t.nw; ++w) T[w] = bilinear(t.trans.data(), t.nw, w, c);
}

// ---- points ----------------------------------------------------------------------------------

struct Points {
    std::vector<double> h;
    std::vector<ZenithAngle<double>> chi;
    void add(double hh, ZenithAngle<double> c) {
        h.push_back(hh);
        chi.push_back(c);
    }
    std::size_t size() const { return h.size(); }
};

double horizon_mu(double R, double h) { return -std::sqrt(h * (2.0 * R + h)) / (R + h); }

// Quasi-random (R2 sequence) points; low: h = top·u²; band: log-uniform 1e-4..1e-1 rad above the horizon.
enum class Sampling { uniform, low, band_uniform, band_low };
Points error_points(const Atmosphere& atm, Sampling s, int n) {
    Points p;
    const double R = atm.planet_radius_m, top = atm.top_altitude_m;
    for (int k = 0; k < n; ++k) {
        const double u = std::fmod(0.5 + k * 0.7548776662466927, 1.0), v = std::fmod(0.5 + k * 0.5698402909980532, 1.0);
        const bool low = s == Sampling::low || s == Sampling::band_low;
        const double h = top * (low ? u * u : u);
        const double mu_h = horizon_mu(R, h);
        if (s == Sampling::uniform || s == Sampling::low) {
            p.add(h, ZenithAngle<double>::from_cos(mu_h + (1.0 - mu_h) * v));
        } else {
            const double delta = std::pow(10.0, -4.0 + 3.0 * v);  // rad above the horizon
            const double chi = std::acos(mu_h) - delta;
            p.add(h, ZenithAngle<double>{std::cos(chi), std::sin(chi)});
        }
    }
    return p;
}

// Nodes of sky view rays, in ray order (64 per ray): observer at 1 m, sun elevations −4..60°.
Points view_ray_points(const Atmosphere& atm) {
    Points p;
    const double R = atm.planet_radius_m, top = atm.top_altitude_m, h0 = 1.0;
    const double deg = std::acos(-1.0) / 180.0;
    for (double sun_el : {-4.0, 2.0, 10.0, 25.0, 60.0})
        for (double el : {-5.0, -1.0, 0.5, 2.0, 5.0, 10.0, 20.0, 35.0, 60.0, 90.0})
            for (double az : {0.0, 45.0, 90.0, 135.0, 180.0}) {
                const double vx = std::cos(el * deg) * std::cos(az * deg), vy = std::cos(el * deg) * std::sin(az * deg),
                             vz = std::sin(el * deg);
                const double sx = std::cos(sun_el * deg), sz = std::sin(sun_el * deg);
                const double r0 = R + h0;
                // exit: the ground when heading into it, else the top
                const double b = r0 * vz;
                const double dg = b * b - h0 * (2.0 * R + h0);
                const double t_end = (vz < 0.0 && dg >= 0.0)
                                         ? -b - std::sqrt(dg)
                                         : -b + std::sqrt(b * b + (top - h0) * (2.0 * R + top + h0));
                for (int k = 0; k < 64; ++k) {
                    const double t = t_end * (k + 0.5) / 64.0;
                    const double px = t * vx, py = t * vy, pz = r0 + t * vz;
                    const double r = std::sqrt(px * px + py * py + pz * pz);
                    const double mu = std::clamp((px * sx + pz * sz) / r, -1.0, 1.0);
                    p.add(std::max(r - R, 0.0), ZenithAngle<double>::from_cos(mu));
                }
            }
    return p;
}

// ---- errors ----------------------------------------------------------------------------------

struct Pct {
    double p50 = 0, p95 = 0, p99 = 0, max = 0;
    std::size_t n = 0;
};
Pct percentiles(std::vector<double>& e) {
    Pct p;
    p.n = e.size();
    if (e.empty()) return p;
    const auto at = [&](double q) {
        auto it = e.begin() + std::ptrdiff_t(q * double(e.size() - 1));
        std::nth_element(e.begin(), it, e.end());
        return *it;
    };
    p.p50 = at(0.50);
    p.p95 = at(0.95);
    p.p99 = at(0.99);
    p.max = *std::max_element(e.begin(), e.end());
    return p;
}

struct ErrorResult {
    Pct all, bright;               // T relative error; bright: T_exact > 1e-3
    std::vector<Pct> mass;         // per constituent (not for the T table)
    std::size_t lit_mismatch = 0;  // points lit by one path only (must be 0)
};

ErrorResult measure_error(const Atmosphere& atm, const SunTable& t, Interp kind, const Points& pts) {
    const std::size_t nc = t.nc, nw = t.nw;
    std::vector<double> all, bright;
    std::vector<std::vector<double>> merr(nc);
    std::vector<double> me(nc), mt(nc), Te(nw), Tt(nw);
    ErrorResult out;
    for (std::size_t k = 0; k < pts.size(); ++k) {
        const bool lit_e = sun_masses(atm, pts.h[k], pts.chi[k], me);
        bool lit_t;
        if (kind == Interp::transmittance) {
            Cell c;
            lit_t = table_cell(t, pts.h[k], pts.chi[k], c);
            table_transmittance(t, pts.h[k], pts.chi[k], Tt.data());
        } else {
            unsigned char l = 0;
            if (kind == Interp::mass)
                table_masses<Interp::mass>(t, &pts.h[k], &pts.chi[k], 1, mt.data(), &l);
            else if (kind == Interp::log_mass)
                table_masses<Interp::log_mass>(t, &pts.h[k], &pts.chi[k], 1, mt.data(), &l);
            else
                table_masses<Interp::hybrid>(t, &pts.h[k], &pts.chi[k], 1, mt.data(), &l);
            lit_t = l != 0;
            for (std::size_t w = 0; w < nw && lit_t; ++w) {
                double tau = 0.0;
                for (std::size_t c = 0; c < nc; ++c) tau += atm.extinction_matrix[w * nc + c] * mt[c];
                Tt[w] = std::exp(-tau);
            }
        }
        if (lit_e != lit_t) ++out.lit_mismatch;
        if (!lit_e || !lit_t) continue;
        for (std::size_t w = 0; w < nw; ++w) {
            double tau = 0.0;
            for (std::size_t c = 0; c < nc; ++c) tau += atm.extinction_matrix[w * nc + c] * me[c];
            Te[w] = std::exp(-tau);
            if (!(Te[w] > 0.0)) continue;  // underflow: nothing to compare
            const double e = std::abs(Tt[w] - Te[w]) / Te[w];
            all.push_back(e);
            if (Te[w] > 1e-3) bright.push_back(e);
        }
        if (kind != Interp::transmittance)
            for (std::size_t c = 0; c < nc; ++c)
                if (me[c] > 1e-3)  // mass in m of density 1; zero masses (above the profile) skipped
                    merr[c].push_back(std::abs(mt[c] - me[c]) / me[c]);
    }
    out.all = percentiles(all);
    out.bright = percentiles(bright);
    for (auto& v : merr) out.mass.push_back(percentiles(v));
    return out;
}

// ---- tables kept for the timings and the summary ---------------------------------------------

const SunTable& table(int a, int size) {
    static std::map<std::pair<int, int>, std::unique_ptr<SunTable>> cache;
    auto& slot = cache[{a, size}];
    if (!slot) slot = std::make_unique<SunTable>(build_table(atmosphere(a), kSizes[size][0], kSizes[size][1]));
    return *slot;
}

const Points& cost_points(int a) {
    static const std::array<Points, 2> p = {view_ray_points(atmosphere(0)), view_ray_points(atmosphere(1))};
    return p[std::size_t(a)];
}

// ---- timings ---------------------------------------------------------------------------------

void BM_exact(benchmark::State& state, int a, std::size_t batch, bool with_T) {
    const Atmosphere& atm = atmosphere(a);
    const Points& p = cost_points(a);
    const std::size_t nc = atm.constituents.size(), nw = atm.wavelength_count(), n = p.size();
    std::vector<double> mass(batch * nc), T(nw);
    std::vector<unsigned char> lit(batch);
    for (auto _ : state) {
        for (std::size_t b = 0; b + batch <= n; b += batch) {
            sun_masses_batch(atm, std::span<const double>(p.h.data() + b, batch),
                             std::span<const ZenithAngle<double>>(p.chi.data() + b, batch), mass, lit);
            if (with_T)
                for (std::size_t k = 0; k < batch; ++k) {
                    if (!lit[k]) continue;
                    for (std::size_t w = 0; w < nw; ++w) {
                        double tau = 0.0;
                        for (std::size_t c = 0; c < nc; ++c)
                            tau += atm.extinction_matrix[w * nc + c] * mass[k * nc + c];
                        T[w] = std::exp(-tau);
                    }
                    benchmark::DoNotOptimize(T.data());
                }
            benchmark::DoNotOptimize(mass.data());
        }
    }
    state.SetItemsProcessed(state.iterations() * int64_t(n / batch * batch));
}

void BM_table(benchmark::State& state, int a, int size, Interp kind) {
    const Atmosphere& atm = atmosphere(a);
    const SunTable& t = table(a, size);
    const Points& p = cost_points(a);
    const std::size_t nc = t.nc, batch = 64, n = p.size();
    std::vector<double> mass(batch * nc), T(t.nw);
    std::vector<unsigned char> lit(batch);
    (void)atm;
    for (auto _ : state) {
        for (std::size_t b = 0; b + batch <= n; b += batch) {
            if (kind == Interp::mass)
                table_masses<Interp::mass>(t, &p.h[b], &p.chi[b], batch, mass.data(), lit.data());
            else if (kind == Interp::log_mass)
                table_masses<Interp::log_mass>(t, &p.h[b], &p.chi[b], batch, mass.data(), lit.data());
            else if (kind == Interp::hybrid)
                table_masses<Interp::hybrid>(t, &p.h[b], &p.chi[b], batch, mass.data(), lit.data());
            else
                for (std::size_t k = 0; k < batch; ++k) {
                    table_transmittance(t, p.h[b + k], p.chi[b + k], T.data());
                    benchmark::DoNotOptimize(T.data());
                }
            benchmark::DoNotOptimize(mass.data());
        }
    }
    state.SetItemsProcessed(state.iterations() * int64_t(n / batch * batch));
}

std::string bench_name(int a, const std::string& what) { return std::string(kPresets[std::size_t(a)]) + "/" + what; }
std::string size_name(int s) { return std::to_string(kSizes[s][0]) + "x" + std::to_string(kSizes[s][1]); }

void register_all() {
    for (int a = 0; a < 2; ++a) {
        benchmark::RegisterBenchmark(bench_name(a, "exact_batch64").c_str(), BM_exact, a, 64, false);
        benchmark::RegisterBenchmark(bench_name(a, "exact_batch32").c_str(), BM_exact, a, 32, false);
        benchmark::RegisterBenchmark(bench_name(a, "exact_batch64+T").c_str(), BM_exact, a, 64, true);
        for (int s = 0; s < int(kSizes.size()); ++s)
            for (Interp k : {Interp::mass, Interp::log_mass, Interp::hybrid, Interp::transmittance})
                benchmark::RegisterBenchmark(
                    bench_name(a, std::string("table_") + interp_name(k) + "/" + size_name(s)).c_str(), BM_table, a, s,
                    k);
    }
}

// ns per point (CPU): the median with repetitions, else the one run.
// ---- report ----------------------------------------------------------------------------------

struct Row {
    int a, size;
    Interp kind;
    ErrorResult sampled, rays;
};

std::vector<Row> measure_all_errors() {
    std::vector<Row> rows;
    for (int a = 0; a < 2; ++a) {
        const Atmosphere& atm = atmosphere(a);
        Points pts;
        for (Sampling s : {Sampling::uniform, Sampling::low, Sampling::band_uniform, Sampling::band_low}) {
            const Points q = error_points(atm, s, 20000);
            for (std::size_t k = 0; k < q.size(); ++k) pts.add(q.h[k], q.chi[k]);
        }
        std::printf(
            "%s: %zu constituents, %zu wavelengths (%.0f-%.0f nm), top %.0f km, %zu sampled points, %zu "
            "view-ray nodes\n",
            kPresets[std::size_t(a)], atm.constituents.size(), atm.wavelength_count(), atm.wavelengths_nm.front(),
            atm.wavelengths_nm.back(), atm.top_altitude_m / 1e3, pts.size(), cost_points(a).size());
        for (int s = 0; s < int(kSizes.size()); ++s)
            for (Interp k : {Interp::mass, Interp::log_mass, Interp::hybrid, Interp::transmittance})
                rows.push_back({a, s, k, measure_error(atm, table(a, s), k, pts),
                                measure_error(atm, table(a, s), k, cost_points(a))});
    }
    std::printf(
        "\nRelative error of T = exp(-sum ext m), table vs exact sun_masses, per point and wavelength "
        "(sampled points: h uniform and top*u^2, mu uniform above the horizon + 1e-4..1e-1 rad band)\n");
    std::printf(
        "| atmosphere | mu x r | interp | all p50 | all p95 | all p99 | all max | T>1e-3 p95 | T>1e-3 p99 | "
        "T>1e-3 max | view rays T>1e-3 p95 / max | lit mismatches "
        "|\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (const Row& r : rows)
        std::printf("| %s | %s | %s | %.1e | %.1e | %.1e | %.1e | %.1e | %.1e | %.1e | %.1e / %.1e | %zu |\n",
                    kPresets[std::size_t(r.a)], size_name(r.size).c_str(), interp_name(r.kind), r.sampled.all.p50,
                    r.sampled.all.p95, r.sampled.all.p99, r.sampled.all.max, r.sampled.bright.p95, r.sampled.bright.p99,
                    r.sampled.bright.max, r.rays.bright.p95, r.rays.bright.max,
                    r.sampled.lit_mismatch + r.rays.lit_mismatch);
    std::printf("\nRelative error of each constituent's mass (sampled points, mass > 1 mm): p50 / p95 / p99 / max\n");
    std::printf(
        "| atmosphere | mu x r | interp | constituent | p50 | p95 | p99 | max "
        "|\n|---|---|---|---|---:|---:|---:|---:|\n");
    for (const Row& r : rows)
        for (std::size_t c = 0; c < r.sampled.mass.size(); ++c) {
            const Pct& p = r.sampled.mass[c];
            std::printf("| %s | %s | %s | %s | %.1e | %.1e | %.1e | %.1e |\n", kPresets[std::size_t(r.a)],
                        size_name(r.size).c_str(), interp_name(r.kind), atmosphere(r.a).constituents[c].name.c_str(),
                        p.p50, p.p95, p.p99, p.max);
        }
    std::printf("\n");
    std::fflush(stdout);
    return rows;
}

void print_summary(const std::vector<Row>& rows, const airmass::bench::RunTimes& rep) {
    std::printf(
        "\nSummary (one thread, CPU ns per point over sky view-ray nodes; ratio = this / exact_batch64 of the "
        "same atmosphere, same run; T-table ratio also against exact_batch64+T, which includes the exp per "
        "wavelength the T table saves)\n");
    std::printf(
        "| atmosphere | mu x r | interp | bytes | T>1e-3 p95 | T>1e-3 max | all p95 | ns/point | / exact | "
        "/ exact+T |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|\n");
    for (int a = 0; a < 2; ++a) {
        const double e64 = rep.get(bench_name(a, "exact_batch64")), e32 = rep.get(bench_name(a, "exact_batch32"));
        const double eT = rep.get(bench_name(a, "exact_batch64+T"));
        std::printf("| %s | exact (batch 64 / 32 / 64+T) | - | 0 | 0 | 0 | 0 | %.1f / %.1f / %.1f | 1 | |\n",
                    kPresets[std::size_t(a)], e64, e32, eT);
        for (const Row& r : rows) {
            if (r.a != a) continue;
            const double ns =
                rep.get(bench_name(a, std::string("table_") + interp_name(r.kind) + "/" + size_name(r.size)));
            const std::size_t bytes = table(a, r.size).bytes(r.kind);
            // "-" where the filter did not run the benchmark
            char t_ns[32] = "-", t_ratio[32] = "-", t_ratio_T[32] = "";
            if (ns > 0) std::snprintf(t_ns, sizeof t_ns, "%.1f", ns);
            if (ns > 0 && e64 > 0) std::snprintf(t_ratio, sizeof t_ratio, "%.2f", ns / e64);
            if (r.kind == Interp::transmittance && ns > 0 && eT > 0)
                std::snprintf(t_ratio_T, sizeof t_ratio_T, "%.2f", ns / eT);
            std::printf("| %s | %s | %s | %zu | %.1e | %.1e | %.1e | %s | %s | %s |\n", kPresets[std::size_t(a)],
                        size_name(r.size).c_str(), interp_name(r.kind), bytes, r.sampled.bright.p95,
                        r.sampled.bright.max, r.sampled.all.p95, t_ns, t_ratio, t_ratio_T);
        }
    }
}

}  // namespace

int main(int argc, char** argv) {
    benchmark::Initialize(&argc, argv);
    const std::vector<Row> rows = measure_all_errors();
    register_all();
    airmass::bench::RunTimes reporter([](const auto& run) {  // ns per point, from the items counter
        const auto it = run.counters.find("items_per_second");
        return it == run.counters.end() || !(it->second.value > 0) ? -1.0 : 1e9 / it->second.value;
    });
    benchmark::RunSpecifiedBenchmarks(&reporter);
    print_summary(rows, reporter);
    benchmark::Shutdown();
    return 0;
}
