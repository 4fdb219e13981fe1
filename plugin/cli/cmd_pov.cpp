// `airmass pov`: a complete POV-Ray 3.7 scene of a scene's camera, sun, sky and atmosphere
// (docs/povray.md).
//
//   airmass pov (--preset NAME | SCENE.toml) -o scene.pov [--path sky|analytic|df3
//       --width W --height H --sky-width N --voxel-size KM --media-intervals N
//       --media-samples N --sun-elevation DEG --sun-rotation DEG
//       --camera-position-km X,Y,Z --camera-direction X,Y,Z --camera-up X,Y,Z --fov DEG
//       --threads N --quiet]
//
// Paths (the names `airmass compare` gives them, pov_<path>):
//   sky       the sky texture (`airmass sky`'s render_sky, the camera's altitude) as a
//             sky_sphere; no media, no ground object (the texture holds the ground);
//   analytic  the atmosphere as media with function-pattern densities (the include of
//             `airmass vdb --pov`), the planet as a Lambertian sphere, black space;
//   df3       the same media with the densities of `airmass vdb --df3` density files
//             (the camera's view region).
// Every path has the sun as a parallel light (sun_light_at_observer: the transmitted
// irradiance for the sky path, the top-of-atmosphere irradiance for the media paths,
// which POV-Ray attenuates itself).
//
// Frame: 1 POV unit = 1 km, POV <x, y, z> = airmass (x, z, y) (y up; swapping two axes
// turns the right-handed Z-up scene frame into POV-Ray's left-handed one without
// mirroring), the camera where the scene puts it (near the origin), the planet centre at
// <0, −R, 0>. Files: STEM.pov and beside it STEM.sky.exr, STEM.atmosphere.inc or
// STEM.<constituent>.df3 + STEM.df3.inc, each written atomically, the .pov last; every
// option is checked before anything is written.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>

#include <glm/geometric.hpp>

#include "airmass/image_io.hpp"
#include "airmass/progress.hpp"
#include "airmass/render.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/sky.hpp"
#include "airmass/sun_light.hpp"
#include "airmass/terminal.hpp"
#include "airmass/version.hpp"
#include "airmass/vdb_export.hpp"
#include "commands.hpp"
#include "vdb_module.hpp"
#include "pov_scene.hpp"
#include "render_options.hpp"

