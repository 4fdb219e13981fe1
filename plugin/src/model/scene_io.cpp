// Reading, validating and writing scene descriptions: the TOML format of docs/scene.md,
// presets embedded from examples/*.toml, validation with messages that name the field, its
// value and the allowed range, and a compact JSON form for metadata.
//
// Reading happens in three steps:
//   1. parse the TOML text (toml++) and resolve `preset = "..."`: the named preset's table is
//      the base and the file's tables are merged over it (rules in merge_table);
//   2. build the Scene, converting the file's units (km, Dobson units, AU, ...) to the Scene's
//      SI ones; every key read is recorded, and any key left over is an error (typos must not
//      be silently ignored);
//   3. validate() the Scene; its messages name TOML paths, which are mapped back to the source
//      line where the field was written.
#include "airmass/scene_io.hpp"

// toml++ 3.3 (Debian 12) states its parser's preconditions as TOML_ASSERT_ASSUME: an assert()
// without NDEBUG, __builtin_assume under clang with NDEBUG. One of them is false on valid-looking
// bad input: a table header whose '[' is followed by a line break ("[\nsun]", found by
// fuzz_scene_toml) reaches parser::parse_key() on the '\n' — an abort with assertions on,
// undefined behaviour in a clang release build. The very next lines of parse_key() are the
// parser's own error path ("expected bare key starting character or string delimiter"), so its
// asserts and assumptions are compiled to nothing here (this file is the only one that includes
// toml++): such input becomes a toml::parse_error, reported below as a TOML syntax error with
// its line and column. Regression: Extremes.TomlHeaderLineBreak, corpus/scene_toml/crash-*.
#pragma push_macro("NDEBUG")
#undef NDEBUG
#undef TOML_ASSERT
#define TOML_ASSERT(expr) static_assert(true)
#include <toml++/toml.h>
#pragma pop_macro("NDEBUG")
#include <cassert>  // assert() as NDEBUG says again

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>

#include "airmass/color.hpp"
#include "airmass/spelling.hpp"

