// Sky textures: the sky seen by an observer (single scattering, plus multiple scattering
// by default), as an equirectangular image in Blender's convention, in the colour units of
// Blender's Nishita sky texture.
//
// Image convention (Blender/Cycles "Environment Texture", equirectangular; verified in
// docs/research and /work/shared/notes/renderer-facts.md): Z up, image centre = +X, a
// quarter from the left = +Y, −X at the seam, top row = zenith. Cycles maps a direction
// d to texture coordinates (v = 0 at the bottom row, v = 1 at the top)
//
//     u = (atan2(d.y, d.x) − π) / (−2π),        v = (acos(d.z) − π) / (−π),
//
// so the inverse used for pixel (x, y), y = 0 the top row, at its centre is
//
//     φ = π − 2π (x + ½)/W,   θ = π (y + ½)/H,   d = (sin θ cos φ, sin θ sin φ, cos θ).
//
// Sun direction (Blender Sky Texture "Sun Elevation" e and "Sun Rotation" r):
// s = (cos e sin r, cos e cos r, sin e) — rotation 0° points the sun toward +Y,
// 90° toward +X — so users type the same numbers as in Blender.
//
// Radiance and colour: per wavelength, L(λ) = in-scatter along the view ray (single
// scattering of sunlight, planet shadow included) + the ground (Lambertian, albedo
// from the scene, lit by the attenuated sun) seen through the view transmittance + the
// sun disc (E(λ)·T(λ)/Ω_sun, uniform disc, box-filtered into pixels so its total
// irradiance is right at any resolution), + with SkySettings::multiple.enabled the
// multiply-scattered light along the view ray and on the ground (multiple_scattering.hpp:
// `multiple_scattering_radiance`, tables precomputed once per render).
// The spectrum goes to linear Rec.709 by the
// scene's basis (color.hpp): XYZ = Σ L(λ)·CMF(λ)·Δλ (CIE 1931 2°, no 683 lm/W), then
// XYZ(D65) → linear Rec.709 — the units of Blender's Nishita texture, so swapping one
// for the other keeps the exposure. With the rgb-schuler basis, L at 615/535/445 nm
// goes through Schüler's matrix instead.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "airmass/atmosphere.hpp"
#include "airmass/chapman.hpp"
#include "airmass/image.hpp"
#include "airmass/multiple_scattering.hpp"
#include "airmass/progress.hpp"
#include "airmass/scene.hpp"

