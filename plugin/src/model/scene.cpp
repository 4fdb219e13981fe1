// The scene's value types: density profiles, spectral coefficients, solar irradiance.
#include "airmass/scene.hpp"

#include <algorithm>
#include <cmath>

namespace airmass {

namespace {

// Linear interpolation in a table of (x, y) knots with increasing x, clamped at the ends.
double interpolate_clamped(const std::vector<std::pair<double, double>>& t, double x) {
    if (t.empty()) return 0.0;
    if (x <= t.front().first) return t.front().second;
    if (x >= t.back().first) return t.back().second;
    const auto hi = std::lower_bound(t.begin(), t.end(), x, [](const auto& k, double v) { return k.first < v; });
    const auto lo = hi - 1;
    const double f = (x - lo->first) / (hi->first - lo->first);
    return lo->second + f * (hi->second - lo->second);
}

}  // namespace

double DensityProfile::at(double h) const {
    switch (kind) {
        case Kind::exponential: return std::exp(-(h - reference_altitude_m) / scale_height_m);
        case Kind::tent:
            if (h <= bottom_m || h >= top_m) return 0.0;
            return h <= peak_m ? (h - bottom_m) / (peak_m - bottom_m) : (top_m - h) / (top_m - peak_m);
        case Kind::piecewise_linear:
            if (knots.empty() || h < knots.front().first || h > knots.back().first) return 0.0;
            return std::max(0.0, interpolate_clamped(knots, h));
        case Kind::constant:
            if (h < bottom_m || (top_m > bottom_m && h > top_m)) return 0.0;
            return value;
    }
    return 0.0;
}

double SpectralCoefficient::at(double wavelength_nm) const {
    switch (law) {
        case Law::constant: return value_per_m;
        case Law::power_law: return value_per_m * std::pow(wavelength_nm / reference_nm, -exponent);
        case Law::table: return interpolate_clamped(table, wavelength_nm);
    }
    return 0.0;
}

bool SpectralCoefficient::is_zero() const {
    switch (law) {
        case Law::constant:
        case Law::power_law: return value_per_m == 0.0;
        case Law::table:
            return std::all_of(table.begin(), table.end(), [](const auto& k) { return k.second == 0.0; });
    }
    return true;
}

double Sun::irradiance_at(double wavelength_nm) const {
    return irradiance_table.empty() ? irradiance_constant : interpolate_clamped(irradiance_table, wavelength_nm);
}

}  // namespace airmass
