// Sub-command registration for the `airmass` CLI. Each sub-command lives in its own
// cmd_*.cpp and adds itself to the app (or to the `report` parent); errors are thrown
// as CliError (or SceneError) and printed by main() as "airmass: <message>", exit 2.
#pragma once

#include <CLI/CLI.hpp>
#include <stdexcept>
#include <string>

namespace airmass::cli {

struct CliError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// The one range check of a numeric option (option_checks.cpp), attached where the option is
// added: `cmd->add_option("--width", w, "...")->check(int_in(1, 65536))`. It runs when the
// command line is parsed, before any work or file, on the option's text: anything that is not
// an integer (int_in) or a number (number_in) inside the range — text, "1.5", "1e308", "inf",
// "nan" — is refused as "--width: '0': must be an integer in [1, 65536]" (CLI11 puts the
// option's name first; main() exits 2), and --help shows the range after the type
// ("INT:in [1, 65536]"). `Ends` says which bounds are excluded.
enum class Ends { closed, open_low, open_high, open };
CLI::Validator int_in(long long lo, long long hi);
CLI::Validator number_in(double lo, double hi, Ends ends = Ends::closed);

void add_chapman_command(CLI::App& app);  // cmd_chapman.cpp
void add_eval_command(CLI::App& app);     // cmd_eval.cpp
void add_sky_command(CLI::App& app);      // cmd_sky.cpp
void add_vdb_command(CLI::App& app);      // cmd_vdb.cpp
void add_render_command(CLI::App& app);   // cmd_render.cpp
void add_compare_command(CLI::App& app);  // cmd_compare.cpp
void add_sun_command(CLI::App& app);      // cmd_sun.cpp
void add_pov_command(CLI::App& app);      // cmd_pov.cpp

// `airmass report <topic>`: measured speed-vs-accuracy trade tables.
void add_report_chapman(CLI::App& report);  // cmd_report_chapman.cpp
void add_report_sky(CLI::App& report);      // cmd_report_sky.cpp
void add_report_vdb(CLI::App& report);      // cmd_report_vdb.cpp
void add_report_ms(CLI::App& report);       // cmd_report_ms.cpp

}  // namespace airmass::cli
