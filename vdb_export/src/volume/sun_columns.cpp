// The sun's columns for renderers that light the atmosphere themselves (volume.hpp,
// sun_column_table): per constituent, the mass along the ray from a point toward the sun
// to the top of the atmosphere, on Bruneton's transmittance-texture parametrisation, from
// the library's own optical depth (sun_masses: Chapman for exponential profiles, closed
// form for piecewise-linear ones).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

#include "airmass/atmosphere.hpp"
#include "airmass/multiple_scattering.hpp"
#include "airmass/optical_depth.hpp"
#include "airmass/volume.hpp"

namespace airmass {

void check_sun_table_sizes(std::string_view what, int mu_size, int r_size) {
    for (const auto& [name, n] : {std::pair<const char*, int>{"mu_size", mu_size}, {"r_size", r_size}})
        if (n < 2 || n > 4096)
            throw VdbError(std::string(what) + ": " + name + " = " + std::to_string(n) + ": must be in [2, 4096]");
}

SunColumnRay sun_column_ray(double planet_radius, double atmosphere_top, double x_mu, double x_r) {
    const double R = planet_radius, top = atmosphere_top;
    const double H = std::sqrt(std::max(0.0, top * top - R * R));
    const double rho = H * std::clamp(x_r, 0.0, 1.0);
    const double r = std::sqrt(rho * rho + R * R);
    const double d_min = top - r, d_max = rho + H;
    const double d = d_min + std::clamp(x_mu, 0.0, 1.0) * (d_max - d_min);
    const double mu = d <= 0.0 ? 1.0 : std::clamp((H * H - rho * rho - d * d) / (2.0 * r * d), -1.0, 1.0);
    return {r, mu};
}

SunColumnTable sun_column_table(const Scene& scene, const VdbOptions& options, int mu_size, int r_size) {
    check_sun_table_sizes("sun column table", mu_size, r_size);
    return sun_column_table(scene, resolve_vdb_layout(scene, options), mu_size, r_size);
}

SunColumnTable sun_column_table(const Scene& scene, const VdbLayout& layout, int mu_size, int r_size) {
    check_sun_table_sizes("sun column table", mu_size, r_size);
    const Atmosphere atmosphere = compile_atmosphere(scene, layout.rgb_wavelengths_nm);
    const std::size_t n_atm = atmosphere.constituents.size();

    SunColumnTable table;
    table.mu_size = mu_size;
    table.r_size = r_size;
    std::vector<std::size_t> from;  // layout constituent k → its index in the atmosphere
    for (const auto& c : layout.constituents) {
        const auto it = std::find_if(atmosphere.constituents.begin(), atmosphere.constituents.end(),
                                     [&](const AtmosphereConstituent& a) { return a.name == c.name; });
        if (it == atmosphere.constituents.end())
            throw std::logic_error("sun column table: constituent '" + c.name + "' is not in the atmosphere");
        from.push_back(static_cast<std::size_t>(it - atmosphere.constituents.begin()));
        table.names.push_back(c.name);
    }
    const std::size_t nc = from.size();
    table.mass.assign(static_cast<std::size_t>(mu_size) * static_cast<std::size_t>(r_size) * nc, 0.0f);

    const double L = layout.metres_per_unit;
    const double R = layout.planet_radius, top = layout.atmosphere_top;
    std::vector<double> mass(n_atm), previous(n_atm, 0.0);
    for (int j = 0; j < r_size; ++j) {
        for (int i = 0; i < mu_size; ++i) {
            const SunColumnRay ray = sun_column_ray(R, top, double(i) / (mu_size - 1), double(j) / (r_size - 1));
            const double altitude_m = std::max(0.0, (ray.r - R) * L);
            // The last column (x_mu = 1) is the ray grazing the ground; nudged up until lit.
            double mu = ray.mu;
            bool lit = sun_masses(atmosphere, altitude_m, ZenithAngle<double>::from_cos(mu), mass);
            for (int k = 0; !lit && k < 8; ++k) {
                mu = std::min(1.0, mu + 1e-9 * std::pow(10.0, k));
                lit = sun_masses(atmosphere, altitude_m, ZenithAngle<double>::from_cos(mu), mass);
            }
            if (!lit) mass = previous;  // the neighbour toward the zenith (i > 0 here)
            previous = mass;
            float* out = table.mass.data() + (static_cast<std::size_t>(j) * mu_size + i) * nc;
            for (std::size_t k = 0; k < nc; ++k) out[k] = static_cast<float>(mass[from[k]] / L);
        }
    }
    return table;
}

SunMsTable sun_ms_table(const Scene& scene, const VdbOptions& options, int mu_size, int r_size) {
    check_sun_table_sizes("sun multiple-scattering table", mu_size, r_size);
    const VdbLayout layout = resolve_vdb_layout(scene, options);
    // The renderer's RGB model (render.hpp renderer_rgb): channel c is wavelength c.
    const Atmosphere atmosphere = compile_atmosphere(scene, layout.rgb_wavelengths_nm);
    MsSettings settings;
    settings.mode = MsMode::isotropic_lut;
    const MultipleScattering ms = precompute_multiple_scattering(atmosphere, settings);

    SunMsTable table;
    table.mu_size = mu_size;
    table.r_size = r_size;
    table.mu_s_min = ms.grid.mu_s_min;
    table.psi.assign(static_cast<std::size_t>(mu_size) * static_cast<std::size_t>(r_size) * 3, 0.0f);
    std::size_t scatterer = atmosphere.constituents.size();
    for (std::size_t i = 0; i < atmosphere.constituents.size(); ++i)
        if (atmosphere.constituents[i].scatters) scatterer = std::min(scatterer, i);
    if (scatterer == atmosphere.constituents.size()) return table;  // nothing scatters: Ψ = 0

    const double L = layout.metres_per_unit;
    const double R = layout.planet_radius, top = layout.atmosphere_top;
    double psi[3];
    for (int j = 0; j < r_size; ++j) {
        // The same altitude axis as the columns' table (its x_r; x_mu plays no part in r).
        const double altitude_m = (sun_column_ray(R, top, 0.0, double(j) / (r_size - 1)).r - R) * L;
        for (int i = 0; i < mu_size; ++i) {
            MsPoint point;
            point.altitude_m = altitude_m;
            point.mu_s = table.mu_s_min + (1.0 - table.mu_s_min) * double(i) / (mu_size - 1);
            ms_phase_radiance(ms, scatterer, point, std::span<double>(psi, 3));
            float* out = table.psi.data() + (static_cast<std::size_t>(j) * mu_size + i) * 3;
            for (int c = 0; c < 3; ++c) out[c] = static_cast<float>(std::max(0.0, psi[c]));
        }
    }
    return table;
}

}  // namespace airmass
