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

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include <glm/geometric.hpp>

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

// voxel_average where it has the closed form (the hat inside [0, top] and inside one piece:
// cheap, and almost every voxel of a fine lattice); false where it needs the quadrature.
bool voxel_average_closed_form(const DensityPieces& prof, double h_m, const Vec3<double>& n, double voxel_m,
                               double& value);

// The means of a lattice's voxels that the planet's symmetry makes equal, each computed once.
// Voxel centres lie at i·Δ and the planet's centre at c; wherever m_a = 2c_a/Δ is an integer
// (axis a is symmetric: c_a = 0 — x and y with the default origin on the surface, every axis
// with the origin at the centre) the reflection i_a → m_a − i_a maps the lattice onto itself,
// and so does swapping two symmetric axes. A voxel's altitude and its hat's projected widths
// |n_a|Δ go with it, hence its mean: the whole planet needs 1/8 of its voxels' quadratures
// (1/48 with the centre as origin). Each class's mean is computed from its canonical member
// (offsets |2i_a − m_a| sorted down over the symmetric axes): every member gets the same
// value, whichever worker asked first. Thread-safe (64 locked shards of an open-addressing
// table); beyond `max_bytes` of table it computes without storing.
class SymmetricAverages {
public:
    struct Lattice {
        double voxel = 1;           // Δ, in the layout's unit
        Vec3<double> centre{0.0};   // the planet's centre, unit
        double planet_radius = 0;   // unit
        double metres_per_unit = 1;

        // What a voxel's value depends on, computed in this one place: the sampler's own voxels
        // and the store's canonical members must get the same bits.
        struct Voxel {
            double r;           // distance of the centre from the planet's centre, unit
            double altitude_m;  // of the centre
            Vec3<double> up;    // outward unit normal ((0, 0, 1) at the planet's centre)
        };
        Vec3<double> point(std::int64_t i, std::int64_t j, std::int64_t k) const {
            return Vec3<double>(double(i), double(j), double(k)) * voxel;
        }
        Voxel at(const Vec3<double>& p) const {
            const double r = glm::length(p - centre);
            return {r, (r - planet_radius) * metres_per_unit, r > 0.0 ? (p - centre) / r : Vec3<double>(0, 0, 1)};
        }
    };
    SymmetricAverages(const Lattice& lattice, const std::vector<DensityPieces>& profiles, std::size_t max_bytes);
    ~SymmetricAverages();
    SymmetricAverages(const SymmetricAverages&) = delete;
    SymmetricAverages& operator=(const SymmetricAverages&) = delete;

    // Whether any axis is symmetric (else get() is voxel_average at the voxel itself).
    bool useful() const { return symmetric_axes_ > 0; }
    // The means over the hat of voxel ijk of the profiles whose bits are set in `which`, into
    // out[c] (the others untouched); one lookup for all of them.
    void get(const std::array<std::int32_t, 3>& ijk, std::uint64_t which, double* out);
    // The mean of profile `c` alone.
    double get(std::size_t c, const std::array<std::int32_t, 3>& ijk) {
        double v[64];
        get(ijk, std::uint64_t(1) << c, v);
        return v[c];
    }
    // How many classes hold a stored mean (tests).
    std::size_t stored() const;

private:
    struct Shard;
    void compute(const std::array<std::int64_t, 3>& ijk, std::uint64_t which, double* out) const;

    Lattice lattice_;
    const std::vector<DensityPieces>& profiles_;
    std::array<std::int64_t, 3> twice_centre_{};  // m_a = 2c_a/Δ (symmetric axes)
    std::array<bool, 3> symmetric_{};
    int symmetric_axes_ = 0;
    std::size_t max_bytes_;
    std::atomic<std::size_t> bytes_{0};
    std::unique_ptr<Shard[]> shards_;
};

}  // namespace airmass::detail
