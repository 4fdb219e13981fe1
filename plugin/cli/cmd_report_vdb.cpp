// Placeholder: `airmass report vdb` is being built (see the open issues).
#include "commands.hpp"

namespace airmass::cli {

void add_report_vdb(CLI::App&) {}

}  // namespace airmass::cli
