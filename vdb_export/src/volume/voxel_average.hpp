// A voxel's value as the mean of the density over its trilinear hat (VoxelValues::average,
// docs/vdb.md "Voxel values"): what makes a grid's trilinear reconstruction carry the
// atmosphere's mass at any voxel size.
//
// A renderer reconstructs ρ̃(x) = Σ_i v_i φ_i(x) from the voxel values v_i with the hats
// φ_i(x) = Π_a (1 − |x_a − x_i,a|/Δ)₊, which sum to 1 everywhere. With
//
//     v_i = ∫_D ρ φ_i dx / ∫_D φ_i dx,        D = the air above the ground (h ≥ 0),
//
// the reconstruction's integral over D is Σ_i v_i ∫_D φ_i = ∫_D ρ Σ_i φ_i = ∫_D ρ: no bias,
// whatever Δ is against the scale heights. Point values v_i = ρ(h_i) (VoxelValues::point) put
// the convex exponential's chords in its place — for Earth's aerosol (1.2 km) in 2 km voxels
// ≈ +26 % optical depth along rays to the ground, in 8 km voxels about 20× — and the error
// depends on where the ground cuts the lattice, which a render shows as ripples.
//
// Within one voxel the ground is taken flat: h(x) = h_i + n·(x − x_i), n the outward normal
// at the voxel (the curvature changes h by Δ²/2R: 5 m for an 8 km voxel on Earth). Then the
// mean is over S = n·(x − x_i), a sum of three independent triangular variables of half-widths
// |n_a|Δ: the one of the widest axis is integrated in closed form, the other two by
// Gauss–Legendre on each half of their triangles — except where the hat lies inside one
// smooth piece of the profile and inside [0, top] (almost every voxel): there the mean is
// exact in closed form (a linear piece: its value at h_i; an exponential: ρ(h_i) times the
// triangles' moment generating functions, Π_a (sinh(y_a)/y_a)², y_a = |n_a|Δ/2H).
#pragma once

#include <vector>

#include "airmass/geometry.hpp"
#include "airmass/scene.hpp"

namespace airmass::detail {

// The profile as pieces of altitude (metres), each linear (c0 + c1 h) or exponential
// (exp(−(h − ref)/H)); 0 outside the pieces and above `top_m` (the atmosphere's top: no
// density there) — DensityProfile::at on [0, top_m].
struct DensityPieces {
    struct Piece {
        double lo, hi;  // altitudes, lo < hi (±inf allowed)
        bool exponential = false;
        double c0 = 0, c1 = 0;      // linear
        double ref = 0, H = 1;      // exponential
    };
    std::vector<Piece> pieces;  // increasing, disjoint
    double top_m = 0;

    static DensityPieces of(const DensityProfile& p, double top_m);
};

// v of the voxel at altitude h_m (metres; its centre) with outward unit normal n, edge
// voxel_m (metres), as above; 0 when no part of its hat is above the ground. ≥ 0, finite,
// at most the profile's largest value on [0, top_m].
double voxel_average(const DensityPieces& prof, double h_m, const Vec3<double>& n, double voxel_m);

}  // namespace airmass::detail
