// Minimal CSV reading for the CLI's stdin queries: numeric rows, an optional header
// line, '#' comments and blank lines skipped; every error names the line.
#pragma once

#include <cstddef>
#include <istream>
#include <string>
#include <vector>

namespace airmass::cli {

struct NumericRow {
    std::size_t line;            // 1-based line number in the input
    std::vector<double> values;
};

// Reads rows of exactly `columns` finite numbers. The first non-comment line may be a
// header (it is skipped when its first field is not a number). Throws CliError naming
// the line and the field on anything else.
std::vector<NumericRow> read_numeric_rows(std::istream& in, const std::vector<std::string>& column_names);

// Shortest round-trip text for a double with 17 significant digits ("inf", "-inf", "nan" as such).
std::string format_g17(double v);

}  // namespace airmass::cli
