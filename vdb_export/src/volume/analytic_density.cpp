// The densities in closed form: a JSON description (for the Blender add-on's Cycles
// node tree) and a POV-Ray include of function patterns. Both carry exactly what the
// grids' metadata carries, so a renderer can use either path (docs/vdb.md).
#include <cstdio>
#include <numbers>
#include <sstream>

#include "airmass/phase.hpp"
#include "airmass/volume.hpp"
#include "volume_format.hpp"

#ifndef AIRMASS_VERSION
#define AIRMASS_VERSION "unknown"
#endif

namespace airmass {

using detail::fmt;

namespace {

// Full precision for numbers that end up in shaders.
std::string num(double x) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.9g", x);
    return buf;
}

nlohmann::json rgb(const std::array<double, 3>& a) { return nlohmann::json::array({a[0], a[1], a[2]}); }

// The profile as a POV-Ray expression of the altitude `h` (an SDL expression string,
// in the unit), zero outside the constituent's support and above `top`.
// POV-Ray's select(a, b, c) is b when a < 0, else c.
std::string pov_profile_expression(const DensityProfile& p, double L, double top, const std::string& h) {
    std::string body;
    switch (p.kind) {
        case DensityProfile::Kind::exponential:
            body = "exp(-(" + h + " - " + num(p.reference_altitude_m / L) + ") / " + num(p.scale_height_m / L) + ")";
            break;
        case DensityProfile::Kind::tent: {
            const double b = p.bottom_m / L, k = p.peak_m / L, t = p.top_m / L;
            body = "select(" + h + " - " + num(b) + ", 0, select(" + h + " - " + num(k) + ", (" + h + " - " + num(b) +
                   ") / " + num(k - b) + ", select(" + h + " - " + num(t) + ", (" + num(t) + " - " + h + ") / " +
                   num(t - k) + ", 0)))";
            break;
        }
        case DensityProfile::Kind::piecewise_linear: {
            // Nested selects from the last piece inwards; 0 outside the knots.
            if (p.knots.empty()) return "0";
            std::string e = "select(" + h + " - " + num(p.knots.back().first / L) + ", " + num(p.knots.back().second) +
                            ", 0)";
            for (std::size_t i = p.knots.size() - 1; i-- > 0;) {
                const double h0 = p.knots[i].first / L, h1 = p.knots[i + 1].first / L;
                const double r0 = p.knots[i].second, r1 = p.knots[i + 1].second;
                const std::string piece =
                    h1 > h0 ? num(r0) + " + (" + h + " - " + num(h0) + ") * " + num((r1 - r0) / (h1 - h0)) : num(r1);
                e = "select(" + h + " - " + num(h1) + ", " + piece + ", " + e + ")";
            }
            body = "select(" + h + " - " + num(p.knots.front().first / L) + ", 0, " + e + ")";
            break;
        }
        case DensityProfile::Kind::constant: {
            const double b = p.bottom_m / L;
            const double t = p.top_m > p.bottom_m ? p.top_m / L : top;
            body = "select(" + h + " - " + num(b) + ", 0, select(" + h + " - " + num(t) + ", " + num(p.value) + ", 0))";
            break;
        }
    }
    return "select(" + h + " - " + num(top) + ", " + body + ", 0)";
}

// POV-Ray's scattering type for a phase function: its own Rayleigh (type 4, the same shape
// as ours) where it matches, isotropic (1) where it is, and otherwise Henyey–Greenstein (5)
// with the eccentricity of the project's one phase -> HG rule (henyey_greenstein_g).
int pov_scattering_type(PhaseFunction::Kind k) {
    switch (k) {
        case PhaseFunction::Kind::rayleigh: return 4;
        case PhaseFunction::Kind::isotropic: return 1;
        case PhaseFunction::Kind::rayleigh_modified:
        case PhaseFunction::Kind::cornette_shanks:
        case PhaseFunction::Kind::henyey_greenstein: return 5;
    }
    return 5;
}

std::string pov_rgb(const std::array<double, 3>& a, double scale = 1.0) {
    return "rgb <" + num(a[0] * scale) + ", " + num(a[1] * scale) + ", " + num(a[2] * scale) + ">";
}

}  // namespace