namespace airmass {

namespace detail {
// Generated at configure time from examples/*.toml (plugin/CMakeLists.txt, "Scene presets").
struct EmbeddedPreset {
    const char* name;
    const unsigned char* text;
    std::size_t size;
};
extern const EmbeddedPreset kEmbeddedPresets[];
extern const std::size_t kEmbeddedPresetCount;
}  // namespace detail

namespace {

constexpr double kMetresPerKm = 1000.0;
// Molecules per m² in one Dobson unit (Bruneton's kDobsonUnit; 0.01 mm of gas at STP).
constexpr double kMoleculesPerM2PerDobson = 2.687e20;
constexpr double kMinSpectralNm = kCmfFirstNm;  // the CIE table's range: nothing is seen outside
constexpr double kMaxSpectralNm = kCmfLastNm;
constexpr std::size_t kMaxWavelengths = 1000;
constexpr double kMaxRadiusKm = 1e6;
constexpr double kMaxAngularRadiusDeg = 5.0;
constexpr double kMinRadiusKm = 1.0;
constexpr double kMaxReferenceScaleHeights = 50.0;
constexpr double kMinScaleHeightKm = 1e-3;
constexpr double kMaxScaleHeightKm = 1e9;
constexpr double kMaxCoefficientPerM = 1e300;
// Spectral irradiance bounds, W m^-2 nm^-1: as written (at 1 AU; the Sun peaks near 2.1), and at
// the planet after the 1/distance^2 scaling (distance >= 1e-3 AU). Above them float radiances
// overflow to +inf (issue 17: 1e300 rendered +inf pixels).
constexpr double kMaxIrradianceAt1Au = 1e6;
constexpr double kMinDistanceAu = 1e-3;
constexpr double kMaxIrradiance = kMaxIrradianceAt1Au / (kMinDistanceAu * kMinDistanceAu);
constexpr double kMaxExponent = 10.0;
constexpr int kMaxImageSide = 65536;

// ---------------------------------------------------------------------------------------------
// Formatting

std::string num(double v) {
    std::ostringstream o;
    o << std::setprecision(10) << v;
    return o.str();
}

std::string in_quotes(std::string_view s) { return "\"" + std::string(s) + "\""; }

std::string join_quoted(const std::vector<std::string>& items) {
    std::string out;
    for (const auto& s : items) out += (out.empty() ? "" : ", ") + in_quotes(s);
    return out;
}

// "file:line:col: " for a node that came from a file, "" otherwise.
std::string where(const toml::source_region& src) {
    if (!src.begin) return src.path ? *src.path + ": " : "";
    std::string out = src.path ? *src.path : std::string("<toml>");
    return out + ":" + std::to_string(src.begin.line) + ":" + std::to_string(src.begin.column) + ": ";
}

// A short rendering of a TOML value for messages.
std::string describe(const toml::node& n) {
    if (n.is_table()) return "a table";
    if (n.is_array()) return "an array";
    if (n.is_string()) return in_quotes(n.as_string()->get());
    std::ostringstream o;
    n.visit([&](const auto& v) { o << v; });
    return o.str();
}

// An error whose message already starts with "file:line:col: ".
struct LocatedError : SceneError {
    using SceneError::SceneError;
};

// Field path → where it was written, to point validate()'s messages at the source line.
using SourceMap = std::map<std::string, toml::source_region, std::less<>>;

// ---------------------------------------------------------------------------------------------
// Scene validation (field paths and values in the file's units)

[[noreturn]] void bad(const std::string& path, double value, const std::string& requirement) {
    throw SceneError(path + " = " + num(value) + ": " + requirement);
}

void require_range(bool ok, const std::string& path, double value, const std::string& requirement) {
    if (!ok) bad(path, value, requirement);
}

void require_positive(const std::string& path, double v) {
    require_range(std::isfinite(v) && v > 0.0, path, v, "must be > 0");
}
void require_non_negative(const std::string& path, double v) {
    require_range(std::isfinite(v) && v >= 0.0, path, v, "must be >= 0");
}
void require_finite(const std::string& path, double v) { require_range(std::isfinite(v), path, v, "must be finite"); }

// Wavelength tables: strictly increasing, inside the visible range we can colour, values ≥ 0,
// and covering every wavelength the spectrum asks for (tables are never extrapolated silently).
void check_table(const std::string& path, const std::vector<std::pair<double, double>>& table,
                 const std::string& values_key, double need_lo_nm, double need_hi_nm, bool values_at_most_one = false) {
    if (table.empty()) throw SceneError(path + ".wavelengths_nm: must have at least one entry");
    for (std::size_t i = 0; i < table.size(); ++i) {
        const std::string wl = path + ".wavelengths_nm[" + std::to_string(i) + "]";
        const double l = table[i].first;
        require_range(std::isfinite(l) && l > 0.0, wl, l, "must be > 0");
        if (i > 0)
            require_range(l > table[i - 1].first, wl, l,
                          "must be > wavelengths_nm[" + std::to_string(i - 1) + "] (" + num(table[i - 1].first) +
                              "): wavelengths must increase");
        const std::string vp = path + "." + values_key + "[" + std::to_string(i) + "]";
        const double v = table[i].second;
        if (values_at_most_one)
            require_range(std::isfinite(v) && v >= 0.0 && v <= 1.0, vp, v, "must be in [0, 1]");
        else
            require_non_negative(vp, v);
    }
    if (table.front().first > need_lo_nm || table.back().first < need_hi_nm)
        throw SceneError(path + ".wavelengths_nm = [" + num(table.front().first) + " ... " + num(table.back().first) +
                         "]: must cover the spectrum's wavelengths [" + num(need_lo_nm) + ", " + num(need_hi_nm) +
                         "] nm (tables are not extrapolated)");
}

void validate_planet(const Planet& p) {
    const double r_km = p.radius_m / kMetresPerKm;
    // Below 1 km (a denormal, 1e-30 km) the geometry near the centre sent NaN zenith angles into
    // the Chapman table: an out-of-bounds read (issue 17 extremes; Extremes.Planet).
    require_range(std::isfinite(r_km) && r_km >= kMinRadiusKm && r_km <= kMaxRadiusKm, "planet.radius_km", r_km,
                  "must be in [" + num(kMinRadiusKm) + ", " + num(kMaxRadiusKm) + "]");
    const double top_km = p.atmosphere_top_m / kMetresPerKm;
    require_range(std::isfinite(top_km) && top_km > r_km, "planet.atmosphere_top_km", top_km,
                  "must be > planet.radius_km (" + num(r_km) + "): it is the radius of the atmosphere's top");
    require_range(std::isfinite(top_km) && top_km <= 2.0 * kMaxRadiusKm, "planet.atmosphere_top_km", top_km,
                  "must be <= " + num(2.0 * kMaxRadiusKm));
    require_range(std::isfinite(p.ground_albedo) && p.ground_albedo >= 0.0 && p.ground_albedo <= 1.0,
                  "planet.ground_albedo", p.ground_albedo, "must be in [0, 1]");
}

void validate_profile(const std::string& path, const DensityProfile& p) {
    const auto km = [](double m) { return m / kMetresPerKm; };
    switch (p.kind) {
        case DensityProfile::Kind::exponential:
            // Thinner layers (1e-30 km, a denormal: issue 17) pushed the optical depths and the
            // Angstrom law's beta / column (proportional to 1/H) beyond float's range: +inf sky pixels.
            // Huge ones (1.8e308 m, found by fuzz_scene_json) gave NaN transmittance: bounded at
            // 1e9 km, a thousand times the largest planet radius (a constant density long before).
            require_range(std::isfinite(p.scale_height_m) && km(p.scale_height_m) >= kMinScaleHeightKm &&
                              km(p.scale_height_m) <= kMaxScaleHeightKm,
                          path + ".scale_height_km", km(p.scale_height_m),
                          "must be in [" + num(kMinScaleHeightKm) + ", " + num(kMaxScaleHeightKm) + "] (1 m to 1e9 km)");
            // exp(h_ref / H) scales the density at the ground: beyond ±50 scale heights the
            // column overflowed or vanished and a derived field (extinction.beta) was refused.
            require_range(std::isfinite(p.reference_altitude_m) &&
                              std::abs(p.reference_altitude_m) <= kMaxReferenceScaleHeights * p.scale_height_m,
                          path + ".reference_altitude_km", km(p.reference_altitude_m),
                          "must be within " + num(kMaxReferenceScaleHeights) + " scale heights of the ground (|" +
                              path + ".reference_altitude_km| <= " +
                              num(km(kMaxReferenceScaleHeights * p.scale_height_m)) + ")");
            return;
        case DensityProfile::Kind::tent:
            require_finite(path + ".bottom_km", km(p.bottom_m));
            require_range(std::isfinite(p.peak_m) && p.peak_m > p.bottom_m, path + ".peak_km", km(p.peak_m),
                          "must be > " + path + ".bottom_km (" + num(km(p.bottom_m)) + ")");
            require_range(std::isfinite(p.top_m) && p.top_m > p.peak_m, path + ".top_km", km(p.top_m),
                          "must be > " + path + ".peak_km (" + num(km(p.peak_m)) + ")");
            return;
        case DensityProfile::Kind::piecewise_linear:
            if (p.knots.size() < 2)
                throw SceneError(path + ".altitudes_km: must have at least 2 knots (has " +
                                 std::to_string(p.knots.size()) + ")");
            for (std::size_t i = 0; i < p.knots.size(); ++i) {
                const std::string ap = path + ".altitudes_km[" + std::to_string(i) + "]";
                const double a = km(p.knots[i].first);
                require_finite(ap, a);
                if (i > 0)
                    require_range(p.knots[i].first > p.knots[i - 1].first, ap, a,
                                  "must be > " + path + ".altitudes_km[" + std::to_string(i - 1) + "] (" +
                                      num(km(p.knots[i - 1].first)) + "): altitudes must increase");
                require_non_negative(path + ".densities[" + std::to_string(i) + "]", p.knots[i].second);
            }
            return;
        case DensityProfile::Kind::constant:
            require_non_negative(path + ".value", p.value);
            require_finite(path + ".bottom_km", km(p.bottom_m));
            require_range(
                std::isfinite(p.top_m) && (p.top_m == 0.0 || p.top_m > p.bottom_m), path + ".top_km", km(p.top_m),
                "must be 0 (up to the atmosphere top) or > " + path + ".bottom_km (" + num(km(p.bottom_m)) + ")");
            return;
    }
    throw SceneError(path + ".type: unknown profile kind");
}

// The lowest altitude where the profile's density is > 0 (-inf: everywhere; +inf: nowhere).
double lowest_density_altitude_m(const DensityProfile& p) {
    constexpr double inf = std::numeric_limits<double>::infinity();
    switch (p.kind) {
        case DensityProfile::Kind::exponential: return -inf;
        case DensityProfile::Kind::tent: return p.bottom_m;
        case DensityProfile::Kind::piecewise_linear:
            for (std::size_t i = 0; i < p.knots.size(); ++i)
                if (p.knots[i].second > 0.0) return i == 0 ? p.knots[0].first : p.knots[i - 1].first;
            return inf;
        case DensityProfile::Kind::constant: return p.value > 0.0 ? p.bottom_m : inf;
    }
    return inf;
}

void require_coefficient(const std::string& path, double v) {
    require_range(std::isfinite(v) && v >= 0.0 && v <= kMaxCoefficientPerM, path, v,
                  "must be in [0, " + num(kMaxCoefficientPerM) + "]");
}

void validate_coefficient(const std::string& path, const SpectralCoefficient& c, double need_lo_nm, double need_hi_nm) {
    switch (c.law) {
        // Coefficients up to 1e300 per m: DBL_MAX scattering plus DBL_MAX absorption overflowed the
        // extinction to inf and gave NaN transmittance (fuzz_scene_json, 2026-12-02).
        case SpectralCoefficient::Law::constant: require_coefficient(path + ".value_per_m", c.value_per_m); return;
        case SpectralCoefficient::Law::power_law:
            require_coefficient(path + ".value_per_m", c.value_per_m);
            require_positive(path + ".reference_nm", c.reference_nm);
            require_range(std::isfinite(c.exponent) && std::abs(c.exponent) <= kMaxExponent, path + ".exponent",
                          c.exponent, "must be in [-" + num(kMaxExponent) + ", " + num(kMaxExponent) + "]");
            // σ(λ) = value · (λ / reference)^−exponent must stay finite over the spectrum: a
            // reference of 1e300 nm with exponent 10 gave σ = inf, refused naming only the derived
            // "scattering at 615 nm" (issue 17, extremes). The factor's bound F gives reference's range.
            if (c.exponent != 0.0) {
                const double F = std::min(1e300, c.value_per_m > 1.0 ? kMaxCoefficientPerM / c.value_per_m : 1e300);
                const double root = std::pow(F, 1.0 / std::abs(c.exponent));
                if (c.exponent > 0.0) {
                    const double max_ref = need_lo_nm * root;
                    require_range(c.reference_nm <= max_ref, path + ".reference_nm", c.reference_nm,
                                  "must be <= " + num(max_ref) + " with exponent " + num(c.exponent) +
                                      " (beyond, the coefficient at " + num(need_lo_nm) + " nm is not finite)");
                } else {
                    const double min_ref = need_hi_nm / root;
                    require_range(c.reference_nm >= min_ref, path + ".reference_nm", c.reference_nm,
                                  "must be >= " + num(min_ref) + " with exponent " + num(c.exponent) +
                                      " (below, the coefficient at " + num(need_hi_nm) + " nm is not finite)");
                }
            }
            return;
        case SpectralCoefficient::Law::table:
            check_table(path, c.table, "values_per_m", need_lo_nm, need_hi_nm);
            for (std::size_t i = 0; i < c.table.size(); ++i)
                require_coefficient(path + ".values_per_m[" + std::to_string(i) + "]", c.table[i].second);
            return;
    }
    throw SceneError(path + ".law: unknown law");
}

// The profile's largest density over the atmosphere (altitudes >= 0) and the field that sets it.
std::pair<double, std::string> peak_density(const DensityProfile& p) {
    switch (p.kind) {
        case DensityProfile::Kind::exponential:
            return {std::exp(p.reference_altitude_m / p.scale_height_m), "reference_altitude_km"};
        case DensityProfile::Kind::tent: return {1.0, "peak_km"};
        case DensityProfile::Kind::piecewise_linear: {
            double m = 0.0;
            for (const auto& k : p.knots) m = std::max(m, k.second);
            return {m, "densities"};
        }
        case DensityProfile::Kind::constant: return {p.value, "value"};
    }
    return {0.0, ""};
}

// Density times coefficient is the extinction the integrators multiply by lengths: each bounded
// alone, a constant density of 1.8e308 times a coefficient of 7e297 per m overflowed it to +inf
// and gave NaN radiance (fuzz_scene_json, --runs 20000). Both fields are named.
void validate_extinction(const std::string& path, const Constituent& c, const std::vector<double>& wavelengths_nm) {
    const auto [density, density_field] = peak_density(c.profile);
    const std::pair<const char*, const SpectralCoefficient*> coefficients[] = {{"scattering", &c.scattering},
                                                                               {"absorption", &c.absorption}};
    for (const auto& [which, coefficient] : coefficients) {
        const SpectralCoefficient& k = *coefficient;
        for (double nm : wavelengths_nm) {
            const double product = density * k.at(nm);
            if (!(product <= kMaxCoefficientPerM))
                throw SceneError(path + ".profile." + density_field + " (peak density " + num(density) + ") x " + path +
                                 "." + which + " (" + num(k.at(nm)) + " per m at " + num(nm) + " nm) = " +
                                 num(product) + " per m: must be <= " + num(kMaxCoefficientPerM) +
                                 " (lower the density or the coefficient)");
        }
    }
}

void validate_phase(const std::string& path, const PhaseFunction& p) {
    if (p.kind == PhaseFunction::Kind::cornette_shanks || p.kind == PhaseFunction::Kind::henyey_greenstein)
        require_range(std::isfinite(p.g) && p.g > -1.0 && p.g < 1.0, path + ".g", p.g, "must be in (-1, 1)");
}

bool valid_name(const std::string& s) {
    if (s.empty() || s.size() > 64) return false;
    return std::all_of(s.begin(), s.end(), [](char ch) {
        return (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '_' ||
               ch == '-' || ch == '.';
    });
}

void validate_vec3(const std::string& path, const double (&v)[3], bool nonzero) {
    for (int i = 0; i < 3; ++i) require_finite(path + "[" + std::to_string(i) + "]", v[i]);
    if (nonzero && v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0)
        throw SceneError(path + " = [0, 0, 0]: must be a non-zero vector");
}

void validate_camera(const Camera& c) {
    for (int i = 0; i < 3; ++i) {
        const double km = c.position_m[i] / kMetresPerKm;
        require_range(std::isfinite(km) && std::abs(km) <= 1e7, "camera.position_km[" + std::to_string(i) + "]", km,
                      "must be in [-1e7, 1e7]");
    }
    validate_vec3("camera.direction", c.direction, true);
    validate_vec3("camera.up", c.up, true);
    const double* d = c.direction;
    const double* u = c.up;
    const double cross[3] = {d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2], d[0] * u[1] - d[1] * u[0]};
    const double cn = std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]);
    const double dn = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    const double un = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (!(cn > 1e-9 * dn * un)) throw SceneError("camera.up: must not be parallel to camera.direction");
    require_range(std::isfinite(c.fov_deg) && c.fov_deg > 0.0 && c.fov_deg < 180.0, "camera.fov_deg", c.fov_deg,
                  "must be in (0, 180)");
    require_positive("camera.max_distance_km", c.max_distance_m / kMetresPerKm);
    require_range(c.width >= 1 && c.width <= kMaxImageSide, "camera.width", c.width,
                  "must be in [1, " + std::to_string(kMaxImageSide) + "]");
    require_range(c.height >= 1 && c.height <= kMaxImageSide, "camera.height", c.height,
                  "must be in [1, " + std::to_string(kMaxImageSide) + "]");
}

