// Small helpers the library shares for its error messages and checks.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>

#include <glm/vec3.hpp>

namespace airmass::detail {

// A number as error messages print it: 9 significant digits by default (a float's worth,
// enough to recognise the value the user typed); 17 where a few ulps matter.
inline std::string message_number(double v, int digits = 9) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    return buf;
}

inline bool all_finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace airmass::detail
