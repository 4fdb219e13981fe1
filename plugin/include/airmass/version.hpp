// The library's version (the project version of CMakeLists.txt), defined in one place:
// EXR metadata, the C ABI and `airmass --version` all read it from here.
#pragma once

namespace airmass {

const char* version_string() noexcept;

}  // namespace airmass