void validate_basis(const SpectralBasis& b) {
    if (b.kind == SpectralBasis::Kind::rgb_schuler) {
        if (!b.wavelengths_nm.empty() && !std::equal(b.wavelengths_nm.begin(), b.wavelengths_nm.end(),
                                                     kSchulerWavelengthsNm.begin(), kSchulerWavelengthsNm.end()))
            throw SceneError("spectrum.wavelengths_nm: must be [615, 535, 445] (or empty) for basis = \"rgb-schuler\"");
        return;
    }
    const auto& w = b.wavelengths_nm;
    if (w.empty()) throw SceneError("spectrum.wavelengths_nm: must have at least one wavelength");
    if (w.size() > kMaxWavelengths)
        throw SceneError("spectrum.wavelengths_nm: " + std::to_string(w.size()) + " wavelengths, at most " +
                         std::to_string(kMaxWavelengths) + " allowed");
    for (std::size_t i = 0; i < w.size(); ++i) {
        const std::string path = "spectrum.wavelengths_nm[" + std::to_string(i) + "]";
        require_range(std::isfinite(w[i]) && w[i] >= kMinSpectralNm && w[i] <= kMaxSpectralNm, path, w[i],
                      "must be in [" + num(kMinSpectralNm) + ", " + num(kMaxSpectralNm) +
                          "] nm (the CIE colour matching functions' range)");
        if (i > 0)
            require_range(w[i] > w[i - 1], path, w[i],
                          "must be > wavelengths_nm[" + std::to_string(i - 1) + "] (" + num(w[i - 1]) +
                              "): wavelengths must increase");
    }
}

// ---------------------------------------------------------------------------------------------
// Reading TOML tables with key bookkeeping

// Reads the keys of one TOML table. Every key looked up is recorded; finish() rejects the rest.
class TableReader {
public:
    TableReader(const toml::table& table, std::string path, SourceMap& sources)
        : table_(table), path_(std::move(path)), sources_(sources) {
        sources_[path_] = table.source();
    }

    const std::string& path() const { return path_; }
    std::string key_path(std::string_view key) const {
        return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
    }
    bool has(std::string_view key) const { return table_.contains(key); }

    const toml::node* take(std::string_view key) {
        looked_up_.emplace_back(key);
        const toml::node* n = table_.get(key);
        if (n) sources_[key_path(key)] = n->source();
        return n;
    }

    [[noreturn]] void fail(const toml::node* n, std::string_view key, const std::string& message) const {
        throw LocatedError(where(n ? n->source() : table_.source()) + key_path(key) + message);
    }
    // A required key is absent. A key of the table that is one or two edits away and not read yet
    // is named too: "radius_kn" is far more likely a typo than a second, unknown field.
    [[noreturn]] void missing(std::string_view key, const std::string& why = "required") const {
        std::string hint;
        for (auto&& [k, node] : table_) {
            if (std::find(looked_up_.begin(), looked_up_.end(), k.str()) != looked_up_.end()) continue;
            if (looks_like_misspelling(k.str(), key)) {
                hint = "; " + in_quotes(k.str()) + (node.source().begin ? " at " + location(node.source()) : "") +
                       " looks like a misspelling of it";
                break;
            }
        }
        fail(nullptr, key, ": missing (" + why + hint + ")");
    }

    std::optional<double> opt_number(std::string_view key) {
        const toml::node* n = take(key);
        if (!n) return std::nullopt;
        return to_number(n, key);
    }
    double number(std::string_view key) {
        const auto v = opt_number(key);
        if (!v) missing(key);
        return *v;
    }
    double number(std::string_view key, double fallback) { return opt_number(key).value_or(fallback); }

    std::optional<std::int64_t> opt_integer(std::string_view key) {
        const toml::node* n = take(key);
        if (!n) return std::nullopt;
        if (!n->is_integer()) fail(n, key, " = " + describe(*n) + ": must be an integer");
        return n->as_integer()->get();
    }

    std::optional<std::string> opt_string(std::string_view key) {
        const toml::node* n = take(key);
        if (!n) return std::nullopt;
        if (!n->is_string()) fail(n, key, " = " + describe(*n) + ": must be a string");
        return n->as_string()->get();
    }
    std::string string(std::string_view key) {
        auto v = opt_string(key);
        if (!v) missing(key);
        return *v;
    }

    std::optional<std::vector<double>> opt_numbers(std::string_view key) {
        const toml::node* n = take(key);
        if (!n) return std::nullopt;
        const toml::array* a = n->as_array();
        if (!a) fail(n, key, " = " + describe(*n) + ": must be an array of numbers");
        std::vector<double> out;
        out.reserve(a->size());
        for (std::size_t i = 0; i < a->size(); ++i)
            out.push_back(to_number(a->get(i), std::string(key) + "[" + std::to_string(i) + "]"));
        return out;
    }
    std::vector<double> numbers(std::string_view key) {
        auto v = opt_numbers(key);
        if (!v) missing(key);
        return std::move(*v);
    }

    const toml::table* opt_table(std::string_view key) {
        const toml::node* n = take(key);
        if (!n) return nullptr;
        if (!n->is_table()) fail(n, key, " = " + describe(*n) + ": must be a table");
        return n->as_table();
    }
    const toml::table& table(std::string_view key) {
        const toml::table* t = opt_table(key);
        if (!t) missing(key);
        return *t;
    }

    // Every key of the table must have been looked up: anything else is a typo or misplaced.
    void finish() const {
        for (auto&& [key, node] : table_) {
            if (std::find(looked_up_.begin(), looked_up_.end(), key.str()) != looked_up_.end()) continue;
            std::vector<std::string> allowed(looked_up_.begin(), looked_up_.end());
            std::sort(allowed.begin(), allowed.end());
            allowed.erase(std::unique(allowed.begin(), allowed.end()), allowed.end());
            throw LocatedError(where(node.source()) + key_path(key.str()) + ": unknown key" +
                               (allowed.empty() ? std::string(" (this table takes no keys)")
                                                : " (allowed here: " + join(allowed) + ")"));
        }
    }

private:
    static std::string location(const toml::source_region& src) {
        std::string w = where(src);
        return w.size() >= 2 ? w.substr(0, w.size() - 2) : w;  // without the trailing ": "
    }
    static std::string join(const std::vector<std::string>& v) {
        std::string out;
        for (const auto& s : v) out += (out.empty() ? "" : ", ") + s;
        return out;
    }
    double to_number(const toml::node* n, std::string_view key) const {
        if (n->is_integer()) return static_cast<double>(n->as_integer()->get());
        if (n->is_floating_point()) return n->as_floating_point()->get();
        fail(n, key, " = " + describe(*n) + ": must be a number");
    }

    const toml::table& table_;
    std::string path_;
    SourceMap& sources_;
    std::vector<std::string> looked_up_;
};

std::vector<std::pair<double, double>> zip(const TableReader& r, std::string_view values_key,
                                           const std::vector<double>& x, const std::vector<double>& y,
                                           double x_scale = 1.0) {
    if (x.size() != y.size())
        r.fail(nullptr, values_key,
               ": has " + std::to_string(y.size()) + " entries but wavelengths_nm/altitudes_km has " +
                   std::to_string(x.size()) + " (they must match)");
    std::vector<std::pair<double, double>> out(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) out[i] = {x[i] * x_scale, y[i]};
    return out;
}