namespace airmass::cli {

namespace {

namespace fs = std::filesystem;

struct PovCommandOptions {
    std::string scene_path, preset, output;
    std::optional<int> width, height;
    std::optional<double> sun_elevation_deg, sun_rotation_deg;
    bool panoramic = false;
    bool quiet = false;
    PovSceneOptions scene;
    render_detail::CameraOverrides camera;
};

std::string num(double x) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.9g", x);
    return buf;
}

// A scene-frame vector in POV-Ray's frame: POV <x, y, z> = airmass (x, z, y).
std::string pov_vec(const glm::dvec3& v, double scale = 1.0) {
    return "<" + num(v.x * scale) + ", " + num(v.z * scale) + ", " + num(v.y * scale) + ">";
}

std::string pov_rgb(const glm::dvec3& c) { return "rgb <" + num(c.x) + ", " + num(c.y) + ", " + num(c.z) + ">"; }

// POV-Ray's media sampling for this scene (docs/povray.md, "Media sampling"): method 3
// puts (samples + 1) / 2 evenly spaced sub-intervals in each of `intervals` equal
// intervals of a ray's path through the container, refining adaptively (aa_level 3)
// where neighbouring samples differ. Every sample also traces a shadow ray through the
// media with the same sampling, so the cost grows with intervals². The rule: intervals of
// kLayersPerInterval thinnest layers (the scale height of Mie on Earth) along the longest
// path the camera can see through the atmosphere, within [kMinIntervals, kMaxIntervals].
constexpr double kLayersPerInterval = 18.0;
constexpr int kMinIntervals = 32, kMaxIntervals = 400, kDefaultSamples = 3;
// --sky-width: even, and the sky texture (width x width/2) within validate(SkySettings)'s 1e9 pixels.
constexpr int kPovMaxSkyWidth = 44720;

// The sky path's anti-aliasing: every pixel the mean of a regular 9 x 9 grid of rays (method 1,
// depth 9, POV-Ray's largest; no jitter), the pixel mean the native box filter computes. The
// horizon is a step inside its pixel row that a regular grid of n x n rays integrates only to
// within 1/(2n) of the step, wherever it falls; 9 x 9 makes that bound the smallest POV-Ray
// allows. Measured on the ground-noon camera (worst pixel of the horizon row against
// native_physical_box): 16 x 9 — 4.6 % (3 x 3), 3.6 % (4 x 4), 2.3 % (9 x 9); 64 x 36 — 3.9 % to
// 5.2 % for every depth from 3 to 9 (there the step falls near a grid line whatever n).
constexpr const char* kSkyAntialias = "+A0.0 +AM1 +R9 -J";

struct MediaSampling {
    int intervals = kMinIntervals, samples = kDefaultSamples;
    double chord_km = 0, layer_km = 0;
    bool automatic_intervals = true, automatic_samples = true;
};

MediaSampling choose_media_sampling(const Scene& scene, double camera_altitude_m, std::optional<double> chord_m,
                                    const PovSceneOptions& o) {
    MediaSampling s;
    const double R = scene.planet.radius_m, top = scene.planet.atmosphere_top_m;
    const double thickness = top - R;
    double layer = thickness;
    for (const auto& c : scene.constituents) layer = std::min(layer, profile_feature_m(c.profile, thickness));
    // The grazing view: from the camera to the tangent point of the ground, then out to the top.
    const double rc = R + std::clamp(camera_altitude_m, 0.0, thickness);
    const double chord =
        chord_m ? *chord_m : std::sqrt(std::max(0.0, rc * rc - R * R)) + std::sqrt(std::max(0.0, top * top - R * R));
    s.chord_km = chord / 1e3;
    s.layer_km = layer / 1e3;
    s.intervals = std::clamp(int(std::ceil(chord / (kLayersPerInterval * layer))), kMinIntervals, kMaxIntervals);
    if (o.media_intervals) s.intervals = *o.media_intervals, s.automatic_intervals = false;
    if (o.media_samples) s.samples = *o.media_samples, s.automatic_samples = false;
    return s;
}

void check_range(const std::string& command, const char* option, const std::optional<int>& v, int lo, int hi) {
    if (v && (*v < lo || *v > hi))
        throw CliError(command + ": " + option + " " + std::to_string(*v) + ": must be in [" +
                       std::to_string(lo) + ", " + std::to_string(hi) + "]");
}

}  // namespace

void check_pov_options(const PovSceneOptions& opt) {
    const std::string& c = opt.command;
    if (opt.path != "sky" && opt.path != "analytic" && opt.path != "df3")
        throw CliError(c + ": --path " + opt.path + ": must be sky, analytic or df3");
    check_range(c, "--sky-width", opt.sky_width, 64, kPovMaxSkyWidth);
    if (opt.sky_width && *opt.sky_width % 2)
        throw CliError(c + ": --sky-width " + std::to_string(*opt.sky_width) + ": must be even, in [64, " +
                       std::to_string(kPovMaxSkyWidth) + "]");
    check_range(c, "--media-intervals", opt.media_intervals, 1, 100000);
    check_range(c, "--media-samples", opt.media_samples, 1, 100000);
    if (opt.threads < 0 || opt.threads > 4096)
        throw CliError(c + ": --threads " + std::to_string(opt.threads) + ": must be in [0, 4096]");
    if (opt.voxel_size_km && !(*opt.voxel_size_km > 0.0 && *opt.voxel_size_km <= 1e6))
        throw CliError(c + ": --voxel-size: must be in (0, 1e6] km");
    if (opt.voxel_size_km && opt.path != "df3") throw CliError(c + ": --voxel-size applies to --path df3 only");
    if (opt.sky_width && opt.path != "sky") throw CliError(c + ": --sky-width applies to --path sky only");
}

