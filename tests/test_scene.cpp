// Scene files: presets against the numbers of their sources, validation messages for every kind
// of bad field, preset inheritance, and the JSON form.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "airmass/color.hpp"
#include "airmass/scene_io.hpp"

namespace {

using airmass::Constituent;
using airmass::PhaseFunction;
using airmass::Scene;
using airmass::SceneError;
using airmass::SpectralBasis;

const Constituent& find(const Scene& s, const std::string& name) {
    for (const auto& c : s.constituents)
        if (c.name == name) return c;
    throw std::runtime_error("no constituent " + name);
}

// A small valid scene; tests break one field at a time.
const std::string kMinimal = R"(name = "minimal"

[planet]
radius_km = 6360
atmosphere_top_km = 6420

[spectrum]
basis = "spectral"
wavelengths_nm = [440, 550, 680]

[[constituent]]
name = "rayleigh"
profile = { type = "exponential", scale_height_km = 8 }
scattering = { law = "rayleigh", value_per_m_at_1um = 1.24062e-6 }
phase = { type = "rayleigh" }

[[constituent]]
name = "mie"
profile = { type = "exponential", scale_height_km = 1.2 }
scattering = { law = "constant", value_per_m = 4e-6 }
phase = { type = "cornette-shanks", g = 0.8 }
)";

std::string with(std::string text, const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    if (at == std::string::npos) throw std::runtime_error("test bug: '" + from + "' not in the scene text");
    return text.replace(at, from.size(), to);
}

