// Placeholder: `airmass report sky` is being built (see the open issues).
#include "commands.hpp"

namespace airmass::cli {

void add_report_sky(CLI::App&) {}

}  // namespace airmass::cli
