// libFuzzer target: the C ABI (plugin/capi/include/airmass/airmass_c.h), as a host calls it.
// The input fills airmass_scene_spec (preset or TOML text, every numeric override, constituent
// overrides, camera), airmass_sky_options, airmass_vdb_options and the call's sizes in one of two
// ways, chosen by its first byte (odd: wild):
//   * tame: every field within its documented range (drawn from the input; an exhausted input
//     gives the earth preset, RGB, a 4x2 sky) except, one input in eight, a single field set to
//     a raw or special value — so most inputs reach the evaluators (sky, session, sun light,
//     solar position, volume plan and values) and the rest probe one refusal at a time;
//   * wild: each field raw, special or typical (most such inputs are refused by validation).
// Either way the scene costs little: at most 16x8 pixels and 8 view samples, three wavelengths
// (RGB) unless one input in eight asks for the preset's spectrum (then at most 8x4 pixels), single
// scattering, a dense limit of at most 0.5 MB. Then it calls airmass_validate_scene,
// airmass_sun_light_at_observer, airmass_solar_position, airmass_render_sky and the same sky
// through airmass_sky_session_create/render (C ABI 6), airmass_analytic_density_json,
// airmass_sun_column_table and airmass_sun_ms_table (C ABI 7), airmass_vdb_plan and airmass_vdb_grid_values (a block of at most 8x8x8 voxels).
// Oracle: every call returns a known airmass_status; a failure carries a non-empty message;
// success gives finite, non-negative pixels / irradiances / values and a sun position in range;
// a NUL-terminated message buffer is never overrun (ASan).
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "airmass/airmass_c.h"
#include "fuzz_common.hpp"
#include "fuzz_values.hpp"