// The error message of parsing `text`, or "" if it parsed.
std::string error_of(const std::string& text) {
    try {
        airmass::parse_scene_toml(text, "test.toml");
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

#define EXPECT_ERROR(text, fragment)                                                          \
    do {                                                                                      \
        const std::string message_ = error_of(text);                                          \
        EXPECT_NE(message_.find(fragment), std::string::npos)                                 \
            << "expected an error containing:\n  " << (fragment) << "\ngot:\n  " << message_; \
    } while (0)

double rel(double a, double b) { return std::abs(a - b) / std::abs(b); }

// ------------------------------------------------------------------------------------------
// Presets

TEST(ScenePresets, AllPresentAndValid) {
    const auto names = airmass::preset_names();
    for (const char* n : {"atmosphere-plus", "blender-nishita", "earth", "earth-hazy", "mars"})
        EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
    for (const auto& n : names) {
        const Scene s = airmass::load_preset(n);
        EXPECT_EQ(s.name, n);
        EXPECT_NO_THROW(airmass::validate(s)) << n;
    }
    EXPECT_ERROR("preset = \"nope\"", "preset = \"nope\": unknown preset (available: \"atmosphere-plus\"");
    try {
        airmass::load_preset("earthh");
        ADD_FAILURE();
    } catch (const SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("unknown preset \"earthh\""), std::string::npos) << e.what();
    }
}

TEST(ScenePresets, EmbeddedSoAnyWorkingDirectoryWorks) {
    const auto cwd = std::filesystem::current_path();
    std::filesystem::current_path(std::filesystem::temp_directory_path());
    EXPECT_NO_THROW(airmass::load_preset("earth"));
    std::filesystem::current_path(cwd);
}

TEST(ScenePresets, EarthIsBrunetonsDemo) {
    const Scene s = airmass::load_preset("earth");
    EXPECT_EQ(s.planet.radius_m, 6360e3);
    EXPECT_EQ(s.planet.atmosphere_top_m, 6420e3);
    EXPECT_EQ(s.planet.ground_albedo, 0.1);
    EXPECT_NEAR(s.sun.angular_radius_deg * M_PI / 180.0, 0.00935 / 2.0, 1e-9);  // kSunAngularRadius
    ASSERT_EQ(s.basis.kind, SpectralBasis::Kind::spectral);
    ASSERT_EQ(s.basis.wavelengths_nm.size(), 48u);
    EXPECT_EQ(s.basis.wavelengths_nm.front(), 360.0);
    EXPECT_EQ(s.basis.wavelengths_nm.back(), 830.0);
    EXPECT_EQ(s.sun.irradiance_at(550.0), 1.8504);  // ASTM G-173 10-nm bin
    EXPECT_EQ(s.sun.irradiance_at(830.0), 1.04992);

    // Rayleigh: 1.24062e-6 · (λ/µm)⁻⁴: 680 nm → 1.24062e-6 / 0.21381376 = 5.802339e-6,
    // 550 nm → /0.09150625 = 1.355776e-5, 440 nm → /0.03748096 = 3.310001e-5.
    const Constituent& r = find(s, "rayleigh");
    EXPECT_LT(rel(r.scattering.at(680.0), 5.802339e-6), 1e-6);
    EXPECT_LT(rel(r.scattering.at(550.0), 1.355776e-5), 1e-6);
    EXPECT_LT(rel(r.scattering.at(440.0), 3.310001e-5), 1e-6);
    EXPECT_TRUE(r.absorption.is_zero());
    EXPECT_EQ(r.profile.kind, airmass::DensityProfile::Kind::exponential);
    EXPECT_EQ(r.profile.scale_height_m, 8000.0);
    EXPECT_EQ(r.phase.kind, PhaseFunction::Kind::rayleigh);

    // Mie: β/H = 5.328e-3 / 1200 m = 4.44e-6 m⁻¹ of extinction at every λ (α = 0); ω = 0.9 →
    // scattering 3.996e-6, absorption 4.44e-7. (The column 1200·(1 − e^−50) m is 1200 in double.)
    const Constituent& m = find(s, "mie");
    for (double l : {360.0, 550.0, 830.0}) {
        EXPECT_LT(rel(m.scattering.at(l), 3.996e-6), 1e-12) << l;
        EXPECT_LT(rel(m.absorption.at(l), 4.44e-7), 1e-12) << l;
    }
    EXPECT_EQ(m.profile.scale_height_m, 1200.0);
    EXPECT_EQ(m.phase.kind, PhaseFunction::Kind::cornette_shanks);
    EXPECT_EQ(m.phase.g, 0.8);

    // Ozone: the tent 10 → 25 → 40 km integrates to (40 − 10)/2 = 15 km, so 300 DU
    // = 300 · 2.687e20 m⁻² needs n_max = 8.061e22 / 15000 = 5.374e18 m⁻³ at the peak.
    // At 600 nm: 5.019e-25 m² · 5.374e18 m⁻³ = 2.6972106e-6 m⁻¹; 550 nm: 3.5e-25 · 5.374e18 = 1.8809e-6.
    const Constituent& o = find(s, "ozone");
    EXPECT_LT(rel(o.absorption.at(600.0), 2.6972106e-6), 1e-9);
    EXPECT_LT(rel(o.absorption.at(550.0), 1.8809e-6), 1e-9);
    EXPECT_TRUE(o.scattering.is_zero());
    EXPECT_EQ(o.profile.kind, airmass::DensityProfile::Kind::tent);
    EXPECT_EQ(o.profile.at(25e3), 1.0);
    EXPECT_EQ(o.profile.at(17.5e3), 0.5);
    EXPECT_NEAR(airmass::vertical_column_m(o.profile, 60e3), 15000.0, 1e-9);
    // Column check the other way: ∫ n ρ dh = 5.374e18 · 15000 = 8.061e22 m⁻² = 300 DU.
    EXPECT_NEAR(o.absorption.at(600.0) / 5.019e-25 * 15000.0 / 2.687e20, 300.0, 1e-9);

    EXPECT_EQ(airmass::active_constituents(s).size(), 3u);
}

TEST(ScenePresets, EarthHazyOverridesOnlyTheAerosol) {
    const Scene e = airmass::load_preset("earth");
    const Scene h = airmass::load_preset("earth-hazy");
    EXPECT_EQ(h.name, "earth-hazy");
    ASSERT_EQ(h.constituents.size(), 3u);
    // Ångström β = 0.2, α = 1.3 over H = 1200 m: extinction at 550 nm = 0.2/1200 · 0.55^−1.3
    // = 1.6667e-4 · 2.17535 = 3.62558e-4 m⁻¹; ω = 0.9 is inherited.
    const Constituent& m = find(h, "mie");
    const double ext550 = m.scattering.at(550.0) + m.absorption.at(550.0);
    EXPECT_LT(rel(ext550, 3.625578e-4), 1e-6);
    EXPECT_LT(rel(m.scattering.at(550.0), 0.9 * 3.625578e-4), 1e-6);
    EXPECT_GT(m.scattering.at(440.0), m.scattering.at(680.0));  // α > 0: bluish haze
    EXPECT_EQ(m.phase.g, 0.8);
    EXPECT_EQ(m.profile.scale_height_m, 1200.0);
    // Everything else is the earth preset's.
    EXPECT_EQ(find(h, "rayleigh").scattering.at(550.0), find(e, "rayleigh").scattering.at(550.0));
    EXPECT_EQ(find(h, "ozone").absorption.at(600.0), find(e, "ozone").absorption.at(600.0));
    EXPECT_EQ(h.sun.irradiance_table, e.sun.irradiance_table);
    EXPECT_EQ(h.basis.wavelengths_nm, e.basis.wavelengths_nm);
}

TEST(ScenePresets, BlenderNishitaMatchesItsTables) {
    const Scene s = airmass::load_preset("blender-nishita");
    ASSERT_EQ(s.basis.wavelengths_nm.size(), 21u);
    for (std::size_t i = 0; i < 21; ++i) EXPECT_EQ(s.basis.wavelengths_nm[i], 380.0 + 20.0 * static_cast<double>(i));
    EXPECT_EQ(s.planet.radius_m, 6360e3);
    EXPECT_EQ(s.planet.atmosphere_top_m, 6420e3);
    EXPECT_EQ(s.observer.altitude_m, 1.0);
    EXPECT_NEAR(2.0 * s.sun.angular_radius_deg * M_PI / 180.0, 0.009512, 1e-8);

    // Table entries, digit for digit from docs/research/blender_nishita.md §2.
    const Constituent& r = find(s, "rayleigh");
    EXPECT_EQ(r.scattering.at(380.0), 0.00005424820087636473);
    EXPECT_EQ(r.scattering.at(560.0), 0.00001150184784075764);
    EXPECT_EQ(r.scattering.at(780.0), 0.00000305591531679811);
    // …and the law they follow: β·(λ/µm)⁴ = 1.1311488e-6 at every entry (the notes' fit).
    for (const auto& [l, v] : r.scattering.table) EXPECT_LT(rel(v * std::pow(l / 1000.0, 4), 1.1311488e-6), 1e-6) << l;
    const Constituent& o = find(s, "ozone");
    EXPECT_EQ(o.absorption.at(600.0), 0.00000273551299461512);
    EXPECT_EQ(o.absorption.at(380.0), 0.00000000325126849861);
    EXPECT_EQ(o.profile.bottom_m, 10e3);
    EXPECT_EQ(o.profile.peak_m, 25e3);
    EXPECT_EQ(o.profile.top_m, 40e3);
    // Mie: scattering 2e-5, extinction 1.11 × 2e-5.
    const Constituent& m = find(s, "mie");
    EXPECT_EQ(m.scattering.at(500.0), 2e-5);
    EXPECT_LT(rel(m.scattering.at(500.0) + m.absorption.at(500.0), 1.11 * 2e-5), 1e-12);
    EXPECT_EQ(m.phase.kind, PhaseFunction::Kind::cornette_shanks);
    EXPECT_EQ(m.phase.g, 0.76);
    EXPECT_EQ(m.profile.scale_height_m, 1200.0);
    // The irradiance is a 5778 K blackbody × 6.7902e-5 sr (the notes' finding), checked here with
    // Planck's law written out: B_λ = 2hc²/λ⁵ / (exp(hc/λkT) − 1).
    const double h = 6.62607015e-34, c = 299792458.0, k = 1.380649e-23;
    EXPECT_EQ(s.sun.irradiance_at(380.0), 1.45756829855592995315);
    for (const auto& [l, e] : s.sun.irradiance_table) {
        const double lm = l * 1e-9;
        const double b_per_nm = 2 * h * c * c / std::pow(lm, 5) / std::expm1(h * c / (lm * k * 5778.0)) * 1e-9;
        EXPECT_LT(rel(e, b_per_nm * 6.7902e-5), 2e-5) << l;
    }
}

TEST(ScenePresets, AtmospherePlusUsesSeedConstants) {
    const Scene s = airmass::load_preset("atmosphere-plus");
    EXPECT_EQ(s.planet.radius_m, 6371e3);
    EXPECT_EQ(s.planet.atmosphere_top_m, 6471e3);
    EXPECT_EQ(s.basis.kind, SpectralBasis::Kind::rgb_schuler);
    EXPECT_EQ(s.basis.wavelengths_nm, (std::vector<double>{615, 535, 445}));
    // Seed 004 §1.6: β_R = (6.55e-6, 1.73e-5, 2.30e-5) at 650 / 510 / 475 nm (3 digits).
    const Constituent& r = find(s, "rayleigh");
    EXPECT_LT(rel(r.scattering.at(650.0), 6.55e-6), 1e-12);
    EXPECT_LT(rel(r.scattering.at(510.0), 1.73e-5), 2e-3);
    EXPECT_LT(rel(r.scattering.at(475.0), 2.30e-5), 2e-3);
    EXPECT_EQ(r.profile.scale_height_m, 8000.0);
    // §1.6–1.7: β_M = 2e-6, extinction β_M / 0.9; H_M = 1200 m; forward-scattering g (seed: −0.85
    // in its own sign convention).
    const Constituent& m = find(s, "mie");
    EXPECT_EQ(m.scattering.at(500.0), 2e-6);
    EXPECT_LT(rel(m.scattering.at(500.0) + m.absorption.at(500.0), 2e-6 / 0.9), 1e-12);
    EXPECT_EQ(m.profile.scale_height_m, 1200.0);
    EXPECT_EQ(m.phase.g, 0.85);
}

TEST(ScenePresets, MarsIsPlausible) {
    const Scene s = airmass::load_preset("mars");
    EXPECT_EQ(s.planet.radius_m, 3389.5e3);
    EXPECT_EQ(s.planet.atmosphere_top_m - s.planet.radius_m, 80e3);
    // Sun at 1.5237 AU: ASTM 1.8504 W m⁻² nm⁻¹ at 550 nm / 1.5237² = 0.797025.
    EXPECT_LT(rel(s.sun.irradiance_at(550.0), 1.8504 / (1.5237 * 1.5237)), 1e-12);
    // CO2 Rayleigh: 2.215e-8 m⁻¹ at 1 µm → 2.215e-8 / 0.55⁴ = 2.42060e-7 m⁻¹ at 550 nm, about
    // 1/56 of Earth's (Bruneton) 1.356e-5.
    const Constituent& r = find(s, "rayleigh");
    EXPECT_LT(rel(r.scattering.at(550.0), 2.215e-8 / std::pow(0.55, 4)), 1e-9);
    // Dust: vertical optical depth (σ_s + σ_a)·column = 0.5 at every wavelength; ω from the table.
    const Constituent& d = find(s, "dust");
    const double column = airmass::vertical_column_m(d.profile, 80e3);
    EXPECT_NEAR(column, 11100.0 * (1.0 - std::exp(-80.0 / 11.1)), 1e-6);
    for (double l : {400.0, 450.0, 550.0, 700.0})
        EXPECT_NEAR((d.scattering.at(l) + d.absorption.at(l)) * column, 0.5, 1e-12) << l;
    EXPECT_NEAR(d.scattering.at(450.0) / (d.scattering.at(450.0) + d.absorption.at(450.0)), 0.80, 1e-12);
    EXPECT_NEAR(d.scattering.at(650.0) / (d.scattering.at(650.0) + d.absorption.at(650.0)), 0.97, 1e-12);
    EXPECT_GT(d.absorption.at(450.0), 5.0 * d.absorption.at(650.0));  // reddish: absorbs the blue
    EXPECT_EQ(d.phase.kind, PhaseFunction::Kind::henyey_greenstein);
    EXPECT_GT(d.phase.g, 0.5);
}

// ------------------------------------------------------------------------------------------
// Reading

TEST(SceneParse, MinimalSceneAndDefaults) {
    const Scene s = airmass::parse_scene_toml(kMinimal, "test.toml");
    EXPECT_EQ(s.name, "minimal");
    EXPECT_EQ(s.sun.elevation_deg, 45.0);
    EXPECT_EQ(s.sun.irradiance_at(500.0), 1.0);
    EXPECT_EQ(s.observer.altitude_m, 0.0);
    EXPECT_FALSE(s.camera.has_value());
    EXPECT_EQ(s.planet.ground_albedo, 0.1);
    ASSERT_EQ(s.constituents.size(), 2u);
    // Without a `name`, a string gets "scene" and a file its stem.
    EXPECT_EQ(airmass::parse_scene_toml(with(kMinimal, "name = \"minimal\"", "")).name, "scene");
}

TEST(SceneParse, UnitsAreConvertedToSi) {
    const std::string text = with(with(kMinimal, "[spectrum]", R"([observer]
altitude_km = 2.5

[camera]
position_km = [0, 0, 0.003]
direction = [0, 1, 0.1]
fov_deg = 40
max_distance_km = 150
width = 320
height = 200

[sun]
elevation_deg = 10
azimuth_deg = 90
distance_au = 2
irradiance = { type = "constant", value_w_m2_nm = 1.6 }

[spectrum])"),
                                  "scale_height_km = 1.2 }", "scale_height_km = 1.2, reference_altitude_km = 0.5 }");
    const Scene s = airmass::parse_scene_toml(text, "test.toml");
    EXPECT_EQ(s.observer.altitude_m, 2500.0);
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_DOUBLE_EQ(s.camera->position_m[2], 3.0);
    EXPECT_EQ(s.camera->max_distance_m, 150e3);
    EXPECT_EQ(s.camera->width, 320);
    EXPECT_EQ(s.sun.azimuth_deg, 90.0);
    EXPECT_EQ(s.sun.irradiance_constant, 1.6 / 4.0);  // given at 1 AU, the sun at 2 AU
    EXPECT_EQ(find(s, "mie").profile.reference_altitude_m, 500.0);
}

// Every length a person types is in km: the old metres key is refused with a pointer to the new one,
// never read as km by mistake.
TEST(SceneParse, CameraPositionIsInKilometres) {
    const std::string old_key = with(kMinimal, "[spectrum]", "[camera]\nposition_m = [0, 0, 2]\n\n[spectrum]");
    const std::string err = error_of(old_key);
    EXPECT_NE(err.find("camera.position_m"), std::string::npos) << err;
    EXPECT_NE(err.find("position_km"), std::string::npos) << err;
    const std::string far = with(kMinimal, "[spectrum]", "[camera]\nposition_km = [0, 0, 2e7]\n\n[spectrum]");
    EXPECT_NE(error_of(far).find("camera.position_km[2]"), std::string::npos) << error_of(far);
    EXPECT_NE(error_of(far).find("[-1e7, 1e7]"), std::string::npos) << error_of(far);
}

TEST(SceneParse, ZeroConstituentsAreAllowedAndDropped) {
    const std::string text = kMinimal + R"(
[[constituent]]
name = "inert"
profile = { type = "constant", value = 1 }
)";
    const Scene s = airmass::parse_scene_toml(text, "test.toml");
    ASSERT_EQ(s.constituents.size(), 3u);
    EXPECT_TRUE(find(s, "inert").scattering.is_zero());
    const auto active = airmass::active_constituents(s);
    ASSERT_EQ(active.size(), 2u);
    EXPECT_EQ(active[0].name, "rayleigh");
    EXPECT_EQ(active[1].name, "mie");
    // An empty atmosphere is a valid scene too.
    const std::string vacuum = kMinimal.substr(0, kMinimal.find("[[constituent]]"));
    EXPECT_TRUE(airmass::parse_scene_toml(vacuum).constituents.empty());
}

