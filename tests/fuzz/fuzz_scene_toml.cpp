// libFuzzer target: the scene TOML reader (parse_scene_toml: toml++ parse, presets and merging,
// unit conversion, unknown-key detection, validate()). Input: the TOML text.
// On a scene that parses, also compiles its atmosphere at three wavelengths and evaluates one
// view ray (transmittance and radiance must be finite and >= 0), and writes it as JSON.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string_view>

#include "airmass/atmosphere.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/single_scattering.hpp"
#include "fuzz_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace airmass;
    if (size > 64 * 1024) return -1;  // scenes are small; keep runs fast
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    Scene scene;
    try {
        scene = parse_scene_toml(text, "fuzz.toml");
    } catch (const SceneError& e) {
        fuzz::require(e.what()[0] != '\0', "SceneError with an empty message");
        return 0;
    }
    (void)scene_to_json(scene);
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
    const ViewRay ray{scene.observer.altitude_m, direction_from_zenith_azimuth_deg<double>(60.0, 0.0),
                      direction_from_zenith_azimuth_deg<double>(90.0 - scene.sun.elevation_deg, 30.0)};
    single_scattering(atm, ray, RadianceOut{T, R, M, L});
    fuzz::require_finite_non_negative<double>(T, "transmittance");
    fuzz::require_finite_non_negative<double>(L, "radiance");
    return 0;
}
