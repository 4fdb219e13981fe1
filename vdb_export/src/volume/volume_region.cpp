// Region membership: exact per-voxel tests and conservative per-block culling.
#include "volume_region.hpp"

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace airmass::detail {

using Vec3d = Vec3<double>;

namespace {

// Squared distance from c to the nearest / farthest point of the box [lo, hi].
double min_distance_sq(const Vec3d& c, const Vec3d& lo, const Vec3d& hi) {
    double s = 0;
    for (int a = 0; a < 3; ++a) {
        const double d = c[a] < lo[a] ? lo[a] - c[a] : (c[a] > hi[a] ? c[a] - hi[a] : 0.0);
        s += d * d;
    }
    return s;
}

double max_distance_sq(const Vec3d& c, const Vec3d& lo, const Vec3d& hi) {
    double s = 0;
    for (int a = 0; a < 3; ++a) {
        const double d = std::max(std::abs(c[a] - lo[a]), std::abs(c[a] - hi[a]));
        s += d * d;
    }
    return s;
}

Vec3d corner(const Vec3d& lo, const Vec3d& hi, int i) {
    return Vec3d(i & 1 ? hi[0] : lo[0], i & 2 ? hi[1] : lo[1], i & 4 ? hi[2] : lo[2]);
}

}  // namespace

VdbRegionTest::VdbRegionTest(const VdbLayout& layout) : center_(layout.planet_center) {
    const double v = layout.voxel_size;
    sphere_margin_ = std::sqrt(3.0) * v;
    double band_min = std::numeric_limits<double>::infinity(), band_max = -band_min;
    for (const auto& c : layout.constituents) {
        band_min = std::min(band_min, c.band_min_m);
        band_max = std::max(band_max, c.band_max_m);
    }
    shell_min_ = layout.planet_radius + band_min / layout.metres_per_unit;
    // (Point values' bands end at the top; the means' reach past it by a hat: volume_layout.cpp.)
    shell_max_ = layout.planet_radius + band_max / layout.metres_per_unit;

    if (layout.view) {
        const VdbViewCone& cam = *layout.view;
        has_view_ = true;
        camera_ = cam.position;
        ball_radius_ = cam.max_distance + sphere_margin_;
        // Inward normals of the four side planes through the camera: a point at local
        // (x, y, z) = (right, up, forward) components is inside when |x| ≤ z tan_h, |y| ≤ z tan_v.
        const Vec3d dirs[4][2] = {{cam.forward * cam.tan_half_h, -cam.right},
                                  {cam.forward * cam.tan_half_h, cam.right},
                                  {cam.forward * cam.tan_half_v, -cam.up},
                                  {cam.forward * cam.tan_half_v, cam.up}};
        for (int i = 0; i < 4; ++i) {
            Vec3d n = dirs[i][0] + dirs[i][1];
            n = n / glm::length(n);
            const double reach = v * (std::abs(n[0]) + std::abs(n[1]) + std::abs(n[2]));
            frustum_[i] = Plane{n, glm::dot(n, camera_) - reach};
        }
        occluder_radius_ = std::max(0.0, layout.planet_radius - sphere_margin_);
        // Shadow of the occluder seen from the camera: the cone tangent to it and the
        // half-space beyond the plane of the tangent circle. A segment from the camera to
        // a point in both crosses that plane inside the tangent disk, i.e. inside the ball.
        const Vec3d to_center = center_ - camera_;
        const double dc = glm::length(to_center);
        if (dc > occluder_radius_ && occluder_radius_ > 0) {
            shadow_axis_ = to_center / dc;
            const double sin_a = occluder_radius_ / dc;
            shadow_cos_ = std::sqrt(std::max(0.0, 1.0 - sin_a * sin_a));
            shadow_plane_ = dc * shadow_cos_ * shadow_cos_;
        } else {
            shadow_cos_ = 2.0;  // no usable cone: never cull by occlusion
        }
    }
    if (layout.options.region == VdbRegion::box) {
        has_box_ = true;
        const auto& b = layout.options.box;
        box_lo_ = Vec3d(b[0], b[1], b[2]) - Vec3d(v);
        box_hi_ = Vec3d(b[3], b[4], b[5]) + Vec3d(v);
    }
}

bool VdbRegionTest::occluded(const Vec3d& p) const {
    // Does the segment camera → p pass through the ball of radius occluder_radius_?
    const Vec3d d = p - camera_;
    const Vec3d f = camera_ - center_;
    const double dd = glm::dot(d, d);
    if (dd == 0.0) return false;
    const double t = std::clamp(-glm::dot(f, d) / dd, 0.0, 1.0);
    const Vec3d q = f + d * t;
    return glm::dot(q, q) < occluder_radius_ * occluder_radius_;
}

bool VdbRegionTest::contains_ignoring_shell(const Vec3d& p) const {
    if (has_box_) {
        for (int a = 0; a < 3; ++a)
            if (p[a] < box_lo_[a] || p[a] > box_hi_[a]) return false;
    }
    if (has_view_) {
        const Vec3d d = p - camera_;
        if (glm::dot(d, d) > ball_radius_ * ball_radius_) return false;
        for (const auto& pl : frustum_)
            if (glm::dot(pl.n, p) < pl.offset) return false;
        if (occluded(p)) return false;
    }
    return true;
}

bool VdbRegionTest::box_outside_plane(const Plane& pl, const Vec3d& lo, const Vec3d& hi) const {
    // The box is outside when even its corner farthest along n is below the offset.
    Vec3d best(0.0);
    for (int a = 0; a < 3; ++a) best[a] = pl.n[a] >= 0 ? hi[a] : lo[a];
    return glm::dot(pl.n, best) < pl.offset;
}

bool VdbRegionTest::box_fully_occluded(const Vec3d& lo, const Vec3d& hi) const {
    if (shadow_cos_ > 1.0) return false;
    for (int i = 0; i < 8; ++i) {
        const Vec3d d = corner(lo, hi, i) - camera_;
        const double along = glm::dot(d, shadow_axis_);
        if (along < shadow_plane_) return false;                 // before the tangent circle
        if (along < glm::length(d) * shadow_cos_) return false;  // outside the tangent cone
    }
    return true;
}

bool VdbRegionTest::may_intersect(const Vec3d& lo, const Vec3d& hi, double r_min, double r_max) const {
    if (min_distance_sq(center_, lo, hi) > r_max * r_max) return false;
    if (max_distance_sq(center_, lo, hi) < r_min * r_min) return false;
    if (has_box_) {
        for (int a = 0; a < 3; ++a)
            if (hi[a] < box_lo_[a] || lo[a] > box_hi_[a]) return false;
    }
    if (has_view_) {
        if (min_distance_sq(camera_, lo, hi) > ball_radius_ * ball_radius_) return false;
        for (const auto& pl : frustum_)
            if (box_outside_plane(pl, lo, hi)) return false;
        if (box_fully_occluded(lo, hi)) return false;
    }
    return true;
}

}  // namespace airmass::detail