TEST(SceneParse, AllProfileKindsAndTheirColumns) {
    const std::string text = kMinimal + R"(
[[constituent]]
name = "layer"
profile = { type = "piecewise-linear", altitudes_km = [0, 10, 20], densities = [0, 1, 0] }
absorption = { law = "table", wavelengths_nm = [400, 700], values_per_m = [1e-6, 2e-6] }

[[constituent]]
name = "slab"
profile = { type = "constant", value = 0.5, bottom_km = 2, top_km = 4 }
absorption = { law = "power-law", value_per_m = 1e-6, reference_nm = 500, exponent = 1 }
)";
    const Scene s = airmass::parse_scene_toml(text, "test.toml");
    const Constituent& layer = find(s, "layer");
    EXPECT_EQ(layer.profile.at(5e3), 0.5);
    EXPECT_NEAR(airmass::vertical_column_m(layer.profile, 60e3), 10e3, 1e-9);           // triangle 20 km × 1 / 2
    EXPECT_NEAR(airmass::vertical_column_m(layer.profile, 15e3), 10e3 - 1250.0, 1e-9);  // cut at 15 km
    EXPECT_NEAR(layer.absorption.at(550.0), 1.5e-6, 1e-18);
    const Constituent& slab = find(s, "slab");
    EXPECT_NEAR(airmass::vertical_column_m(slab.profile, 60e3), 1000.0, 1e-9);  // 0.5 × 2 km
    EXPECT_NEAR(slab.absorption.at(1000.0), 0.5e-6, 1e-18);
    // Exponential: H (1 − e^{−T/H}) = 8000 (1 − e^{−7.5}) = 7995.8518 m.
    EXPECT_NEAR(airmass::vertical_column_m(find(s, "rayleigh").profile, 60e3), 8000.0 * (1.0 - std::exp(-7.5)), 1e-9);
}

