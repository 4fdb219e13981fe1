// libFuzzer target: the scene's JSON form. The library has no scene JSON *reader*: a scene
// leaves it as JSON (scene_to_json, in EXR/VDB metadata, read back by the Blender add-on and by
// `airmass compare`), and that JSON comes from a Scene that validate() accepted. So this target
// builds a Scene field by field from the input (a preset, then every numeric field maybe replaced
// by a raw or special double), runs validate() — which must throw SceneError or accept — and,
// when accepted, checks that scene_to_json gives JSON that nlohmann parses back with the same
// numbers (no "inf"/"nan" tokens: JSON has none) and that one view ray gives finite output.
#include <fuzzer/FuzzedDataProvider.h>

#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "airmass/atmosphere.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/single_scattering.hpp"
#include "fuzz_common.hpp"
#include "fuzz_values.hpp"

namespace {

using namespace airmass;
using fuzz::pick_double;

void fuzz_coefficient(FuzzedDataProvider& in, SpectralCoefficient& c) {
    c.value_per_m = pick_double(in, c.value_per_m);
    c.reference_nm = pick_double(in, c.reference_nm);
    c.exponent = pick_double(in, c.exponent);
    for (auto& [l, v] : c.table) {
        l = pick_double(in, l);
        v = pick_double(in, v);
    }
}

void fuzz_profile(FuzzedDataProvider& in, DensityProfile& p) {
    if (in.ConsumeBool()) p.kind = static_cast<DensityProfile::Kind>(in.ConsumeIntegralInRange<int>(0, 3));
    p.scale_height_m = pick_double(in, p.scale_height_m);
    p.reference_altitude_m = pick_double(in, p.reference_altitude_m);
    p.bottom_m = pick_double(in, p.bottom_m);
    p.peak_m = pick_double(in, p.peak_m);
    p.top_m = pick_double(in, p.top_m);
    p.value = pick_double(in, p.value);
    if (p.kind == DensityProfile::Kind::piecewise_linear && p.knots.size() < 2 && in.ConsumeBool())
        p.knots = {{0.0, 1.0}, {10e3, 0.5}, {30e3, 0.0}};
    for (auto& [a, d] : p.knots) {
        a = pick_double(in, a);
        d = pick_double(in, d);
    }
}

Scene fuzz_scene(FuzzedDataProvider& in) {
    static const std::vector<Scene> presets = [] {  // parsed once: the TOML reader has its own target
        std::vector<Scene> all;
        for (const auto& name : preset_names()) all.push_back(load_preset(name));
        return all;
    }();
    Scene s = presets[in.ConsumeIntegralInRange<std::size_t>(0, presets.size() - 1)];
    s.planet.radius_m = pick_double(in, s.planet.radius_m);
    s.planet.atmosphere_top_m = pick_double(in, s.planet.atmosphere_top_m);
    s.planet.ground_albedo = pick_double(in, s.planet.ground_albedo);
    s.sun.elevation_deg = pick_double(in, s.sun.elevation_deg);
    s.sun.azimuth_deg = pick_double(in, s.sun.azimuth_deg);
    s.sun.angular_radius_deg = pick_double(in, s.sun.angular_radius_deg);
    s.sun.irradiance_constant = pick_double(in, s.sun.irradiance_constant);
    for (auto& [l, e] : s.sun.irradiance_table) {
        if (in.ConsumeIntegral<uint8_t>() < 16) l = pick_double(in, l);
        if (in.ConsumeIntegral<uint8_t>() < 16) e = pick_double(in, e);
    }
    s.observer.altitude_m = pick_double(in, s.observer.altitude_m);
    if (in.ConsumeBool()) {
        Camera c = s.camera.value_or(Camera{});
        for (double* v : {&c.position_m[0], &c.position_m[1], &c.position_m[2], &c.direction[0], &c.direction[1],
                          &c.direction[2], &c.up[0], &c.up[1], &c.up[2], &c.fov_deg, &c.max_distance_m})
            *v = pick_double(in, *v);
        c.width = fuzz::pick_int(in, 1, 64);
        c.height = fuzz::pick_int(in, 1, 64);
        s.camera = c;
    }
    if (in.ConsumeBool()) {
        s.basis.kind = in.ConsumeBool() ? SpectralBasis::Kind::rgb_schuler : SpectralBasis::Kind::spectral;
        s.basis.wavelengths_nm.resize(in.ConsumeIntegralInRange<std::size_t>(0, 4));
        for (auto& l : s.basis.wavelengths_nm) l = pick_double(in, 550.0);
    }
    for (auto& c : s.constituents) {
        fuzz_profile(in, c.profile);
        fuzz_coefficient(in, c.scattering);
        fuzz_coefficient(in, c.absorption);
        if (in.ConsumeBool()) c.phase.kind = static_cast<PhaseFunction::Kind>(in.ConsumeIntegralInRange<int>(0, 4));
        c.phase.g = pick_double(in, c.phase.g);
    }
    return s;
}

// Every number in the JSON is finite (a NaN or Inf would have been written as null).
void require_no_null_numbers(const nlohmann::json& j) {
    if (j.is_null()) fuzz::require(false, "scene_to_json wrote null (a NaN or Inf field)");
    if (j.is_number_float()) fuzz::require(std::isfinite(j.get<double>()), "non-finite number in scene JSON");
    if (j.is_structured())
        for (const auto& v : j) require_no_null_numbers(v);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    FuzzedDataProvider in(data, size);
    Scene scene = fuzz_scene(in);
    try {
        validate(scene);
    } catch (const SceneError& e) {
        fuzz::require(e.what()[0] != '\0', "SceneError with an empty message");
        return 0;
    }
    const std::string text = scene_to_json(scene);
    const auto j = nlohmann::json::parse(text);  // throws (a crash here) on invalid JSON
    require_no_null_numbers(j);
    fuzz::require(j.at("planet").at("radius_m").get<double>() == scene.planet.radius_m, "radius round trip");

    const double wl[] = {680.0, 550.0, 440.0};
    EvalSettings settings;
    settings.view_samples = 4;
    Atmosphere atm;
    try {
        atm = compile_atmosphere(scene, wl, settings);
    } catch (const SceneError&) {
        return 0;
    } catch (const std::invalid_argument&) {
        return 0;
    }
    double T[3], R[3], M[3], L[3];
    const double view_zenith = in.ConsumeFloatingPointInRange<double>(0.0, 180.0);
    const ViewRay ray{scene.observer.altitude_m, direction_from_zenith_azimuth_deg<double>(view_zenith, 0.0),
                      direction_from_zenith_azimuth_deg<double>(90.0 - scene.sun.elevation_deg, 30.0)};
    single_scattering(atm, ray, RadianceOut{T, R, M, L});
    fuzz::require_finite_non_negative<double>(T, "transmittance");
    fuzz::require_finite_non_negative<double>(L, "radiance");
    return 0;
}
