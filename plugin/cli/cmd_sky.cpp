// Placeholder: `airmass sky` is being built (see the open issues).
#include "commands.hpp"

namespace airmass::cli {

void add_sky_command(CLI::App&) {}

}  // namespace airmass::cli