TEST(SceneParse, PresetInheritanceMergesByName) {
    const std::string text = R"(preset = "earth"
name = "my-earth"

[planet]
ground_albedo = 0.3

[sun]
elevation_deg = 5

[spectrum]
wavelengths_nm = [440, 550, 680]

[[constituent]]
name = "mie"
phase = { type = "henyey-greenstein", g = 0.7 }

[[constituent]]
name = "smoke"
profile = { type = "exponential", scale_height_km = 3 }
absorption = { law = "constant", value_per_m = 1e-6 }
)";
    const Scene s = airmass::parse_scene_toml(text, "test.toml");
    const Scene e = airmass::load_preset("earth");
    EXPECT_EQ(s.name, "my-earth");
    EXPECT_EQ(s.planet.ground_albedo, 0.3);
    EXPECT_EQ(s.planet.radius_m, 6360e3);  // inherited
    EXPECT_EQ(s.sun.elevation_deg, 5.0);
    EXPECT_EQ(s.sun.irradiance_table, e.sun.irradiance_table);                // inherited
    EXPECT_EQ(s.basis.wavelengths_nm, (std::vector<double>{440, 550, 680}));  // replaced the sampling
    ASSERT_EQ(s.constituents.size(), 4u);
    const Constituent& m = find(s, "mie");
    EXPECT_EQ(m.phase.kind, PhaseFunction::Kind::henyey_greenstein);
    EXPECT_EQ(m.phase.g, 0.7);
    EXPECT_EQ(m.scattering.at(550.0), find(e, "mie").scattering.at(550.0));  // inherited
    EXPECT_EQ(find(s, "smoke").absorption.at(550.0), 1e-6);
    // A file without a name is named after itself, not after its preset.
    EXPECT_EQ(airmass::parse_scene_toml(with(text, "name = \"my-earth\"", ""), "dir/evening.toml").name, "evening");
    // Switching the basis drops the inherited wavelengths.
    const Scene rgb = airmass::parse_scene_toml("preset = \"earth\"\n[spectrum]\nbasis = \"rgb-schuler\"\n");
    EXPECT_EQ(rgb.basis.kind, SpectralBasis::Kind::rgb_schuler);
}

