// Membership in the exported region: the atmosphere shell, intersected with the
// camera's visible volume (view) or an explicit box (box).
//
// A voxel is kept when its centre lies in the region grown by the reach of trilinear
// interpolation (one voxel along each axis), so that every point of the region is
// interpolated from correct neighbours rather than from inactive zeros:
//   * planes (frustum sides): margin voxel · ‖n‖₁ along the plane normal n;
//   * spheres (ground, max distance, the occluding planet): margin √3 · voxel;
//   * the box: one voxel along each axis;
//   * the top of the atmosphere: no margin for point values — the model's density is zero
//     above it; the means reach past it by their hats (a node there holds its share of the air
//     below the top), through the constituents' altitude bands (volume_layout.cpp).
#pragma once

#include <array>

#include "airmass/volume.hpp"

namespace airmass::detail {

class VdbRegionTest {
public:
    explicit VdbRegionTest(const VdbLayout& layout);

    // Shell radii (unit) holding the union of the constituents' altitude bands.
    double shell_min() const { return shell_min_; }
    double shell_max() const { return shell_max_; }

    // Exact test of one voxel centre against everything but the shell (the caller
    // tests radii per constituent band). `p` in world units.
    bool contains_ignoring_shell(const Vec3<double>& p) const;

    // Conservative: false only when no point of the world box [lo, hi] can be in the
    // region with radius in [r_min, r_max] around the planet centre.
    bool may_intersect(const Vec3<double>& lo, const Vec3<double>& hi, double r_min, double r_max) const;

private:
    struct Plane {
        Vec3<double> n{0.0};  // unit normal, pointing into the region
        double offset = 0;  // inside when n · p ≥ offset
    };
    bool box_outside_plane(const Plane& pl, const Vec3<double>& lo, const Vec3<double>& hi) const;
    bool box_fully_occluded(const Vec3<double>& lo, const Vec3<double>& hi) const;
    bool occluded(const Vec3<double>& p) const;

    Vec3<double> center_{0.0};
    double shell_min_ = 0, shell_max_ = 0;
    double sphere_margin_ = 0;
    // view region
    bool has_view_ = false;
    Vec3<double> camera_{0.0};
    double ball_radius_ = 0;  // max distance + margin
    std::array<Plane, 4> frustum_{};
    double occluder_radius_ = 0;  // planet radius − margin
    // shadow cone of the occluder seen from the camera (conservative block culling)
    Vec3<double> shadow_axis_{0.0};
    double shadow_cos_ = 1, shadow_plane_ = 0;
    // box region
    bool has_box_ = false;
    Vec3<double> box_lo_{0.0}, box_hi_{0.0};
};

}  // namespace airmass::detail
