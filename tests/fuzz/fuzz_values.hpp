// Numbers for the fuzz targets: raw doubles from the input, or (chosen by a byte) the values
// validation code gets wrong — 0, -0, ±Inf, NaN, denormals, 1e±30, 1e±300, bounds of ranges.
#pragma once

#include <fuzzer/FuzzedDataProvider.h>

#include <array>
#include <cstdint>
#include <limits>

namespace airmass::fuzz {

inline double pick_double(FuzzedDataProvider& in, double typical) {
    static constexpr double inf = std::numeric_limits<double>::infinity();
    static constexpr std::array<double, 24> special = {
        0.0, -0.0, 1.0, -1.0, inf, -inf, std::numeric_limits<double>::quiet_NaN(),
        std::numeric_limits<double>::denorm_min(), std::numeric_limits<double>::min(),
        std::numeric_limits<double>::max(), 1e-30, 1e-300, 1e30, 1e300, -1e-30,
        90.0, -90.0, 180.0, 360.0, 1e6, 1e9, 6360e3, 0.5, 0.999999};
    const uint8_t mode = in.ConsumeIntegral<uint8_t>();
    if (mode < 64) return typical;
    if (mode < 128) return special[mode % special.size()];
    if (mode < 192) return typical * in.ConsumeFloatingPointInRange<double>(-4.0, 4.0);
    return in.ConsumeFloatingPoint<double>();
}

inline int32_t pick_int(FuzzedDataProvider& in, int32_t lo, int32_t hi) {
    const uint8_t mode = in.ConsumeIntegral<uint8_t>();
    if (mode < 16) return in.ConsumeIntegral<int32_t>();  // anything, out of range included
    return in.ConsumeIntegralInRange<int32_t>(lo, hi);
}

}  // namespace airmass::fuzz
