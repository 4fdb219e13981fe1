// The evaluator: the one object every consumer asks for light in the atmosphere.
//
// Pipeline (docs/architecture.md): Scene → compile_atmosphere (atmosphere.hpp) → Evaluator
// (this file: the compiled atmosphere, plus the multiple-scattering tables when they are
// asked for) → writers (sky images, camera renders, `airmass eval`, the C ABI and the
// add-on's sun lamp, the volume export's lamp). In the manner of Bruneton's
// `Model::GetSkyRadiance / GetSkyRadianceToPoint / GetSunAndSkyIrradiance`:
//
//   radiance(view ray)          L(λ) seen along a ray: single scattering of sunlight, the
//                               sunlit ground, the sun disc (EvalSettings), and — with
//                               tables — the multiply-scattered light along the ray and on
//                               the ground (multiple_scattering.hpp). Added exactly once here,
//                               so no caller adds the tables itself.
//   aerial_perspective(a → b)   T and in-scatter S between two points (single scattering).
//   transmittance(segment)      T(λ) along a segment of a ray (0 through the ground).
//   sun_light(point)            the direct sunlight reaching a point, E_sun(λ)·T_sun(λ)
//                               (0 in the planet's shadow) — the one sun-ray computation,
//                               optical_depth.hpp sun_masses.
//
// Units: metres, unit direction vectors in the evaluator's frame (planet centre at the
// origin, the observer on +Z: see single_scattering.hpp ViewRay); radiance in
// W m⁻² sr⁻¹ nm⁻¹ and irradiance in W m⁻² nm⁻¹ for the atmosphere's E_sun.
// Every member is const and thread-safe; an Evaluator is cheap to move and its tables can
// be shared between evaluators of one atmosphere (a sequence of sun positions).
#pragma once

#include <memory>
#include <span>

#include "airmass/atmosphere.hpp"
#include "airmass/geometry.hpp"
#include "airmass/multiple_scattering.hpp"
#include "airmass/progress.hpp"
#include "airmass/single_scattering.hpp"
#include "airmass/sky_grid.hpp"

namespace airmass {

// Multiple scattering as one observer sees it: the tables' radiance integrated along the rays
// of a coarse sun-aligned grid of view directions (sky_grid.hpp; `intervals` azimuth steps
// over 0–180° and intervals/2 + 1 zenith rows above and below the horizon) and interpolated
// (Catmull–Rom, sky_grid.hpp; clamped at 0) for any direction. Multiply-scattered light varies slowly with direction, so a
// few hundred rays stand for a whole sky image's tens of thousands. Built by
// Evaluator::ms_view for one altitude and sun; its error and cost against per-ray
// integration are measured by `bench/sky_vs_blender.sh` (docs/sky.md).
//
// What is interpolated is normalised by the ray's own view transmittance T(λ), which the
// single-scattering pass has for every ray: the in-scattered part over (1 − T) and the
// ground's part over T. Near the horizon the length of a ray changes by orders of magnitude
// within a fraction of a degree (a ground ray from 2 m meets the ground 100 m away 1° below
// the horizon, and 200 km away at it); the in-scatter follows its (1 − T), while the ratio
// — a mean source along the ray — stays smooth.
struct MsView {
    double altitude_m = 0.0;
    Vec3<double> sun{0.0, 0.0, 1.0};
    SkyGrid grid;  // 2 × wavelength count channels: in-scatter / (1 − T), ground part / T

    // The multiple-scattering radiance of a unit direction whose view transmittance is
    // `transmittance` (0 where it misses the atmosphere): `out` the total, `inscatter` (if not
    // empty) the part scattered along the ray, without the ground's.
    void lookup(Vec3<double> direction, std::span<const double> transmittance, std::span<double> out,
                std::span<double> inscatter = {}) const;
};

class Evaluator {
public:
    // Single scattering only.
    explicit Evaluator(Atmosphere atmosphere);
    // With multiple-scattering tables computed for this atmosphere (same wavelengths and
    // constituents; std::invalid_argument otherwise) and `ms_view_samples` intervals per ray.
    Evaluator(Atmosphere atmosphere, std::shared_ptr<const MultipleScattering> tables, int ms_view_samples = 32);

