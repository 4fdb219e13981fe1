// Cameras exactly as Blender and Cycles (3.4) define them, so that a native render and a
// Blender render of the same camera put the same direction through every pixel.
//
// Pose (Blender): a camera looks down its local −Z axis, local +Y is up in the image and
// local +X to the right. `CameraPose` holds those three axes in the scene frame (Z up at
// the observer, metres; scene.hpp) and the camera's position.
//
// Perspective (Cycles blender/camera.cpp, blender_camera_viewplane and the fov it derives):
// the sensor of size `sensor_mm` spans the *fitted* image dimension at distance
// `focal_length_mm`:
//   * sensor fit AUTO: the larger of width and height (width when width > height, as
//     Cycles' `xratio > yratio`; a square image fits vertically, which is the same) with
//     the sensor *width* (36 mm by default);
//   * HORIZONTAL: the width, with the sensor width;
//   * VERTICAL: the height, with the sensor *height* (24 mm by default).
// The field of view along the fitted dimension is 2 atan(sensor / (2 focal)); pixels are
// square (pixel aspect 1, no lens shift). A raster point (x, y), x ∈ [0, W] from the left,
// y ∈ [0, H] from the top, looks along the local direction
//     (x − W/2, H/2 − y, −F) / |…|,   F = N · focal / sensor,   N = the fitted dimension,
// i.e. with the focal length expressed in pixels. Pixel (i, j) is sampled at its centre
// (i + ½, j + ½) — what Cycles renders with the pixel filter width at its minimum.
//
// Equirectangular panorama (Cycles kernel/camera/projection.h, equirectangular_range_to_
// direction, and blender_camera_matrix): with the default ranges (latitude −90…90°,
// longitude −180…180°) the image is the Environment Texture mapping of sky.hpp in a frame
// whose +X is the camera's view direction (local −Z), +Y its left (local −X) and +Z its
// up (local +Y). A camera looking along +X with up +Z therefore renders exactly the sky
// texture image. Other ranges map (u, v) linearly onto them, as Cycles does.
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

#include <glm/vec3.hpp>

#include "airmass/scene.hpp"

namespace airmass {

// Every problem with camera settings: the message names the field, value and allowed range.
struct CameraError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

enum class SensorFit { automatic, horizontal, vertical };
enum class Projection { perspective, equirectangular };

std::string_view sensor_fit_name(SensorFit f);      // "AUTO", "HORIZONTAL", "VERTICAL" (Blender's enum)
std::string_view projection_name(Projection p);     // "perspective", "equirectangular"

inline constexpr double kBlenderSensorWidthMm = 36.0;   // Blender's default camera
inline constexpr double kBlenderSensorHeightMm = 24.0;

// Where the camera is and how it is turned: position in the scene frame (metres) and the
// scene-frame directions of the camera's local axes (orthonormal, right-handed:
// right × up = back). The view direction is −back.
struct CameraPose {
    glm::dvec3 position_m{0.0, 0.0, 2.0};
    glm::dvec3 right{0.0, -1.0, 0.0};
    glm::dvec3 up{0.0, 0.0, 1.0};
    glm::dvec3 back{-1.0, 0.0, 0.0};

    glm::dvec3 forward() const { return -back; }
};

// The pose looking along `direction` with `up` projected to be perpendicular to it (both
// need not be unit). Throws CameraError when either is zero or not finite, or when they are
// parallel (no roll is defined).
CameraPose look_at(const glm::dvec3& position_m, const glm::dvec3& direction, const glm::dvec3& up);

struct CameraModel {
    Projection projection = Projection::perspective;
    int width = 640, height = 360;
    // Perspective.
    double focal_length_mm = 50.0;
    double sensor_width_mm = kBlenderSensorWidthMm;
    double sensor_height_mm = kBlenderSensorHeightMm;
    SensorFit sensor_fit = SensorFit::automatic;
    // Equirectangular (Cycles' defaults cover the whole sphere).
    double latitude_min_deg = -90.0, latitude_max_deg = 90.0;
    double longitude_min_deg = -180.0, longitude_max_deg = 180.0;
    CameraPose pose;
};

// Throws CameraError naming the first bad field.
void validate(const CameraModel& camera);

// Focal length ↔ field of view along a sensor dimension: fov = 2 atan(sensor / (2 f)).
double focal_length_mm_from_fov(double fov_deg, double sensor_mm);
double fov_deg_from_focal_length(double focal_length_mm, double sensor_mm);

// True when the sensor spans the image width (see the header comment).
bool fits_horizontally(const CameraModel& camera);
// The sensor dimension used by the fit (sensor width for AUTO and HORIZONTAL).
double fitted_sensor_mm(const CameraModel& camera);
// Field of view along the width and along the height, degrees (perspective).
double horizontal_fov_deg(const CameraModel& camera);
double vertical_fov_deg(const CameraModel& camera);

// Direction through the raster point (x, y) (x from the left, y from the top, in pixels;
// the image spans [0, W] × [0, H]) in the camera's local frame (looking down −Z) and in
// the scene frame. Unit vectors. Throws nothing; call validate() first.
glm::dvec3 camera_local_direction(const CameraModel& camera, double raster_x, double raster_y);
glm::dvec3 camera_ray_direction(const CameraModel& camera, double raster_x, double raster_y);
// Through the centre of pixel (i, j), j = 0 the top row.
glm::dvec3 camera_pixel_direction(const CameraModel& camera, int i, int j);

// The camera a scene describes ([camera], scene.hpp): its position, direction and up, its
// size, and `fov_deg` as the field of view along the fitted dimension with Blender's
// defaults (sensor fit AUTO, 36 mm sensor width), i.e. Blender's `camera.data.angle`.
// Throws CameraError when the scene has no camera.
CameraModel camera_from_scene(const Scene& scene, Projection projection = Projection::perspective);

// JSON of the camera in Blender's terms (type, lens, sensor, fit, panorama ranges, the
// location and the rotation matrix columns), for the Blender-side scripts. Lengths in
// `metres_per_unit` (1000 for Blender scenes in kilometres).
std::string camera_to_json(const CameraModel& camera, double metres_per_unit);

}  // namespace airmass
