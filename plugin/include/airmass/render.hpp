// Native renders of a camera: the image Airmass itself computes for the camera of a scene,
// pixel for pixel comparable with a Blender render of the same camera (camera.hpp).
//
// Frame (scene.hpp): Z up, the origin on the surface below the observer, the planet centre
// at (0, 0, −R), metres. The camera sits anywhere (on the ground, in the air, in space);
// its position p gives the planet-centred vector q = p − (0, 0, −R) and the altitude
// h = |q| − R, computed as (x² + y² + z(z + 2R)) / (|q| + R) so that a camera 2 m above a
// 6360-km planet keeps its 2 m. The evaluator's frame has the observer on its +Z axis, so
// view and sun directions are turned by the rotation taking q/|q| to +Z (the identity for
// the usual camera above the origin).
//
// Per pixel (one ray through its centre, camera.hpp, or the box filter's 16+ rays,
// PixelFilter below), per ray and wavelength:
//   L = single scattering of sunlight + [ground] + [sun disc] (single_scattering.hpp)
//     + [multiple scattering] (multiple_scattering.hpp, when asked for),
// then to linear Rec.709 by the colour model:
//   * spectral: the scene's basis (color.hpp), XYZ = Σ L·CMF·Δλ → Rec.709, negative
//     channels clamped to 0 like Cycles' xyz_to_rgb_clamped and the sky texture (sky.hpp);
//     the same units as `airmass sky`, i.e. as Blender's Nishita texture;
//   * renderer_rgb: what an RGB renderer computes from Airmass's volume export — the
//     coefficients at three wavelengths (`rgb_wavelengths_nm`, the exporter's choice,
//     vdb_export.hpp) and the sun lamp's RGB irradiance (sun_irradiance_rgb below) as the
//     source, channel c = the radiance computed at wavelength c. No colour matrix.
//
// "Renderer-matched" (renderer_matched_scene): every phase function replaced by
// Henyey–Greenstein with the g of henyey_greenstein_g (phase.hpp: Cornette–Shanks → the HG of
// the same mean cosine, Rayleigh, modified Rayleigh and isotropic → 0), which is all Blender
// 3.4's Volume Scatter offers and exactly what the add-on's material gives it. With renderer_rgb and (for a volume cut
// to a box) `medium_box`, the native image is what Cycles should converge to, so a
// comparison isolates Cycles' own errors (docs/compare.md).
//
// Medium box: the medium (every constituent) restricted to an axis-aligned box of the scene
// frame — what a VDB export of a `box` region holds. Then view rays gather in-scatter only
// inside the box, sun rays are attenuated only inside it, the sky beyond is black, and the
// planet (an opaque Lambertian sphere) stays whole. That integral is not the evaluator's;
// it is done here by composite 4-point Gauss–Legendre on panels of at most one scale height
// of altitude change and 0.3 of optical depth, split exactly at Earth's shadow, with
// closed-form optical depths (optical_depth.hpp) at every node.
#pragma once

#include <array>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>

#include <glm/vec3.hpp>

#include "airmass/atmosphere.hpp"
#include "airmass/camera.hpp"
#include "airmass/chapman.hpp"
#include "airmass/image.hpp"
#include "airmass/multiple_scattering.hpp"
#include "airmass/progress.hpp"
#include "airmass/scene.hpp"