    const Atmosphere& atmosphere() const { return atmosphere_; }
    std::size_t wavelength_count() const { return atmosphere_.wavelength_count(); }
    // The tables in use, or null (single scattering only).
    const MultipleScattering* tables() const { return tables_.get(); }
    const std::shared_ptr<const MultipleScattering>& shared_tables() const { return tables_; }
    int ms_view_samples() const { return ms_view_samples_; }

    // The radiance along one view ray. out.radiance is the total (single + ground + disc +
    // multiple); out.radiance_rayleigh / radiance_mie the single-scattering in-scatter.
    // `multiple`, if given, receives the multiple-scattering parts (zero without tables).
    void radiance(const ViewRay& ray, RadianceOut out, const MsRadianceOut* multiple = nullptr) const;
    // Many view directions from one observer (ray-major spans, n × wavelength_count()). With
    // `view` (from ms_view for the same altitude and sun; std::invalid_argument otherwise) the
    // multiple scattering is interpolated from it instead of integrated along every ray.
    // `multiple_inscatter`, if not empty (n × wavelength_count()), receives the part of the
    // multiple scattering added to out.radiance that was scattered along the ray (the rest is
    // the ground's), so that out.radiance − out.radiance_rayleigh − out.radiance_mie −
    // multiple_inscatter is the light from the ground (and the disc, when the atmosphere adds it).
    void radiance(double altitude_m, Vec3<double> sun_direction, std::span<const Vec3<double>> view_directions,
                  RadianceOut out, const MsView* view = nullptr, std::span<double> multiple_inscatter = {}) const;

    // The horizon of an observer at altitude_m ≥ 0 in this atmosphere, with its kinks (the
    // profiles' knots, the horizontal): where the sky grids split (sky_grid.hpp).
    // std::invalid_argument for a negative or non-finite altitude.
    Horizon horizon(double altitude_m) const;

    // The multiple-scattering view of an observer (MsView) at altitude_m ≥ 0, `intervals` in
    // [2, 16384] (std::invalid_argument otherwise), its rays integrated on `threads` threads
    // (0: all); cancellable through hooks.cancel (Cancelled). All zero without tables.
    MsView ms_view(double altitude_m, Vec3<double> sun_direction, int intervals, int threads = 0,
                   const RenderHooks& hooks = {}) const;

    // Aerial perspective (single_scattering.hpp aerial_perspective): T and S from `from_m` to
    // `to_m` (planet-centred metres), or along that ray out of the atmosphere.
    void aerial_perspective(Vec3<double> from_m, Vec3<double> to_m, Vec3<double> sun_direction, bool to_infinity,
                            std::span<double> transmittance_out, std::span<double> inscatter_out) const;

    // T(λ) along t ∈ [t0, t1] of `ray` (t1 may be +inf: out of the atmosphere); 0 through
    // the ground.
    void transmittance(const PlanetRay<double>& ray, double t0_m, double t1_m, std::span<double> out) const;

    // Direct sunlight at a point `altitude_m` above the ground whose sun direction makes the
    // zenith cosine `sun_zenith`: E_sun(λ)·T_sun(λ) in `irradiance_out` (W m⁻² nm⁻¹ on a
    // surface facing the sun). Returns false — and zeros — in the planet's shadow.
    bool sun_light(double altitude_m, ZenithAngle<double> sun_zenith, std::span<double> irradiance_out) const;

private:
    Atmosphere atmosphere_;
    std::shared_ptr<const MultipleScattering> tables_;
    int ms_view_samples_ = 32;
};

// The multiple-scattering tables of `atmosphere` with `options.tables`, computed on `threads`
// threads (the consumer's one thread count; options.tables.threads is not read) and cancelled
// by options.tables.cancel or else hooks.cancel, progress reported through hooks.work_done as
// `units` of `total` while they are computed. Throws Cancelled.
std::shared_ptr<const MultipleScattering> compute_tables(const Atmosphere& atmosphere,
                                                         const MultipleScatteringOptions& options, int threads,
                                                         const RenderHooks& hooks = {}, std::size_t units = 0,
                                                         std::size_t total = 0);

// The evaluator of `atmosphere` with the options: given `tables` are checked and shared,
// else computed when options.enabled (compute_tables). Single scattering when disabled.
Evaluator make_evaluator(Atmosphere atmosphere, const MultipleScatteringOptions& options, int threads = 0,
                         const RenderHooks& hooks = {}, std::shared_ptr<const MultipleScattering> tables = nullptr,
                         std::size_t units = 0, std::size_t total = 0);

}  // namespace airmass
