// The Monte Carlo reference path tracer (monte_carlo.hpp states the estimator).
#include "airmass/monte_carlo.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>

#include "airmass/optical_depth.hpp"
#include "airmass/parallel.hpp"
#include "airmass/phase.hpp"

namespace airmass {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::uint64_t kBlock = 2048;  // paths per random stream / work item
constexpr int kMaxEvents = 10000;

using V3 = Vec3<double>;

// SplitMix64 (Steele et al. 2014): a counter-based stream per (seed, wavelength, block).
struct Rng {
    std::uint64_t state;
    std::uint64_t next() {
        std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
        return z ^ (z >> 31);
    }
    double uniform() { return double(next() >> 11) * 0x1.0p-53; }  // [0, 1)
};

std::uint64_t mix(std::uint64_t a, std::uint64_t b) {
    Rng r{a * 0x9e3779b97f4a7c15ULL ^ b};
    r.next();
    return r.next();
}

// An orthonormal frame around a unit vector (Duff et al. 2017).
void frame(const V3& n, V3& t, V3& b) {
    const double sign = std::copysign(1.0, n.z);
    const double a = -1.0 / (sign + n.z);
    const double c = n.x * n.y * a;
    t = V3(1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x);
    b = V3(c, sign + n.y * n.y * a, -n.y);
}

V3 around(const V3& axis, double cos_theta, double phi) {
    V3 t, b;
    frame(axis, t, b);
    const double s = std::sqrt(std::max(0.0, (1.0 - cos_theta) * (1.0 + cos_theta)));
    return glm::normalize(s * std::cos(phi) * t + s * std::sin(phi) * b + cos_theta * axis);
}

// Direction cosine drawn from a phase function; `weight` gets f/p (1 when exact).
double sample_phase(const PhaseFunction& f, Rng& rng, double& weight) {
    const double xi = rng.uniform();
    switch (f.kind) {
        case PhaseFunction::Kind::rayleigh: {
            // CDF (μ³ + 3μ + 4)/8 = ξ: Cardano, μ = u − 1/u
            const double c = 4.0 * xi - 2.0;
            const double u = std::cbrt(c + std::sqrt(c * c + 1.0));
            return std::clamp(u - 1.0 / u, -1.0, 1.0);
        }
        case PhaseFunction::Kind::henyey_greenstein:
        case PhaseFunction::Kind::cornette_shanks: {
            const double g = f.g;
            double mu;
            if (std::abs(g) < 1e-4) {
                mu = 2.0 * xi - 1.0;
            } else {
                const double s = (1.0 - g * g) / (1.0 - g + 2.0 * g * xi);
                mu = std::clamp((1.0 + g * g - s * s) / (2.0 * g), -1.0, 1.0);
            }
            if (f.kind == PhaseFunction::Kind::cornette_shanks) weight *= 1.5 * (1.0 + mu * mu) / (2.0 + g * g);
            return mu;
        }
        case PhaseFunction::Kind::isotropic: return 2.0 * xi - 1.0;
        case PhaseFunction::Kind::rayleigh_modified: {
            const double mu = 2.0 * xi - 1.0;
            weight *= 4.0 * kPi * phase<double>(f, mu);
            return mu;
        }
    }
    return 2.0 * xi - 1.0;
}

struct Tracer {
    const Atmosphere& atm;
    const McSettings& set;
    std::size_t nc;
    double R, top;

    // Masses of all constituents along [t0, t1] (no ground test: callers stay above it).
    void masses(const PlanetRay<double>& ray, double t0, double t1, double* m) const {
        for (std::size_t j = 0; j < nc; ++j)
            m[j] = std::max(profile_segment_mass(atm.constituents[j].profile, atm.settings.chapman, ray,
                                                 atm.top_altitude_m, t0, t1),
                            0.0);
    }
    double tau_of(const double* m, std::size_t w) const {
        double tau = 0.0;
        for (std::size_t j = 0; j < nc; ++j) tau += atm.constituents[j].extinction_per_m[w] * m[j];
        return tau;
    }
    double density(std::size_t j, double h) const {
        return h > atm.top_altitude_m ? 0.0 : atm.constituents[j].profile.at(h);
    }
    // Sun transmittance from a point (0 in the planet's shadow).
    double sun_transmittance(const V3& p, const V3& sun, std::size_t w) const {
        const auto ray = PlanetRay<double>::from_vectors(R, p, sun);
        if (hits_ground(ray)) return 0.0;
        double m[kMaxConstituents];
        masses(ray, 0.0, kInf, m);
        return std::exp(-tau_of(m, w));
    }