std::string analytic_density_json(const Scene& scene, const VdbOptions& options) {
    const VdbLayout layout = resolve_vdb_layout(scene, options);
    using nlohmann::json;
    json constituents = json::array();
    for (const auto& c : layout.constituents) {
        std::array<double, 3> ext{};
        for (int i = 0; i < 3; ++i) ext[i] = c.scattering_rgb[i] + c.absorption_rgb[i];
        constituents.push_back(json{{"name", c.name},
                                    {"profile", detail::profile_json(c.source->profile, layout.metres_per_unit)},
                                    {"density_max", c.density_max},
                                    {"scattering_rgb", rgb(c.scattering_rgb)},
                                    {"absorption_rgb", rgb(c.absorption_rgb)},
                                    {"extinction_rgb", rgb(ext)},
                                    {"phase", detail::phase_name(c.source->phase.kind)},
                                    {"g", c.source->phase.g},
                                    // What Henyey–Greenstein-only renderers get (phase.hpp).
                                    {"g_hg", henyey_greenstein_g(c.source->phase)}});
    }
    const json j{
        {"format", "airmass-analytic-density"},
        {"format_version", kVdbFormatVersion},
        {"airmass_version", AIRMASS_VERSION},
        {"scene_name", layout.scene_name},
        {"length_unit", std::string(length_unit_name(options.unit))},
        {"planet_radius", layout.planet_radius},
        {"planet_center", {layout.planet_center[0], layout.planet_center[1], layout.planet_center[2]}},
        {"atmosphere_top", layout.atmosphere_top},
        {"altitude", "h = |p - planet_center| - planet_radius; density 0 where h > atmosphere_top - planet_radius"},
        {"spectral_basis", layout.spectral_basis},
        {"rgb_wavelengths_nm", rgb(layout.rgb_wavelengths_nm)},
        {"constituents", constituents}};
    return j.dump(2) + "\n";
}