PovSceneInfo write_pov_scene(const Scene& scene, const CameraModel& cam, const PovSceneOptions& options,
                             const fs::path& out, const CancelFlag& cancel) {
    using namespace render_detail;
    const PovSceneOptions* o = &options;
    check_pov_options(options);
    if (out.extension() != ".pov")
        throw CliError(o->command + ": " + out.string() + ": the scene file must end in .pov");
    const bool panoramic = cam.projection == Projection::equirectangular;
    if (panoramic) {
        // POV-Ray's spherical camera spans `angle H V` centred on its direction: the panorama's
        // ranges must be centred too (Cycles' defaults, the whole sphere, are).
        if (std::abs(cam.longitude_min_deg + cam.longitude_max_deg) > 1e-9)
            throw CliError(o->command + ": camera longitude range [" + num(cam.longitude_min_deg) + ", " +
                           num(cam.longitude_max_deg) + "] deg: POV-Ray's spherical camera needs it centred (min = -max)");
        if (std::abs(cam.latitude_min_deg + cam.latitude_max_deg) > 1e-9)
            throw CliError(o->command + ": camera latitude range [" + num(cam.latitude_min_deg) + ", " +
                           num(cam.latitude_max_deg) + "] deg: POV-Ray's spherical camera needs it centred (min = -max)");
    }
    PovSceneInfo info;
    const fs::path dir = out.has_parent_path() ? out.parent_path() : fs::path(".");
    const std::string stem = out.stem().string();
    check_exr_destination(dir / (stem + ".sky.exr"));  // the folder exists and takes files

    VdbOptions vo;
    vo.unit = LengthUnit::km;
    vo.origin = PlanetOrigin::surface;
    // The df3 files: the box of what the camera sees up to its max distance (as `airmass
    // compare` exports for its VDB path), and the media container is that box, so POV-Ray's
    // intervals fall where the density is.
    const MediumBox mbox = view_box(scene, cam);
    VdbOptions dv = vo;
    dv.region = VdbRegion::box;
    dv.box = {mbox.min_m.x * 1e-3, mbox.min_m.y * 1e-3, mbox.min_m.z * 1e-3,
              mbox.max_m.x * 1e-3, mbox.max_m.y * 1e-3, mbox.max_m.z * 1e-3};
    dv.voxel_size = o->voxel_size_km;
    if (o->path == "df3") {
        // df3 sizes are 16-bit: refuse a region the files cannot hold before any work.
        VdbLayout l;
        try {
            l = resolve_vdb_layout(scene, dv);
        } catch (const VdbError& e) {
            throw CliError(o->command + " --path df3: " + e.what());
        }
        for (int a = 0; a < 3; ++a) {
            const std::int64_t n = l.index_bounds.dim(a) + 2;  // + the zero border
            if (n > 65535)
                throw CliError(o->command + ": --voxel-size " + num(l.voxel_size) + " km: the camera's box is " +
                               std::to_string(n) + " voxels along " + "xyz"[a] +
                               "; a df3 file holds at most 65535 per axis: use --voxel-size >= " +
                               num(l.voxel_size * double(n) / 65535.0 * 1.001) + " km");
        }
    }
    const double R = scene.planet.radius_m;
    const ObserverFrame frame = observer_frame(R, cam.pose.position_m);
    Scene local = scene;  // the observer where the camera is (sky texture, sun light)
    local.observer.altitude_m = frame.altitude_m;
    const SunLight sun = sun_light_at_observer(local);
    const bool sky_path = o->path == "sky";
    const double box_diagonal_m = glm::length(mbox.max_m - mbox.min_m);
    const MediaSampling sampling =
        choose_media_sampling(scene, frame.altitude_m, o->path == "df3" ? std::optional(box_diagonal_m) : std::nullopt, *o);

    const bool bar_on = o->progress_bar;

    // ---- the inputs ---------------------------------------------------------------------
    // The angle of a pixel at the image centre (where a perspective pixel subtends the most;
    // a panorama's pixels are equal in longitude): 1 / focal length in pixels.
    const double lon_span_deg = cam.longitude_max_deg - cam.longitude_min_deg;
    const double lat_span_deg = cam.latitude_max_deg - cam.latitude_min_deg;
    const double f_px = panoramic ? cam.width / (lon_span_deg * std::numbers::pi / 180.0)
                                  : 0.5 * cam.width / std::tan(0.5 * horizontal_fov_deg(cam) * std::numbers::pi / 180.0);
    std::optional<FloatImage> sky;
    SkySettings ss;
    if (sky_path) {
        // Texels no larger than 1/oversample of the camera's pixels at the image centre
        // (where a perspective pixel subtends the most), as `airmass compare` sizes them.
        int w = o->sky_width ? *o->sky_width
                             : int(std::ceil(o->sky_oversample * 2.0 * std::numbers::pi * f_px / 4.0)) * 4;
        w = std::clamp(w, 64, 16384);
        ss.width = w;
        ss.height = w / 2;
        ss.view.sun_disc = false;  // a disc a fraction of a pixel wide; the light carries the sun
        ss.threads = o->threads;
        validate(ss);
        ProgressBar bar("sky texture " + std::to_string(w) + "x" + std::to_string(w / 2), 0, bar_on);
        const RenderHooks hooks = progress_hooks(bar, cancel);
        sky = render_sky(local, ss, hooks);
        if (cancel.requested()) throw Cancelled(o->command + ": cancelled; no file written");
    }
    std::string include;
    if (!sky_path) include = pov_include(scene, vo);
    std::vector<fs::path> written;
    std::vector<std::string> constituents;
    std::vector<bool> scatterer;
    if (!sky_path)
        for (const auto& c : resolve_vdb_layout(scene, vo).constituents) {
            constituents.push_back(c.name);
            scatterer.push_back(c.scattering_rgb[0] > 0 || c.scattering_rgb[1] > 0 || c.scattering_rgb[2] > 0);
        }
    if (o->path == "df3") {
        VdbRunOptions run;
        run.cancel = &cancel;
        run.threads = o->threads;
        try {
            written = vdb_module().export_df3(scene, dv, dir / stem, run);
        } catch (const VdbError& e) {
            throw CliError(o->command + " --path df3: " + e.what());
        }
    }

    // ---- the scene ----------------------------------------------------------------------
    std::ostringstream p;
    const CameraPose& pose = cam.pose;
    const double km = 1e-3;
    p << "// Generated by airmass " << version_string() << " (`airmass pov --path " << o->path << "`): scene '"
      << scene.name << "'.\n"
      << "// Render from this folder:  povray +I" << out.filename().string() << " +O" << stem
      << ".exr +FE +W" << cam.width << " +H" << cam.height << " -D -V"
      << (sky_path ? " " + std::string(kSkyAntialias) : std::string()) << "\n"
      << "// (+FE writes a half-float OpenEXR, linear; "
      << (sky_path ? std::string(kSkyAntialias) + ": every pixel the mean of a 9x9 grid of rays, as a box filter"
                   : std::string("no anti-aliasing: one ray through each pixel centre"))
      << ").\n"
      << "// Units: 1 POV unit = 1 km. Frame: POV <x, y, z> = airmass scene (x, z, y): y up, the origin on the\n"
      << "// ground below the scene's origin, the planet centre at <0, " << num(-R * km) << ", 0>. Colours: linear Rec.709\n"
      << "// in the sky texture's units (Sum L CMF dlambda, no 683 lm/W; docs/sky.md).\n"
      << "#version 3.7;\n"
      << "global_settings { assumed_gamma 1.0 ambient_light rgb 0 max_trace_level 10 adc_bailout 0 }\n\n";
    // Camera: Blender's (camera.hpp) mapped to POV-Ray. POV-Ray traces pixel (i, j) (j from the
    // top) along direction + ((i + 0.5)/W - 0.5) right + (0.5 - (j + 0.5)/H) up (measured), so
    // right = camera right * W / F and up = camera up * H / F with F the focal length in pixels.
    if (panoramic) {
        // Blender's equirectangular panorama (camera.hpp: longitude across the image, 0 at the
        // view direction, increasing to the camera's left; latitude up, 0 at the view's
        // horizon) is POV-Ray's spherical camera spanning the same angles around `direction`,
        // with `up` and `right` the camera's (measured: tests/python/test_pov.py).
        p << "// Camera: Blender's equirectangular panorama (docs/compare.md) — " << cam.width << "x" << cam.height
          << " pixels, longitude " << num(cam.longitude_min_deg) << ".." << num(cam.longitude_max_deg)
          << " deg, latitude " << num(cam.latitude_min_deg) << ".." << num(cam.latitude_max_deg) << " deg,\n// at "
          << num(pose.position_m.x) << ", " << num(pose.position_m.y) << ", " << num(pose.position_m.z)
          << " m (scene frame), altitude " << num(frame.altitude_m) << " m.\n"
          << "camera {\n  spherical\n  angle " << num(lon_span_deg) << " " << num(lat_span_deg) << "\n  location "
          << pov_vec(pose.position_m, km) << "\n  direction " << pov_vec(pose.forward()) << "\n  right "
          << pov_vec(pose.right) << "\n  up " << pov_vec(pose.up) << "\n}\n\n";
    } else {
        p << "// Camera: Blender's (docs/compare.md) — " << cam.width << "x" << cam.height << " pixels, "
          << num(horizontal_fov_deg(cam)) << " deg horizontal field of view, focal length " << num(f_px)
          << " pixels,\n// at " << num(pose.position_m.x) << ", " << num(pose.position_m.y) << ", "
          << num(pose.position_m.z) << " m (scene frame), altitude " << num(frame.altitude_m) << " m.\n"
          << "camera {\n  perspective\n  location " << pov_vec(pose.position_m, km) << "\n  direction "
          << pov_vec(pose.forward()) << "\n  right " << pov_vec(pose.right, cam.width / f_px) << "\n  up "
          << pov_vec(pose.up, cam.height / f_px) << "\n}\n\n";
    }
    // Sun.
    const glm::dvec3 e = sky_path ? sun.irradiance_rgb : sun.irradiance_top_rgb;
    p << "// Sun: elevation " << num(scene.sun.elevation_deg) << " deg, rotation " << num(scene.sun.azimuth_deg)
      << " deg (Blender's Sky Texture angles), direction " << pov_vec(sun.direction) << " (POV frame).\n";
    if (sky_path)
        p << "// Colour = the direct sun at the camera, E(lambda) T(lambda) through the atmosphere (sun_light_at_observer):\n"
          << "// what lights objects you add to this scene" << (sun.below_horizon ? " (0: the sun is below the horizon)" : "")
          << ". A Lambertian surface of albedo a takes\n// pigment a and finish { diffuse 1/pi }.\n";
    else
        p << "// Colour = the sun's irradiance at the top of the atmosphere (sun_light_at_observer); POV-Ray attenuates it\n"
          << "// through the media itself (media_attenuation on), and the planet casts the shadow.\n";
    p << "light_source { " << pov_vec(sun.direction, 1e7) << " color " << pov_rgb(e)
      << " parallel point_at <0, 0, 0> media_interaction on media_attenuation on }\n\n";

    if (sky_path) {
        const std::string sky_file = stem + ".sky.exr";
        p << "// Sky: " << sky_file << ", `airmass sky` of this scene at the camera's altitude (" << ss.width << "x"
          << ss.height << ", equirectangular in Blender's convention, multiple scattering included, no sun disc).\n"
          << "// POV-Ray's spherical map (map_type 1) reads direction <x, y, z> at u = atan2(z, x) / 2 pi from the\n"
          << "// image's left edge, the top row at +y (measured); Blender's at u = 1/2 - atan2(y, x) / 2 pi (scene\n"
          << "// frame). scale <-1, 1, 1> turns one into the other, so every direction picks its own texel.\n"
          << "sky_sphere {\n  pigment {\n    image_map { exr \"" << sky_file
          << "\" map_type 1 interpolate 2 }\n    scale <-1, 1, 1>\n  }\n}\n";
    } else {
        p << "// Media sampling: method 3 (adaptive), intervals " << sampling.intervals << ", samples "
          << sampling.samples << ".\n";
        if (sampling.automatic_intervals)
            p << "// Chosen from the scene's scale: the longest path through the media container ("
              << (o->path == "df3" ? "the box's diagonal" : "the grazing view through the atmosphere") << ")\n"
              << "// is " << num(sampling.chord_km) << " km and the thinnest layer (scale height / tent flank / knot\n"
              << "// spacing) " << num(sampling.layer_km) << " km; an interval spans " << num(kLayersPerInterval)
              << " layers along that path (within [" << kMinIntervals << ", " << kMaxIntervals
              << "]). Each sample traces a shadow ray\n// through the media with the same sampling: the cost grows "
                 "with intervals^2 (--media-intervals to trade).\n";
        else
            p << "// Given on the command line (--media-intervals / --media-samples).\n";
        p << "// POV-Ray averages the phase functions of all media on a ray (media.cpp,\n"
          << "// ComputeMediaScatteringAttenuation: k /= medias.size()), so one render of several constituents\n"
          << "// gives every scatterer the mean phase. Exact: render each scatterer as a split pass and sum the\n"
          << "// images, povray ... Declare=Airmass_Pass=K with K in:";
        for (std::size_t i = 0; i < constituents.size(); ++i)
            if (scatterer[i]) p << " " << i + 1 << " (" << constituents[i] << ")";
        p << ".\n";
        p << "// (povray ... Declare=Airmass_MediaIntervals=N overrides them: `airmass compare` renders 2N to measure\n"
          << "// the sampling error.)\n"
          << "#ifndef (Airmass_MediaIntervals) #declare Airmass_MediaIntervals = " << sampling.intervals << "; #end\n"
          << "#ifndef (Airmass_MediaSamples) #declare Airmass_MediaSamples = " << sampling.samples << "; #end\n"
          << "#include \"" << stem << ".atmosphere.inc\"\n";
        if (o->path == "df3") p << "#include \"" << stem << ".df3.inc\"\n";
        p << "background { rgb 0 }\n\n"
          << "// Ground: the planet, Lambertian of albedo " << num(scene.planet.ground_albedo)
          << " (diffuse 1/pi: POV-Ray's diffuse term has no 1/pi).\n"
          << "// Split passes (Declare=Airmass_Pass=k, docs/povray.md): the ground is lit in pass 0 and the first.\n"
          << "sphere { Airmass_PlanetCenter, Airmass_PlanetRadius\n  pigment { rgb " << num(scene.planet.ground_albedo)
          << " * ((Airmass_Pass = 0 | Airmass_Pass = Airmass_FirstPass) ? 1 : 0) }\n  finish { ambient 0 emission 0 diffuse " << num(1.0 / std::numbers::pi)
          << " specular 0 phong 0 }\n}\n\n";
        if (o->path == "analytic") {
            p << "// Atmosphere: one media per constituent, densities as function patterns (" << stem
              << ".atmosphere.inc).\nobject { Airmass_Container }\n";
        } else {
            p << "// Atmosphere: one media per constituent, densities from the df3 files (trilinear, " << stem
              << ".df3.inc places them).\n";
            for (const auto& c : constituents)
                p << "#declare Airmass_" << c << "_Df3Density = density { density_file df3 Airmass_" << c
                  << "_Df3File interpolate 1 transform { Airmass_Df3_Transform } }\n";
            p << "// airmass:medium_box_km = " << num(dv.box[0]) << "," << num(dv.box[1]) << "," << num(dv.box[2]) << ","
              << num(dv.box[3]) << "," << num(dv.box[4]) << "," << num(dv.box[5])
              << " (scene frame; `airmass render --box` of the same medium)\n"
              << "box { <0, 0, 0>, <1, 1, 1> transform { Airmass_Df3_Transform }\n  hollow pigment { rgbt 1 }\n  interior {";
            for (const auto& c : constituents)
                p << "\n    Airmass_" << c << "_MediaOf(Airmass_" << c << "_Df3Max, Airmass_" << c << "_Df3Density)";
            p << "\n  }\n}\n";
        }
    }

    // ---- write: the inputs, then the scene -------------------------------------------------
    if (cancel.requested()) throw Cancelled(o->command + ": cancelled; no file written");
    if (sky) {
        write_exr_atomic(dir / (stem + ".sky.exr"), *sky, sky_metadata(local, ss));
        written.push_back(dir / (stem + ".sky.exr"));
    }
    if (!include.empty()) {
        write_text_atomic(dir / (stem + ".atmosphere.inc"), include);
        written.push_back(dir / (stem + ".atmosphere.inc"));
    }
    write_text_atomic(out, p.str());
    written.push_back(out);
    info.written = written;
    if (sky_path) {
        info.sky_width = ss.width;
        std::istringstream flags(kSkyAntialias);
        for (std::string f; flags >> f;) info.povray_flags.push_back(f);
    } else {
        info.intervals = sampling.intervals;
        info.media_samples = sampling.samples;
        for (std::size_t i = 0; i < constituents.size(); ++i)
            if (scatterer[i]) {
                info.passes.push_back(int(i) + 1);
                info.pass_names.push_back(constituents[i]);
            }
    }
    if (o->path == "df3") {
        info.medium_box_km = std::array<double, 6>{dv.box[0], dv.box[1], dv.box[2], dv.box[3], dv.box[4], dv.box[5]};
        info.voxel_size_km = resolve_vdb_layout(scene, dv).voxel_size;
    }
    return info;
}

