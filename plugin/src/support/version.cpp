// airmass::version_string (version.hpp): AIRMASS_VERSION_STRING is set for this file only
// (plugin/CMakeLists.txt), so a version bump recompiles one file.
#include "airmass/version.hpp"

#ifndef AIRMASS_VERSION_STRING
#define AIRMASS_VERSION_STRING "unknown"
#endif

namespace airmass {

const char* version_string() noexcept { return AIRMASS_VERSION_STRING; }

}  // namespace airmass