// ---------------------------------------------------------------------------------------------
// Building the Scene

const std::map<std::string, std::vector<double>, std::less<>>& named_samplings() {
    static const auto samplings = [] {
        const auto range = [](double first, double last, double step) {
            std::vector<double> v;
            for (double l = first; l <= last + 1e-9; l += step) v.push_back(l);
            return v;
        };
        return std::map<std::string, std::vector<double>, std::less<>>{
            {"cie-95", range(360.0, 830.0, 5.0)},        // the CIE table's own grid
            {"bruneton-48", range(360.0, 830.0, 10.0)},  // Bruneton's demo (kLambdaMin..kLambdaMax)
            {"blender-21", range(380.0, 780.0, 20.0)},   // Blender's Nishita sky
        };
    }();
    return samplings;
}

SpectralCoefficient scaled(SpectralCoefficient c, double f) {
    c.value_per_m *= f;
    for (auto& [l, v] : c.table) v *= f;
    return c;
}

class SceneBuilder {
public:
    explicit SceneBuilder(SourceMap& sources) : sources_(sources) {}

    Scene build(const toml::table& root, const std::string& default_name) {
        Scene s;
        TableReader r(root, "", sources_);
        s.name = r.opt_string("name").value_or(default_name);
        s.planet = planet(r.table("planet"));
        thickness_m_ = s.planet.atmosphere_top_m - s.planet.radius_m;
        radius_km_ = s.planet.radius_m / kMetresPerKm;
        if (const toml::table* t = r.opt_table("sun")) s.sun = sun(*t);
        if (const toml::table* t = r.opt_table("observer")) s.observer = observer(*t);
        if (const toml::table* t = r.opt_table("camera")) s.camera = camera(*t);
        s.basis = spectrum(r.table("spectrum"));
        validate_basis(s.basis);
        const std::vector<double> wl = basis_wavelengths_nm(s.basis);
        basis_lo_nm_ = *std::min_element(wl.begin(), wl.end());
        basis_hi_nm_ = *std::max_element(wl.begin(), wl.end());
        if (const toml::node* n = r.take("constituent")) {
            const toml::array* a = n->as_array();
            if (!a) r.fail(n, "constituent", ": must be an array of tables, written [[constituent]]");
            for (std::size_t i = 0; i < a->size(); ++i) {
                const toml::node* e = a->get(i);
                const std::string path = "constituent[" + std::to_string(i) + "]";
                if (!e->is_table())
                    throw LocatedError(where(e->source()) + path + " = " + describe(*e) + ": must be a table");
                s.constituents.push_back(constituent(*e->as_table(), path));
            }
        }
        r.finish();
        return s;
    }

private:
    Planet planet(const toml::table& t) {
        TableReader r(t, "planet", sources_);
        Planet p;
        p.radius_m = r.number("radius_km") * kMetresPerKm;
        p.atmosphere_top_m = r.number("atmosphere_top_km") * kMetresPerKm;
        p.ground_albedo = r.number("ground_albedo", p.ground_albedo);
        r.finish();
        validate_planet(p);  // now: the column of every profile below depends on the thickness
        return p;
    }

    Sun sun(const toml::table& t) {
        TableReader r(t, "sun", sources_);
        Sun s;
        // The sun's direction: elevation_deg/azimuth_deg, or latitude_deg/longitude_deg/time
        // (+ delta_t_s) resolved here by the Solar Position Algorithm — never both.
        const std::vector<std::string_view> angle_keys = {"elevation_deg", "azimuth_deg"};
        const std::vector<std::string_view> place_keys = {"latitude_deg", "longitude_deg", "time", "delta_t_s"};
        const auto first_of = [&](const std::vector<std::string_view>& keys) -> std::optional<std::string_view> {
            for (std::string_view k : keys)
                if (r.has(k)) return k;
            return std::nullopt;
        };
        const auto angle_key = first_of(angle_keys);
        const auto place_key = first_of(place_keys);
        if (angle_key && place_key)
            r.fail(r.take(*place_key), *place_key,
                   ": the sun is given both by angles (sun." + std::string(*angle_key) +
                       ") and by place and time; use elevation_deg/azimuth_deg or latitude_deg/longitude_deg/time, "
                       "not both");
        if (place_key) {
            for (std::string_view k : {"latitude_deg", "longitude_deg", "time"})
                if (!r.has(k))
                    r.missing(k, "the sun's place and time are latitude_deg, longitude_deg and time together; sun." +
                                     std::string(*place_key) + " is set");
            SunPlace place;
            place.latitude_deg = r.number("latitude_deg");
            place.longitude_deg = r.number("longitude_deg");
            const std::string time = r.string("time");
            std::string why;
            const auto t = try_parse_utc(time, &why);
            if (!t) r.fail(r.take("time"), "time", " = " + in_quotes(time) + ": " + why);
            place.time = *t;
            place.delta_t_s = r.opt_number("delta_t_s");
            SolarPositionInput in;
            in.latitude_deg = place.latitude_deg;
            in.longitude_deg = place.longitude_deg;
            in.time = place.time;
            in.delta_t_s = place.delta_t_s;
            SolarPosition pos;
            try {
                pos = solar_position(in);
            } catch (const SolarPositionError& e) {
                const std::string what = e.what();
                const std::string key = what.substr(0, what.find(' '));
                r.fail(r.take(key), key, what.substr(key.size()));
            }
            s.elevation_deg = pos.blender_elevation_deg;
            s.azimuth_deg = pos.blender_rotation_deg;
            s.place = place;
        } else {
            s.elevation_deg = r.number("elevation_deg", s.elevation_deg);
            s.azimuth_deg = r.number("azimuth_deg", s.azimuth_deg);
        }
        s.angular_radius_deg = r.number("angular_radius_deg", s.angular_radius_deg);
        const double d_au = r.number("distance_au", 1.0);
        require_range(std::isfinite(d_au) && d_au >= kMinDistanceAu && d_au <= 1000.0, "sun.distance_au", d_au,
                      "must be in [" + num(kMinDistanceAu) + ", 1000]");
        const double inverse_square = 1.0 / (d_au * d_au);  // irradiance is given at 1 AU
        // The values as written are checked before the scaling, so a refusal names them.
        const auto at_1au = [](const std::string& path, double v) {
            require_range(std::isfinite(v) && v >= 0.0 && v <= kMaxIrradianceAt1Au, path, v,
                          "must be in [0, " + num(kMaxIrradianceAt1Au) + "] (W m^-2 nm^-1 at 1 AU)");
            return v;
        };
        if (const toml::table* it = r.opt_table("irradiance")) {
            TableReader ir(*it, "sun.irradiance", sources_);
            const std::string type = ir.string("type");
            if (type == "constant") {
                s.irradiance_constant =
                    at_1au("sun.irradiance.value_w_m2_nm", ir.number("value_w_m2_nm", 1.0)) * inverse_square;
            } else if (type == "table") {
                const auto w = ir.numbers("wavelengths_nm");
                auto v = ir.numbers("values_w_m2_nm");
                for (std::size_t i = 0; i < v.size(); ++i)
                    v[i] = at_1au("sun.irradiance.values_w_m2_nm[" + std::to_string(i) + "]", v[i]) * inverse_square;
                s.irradiance_table = zip(ir, "values_w_m2_nm", w, v);
            } else {
                ir.fail(it->get("type"), "type", " = " + in_quotes(type) + ": must be \"constant\" or \"table\"");
            }
            ir.finish();
        } else {
            s.irradiance_constant *= inverse_square;
        }
        r.finish();
        return s;
    }

    Observer observer(const toml::table& t) {
        TableReader r(t, "observer", sources_);
        Observer o;
        o.altitude_m = r.number("altitude_km", 0.0) * kMetresPerKm;
        r.finish();
        return o;
    }

    Camera camera(const toml::table& t) {
        TableReader r(t, "camera", sources_);
        Camera c;
        const auto vec3 = [&](std::string_view key, double(&out)[3]) {
            if (auto v = r.opt_numbers(key)) {
                if (v->size() != 3)
                    r.fail(t.get(key), key, ": must have 3 components (has " + std::to_string(v->size()) + ")");
                std::copy(v->begin(), v->end(), out);
            }
        };
        // Every length a person types is in km (docs/scene.md); the library keeps metres.
        if (r.has("position_m"))
            r.fail(t.get("position_m"), "position_m",
                   ": no longer read — the camera position is position_km, in kilometres like every length in the "
                   "scene file (multiply metres by 0.001)");
        vec3("position_km", c.position_m);
        for (double& x : c.position_m) x *= kMetresPerKm;
        vec3("direction", c.direction);
        vec3("up", c.up);
        c.fov_deg = r.number("fov_deg", c.fov_deg);
        c.max_distance_m = r.number("max_distance_km", c.max_distance_m / kMetresPerKm) * kMetresPerKm;
        const auto side = [&](std::string_view key, int& out) {
            if (auto v = r.opt_integer(key)) {
                require_range(*v >= 1 && *v <= kMaxImageSide, r.key_path(key), static_cast<double>(*v),
                              "must be in [1, " + std::to_string(kMaxImageSide) + "]");
                out = static_cast<int>(*v);
            }
        };
        side("width", c.width);
        side("height", c.height);
        r.finish();
        return c;
    }

