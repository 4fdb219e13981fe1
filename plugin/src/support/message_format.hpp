// Small helpers the camera and render code share for their error messages and checks.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>

#include <glm/vec3.hpp>

namespace airmass::detail {

// A number as error messages print it: 9 significant digits (a float's worth, enough to
// recognise the value the user typed).
inline std::string message_number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g", v);
    return buf;
}

inline bool all_finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace airmass::detail