    double invert(const PlanetRay<double>& ray, double tb, double te, std::size_t w, double target) const {
        if (!(target > 0.0)) return tb;
        double m[kMaxConstituents];
        double lo = tb, hi = te;
        masses(ray, tb, te, m);
        const double total = tau_of(m, w);
        if (!(target < total)) return te;
        double t = tb + (te - tb) * (target / total);
        for (int it = 0; it < 100; ++it) {
            masses(ray, tb, t, m);
            const double f = tau_of(m, w) - target;
            if (f > 0.0) hi = t;
            else lo = t;
            if (std::abs(f) <= 1e-12 * target || hi - lo <= 1e-10 * (te - tb)) break;
            const double h = ray.altitude_at(t);
            double sigma = 0.0;
            for (std::size_t j = 0; j < nc; ++j) sigma += atm.constituents[j].extinction_per_m[w] * density(j, h);
            double tn = sigma > 0.0 ? t - f / sigma : 0.5 * (lo + hi);
            if (!(tn > lo && tn < hi)) tn = 0.5 * (lo + hi);
            t = tn;
        }
        return t;
    }

    // One path's contribution at wavelength w (E_sun applied).
    double trace(V3 x, V3 dir, const V3& sun, std::size_t w, Rng& rng) const {
        const double E = atm.sun_irradiance[w];
        const double albedo = atm.ground_albedo;
        double weight = 1.0, L = 0.0;
        int order = 0;
        const auto counted = [&](int k) { return k >= set.min_order && (set.max_order == 0 || k <= set.max_order); };
        const bool bounded = set.max_order > 0;
        double m[kMaxConstituents];
        for (int event = 0; event < kMaxEvents; ++event) {
            const auto ray = PlanetRay<double>::from_vectors(R, x, dir);
            const auto seg = atmosphere_segment(ray, atm.top_altitude_m);
            if (!seg.valid) break;
            masses(ray, seg.t_begin, seg.t_end, m);
            const double tau_e = tau_of(m, w);
            const double absorbed = -std::expm1(-tau_e);  // 1 − T_e
            bool collide;
            if (seg.hits_ground) {
                collide = rng.uniform() < absorbed;
            } else {
                if (!(absorbed > 0.0)) break;
                weight *= absorbed;
                collide = true;
            }
            if (collide) {
                const double tau_star = -std::log1p(-rng.uniform() * absorbed);
                const double t = invert(ray, seg.t_begin, seg.t_end, w, tau_star);
                const V3 y = x + t * dir;
                const double h = ray.altitude_at(t);
                double ss[kMaxConstituents], sigma_s = 0.0, sigma_t = 0.0;
                for (std::size_t j = 0; j < nc; ++j) {
                    const double rho = density(j, h);
                    ss[j] = atm.constituents[j].scattering_per_m[w] * rho;
                    sigma_s += ss[j];
                    sigma_t += atm.constituents[j].extinction_per_m[w] * rho;
                }
                if (!(sigma_t > 0.0) || !(sigma_s > 0.0)) break;
                weight *= sigma_s / sigma_t;
                ++order;
                const double nu = glm::dot(dir, sun);
                if (counted(order)) {
                    const double ts = sun_transmittance(y, sun, w);
                    if (ts > 0.0) {
                        double p = 0.0;
                        for (std::size_t j = 0; j < nc; ++j)
                            if (ss[j] > 0.0) p += ss[j] * phase<double>(atm.constituents[j].phase, nu);
                        L += weight * p / sigma_s * ts * E;
                    }
                }
                if (bounded && order >= set.max_order) break;
                // pick the scatterer, then the direction
                double pick = rng.uniform() * sigma_s;
                std::size_t j = nc;
                for (std::size_t c = 0; c < nc; ++c) {
                    if (!(ss[c] > 0.0)) continue;
                    j = c;
                    if (pick < ss[c]) break;
                    pick -= ss[c];
                }
                const double mu = sample_phase(atm.constituents[j].phase, rng, weight);
                dir = around(dir, mu, 2.0 * kPi * rng.uniform());
                x = y;
            } else {
                const V3 g = x + seg.t_end * dir;
                const V3 n = glm::normalize(g);
                ++order;
                if (counted(order) && albedo > 0.0) {
                    const double cos_s = glm::dot(n, sun);
                    if (cos_s > 0.0) L += weight * albedo / kPi * cos_s * sun_transmittance(g, sun, w) * E;
                }
                if ((bounded && order >= set.max_order) || !(albedo > 0.0)) break;
                weight *= albedo;
                const double u = rng.uniform();
                dir = around(n, std::sqrt(u), 2.0 * kPi * rng.uniform());  // cosine-distributed
                x = g * (1.0 + 1e-12);
            }
            if (weight < set.roulette_weight) {
                const double survive = weight / set.roulette_weight;
                if (rng.uniform() >= survive) break;
                weight = set.roulette_weight;
            }
        }
        return L;
    }
};

// Runs `path(w, rng) → value` for every wavelength and path, in blocks.
template <class Path>
McResult run(const Atmosphere& atm, const McSettings& set, Path&& path) {
    validate(set);
    const auto start = std::chrono::steady_clock::now();
    const std::size_t nw = atm.wavelength_count();
    const std::uint64_t blocks = (set.paths + kBlock - 1) / kBlock;
    std::vector<double> sum(nw * blocks, 0.0), sum2(nw * blocks, 0.0);
    std::atomic<bool> stop{false};
    std::atomic<std::uint64_t> done{0};
    {
        parallel_for(0, std::size_t(nw * blocks), 1, set.threads,
                          [&](std::size_t ib, std::size_t ie, int) {
                              for (std::uint64_t item = ib; item != ie; ++item) {
                                  if (stop.load(std::memory_order_relaxed)) return;
                                  if (set.cancel && set.cancel->requested()) {
                                      stop = true;
                                      return;
                                  }
                                  const std::size_t w = std::size_t(item / blocks);
                                  const std::uint64_t b = item % blocks;
                                  Rng rng{mix(mix(set.seed, w), b)};
                                  const std::uint64_t n = std::min(kBlock, set.paths - b * kBlock);
                                  double s = 0.0, s2 = 0.0;
                                  for (std::uint64_t p = 0; p < n; ++p) {
                                      const double v = path(w, rng);
                                      s += v;
                                      s2 += v * v;
                                  }
                                  sum[item] = s;
                                  sum2[item] = s2;
                                  done.fetch_add(1, std::memory_order_relaxed);
                              }
                          });
    }
    if (set.cancel && set.cancel->requested()) throw Cancelled("Monte Carlo cancelled");
    if (set.progress) set.progress(1.0);
    McResult out;
    out.paths = set.paths;
    out.value.assign(nw, 0.0);
    out.standard_error.assign(nw, 0.0);
    const double N = double(set.paths);
    for (std::size_t w = 0; w < nw; ++w) {
        double s = 0.0, s2 = 0.0;
        for (std::uint64_t b = 0; b < blocks; ++b) {  // fixed order: thread-independent sums
            s += sum[w * blocks + b];
            s2 += sum2[w * blocks + b];
        }
        const double mean = s / N;
        out.value[w] = mean;
        out.standard_error[w] = N > 1 ? std::sqrt(std::max(s2 / N - mean * mean, 0.0) / (N - 1)) : 0.0;
    }
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return out;
}

}  // namespace