    SpectralBasis spectrum(const toml::table& t) {
        TableReader r(t, "spectrum", sources_);
        SpectralBasis b;
        const std::string basis = r.string("basis");
        if (basis == "rgb-schuler") {
            b.kind = SpectralBasis::Kind::rgb_schuler;
            for (std::string_view key : {"wavelengths_nm", "sampling"})
                if (r.has(key))
                    r.fail(t.get(key), key,
                           ": not allowed with basis = \"rgb-schuler\" (its wavelengths are 615, 535, 445 nm)");
            b.wavelengths_nm.assign(kSchulerWavelengthsNm.begin(), kSchulerWavelengthsNm.end());
        } else if (basis == "spectral") {
            b.kind = SpectralBasis::Kind::spectral;
            const auto explicit_nm = r.opt_numbers("wavelengths_nm");
            const auto sampling = r.opt_string("sampling");
            if (explicit_nm && sampling)
                r.fail(t.get("sampling"), "sampling",
                       ": give either spectrum.wavelengths_nm or spectrum.sampling, not both");
            if (explicit_nm) {
                b.wavelengths_nm = *explicit_nm;
            } else if (sampling) {
                const auto& named = named_samplings();
                const auto it = named.find(*sampling);
                if (it == named.end()) {
                    std::vector<std::string> names;
                    for (const auto& [k, v] : named) names.push_back(k);
                    r.fail(t.get("sampling"), "sampling",
                           " = " + in_quotes(*sampling) + ": must be one of " + join_quoted(names));
                }
                b.wavelengths_nm = it->second;
            } else {
                r.missing("wavelengths_nm", "a spectral basis needs wavelengths_nm = [...] or sampling = \"...\"");
            }
        } else {
            r.fail(t.get("basis"), "basis", " = " + in_quotes(basis) + ": must be \"spectral\" or \"rgb-schuler\"");
        }
        r.finish();
        return b;
    }

    DensityProfile profile(const toml::table& t, const std::string& path) {
        TableReader r(t, path, sources_);
        DensityProfile p;
        const std::string type = r.string("type");
        if (type == "exponential") {
            p.kind = DensityProfile::Kind::exponential;
            p.scale_height_m = r.number("scale_height_km") * kMetresPerKm;
            p.reference_altitude_m = r.number("reference_altitude_km", 0.0) * kMetresPerKm;
        } else if (type == "tent") {
            p.kind = DensityProfile::Kind::tent;
            p.bottom_m = r.number("bottom_km") * kMetresPerKm;
            p.peak_m = r.number("peak_km") * kMetresPerKm;
            p.top_m = r.number("top_km") * kMetresPerKm;
        } else if (type == "piecewise-linear") {
            p.kind = DensityProfile::Kind::piecewise_linear;
            p.knots = zip(r, "densities", r.numbers("altitudes_km"), r.numbers("densities"), kMetresPerKm);
        } else if (type == "constant") {
            p.kind = DensityProfile::Kind::constant;
            p.value = r.number("value", 1.0);
            p.bottom_m = r.number("bottom_km", 0.0) * kMetresPerKm;
            p.top_m = r.number("top_km", 0.0) * kMetresPerKm;
        } else {
            r.fail(t.get("type"), "type",
                   " = " + in_quotes(type) +
                       ": must be one of \"exponential\", \"tent\", \"piecewise-linear\", \"constant\"");
        }
        r.finish();
        validate_profile(path, p);  // now: the laws below integrate it
        return p;
    }

    // A coefficient law (docs/scene.md "Coefficients"). The profile and the atmosphere's
    // thickness give the vertical column for the "angstrom" law and for ozone columns.
    SpectralCoefficient coefficient(const toml::table& t, const std::string& path, const DensityProfile& prof) {
        TableReader r(t, path, sources_);
        SpectralCoefficient c;
        // The law spreads `what` over the profile's column below the atmosphere's top: a column of
        // 0 or inf is refused naming the field that is out of range (issue 17, extremes).
        const auto column_m = [&](std::string_view what, double amount) {
            const double col = vertical_column_m(prof, thickness_m_);
            const std::string profile_path = path.substr(0, path.rfind('.')) + ".profile";
            const std::string needs = r.key_path(what) + " is spread over the profile's column below the top";
            if (std::isfinite(col) && col > 0.0) {
                if (std::isfinite(amount / col)) return col;
                // A column so thin (a denormal density) that amount / column overflows.
                const double least = amount / std::numeric_limits<double>::max();
                if (prof.kind == DensityProfile::Kind::constant)
                    r.fail(t.get(what), what,
                           ": " + profile_path + ".value = " + num(prof.value) + ": must be >= " +
                               num(least / (col / prof.value)) + " (" + needs + ")");
                r.fail(t.get(what), what, ": " + profile_path + "'s column below the top (" + num(col) +
                                              " m) must be >= " + num(least) + " m (" + needs + ")");
            }
            if (std::isfinite(col)) {
                const double bottom_m = lowest_density_altitude_m(prof);
                // Density only above the top (the earth preset's ozone, from 10 km, under a top
                // 1 m above the ground): the top is out of range.
                if (std::isfinite(bottom_m) && bottom_m >= thickness_m_ && bottom_m >= 0.0) {
                    const auto src = sources_.find(std::string("planet.atmosphere_top_km"));
                    throw LocatedError((src != sources_.end() ? where(src->second) : std::string()) +
                                       "planet.atmosphere_top_km = " + num(radius_km_ + thickness_m_ / kMetresPerKm) +
                                       ": must be > " + num(radius_km_ + bottom_m / kMetresPerKm) +
                                       " (planet.radius_km + " + num(bottom_m / kMetresPerKm) + " km, where " +
                                       profile_path + "'s density begins: " + needs + ")");
                }
                if (prof.kind == DensityProfile::Kind::constant)
                    r.fail(t.get(what), what, ": " + profile_path + ".value = " + num(prof.value) + ": must be > 0 (" +
                                                  needs + ")");
                r.fail(t.get(what), what,
                       ": " + profile_path + " must have density between the ground and the atmosphere top (0 and " +
                           num(thickness_m_ / kMetresPerKm) + " km; its column there is 0 m: " + needs + ")");
            }
            r.fail(t.get(what), what, ": " + profile_path + "'s column below the atmosphere top (" + num(col) +
                                          " m) must be finite: its densities are too large");
        };
        const auto non_negative = [&](std::string_view key) {
            const double v = r.number(key);
            require_non_negative(r.key_path(key), v);
            return v;
        };
        const std::string law = r.string("law");
        if (law == "constant") {
            c.law = SpectralCoefficient::Law::constant;
            c.value_per_m = r.number("value_per_m");
        } else if (law == "power-law") {
            c.law = SpectralCoefficient::Law::power_law;
            c.value_per_m = r.number("value_per_m");
            c.reference_nm = r.number("reference_nm");
            c.exponent = r.number("exponent");
        } else if (law == "rayleigh") {
            // σ(λ) = k · (λ / 1 µm)⁻⁴
            c.law = SpectralCoefficient::Law::power_law;
            c.value_per_m = non_negative("value_per_m_at_1um");
            c.reference_nm = 1000.0;
            c.exponent = 4.0;
        } else if (law == "angstrom") {
            // Ångström: vertical optical depth τ(λ) = β·(λ / 1 µm)^−α, spread over the profile's
            // column: σ(λ) = β / column · (λ / 1 µm)^−α (Bruneton's demo: β / H).
            c.law = SpectralCoefficient::Law::power_law;
            const double beta = non_negative("beta");
            const double alpha = r.number("alpha");
            require_range(std::isfinite(alpha) && std::abs(alpha) <= kMaxExponent, r.key_path("alpha"), alpha,
                          "must be in [-" + num(kMaxExponent) + ", " + num(kMaxExponent) + "]");
            c.value_per_m = beta / column_m("beta", beta);
            c.reference_nm = 1000.0;
            c.exponent = alpha;
        } else if (law == "table") {
            c.law = SpectralCoefficient::Law::table;
            const auto w = r.numbers("wavelengths_nm");
            const auto values = r.opt_numbers("values_per_m");
            const auto cross = r.opt_numbers("cross_sections_m2");
            if (values.has_value() == cross.has_value())
                r.fail(nullptr, "values_per_m",
                       ": give exactly one of values_per_m or cross_sections_m2 (with "
                       "number_density_per_m3 or column_du)");
            if (values) {
                c.table = zip(r, "values_per_m", w, *values);
            } else {
                for (std::size_t i = 0; i < cross->size(); ++i)
                    require_non_negative(r.key_path("cross_sections_m2") + "[" + std::to_string(i) + "]", (*cross)[i]);
                const auto density = r.opt_number("number_density_per_m3");
                const auto column_du = r.opt_number("column_du");
                if (density.has_value() == column_du.has_value())
                    r.fail(nullptr, "number_density_per_m3",
                           ": cross_sections_m2 need exactly one of number_density_per_m3 or column_du");
                double n_per_m3 = 0.0;
                if (density) {
                    require_non_negative(r.key_path("number_density_per_m3"), *density);
                    n_per_m3 = *density;
                } else {
                    // Number density at density 1 such that ∫ n ρ(h) dh = column (Bruneton's
                    // kMaxOzoneNumberDensity = 300 DU / 15 km for the ozone tent).
                    require_non_negative(r.key_path("column_du"), *column_du);
                    n_per_m3 = *column_du * kMoleculesPerM2PerDobson /
                               column_m("column_du", *column_du * kMoleculesPerM2PerDobson);
                }
                std::vector<double> v(cross->size());
                for (std::size_t i = 0; i < v.size(); ++i) v[i] = (*cross)[i] * n_per_m3;
                c.table = zip(r, "cross_sections_m2", w, v);
            }
        } else {
            r.fail(t.get("law"), "law",
                   " = " + in_quotes(law) +
                       ": must be one of \"constant\", \"power-law\", \"rayleigh\", \"angstrom\", \"table\"");
        }
        r.finish();
        return c;
    }