namespace airmass {

// Every problem with render settings; the message names the field, value and allowed range.
struct RenderError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

enum class ColorModel { spectral, renderer_rgb };

// How a pixel's value is formed: `centre`, one ray through the pixel centre (Cycles with a
// Gaussian filter of the minimum width); `box`, the mean over the pixel's square (Cycles'
// Box filter), integrated by a 4×4 Gauss–Legendre rule split at the horizon (render.cpp).
enum class PixelFilter { centre, box };

struct MediumBox {
    glm::dvec3 min_m{0.0};
    glm::dvec3 max_m{0.0};
};

// The renderer a renderer-matched image is matched to: Blender 3.4 (Henyey–Greenstein only)
// or POV-Ray 3.7 (its Rayleigh, scattering type 4, has our Rayleigh's shape; everything else
// Henyey–Greenstein, type 5; docs/povray.md).
enum class MatchedRenderer { blender, povray };

struct RenderSettings {
    // The camera; empty: the scene's [camera] (camera_from_scene) with `projection`.
    std::optional<CameraModel> camera;
    Projection projection = Projection::perspective;
    // View-ray quality (atmosphere.hpp EvalSettings: chapman, view_samples per scattering
    // constituent, sun_disc, ground). The sun disc is off by default here: a disc a fraction
    // of a pixel wide is not comparable (and never drawn with medium_box).
    EvalSettings view{};
    bool renderer_matched = false;  // phase functions → Henyey–Greenstein (renderer_matched_scene)
    MatchedRenderer matched_renderer = MatchedRenderer::blender;  // whose phase functions, with renderer_matched
    ColorModel color = ColorModel::spectral;
    PixelFilter pixel_filter = PixelFilter::centre;
    std::array<double, 3> rgb_wavelengths_nm{680.0, 550.0, 440.0};  // renderer_rgb only
    std::optional<MediumBox> medium_box;
    // Multiple scattering (multiple_scattering.hpp MultipleScatteringOptions), off by default
    // here; adds multiple_scattering_radiance (not with medium_box).
    MultipleScatteringOptions multiple{.enabled = false};
    int threads = 0;  // 0: all hardware threads (the table precompute's too)
};

// Throws RenderError naming the first bad field.
void validate(const RenderSettings& settings);

// The scene with every phase function replaced by Henyey–Greenstein of g = henyey_greenstein_g (phase.hpp);
// for MatchedRenderer::povray the Rayleigh phase is kept (POV-Ray has it).
Scene renderer_matched_scene(const Scene& scene, MatchedRenderer renderer = MatchedRenderer::blender);

// The sun's top-of-atmosphere irradiance in linear Rec.709 through the scene's basis,
// clamped at 0: what a Blender Sun lamp of strength S and colour C must give as S·C, in the
// units of the sky texture (Σ E·CMF·Δλ, no 683 lm/W).
std::array<double, 3> sun_irradiance_rgb(const Scene& scene);

// Where the camera is: altitude above the surface (metres) and the rotation (rows) taking
// scene-frame directions into the evaluator's frame (observer on +Z).
struct ObserverFrame {
    double altitude_m = 0.0;
    std::array<glm::dvec3, 3> rotation{glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1)};
    glm::dvec3 to_observer(const glm::dvec3& d) const {
        return {rotation[0].x * d.x + rotation[0].y * d.y + rotation[0].z * d.z,
                rotation[1].x * d.x + rotation[1].y * d.y + rotation[1].z * d.z,
                rotation[2].x * d.x + rotation[2].y * d.y + rotation[2].z * d.z};
    }
};
ObserverFrame observer_frame(double planet_radius_m, const glm::dvec3& position_m);

// Renders the camera into a linear Rec.709 RGB image (rows top to bottom). Validates the
// scene and settings; throws RenderError / SceneError / CameraError, Cancelled (hooks.cancel).
// Never returns a non-finite pixel (a non-finite value is an error, not an image).
FloatImage render_camera(const Scene& scene, const RenderSettings& settings, const RenderHooks& hooks = {});

// EXR metadata: "airmass:scene", "airmass:render" (settings, camera, units, colour model),
// "airmass:version".
ImageMetadata render_metadata(const Scene& scene, const RenderSettings& settings);

// Radiance per wavelength of one view ray through a medium cut to `box` (see the header
// comment), for tests: from `origin_m` (scene frame) along `direction`. `atmosphere` from
// compile_atmosphere; out.size() = wavelength_count(). Includes the ground, not the disc.
void box_limited_radiance(const Atmosphere& atmosphere, const MediumBox& box, const glm::dvec3& origin_m,
                          const glm::dvec3& direction, const glm::dvec3& sun_direction, std::span<double> out);

}  // namespace airmass