void add_pov_command(CLI::App& app) {
    using namespace render_detail;
    auto* cmd = app.add_subcommand("pov", "Write a POV-Ray 3.7 scene of a scene's camera, sun, sky and atmosphere");
    auto o = std::make_shared<PovCommandOptions>();
    add_scene_and_size_options(cmd, o->scene_path, o->preset, o->width, o->height);
    cmd->add_option("-o,--output", o->output, "Output .pov (its inputs are written beside it)");
    cmd->add_option("--path", o->scene.path,
                    "sky (sky texture as sky_sphere), analytic (media, function densities) or df3 (media, density files)")
        ->check(CLI::IsMember({"sky", "analytic", "df3"}))
        ->capture_default_str();
    cmd->add_flag("--panoramic", o->panoramic,
                  "Blender's equirectangular panorama (whole sphere) as POV-Ray's spherical camera [default: perspective]");
    cmd->add_option("--sky-width", o->scene.sky_width,
                    "sky path: texture width, even [default: texels at most 1/2 of a camera pixel at the image centre]")
        ->check(int_in(64, kPovMaxSkyWidth));
    cmd->add_option("--voxel-size", o->scene.voxel_size_km, "df3 path: voxel edge, km [default: automatic, docs/vdb.md]")
        ->check(number_in(0.0, 1e6, Ends::open_low));
    cmd->add_option("--media-intervals", o->scene.media_intervals, "Media intervals [default: from the scene's scale]")
        ->check(int_in(1, 100000));
    cmd->add_option("--media-samples", o->scene.media_samples, "Media samples (method 3) [default: 3]")
        ->check(int_in(1, 100000));
    add_sun_overrides(cmd, o->sun_elevation_deg, o->sun_rotation_deg);
    cmd->add_option("--threads", o->scene.threads, "Worker threads (0: all)")->check(int_in(0, 4096))->capture_default_str();
    cmd->add_flag("-q,--quiet", o->quiet, "No progress bar or summary");
    add_camera_options(cmd, o->camera);

    cmd->callback([o] {
        // ---- every check before any work or file -------------------------------------------
        if (o->output.empty()) throw CliError("pov: -o/--output is required");
        const fs::path out = o->output;
        if (out.extension() != ".pov") throw CliError("pov: -o " + o->output + ": the scene file must end in .pov");
        check_range("pov", "--width", o->width, 1, 65536);
        check_range("pov", "--height", o->height, 1, 65536);
        check_pov_options(o->scene);
        const Scene scene =
            load_render_scene(o->scene_path, o->preset, o->sun_elevation_deg, o->sun_rotation_deg, "pov", o->camera);
        const CameraModel cam = resized_camera(scene, o->panoramic ? Projection::equirectangular : Projection::perspective,
                                               o->width, o->height, SensorFit::automatic);
        CancelFlag cancel;
        InterruptGuard guard(cancel);
        PovSceneOptions so = o->scene;
        so.progress_bar = stderr_is_terminal() && !o->quiet;
        const PovSceneInfo info = write_pov_scene(scene, cam, so, out, cancel);
        if (!o->quiet)
            for (const auto& f : info.written) std::printf("pov: wrote %s\n", f.string().c_str());
    });
}

}  // namespace airmass::cli
