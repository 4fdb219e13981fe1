// Placeholder: `airmass vdb` is being built (see the open issues).
#include "commands.hpp"

namespace airmass::cli {

void add_vdb_command(CLI::App&) {}

}  // namespace airmass::cli
