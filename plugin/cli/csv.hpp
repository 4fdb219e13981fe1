// Minimal CSV reading for the CLI's stdin queries: numeric rows, an optional header
// line, '#' comments and blank lines skipped; every error names the line.
#pragma once

#include <cstddef>
#include <istream>
#include <string>
#include <string_view>
#include <vector>

#include "airmass/solar_position.hpp"

namespace airmass::cli {

struct NumericRow {
    std::size_t line;            // 1-based line number in the input
    std::vector<double> values;
};

// Reads rows of exactly `columns` finite numbers. The first non-comment line may be a
// header (it is skipped when its first field is not a number). Throws CliError naming
// the line and the field on anything else.
std::vector<NumericRow> read_numeric_rows(std::istream& in, const std::vector<std::string>& column_names);

// Rows of exactly names.size() comma-separated fields, each trimmed of blanks (for inputs
// that mix numbers and text, e.g. `airmass sun`'s latitude_deg,longitude_deg,utc). Comments,
// blank lines and the optional header as read_numeric_rows; a wrong field count throws
// CliError naming the line.
struct TextRow {
    std::size_t line;
    std::vector<std::string> fields;
};
std::vector<TextRow> read_text_rows(std::istream& in, const std::vector<std::string>& column_names);

// A finite number as read_numeric_rows accepts it (blanks around, a leading '+').
bool parse_finite_number(std::string_view text, double& out);

// The stdin readers of the commands, rows read and checked (callable without the CLI: the fuzz
// target tests/fuzz/fuzz_csv.cpp). Throw CliError naming the line, the column and its range.
//   `airmass chapman`: x,chi_deg with x > 0 and chi_deg in [0, 180]; with `single_precision`
//   (--precision float) x must also be a positive float (in [1.4e-45, 3.4e38]).
std::vector<NumericRow> read_chapman_rows(std::istream& in, bool single_precision = false);
//   `airmass eval`: altitude_m in [0, 1e9], view_zenith_deg and sun_zenith_deg in [0, 180],
//   azimuth_deg in [-360, 360].
std::vector<NumericRow> read_eval_rows(std::istream& in);
//   `airmass sun`: latitude_deg,longitude_deg,utc with latitude_deg and longitude_deg finite numbers
//   and utc an ISO 8601 time with a zone (parse_utc). Errors read "line 2: longitude_deg is not a
//   finite number: 'x'", "line 2: utc '...': hour 25 is not in [0, 23]". The ranges of the place
//   (latitude in [-90, 90], ...) are solar_position()'s to check, with the command's options.
struct SunRow {
    std::size_t line;
    double latitude_deg, longitude_deg;
    UtcTime time;
};
std::vector<SunRow> read_sun_rows(std::istream& in);

// A comma-separated list of finite numbers given on the command line ("680,550, 440"),
// surrounding blanks allowed. `what` names the option in errors ("render: --box"); `kind`
// says what each number must be ("a finite number", "a wavelength in nm (a number in
// (0, 1e6))") and `ok` checks it. Throws CliError naming the option, the text and the bad
// part; an empty list, an empty part or a trailing comma is an error.
std::vector<double> parse_number_list(const std::string& text, const std::string& what, const std::string& kind,
                                      bool (*ok)(double) = nullptr);

// Shortest round-trip text for a double with 17 significant digits ("inf", "-inf", "nan" as such).
std::string format_g17(double v);

// Writes a command's whole CSV output to stdout and flushes it; CliError "<command>: cannot
// write the output: <cause>" when that fails (a full disk behind a redirection, a closed pipe
// reported as EPIPE), so the exit status says the output is incomplete.
void write_stdout(std::string_view text, const char* command);

}  // namespace airmass::cli
