// ZenithAngle: cos and sin of a zenith angle given in degrees, without the loss that
// cos(chi * pi / 180) suffers at 90° (6e-17 instead of 0) and sin suffers at 180°.
// The reduction to the nearest of 0°, 90°, 180° is exact in binary floating point
// (Sterbenz), so what remains is a small angle whose sine and cosine are accurate.
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <numbers>

#include "airmass/chapman.hpp"
#include "support/message_format.hpp"

namespace airmass {

template <class T>
ZenithAngle<T> ZenithAngle<T>::from_degrees(double chi_deg) {
    constexpr double deg = std::numbers::pi / 180.0;
    chi_deg = std::abs(chi_deg);  // Ch is even in chi: make that exact, not merely close
    double c, s;
    if (chi_deg <= 45.0) {
        c = std::cos(chi_deg * deg);
        s = std::sin(chi_deg * deg);
    } else if (chi_deg <= 135.0) {
        const double d = (90.0 - chi_deg) * deg;  // exact subtraction
        c = std::sin(d);
        s = std::cos(d);
    } else {
        const double d = (180.0 - chi_deg) * deg;  // exact subtraction
        c = -std::cos(d);
        s = std::sin(d);
    }
    return {static_cast<T>(c), static_cast<T>(std::abs(s))};
}

template <class T>
ZenithAngle<T> ZenithAngle<T>::from_cos(T cos_chi) {
    // A cosine formed from unit vectors may pass ±1 by rounding: within 16 ulps it is the end.
    constexpr T kRounding = T(16) * std::numeric_limits<T>::epsilon();
    if (!(std::abs(cos_chi) < T(1))) {
        if (!(std::abs(cos_chi) <= T(1) + kRounding))
            throw std::invalid_argument(
                "ZenithAngle::from_cos: cos_chi = " +
                detail::message_number(double(cos_chi), std::numeric_limits<T>::max_digits10) +
                " is outside [-1, 1] (by more than 16 ulps of rounding)");
        return {std::copysign(T(1), cos_chi), T(0)};
    }
    const T s2 = (T(1) - cos_chi) * (T(1) + cos_chi);
    return {cos_chi, std::sqrt(s2 > T(0) ? s2 : T(0))};
}

template struct ZenithAngle<float>;
template struct ZenithAngle<double>;

}  // namespace airmass