TEST(SceneParse, LoadSceneFile) {
    const auto dir = std::filesystem::temp_directory_path() / ("airmass_scene_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const auto path = dir / "sunset.toml";
    {
        std::ofstream out(path);
        out << with(kMinimal, "name = \"minimal\"", "");
    }
    const Scene s = airmass::load_scene_file(path);
    EXPECT_EQ(s.name, "sunset");
    EXPECT_EQ(s.constituents.size(), 2u);
    {
        std::ofstream out(path);
        out << with(kMinimal, "g = 0.8", "g = 1.2");
    }
    try {
        airmass::load_scene_file(path);
        ADD_FAILURE();
    } catch (const SceneError& e) {
        // The message points at the file and line (21) where the bad field was written.
        EXPECT_NE(std::string(e.what()).find(path.string() + ":21:"), std::string::npos) << e.what();
    }
    std::filesystem::remove_all(dir);
    try {
        airmass::load_scene_file(path);
        ADD_FAILURE();
    } catch (const SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos) << e.what();
    }
}

// ------------------------------------------------------------------------------------------
// Validation: one broken field at a time; messages name the field, its value and the range.

TEST(SceneValidate, PlanetFields) {
    EXPECT_ERROR(with(kMinimal, "radius_km = 6360", "radius_km = -1"),
                 "planet.radius_km = -1: must be in [1, 1000000]");
    EXPECT_ERROR(with(kMinimal, "atmosphere_top_km = 6420", "atmosphere_top_km = 6000"),
                 "planet.atmosphere_top_km = 6000: must be > planet.radius_km (6360)");
    EXPECT_ERROR(with(kMinimal, "radius_km = 6360", "radius_km = nan"), "planet.radius_km = nan: must be in");
    EXPECT_ERROR(with(kMinimal, "atmosphere_top_km = 6420", "atmosphere_top_km = 6420\nground_albedo = 1.5"),
                 "planet.ground_albedo = 1.5: must be in [0, 1]");
    EXPECT_ERROR(with(kMinimal, "radius_km = 6360\n", ""), "planet.radius_km: missing (required)");
    EXPECT_ERROR(with(kMinimal, "radius_km = 6360", "radius_km = \"6360\""),
                 "planet.radius_km = \"6360\": must be a number");
}

TEST(SceneValidate, UnknownKeysAreRejectedWithWhereAndWhatIsAllowed) {
    // A misspelt optional key: reported as unknown, with what the table accepts.
    EXPECT_ERROR(with(kMinimal, "atmosphere_top_km = 6420", "atmosphere_top_km = 6420\nground_albedoo = 0.2"),
                 "test.toml:6:18: planet.ground_albedoo: unknown key (allowed here: atmosphere_top_km, ground_albedo, "
                 "radius_km)");
    // A misspelt required key: reported as missing, naming the look-alike and where it is.
    EXPECT_ERROR(
        with(kMinimal, "radius_km = 6360", "radius_kn = 6360"),
        "planet.radius_km: missing (required; \"radius_kn\" at test.toml:4:13 looks like a misspelling of it)");
    EXPECT_ERROR(with(kMinimal, "g = 0.8", "gg = 0.8"),
                 "constituent[1].phase.g: missing (required; \"gg\" at test.toml:21:");
    EXPECT_ERROR(with(kMinimal, "g = 0.8", "g = 0.8, gamma = 2"),
                 "constituent[1].phase.gamma: unknown key (allowed here: g, type)");
    EXPECT_ERROR(with(kMinimal, "type = \"rayleigh\"", "type = \"rayleigh\", g = 0.5"),
                 "constituent[0].phase.g: unknown key (allowed here: type)");
    EXPECT_ERROR("typo = 1\n" + kMinimal, "typo: unknown key");
    EXPECT_ERROR(with(kMinimal, "[spectrum]", "[spectra]\nbasis = \"spectral\"\n[spectrum]"), "spectra: unknown key");
}

