// Reading, validating and writing scene descriptions (TOML; every field and its unit
// in docs/scene.md). Presets are the TOML files in examples/, embedded at build time
// and usable by name ("earth", "earth-hazy", "atmosphere-plus", "blender-nishita", "mars").
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "airmass/scene.hpp"

namespace airmass {

// Every problem with a scene: the message names the field (TOML path), the value
// and the allowed range, e.g. "planet.radius_km = -1: must be > 0".
struct SceneError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

Scene parse_scene_toml(std::string_view toml_text, std::string_view source_name = "<string>");
Scene load_scene_file(const std::filesystem::path& path);
Scene load_preset(std::string_view name);
std::vector<std::string> preset_names();

// Throws SceneError on the first invalid field.
void validate(const Scene& scene);

// A compact JSON description of the scene (for EXR/VDB metadata).
std::string scene_to_json(const Scene& scene);

// The constituents that can affect light: those whose scattering or absorption is non-zero at
// some wavelength. A constituent with both zero (allowed in a file) is dropped here, so a scene
// pays nothing for it.
std::vector<Constituent> active_constituents(const Scene& scene);

// Vertical column of a density profile, ∫₀^thickness ρ(h) dh in metres (exact for every profile
// kind). Used by the "angstrom" law (β / column) and by ozone columns in Dobson units.
double vertical_column_m(const DensityProfile& profile, double thickness_m);

}  // namespace airmass
