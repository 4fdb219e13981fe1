// compile_atmosphere: a Scene reduced to what the evaluator needs at given wavelengths.
#include "airmass/atmosphere.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "airmass/phase.hpp"
#include "math/quadrature.hpp"
#include "airmass/scene_io.hpp"

namespace airmass {

namespace {

std::string num(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

[[noreturn]] void scene_error(const std::string& field, double value, const std::string& range) {
    throw SceneError(field + " = " + num(value) + ": " + range);
}

void require(bool ok, const std::string& field, double value, const std::string& range) {
    if (!ok) scene_error(field, value, range);
}

// A scene profile as exponential or as knots of a piecewise-linear function of altitude.
CompiledProfile compile_profile(const DensityProfile& d, const std::string& field, double top_altitude_m,
                                double planet_radius_m) {
    CompiledProfile c;
    switch (d.kind) {
        case DensityProfile::Kind::exponential: {
            require(std::isfinite(d.scale_height_m) && d.scale_height_m > 0.0, field + ".scale_height_m",
                    d.scale_height_m, "must be finite and > 0");
            require(std::isfinite(d.reference_altitude_m), field + ".reference_altitude_m", d.reference_altitude_m,
                    "must be finite");
            c.kind = CompiledProfile::Kind::exponential;
            c.scale_height_m = d.scale_height_m;
            c.reference_altitude_m = d.reference_altitude_m;
            // Mass above the top, relative to the ground column, is at most
            // exp(−top/H) · Ch∥(x_top) (a grazing exit); below 1e-12 the top is left out.
            const double x_top = (planet_radius_m + top_altitude_m) / d.scale_height_m;
            const double ch_par = (0.5 / x_top + 1.0) * std::sqrt(0.5 * std::numbers::pi * x_top);
            c.truncate_at_top = -top_altitude_m / d.scale_height_m + std::log(ch_par) > std::log(1e-12);
            return c;
        }
        case DensityProfile::Kind::tent: {
            require(std::isfinite(d.bottom_m), field + ".bottom_m", d.bottom_m, "must be finite");
            require(std::isfinite(d.peak_m) && d.peak_m >= d.bottom_m, field + ".peak_m", d.peak_m,
                    "must be finite and ≥ bottom_m (" + num(d.bottom_m) + ")");
            require(std::isfinite(d.top_m) && d.top_m >= d.peak_m && d.top_m > d.bottom_m, field + ".top_m", d.top_m,
                    "must be finite, ≥ peak_m and > bottom_m");
            c.kind = CompiledProfile::Kind::piecewise_linear;
            c.altitude_m = {d.bottom_m, d.peak_m, d.top_m};
            c.density = {0.0, 1.0, 0.0};
            return c;
        }
        case DensityProfile::Kind::piecewise_linear: {
            if (d.knots.size() < 2) scene_error(field + ".knots (count)", double(d.knots.size()), "needs ≥ 2 knots");
            c.kind = CompiledProfile::Kind::piecewise_linear;
            for (std::size_t k = 0; k < d.knots.size(); ++k) {
                const auto [a, v] = d.knots[k];
                const std::string f = field + ".knots[" + std::to_string(k) + "]";
                require(std::isfinite(a) && (k == 0 || a > d.knots[k - 1].first), f + ".altitude_m", a,
                        "must be finite and increasing");
                require(std::isfinite(v) && v >= 0.0, f + ".density", v, "must be finite and ≥ 0");
                c.altitude_m.push_back(a);
                c.density.push_back(v);
            }
            return c;
        }
        case DensityProfile::Kind::constant: {
            require(std::isfinite(d.value) && d.value >= 0.0, field + ".value", d.value, "must be finite and ≥ 0");
            require(std::isfinite(d.bottom_m), field + ".bottom_m", d.bottom_m, "must be finite");
            const double top = d.top_m > d.bottom_m ? d.top_m : top_altitude_m;
            require(std::isfinite(top) && top > d.bottom_m, field + ".top_m", d.top_m,
                    "must be > bottom_m, or 0 for the top of the atmosphere");
            c.kind = CompiledProfile::Kind::piecewise_linear;
            c.altitude_m = {d.bottom_m, top};
            c.density = {d.value, d.value};
            return c;
        }
    }
    throw SceneError(field + ": unknown density profile kind");
}

bool profile_is_zero(const CompiledProfile& c) {
    if (c.kind == CompiledProfile::Kind::exponential) return false;
    return std::all_of(c.density.begin(), c.density.end(), [](double v) { return v == 0.0; });
}

}  // namespace

double CompiledProfile::at(double h) const {
    if (kind == Kind::exponential) return std::exp(-(h - reference_altitude_m) / scale_height_m);
    if (altitude_m.empty() || h < altitude_m.front() || h > altitude_m.back()) return 0.0;
    const auto hi = std::upper_bound(altitude_m.begin(), altitude_m.end(), h);
    if (hi == altitude_m.end()) return density.back();
    const std::size_t k = std::size_t(hi - altitude_m.begin()) - 1;
    const double f = (h - altitude_m[k]) / (altitude_m[k + 1] - altitude_m[k]);
    return density[k] + f * (density[k + 1] - density[k]);
}

Atmosphere compile_atmosphere(const Scene& scene, std::span<const double> wavelengths_nm,
                              const EvalSettings& settings) {
    const Planet& planet = scene.planet;
    require(std::isfinite(planet.radius_m) && planet.radius_m > 0.0, "planet.radius_m", planet.radius_m,
            "must be finite and > 0");
    require(std::isfinite(planet.atmosphere_top_m) && planet.atmosphere_top_m > planet.radius_m,
            "planet.atmosphere_top_m", planet.atmosphere_top_m,
            "must be finite and > planet.radius_m (" + num(planet.radius_m) + ")");
    require(std::isfinite(planet.ground_albedo) && planet.ground_albedo >= 0.0 && planet.ground_albedo <= 1.0,
            "planet.ground_albedo", planet.ground_albedo, "must be in [0, 1]");
    require(std::isfinite(scene.sun.angular_radius_deg) && scene.sun.angular_radius_deg >= 0.0 &&
                scene.sun.angular_radius_deg < 90.0,
            "sun.angular_radius_deg", scene.sun.angular_radius_deg, "must be in [0, 90)");
    if (wavelengths_nm.empty()) throw std::invalid_argument("wavelengths: need at least one wavelength");
    for (double w : wavelengths_nm)
        if (!(std::isfinite(w) && w > 0.0 && w < 1e6))
            throw std::invalid_argument("wavelength_nm = " + num(w) + ": must be in (0, 1e6)");
    if (settings.view_samples < 1 || settings.view_samples > 1000000)
        throw std::invalid_argument("view_samples = " + std::to_string(settings.view_samples) +
                                    ": must be in [1, 1000000]");

    Atmosphere atm;
    atm.planet_radius_m = planet.radius_m;
    atm.top_altitude_m = planet.atmosphere_top_m - planet.radius_m;
    atm.ground_albedo = planet.ground_albedo;
    atm.sun_angular_radius_rad = scene.sun.angular_radius_deg * std::numbers::pi / 180.0;
    atm.settings = settings;
    atm.wavelengths_nm.assign(wavelengths_nm.begin(), wavelengths_nm.end());
    for (double w : wavelengths_nm) {
        const double e = scene.sun.irradiance_at(w);
        require(std::isfinite(e) && e >= 0.0, "sun.irradiance at " + num(w) + " nm", e, "must be finite and ≥ 0");
        atm.sun_irradiance.push_back(e);
    }

    std::vector<CompiledProfile> profiles;  // every constituent's, for the knots
    for (std::size_t i = 0; i < scene.constituents.size(); ++i) {
        const Constituent& sc = scene.constituents[i];
        const std::string field = "constituents[" + std::to_string(i) + "] (" + sc.name + ")";
        AtmosphereConstituent c;
        c.name = sc.name;
        c.scene_index = i;
        c.phase = sc.phase;
        if (sc.phase.kind == PhaseFunction::Kind::cornette_shanks ||
            sc.phase.kind == PhaseFunction::Kind::henyey_greenstein)
            require(std::isfinite(sc.phase.g) && sc.phase.g > -1.0 && sc.phase.g < 1.0, field + ".phase.g",
                    sc.phase.g, "must be in (-1, 1)");
        c.rayleigh_like = is_rayleigh_like(sc.phase);
        bool active = false;
        for (double w : wavelengths_nm) {
            const double s = sc.scattering.at(w), a = sc.absorption.at(w);
            require(std::isfinite(s) && s >= 0.0, field + ".scattering at " + num(w) + " nm", s,
                    "must be finite and ≥ 0 m^-1");
            require(std::isfinite(a) && a >= 0.0, field + ".absorption at " + num(w) + " nm", a,
                    "must be finite and ≥ 0 m^-1");
            c.scattering_per_m.push_back(s);
            c.absorption_per_m.push_back(a);
            c.extinction_per_m.push_back(s + a);
            active = active || s + a > 0.0;
            c.scatters = c.scatters || s > 0.0;
        }
        c.profile = compile_profile(sc.profile, field + ".profile", atm.top_altitude_m, atm.planet_radius_m);
        profiles.push_back(c.profile);
        if (!active || profile_is_zero(c.profile)) continue;  // a scene pays only for what it declares
        atm.constituents.push_back(std::move(c));
    }
    if (atm.constituents.size() > kMaxConstituents)
        throw SceneError("constituents: " + std::to_string(atm.constituents.size()) +
                         " active constituents, at most " + std::to_string(kMaxConstituents) + " are supported");
    for (std::size_t w = 0; w < atm.wavelengths_nm.size(); ++w)
        for (const auto& c : atm.constituents) atm.extinction_matrix.push_back(c.extinction_per_m[w]);
    atm.gauss_rules = unit_gauss_rule_table();
    atm.knots_m = profile_knots_m(profiles);
    return atm;
}

std::vector<double> profile_knots_m(const Scene& scene) {
    const double R = scene.planet.radius_m, top = scene.planet.atmosphere_top_m - R;
    std::vector<CompiledProfile> profiles;
    for (std::size_t i = 0; i < scene.constituents.size(); ++i)
        profiles.push_back(compile_profile(scene.constituents[i].profile,
                                           "constituents[" + std::to_string(i) + "] (" +
                                               scene.constituents[i].name + ").profile",
                                           top, R));
    return profile_knots_m(profiles);
}

std::vector<double> profile_knots_m(std::span<const CompiledProfile> profiles) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    std::vector<std::pair<double, double>> knots;  // (strength, altitude)
    for (const CompiledProfile& c : profiles) {
        if (c.kind != CompiledProfile::Kind::piecewise_linear || profile_is_zero(c)) continue;
        const std::vector<double>&a = c.altitude_m, &d = c.density;
        const std::size_t n = a.size();
        const double d_max = *std::max_element(d.begin(), d.end()), thickness = a.back() - a.front();
        // The slope on either side of a knot (0 outside the profile); a density that jumps —
        // at a repeated altitude or at an end that is not 0 — counts as infinitely steep.
        const auto slope = [&](std::size_t j) {  // of the piece [a_j, a_{j+1}]
            return a[j + 1] > a[j] ? (d[j + 1] - d[j]) / (a[j + 1] - a[j]) : kInf;
        };
        for (std::size_t j = 0; j < n; ++j) {
            const double left = j == 0 ? (d[0] > 0.0 ? kInf : 0.0) : slope(j - 1);
            const double right = j + 1 == n ? (d[n - 1] > 0.0 ? kInf : 0.0) : slope(j);
            const double jump = std::isinf(left) || std::isinf(right) ? kInf : std::abs(right - left);
            // The slope's jump against the profile's mean slope d_max / thickness (a tent's
            // knots: 2, 4, 2); smaller ones, a smooth curve sampled densely, are no kinks.
            const double strength = jump * thickness / d_max;
            if (strength >= kMinKinkStrength) knots.emplace_back(strength, a[j]);
        }
    }
    std::stable_sort(knots.begin(), knots.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
    if (knots.size() > kMaxProfileKinks) knots.resize(kMaxProfileKinks);
    std::vector<double> altitudes;
    for (const auto& k : knots) altitudes.push_back(k.second);
    return altitudes;
}

void set_view_samples(Atmosphere& atmosphere, int view_samples) {
    if (view_samples < 1 || view_samples > 1000000)
        throw std::invalid_argument("view_samples = " + std::to_string(view_samples) + ": must be in [1, 1000000]");
    atmosphere.settings.view_samples = view_samples;
}

void set_constant_irradiance(Atmosphere& atmosphere, double irradiance) {
    if (!(std::isfinite(irradiance) && irradiance >= 0.0))
        throw std::invalid_argument("solar irradiance = " + num(irradiance) + ": must be finite and ≥ 0");
    std::fill(atmosphere.sun_irradiance.begin(), atmosphere.sun_irradiance.end(), irradiance);
}

}  // namespace airmass
