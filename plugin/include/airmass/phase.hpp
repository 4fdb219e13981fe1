// Phase functions, in sr⁻¹: each integrates to 1 over the sphere of directions.
//
// The argument mu is the cosine of the scattering angle: the angle between the
// direction light travels before and after the event. For sunlight seen along a view
// ray, mu = dot(view direction, direction toward the sun) (forward scattering, mu = 1,
// is looking at the sun).
//
//   Rayleigh            3/(16π) (1 + mu²)                                (Bruneton 2017, seed 004 F_R / 4π)
//   Rayleigh, modified  (1.4 + 0.5 mu²) / (4π · 47/30)                    (seed 004 §1.5, Boody; see below)
//   Cornette–Shanks     3/(8π) (1 − g²)/(2 + g²) (1 + mu²)/(1 + g² − 2g mu)^{3/2}
//   Henyey–Greenstein   1/(4π) (1 − g²)/(1 + g² − 2g mu)^{3/2}
//   isotropic           1/(4π)
//
// Modified Rayleigh: seed 004 writes F_R = 0.8 (1.4 + 0.5 mu²) next to the standard
// F_R = 0.75 (1 + mu²), whose mean over the sphere is 1. The modified form's mean is
// 0.8 (1.4 + 0.5/3) = 1.2533, i.e. it is 25.3 % brighter than Rayleigh; we keep its
// shape and normalise it: (1.4 + 0.5 mu²)/(1.4 + 1/6) / (4π).
// Cornette–Shanks in seed 004 is written with "+2g cos" and g < 0 for forward
// scattering; with mu as defined above it is Bruneton's form (g > 0 forward).
#pragma once

#include "airmass/scene.hpp"

namespace airmass {

template <class T>
T phase_rayleigh(T mu);

template <class T>
T phase_rayleigh_modified(T mu);

template <class T>
T phase_cornette_shanks(T mu, T g);

template <class T>
T phase_henyey_greenstein(T mu, T g);

template <class T>
T phase_isotropic();

// Dispatch on a scene's phase function.
template <class T>
T phase(const PhaseFunction& f, T mu);

// The rule that splits radiance into `radiance_rayleigh` and `radiance_mie`: a
// constituent is Rayleigh-like when its phase function is Rayleigh or modified Rayleigh;
// every other phase function (Cornette–Shanks, Henyey–Greenstein, isotropic) is Mie-like.
bool is_rayleigh_like(const PhaseFunction& f);

// The one phase → Henyey–Greenstein rule (docs/compare.md, "One phase → HG rule"): the g a
// renderer whose only phase function is Henyey–Greenstein (Cycles 3.4–4.2's Volume Scatter)
// is given for `f` — HG keeps its g; Cornette–Shanks gets the HG of the same mean cosine,
// 3g(4 + g²)/(5(2 + g²)) (0.8 → 0.8436); Rayleigh, modified Rayleigh and isotropic 0. Used by
// renderer_matched_scene, the analytic-density JSON ("g_hg", read by the Blender add-on and
// `airmass compare`) and mirrored by the add-on's compat.hg_anisotropy (tested equal).
double henyey_greenstein_g(const PhaseFunction& f);

}  // namespace airmass
