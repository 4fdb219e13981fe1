// Placeholder: `airmass eval` is being built (see the open issues).
#include "commands.hpp"

namespace airmass::cli {

void add_eval_command(CLI::App&) {}

}  // namespace airmass::cli
