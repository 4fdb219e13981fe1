// `airmass pov`'s scene writer (cmd_pov.cpp), shared with `airmass compare`'s pov_* paths:
// the one code that turns a scene and a camera into a POV-Ray 3.7 scene (docs/povray.md).
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "airmass/camera.hpp"
#include "airmass/progress.hpp"
#include "airmass/scene.hpp"

namespace airmass::cli {

struct PovSceneOptions {
    std::string path = "analytic";  // sky | analytic | df3
    std::optional<int> sky_width, media_intervals, media_samples;
    std::optional<double> voxel_size_km;
    double sky_oversample = 2.0;
    int threads = 0;
    bool progress_bar = false;
    std::string command = "pov";  // names the command in error messages
};

// What was written and how to render it.
struct PovSceneInfo {
    std::vector<std::filesystem::path> written;  // the inputs, then the .pov (last)
    std::vector<int> passes;                     // media paths: the split passes (Declare=Airmass_Pass=K)
    std::vector<std::string> pass_names;         // their constituents
    std::vector<std::string> povray_flags;       // beyond +I +O +FE +W +H -D: the anti-aliasing of the sky path
    int intervals = 0, media_samples = 0;        // media paths
    int sky_width = 0;                           // sky path
    std::optional<std::array<double, 6>> medium_box_km;  // df3: the box (scene frame), `render --box`
    double voxel_size_km = 0.0;                  // df3
};

// Option-level checks (no scene needed); throws CliError naming the option and its range.
void check_pov_options(const PovSceneOptions& o);

// Writes `out` (.pov) and its inputs beside it, each atomically, the .pov last. Every check
// (the df3 box against the 16-bit df3 sizes, the panorama's ranges) comes before any work or
// file: a CliError names the field. Honours `cancel` (Cancelled: nothing written).
PovSceneInfo write_pov_scene(const Scene& scene, const CameraModel& cam, const PovSceneOptions& o,
                             const std::filesystem::path& out, const CancelFlag& cancel);

}  // namespace airmass::cli