TEST(SceneValidate, SunObserverCamera) {
    EXPECT_ERROR(with(kMinimal, "[spectrum]", "[sun]\nelevation_deg = 91\n[spectrum]"),
                 "sun.elevation_deg = 91: must be in [-90, 90]");
    EXPECT_ERROR(with(kMinimal, "[spectrum]", "[sun]\nangular_radius_deg = 0\n[spectrum]"),
                 "sun.angular_radius_deg = 0: must be in (0, 5]");
    EXPECT_ERROR(with(kMinimal, "[spectrum]", "[sun]\ndistance_au = -1\n[spectrum]"),
                 "sun.distance_au = -1: must be in [0.001, 1000]");
    EXPECT_ERROR(with(kMinimal, "[spectrum]", "[sun]\nirradiance = { type = \"blackbody\" }\n[spectrum]"),
                 "sun.irradiance.type = \"blackbody\": must be \"constant\" or \"table\"");
    EXPECT_ERROR(with(kMinimal, "[spectrum]",
                      "[sun]\nirradiance = { type = \"table\", wavelengths_nm = [500, 600], values_w_m2_nm = [1, 1] "
                      "}\n[spectrum]"),
                 "sun.irradiance.wavelengths_nm = [500 ... 600]: must cover the spectrum's wavelengths [440, 680] nm");
    EXPECT_ERROR(with(kMinimal, "[spectrum]", "[observer]\naltitude_km = -0.5\n[spectrum]"),
                 "observer.altitude_km = -0.5: must be in [0, 1000000]");
    EXPECT_ERROR(with(kMinimal, "[spectrum]", "[camera]\ndirection = [0, 0, 1]\n[spectrum]"),
                 "camera.up: must not be parallel to camera.direction");
    EXPECT_ERROR(with(kMinimal, "[spectrum]", "[camera]\nfov_deg = 180\n[spectrum]"),
                 "camera.fov_deg = 180: must be in (0, 180)");
    EXPECT_ERROR(with(kMinimal, "[spectrum]", "[camera]\nwidth = 0\n[spectrum]"),
                 "camera.width = 0: must be in [1, 65536]");
    EXPECT_ERROR(with(kMinimal, "[spectrum]", "[camera]\nwidth = 64.5\n[spectrum]"),
                 "camera.width = 64.5: must be an integer");
    EXPECT_ERROR(with(kMinimal, "[spectrum]", "[camera]\nup = [0, 1]\n[spectrum]"),
                 "camera.up: must have 3 components (has 2)");
}

TEST(SceneValidate, Spectrum) {
    EXPECT_ERROR(with(kMinimal, "[440, 550, 680]", "[350, 550]"),
                 "spectrum.wavelengths_nm[0] = 350: must be in [360, 830] nm");
    EXPECT_ERROR(with(kMinimal, "[440, 550, 680]", "[440, 680, 550]"),
                 "spectrum.wavelengths_nm[2] = 550: must be > wavelengths_nm[1] (680): wavelengths must increase");
    EXPECT_ERROR(with(kMinimal, "[440, 550, 680]", "[]"), "spectrum.wavelengths_nm: must have at least one wavelength");
    EXPECT_ERROR(with(kMinimal, "wavelengths_nm = [440, 550, 680]", "sampling = \"blender\""),
                 "spectrum.sampling = \"blender\": must be one of \"blender-21\", \"bruneton-48\", \"cie-95\"");
    EXPECT_ERROR(with(kMinimal, "basis = \"spectral\"", "basis = \"rgb-schuler\""),
                 "spectrum.wavelengths_nm: not allowed with basis = \"rgb-schuler\"");
    EXPECT_ERROR(with(kMinimal, "basis = \"spectral\"", "basis = \"rgb\""),
                 "spectrum.basis = \"rgb\": must be \"spectral\" or \"rgb-schuler\"");
    EXPECT_ERROR(with(kMinimal, "wavelengths_nm = [440, 550, 680]", "sampling = \"cie-95\"\nwavelengths_nm = [440]"),
                 "give either spectrum.wavelengths_nm or spectrum.sampling, not both");
}

