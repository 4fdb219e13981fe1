// The multiple-scattering grid: where its nodes are and the continuous node coordinates
// of any (altitude, view zenith, sun zenith, azimuth) — the parameterisation of seed 004
// with the mappings of multiple_scattering.hpp (MsParameterisation).
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>

#include "airmass/multiple_scattering.hpp"
#include "airmass/optical_depth.hpp"

namespace airmass {

namespace {

constexpr double kPi = std::numbers::pi;

std::string num(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

void require(bool ok, const std::string& field, double value, const std::string& range) {
    if (!ok) throw std::invalid_argument("multiple scattering: " + field + " = " + num(value) + ": " + range);
}

// sqrt(r² − R²) without cancellation for r ≈ R.
double rho_of(double r, double R) { return std::sqrt(std::max((r - R) * (r + R), 0.0)); }

// Position x ∈ [0, 1] of coordinate s inside a half [lo, lo + n − 1] of nodes.
double clamp01(double x) { return std::clamp(x, 0.0, 1.0); }

}  // namespace

std::string_view ms_mode_name(MsMode m) {
    switch (m) {
        case MsMode::orders: return "orders";
        case MsMode::isotropic_lut: return "isotropic-lut";
    }
    return "?";
}

std::string_view ms_parameterisation_name(MsParameterisation p) {
    switch (p) {
        case MsParameterisation::horizon: return "horizon";
        case MsParameterisation::bruneton: return "bruneton";
        case MsParameterisation::seed004: return "seed004";
    }
    return "?";
}

void validate(const MsSettings& s) {
    const bool split = s.parameterisation != MsParameterisation::seed004;
    require(s.table.altitude >= 2 && s.table.altitude <= 1024, "table.altitude", s.table.altitude, "must be in [2, 1024]");
    require(s.table.view_zenith >= (split ? 4 : 2) && s.table.view_zenith <= 4096 &&
                (!split || s.table.view_zenith % 2 == 0),
            "table.view_zenith", s.table.view_zenith,
            split ? "must be even and in [4, 4096] (the horizon splits the nodes in two halves)"
                  : "must be in [2, 4096]");
    require(s.table.sun_zenith >= 2 && s.table.sun_zenith <= 4096, "table.sun_zenith", s.table.sun_zenith,
            "must be in [2, 4096]");
    require(s.table.azimuth >= 0 && s.table.azimuth <= 1024, "table.azimuth", s.table.azimuth,
            "must be in [0, 1024] (0: automatic, 1: azimuth-averaged)");
    require(s.max_order == 0 || (s.max_order >= 2 && s.max_order <= 1000), "max_order", s.max_order,
            "must be 0 (automatic) or in [2, 1000]");
    require(std::isfinite(s.tolerance) && s.tolerance > 0.0 && s.tolerance < 1.0, "tolerance", s.tolerance,
            "must be in (0, 1)");
    require(s.max_auto_order >= 2 && s.max_auto_order <= 1000, "max_auto_order", s.max_auto_order,
            "must be in [2, 1000]");
    require(s.ray_samples >= 1 && s.ray_samples <= 100000, "ray_samples", s.ray_samples, "must be in [1, 100000]");
    require(s.order1_ray_samples >= 1 && s.order1_ray_samples <= 100000, "order1_ray_samples", s.order1_ray_samples,
            "must be in [1, 100000]");
    require(s.transmittance_altitude >= 2 && s.transmittance_altitude <= 100000, "transmittance_altitude",
            s.transmittance_altitude, "must be in [2, 100000]");
    require(s.transmittance_sun >= 2 && s.transmittance_sun <= 100000, "transmittance_sun", s.transmittance_sun,
            "must be in [2, 100000]");
    require(s.phase_subsamples >= 1 && s.phase_subsamples <= 64, "phase_subsamples", s.phase_subsamples,
            "must be in [1, 64]");
    require(s.threads >= 0 && s.threads <= 4096, "threads", s.threads, "must be in [0, 4096] (0: all)");
    const double nodes =
        double(s.table.altitude) * s.table.view_zenith * s.table.sun_zenith * std::max(s.table.azimuth, 12);
    require(nodes <= 2e8, "table node count", nodes, "must be ≤ 2e8");
}

int ms_automatic_azimuth_nodes(const Atmosphere& atm) {
    // Forward-peaked scatterers put structure into the multiple-scattering field that is
    // narrow in azimuth (the aureole of once-scattered light, scattered forward again); with
    // g·τ_s above 0.05 six azimuth nodes (36° cells) misplace it by several per cent
    // (`earth-hazy`, `mars`: 4–17 % at 6 nodes, ≤ 3 % at 12; docs/multiple_scattering.md).
    const PlanetRay<double> up{atm.planet_radius_m, 0.0, {1.0, 0.0}};
    for (const auto& c : atm.constituents) {
        if (!c.scatters) continue;
        const bool peaked = (c.phase.kind == PhaseFunction::Kind::cornette_shanks ||
                             c.phase.kind == PhaseFunction::Kind::henyey_greenstein) &&
                            std::abs(c.phase.g) > 0.3;
        if (!peaked) continue;
        const double column = profile_segment_mass(c.profile, atm.settings.chapman, up, atm.top_altitude_m, 0.0,
                                                   std::numeric_limits<double>::infinity());
        for (double s : c.scattering_per_m)
            if (std::abs(c.phase.g) * s * column > 0.05) return 12;
    }
    return 6;
}

MsGrid MsGrid::make(const Atmosphere& atm, MsParameterisation p, MsTableSize size) {
    if (size.azimuth == 0) size.azimuth = ms_automatic_azimuth_nodes(atm);
    MsGrid g;
    g.parameterisation = p;
    g.size = size;
    g.planet_radius_m = atm.planet_radius_m;
    g.top_radius_m = atm.planet_radius_m + atm.top_altitude_m;
    if (p == MsParameterisation::seed004) {
        g.mu_s_min = -1.0;
    } else {
        // Secondary light reaches a ground point whose sun is up to two horizon dips below
        // its horizon (the lit top of the atmosphere seen past the tangent point); beyond
        // that only light that crossed the shadow twice at grazing incidence remains, which
        // is negligible (docs/multiple_scattering.md). Fewer wasted sun nodes than 3 dips.
        const double dip = std::acos(std::clamp(g.planet_radius_m / g.top_radius_m, 0.0, 1.0));
        g.mu_s_min = std::cos(std::min(kPi, 0.5 * kPi + 2.0 * dip));
    }
    return g;
}

double MsGrid::horizon_mu(double r) const {
    if (!(r > planet_radius_m)) return 0.0;
    return -rho_of(r, planet_radius_m) / r;
}

// ---- altitude ----------------------------------------------------------------------------

double MsGrid::altitude_node_m(int a) const {
    const double x = double(a) / (size.altitude - 1);
    const double R = planet_radius_m, top = top_radius_m - R;
    if (parameterisation == MsParameterisation::seed004) return x * x * top;
    const double rho = x * rho_of(top_radius_m, R);
    return rho * rho / (std::sqrt(R * R + rho * rho) + R);  // r − R without cancellation
}

double MsGrid::altitude_coord(double h) const {
    const double R = planet_radius_m, top = top_radius_m - R;
    h = std::clamp(h, 0.0, top);
    double x;
    if (parameterisation == MsParameterisation::seed004) x = std::sqrt(h / top);
    else x = std::sqrt(h * (2.0 * R + h)) / rho_of(top_radius_m, R);
    return clamp01(x) * (size.altitude - 1);
}

// ---- view zenith ---------------------------------------------------------------------------

double MsGrid::view_node_mu(int a, int b) const { return view_mu(planet_radius_m + altitude_node_m(a), b); }

double MsGrid::view_mu(double r, double s) const {
    const int n = size.view_zenith;
    if (!split_view()) {
        const double v = 2.0 * s / (n - 1) - 1.0;
        return v * v * v;
    }
    const int half = n / 2;
    const bool ground = s < half - 0.5;
    // ground: nadir (x = 0) → horizon (x = 1); sky: horizon (x = 0) → zenith (x = 1)
    const double x = clamp01((ground ? s : s - half) / (half - 1));
    const double mu_h = horizon_mu(r);
    if (parameterisation == MsParameterisation::horizon) {
        if (ground) return mu_h - (1.0 + mu_h) * (1.0 - x) * (1.0 - x);
        return mu_h + (1.0 - mu_h) * x * x;
    }
    // Bruneton 2017: uniform in the distance to the ground / to the top.
    const double R = planet_radius_m, H = rho_of(top_radius_m, R), rho = rho_of(r, R);
    if (ground) {
        const double d_min = r - R, d_max = rho;
        if (!(d_max - d_min > 1e-9 * R)) return -1.0 + x * (1.0 + mu_h);  // at the ground: linear
        const double d = d_min + x * (d_max - d_min);
        return d == 0.0 ? -1.0 : std::clamp(-(rho * rho + d * d) / (2.0 * r * d), -1.0, mu_h);
    }
    const double d_min = top_radius_m - r, d_max = rho + H;
    const double d = d_max - x * (d_max - d_min);
    return d == 0.0 ? 1.0 : std::clamp((H * H - rho * rho - d * d) / (2.0 * r * d), mu_h, 1.0);
}

double MsGrid::view_coord(double r, double mu, bool ground) const {
    const int n = size.view_zenith;
    mu = std::clamp(mu, -1.0, 1.0);
    if (!split_view()) {
        const double v = 0.5 * (1.0 + std::copysign(std::cbrt(std::abs(mu)), mu));
        return clamp01(v) * (n - 1);
    }
    const int half = n / 2;
    r = std::clamp(r, planet_radius_m, top_radius_m);
    const double mu_h = horizon_mu(r);
    double x;
    if (parameterisation == MsParameterisation::horizon) {
        if (ground) x = 1.0 - std::sqrt(std::max(mu_h - mu, 0.0) / (1.0 + mu_h));
        else x = std::sqrt(std::max(mu - mu_h, 0.0) / (1.0 - mu_h));
    } else {
        const double R = planet_radius_m, H = rho_of(top_radius_m, R), rho = rho_of(r, R);
        const double disc_base = r * r * (mu * mu - 1.0);
        if (ground) {
            const double d_min = r - R, d_max = rho;
            if (!(d_max - d_min > 1e-9 * R)) {
                x = (mu + 1.0) / std::max(1.0 + mu_h, 1e-300);
            } else {
                const double d = -r * mu - std::sqrt(std::max(disc_base + R * R, 0.0));
                x = (d - d_min) / (d_max - d_min);
            }
        } else {
            const double d_min = top_radius_m - r, d_max = rho + H;
            const double d = -r * mu + std::sqrt(std::max(disc_base + top_radius_m * top_radius_m, 0.0));
            x = d_max > d_min ? (d_max - d) / (d_max - d_min) : 1.0;
        }
    }
    x = clamp01(x);
    return ground ? x * (half - 1) : half + x * (half - 1);
}

// ---- sun zenith ------------------------------------------------------------------------------

double MsGrid::sun_node_mu(int c) const {
    const double x = double(c) / (size.sun_zenith - 1);
    if (parameterisation == MsParameterisation::seed004) {
        const double v = 2.0 * x - 1.0;
        return v * v * v;
    }
    // Bruneton 2017 (GetRMuMuSNuFromScatteringTextureUvwz), with this planet's mu_s_min.
    const double R = planet_radius_m, H = rho_of(top_radius_m, R);
    const double d_min = top_radius_m - R, d_max = H;
    const auto dist = [&](double mu_s) { return -R * mu_s + std::sqrt(R * R * mu_s * mu_s + H * H); };
    const double A = (dist(mu_s_min) - d_min) / (d_max - d_min);
    const double a = (A - x * A) / (1.0 + x * A);
    const double d = d_min + std::min(a, A) * (d_max - d_min);
    return d == 0.0 ? 1.0 : std::clamp((H * H - d * d) / (2.0 * R * d), -1.0, 1.0);
}

double MsGrid::sun_coord(double mu_s) const {
    mu_s = std::clamp(mu_s, mu_s_min, 1.0);
    double x;
    if (parameterisation == MsParameterisation::seed004) {
        x = 0.5 * (1.0 + std::copysign(std::cbrt(std::abs(mu_s)), mu_s));
    } else {
        const double R = planet_radius_m, H = rho_of(top_radius_m, R);
        const double d_min = top_radius_m - R, d_max = H;
        const auto dist = [&](double m) { return -R * m + std::sqrt(R * R * m * m + H * H); };
        const double A = (dist(mu_s_min) - d_min) / (d_max - d_min);
        const double a = (dist(mu_s) - d_min) / (d_max - d_min);
        x = std::max(1.0 - a / A, 0.0) / (1.0 + a);
    }
    return clamp01(x) * (size.sun_zenith - 1);
}

// ---- azimuth -------------------------------------------------------------------------------

double MsGrid::azimuth_node_rad(int d) const {
    if (size.azimuth == 1) return 0.0;
    return kPi * d / (size.azimuth - 1);
}

double MsGrid::azimuth_coord(double phi) const {
    if (size.azimuth == 1) return 0.0;
    return std::clamp(phi / kPi, 0.0, 1.0) * (size.azimuth - 1);
}

// ---- points -----------------------------------------------------------------------------

MsPoint MsPoint::from_vectors(double R, Vec3<double> position, Vec3<double> view, Vec3<double> sun) {
    const double r = glm::length(position);
    MsPoint p;
    p.altitude_m = r - R;
    const Vec3<double> up = r > 0.0 ? position / r : Vec3<double>(0.0, 0.0, 1.0);
    p.mu = std::clamp(glm::dot(up, view), -1.0, 1.0);
    p.mu_s = std::clamp(glm::dot(up, sun), -1.0, 1.0);
    p.nu = std::clamp(glm::dot(view, sun), -1.0, 1.0);
    return p;
}

}  // namespace airmass
