// Blender/Cycles camera conventions (see camera.hpp for the derivations and sources).
#include "airmass/camera.hpp"

#include <cmath>
#include <cstdio>
#include <numbers>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "airmass/sky.hpp"

#include "support/message_format.hpp"

namespace airmass {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

using detail::all_finite;
using detail::message_number;

}  // namespace

std::string_view sensor_fit_name(SensorFit f) {
    switch (f) {
        case SensorFit::automatic: return "AUTO";
        case SensorFit::horizontal: return "HORIZONTAL";
        case SensorFit::vertical: return "VERTICAL";
    }
    return "AUTO";
}

std::string_view projection_name(Projection p) {
    return p == Projection::perspective ? "perspective" : "equirectangular";
}

CameraPose look_at(const glm::dvec3& position_m, const glm::dvec3& direction, const glm::dvec3& up) {
    if (!all_finite(position_m)) throw CameraError("camera.position_m: must be 3 finite numbers");
    const double dl = glm::length(direction), ul = glm::length(up);
    if (!all_finite(direction) || !(dl > 0.0)) throw CameraError("camera.direction: must be a finite non-zero vector");
    if (!all_finite(up) || !(ul > 0.0)) throw CameraError("camera.up: must be a finite non-zero vector");
    const glm::dvec3 f = direction / dl;
    const glm::dvec3 r = glm::cross(f, up / ul);
    const double rl = glm::length(r);
    // sin of the angle between direction and up; below ~1e-9 the roll is undefined.
    if (!(rl > 1e-9)) throw CameraError("camera.up: must not be parallel to camera.direction");
    CameraPose pose;
    pose.position_m = position_m;
    pose.right = r / rl;
    pose.up = glm::cross(pose.right, f);  // unit: right ⟂ f, both unit
    pose.back = -f;
    return pose;
}

void validate(const CameraModel& c) {
    auto fail = [](const std::string& field, double v, const std::string& allowed) {
        throw CameraError("camera." + field + " = " + message_number(v) + ": must be " + allowed);
    };
    if (c.width < 1 || c.width > 65536) fail("width", c.width, "an integer in [1, 65536]");
    if (c.height < 1 || c.height > 65536) fail("height", c.height, "an integer in [1, 65536]");
    if (c.projection == Projection::perspective) {
        if (!(c.focal_length_mm > 0.0) || !std::isfinite(c.focal_length_mm))
            fail("focal_length_mm", c.focal_length_mm, "> 0");
        if (!(c.sensor_width_mm > 0.0) || !std::isfinite(c.sensor_width_mm))
            fail("sensor_width_mm", c.sensor_width_mm, "> 0");
        if (!(c.sensor_height_mm > 0.0) || !std::isfinite(c.sensor_height_mm))
            fail("sensor_height_mm", c.sensor_height_mm, "> 0");
    } else {
        if (!(c.latitude_min_deg >= -90.0 && c.latitude_min_deg < c.latitude_max_deg && c.latitude_max_deg <= 90.0))
            fail("latitude_min_deg", c.latitude_min_deg, "< latitude_max_deg, both in [-90, 90]");
        if (!(c.longitude_min_deg >= -180.0 && c.longitude_min_deg < c.longitude_max_deg &&
              c.longitude_max_deg <= 180.0))
            fail("longitude_min_deg", c.longitude_min_deg, "< longitude_max_deg, both in [-180, 180]");
    }
    const CameraPose& p = c.pose;
    if (!all_finite(p.position_m)) throw CameraError("camera.position_m: must be 3 finite numbers");
    const double ortho = std::abs(glm::dot(p.right, p.up)) + std::abs(glm::dot(p.up, p.back)) +
                         std::abs(glm::dot(p.back, p.right));
    const double norm = std::abs(glm::length(p.right) - 1.0) + std::abs(glm::length(p.up) - 1.0) +
                        std::abs(glm::length(p.back) - 1.0);
    const double handed = glm::length(glm::cross(p.right, p.up) - p.back);
    if (!(ortho < 1e-9 && norm < 1e-9 && handed < 1e-9))
        throw CameraError("camera pose: right, up, back must be orthonormal and right-handed (use look_at)");
}

double focal_length_mm_from_fov(double fov_deg, double sensor_mm) {
    if (!(fov_deg > 0.0 && fov_deg < 180.0))
        throw CameraError("camera.fov_deg = " + message_number(fov_deg) + ": must be in (0, 180)");
    if (!(sensor_mm > 0.0) || !std::isfinite(sensor_mm))
        throw CameraError("camera sensor = " + message_number(sensor_mm) + " mm: must be > 0");
    return 0.5 * sensor_mm / std::tan(0.5 * fov_deg * kDeg);
}

double fov_deg_from_focal_length(double focal_length_mm, double sensor_mm) {
    if (!(focal_length_mm > 0.0) || !std::isfinite(focal_length_mm))
        throw CameraError("camera.focal_length_mm = " + message_number(focal_length_mm) + ": must be > 0");
    return 2.0 * std::atan(0.5 * sensor_mm / focal_length_mm) / kDeg;
}

bool fits_horizontally(const CameraModel& c) {
    switch (c.sensor_fit) {
        case SensorFit::automatic: return c.width > c.height;  // Cycles: xratio > yratio
        case SensorFit::horizontal: return true;
        case SensorFit::vertical: return false;
    }
    return true;
}