    PhaseFunction phase(const toml::table& t, const std::string& path) {
        TableReader r(t, path, sources_);
        PhaseFunction p;
        const std::string type = r.string("type");
        if (type == "rayleigh") {
            p.kind = PhaseFunction::Kind::rayleigh;
        } else if (type == "rayleigh-modified") {
            p.kind = PhaseFunction::Kind::rayleigh_modified;
        } else if (type == "isotropic") {
            p.kind = PhaseFunction::Kind::isotropic;
        } else if (type == "cornette-shanks" || type == "henyey-greenstein") {
            p.kind = type == "cornette-shanks" ? PhaseFunction::Kind::cornette_shanks
                                               : PhaseFunction::Kind::henyey_greenstein;
            p.g = r.number("g");
        } else {
            r.fail(t.get("type"), "type",
                   " = " + in_quotes(type) +
                       ": must be one of \"rayleigh\", \"rayleigh-modified\", \"cornette-shanks\", "
                       "\"henyey-greenstein\", \"isotropic\"");
        }
        r.finish();
        validate_phase(path, p);
        return p;
    }

    Constituent constituent(const toml::table& t, const std::string& path) {
        TableReader r(t, path, sources_);
        Constituent c;
        c.name = r.string("name");
        c.profile = profile(r.table("profile"), path + ".profile");
        const bool by_extinction = r.has("extinction");
        if (by_extinction && (r.has("scattering") || r.has("absorption")))
            r.fail(t.get("extinction"), "extinction",
                   ": give either extinction + single_scattering_albedo, or scattering and/or absorption — not both");
        if (by_extinction) {
            const SpectralCoefficient ext = coefficient(r.table("extinction"), path + ".extinction", c.profile);
            const toml::node* ssa = r.take("single_scattering_albedo");
            if (!ssa) r.missing("single_scattering_albedo", "required with extinction");
            split_extinction(c, ext, *ssa, path + ".single_scattering_albedo");
        } else {
            if (r.has("single_scattering_albedo"))
                r.fail(t.get("single_scattering_albedo"), "single_scattering_albedo", ": only allowed with extinction");
            if (const toml::table* s = r.opt_table("scattering"))
                c.scattering = coefficient(*s, path + ".scattering", c.profile);
            if (const toml::table* a = r.opt_table("absorption"))
                c.absorption = coefficient(*a, path + ".absorption", c.profile);
        }
        if (const toml::table* ph = r.opt_table("phase")) {
            c.phase = phase(*ph, path + ".phase");
        } else {
            if (!c.scattering.is_zero()) r.missing("phase", "required: the constituent scatters light");
            c.phase.kind = PhaseFunction::Kind::isotropic;  // never used: nothing is scattered
        }
        r.finish();
        return c;
    }

    // scattering = ω·extinction, absorption = (1 − ω)·extinction. ω is a number, or a table
    // {wavelengths_nm, values}: then both become tables at ω's wavelengths (exact at the knots,
    // linear between them).
    void split_extinction(Constituent& c, const SpectralCoefficient& ext, const toml::node& ssa,
                          const std::string& path) {
        if (ssa.is_integer() || ssa.is_floating_point()) {
            const double w =
                ssa.is_integer() ? static_cast<double>(ssa.as_integer()->get()) : ssa.as_floating_point()->get();
            sources_[path] = ssa.source();
            require_range(std::isfinite(w) && w >= 0.0 && w <= 1.0, path, w, "must be in [0, 1]");
            c.scattering = scaled(ext, w);
            c.absorption = scaled(ext, 1.0 - w);
            return;
        }
        if (!ssa.is_table())
            throw LocatedError(where(ssa.source()) + path + " = " + describe(ssa) +
                               ": must be a number in [0, 1] or a table {wavelengths_nm, values}");
        TableReader r(*ssa.as_table(), path, sources_);
        const auto table = zip(r, "values", r.numbers("wavelengths_nm"), r.numbers("values"));
        r.finish();
        check_table(path, table, "values", basis_lo_nm_, basis_hi_nm_, /*values_at_most_one=*/true);
        c.scattering = SpectralCoefficient{};
        c.absorption = SpectralCoefficient{};
        c.scattering.law = c.absorption.law = SpectralCoefficient::Law::table;
        for (const auto& [l, w] : table) {
            c.scattering.table.emplace_back(l, w * ext.at(l));
            c.absorption.table.emplace_back(l, (1.0 - w) * ext.at(l));
        }
    }

    SourceMap& sources_;
    double thickness_m_ = 0.0, radius_km_ = 0.0;
    double basis_lo_nm_ = 0.0, basis_hi_nm_ = 0.0;
};

// ---------------------------------------------------------------------------------------------
// Presets and merging

std::optional<std::string_view> embedded_preset(std::string_view name) {
    for (std::size_t i = 0; i < detail::kEmbeddedPresetCount; ++i) {
        const auto& p = detail::kEmbeddedPresets[i];
        if (p.name && name == p.name) return std::string_view(reinterpret_cast<const char*>(p.text), p.size);
    }
    return std::nullopt;
}

std::string preset_source_name(std::string_view name) { return "<preset " + std::string(name) + ">"; }

// toml++ 3.3's is_non_ascii_horizontal_whitespace() reaches TOML_UNREACHABLE (__builtin_unreachable:
// undefined behaviour) for most code points from U+00A1 on, e.g. 'µ' (found by fuzz_scene_toml: a
// table header "[plaµm)"). The parser asks it about characters outside strings and comments, after
// a backslash in a multi-line string, and at the start of a line continued by a line-ending
// backslash. TOML allows non-ASCII characters only inside strings and comments, and none of its
// escapes is one, so those are refused here first, as TOML syntax errors with line and column.
// (Only a non-ASCII character right after a line-ending backslash's whitespace is valid TOML.)
void refuse_misplaced_non_ascii(std::string_view text, std::string_view source_name) {
    enum class In { code, comment, basic, literal, ml_basic, ml_literal } in = In::code;
    std::size_t line = 1, line_start = 0;
    const auto fail = [&](std::size_t i, const char* what) {
        throw LocatedError(std::string(source_name) + ":" + std::to_string(line) + ":" +
                           std::to_string(i - line_start + 1) + ": TOML syntax error: a non-ASCII character " + what);
    };
    const auto at = [&](std::size_t i, std::string_view s) { return text.substr(i, s.size()) == s; };
    const auto newline = [&](std::size_t i) { ++line; line_start = i + 1; };
    for (std::size_t i = 0; i < text.size(); ++i) {
        const unsigned char ch = static_cast<unsigned char>(text[i]);
        if (ch == '\n') newline(i);
        switch (in) {
            case In::code:
                if (ch >= 0x80) fail(i, "outside a string or comment");
                if (ch == '#') in = In::comment;
                else if (at(i, "\"\"\"")) in = In::ml_basic, i += 2;
                else if (at(i, "'''")) in = In::ml_literal, i += 2;
                else if (ch == '"') in = In::basic;
                else if (ch == '\'') in = In::literal;
                break;
            case In::comment:
                if (ch == '\n') in = In::code;
                break;
            case In::literal:
                if (ch == '\'' || ch == '\n') in = In::code;
                break;
            case In::ml_literal:
                if (at(i, "'''")) {
                    in = In::code;
                    i += 2;
                    while (i + 1 < text.size() && text[i + 1] == '\'') ++i;  // up to two quotes of content
                }
                break;
            case In::basic:
            case In::ml_basic:
                if (ch == '\\') {
                    if (i + 1 >= text.size()) break;
                    if (static_cast<unsigned char>(text[i + 1]) >= 0x80) fail(i + 1, "after a backslash");
                    if (in == In::ml_basic && (text[i + 1] == ' ' || text[i + 1] == '\t' || text[i + 1] == '\r' ||
                                               text[i + 1] == '\n')) {
                        // a line-ending backslash: the whitespace after it is skipped
                        while (i + 1 < text.size() && (text[i + 1] == ' ' || text[i + 1] == '\t' ||
                                                       text[i + 1] == '\r' || text[i + 1] == '\n'))
                            if (text[++i] == '\n') newline(i);
                        if (i + 1 < text.size() && static_cast<unsigned char>(text[i + 1]) >= 0x80)
                            fail(i + 1, "right after a line-ending backslash (not supported by toml++ 3.3)");
                        break;
                    }
                    if (text[++i] == '\n') newline(i);
                } else if (in == In::basic && (ch == '"' || ch == '\n')) {
                    in = In::code;
                } else if (in == In::ml_basic && at(i, "\"\"\"")) {
                    in = In::code;
                    i += 2;
                    while (i + 1 < text.size() && text[i + 1] == '"') ++i;
                }
                break;
        }
    }
}