TEST(SceneValidate, Constituents) {
    EXPECT_ERROR(with(kMinimal, "g = 0.8", "g = 1.2"), "constituent[1].phase.g = 1.2: must be in (-1, 1)");
    EXPECT_ERROR(with(kMinimal, "g = 0.8", "g = -1"), "constituent[1].phase.g = -1: must be in (-1, 1)");
    EXPECT_ERROR(with(kMinimal, "type = \"cornette-shanks\"", "type = \"mie\""),
                 "constituent[1].phase.type = \"mie\": must be one of");
    EXPECT_ERROR(with(kMinimal, "name = \"mie\"", "name = \"rayleigh\""),
                 "constituent[1].name = \"rayleigh\": another constituent already has this name");
    EXPECT_ERROR(with(kMinimal, "name = \"mie\"", "name = \"mie dust\""),
                 "constituent[1].name = \"mie dust\": must be 1-64 characters");
    EXPECT_ERROR(with(kMinimal, "scale_height_km = 8", "scale_height_km = 0"),
                 "constituent[0].profile.scale_height_km = 0: must be in [0.001, 1000000000] (1 m to 1e9 km)");
    EXPECT_ERROR(with(kMinimal, "value_per_m = 4e-6", "value_per_m = -4e-6"),
                 "constituent[1].scattering.value_per_m = -4e-06: must be in [0, 1e+300]");
    EXPECT_ERROR(with(kMinimal, "value_per_m_at_1um = 1.24062e-6", "value_per_m_at_1um = -1"),
                 "constituent[0].scattering.value_per_m_at_1um = -1: must be >= 0");
    EXPECT_ERROR(with(kMinimal, "law = \"constant\"", "law = \"linear\""),
                 "constituent[1].scattering.law = \"linear\": must be one of \"constant\", \"power-law\"");
    EXPECT_ERROR(with(kMinimal, "phase = { type = \"cornette-shanks\", g = 0.8 }\n", ""),
                 "constituent[1].phase: missing (required: the constituent scatters light)");
    EXPECT_ERROR(with(kMinimal, "scattering = { law = \"constant\", value_per_m = 4e-6 }",
                      "scattering = { law = \"constant\", value_per_m = 4e-6 }\nextinction = { law = \"constant\", "
                      "value_per_m = 1e-6 }"),
                 "constituent[1].extinction: give either extinction + single_scattering_albedo, or scattering and/or "
                 "absorption");
    EXPECT_ERROR(with(kMinimal, "scattering = { law = \"constant\", value_per_m = 4e-6 }",
                      "extinction = { law = \"constant\", value_per_m = 1e-6 }"),
                 "constituent[1].single_scattering_albedo: missing (required with extinction)");
    EXPECT_ERROR(with(kMinimal, "scattering = { law = \"constant\", value_per_m = 4e-6 }",
                      "extinction = { law = \"constant\", value_per_m = 1e-6 }\nsingle_scattering_albedo = 1.1"),
                 "constituent[1].single_scattering_albedo = 1.1: must be in [0, 1]");
    EXPECT_ERROR(with(kMinimal, "[[constituent]]\nname = \"mie\"", "[constituent]\nname = \"mie\""),
                 "TOML syntax error");
}

// Density x coefficient is the extinction the integrators multiply by path lengths: each may be
// in range while the product overflows (fuzz_scene_json: a constant density of 1.8e308 times
// 7e297 per m gave NaN radiance). The product is bounded like a coefficient, naming both fields.
TEST(SceneValidate, ExtinctionDensityTimesCoefficient) {
    const std::string constant_mie = with(kMinimal, "profile = { type = \"exponential\", scale_height_km = 1.2 }",
                                          "profile = { type = \"constant\", value = 1e10 }");
    EXPECT_NO_THROW(airmass::parse_scene_toml(with(constant_mie, "value_per_m = 4e-6", "value_per_m = 1e290")));
    EXPECT_ERROR(with(constant_mie, "value_per_m = 4e-6", "value_per_m = 1e291"),
                 "constituent[1].profile.value (peak density 1e+10) x constituent[1].scattering (1e+291 per m "
                 "at 440 nm) = 1e+301 per m: must be <= 1e+300");
    // An exponential profile's density at the ground is exp(reference_altitude / scale_height).
    const std::string raised = with(kMinimal, "scale_height_km = 1.2 }", "scale_height_km = 1, reference_altitude_km = 46 }");
    EXPECT_NO_THROW(airmass::parse_scene_toml(with(raised, "value_per_m = 4e-6", "value_per_m = 1e280")));
    EXPECT_ERROR(with(raised, "value_per_m = 4e-6", "value_per_m = 1e281"),
                 "constituent[1].profile.reference_altitude_km (peak density 9.496119421e+19) x constituent[1].scattering");
}