void validate(const McSettings& s) {
    const auto fail = [](const std::string& field, double v, const std::string& range) {
        char buf[40];
        std::snprintf(buf, sizeof buf, "%.17g", v);
        throw std::invalid_argument("monte carlo: " + field + " = " + buf + ": " + range);
    };
    if (s.paths < 2 || s.paths > (std::uint64_t(1) << 40)) fail("paths", double(s.paths), "must be in [2, 2^40]");
    if (s.min_order < 1 || s.min_order > kMaxEvents) fail("min_order", s.min_order, "must be in [1, 10000]");
    if (s.max_order < 0 || s.max_order > kMaxEvents || (s.max_order > 0 && s.max_order < s.min_order))
        fail("max_order", s.max_order, "must be 0 (unlimited) or in [min_order, 10000]");
    if (!(std::isfinite(s.roulette_weight) && s.roulette_weight > 0.0 && s.roulette_weight <= 1.0))
        fail("roulette_weight", s.roulette_weight, "must be in (0, 1]");
    if (s.threads < 0 || s.threads > 4096) fail("threads", s.threads, "must be in [0, 4096] (0: all)");
}

McResult monte_carlo_radiance(const Atmosphere& atm, const ViewRay& vr, const McSettings& set) {
    const double vl = glm::length(vr.view_direction), sl = glm::length(vr.sun_direction);
    if (!(vl > 0.0) || !(sl > 0.0)) throw std::invalid_argument("monte carlo: view and sun directions must be non-zero");
    if (!(std::isfinite(vr.altitude_m) && vr.altitude_m >= 0.0))
        throw std::invalid_argument("monte carlo: observer altitude_m must be finite and ≥ 0");
    const Tracer tr{atm, set, atm.constituents.size(), atm.planet_radius_m, atm.planet_radius_m + atm.top_altitude_m};
    const V3 x0(0.0, 0.0, atm.planet_radius_m + vr.altitude_m);
    const V3 v = vr.view_direction / vl, s = vr.sun_direction / sl;
    return run(atm, set, [&](std::size_t w, Rng& rng) { return tr.trace(x0, v, s, w, rng); });
}