toml::table parse_toml(std::string_view text, std::string_view source_name) {
    refuse_misplaced_non_ascii(text, source_name);
    try {
        return toml::parse(text, source_name);
    } catch (const toml::parse_error& e) {
        throw LocatedError(where(e.source()) + "TOML syntax error: " + std::string(e.description()));
    }
}

// Keys that exclude each other: an override that sets one side drops the other side inherited
// from the preset (e.g. a file giving spectrum.wavelengths_nm replaces the preset's sampling).
const std::vector<std::pair<std::vector<std::string_view>, std::vector<std::string_view>>>& exclusive_keys() {
    static const std::vector<std::pair<std::vector<std::string_view>, std::vector<std::string_view>>> groups = {
        {{"sampling"}, {"wavelengths_nm"}},
        {{"extinction", "single_scattering_albedo"}, {"scattering", "absorption"}},
        {{"values_per_m"}, {"cross_sections_m2", "number_density_per_m3", "column_du"}},
        {{"number_density_per_m3"}, {"column_du"}},
        // [sun]: angles or place and time (a file giving a place replaces a preset's angles)
        {{"elevation_deg", "azimuth_deg"}, {"latitude_deg", "longitude_deg", "time", "delta_t_s"}},
    };
    return groups;
}

void merge_table(toml::table& base, toml::table&& over);

// [[constituent]] entries of an override are matched to the preset's by name and merged into
// them; entries with a new name are appended.
void merge_constituents(toml::array& base, toml::array&& over) {
    for (toml::node& e : over) {
        toml::table* ot = e.as_table();
        const toml::node* name = ot ? ot->get("name") : nullptr;
        toml::table* match = nullptr;
        if (name && name->is_string())
            for (toml::node& b : base)
                if (toml::table* bt = b.as_table())
                    if (const toml::node* bn = bt->get("name");
                        bn && bn->is_string() && bn->value<std::string>() == name->value<std::string>())
                        match = bt;
        if (match)
            merge_table(*match, std::move(*ot));
        else
            base.push_back(std::move(e));
    }
}

// Tables merge key by key; a sub-table that names its kind (`type` or `law`), a spectrum that
// names its `basis`, and every non-table value replace the inherited one as a whole.
void merge_table(toml::table& base, toml::table&& over) {
    for (const auto& [side_a, side_b] : exclusive_keys()) {
        const auto sets = [&](const std::vector<std::string_view>& keys) {
            return std::any_of(keys.begin(), keys.end(), [&](std::string_view k) { return over.contains(k); });
        };
        const auto drop = [&](const std::vector<std::string_view>& keys) {
            for (std::string_view k : keys) base.erase(k);
        };
        if (sets(side_a)) drop(side_b);
        if (sets(side_b)) drop(side_a);
    }
    for (auto&& [key, value] : over) {
        toml::node* existing = base.get(key.str());
        if (existing && key.str() == "constituent" && existing->is_array() && value.is_array()) {
            merge_constituents(*existing->as_array(), std::move(*value.as_array()));
            continue;
        }
        if (existing && existing->is_table() && value.is_table()) {
            const toml::table& ov = *value.as_table();
            const bool whole =
                ov.contains("type") || ov.contains("law") || (key.str() == "spectrum" && ov.contains("basis"));
            if (!whole) {
                merge_table(*existing->as_table(), std::move(*value.as_table()));
                continue;
            }
        }
        base.insert_or_assign(key.str(), std::move(value));
    }
}

// Replaces `preset = "name"` by the named preset with this table merged over it.
toml::table resolve_presets(toml::table doc, std::vector<std::string>& chain) {
    const toml::node* p = doc.get("preset");
    if (!p) return doc;
    std::vector<std::string> names = preset_names();
    if (!p->is_string())
        throw LocatedError(where(p->source()) + "preset = " + describe(*p) + ": must be a preset name (one of " +
                           join_quoted(names) + ")");
    const std::string name = p->as_string()->get();
    const auto text = embedded_preset(name);
    if (!text)
        throw LocatedError(where(p->source()) + "preset = " + in_quotes(name) +
                           ": unknown preset (available: " + join_quoted(names) + ")");
    if (std::find(chain.begin(), chain.end(), name) != chain.end())
        throw LocatedError(where(p->source()) + "preset = " + in_quotes(name) +
                           ": presets include each other in a cycle");
    chain.push_back(name);
    toml::table base = resolve_presets(parse_toml(*text, preset_source_name(name)), chain);
    doc.erase("preset");
    base.erase("name");  // a scene derived from a preset is named by its own file
    merge_table(base, std::move(doc));
    return base;
}

// Prefix a validate() message with the source position of the field it names.
std::string locate(const std::string& message, const SourceMap& sources, std::string_view source_name) {
    std::string path = message.substr(0, message.find_first_of(" :"));
    while (!path.empty()) {
        const auto it = sources.find(path);
        if (it != sources.end() && it->second.begin) return where(it->second) + message;
        const auto cut = path.find_last_of(".[");
        if (cut == std::string::npos) break;
        path.resize(cut);
    }
    return std::string(source_name) + ": " + message;
}

Scene parse_impl(std::string_view text, std::string_view source_name, const std::string& default_name,
                 std::vector<std::string> chain = {}) {
    toml::table root = resolve_presets(parse_toml(text, source_name), chain);
    SourceMap sources;
    try {
        Scene scene = SceneBuilder(sources).build(root, default_name);
        validate(scene);
        return scene;
    } catch (const LocatedError&) {
        throw;
    } catch (const SceneError& e) {
        // validate()'s messages name a field path: point them at the line that set it.
        throw SceneError(locate(e.what(), sources, source_name));
    }
}

std::string default_name_for(std::string_view source_name) {
    const std::filesystem::path p(source_name);
    if (p.extension() == ".toml") return p.stem().string();
    return "scene";
}

// ---------------------------------------------------------------------------------------------
// JSON

using Json = nlohmann::ordered_json;

Json pairs_json(const std::vector<std::pair<double, double>>& t, const char* x_key, const char* y_key) {
    Json x = Json::array(), y = Json::array();
    for (const auto& [a, b] : t) {
        x.push_back(a);
        y.push_back(b);
    }
    return Json{{x_key, std::move(x)}, {y_key, std::move(y)}};
}

Json coefficient_json(const SpectralCoefficient& c) {
    switch (c.law) {
        case SpectralCoefficient::Law::constant: return {{"law", "constant"}, {"value_per_m", c.value_per_m}};
        case SpectralCoefficient::Law::power_law:
            return {{"law", "power-law"},
                    {"value_per_m", c.value_per_m},
                    {"reference_nm", c.reference_nm},
                    {"exponent", c.exponent}};
        case SpectralCoefficient::Law::table: {
            Json j = {{"law", "table"}};
            j.update(pairs_json(c.table, "wavelengths_nm", "values_per_m"));
            return j;
        }
    }
    return {};
}

Json profile_json(const DensityProfile& p) {
    switch (p.kind) {
        case DensityProfile::Kind::exponential:
            return {{"type", "exponential"},
                    {"scale_height_m", p.scale_height_m},
                    {"reference_altitude_m", p.reference_altitude_m}};
        case DensityProfile::Kind::tent:
            return {{"type", "tent"}, {"bottom_m", p.bottom_m}, {"peak_m", p.peak_m}, {"top_m", p.top_m}};
        case DensityProfile::Kind::piecewise_linear: {
            Json j = {{"type", "piecewise-linear"}};
            j.update(pairs_json(p.knots, "altitudes_m", "densities"));
            return j;
        }
        case DensityProfile::Kind::constant:
            return {{"type", "constant"}, {"value", p.value}, {"bottom_m", p.bottom_m}, {"top_m", p.top_m}};
    }
    return {};
}

Json phase_json(const PhaseFunction& p) {
    switch (p.kind) {
        case PhaseFunction::Kind::rayleigh: return {{"type", "rayleigh"}};
        case PhaseFunction::Kind::rayleigh_modified: return {{"type", "rayleigh-modified"}};
        case PhaseFunction::Kind::isotropic: return {{"type", "isotropic"}};
        case PhaseFunction::Kind::cornette_shanks: return {{"type", "cornette-shanks"}, {"g", p.g}};
        case PhaseFunction::Kind::henyey_greenstein: return {{"type", "henyey-greenstein"}, {"g", p.g}};
    }
    return {};
}