namespace {

using airmass::fuzz::pick_double;
using airmass::fuzz::require;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Most numeric spec fields keep the scene's value (NaN) unless the input says otherwise.
double maybe(FuzzedDataProvider& in, double typical) { return in.ConsumeBool() ? pick_double(in, typical) : kNaN; }

void check_status(int32_t status, const char* message, size_t message_size) {
    if (status == AIRMASS_INTERNAL_ERROR) std::fprintf(stderr, "internal error: %s\n", message);
    require(status == AIRMASS_OK || status == AIRMASS_INVALID_ARGUMENT || status == AIRMASS_SCENE_ERROR ||
                status == AIRMASS_SETTINGS_ERROR || status == AIRMASS_UNSUPPORTED,
            "unexpected airmass_status (internal error, I/O or cancel with no cause)");
    // A failure carries a message, truncated to the buffer (a 1-byte buffer holds only the NUL).
    if (status != AIRMASS_OK && message_size >= 2) require(message[0] != '\0', "failure without a message");
    if (message_size) require(std::memchr(message, '\0', message_size) != nullptr, "message not NUL-terminated");
}

// Everything a host passes in (the strings and overrides the structs point to live here).
struct Call {
    airmass_scene_spec spec;
    std::string toml;
    std::vector<airmass_constituent_override> overrides;
    airmass_sky_options sky;
    airmass_vdb_options vdb;
    airmass_solar_query solar;
    std::string utc;
};

constexpr const char* kPresets[] = {"earth", "earth-hazy", "mars", "atmosphere-plus", "blender-nishita",
                                    "no-such-preset"};
constexpr const char* kChapman[] = {nullptr, "airmass", "exact", "no-such-method", ""};
constexpr const char* kRegions[] = {"planet", "view", "box", "nowhere", nullptr};
constexpr const char* kUnits[] = {"km", "m", "mm", nullptr};
// ABI 8's voxel values (an exhausted input gets "auto", the default).
constexpr const char* kVoxelValues[] = {"auto", "average", "point", "mean", nullptr};

void init(Call& c) {
    c.spec.struct_size = sizeof c.spec;  // C ABI 4+: the host sets it, *_init checks it
    airmass_scene_spec_init(&c.spec);
    c.sky.struct_size = sizeof c.sky;
    airmass_sky_options_init(&c.sky);
    c.vdb.struct_size = sizeof c.vdb;
    airmass_vdb_options_init(&c.vdb);
    c.solar.struct_size = sizeof c.solar;
    airmass_solar_query_init(&c.solar);
}

// Wild: each field raw, special or typical (the harness's first form; mostly refusals).
void fill_wild(FuzzedDataProvider& in, Call& c) {
    static const char* const kNames[] = {"rayleigh", "mie", "ozone", "dust", ""};
    airmass_scene_spec& spec = c.spec;
    const uint8_t source = in.ConsumeIntegral<uint8_t>();
    if (source < 200) spec.preset = kPresets[source % 6];
    if (source >= 150) {  // TOML text (with a preset too: both set is an error to report)
        c.toml = in.ConsumeRandomLengthString(2048);
        spec.toml = c.toml.c_str();
    }
    spec.sun_elevation_deg = maybe(in, 30.0);
    spec.sun_rotation_deg = maybe(in, 0.0);
    spec.altitude_m = maybe(in, 1000.0);
    spec.planet_radius_m = maybe(in, 6360e3);
    spec.atmosphere_top_m = maybe(in, 6420e3);
    spec.ground_albedo = maybe(in, 0.3);
    spec.basis = airmass::fuzz::pick_int(in, -1, 1);
    c.overrides.resize(in.ConsumeIntegralInRange<int>(0, 3));
    for (auto& o : c.overrides) {
        o.name = in.ConsumeIntegral<uint8_t>() == 0 ? nullptr : kNames[in.ConsumeIntegralInRange<int>(0, 4)];
        o.enabled = in.ConsumeIntegral<uint8_t>() < 32 ? 0 : 1;
        o.density_scale = maybe(in, 2.0);
        o.scale_height_m = maybe(in, 8000.0);
    }
    spec.constituent_count = static_cast<uint32_t>(c.overrides.size());
    spec.constituents = c.overrides.empty() ? nullptr : c.overrides.data();
    if (in.ConsumeBool() && spec.constituents && in.ConsumeBool()) spec.constituents = nullptr;  // count > 0, NULL
    spec.has_camera = in.ConsumeIntegralInRange<int32_t>(0, 1);
    for (int k = 0; k < 3; ++k) {
        spec.camera_position_m[k] = pick_double(in, k == 2 ? 2.0 : 0.0);
        spec.camera_direction[k] = pick_double(in, k == 0 ? 1.0 : 0.0);
        spec.camera_up[k] = pick_double(in, k == 2 ? 1.0 : 0.0);
    }
    spec.camera_fov_deg = pick_double(in, 60.0);
    spec.camera_max_distance_m = pick_double(in, 200e3);
    spec.camera_width = airmass::fuzz::pick_int(in, 1, 64);
    spec.camera_height = airmass::fuzz::pick_int(in, 1, 64);
    if (in.ConsumeIntegral<uint8_t>() == 0) spec.struct_size = in.ConsumeIntegral<uint32_t>();  // a stale host

    airmass_sky_options& sky = c.sky;
    sky.width = in.ConsumeIntegral<uint8_t>() < 8 ? in.ConsumeIntegral<int32_t>() : in.ConsumeIntegralInRange<int>(1, 16);
    sky.height = in.ConsumeIntegralInRange<int32_t>(-1, 8);
    sky.view_samples = airmass::fuzz::pick_int(in, 0, 8);
    sky.chapman = kChapman[in.ConsumeIntegralInRange<int>(0, 4)];
    sky.sun_disc = in.ConsumeIntegral<int32_t>();
    sky.upper_only = in.ConsumeBool();
    sky.threads = in.ConsumeIntegralInRange<int32_t>(-1, 2);
    sky.grid = airmass::fuzz::pick_int(in, -1, 8);

    airmass_vdb_options& vdb = c.vdb;
    vdb.region = kRegions[in.ConsumeIntegralInRange<int>(0, 4)];
    vdb.unit = kUnits[in.ConsumeIntegralInRange<int>(0, 3)];
    vdb.origin_center = in.ConsumeIntegralInRange<int32_t>(-1, 2);
    vdb.voxel_size = in.ConsumeBool() ? pick_double(in, 20.0) : kNaN;
    for (int k = 0; k < 6; ++k) vdb.box[k] = pick_double(in, k < 3 ? -10.0 : 10.0);
    vdb.tolerance = maybe(in, 1e-3);
    // A small dense limit keeps the sampling pass short (the auto voxel size follows it).
    vdb.max_dense_mb = in.ConsumeBool() ? in.ConsumeFloatingPointInRange<double>(-1.0, 2.0) : 0.5;
    vdb.tile_voxels = airmass::fuzz::pick_int(in, -1, 64);

    c.solar.latitude_deg = pick_double(in, 45.0);
    c.solar.longitude_deg = pick_double(in, 10.0);
    c.utc = in.ConsumeRandomLengthString(40);
    c.solar.utc = in.ConsumeBool() ? nullptr : c.utc.c_str();
    c.solar.site_elevation_m = pick_double(in, 0.0);
    c.solar.delta_t_s = maybe(in, 69.0);
    c.solar.delta_ut1_s = pick_double(in, 0.0);
}

// A value in [lo, hi] from the input (lo when the input is exhausted).
double in_range(FuzzedDataProvider& in, double lo, double hi) { return in.ConsumeFloatingPointInRange(lo, hi); }
// NaN (keep the scene's value; also when the input is exhausted) or a value in [lo, hi].
double keep_or(FuzzedDataProvider& in, double lo, double hi) { return in.ConsumeBool() ? in_range(in, lo, hi) : kNaN; }

// Tame: every field within its range, so the evaluators run; one input in eight then makes a
// single field raw or special (a single refusal, or an edge value that is accepted).
void fill_tame(FuzzedDataProvider& in, Call& c) {
    // The constituents each preset has (earth, earth-hazy, mars, atmosphere-plus, blender-nishita).
    static const char* const kPresetNames[5][3] = {{"rayleigh", "mie", "ozone"}, {"rayleigh", "mie", "ozone"},
                                                   {"rayleigh", "dust", "dust"},  {"rayleigh", "mie", "mie"},
                                                   {"rayleigh", "mie", "ozone"}};
    airmass_scene_spec& spec = c.spec;
    const uint8_t preset = in.ConsumeIntegral<uint8_t>() % 5;
    spec.preset = kPresets[preset];
    // A TOML scene naming the preset (text goes through the parser, overrides merged).
    if (in.ConsumeIntegral<uint8_t>() >= 224) {
        char text[256];
        std::snprintf(text, sizeof text, "preset = \"%s\"\n[sun]\nelevation_deg = %.17g\n[observer]\naltitude_km = %.17g\n",
                      kPresets[preset], in_range(in, -90.0, 90.0), in_range(in, 0.0, 100.0));
        c.toml = text;
        spec.toml = c.toml.c_str();
        spec.preset = nullptr;
    }
    spec.sun_elevation_deg = keep_or(in, -90.0, 90.0);
    spec.sun_rotation_deg = keep_or(in, -720.0, 720.0);
    spec.altitude_m = in.ConsumeBool() ? (in.ConsumeBool() ? in_range(in, 0.0, 1e9) : in_range(in, 0.0, 1e5)) : kNaN;
    if (in.ConsumeIntegral<uint8_t>() >= 224) {  // another planet size
        spec.planet_radius_m = in_range(in, 1e3, 1e7);
        spec.atmosphere_top_m = spec.planet_radius_m + in_range(in, 1e3, 3e5);
    }
    spec.ground_albedo = keep_or(in, 0.0, 1.0);
    // RGB (three wavelengths) unless one input in eight keeps the preset's spectrum.
    const bool spectral = in.ConsumeIntegral<uint8_t>() >= 224;
    spec.basis = spectral ? -1 : 1;
    c.overrides.resize(in.ConsumeIntegralInRange<int>(0, 3));
    for (auto& o : c.overrides) {
        o.name = kPresetNames[preset][in.ConsumeIntegralInRange<int>(0, 2)];
        o.enabled = in.ConsumeIntegral<uint8_t>() < 32 ? 0 : 1;
        o.density_scale = keep_or(in, 0.0, 10.0);
        o.scale_height_m = keep_or(in, 100.0, 1e5);
    }
    spec.constituent_count = static_cast<uint32_t>(c.overrides.size());
    spec.constituents = c.overrides.empty() ? nullptr : c.overrides.data();
    // A camera looking out from near the ground (the VDB `view` region).
    spec.has_camera = in.ConsumeBool() ? 0 : 1;
    const double az = in_range(in, 0.0, 2 * std::numbers::pi), el = in_range(in, -0.5, 1.5);
    const double dir[3] = {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
    for (int k = 0; k < 3; ++k) {
        spec.camera_position_m[k] = k == 2 ? in_range(in, 1.0, 1e4) : in_range(in, -1e3, 1e3);
        spec.camera_direction[k] = dir[k];
    }
    // Up: perpendicular to the direction (the world's z made orthogonal to it).
    const double up[3] = {-dir[2] * dir[0], -dir[2] * dir[1], 1.0 - dir[2] * dir[2]};
    for (int k = 0; k < 3; ++k) spec.camera_up[k] = up[k];
    spec.camera_fov_deg = in_range(in, 10.0, 120.0);
    spec.camera_max_distance_m = in_range(in, 1e3, 3e5);
    spec.camera_width = in.ConsumeIntegralInRange<int32_t>(16, 64);
    spec.camera_height = in.ConsumeIntegralInRange<int32_t>(8, 64);

    airmass_sky_options& sky = c.sky;
    const int max_w = spectral ? 8 : 16;
    sky.width = 8 + 2 * in.ConsumeIntegralInRange<int>(-2, (max_w - 8) / 2);  // even, 4 … max_w
    sky.height = in.ConsumeBool() ? in.ConsumeIntegralInRange<int>(2, max_w / 2) : 0;
    sky.view_samples = in.ConsumeIntegralInRange<int>(1, 8);
    sky.chapman = kChapman[in.ConsumeIntegralInRange<int>(0, 2)];
    sky.sun_disc = in.ConsumeBool() ? 0 : 1;
    sky.upper_only = in.ConsumeBool();
    sky.threads = 1;
    static const int32_t kGrids[] = {-1, 0, 4, 8};
    sky.grid = kGrids[in.ConsumeIntegralInRange<int>(0, 3)];

    airmass_vdb_options& vdb = c.vdb;
    vdb.region = kRegions[in.ConsumeIntegralInRange<int>(0, 2)];
    vdb.unit = kUnits[in.ConsumeIntegralInRange<int>(0, 1)];
    vdb.origin_center = in.ConsumeBool();
    const double unit_m = vdb.unit[0] == 'k' ? 1000.0 : 1.0;
    double largest = 0.0;
    for (int k = 0; k < 3; ++k) {
        const double half = in_range(in, 100.0, 3e4) / unit_m;
        const double centre = (k == 2 ? in_range(in, 0.0, 2e4) : in_range(in, -1e4, 1e4)) / unit_m;
        vdb.box[k] = centre - half;
        vdb.box[k + 3] = centre + half;
        largest = std::max(largest, 2 * half);
    }
    // An explicit voxel size for a box only, 2 to 32 voxels across its largest side, so at most
    // 32^3 voxels (a planet at a voxel size of kilometres, or 2 voxels across a box's thin side
    // and thousands across its long one, is a legitimate job of minutes, a libFuzzer timeout);
    // else the automatic size, which follows the dense limit.
    vdb.voxel_size = vdb.region[0] == 'b' && in.ConsumeBool() ? largest / in.ConsumeIntegralInRange<int>(2, 32) : kNaN;
    vdb.tolerance = keep_or(in, 1e-6, 0.1);
    vdb.max_dense_mb = in_range(in, 0.05, 0.5);  // small: the sampling pass stays short
    vdb.tile_voxels = in.ConsumeBool() ? 0 : in.ConsumeIntegralInRange<int32_t>(-1, 64);

    c.solar.latitude_deg = in_range(in, -90.0, 90.0);
    c.solar.longitude_deg = in_range(in, -180.0, 180.0);
    char utc[64];
    std::snprintf(utc, sizeof utc, "%04d-%02d-%02dT%02d:%02d:%06.3f%s", in.ConsumeIntegralInRange<int>(0, 6000),
                  in.ConsumeIntegralInRange<int>(1, 12), in.ConsumeIntegralInRange<int>(1, 28),
                  in.ConsumeIntegralInRange<int>(0, 23), in.ConsumeIntegralInRange<int>(0, 59),
                  in_range(in, 0.0, 59.999), in.ConsumeBool() ? "+05:30" : "Z");
    c.utc = utc;
    c.solar.utc = c.utc.c_str();
    c.solar.site_elevation_m = in.ConsumeBool() ? in_range(in, -1e4, 1e7) : 0.0;
    c.solar.delta_t_s = keep_or(in, -1e5, 1e5);
    c.solar.delta_ut1_s = in_range(in, -1.0, 1.0);

    // One input in eight: one field raw or special (a single refusal, or an accepted edge).
    if (in.ConsumeIntegral<uint8_t>() < 224) return;
    double* const doubles[] = {&spec.sun_elevation_deg, &spec.sun_rotation_deg, &spec.altitude_m,
                               &spec.planet_radius_m,   &spec.atmosphere_top_m, &spec.ground_albedo,
                               &spec.camera_fov_deg,    &spec.camera_max_distance_m,
                               vdb.region[0] == 'b' ? &vdb.voxel_size : &vdb.tolerance,  // see above
                               &vdb.tolerance,          &vdb.max_dense_mb,      &vdb.box[0],
                               &vdb.box[5],             &c.solar.latitude_deg,  &c.solar.delta_t_s};
    const size_t which = in.ConsumeIntegralInRange<size_t>(0, std::size(doubles) + 1);
    if (which < std::size(doubles)) {
        *doubles[which] = pick_double(in, std::isnan(*doubles[which]) ? 1.0 : *doubles[which]);
    } else if (!c.overrides.empty()) {
        auto& o = c.overrides[in.ConsumeIntegralInRange<size_t>(0, c.overrides.size() - 1)];
        (which == std::size(doubles) ? o.density_scale : o.scale_height_m) = pick_double(in, 1.0);
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 1) return -1;
    const bool wild = data[0] & 1;
    FuzzedDataProvider in(data + 1, size - 1);
    Call c;
    init(c);
    if (wild)
        fill_wild(in, c);
    else
        fill_tame(in, c);
    c.vdb.voxel_values = kVoxelValues[in.ConsumeIntegralInRange<int>(0, wild ? 4 : 2)];
    const airmass_scene_spec& spec = c.spec;
    airmass_sky_options& sky = c.sky;
    const airmass_vdb_options& vdb = c.vdb;
    if (std::getenv("AIRMASS_FUZZ_PRINT"))  // what an input asks for (to describe a finding)
        std::fprintf(stderr,
                     "%s: preset %s toml %s sun %g/%g alt %g radius %g top %g albedo %g basis %d overrides %u "
                     "camera %d pos (%g %g %g) dir (%g %g %g) fov %g max %g %dx%d | sky %dx%d samples %d grid %d | "
                     "vdb %s %s centre %d voxel %g box (%g %g %g)-(%g %g %g) tol %g dense %g MB tiles %d\n",
                     wild ? "wild" : "tame", spec.preset ? spec.preset : "-", spec.toml ? "yes" : "no",
                     spec.sun_elevation_deg, spec.sun_rotation_deg, spec.altitude_m, spec.planet_radius_m,
                     spec.atmosphere_top_m, spec.ground_albedo, spec.basis, spec.constituent_count, spec.has_camera,
                     spec.camera_position_m[0], spec.camera_position_m[1], spec.camera_position_m[2],
                     spec.camera_direction[0], spec.camera_direction[1], spec.camera_direction[2], spec.camera_fov_deg,
                     spec.camera_max_distance_m, spec.camera_width, spec.camera_height, sky.width, sky.height,
                     sky.view_samples, sky.grid, vdb.region ? vdb.region : "-", vdb.unit ? vdb.unit : "-",
                     vdb.origin_center, vdb.voxel_size, vdb.box[0], vdb.box[1], vdb.box[2], vdb.box[3], vdb.box[4],
                     vdb.box[5], vdb.tolerance, vdb.max_dense_mb, vdb.tile_voxels);
    // Multiple scattering off: its tables take tens of seconds under the fuzz build's
    // instrumentation (a libFuzzer timeout, not a hang); the GoogleTest suite covers it under ASan.
    sky.multiple_scattering = 0;

    // A small message buffer, sometimes 1 byte or none: truncation must be safe.
    const size_t message_size = !wild || in.ConsumeBool() ? 256 : in.ConsumeIntegralInRange<size_t>(0, 8);
    std::vector<char> message(std::max<size_t>(message_size, 1), '\0');
    char* msg = message_size ? message.data() : nullptr;
    const auto status_ok = [&](int32_t s) {
        if (msg) check_status(s, msg, message_size);
        if (msg) message.assign(message.size(), '\0');
        return s == AIRMASS_OK;
    };

    char* json = nullptr;
    const bool valid = status_ok(airmass_validate_scene(&spec, in.ConsumeBool() ? &json : nullptr, msg, message_size));
    if (json) {
        require(nlohmann::json::accept(json), "returned JSON does not parse");
        airmass_string_free(json);
        json = nullptr;
    }

    airmass_sun_light sun{};
    sun.struct_size = sizeof sun;
    if (status_ok(airmass_sun_light_at_observer(&spec, kChapman[in.ConsumeIntegralInRange<int>(0, wild ? 4 : 2)], &sun,
                                                msg, message_size))) {
        for (int k = 0; k < 3; ++k) {
            require(std::isfinite(sun.irradiance_rgb[k]) && sun.irradiance_rgb[k] >= 0.0, "sun irradiance_rgb");
            require(std::isfinite(sun.transmittance_rgb[k]) && sun.transmittance_rgb[k] >= 0.0, "sun transmittance");
            require(std::isfinite(sun.direction[k]), "sun direction");
        }
    }

    airmass_sun_position pos{};
    pos.struct_size = sizeof pos;
    if (status_ok(airmass_solar_position(&c.solar, &pos, msg, message_size))) {
        require(pos.elevation_deg >= -90.0 && pos.elevation_deg <= 90.0, "solar elevation_deg outside [-90, 90]");
        require(pos.azimuth_deg >= 0.0 && pos.azimuth_deg <= 360.0, "solar azimuth_deg outside [0, 360]");
        require(std::isfinite(pos.blender_rotation_deg) && std::isfinite(pos.julian_day) &&
                    std::isfinite(pos.delta_t_s),
                "solar position not finite");
    }

    const int64_t w = std::clamp<int64_t>(sky.width, 0, 16);
    const int64_t h = sky.height > 0 ? std::min<int64_t>(sky.height, 8) : std::max<int64_t>(2, w / 2);
    std::vector<float> rgba(size_t(w * h * 4) + 4, -1.0f);
    const size_t float_count = wild && in.ConsumeIntegral<uint8_t>() < 8
                                   ? in.ConsumeIntegralInRange<size_t>(0, rgba.size())
                                   : size_t(w * h * 4);
    if (status_ok(airmass_render_sky(&spec, &sky, rgba.data(), float_count, nullptr,
                                     in.ConsumeBool() ? &json : nullptr, msg, message_size))) {
        require(float_count == size_t(w * h * 4), "render_sky accepted a wrong float_count");
        airmass::fuzz::require_finite_non_negative<float>(std::span(rgba.data(), float_count), "sky pixel");
    }
    if (json) {
        require(nlohmann::json::accept(json), "returned JSON does not parse");
        airmass_string_free(json);
        json = nullptr;
    }

    // C ABI 6: the same sky through a session (its create and one render; multiple scattering
    // off as above), with a fuzzed view.
    if (in.ConsumeBool()) {
        airmass_sky_session* session = nullptr;
        if (status_ok(airmass_sky_session_create(&spec, &sky, nullptr, &session, msg, message_size))) {
            require(session != nullptr, "session_create succeeded without a session");
            airmass_sky_view view;
            view.struct_size = sizeof view;
            airmass_sky_view_init(&view);
            view.sun_elevation_deg = wild ? maybe(in, 10.0) : keep_or(in, -90.0, 90.0);
            view.sun_rotation_deg = wild ? maybe(in, 90.0) : keep_or(in, -360.0, 360.0);
            view.altitude_m = wild ? maybe(in, 1000.0) : keep_or(in, 0.0, 1e5);
            if (status_ok(airmass_sky_session_render(session, &view, in.ConsumeBool() ? &sky : nullptr, rgba.data(),
                                                     float_count, nullptr, nullptr, msg, message_size)))
                airmass::fuzz::require_finite_non_negative<float>(std::span(rgba.data(), float_count), "session pixel");
        } else {
            require(session == nullptr, "a failed session_create left a session");
        }
        airmass_sky_session_free(session);
    }

    if (status_ok(airmass_analytic_density_json(&spec, &vdb, &json, msg, message_size))) {
        require(nlohmann::json::accept(json), "returned JSON does not parse");
    }
    if (json) airmass_string_free(json), json = nullptr;

    {  // C ABI 7: the sun's columns, sizes around the allowed range, a buffer of any size
        const int32_t mu_size = in.ConsumeIntegralInRange<int32_t>(-1, 24);
        const int32_t r_size = in.ConsumeIntegralInRange<int32_t>(-1, 12);
        std::vector<float> columns(in.ConsumeIntegralInRange<std::size_t>(0, 24 * 12 * 16));
        if (status_ok(airmass_sun_column_table(&spec, &vdb, mu_size, r_size, columns.data(), columns.size(), msg,
                                               message_size))) {
            require(mu_size >= 2 && r_size >= 2 && columns.size() % (std::size_t(mu_size) * r_size) == 0,
                    "sun column table accepted sizes it should refuse");
            for (float v : columns) require(std::isfinite(v) && v >= 0.0f, "sun column not finite or negative");
        }
    }
    // C ABI 7: the sun's multiple scattering (Hillaire's Ψ at three wavelengths: a precompute of
    // ≈ 0.1 s, so for one input in 32), sizes around the allowed range, a buffer of any size.
    if (in.ConsumeIntegral<uint8_t>() < 8) {
        const int32_t mu_size = in.ConsumeIntegralInRange<int32_t>(-1, 12);
        const int32_t r_size = in.ConsumeIntegralInRange<int32_t>(-1, 6);
        std::vector<float> psi(in.ConsumeIntegralInRange<std::size_t>(0, 12 * 6 * 4));
        double mu_s_min = std::nan("");
        if (status_ok(airmass_sun_ms_table(&spec, &vdb, mu_size, r_size, psi.data(), psi.size(), &mu_s_min, msg,
                                           message_size))) {
            require(mu_size >= 2 && r_size >= 2 && psi.size() == std::size_t(mu_size) * r_size * 3,
                    "sun multiple-scattering table accepted sizes it should refuse");
            require(mu_s_min >= -1.0 && mu_s_min < 1.0, "sun multiple-scattering table: mu_s_min outside [-1, 1)");
            for (float v : psi) require(std::isfinite(v) && v >= 0.0f, "sun multiple scattering not finite or negative");
        }
    }

    if (!valid || (wild && !in.ConsumeBool())) return 0;
    // A volume outside the tame sizes (a raw dense limit above 0.5 MB, or a raw voxel size giving
    // more than 32^3 voxels) is a legitimate job of minutes under this build: the plan runs with a
    // progress callback that cancels at its first report, so it must end AIRMASS_CANCELLED (or
    // finish first), never time out. The CI's fuzz run found it (max_dense_mb raw, 20 s, 2026-12-02).
    double box_voxels = 1.0;
    for (int k = 0; k < 3; ++k) box_voxels *= (vdb.box[k + 3] - vdb.box[k]) / vdb.voxel_size;
    const bool large = !(vdb.max_dense_mb <= 0.5) || (std::isfinite(vdb.voxel_size) && !(box_voxels <= 32768.0));
    airmass_job cancel_first{};
    cancel_first.struct_size = sizeof cancel_first;
    cancel_first.progress = [](void*, double) -> int32_t { return 1; };
    const int32_t plan_status =
        airmass_vdb_plan(&spec, &vdb, nullptr, large ? &cancel_first : nullptr, &json, msg, message_size);
    if (large && plan_status == AIRMASS_CANCELLED) {
        require(json == nullptr, "a cancelled plan returned JSON");
        if (msg && message_size >= 2) require(message[0] != '\0', "a cancelled plan without a message");
        return 0;
    }
    if (status_ok(plan_status)) {
        const auto plan = nlohmann::json::parse(json);
        airmass_string_free(json);
        json = nullptr;
        if (plan.at("grids").empty()) return 0;
        const auto& g = plan.at("grids").at(in.ConsumeIntegralInRange<size_t>(0, plan.at("grids").size() - 1));
        const std::string name = g.at("name").get<std::string>();
        airmass_vdb_block block;
        block.struct_size = sizeof block;  // C ABI 4+: the host sets it, *_init checks it
        airmass_vdb_block_init(&block);
        block.grid = name.c_str();
        for (int k = 0; k < 3; ++k) {
            const int lo = g.at("bbox_min").at(k).get<int>();
            block.min[k] = lo + in.ConsumeIntegralInRange<int>(wild ? -2 : 0, 4);
            block.max[k] = block.min[k] + in.ConsumeIntegralInRange<int>(wild ? -1 : 0, 7);
        }
        block.threads = 1;
        int64_t n = 1;
        for (int k = 0; k < 3; ++k) n *= std::max<int64_t>(0, int64_t(block.max[k]) - block.min[k] + 1);
        std::vector<float> values(size_t(n) + 1, -1.0f);
        if (status_ok(airmass_vdb_grid_values(&spec, &vdb, &block, values.data(), size_t(n), nullptr, msg,
                                              message_size))) {
            airmass::fuzz::require_finite_non_negative<float>(std::span(values.data(), size_t(n)), "vdb value");
            // The same block from a session (ABI 8) after its plan, whose pass filled the session's
            // store of voxel means: accepted too, the same values bit for bit.
            airmass_vdb_session* session = nullptr;
            require(status_ok(airmass_vdb_session_create(&spec, &vdb, &session, msg, message_size)) && session,
                    "a VDB session refused what the stateless calls accepted");
            char* session_plan = nullptr;
            const int32_t sp = airmass_vdb_session_plan(session, nullptr, large ? &cancel_first : nullptr,
                                                        &session_plan, msg, message_size);
            if (large && sp == AIRMASS_CANCELLED) {  // a long plan: cancelled as the stateless one could be
                if (msg) message.assign(message.size(), '\0');
            } else {
                require(status_ok(sp), "a VDB session's plan refused where the stateless plan was accepted");
            }
            if (session_plan) airmass_string_free(session_plan);
            std::vector<float> again(size_t(n) + 1, -1.0f);
            require(status_ok(airmass_vdb_session_grid_values(session, &block, again.data(), size_t(n), nullptr, msg,
                                                              message_size)),
                    "a VDB session's block refused where the stateless call's was accepted");
            require(std::memcmp(again.data(), values.data(), sizeof(float) * size_t(n)) == 0,
                    "a VDB session's block differs from the stateless call's");
            airmass_vdb_session_free(session);
        }
    }
    if (json) airmass_string_free(json);
    return 0;
}
