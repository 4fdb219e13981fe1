// int_in / number_in (commands.hpp): the range checks of the CLI's numeric options.
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "commands.hpp"
#include "sun_options.hpp"

namespace airmass::cli {

namespace {

// Text that reads back as `v`: "90", "273.15", "1e6" (not "1e+06"), "inf".
std::string bound_text(double v) {
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    char buf[40];
    // Whole digits below 1e6 ("90", "5000"), the shortest round trip otherwise ("1e6", "0.25").
    const double a = std::abs(v);
    const int first = a >= 1.0 && a < 1e6 ? int(std::floor(std::log10(a))) + 1 : 1;
    for (int digits = first; digits <= 17; ++digits) {
        std::snprintf(buf, sizeof buf, "%.*g", digits, v);
        if (std::strtod(buf, nullptr) == v) break;
    }
    std::string s = buf;
    // "1e+06" -> "1e6", "1e-05" -> "1e-5"
    const auto e = s.find('e');
    if (e != std::string::npos) {
        std::string mant = s.substr(0, e), exp = s.substr(e + 1);
        const bool neg = !exp.empty() && exp[0] == '-';
        if (!exp.empty() && (exp[0] == '+' || exp[0] == '-')) exp.erase(0, 1);
        while (exp.size() > 1 && exp[0] == '0') exp.erase(0, 1);
        s = mant + "e" + (neg ? "-" : "") + exp;
    }
    return s;
}

bool blank(char c) { return c == ' ' || c == '\t'; }

// The whole text (blanks around allowed) as a number; false for anything else.
bool whole_double(const std::string& text, double& out) {
    const char* begin = text.c_str();
    while (blank(*begin)) ++begin;
    if (*begin == '\0') return false;
    char* end = nullptr;
    errno = 0;
    out = std::strtod(begin, &end);
    if (end == begin) return false;
    while (blank(*end)) ++end;
    return *end == '\0';
}

bool whole_integer(const std::string& text, long long& out) {
    const char* begin = text.c_str();
    while (blank(*begin)) ++begin;
    if (*begin == '\0') return false;
    char* end = nullptr;
    errno = 0;
    out = std::strtoll(begin, &end, 10);
    if (end == begin || errno == ERANGE) return false;
    while (blank(*end)) ++end;
    return *end == '\0';
}

}  // namespace

CLI::Validator int_in(long long lo, long long hi) {
    const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    return CLI::Validator(
        [lo, hi, range](std::string& text) -> std::string {
            long long v = 0;
            if (whole_integer(text, v) && v >= lo && v <= hi) return {};
            return "'" + text + "': must be an integer in " + range;
        },
        "in " + range);
}

CLI::Validator number_in(double lo, double hi, Ends ends) { return number_in(lo, hi, ends, nullptr, nullptr); }

CLI::Validator number_in(double lo, double hi, Ends ends, const char* field, const char* unit) {
    const bool open_low = ends == Ends::open_low || ends == Ends::open;
    const bool open_high = ends == Ends::open_high || ends == Ends::open;
    const std::string range =
        std::string(open_low ? "(" : "[") + bound_text(lo) + ", " + bound_text(hi) + (open_high ? ")" : "]");
    return CLI::Validator(
        [lo, hi, open_low, open_high, range, name = std::string(field ? field : ""),
         units = std::string(unit ? unit : "")](std::string& text) -> std::string {
            double v = 0.0;
            // NaN fails every comparison; ±inf only passes an infinite closed bound.
            if (whole_double(text, v) && (open_low ? v > lo : v >= lo) && (open_high ? v < hi : v <= hi)) return {};
            if (!name.empty()) return name + " = " + text + ": must be in " + range + (units.empty() ? "" : " " + units);
            return "'" + text + "': must be a number in " + range;
        },
        "in " + range);
}

}  // namespace airmass::cli