namespace airmass {

// ---- Equirectangular mapping (Blender/Cycles convention) -------------------------------

// Cycles' direction_to_equirectangular: unit direction → (u, v) ∈ [0, 1]², v = 1 up.
glm::dvec2 equirect_uv_from_direction(const glm::dvec3& direction);
// Its inverse: (u, v) → unit direction.
glm::dvec3 equirect_direction_from_uv(const glm::dvec2& uv);
// Direction through the centre of pixel (x, y) of a width × height image, y = 0 top row.
glm::dvec3 equirect_pixel_direction(int x, int y, int width, int height);
// Continuous pixel coordinates of a direction: pixel (x, y)'s centre is (x + ½, y + ½).
glm::dvec2 equirect_pixel_from_direction(const glm::dvec3& direction, int width, int height);
// Solid angle of a pixel in row y, steradians: (2π/W)·(cos θ_top − cos θ_bottom).
double equirect_pixel_solid_angle(int y, int width, int height);

// Unit vector toward the sun from Blender Sky Texture angles (see the header comment).
glm::dvec3 sun_direction(double elevation_deg, double rotation_deg);

// ---- Rendering -----------------------------------------------------------------------

// Every problem with sky settings: the message names the field, value and allowed range.
struct SkyError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

enum class SkyRegion {
    full,   // the whole sphere: sky, ground / planet, limb
    upper,  // only rows whose centre is at or above the horizon are computed; the others are 0
};

inline constexpr int kSkyDefaultMultipleGrid = 32;

struct SkySettings {
    int width = 2048;   // pixels over 360°
    int height = 1024;  // pixels over 180° (width/2 keeps pixels square)
    SkyRegion region = SkyRegion::full;
    // View-ray quality (atmosphere.hpp EvalSettings: chapman, view_samples, sun_disc, ground).
    // The sun disc is on by default here and box-filtered into pixels (render_sky; point-sampled
    // by sky_radiance_rgb).
    EvalSettings view{.sun_disc = true};
    int threads = 0;  // 0: all hardware threads (the table precompute's too)
    // Sky grid (Blender's precomputed-texture idea, with its error measured by
    // `airmass report sky`): evaluate the sky on a grid over (view zenith angle, azimuth
    // from the sun) and interpolate every pixel from it (Catmull–Rom, sky_grid.hpp
    // SkyGridLayout::image). By mirror symmetry the azimuth spans [0°, 180°] in `grid`
    // intervals, denser toward the sun; the zenith angle has two pieces split exactly at the
    // horizon (sky / ground, never interpolated across), each `grid` intervals, far denser
    // toward the horizon — and, for an observer above a profile's knot or above the
    // atmosphere, the sky split further where rays graze the knots, and from 60 m up at the
    // horizontal (sky_grid.hpp Horizon::kinks), each piece below a kink `grid`/2 + 1 rows. Each radiance column's single scattering is held over its
    // constituents' phase functions mixed by optical depth and multiplied back per pixel (the
    // aureole is not interpolated). 0: evaluate every
    // pixel. −1 (auto): the grid of kSkyDefaultGrid. A grid (auto or given) is used only when it has fewer nodes than
    // the rays a per-pixel render evaluates (the region's pixels, halved by the mirror
    // symmetry when it applies); otherwise every pixel is evaluated (as grid 0: the grid's
    // own limit, exact and cheaper). effective_sky_grid says which.
    int grid = -1;
    // Multiple scattering (multiple_scattering.hpp MultipleScatteringOptions: enabled, tables,
    // view_samples), on by default: without it the sky is far too dark at twilight and in the
    // Earth's shadow (docs/multiple_scattering.md). The tables are precomputed once per
    // render_sky call, at the wavelengths the image uses, and the radiance is added wherever
    // single scattering is evaluated (grid nodes or pixels). `multiple.tables.cancel` unset
    // takes the render's cancel flag; `multiple.tables.progress`, if set, is called besides
    // the render's progress hook.
    MultipleScatteringOptions multiple{};
    // The multiple-scattering view (evaluator.hpp MsView): the tables are integrated along the
    // rays of a coarse sun-aligned grid of this many azimuth intervals and interpolated for
    // every grid node or pixel (the light is smooth in direction). 0: integrated along every
    // evaluated ray. As for `grid`, the view is built only when it has fewer rays
    // ((M + 1) × 2 (M/2 + 1) for M intervals) than the render evaluates (the sky grid's nodes
    // when it is used, else the pixels); otherwise the tables are integrated along every
    // evaluated ray (as 0). effective_sky_multiple_grid says which. Error and cost:
    // `airmass report sky`, docs/sky.md. A knob of how one sky image samples the evaluator per
    // observer and sun (Evaluator::ms_view), not of the evaluator or its tables, so it stays
    // here beside `grid` (a render or `eval` has none).
    int multiple_grid = kSkyDefaultMultipleGrid;
    // Where either grid is rough — its cubic cannot follow the light across a cell
    // (SkyGrid::rough_cells: a shadow's edge across the limb seen from orbit, a band next to
    // the horizontal at twilight) — evaluate the pixels of those cells along their own rays
    // (the multiple scattering too where the view's cell is rough) instead of interpolating.
    // On by default; it costs nothing where the grids are smooth (the ground at day) and
    // 1.7-4x from orbit at twilight (docs/sky.md "Rough cells"). false: interpolate every pixel.
    bool refine_rough_cells = true;
};

inline constexpr int kSkyDefaultGrid = 40;
inline constexpr int kSkyMaxGrid = 16384;

// Limits checked by validate(SkySettings).
inline constexpr int kSkyMaxDimension = 65536;
inline constexpr int kSkyMaxViewSamples = 65536;
inline constexpr int kSkyMaxMultipleSamples = 100000;

void validate(const SkySettings& settings);  // throws SkyError

// The grid intervals a render will use (settings.grid resolved: 0 = every pixel).
int effective_sky_grid(const Scene& scene, const SkySettings& settings);
// The multiple-scattering view's intervals a render will use (settings.multiple_grid
// resolved: 0 = the tables integrated along every evaluated ray, and 0 without multiple
// scattering).
int effective_sky_multiple_grid(const Scene& scene, const SkySettings& settings);

// The multiple-scattering tables render_sky computes for `scene` and `settings` (the
// atmosphere at the wavelengths the image uses; settings.multiple.tables). They depend on neither
// the sun nor the observer nor the image size, so callers that render many skies of one
// scene (animations of the sun, reports, tests) compute them once and pass them below.
// Progress goes to hooks.work_done in units of 1/1000 of the precompute; cancellable.
MultipleScattering sky_multiple_scattering(const Scene& scene, const SkySettings& settings,
                                           const RenderHooks& hooks = {});

// Renders the sky of `scene` (validated here) into a linear Rec.709 RGB image. With
// settings.multiple.enabled, `tables` (from sky_multiple_scattering for the same scene
// and settings) are used if given, else computed here (progress and cancel through `hooks`).
// Tables of another wavelength count or constituent set are rejected (SkyError).
FloatImage render_sky(const Scene& scene, const SkySettings& settings, const RenderHooks& hooks = {},
                      const MultipleScattering* tables = nullptr);

// A sky renderer for one atmosphere, for many suns and observers (an add-on's live preview
// while the sun is dragged, animations of the sun). Made once: the scene's atmosphere is
// compiled at the image's wavelengths and the multiple-scattering tables computed (or taken
// from `tables`, or from settings.multiple.tables.store) — neither depends on the sun, the observer
// or the image size (table_store.cpp: the tables' key holds neither). Then each render()
// pays only for the sun direction: the multiple-scattering view, the sky grid and the pixels.
//
// render() takes its own settings, which may differ from the session's in everything that
// neither the atmosphere nor the tables depend on: width, height, region, view.view_samples,
// view.sun_disc, threads, grid, multiple.view_samples, multiple_grid. A different
// view.chapman, view.ground, multiple.enabled or table setting (multiple.tables) is a
// SkyError naming the field.
// render() is const and thread-safe (several renders of one session may run at once); the
// session must outlive them.
class SkySession {
public:
    // Validates the scene and settings (SkyError/SceneError name the field). `tables`, if
    // given, must be those of this scene and settings (SkyError otherwise). The table
    // precompute reports through hooks.work_done as `units` of `total`; cancellable (Cancelled).
    SkySession(const Scene& scene, const SkySettings& settings, const RenderHooks& hooks = {},
               std::shared_ptr<const MultipleScattering> tables = nullptr, std::size_t units = 1000,
               std::size_t total = 1000);