TEST(SceneValidate, ProfilesAndTables) {
    const std::string ozone = kMinimal + R"(
[[constituent]]
name = "ozone"
profile = { type = "tent", bottom_km = 10, peak_km = 25, top_km = 40 }
absorption = { law = "table", wavelengths_nm = [400, 510, 600, 700], values_per_m = [1e-7, 1e-6, 2e-6, 1e-6] }
)";
    EXPECT_NO_THROW(airmass::parse_scene_toml(ozone));
    EXPECT_ERROR(with(ozone, "peak_km = 25", "peak_km = 5"),
                 "constituent[2].profile.peak_km = 5: must be > constituent[2].profile.bottom_km (10)");
    EXPECT_ERROR(with(ozone, "top_km = 40", "top_km = 25"),
                 "constituent[2].profile.top_km = 25: must be > constituent[2].profile.peak_km (25)");
    EXPECT_ERROR(with(ozone, "[400, 510, 600, 700]", "[400, 510, 500, 700]"),
                 "constituent[2].absorption.wavelengths_nm[2] = 500: must be > wavelengths_nm[1] (510): wavelengths "
                 "must increase");
    EXPECT_ERROR(with(ozone, "[400, 510, 600, 700]", "[450, 510, 600, 700]"),
                 "constituent[2].absorption.wavelengths_nm = [450 ... 700]: must cover the spectrum's wavelengths "
                 "[440, 680] nm");
    EXPECT_ERROR(with(ozone, "[1e-7, 1e-6, 2e-6, 1e-6]", "[1e-7, 1e-6, 2e-6]"),
                 "constituent[2].absorption.values_per_m: has 3 entries but wavelengths_nm/altitudes_km has 4");
    EXPECT_ERROR(with(ozone, "[1e-7, 1e-6, 2e-6, 1e-6]", "[1e-7, -1e-6, 2e-6, 1e-6]"),
                 "constituent[2].absorption.values_per_m[1] = -1e-06: must be >= 0");
    EXPECT_ERROR(
        with(ozone, "values_per_m = [1e-7, 1e-6, 2e-6, 1e-6]", "cross_sections_m2 = [1e-26, 1e-25, 5e-25, 1e-25]"),
        "cross_sections_m2 need exactly one of number_density_per_m3 or column_du");
    EXPECT_ERROR(with(ozone, "type = \"tent\", bottom_km = 10, peak_km = 25, top_km = 40",
                      "type = \"piecewise-linear\", altitudes_km = [10, 5], densities = [1, 1]"),
                 "constituent[2].profile.altitudes_km[1] = 5: must be > constituent[2].profile.altitudes_km[0] (10): altitudes "
                 "must increase");
    EXPECT_ERROR(with(ozone, "type = \"tent\", bottom_km = 10, peak_km = 25, top_km = 40", "type = \"gaussian\""),
                 "constituent[2].profile.type = \"gaussian\": must be one of");
    // Ångström needs a column inside the atmosphere: a tent above the top has none.
    const std::string high_tent =
        with(with(ozone, "bottom_km = 10, peak_km = 25, top_km = 40", "bottom_km = 70, peak_km = 80, top_km = 90"),
             "law = \"table\", wavelengths_nm = [400, 510, 600, 700], values_per_m = [1e-7, 1e-6, 2e-6, 1e-6]",
             "law = \"angstrom\", beta = 0.1, alpha = 1");
    // The top is what is out of range: the refusal names it and its bound (radius + 70 km).
    EXPECT_ERROR(high_tent, "planet.atmosphere_top_km = 6420: must be > 6430 (planet.radius_km + 70 km, where ");
    EXPECT_ERROR(high_tent, " km, where constituent[2].profile's density begins: constituent[2].absorption.beta is "
                            "spread over the profile's column below the top)");
}

TEST(SceneValidate, MessagesPointAtTheLine) {
    // The bad g is on line 21 of kMinimal.
    EXPECT_ERROR(with(kMinimal, "g = 0.8", "g = 1.2"), "test.toml:21:");
    EXPECT_ERROR("[planet\n", "test.toml:1:");
    // Errors from a validate() call on a Scene built in code name the same paths.
    Scene s = airmass::load_preset("earth");
    s.constituents[1].phase.g = 1.0;
    try {
        airmass::validate(s);
        ADD_FAILURE();
    } catch (const SceneError& e) {
        EXPECT_STREQ(e.what(), "constituent[1].phase.g = 1: must be in (-1, 1) (constituent \"mie\")");
    }
}

// ------------------------------------------------------------------------------------------
// JSON

TEST(SceneJson, CompleteAndCompact) {
    for (const auto& name : airmass::preset_names()) {
        const Scene s = airmass::load_preset(name);
        const std::string text = airmass::scene_to_json(s);
        EXPECT_EQ(text.find('\n'), std::string::npos) << name;
        const auto j = nlohmann::json::parse(text);
        EXPECT_EQ(j.at("name"), name);
        EXPECT_EQ(j.at("planet").at("radius_m").get<double>(), s.planet.radius_m);
        EXPECT_EQ(j.at("planet").at("atmosphere_top_m").get<double>(), s.planet.atmosphere_top_m);
        EXPECT_EQ(j.at("sun").at("elevation_deg").get<double>(), s.sun.elevation_deg);
        EXPECT_EQ(j.at("spectrum").at("wavelengths_nm").size(), airmass::basis_wavelengths_nm(s.basis).size());
        ASSERT_EQ(j.at("constituents").size(), s.constituents.size());
        for (std::size_t i = 0; i < s.constituents.size(); ++i) {
            const auto& c = j.at("constituents")[i];
            EXPECT_EQ(c.at("name"), s.constituents[i].name);
            for (const char* k : {"profile", "scattering", "absorption", "phase"}) EXPECT_TRUE(c.contains(k)) << k;
        }
    }
    // Values survive exactly (shortest round-trip formatting).
    const Scene e = airmass::load_preset("earth");
    const auto j = nlohmann::json::parse(airmass::scene_to_json(e));
    const auto& ozone = j.at("constituents")[2];
    EXPECT_EQ(ozone.at("absorption").at("law"), "table");
    EXPECT_EQ(ozone.at("absorption").at("values_per_m")[24].get<double>(),
              e.constituents[2].absorption.table[24].second);
    EXPECT_EQ(ozone.at("profile").at("type"), "tent");
    EXPECT_EQ(ozone.at("profile").at("peak_m").get<double>(), 25e3);
    EXPECT_EQ(j.at("constituents")[1].at("phase").at("g").get<double>(), 0.8);
    EXPECT_EQ(j.at("sun").at("irradiance").at("values_w_m2_nm").size(), 48u);
    EXPECT_FALSE(j.contains("camera"));
    const Scene withcam = airmass::parse_scene_toml(with(kMinimal, "[spectrum]", "[camera]\nwidth = 100\n[spectrum]"));
    EXPECT_EQ(nlohmann::json::parse(airmass::scene_to_json(withcam)).at("camera").at("width"), 100);
}

}  // namespace
