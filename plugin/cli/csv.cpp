#include "csv.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string_view>

#include "commands.hpp"

namespace airmass::cli {

namespace {

std::string_view trim(std::string_view s) {
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
    return s;
}

bool parse_double(std::string_view s, double& out) {
    s = trim(s);
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
    return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

std::vector<std::string_view> split(std::string_view line) {
    std::vector<std::string_view> fields;
    size_t start = 0;
    for (;;) {
        const size_t comma = line.find(',', start);
        fields.push_back(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
        if (comma == std::string_view::npos) break;
        start = comma + 1;
    }
    return fields;
}

}  // namespace

namespace {

// Every data row of a CSV stream (comments, blank lines and an optional header skipped),
// checked to have exactly names.size() fields: on_row(line number, fields).
template <class OnRow>
void for_each_row(std::istream& in, const std::vector<std::string>& names, const OnRow& on_row) {
    std::string line;
    size_t line_no = 0;
    bool first = true;
    while (std::getline(in, line)) {
        ++line_no;
        const std::string_view l = trim(line);
        if (l.empty() || l.front() == '#') continue;
        const auto fields = split(l);
        double probe;
        if (first && !parse_double(fields[0], probe)) {  // a header line
            first = false;
            continue;
        }
        first = false;
        if (fields.size() != names.size()) {
            std::string expect;
            for (const auto& n : names) expect += (expect.empty() ? "" : ",") + n;
            throw CliError("line " + std::to_string(line_no) + ": expected " + std::to_string(names.size()) +
                           " comma-separated values (" + expect + "), got " + std::to_string(fields.size()));
        }
        on_row(line_no, fields);
    }
}

}  // namespace

std::vector<NumericRow> read_numeric_rows(std::istream& in, const std::vector<std::string>& names) {
    std::vector<NumericRow> rows;
    for_each_row(in, names, [&](size_t line_no, const auto& fields) {
        NumericRow row{line_no, std::vector<double>(fields.size())};
        for (size_t k = 0; k < fields.size(); ++k) {
            if (!parse_double(fields[k], row.values[k]) || !std::isfinite(row.values[k]))
                throw CliError("line " + std::to_string(line_no) + ": " + names[k] + " is not a finite number: '" +
                               std::string(trim(fields[k])) + "'");
        }
        rows.push_back(std::move(row));
    });
    return rows;
}

std::vector<TextRow> read_text_rows(std::istream& in, const std::vector<std::string>& names) {
    std::vector<TextRow> rows;
    for_each_row(in, names, [&](size_t line_no, const auto& fields) {
        TextRow row{line_no, {}};
        for (const auto f : fields) row.fields.emplace_back(trim(f));
        rows.push_back(std::move(row));
    });
    return rows;
}

std::vector<NumericRow> read_chapman_rows(std::istream& in, bool single_precision) {
    auto rows = read_numeric_rows(in, {"x", "chi_deg"});
    for (const auto& r : rows) {
        if (!(r.values[0] > 0.0))
            throw CliError("chapman: line " + std::to_string(r.line) + ": x must be > 0, got " + format_g17(r.values[0]));
        const float xf = static_cast<float>(r.values[0]);
        if (single_precision && !(xf > 0.0f && xf <= std::numeric_limits<float>::max()))
            throw CliError("chapman: line " + std::to_string(r.line) + ": x must be in [" +
                           format_g17(std::numeric_limits<float>::denorm_min()) + ", " +
                           format_g17(std::numeric_limits<float>::max()) + "] with --precision float, got " +
                           format_g17(r.values[0]));
        if (!(r.values[1] >= 0.0 && r.values[1] <= 180.0))
            throw CliError("chapman: line " + std::to_string(r.line) + ": chi_deg must be in [0, 180], got " +
                           format_g17(r.values[1]));
    }
    return rows;
}

bool parse_finite_number(std::string_view text, double& out) { return parse_double(text, out) && std::isfinite(out); }

std::vector<SunRow> read_sun_rows(std::istream& in) {
    static const std::vector<std::string> names = {"latitude_deg", "longitude_deg", "utc"};
    std::vector<SunRow> rows;
    for (const TextRow& r : read_text_rows(in, names)) {
        const std::string at = "line " + std::to_string(r.line) + ": ";
        double v[2];
        for (int k = 0; k < 2; ++k)
            if (!parse_finite_number(r.fields[k], v[k]))
                throw CliError(at + names[k] + " is not a finite number: '" + r.fields[k] + "'");
        try {
            rows.push_back(SunRow{r.line, v[0], v[1], parse_utc(r.fields[2], "utc")});
        } catch (const SolarPositionError& e) {
            throw CliError(at + e.what());
        }
    }
    return rows;
}

std::vector<NumericRow> read_eval_rows(std::istream& in) {
    auto rows = read_numeric_rows(in, {"altitude_m", "view_zenith_deg", "sun_zenith_deg", "azimuth_deg"});
    for (const auto& r : rows) {
        const auto fail = [&](const char* name, double v, const char* range) {
            throw CliError("eval: line " + std::to_string(r.line) + ": " + name + " = " + format_g17(v) + ": " + range);
        };
        if (!(r.values[0] >= 0.0 && r.values[0] <= 1e9)) fail("altitude_m", r.values[0], "must be in [0, 1e9]");
        if (!(r.values[1] >= 0.0 && r.values[1] <= 180.0)) fail("view_zenith_deg", r.values[1], "must be in [0, 180]");
        if (!(r.values[2] >= 0.0 && r.values[2] <= 180.0)) fail("sun_zenith_deg", r.values[2], "must be in [0, 180]");
        if (!(r.values[3] >= -360.0 && r.values[3] <= 360.0)) fail("azimuth_deg", r.values[3], "must be in [-360, 360]");
    }
    return rows;
}

std::vector<double> parse_number_list(const std::string& text, const std::string& what, const std::string& kind,
                                      bool (*ok)(double)) {
    if (trim(text).empty()) throw CliError(what + ": empty; give " + kind + " values separated by commas");
    std::vector<double> out;
    for (const std::string_view part : split(text)) {
        double v = 0.0;
        if (!parse_double(part, v) || !std::isfinite(v) || (ok && !ok(v)))
            throw CliError(what + " '" + text + "': '" + std::string(trim(part)) + "' is not " + kind);
        out.push_back(v);
    }
    return out;
}

std::string format_g17(double v) {
    if (std::isnan(v)) return "nan";
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

}  // namespace airmass::cli

namespace airmass::cli {

void write_stdout(std::string_view text, const char* command) {
    errno = 0;
    const bool ok = std::fwrite(text.data(), 1, text.size(), stdout) == text.size() && std::fflush(stdout) == 0;
    if (!ok)
        throw CliError(std::string(command) + ": cannot write the output" +
                       (errno != 0 ? std::string(": ") + std::strerror(errno) : std::string()));
}

}  // namespace airmass::cli