std::string pov_include(const Scene& scene, const VdbOptions& options) {
    const VdbLayout layout = resolve_vdb_layout(scene, options);
    const double L = layout.metres_per_unit;
    const double R = layout.planet_radius, top_alt = layout.atmosphere_top - layout.planet_radius;
    const std::string unit(length_unit_name(options.unit));
    // POV-Ray is y-up and left-handed: POV (x, y, z) = airmass (x, z, y). Swapping two
    // axes turns the right-handed Z-up frame into POV's without mirroring the scene.
    const auto& c0 = layout.planet_center;
    std::ostringstream o;
    o << "// Generated by airmass " << AIRMASS_VERSION << " (`airmass vdb --pov`): analytic densities of scene '"
      << layout.scene_name << "'.\n"
      << "// Units: 1 POV unit = 1 " << unit << ". Frame: POV-Ray's y-up, i.e. POV <x, y, z> = airmass (x, z, y).\n"
      << "// Densities are relative (1 at each profile's reference); coefficients are per " << unit
      << " at density 1,\n"
      << "// evaluated at " << fmt(layout.rgb_wavelengths_nm[0]) << "/" << fmt(layout.rgb_wavelengths_nm[1]) << "/"
      << fmt(layout.rgb_wavelengths_nm[2]) << " nm (" << layout.spectral_basis << ").\n"
      << "// POV-Ray wraps pattern values above 1 (fmod 1.00001): use the *_Pattern functions, which are\n"
      << "// normalised to [0, 1], and multiply the media colours by *_DensityMax (the macros do).\n"
      << "// Media units (measured in POV-Ray 3.7's media.cpp, docs/povray.md): in-scattered radiance =\n"
      << "// scattering colour x k(phase) x light colour per unit length, with k = 1 for isotropic\n"
      << "// scattering (no 1/(4 pi)); type 4 is k = 0.799372013 (1 + mu^2), not 3/4 (1 + mu^2). So a\n"
      << "// light of colour = irradiance E gives physical radiance when the scattering colour is\n"
      << "// sigma_s / (4 pi) (Rayleigh: x 0.75 / 0.799372013) and `extinction` restores sigma_s as\n"
      << "// the extinction: *_ScatteringColour and *_ScatteringExtinction below.\n"
      << "// Sampling: set Airmass_MediaIntervals / Airmass_MediaSamples before including (defaults 10, 3).\n\n"
      << "#ifndef (Airmass_MediaIntervals) #declare Airmass_MediaIntervals = 10; #end\n"
      << "#ifndef (Airmass_MediaSamples) #declare Airmass_MediaSamples = 3; #end\n"
      << "// Airmass_Pass: 0 (default) every constituent in one render; k > 0 one split pass (docs/povray.md).\n"
      << "#ifndef (Airmass_Pass) #declare Airmass_Pass = 0; #end\n"
      << "#declare Airmass_PlanetRadius = " << num(R) << ";\n"
      << "#declare Airmass_AtmosphereTop = " << num(layout.atmosphere_top) << ";\n"
      << "#declare Airmass_PlanetCenter = <" << num(c0[0]) << ", " << num(c0[2]) << ", " << num(c0[1]) << ">;\n"
      << "#declare Airmass_Altitude = function(x, y, z) { sqrt((x - " << num(c0[0]) << ")*(x - " << num(c0[0])
      << ") + (y - " << num(c0[2]) << ")*(y - " << num(c0[2]) << ") + (z - " << num(c0[1]) << ")*(z - " << num(c0[1])
      << ")) - " << num(R) << " }\n\n";
    int index = 0, first_scatterer = 0;
    std::ostringstream pass_types;
    for (const auto& c : layout.constituents) {
        const std::string n = "Airmass_" + c.name;
        ++index;
        const double dmax = c.density_max > 0 ? c.density_max : 1.0;
        o << "// " << c.name << ": " << detail::profile_json(c.source->profile, L).dump() << "\n"
          << "#declare " << n << "_Density = function(x, y, z) { "
          << pov_profile_expression(c.source->profile, L, top_alt, "Airmass_Altitude(x, y, z)") << " }\n"
          << "#declare " << n << "_DensityMax = " << num(dmax) << ";\n"
          << "#declare " << n << "_Pattern = function(x, y, z) { min(1, max(0, " << n << "_Density(x, y, z) / " << n
          << "_DensityMax)) }\n"
          << "#declare " << n << "_Scattering = " << pov_rgb(c.scattering_rgb) << ";\n"
          << "#declare " << n << "_Absorption = " << pov_rgb(c.absorption_rgb) << ";\n"
          << "#declare " << n << "_G = " << num(henyey_greenstein_g(c.source->phase)) << ";  // henyey_greenstein_g (phase.hpp)\n";
        const int type = pov_scattering_type(c.source->phase.kind);
        // POV-Ray's k over the physical 4 pi p (Rayleigh: 0.799372013 / 0.75; HG and isotropic: 1).
        const double k_excess = type == 4 ? 0.799372013 / 0.75 : 1.0;
        const double colour_scale = 1.0 / (4.0 * std::numbers::pi * k_excess);
        o << "#declare " << n << "_ScatteringColour = " << n << "_Scattering * " << num(colour_scale) << ";\n"
          << "#declare " << n << "_ScatteringExtinction = " << num(1.0 / colour_scale) << ";\n"
          << "#declare " << n << "_Index = " << index << ";\n";
        const bool scatters = c.scattering_rgb[0] > 0 || c.scattering_rgb[1] > 0 || c.scattering_rgb[2] > 0;
        const bool absorbs = c.absorption_rgb[0] > 0 || c.absorption_rgb[1] > 0 || c.absorption_rgb[2] > 0;
        if (scatters) {
            if (!first_scatterer) first_scatterer = index;
            pass_types << "#if (Airmass_Pass = " << index << ") #declare Airmass_PassType = " << type
                       << "; #declare Airmass_PassG = " << num(type == 5 ? henyey_greenstein_g(c.source->phase) : 0.0)
                       << "; #end\n";
        }
        // One media of this constituent with any density block (values in [0, 1]) times
        // DensityMax. Airmass_Pass (docs/povray.md, "Split passes"): 0 renders every
        // constituent; k renders only scatterer k's in-scatter, with every media given k's
        // phase (POV-Ray averages the phase functions of all media on a ray: media.cpp
        // ComputeMediaScatteringAttenuation) and the others' scattering turned into absorption
        // so that the extinction stays whole.
        o << "#macro " << n << "_MediaOf(DensityMax, Density)\n"
          << "  media {\n"
          << "    method 3 intervals Airmass_MediaIntervals samples Airmass_MediaSamples\n";
        if (scatters) {
            o << "    #if (Airmass_Pass = 0 | Airmass_Pass = " << n << "_Index)\n"
              << "      scattering { " << type << ", " << n << "_ScatteringColour * DensityMax";
            if (type == 5) o << " eccentricity " << n << "_G";
            o << " extinction " << n << "_ScatteringExtinction }\n";
            if (absorbs) o << "      absorption " << n << "_Absorption * DensityMax\n";
            o << "    #else\n"
              << "      Airmass_PassScattering()\n"
              << "      absorption (" << n << "_Absorption + " << n << "_Scattering) * DensityMax\n"
              << "    #end\n";
        } else {
            o << "    #if (Airmass_Pass != 0) Airmass_PassScattering() #end\n";
            if (absorbs) o << "    absorption " << n << "_Absorption * DensityMax\n";
        }
        o << "    density { Density }\n"
          << "  }\n"
          << "#end\n"
          << "#macro " << n << "_Media()\n"
          << "  " << n << "_MediaOf(" << n << "_DensityMax, density { function { " << n << "_Pattern(x, y, z) } })\n"
          << "#end\n\n";
    }
    o << "// Split passes: the phase every media takes in pass k (scatterer k's).\n"
      << "#declare Airmass_PassType = 1; #declare Airmass_PassG = 0;\n"
      << pass_types.str() << "#declare Airmass_FirstPass = " << first_scatterer << ";\n"
      << "// A media that does not scatter in this pass still takes its phase (POV-Ray allows eccentricity on type 5 only).\n"
      << "#macro Airmass_PassScattering()\n"
      << "  #if (Airmass_PassType = 5) scattering { 5, rgb 0 eccentricity Airmass_PassG } #else scattering { Airmass_PassType, rgb 0 } #end\n"
      << "#end\n\n";
    o << "// The atmosphere's container: media are evaluated inside it (hollow, invisible surface).\n"
      << "#declare Airmass_Container = sphere { Airmass_PlanetCenter, Airmass_AtmosphereTop\n"
      << "  hollow pigment { rgbt 1 }\n"
      << "  interior {";
    for (const auto& c : layout.constituents) o << " Airmass_" << c.name << "_Media()";
    o << " }\n}\n";
    return o.str();
}

}  // namespace airmass
