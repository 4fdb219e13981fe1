// Shared helpers of the libFuzzer targets (docs/reliability.md).
//
// Oracle: the project rule is that bad input gets a clear, named error (SceneError, SkyError,
// std::invalid_argument, CliError, a non-OK airmass_status with a message) and never a crash,
// a hang, undefined behaviour or a silent Inf/NaN. So every target catches exactly the
// documented error types and lets anything else escape (libFuzzer reports an uncaught
// exception as a crash), and require() aborts on a broken property of a result.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <span>

namespace airmass::fuzz {

inline void require(bool ok, const char* what) {
    if (!ok) {
        std::fprintf(stderr, "fuzz property violated: %s\n", what);
        std::abort();
    }
}

template <class T>
void require_finite_non_negative(std::span<const T> values, const char* what) {
    for (std::size_t i = 0; i < values.size(); ++i)
        if (!(std::isfinite(values[i]) && values[i] >= T(0))) {
            std::fprintf(stderr, "%s[%zu] of %zu = %.9g\n", what, i, values.size(), double(values[i]));
            require(false, what);
        }
}

}  // namespace airmass::fuzz
