// NREL's Solar Position Algorithm (Reda & Andreas 2004/2008), written from the published
// algorithm: the step numbers below are the report's sections (3.1 … 3.15). The periodic
// terms are the report's Tables A4.2 (Earth: L0–L5, B0–B1, R0–R4, in 1e-8 rad / 1e-8 AU)
// and A4.3 (nutation in longitude and obliquity, 0.0001″). Times are proleptic Gregorian.
#include "airmass/solar_position.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "support/message_format.hpp"

namespace airmass {

namespace {

using detail::message_number;

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kJd1970 = 2440587.5;  // JD of 1970-01-01T00:00 UT
constexpr double kJ2000 = 2451545.0;

double limit_degrees(double d) {
    d = std::fmod(d, 360.0);
    return d < 0.0 ? d + 360.0 : d;
}

// ---- Table A4.2: Earth periodic terms (A, B, C): A·cos(B + C·JME) -------------------------
struct PeriodicTerm {
    double a, b, c;
};

constexpr PeriodicTerm kL0[] = {
    {175347046, 0, 0}, {3341656, 4.6692568, 6283.07585}, {34894, 4.6261, 12566.1517},
    {3497, 2.7441, 5753.3849}, {3418, 2.8289, 3.5231}, {3136, 3.6277, 77713.7715},
    {2676, 4.4181, 7860.4194}, {2343, 6.1352, 3930.2097}, {1324, 0.7425, 11506.7698},
    {1273, 2.0371, 529.691}, {1199, 1.1096, 1577.3435}, {990, 5.233, 5884.927},
    {902, 2.045, 26.298}, {857, 3.508, 398.149}, {780, 1.179, 5223.694},
    {753, 2.533, 5507.553}, {505, 4.583, 18849.228}, {492, 4.205, 775.523},
    {357, 2.92, 0.067}, {317, 5.849, 11790.629}, {284, 1.899, 796.298},
    {271, 0.315, 10977.079}, {243, 0.345, 5486.778}, {206, 4.806, 2544.314},
    {205, 1.869, 5573.143}, {202, 2.4458, 6069.777}, {156, 0.833, 213.299},
    {132, 3.411, 2942.463}, {126, 1.083, 20.775}, {115, 0.645, 0.98},
    {103, 0.636, 4694.003}, {102, 0.976, 15720.839}, {102, 4.267, 7.114},
    {99, 6.21, 2146.17}, {98, 0.68, 155.42}, {86, 5.98, 161000.69},
    {85, 1.3, 6275.96}, {85, 3.67, 71430.7}, {80, 1.81, 17260.15},
    {79, 3.04, 12036.46}, {71, 1.76, 5088.63}, {74, 3.5, 3154.69},
    {74, 4.68, 801.82}, {70, 0.83, 9437.76}, {62, 3.98, 8827.39},
    {61, 1.82, 7084.9}, {57, 2.78, 6286.6}, {56, 4.39, 14143.5},
    {56, 3.47, 6279.55}, {52, 0.19, 12139.55}, {52, 1.33, 1748.02},
    {51, 0.28, 5856.48}, {49, 0.49, 1194.45}, {41, 5.37, 8429.24},
    {41, 2.4, 19651.05}, {39, 6.17, 10447.39}, {37, 6.04, 10213.29},
    {37, 2.57, 1059.38}, {36, 1.71, 2352.87}, {36, 1.78, 6812.77},
    {33, 0.59, 17789.85}, {30, 0.44, 83996.85}, {30, 2.74, 1349.87},
    {25, 3.16, 4690.48},
};
constexpr PeriodicTerm kL1[] = {
    {628331966747, 0, 0}, {206059, 2.678235, 6283.07585}, {4303, 2.6351, 12566.1517},
    {425, 1.59, 3.523}, {119, 5.796, 26.298}, {109, 2.966, 1577.344},
    {93, 2.59, 18849.23}, {72, 1.14, 529.69}, {68, 1.87, 398.15},
    {67, 4.41, 5507.55}, {59, 2.89, 5223.69}, {56, 2.17, 155.42},
    {45, 0.4, 796.3}, {36, 0.47, 775.52}, {29, 2.65, 7.11},
    {21, 5.34, 0.98}, {19, 1.85, 5486.78}, {19, 4.97, 213.3},
    {17, 2.99, 6275.96}, {16, 0.03, 2544.31}, {16, 1.43, 2146.17},
    {15, 1.21, 10977.08}, {12, 2.83, 1748.02}, {12, 3.26, 5088.63},
    {12, 5.27, 1194.45}, {12, 2.08, 4694}, {11, 0.77, 553.57},
    {10, 1.3, 3286.6}, {10, 4.24, 1349.87}, {9, 2.7, 242.73},
    {9, 5.64, 951.72}, {8, 5.3, 2352.87}, {6, 2.65, 9437.76},
    {6, 4.67, 4690.48},
};
constexpr PeriodicTerm kL2[] = {
    {52919, 0, 0}, {8720, 1.0721, 6283.0758}, {309, 0.867, 12566.152},
    {27, 0.05, 3.52}, {16, 5.19, 26.3}, {16, 3.68, 155.42},
    {10, 0.76, 18849.23}, {9, 2.06, 77713.77}, {7, 0.83, 775.52},
    {5, 4.66, 1577.34}, {4, 1.03, 7.11}, {4, 3.44, 5573.14},
    {3, 5.14, 796.3}, {3, 6.05, 5507.55}, {3, 1.19, 242.73},
    {3, 6.12, 529.69}, {3, 0.31, 398.15}, {3, 2.28, 553.57},
    {2, 4.38, 5223.69}, {2, 3.75, 0.98},
};
constexpr PeriodicTerm kL3[] = {
    {289, 5.844, 6283.076}, {35, 0, 0}, {17, 5.49, 12566.15},
    {3, 5.2, 155.42}, {1, 4.72, 3.52}, {1, 5.3, 18849.23},
    {1, 5.97, 242.73},
};
constexpr PeriodicTerm kL4[] = {
    {114, 3.142, 0}, {8, 4.13, 6283.08}, {1, 3.84, 12566.15},
};
constexpr PeriodicTerm kL5[] = {
    {1, 3.14, 0},
};
constexpr PeriodicTerm kB0[] = {
    {280, 3.199, 84334.662}, {102, 5.422, 5507.553}, {80, 3.88, 5223.69},
    {44, 3.7, 2352.87}, {32, 4, 1577.34},
};
constexpr PeriodicTerm kB1[] = {
    {9, 3.9, 5507.55}, {6, 1.73, 5223.69},
};
constexpr PeriodicTerm kR0[] = {
    {100013989, 0, 0}, {1670700, 3.0984635, 6283.07585}, {13956, 3.05525, 12566.1517},
    {3084, 5.1985, 77713.7715}, {1628, 1.1739, 5753.3849}, {1576, 2.8469, 7860.4194},
    {925, 5.453, 11506.77}, {542, 4.564, 3930.21}, {472, 3.661, 5884.927},
    {346, 0.964, 5507.553}, {329, 5.9, 5223.694}, {307, 0.299, 5573.143},
    {243, 4.273, 11790.629}, {212, 5.847, 1577.344}, {186, 5.022, 10977.079},
    {175, 3.012, 18849.228}, {110, 5.055, 5486.778}, {98, 0.89, 6069.78},
    {86, 5.69, 15720.84}, {86, 1.27, 161000.69}, {85, 0.27, 17260.15},
    {63, 0.92, 529.69}, {57, 2.01, 83996.85}, {56, 5.24, 71430.7},
    {49, 3.25, 2544.31}, {47, 2.58, 775.52}, {45, 5.54, 9437.76},
    {43, 6.01, 6275.96}, {39, 5.36, 4694}, {38, 2.39, 8827.39},
    {37, 0.83, 19651.05}, {37, 4.9, 12139.55}, {36, 1.67, 12036.46},
    {35, 1.84, 2942.46}, {33, 0.24, 7084.9}, {32, 0.18, 5088.63},
    {32, 1.78, 398.15}, {28, 1.21, 6286.6}, {28, 1.9, 6279.55},
    {26, 4.59, 10447.39},
};
constexpr PeriodicTerm kR1[] = {
    {103019, 1.10749, 6283.07585}, {1721, 1.0644, 12566.1517}, {702, 3.142, 0},
    {32, 1.02, 18849.23}, {31, 2.84, 5507.55}, {25, 1.32, 5223.69},
    {18, 1.42, 1577.34}, {10, 5.91, 10977.08}, {9, 1.42, 6275.96},
    {9, 0.27, 5486.78},
};
constexpr PeriodicTerm kR2[] = {
    {4359, 5.7846, 6283.0758}, {124, 5.579, 12566.152}, {12, 3.14, 0},
    {9, 3.63, 77713.77}, {6, 1.87, 5573.14}, {3, 5.47, 18849},
};
constexpr PeriodicTerm kR3[] = {
    {145, 4.273, 6283.076}, {7, 3.92, 12566.15},
};
constexpr PeriodicTerm kR4[] = {
    {4, 2.56, 6283.08},
};

// ---- Table A4.3: nutation. Y: multiples of (D, M, M′, F, Ω); Δψ term (a + b·JCE)·sin,
// Δε term (c + d·JCE)·cos, in 0.0001 arcseconds.
struct NutationTerm {
    int y[5];
    double a, b, c, d;
};

constexpr NutationTerm kNutation[] = {
    {{0, 0, 0, 0, 1}, -171996, -174.2, 92025, 8.9},
    {{-2, 0, 0, 2, 2}, -13187, -1.6, 5736, -3.1},
    {{0, 0, 0, 2, 2}, -2274, -0.2, 977, -0.5},
    {{0, 0, 0, 0, 2}, 2062, 0.2, -895, 0.5},
    {{0, 1, 0, 0, 0}, 1426, -3.4, 54, -0.1},
    {{0, 0, 1, 0, 0}, 712, 0.1, -7, 0},
    {{-2, 1, 0, 2, 2}, -517, 1.2, 224, -0.6},
    {{0, 0, 0, 2, 1}, -386, -0.4, 200, 0},
    {{0, 0, 1, 2, 2}, -301, 0, 129, -0.1},
    {{-2, -1, 0, 2, 2}, 217, -0.5, -95, 0.3},
    {{-2, 0, 1, 0, 0}, -158, 0, 0, 0},
    {{-2, 0, 0, 2, 1}, 129, 0.1, -70, 0},
    {{0, 0, -1, 2, 2}, 123, 0, -53, 0},
    {{2, 0, 0, 0, 0}, 63, 0, 0, 0},
    {{0, 0, 1, 0, 1}, 63, 0.1, -33, 0},
    {{2, 0, -1, 2, 2}, -59, 0, 26, 0},
    {{0, 0, -1, 0, 1}, -58, -0.1, 32, 0},
    {{0, 0, 1, 2, 1}, -51, 0, 27, 0},
    {{-2, 0, 2, 0, 0}, 48, 0, 0, 0},
    {{0, 0, -2, 2, 1}, 46, 0, -24, 0},
    {{2, 0, 0, 2, 2}, -38, 0, 16, 0},
    {{0, 0, 2, 2, 2}, -31, 0, 13, 0},
    {{0, 0, 2, 0, 0}, 29, 0, 0, 0},
    {{-2, 0, 1, 2, 2}, 29, 0, -12, 0},
    {{0, 0, 0, 2, 0}, 26, 0, 0, 0},
    {{-2, 0, 0, 2, 0}, -22, 0, 0, 0},
    {{0, 0, -1, 2, 1}, 21, 0, -10, 0},
    {{0, 2, 0, 0, 0}, 17, -0.1, 0, 0},
    {{2, 0, -1, 0, 1}, 16, 0, -8, 0},
    {{-2, 2, 0, 2, 2}, -16, 0.1, 7, 0},
    {{0, 1, 0, 0, 1}, -15, 0, 9, 0},
    {{-2, 0, 1, 0, 1}, -13, 0, 7, 0},
    {{0, -1, 0, 0, 1}, -12, 0, 6, 0},
    {{0, 0, 2, -2, 0}, 11, 0, 0, 0},
    {{2, 0, -1, 2, 1}, -10, 0, 5, 0},
    {{2, 0, 1, 2, 2}, -8, 0, 3, 0},
    {{0, 1, 0, 2, 2}, 7, 0, -3, 0},
    {{-2, 1, 1, 0, 0}, -7, 0, 0, 0},
    {{0, -1, 0, 2, 2}, -7, 0, 3, 0},
    {{2, 0, 0, 2, 1}, -7, 0, 3, 0},
    {{2, 0, 1, 0, 0}, 6, 0, 0, 0},
    {{-2, 0, 2, 2, 2}, 6, 0, -3, 0},
    {{-2, 0, 1, 2, 1}, 6, 0, -3, 0},
    {{2, 0, -2, 0, 1}, -6, 0, 3, 0},
    {{2, 0, 0, 0, 1}, -6, 0, 3, 0},
    {{0, -1, 1, 0, 0}, 5, 0, 0, 0},
    {{-2, -1, 0, 2, 1}, -5, 0, 3, 0},
    {{-2, 0, 0, 0, 1}, -5, 0, 3, 0},
    {{0, 0, 2, 2, 1}, -5, 0, 3, 0},
    {{-2, 0, 2, 0, 1}, 4, 0, 0, 0},
    {{-2, 1, 0, 2, 1}, 4, 0, 0, 0},
    {{0, 0, 1, -2, 0}, 4, 0, 0, 0},
    {{-1, 0, 1, 0, 0}, -4, 0, 0, 0},
    {{-2, 1, 0, 0, 0}, -4, 0, 0, 0},
    {{1, 0, 0, 0, 0}, -4, 0, 0, 0},
    {{0, 0, 1, 2, 0}, 3, 0, 0, 0},
    {{0, 0, -2, 2, 2}, -3, 0, 0, 0},
    {{-1, -1, 1, 0, 0}, -3, 0, 0, 0},
    {{0, 1, 1, 0, 0}, -3, 0, 0, 0},
    {{0, -1, 1, 2, 2}, -3, 0, 0, 0},
    {{2, -1, -1, 2, 2}, -3, 0, 0, 0},
    {{0, 0, 3, 2, 2}, -3, 0, 0, 0},
    {{2, -1, 0, 2, 2}, -3, 0, 0, 0},
};

template <std::size_t N>
double series(const PeriodicTerm (&terms)[N], double jme) {
    double sum = 0.0;
    for (const PeriodicTerm& t : terms) sum += t.a * std::cos(t.b + t.c * jme);
    return sum;
}

// Σ_i X_i·JME^i / 1e8 (eqs. 10–11: the series' polynomial in the millennium).
double earth_value(std::initializer_list<double> parts, double jme) {
    double value = 0.0, power = 1.0;
    for (double p : parts) {
        value += p * power;
        power *= jme;
    }
    return value / 1e8;
}

// Thrown inside try_parse_utc only.
struct TimeSyntax {
    std::string why;
};
[[noreturn]] void fail(std::string_view, std::string_view, const std::string& why) { throw TimeSyntax{why}; }

void require(bool ok, const char* field, double value, const std::string& range) {
    if (!ok) throw SolarPositionError(std::string(field) + " = " + message_number(value) + ": must be " + range);
}

std::chrono::sys_days to_sys_days(std::int64_t days) {
    return std::chrono::sys_days{std::chrono::days{days}};
}

}  // namespace

// ---- Time ------------------------------------------------------------------------------

UtcTime parse_utc(std::string_view text, std::string_view field) {
    std::string why;
    const auto t = try_parse_utc(text, &why);
    if (!t) throw SolarPositionError(std::string(field) + " '" + std::string(text) + "': " + why);
    return *t;
}

namespace {

UtcTime parse_utc_or_throw(std::string_view text) {
    const std::string_view field;
    const char* const expect =
        "expected an ISO 8601 time YYYY-MM-DDThh:mm[:ss[.fff]] with Z or an offset such as +02:00, e.g. "
        "2026-06-21T12:00:00Z";
    std::string_view s = text;
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
    std::size_t pos = 0;
    const auto digits = [&](std::size_t n, int& out) {
        if (pos + n > s.size()) return false;
        int v = 0;
        for (std::size_t k = 0; k < n; ++k) {
            const char c = s[pos + k];
            if (c < '0' || c > '9') return false;
            v = v * 10 + (c - '0');
        }
        out = v;
        pos += n;
        return true;
    };
    const auto literal = [&](char c) {
        if (pos < s.size() && s[pos] == c) {
            ++pos;
            return true;
        }
        return false;
    };
    int year = 0, month = 0, day = 0, hour = 0, minute = 0, whole_second = 0;
    double fraction = 0.0;
    if (!digits(4, year) || !literal('-') || !digits(2, month) || !literal('-') || !digits(2, day))
        fail(field, text, expect);
    if (!(literal('T') || literal('t') || literal(' '))) fail(field, text, expect);
    if (!digits(2, hour) || !literal(':') || !digits(2, minute)) fail(field, text, expect);
    if (literal(':')) {
        if (!digits(2, whole_second)) fail(field, text, expect);
        if (literal('.') || literal(',')) {
            double scale = 0.1;
            const std::size_t start = pos;
            while (pos < s.size() && s[pos] >= '0' && s[pos] <= '9') {
                fraction += (s[pos] - '0') * scale;
                scale *= 0.1;
                ++pos;
            }
            if (pos == start) fail(field, text, expect);
        }
    }
    int offset_minutes = 0;
    if (literal('Z') || literal('z')) {
    } else if (pos < s.size() && (s[pos] == '+' || s[pos] == '-')) {
        const int sign = s[pos] == '-' ? -1 : 1;
        ++pos;
        int oh = 0, om = 0;
        if (!digits(2, oh)) fail(field, text, expect);
        if (literal(':')) {
            if (!digits(2, om)) fail(field, text, expect);
        } else if (pos < s.size()) {
            if (!digits(2, om)) fail(field, text, expect);
        }
        if (oh > 23 || om > 59) fail(field, text, "the UTC offset must be within ±23:59");
        offset_minutes = sign * (oh * 60 + om);
    } else {
        fail(field, text, pos == s.size() ? std::string("no time zone: end the time with Z for UTC (or an offset such "
                                                        "as +02:00)")
                                          : std::string(expect));
    }
    if (pos != s.size()) fail(field, text, expect);
    if (year < kSolarMinYear || year > kSolarMaxYear)
        fail(field, text,
             "year " + std::to_string(year) + " is outside [" + std::to_string(kSolarMinYear) + ", " +
                 std::to_string(kSolarMaxYear) + "] (the Solar Position Algorithm's range)");
    if (month < 1 || month > 12) fail(field, text, "month " + std::to_string(month) + " is not in [1, 12]");
    const std::chrono::year_month_day ymd{std::chrono::year{year}, std::chrono::month{unsigned(month)},
                                          std::chrono::day{unsigned(day)}};
    if (!ymd.ok()) fail(field, text, "day " + std::to_string(day) + " does not exist in that month");
    if (hour > 23) fail(field, text, "hour " + std::to_string(hour) + " is not in [0, 23]");
    if (minute > 59) fail(field, text, "minute " + std::to_string(minute) + " is not in [0, 59]");
    if (whole_second > 60) fail(field, text, "second " + std::to_string(whole_second) + " is not in [0, 60]");
    UtcTime t;
    t.days = std::chrono::sys_days{ymd}.time_since_epoch().count();
    t.seconds = 0.0;
    return add_seconds(t, hour * 3600.0 + minute * 60.0 + whole_second + fraction - offset_minutes * 60.0);
}

}  // namespace

std::optional<UtcTime> try_parse_utc(std::string_view text, std::string* why) {
    try {
        return parse_utc_or_throw(text);
    } catch (const TimeSyntax& e) {
        if (why) *why = e.why;
        return std::nullopt;
    }
}

UtcTime add_seconds(const UtcTime& t, double seconds) {
    UtcTime out = t;
    const double whole_days = std::floor(seconds / 86400.0);
    out.days += static_cast<std::int64_t>(whole_days);
    out.seconds += seconds - whole_days * 86400.0;
    const double carry = std::floor(out.seconds / 86400.0);
    out.days += static_cast<std::int64_t>(carry);
    out.seconds -= carry * 86400.0;
    if (out.seconds < 0.0) out.seconds = 0.0;  // rounding of a tiny negative remainder
    return out;
}

double seconds_between(const UtcTime& a, const UtcTime& b) {
    return double(b.days - a.days) * 86400.0 + (b.seconds - a.seconds);
}

std::string format_utc(const UtcTime& t) {
    // Milliseconds, rounded, carried into the date when they reach a whole day.
    std::int64_t ms = std::llround(t.seconds * 1000.0);
    std::int64_t days = t.days;
    if (ms >= 86400000) {
        ms -= 86400000;
        ++days;
    }
    const std::chrono::year_month_day ymd{to_sys_days(days)};
    const int h = int(ms / 3600000), m = int(ms / 60000 % 60), sec = int(ms / 1000 % 60), frac = int(ms % 1000);
    char buf[64];
    std::snprintf(buf, sizeof buf, "%04d-%02u-%02uT%02d:%02d:%02d", int(ymd.year()), unsigned(ymd.month()),
                  unsigned(ymd.day()), h, m, sec);
    std::string out = buf;
    if (frac != 0) {
        std::snprintf(buf, sizeof buf, ".%03d", frac);
        std::string f = buf;
        while (f.back() == '0') f.pop_back();
        out += f;
    }
    return out + "Z";
}

double julian_day(const UtcTime& t) { return kJd1970 + double(t.days) + t.seconds / 86400.0; }

double decimal_year(const UtcTime& t) {
    const std::chrono::year_month_day ymd{to_sys_days(t.days)};
    const std::chrono::year y = ymd.year();
    const auto start = std::chrono::sys_days{y / std::chrono::January / 1};
    const auto next = std::chrono::sys_days{(y + std::chrono::years{1}) / std::chrono::January / 1};
    const double into = double((to_sys_days(t.days) - start).count()) + t.seconds / 86400.0;
    return int(y) + into / double((next - start).count());
}

double delta_t_espenak_meeus(double y) {
    if (y < -500.0) {
        const double u = (y - 1820.0) / 100.0;
        return -20.0 + 32.0 * u * u;
    }
    if (y < 500.0) {
        const double u = y / 100.0;
        return 10583.6 + u * (-1014.41 + u * (33.78311 + u * (-5.952053 + u * (-0.1798452 + u * (0.022174192 +
                                                                                                  u * 0.0090316521)))));
    }
    if (y < 1600.0) {
        const double u = (y - 1000.0) / 100.0;
        return 1574.2 + u * (-556.01 + u * (71.23472 + u * (0.319781 + u * (-0.8503463 + u * (-0.005050998 +
                                                                                               u * 0.0083572073)))));
    }
    if (y < 1700.0) {
        const double t = y - 1600.0;
        return 120.0 + t * (-0.9808 + t * (-0.01532 + t / 7129.0));
    }
    if (y < 1800.0) {
        const double t = y - 1700.0;
        return 8.83 + t * (0.1603 + t * (-0.0059285 + t * (0.00013336 - t / 1174000.0)));
    }
    if (y < 1860.0) {
        const double t = y - 1800.0;
        return 13.72 + t * (-0.332447 + t * (0.0068612 + t * (0.0041116 + t * (-0.00037436 + t * (0.0000121272 +
                                                                                                    t * (-0.0000001699 +
                                                                                                         t * 0.000000000875))))));
    }
    if (y < 1900.0) {
        const double t = y - 1860.0;
        return 7.62 + t * (0.5737 + t * (-0.251754 + t * (0.01680668 + t * (-0.0004473624 + t / 233174.0))));
    }
    if (y < 1920.0) {
        const double t = y - 1900.0;
        return -2.79 + t * (1.494119 + t * (-0.0598939 + t * (0.0061966 - t * 0.000197)));
    }
    if (y < 1941.0) {
        const double t = y - 1920.0;
        return 21.20 + t * (0.84493 + t * (-0.076100 + t * 0.0020936));
    }
    if (y < 1961.0) {
        const double t = y - 1950.0;
        return 29.07 + t * (0.407 + t * (-1.0 / 233.0 + t / 2547.0));
    }
    if (y < 1986.0) {
        const double t = y - 1975.0;
        return 45.45 + t * (1.067 + t * (-1.0 / 260.0 - t / 718.0));
    }
    if (y < 2005.0) {
        const double t = y - 2000.0;
        return 63.86 + t * (0.3345 + t * (-0.060374 + t * (0.0017275 + t * (0.000651814 + t * 0.00002373599))));
    }
    if (y < 2050.0) {
        const double t = y - 2000.0;
        return 62.92 + t * (0.32217 + t * 0.005589);
    }
    const double u = (y - 1820.0) / 100.0;
    if (y < 2150.0) return -20.0 + 32.0 * u * u - 0.5628 * (2150.0 - y);
    return -20.0 + 32.0 * u * u;
}

// ---- The algorithm ---------------------------------------------------------------------

void validate(const SolarPositionInput& in) {
    require(std::isfinite(in.latitude_deg) && std::abs(in.latitude_deg) <= 90.0, "latitude_deg", in.latitude_deg,
            "in [-90, 90] degrees");
    require(std::isfinite(in.longitude_deg) && std::abs(in.longitude_deg) <= 180.0, "longitude_deg",
            in.longitude_deg, "in [-180, 180] degrees (east positive)");
    require(std::isfinite(in.elevation_m) && in.elevation_m >= -10000.0 && in.elevation_m <= 1e7, "elevation_m",
            in.elevation_m, "in [-10000, 1e7] metres above sea level");
    if (in.delta_t_s)
        require(std::isfinite(*in.delta_t_s) && std::abs(*in.delta_t_s) <= kMaxAbsDeltaT, "delta_t_s", *in.delta_t_s,
                "in [-100000, 100000] seconds (TT - UT1)");
    require(std::isfinite(in.delta_ut1_s) && std::abs(in.delta_ut1_s) <= kMaxAbsDeltaUt1, "delta_ut1_s",
            in.delta_ut1_s, "in [-1, 1] seconds (UT1 - UTC)");
    require(std::isfinite(in.time.seconds) && in.time.seconds >= 0.0 && in.time.seconds < 86400.0, "time.seconds",
            in.time.seconds, "in [0, 86400)");
    if (in.refraction) {
        require(std::isfinite(in.pressure_mbar) && in.pressure_mbar > 0.0 && in.pressure_mbar <= 5000.0,
                "pressure_mbar", in.pressure_mbar, "in (0, 5000] mbar");
        // Not down to -273.15: eq. 42's 283 / (273 + T) is infinite at T = -273 and flips sign
        // below; near it the "refraction" was thousands of degrees (fuzz_csv). From -120 °C (Earth's
        // coldest air is about -89 °C) with the highest pressure, 5000 mbar, the correction stays
        // below 6° at the horizon and the elevation within [-90, 90].
        require(std::isfinite(in.temperature_c) && in.temperature_c >= -120.0 && in.temperature_c < 1000.0,
                "temperature_c", in.temperature_c, "in [-120, 1000) degrees Celsius");
    }
}

SolarPosition solar_position(const SolarPositionInput& in) {
    validate(in);
    SolarPosition out;
    // 3.1 Julian day (UT1 = UTC + ΔUT1), ephemeris day, centuries and millennia.
    const double jd = julian_day(in.time) + in.delta_ut1_s / 86400.0;
    const double delta_t = in.delta_t_s ? *in.delta_t_s : delta_t_espenak_meeus(decimal_year(in.time));
    const double jde = jd + delta_t / 86400.0;
    const double jc = (jd - kJ2000) / 36525.0;
    const double jce = (jde - kJ2000) / 36525.0;
    const double jme = jce / 10.0;
    out.julian_day = jd;
    out.julian_ephemeris_day = jde;
    out.delta_t_s = delta_t;

    // 3.2 Earth heliocentric longitude, latitude and radius vector.
    const double l_rad = earth_value({series(kL0, jme), series(kL1, jme), series(kL2, jme), series(kL3, jme),
                                      series(kL4, jme), series(kL5, jme)},
                                     jme);
    const double b_rad = earth_value({series(kB0, jme), series(kB1, jme)}, jme);
    const double r_au = earth_value({series(kR0, jme), series(kR1, jme), series(kR2, jme), series(kR3, jme),
                                     series(kR4, jme)},
                                    jme);
    const double L = limit_degrees(l_rad / kDeg);
    const double B = b_rad / kDeg;
    out.heliocentric_longitude_deg = L;
    out.heliocentric_latitude_deg = B;
    out.earth_radius_vector_au = r_au;

    // 3.3 Geocentric longitude and latitude.
    const double theta = limit_degrees(L + 180.0);
    const double beta = -B;

    // 3.4 Nutation in longitude and obliquity.
    const double x[5] = {
        297.85036 + jce * (445267.111480 + jce * (-0.0019142 + jce / 189474.0)),  // D, Moon–Sun elongation
        357.52772 + jce * (35999.050340 + jce * (-0.0001603 - jce / 300000.0)),   // M, Sun's mean anomaly
        134.96298 + jce * (477198.867398 + jce * (0.0086972 + jce / 56250.0)),    // M′, Moon's mean anomaly
        93.27191 + jce * (483202.017538 + jce * (-0.0036825 + jce / 327270.0)),   // F, Moon's argument of latitude
        125.04452 + jce * (-1934.136261 + jce * (0.0020708 + jce / 450000.0)),    // Ω, Moon's ascending node
    };
    double dpsi = 0.0, deps = 0.0;
    for (const NutationTerm& t : kNutation) {
        double arg = 0.0;
        for (int j = 0; j < 5; ++j) arg += x[j] * t.y[j];
        arg *= kDeg;
        dpsi += (t.a + t.b * jce) * std::sin(arg);
        deps += (t.c + t.d * jce) * std::cos(arg);
    }
    dpsi /= 36000000.0;
    deps /= 36000000.0;
    out.nutation_longitude_deg = dpsi;
    out.nutation_obliquity_deg = deps;

    // 3.5 True obliquity of the ecliptic (Laskar's polynomial in U = JME/10, arcseconds).
    const double u = jme / 10.0;
    const double eps0 =
        84381.448 +
        u * (-4680.93 + u * (-1.55 + u * (1999.25 + u * (-51.38 + u * (-249.67 + u * (-39.05 + u * (7.12 +
                                                                                                     u * (27.87 + u * (5.79 + u * 2.45)))))))));
    const double eps = eps0 / 3600.0 + deps;
    out.true_obliquity_deg = eps;

    // 3.6 Aberration, 3.7 apparent sun longitude.
    const double dtau = -20.4898 / (3600.0 * r_au);
    const double lambda = theta + dpsi + dtau;
    out.apparent_longitude_deg = limit_degrees(lambda);

    // 3.8 Apparent sidereal time at Greenwich.
    const double nu0 = limit_degrees(280.46061837 + 360.98564736629 * (jd - kJ2000) + jc * jc * (0.000387933 - jc / 38710000.0));
    const double nu = nu0 + dpsi * std::cos(eps * kDeg);
    out.apparent_sidereal_time_deg = limit_degrees(nu);

    // 3.9–3.10 Geocentric right ascension and declination.
    const double lr = lambda * kDeg, er = eps * kDeg, br = beta * kDeg;
    const double alpha = limit_degrees(
        std::atan2(std::sin(lr) * std::cos(er) - std::tan(br) * std::sin(er), std::cos(lr)) / kDeg);
    const double delta = std::asin(std::sin(br) * std::cos(er) + std::cos(br) * std::sin(er) * std::sin(lr)) / kDeg;
    out.right_ascension_deg = alpha;
    out.declination_deg = delta;

    // 3.11 Observer local hour angle.
    const double h = limit_degrees(nu + in.longitude_deg - alpha);

    // 3.12 Topocentric right ascension (parallax) and declination.
    const double xi = 8.794 / (3600.0 * r_au);  // equatorial horizontal parallax of the sun
    const double phi = in.latitude_deg * kDeg;
    const double uu = std::atan(0.99664719 * std::tan(phi));
    const double xx = std::cos(uu) + in.elevation_m / 6378140.0 * std::cos(phi);
    const double yy = 0.99664719 * std::sin(uu) + in.elevation_m / 6378140.0 * std::sin(phi);
    const double xir = xi * kDeg, hr = h * kDeg, dr = delta * kDeg;
    const double dalpha = std::atan2(-xx * std::sin(xir) * std::sin(hr), std::cos(dr) - xx * std::sin(xir) * std::cos(hr));
    const double delta_p = std::atan2((std::sin(dr) - yy * std::sin(xir)) * std::cos(dalpha),
                                      std::cos(dr) - xx * std::sin(xir) * std::cos(hr));
    // 3.13 Topocentric local hour angle.
    const double h_p = hr - dalpha;
    out.topocentric_hour_angle_deg = h_p / kDeg;
    out.topocentric_declination_deg = delta_p / kDeg;

    // 3.14 Topocentric elevation (without, then with refraction) and zenith angle.
    const double e0 =
        std::asin(std::sin(phi) * std::sin(delta_p) + std::cos(phi) * std::cos(delta_p) * std::cos(h_p)) / kDeg;
    double de = 0.0;
    // SPA applies the correction only while the sun's upper limb can be above the horizon
    // (e0 >= −(sun radius 0.26667° + refraction at the horizon 0.5667°)).
    if (in.refraction && e0 >= -(0.26667 + 0.5667))
        de = (in.pressure_mbar / 1010.0) * (283.0 / (273.0 + in.temperature_c)) * 1.02 /
             (60.0 * std::tan((e0 + 10.3 / (e0 + 5.11)) * kDeg));
    const double e = e0 + de;
    out.refraction_deg = de;
    out.elevation_deg = e;
    out.zenith_deg = 90.0 - e;

    // 3.15 Topocentric azimuth, from north eastward.
    const double gamma = std::atan2(std::sin(h_p), std::cos(h_p) * std::sin(phi) - std::tan(delta_p) * std::cos(phi));
    out.azimuth_deg = limit_degrees(gamma / kDeg + 180.0);

    out.blender_elevation_deg = out.elevation_deg;
    out.blender_rotation_deg = out.azimuth_deg;
    return out;
}

}  // namespace airmass