double fitted_sensor_mm(const CameraModel& c) {
    return c.sensor_fit == SensorFit::vertical ? c.sensor_height_mm : c.sensor_width_mm;
}

namespace {

// The focal length in pixels: the distance at which one pixel is one unit wide.
double focal_length_px(const CameraModel& c) {
    const double n = fits_horizontally(c) ? c.width : c.height;
    return n * c.focal_length_mm / fitted_sensor_mm(c);
}

}  // namespace

double horizontal_fov_deg(const CameraModel& c) {
    return 2.0 * std::atan(0.5 * c.width / focal_length_px(c)) / kDeg;
}

double vertical_fov_deg(const CameraModel& c) {
    return 2.0 * std::atan(0.5 * c.height / focal_length_px(c)) / kDeg;
}

glm::dvec3 camera_local_direction(const CameraModel& c, double x, double y) {
    if (c.projection == Projection::perspective) {
        const glm::dvec3 d(x - 0.5 * c.width, 0.5 * c.height - y, -focal_length_px(c));
        return glm::normalize(d);
    }
    // Cycles (Camera::update, equirectangular_range): u = x/W, v = (H − y)/H (v from the
    // bottom); azimuth φ = −(lon_min + (lon_max − lon_min) u), latitude lat_min + (lat_max −
    // lat_min) v; the panorama frame is (forward, left, up) = (−Z, −X, +Y) of the camera.
    const double u = x / c.width, v = 1.0 - y / c.height;
    const double phi = -(c.longitude_min_deg + (c.longitude_max_deg - c.longitude_min_deg) * u) * kDeg;
    const double lat = (c.latitude_min_deg + (c.latitude_max_deg - c.latitude_min_deg) * v) * kDeg;
    const double cl = std::cos(lat);
    const glm::dvec3 pano(cl * std::cos(phi), cl * std::sin(phi), std::sin(lat));  // forward, left, up
    return {-pano.y, pano.z, -pano.x};
}

glm::dvec3 camera_ray_direction(const CameraModel& c, double x, double y) {
    const glm::dvec3 l = camera_local_direction(c, x, y);
    return glm::normalize(l.x * c.pose.right + l.y * c.pose.up + l.z * c.pose.back);
}

glm::dvec3 camera_pixel_direction(const CameraModel& c, int i, int j) {
    if (c.projection == Projection::equirectangular && c.latitude_min_deg == -90.0 && c.latitude_max_deg == 90.0 &&
        c.longitude_min_deg == -180.0 && c.longitude_max_deg == 180.0) {
        // The full sphere: exactly sky.hpp's pixel mapping in the panorama frame.
        const glm::dvec3 pano = equirect_pixel_direction(i, j, c.width, c.height);
        return glm::normalize(pano.x * c.pose.forward() - pano.y * c.pose.right + pano.z * c.pose.up);
    }
    return camera_ray_direction(c, i + 0.5, j + 0.5);
}

CameraModel camera_from_scene(const Scene& scene, Projection projection) {
    if (!scene.camera) throw CameraError("scene '" + scene.name + "' has no [camera] table (docs/scene.md)");
    const Camera& sc = *scene.camera;
    CameraModel c;
    c.projection = projection;
    c.width = sc.width;
    c.height = sc.height;
    c.sensor_fit = SensorFit::automatic;
    c.focal_length_mm = focal_length_mm_from_fov(sc.fov_deg, c.sensor_width_mm);
    c.pose = look_at({sc.position_m[0], sc.position_m[1], sc.position_m[2]},
                     {sc.direction[0], sc.direction[1], sc.direction[2]}, {sc.up[0], sc.up[1], sc.up[2]});
    validate(c);
    return c;
}

std::string camera_to_json(const CameraModel& c, double metres_per_unit) {
    using nlohmann::json;
    auto vec = [](const glm::dvec3& v) { return json::array({v.x, v.y, v.z}); };
    json j{{"type", c.projection == Projection::perspective ? "PERSP" : "PANO"},
           {"panorama_type", "EQUIRECTANGULAR"},
           {"width", c.width},
           {"height", c.height},
           {"lens_mm", c.focal_length_mm},
           {"sensor_width_mm", c.sensor_width_mm},
           {"sensor_height_mm", c.sensor_height_mm},
           {"sensor_fit", std::string(sensor_fit_name(c.sensor_fit))},
           {"latitude_min_deg", c.latitude_min_deg},
           {"latitude_max_deg", c.latitude_max_deg},
           {"longitude_min_deg", c.longitude_min_deg},
           {"longitude_max_deg", c.longitude_max_deg},
           {"location", vec(c.pose.position_m / metres_per_unit)},
           // Columns of the rotation part of Blender's matrix_world: local X, Y, Z in the world.
           {"axis_x", vec(c.pose.right)},
           {"axis_y", vec(c.pose.up)},
           {"axis_z", vec(c.pose.back)},
           {"horizontal_fov_deg", c.projection == Projection::perspective ? horizontal_fov_deg(c) : 360.0},
           {"vertical_fov_deg", c.projection == Projection::perspective ? vertical_fov_deg(c) : 180.0}};
    return j.dump();
}

}  // namespace airmass