    // The sky for the sun at `sun_direction` (unit, scene frame: Z up; sun_direction() of
    // Blender's angles) and an observer `altitude_m` above the ground. Progress through
    // hooks.work_done in units of a total that render() chooses; cancellable (Cancelled).
    FloatImage render(const glm::dvec3& sun_direction, double altitude_m, const SkySettings& settings,
                      const RenderHooks& hooks = {}) const;
    // The same with the session's settings.
    FloatImage render(const glm::dvec3& sun_direction, double altitude_m, const RenderHooks& hooks = {}) const;

    const Scene& scene() const;
    const SkySettings& settings() const;
    // The tables in use (null with multiple scattering off).
    const std::shared_ptr<const MultipleScattering>& tables() const;

    struct Impl;

private:
    std::shared_ptr<const Impl> impl_;
};

// Linear Rec.709 radiance of one direction (sun disc as a point-sampled uniform disc);
// for tests and reports. `direction` need not be unit. With multiple scattering on, this
// form precomputes the tables on every call (about a second at 48 wavelengths): use the
// batch form, or pass tables.
glm::dvec3 sky_radiance_rgb(const Scene& scene, const SkySettings& settings, const glm::dvec3& direction);
// The same for many directions (one atmosphere set-up and one table precompute; parallel).
std::vector<glm::dvec3> sky_radiance_rgb(const Scene& scene, const SkySettings& settings,
                                         std::span<const glm::dvec3> directions,
                                         const MultipleScattering* tables = nullptr);

// EXR metadata for a sky: "airmass:scene" (scene_to_json), "airmass:settings" (JSON of
// the settings and derived quantities: sun direction, wavelengths, units, whether multiple
// scattering is included and its table settings),
// "airmass:version", "airmass:convention", and "airmass:units".
ImageMetadata sky_metadata(const Scene& scene, const SkySettings& settings);
std::string sky_settings_to_json(const Scene& scene, const SkySettings& settings);

}  // namespace airmass
