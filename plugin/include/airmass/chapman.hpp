// The Chapman function family.
//
// Ch(x, chi) is the relative optical air mass of a semi-infinite ray that starts at
// normalised radius x = r / H (H the scale height) in an exponential, spherically
// symmetric atmosphere and leaves with zenith angle chi; it is normalised so that
// Ch(x, 0) = 1 (Schüler 2012, GPU Pro 3 §2.3; Golubev 2019 Eq. 35):
//
//     Ch(x, chi) = ∫_0^∞ exp(x − sqrt(x² + 2 x u cos chi + u²)) du.
//
// Every method here returns a `ScaledChapman`, Ch = mantissa · exp(log_scale), so that
// values far beyond the range of the floating-point type (Ch ≈ 2·e^x at chi = 180°,
// e^(1e7) for x = 1e7) stay representable. From it derive:
//   * chapman()            Ch itself, +inf beyond the type's range;
//   * log_chapman()        ln Ch, always finite;
//   * chapman_rescaled()   Ch(X + h, chi) · exp(−h), Schüler's Ch_h (§2.5.1) and
//                          Golubev's C_r (Eq. 36): the form an optical depth needs.
//
// The angle is passed as the pair (cos chi, sin chi) with sin chi ≥ 0: near 180° the
// sine carries information that rounding the cosine to the type already destroyed,
// and the reflection identity needs x·sin chi. `ZenithAngle` builds the pair from
// degrees without that loss.
#pragma once

#include <cmath>
#include <cstddef>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

namespace airmass {

// Ch = mantissa · exp(log_scale). mantissa is O(1)-to-O(sqrt x); log_scale ≥ 0 is
// nonzero only below the horizon (chi > 90°), where it equals x − x·sin chi.
template <class T>
struct ScaledChapman {
    T mantissa;
    T log_scale;
};

// cos and sin of a zenith angle in [0°, 180°], both accurate to the last bit even at
// exactly 90° and 180° (where cos(M_PI/2) in floating point is 6e-17, not 0).
template <class T>
struct ZenithAngle {
    T cos_chi;
    T sin_chi;  // ≥ 0

    static ZenithAngle from_degrees(double chi_deg);
    // sin from (1 − c)(1 + c): exact for exact c. |c| up to 16 ulps past 1 (rounding) is ±1;
    // beyond that, or NaN, throws std::invalid_argument naming cos_chi.
    static ZenithAngle from_cos(T cos_chi);
};

enum class ChapmanMethod {
    exact,                     // adaptive Gauss–Kronrod quadrature, rel. error ≤ 1e-12
    airmass,                   // ours: bicubic correction table over a rational base
    schuler2012,               // GPU Pro 3 Eq. for Ch', c = sqrt(pi x / 2) ≈ 1.2533 sqrt(x)
    schuler2012_full,          // same rational form with the full Ch∥(x) = (1/2x + 1) sqrt(pi x/2)
    schuler2012_rigged,        // Listing 2.1 chapman_h: c = sqrt(x), 50%-heights, exp2
    schuler2012_rigged_exp2pp, // Listing 2.1 with the Listing 2.3 exp2pp fast exp2
    kocifaj1996,               // closed form with erfcx (Schüler Eq. in §2.3, Golubev Eq. 40)
    golubev2019,               // Golubev Eq. 44/45: erfcx replaced by a rational approximation
};

struct ChapmanMethodInfo {
    ChapmanMethod method;
    std::string_view name;         // CLI name, e.g. "schuler2012-rigged"
    std::string_view description;  // one line: source and what it is
};

// All methods, in the order the reports list them.
std::span<const ChapmanMethodInfo> chapman_methods();
std::optional<ChapmanMethod> chapman_method_from_name(std::string_view name);
std::string_view chapman_method_name(ChapmanMethod m);

// The core evaluation: Ch(x, chi) in scaled form. x > 0, sin_chi ≥ 0.
template <class T>
ScaledChapman<T> chapman_scaled(ChapmanMethod method, T x, ZenithAngle<T> chi);

// Ch(x, chi); +inf where the value exceeds the type's range.
template <class T>
T chapman(ChapmanMethod method, T x, ZenithAngle<T> chi);

// ln Ch(x, chi); finite for every x > 0 and chi in [0°, 180°].
template <class T>
T log_chapman(ChapmanMethod method, T x, ZenithAngle<T> chi);

// Ch(X + h, chi) · exp(−h): the air mass in units of H·rho(X) of a ray starting at
// height h above the reference radius X (both in scale heights). Never overflows in
// an intermediate; it is +inf only where the true value exceeds the type's range
// (rays whose periapsis lies far below X, which a ground would block).
template <class T>
T chapman_rescaled(ChapmanMethod method, T X, T h, ZenithAngle<T> chi);

// Batch form over arrays (same length), scaled output. Loops are branch-light so the
// compiler can vectorise the fast methods. The outputs must not share memory with the inputs
// (the airmass kernel rereads inputs of careful lanes after it has stored whole blocks).
template <class T>
void chapman_scaled_batch(ChapmanMethod method, std::span<const T> x, std::span<const T> cos_chi,
                          std::span<const T> sin_chi, std::span<T> mantissa, std::span<T> log_scale);

// Batch of chapman_rescaled (the same: `out` must not share memory with the inputs).
template <class T>
void chapman_rescaled_batch(ChapmanMethod method, T X, std::span<const T> h, std::span<const T> cos_chi,
                            std::span<const T> sin_chi, std::span<T> out);

// Ch∥(x) = Ch(x, 90°) = x e^x K₁(x), exactly (quadrature / asymptotic series).
double chapman_horizontal_exact(double x);

// Schüler's partial-precision exp2 (GPU Pro 3 Listing 2.3), accurate to ~12 bits.
template <class T>
T exp2pp(T x);

}  // namespace airmass
