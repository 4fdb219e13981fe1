// Sub-command registration for the `airmass` CLI. Each sub-command lives in its own
// cmd_*.cpp and adds itself to the app; errors are thrown as CliError and printed
// by main() as "airmass <cmd>: <message>" with exit code 2.
#pragma once

#include <CLI/CLI.hpp>
#include <stdexcept>
#include <string>

namespace airmass::cli {

struct CliError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

void add_chapman_command(CLI::App& app);
void add_report_command(CLI::App& app);

}  // namespace airmass::cli