McResult monte_carlo_energy_balance(const Atmosphere& atm, const McSettings& set) {
    const Tracer tr{atm, set, atm.constituents.size(), atm.planet_radius_m, atm.planet_radius_m + atm.top_altitude_m};
    const V3 x0(0.0, 0.0, tr.top);
    return run(atm, set, [&](std::size_t w, Rng& rng) {
        const double E = atm.sun_irradiance[w];
        if (!(E > 0.0)) return 0.0;
        const double mu_s = 2.0 * rng.uniform() - 1.0;
        const V3 sun(std::sqrt(std::max(0.0, 1.0 - mu_s * mu_s)), 0.0, mu_s);
        const double u = rng.uniform();
        const V3 dir = around(V3(0.0, 0.0, -1.0), std::sqrt(u), 2.0 * kPi * rng.uniform());
        double x = 4.0 * kPi * tr.trace(x0, dir, sun, w, rng) / E;
        // plus the sunlight crossing the shell without any event: a uniform point of the disc
        // of radius r_top facing the sun; beyond the planet's disc it passes along a line
        const double p = tr.top * std::sqrt(rng.uniform());
        if (p > tr.R) {
            const PlanetRay<double> line{tr.R, p - tr.R, {0.0, 1.0}};
            double m[kMaxConstituents];
            tr.masses(line, -kInf, kInf, m);
            x += std::exp(-tr.tau_of(m, w));
        }
        return x;
    });
}

double free_path_distance(const Atmosphere& atm, const PlanetRay<double>& ray, double t_begin, double t_end,
                          std::size_t w, double tau) {
    const McSettings set;
    const Tracer tr{atm, set, atm.constituents.size(), atm.planet_radius_m, atm.planet_radius_m + atm.top_altitude_m};
    return tr.invert(ray, t_begin, t_end, w, tau);
}

}  // namespace airmass
