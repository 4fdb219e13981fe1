// Phase functions (phase.hpp has the equations and the normalisation of the modified
// Rayleigh form).
#include "airmass/phase.hpp"

#include <cmath>
#include <numbers>

namespace airmass {

namespace {
template <class T>
constexpr T inv_4pi = T(0.25 / std::numbers::pi);

// 1 + g² − 2 g mu as a sum of non-negative terms: at the forward peak (mu → 1, g → 1)
// the direct form cancels to 0 in float and the phase function would be +inf.
template <class T>
T hg_denominator(T mu, T g) {
    return g >= T(0) ? (T(1) - g) * (T(1) - g) + T(2) * g * (T(1) - mu)
                     : (T(1) + g) * (T(1) + g) - T(2) * g * (T(1) + mu);
}
}  // namespace

template <class T>
T phase_rayleigh(T mu) {
    // 3/(16π) (1 + mu²) (Rayleigh; seed 004 §1.5 F_R = 3/4 (1 + mu²) per 4π)
    return T(3.0 / (16.0 * std::numbers::pi)) * (T(1) + mu * mu);
}

template <class T>
T phase_rayleigh_modified(T mu) {
    // Seed 004 §1.5: 0.8 (1.4 + 0.5 mu²), whose sphere mean is 1.2533, renormalised:
    // mean of (1.4 + 0.5 mu²) is 1.4 + 0.5/3 = 47/30.
    return T(30.0 / 47.0) * inv_4pi<T> * (T(1.4) + T(0.5) * mu * mu);
}

template <class T>
T phase_cornette_shanks(T mu, T g) {
    // Cornette & Shanks 1992, as in Bruneton 2017 (seed 004 §1.5 with g → −g).
    const T g2 = g * g;
    const T k = T(3.0 / (8.0 * std::numbers::pi)) * (T(1) - g2) / (T(2) + g2);
    const T d = hg_denominator(mu, g);  // ≥ (1 − |g|)² > 0
    return k * (T(1) + mu * mu) / (d * std::sqrt(d));
}

template <class T>
T phase_henyey_greenstein(T mu, T g) {
    const T g2 = g * g;
    const T d = hg_denominator(mu, g);
    return inv_4pi<T> * (T(1) - g2) / (d * std::sqrt(d));
}

template <class T>
T phase_isotropic() {
    return inv_4pi<T>;
}

template <class T>
T phase(const PhaseFunction& f, T mu) {
    const T g = static_cast<T>(f.g);
    switch (f.kind) {
        case PhaseFunction::Kind::rayleigh: return phase_rayleigh(mu);
        case PhaseFunction::Kind::rayleigh_modified: return phase_rayleigh_modified(mu);
        case PhaseFunction::Kind::cornette_shanks: return phase_cornette_shanks(mu, g);
        case PhaseFunction::Kind::henyey_greenstein: return phase_henyey_greenstein(mu, g);
        case PhaseFunction::Kind::isotropic: return phase_isotropic<T>();
    }
    return phase_isotropic<T>();
}

bool is_rayleigh_like(const PhaseFunction& f) {
    return f.kind == PhaseFunction::Kind::rayleigh || f.kind == PhaseFunction::Kind::rayleigh_modified;
}

double henyey_greenstein_g(const PhaseFunction& f) {
    switch (f.kind) {
        case PhaseFunction::Kind::henyey_greenstein: return f.g;
        case PhaseFunction::Kind::cornette_shanks: return 3.0 * f.g * (4.0 + f.g * f.g) / (5.0 * (2.0 + f.g * f.g));
        case PhaseFunction::Kind::rayleigh:
        case PhaseFunction::Kind::rayleigh_modified:
        case PhaseFunction::Kind::isotropic: return 0.0;
    }
    return 0.0;
}

#define AIRMASS_INSTANTIATE(T)                                \
    template T phase_rayleigh<T>(T);                          \
    template T phase_rayleigh_modified<T>(T);                 \
    template T phase_cornette_shanks<T>(T, T);                \
    template T phase_henyey_greenstein<T>(T, T);              \
    template T phase_isotropic<T>();                          \
    template T phase<T>(const PhaseFunction&, T);
AIRMASS_INSTANTIATE(float)
AIRMASS_INSTANTIATE(double)
#undef AIRMASS_INSTANTIATE

}  // namespace airmass
