// Helpers of `airmass render` (defined in cmd_render.cpp) that other commands reuse so
// that every command reads a scene's camera the same way: the camera overrides, the
// scene a command line names (default camera, sun overrides) and the resized camera.
#pragma once

#include <array>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "airmass/camera.hpp"
#include "airmass/render.hpp"
#include "airmass/scene.hpp"

namespace airmass::cli::render_detail {

// Camera options shared by `render`, `compare` and `pov` (metres, scene frame; fov along
// the fitted side).
struct CameraOverrides {
    std::string position_km, direction, up;  // position in km, as in the scene file
    std::optional<double> fov_deg, max_distance_km;
};
void add_camera_options(CLI::App* cmd, CameraOverrides& c);
// The scene (a file or --preset, one of them) and the image size (--width, --height) of a
// command that renders the scene's camera.
void add_scene_and_size_options(CLI::App* cmd, std::string& scene_path, std::string& preset, std::optional<int>& width,
                                std::optional<int>& height);
// --sun-elevation / --sun-rotation, the overrides load_render_scene applies.
void add_sun_overrides(CLI::App* cmd, std::optional<double>& elevation_deg, std::optional<double>& rotation_deg);
Scene load_render_scene(const std::string& scene_path, const std::string& preset,
                        const std::optional<double>& sun_elevation_deg, const std::optional<double>& sun_rotation_deg,
                        const char* command, const CameraOverrides& camera);
std::array<double, 3> exporter_rgb_wavelengths(const Scene& scene, const std::string& which);
CameraModel resized_camera(const Scene& scene, Projection projection, const std::optional<int>& width,
                           const std::optional<int>& height, SensorFit fit);

// The box of the scene frame (metres) holding what the camera sees up to its max distance,
// within the atmosphere (the region `compare` exports for the VDB path and `pov` for df3).
MediumBox view_box(const Scene& scene, const CameraModel& cam);

}  // namespace airmass::cli::render_detail