Json vec3_json(const double (&v)[3]) { return Json::array({v[0], v[1], v[2]}); }

}  // namespace

// =============================================================================================
// Public interface

double vertical_column_m(const DensityProfile& p, double thickness_m) {
    if (!(thickness_m > 0.0)) return 0.0;
    // ∫ of a piecewise-linear function through `knots` (0 outside them) over [0, thickness].
    const auto piecewise = [thickness_m](const std::vector<std::pair<double, double>>& knots) {
        double sum = 0.0;
        for (std::size_t i = 0; i + 1 < knots.size(); ++i) {
            // Plain copies, not structured bindings: clang < 16 cannot capture those (the fuzz build).
            const double x0 = knots[i].first, y0 = knots[i].second;
            const double x1 = knots[i + 1].first, y1 = knots[i + 1].second;
            const double a = std::max(x0, 0.0), b = std::min(x1, thickness_m);
            if (!(b > a) || !(x1 > x0)) continue;
            const auto y = [&](double x) { return y0 + (y1 - y0) * (x - x0) / (x1 - x0); };
            sum += 0.5 * (b - a) * (y(a) + y(b));
        }
        return sum;
    };
    switch (p.kind) {
        case DensityProfile::Kind::exponential:
            // ∫₀^T exp(−(h − h₀)/H) dh = H·exp(h₀/H)·(1 − exp(−T/H))
            return -p.scale_height_m * std::exp(p.reference_altitude_m / p.scale_height_m) *
                   std::expm1(-thickness_m / p.scale_height_m);
        case DensityProfile::Kind::tent: return piecewise({{p.bottom_m, 0.0}, {p.peak_m, 1.0}, {p.top_m, 0.0}});
        case DensityProfile::Kind::piecewise_linear: return piecewise(p.knots);
        case DensityProfile::Kind::constant: {
            const double lo = std::max(p.bottom_m, 0.0);
            const double hi = p.top_m > p.bottom_m ? std::min(p.top_m, thickness_m) : thickness_m;
            return hi > lo ? p.value * (hi - lo) : 0.0;
        }
    }
    return 0.0;
}

void validate(const Scene& scene) {
    validate_planet(scene.planet);

    const Sun& sun = scene.sun;
    require_range(std::isfinite(sun.elevation_deg) && std::abs(sun.elevation_deg) <= 90.0, "sun.elevation_deg",
                  sun.elevation_deg, "must be in [-90, 90]");
    require_range(std::isfinite(sun.azimuth_deg) && std::abs(sun.azimuth_deg) <= 360.0, "sun.azimuth_deg",
                  sun.azimuth_deg, "must be in [-360, 360]");
    require_range(std::isfinite(sun.angular_radius_deg) && sun.angular_radius_deg > 0.0 &&
                      sun.angular_radius_deg <= kMaxAngularRadiusDeg,
                  "sun.angular_radius_deg", sun.angular_radius_deg,
                  "must be in (0, " + num(kMaxAngularRadiusDeg) + "]");

    const double altitude_km = scene.observer.altitude_m / kMetresPerKm;
    require_range(std::isfinite(altitude_km) && altitude_km >= 0.0 && altitude_km <= kMaxRadiusKm,
                  "observer.altitude_km", altitude_km, "must be in [0, " + num(kMaxRadiusKm) + "]");
    if (scene.camera) validate_camera(*scene.camera);

    validate_basis(scene.basis);
    const std::vector<double> wl = basis_wavelengths_nm(scene.basis);
    const double lo = *std::min_element(wl.begin(), wl.end());
    const double hi = *std::max_element(wl.begin(), wl.end());

    if (sun.irradiance_table.empty()) {
        require_range(std::isfinite(sun.irradiance_constant) && sun.irradiance_constant >= 0.0 &&
                          sun.irradiance_constant <= kMaxIrradiance,
                      "sun.irradiance.value_w_m2_nm", sun.irradiance_constant,
                      "must be in [0, " + num(kMaxIrradiance) + "] at the planet");
    } else {
        check_table("sun.irradiance", sun.irradiance_table, "values_w_m2_nm", lo, hi);
        for (std::size_t i = 0; i < sun.irradiance_table.size(); ++i)
            require_range(sun.irradiance_table[i].second <= kMaxIrradiance,
                          "sun.irradiance.values_w_m2_nm[" + std::to_string(i) + "]", sun.irradiance_table[i].second,
                          "must be in [0, " + num(kMaxIrradiance) + "] at the planet");
    }

    std::set<std::string> names;
    for (std::size_t i = 0; i < scene.constituents.size(); ++i) {
        const Constituent& c = scene.constituents[i];
        const std::string path = "constituent[" + std::to_string(i) + "]";
        if (!valid_name(c.name))
            throw SceneError(path + ".name = " + in_quotes(c.name) +
                             ": must be 1-64 characters from A-Z a-z 0-9 _ - . (it names a VDB grid)");
        if (!names.insert(c.name).second)
            throw SceneError(path + ".name = " + in_quotes(c.name) + ": another constituent already has this name");
        try {
            validate_profile(path + ".profile", c.profile);
            validate_coefficient(path + ".scattering", c.scattering, lo, hi);
            validate_coefficient(path + ".absorption", c.absorption, lo, hi);
            validate_phase(path + ".phase", c.phase);
            validate_extinction(path, c, wl);
        } catch (const SceneError& e) {
            throw SceneError(std::string(e.what()) + " (constituent " + in_quotes(c.name) + ")");
        }
    }
}

std::vector<Constituent> active_constituents(const Scene& scene) {
    std::vector<Constituent> out;
    for (const Constituent& c : scene.constituents)
        if (!c.scattering.is_zero() || !c.absorption.is_zero()) out.push_back(c);
    return out;
}

Scene parse_scene_toml(std::string_view toml_text, std::string_view source_name) {
    return parse_impl(toml_text, source_name, default_name_for(source_name));
}

Scene load_scene_file(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw SceneError(path.string() + ": cannot open the scene file");
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) throw SceneError(path.string() + ": cannot read the scene file");
    return parse_impl(text.str(), path.string(), path.stem().string());
}

Scene load_preset(std::string_view name) {
    const auto text = embedded_preset(name);
    if (!text)
        throw SceneError("unknown preset " + in_quotes(name) + " (available: " + join_quoted(preset_names()) + ")");
    return parse_impl(*text, preset_source_name(name), std::string(name), {std::string(name)});
}

std::vector<std::string> preset_names() {
    std::vector<std::string> names;
    for (std::size_t i = 0; i < detail::kEmbeddedPresetCount; ++i)
        if (detail::kEmbeddedPresets[i].name) names.emplace_back(detail::kEmbeddedPresets[i].name);
    std::sort(names.begin(), names.end());
    return names;
}

std::string scene_to_json(const Scene& scene) {
    Json j;
    j["format"] = "airmass-scene-1";
    j["name"] = scene.name;
    j["planet"] = {{"radius_m", scene.planet.radius_m},
                   {"atmosphere_top_m", scene.planet.atmosphere_top_m},
                   {"ground_albedo", scene.planet.ground_albedo}};
    Json irradiance;
    if (scene.sun.irradiance_table.empty()) {
        irradiance = {{"type", "constant"}, {"value_w_m2_nm", scene.sun.irradiance_constant}};
    } else {
        irradiance = {{"type", "table"}};
        irradiance.update(pairs_json(scene.sun.irradiance_table, "wavelengths_nm", "values_w_m2_nm"));
    }
    j["sun"] = {{"elevation_deg", scene.sun.elevation_deg},
                {"azimuth_deg", scene.sun.azimuth_deg},
                {"angular_radius_deg", scene.sun.angular_radius_deg},
                {"irradiance", std::move(irradiance)}};
    if (const auto& p = scene.sun.place) {
        j["sun"]["place"] = {{"latitude_deg", p->latitude_deg},
                             {"longitude_deg", p->longitude_deg},
                             {"time", format_utc(p->time)}};
        if (p->delta_t_s) j["sun"]["place"]["delta_t_s"] = *p->delta_t_s;
    }
    j["observer"] = {{"altitude_m", scene.observer.altitude_m}};
    if (scene.camera) {
        const Camera& c = *scene.camera;
        j["camera"] = {{"position_m", vec3_json(c.position_m)},
                       {"direction", vec3_json(c.direction)},
                       {"up", vec3_json(c.up)},
                       {"fov_deg", c.fov_deg},
                       {"max_distance_m", c.max_distance_m},
                       {"width", c.width},
                       {"height", c.height}};
    }
    j["spectrum"] = {{"basis", scene.basis.kind == SpectralBasis::Kind::rgb_schuler ? "rgb-schuler" : "spectral"},
                     {"wavelengths_nm", basis_wavelengths_nm(scene.basis)}};
    Json constituents = Json::array();
    for (const Constituent& c : scene.constituents)
        constituents.push_back({{"name", c.name},
                                {"profile", profile_json(c.profile)},
                                {"scattering", coefficient_json(c.scattering)},
                                {"absorption", coefficient_json(c.absorption)},
                                {"phase", phase_json(c.phase)}});
    j["constituents"] = std::move(constituents);
    return j.dump();
}

}  // namespace airmass
