// libFuzzer target: the C ABI (plugin/capi/include/airmass/airmass_c.h), as a host calls it.
// The input fills airmass_scene_spec (preset or TOML text, every numeric override, constituent
// overrides, camera), airmass_sky_options, airmass_vdb_options and the call's sizes; then it calls
// airmass_validate_scene, airmass_sun_light_at_observer, airmass_render_sky (at most 16x8 pixels) and the
// same sky through airmass_sky_session_create/render (C ABI 6),
// airmass_analytic_density_json, airmass_vdb_plan and airmass_vdb_grid_values (single scattering;
// small dense limit and box, so a run stays fast). Oracle: every call returns a known airmass_status; a failure
// carries a non-empty message; success gives finite, non-negative pixels / irradiances / values,
// and a NUL-terminated message buffer is never overrun (ASan).
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <nlohmann/json.hpp>
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

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    FuzzedDataProvider in(data, size);
    static const char* const kPresets[] = {"earth", "earth-hazy", "mars", "atmosphere-plus", "blender-nishita",
                                           "no-such-preset"};
    static const char* const kChapman[] = {nullptr, "airmass", "exact", "no-such-method", ""};
    static const char* const kNames[] = {"rayleigh", "mie", "ozone", "dust", ""};

    airmass_scene_spec spec;
    spec.struct_size = sizeof spec;  // C ABI 4+: the host sets it, *_init checks it
    airmass_scene_spec_init(&spec);
    std::string toml;
    const uint8_t source = in.ConsumeIntegral<uint8_t>();
    if (source < 200) spec.preset = kPresets[source % 6];
    if (source >= 150) {  // TOML text (with a preset too: both set is an error to report)
        toml = in.ConsumeRandomLengthString(2048);
        spec.toml = toml.c_str();
    }
    spec.sun_elevation_deg = maybe(in, 30.0);
    spec.sun_rotation_deg = maybe(in, 0.0);
    spec.altitude_m = maybe(in, 1000.0);
    spec.planet_radius_m = maybe(in, 6360e3);
    spec.atmosphere_top_m = maybe(in, 6420e3);
    spec.ground_albedo = maybe(in, 0.3);
    spec.basis = airmass::fuzz::pick_int(in, -1, 1);
    std::vector<airmass_constituent_override> overrides(in.ConsumeIntegralInRange<int>(0, 3));
    for (auto& o : overrides) {
        o.name = in.ConsumeIntegral<uint8_t>() == 0 ? nullptr : kNames[in.ConsumeIntegralInRange<int>(0, 4)];
        o.enabled = in.ConsumeIntegral<uint8_t>() < 32 ? 0 : 1;
        o.density_scale = maybe(in, 2.0);
        o.scale_height_m = maybe(in, 8000.0);
    }
    spec.constituent_count = static_cast<uint32_t>(overrides.size());
    spec.constituents = overrides.empty() ? nullptr : overrides.data();
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

    // A small message buffer, sometimes 1 byte or none: truncation must be safe.
    const size_t message_size = in.ConsumeBool() ? 256 : in.ConsumeIntegralInRange<size_t>(0, 8);
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
    if (status_ok(airmass_sun_light_at_observer(&spec, kChapman[in.ConsumeIntegralInRange<int>(0, 4)], &sun, msg,
                                                message_size))) {
        for (int k = 0; k < 3; ++k) {
            require(std::isfinite(sun.irradiance_rgb[k]) && sun.irradiance_rgb[k] >= 0.0, "sun irradiance_rgb");
            require(std::isfinite(sun.transmittance_rgb[k]) && sun.transmittance_rgb[k] >= 0.0, "sun transmittance");
            require(std::isfinite(sun.direction[k]), "sun direction");
        }
    }

    airmass_sky_options sky;
    sky.struct_size = sizeof sky;  // C ABI 4+: the host sets it, *_init checks it
    airmass_sky_options_init(&sky);
    sky.width = in.ConsumeIntegral<uint8_t>() < 8 ? in.ConsumeIntegral<int32_t>() : in.ConsumeIntegralInRange<int>(1, 16);
    sky.height = in.ConsumeIntegralInRange<int32_t>(-1, 8);
    sky.view_samples = airmass::fuzz::pick_int(in, 0, 8);
    sky.chapman = kChapman[in.ConsumeIntegralInRange<int>(0, 4)];
    sky.sun_disc = in.ConsumeIntegral<int32_t>();
    sky.upper_only = in.ConsumeBool();
    sky.threads = in.ConsumeIntegralInRange<int32_t>(-1, 2);
    sky.grid = airmass::fuzz::pick_int(in, -1, 8);
    // Multiple scattering off: its tables take tens of seconds under the fuzz build's
    // instrumentation (a libFuzzer timeout, not a hang); the GoogleTest suite covers it under ASan.
    sky.multiple_scattering = 0;
    const int64_t w = std::clamp<int64_t>(sky.width, 0, 16);
    const int64_t h = sky.height > 0 ? std::min<int64_t>(sky.height, 8) : std::max<int64_t>(2, w / 2);
    std::vector<float> rgba(size_t(w * h * 4) + 4, -1.0f);
    const size_t float_count = in.ConsumeIntegral<uint8_t>() < 8 ? in.ConsumeIntegralInRange<size_t>(0, rgba.size())
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
            view.sun_elevation_deg = maybe(in, 10.0);
            view.sun_rotation_deg = maybe(in, 90.0);
            view.altitude_m = maybe(in, 1000.0);
            if (status_ok(airmass_sky_session_render(session, &view, in.ConsumeBool() ? &sky : nullptr, rgba.data(),
                                                     float_count, nullptr, nullptr, msg, message_size)))
                airmass::fuzz::require_finite_non_negative<float>(std::span(rgba.data(), float_count), "session pixel");
        } else {
            require(session == nullptr, "a failed session_create left a session");
        }
        airmass_sky_session_free(session);
    }

    airmass_vdb_options vdb;
    vdb.struct_size = sizeof vdb;  // C ABI 4+: the host sets it, *_init checks it
    airmass_vdb_options_init(&vdb);
    static const char* const kRegions[] = {"planet", "view", "box", "nowhere", nullptr};
    static const char* const kUnits[] = {"km", "m", "mm", nullptr};
    vdb.region = kRegions[in.ConsumeIntegralInRange<int>(0, 4)];
    vdb.unit = kUnits[in.ConsumeIntegralInRange<int>(0, 3)];
    vdb.origin_center = in.ConsumeIntegralInRange<int32_t>(-1, 2);
    vdb.voxel_size = in.ConsumeBool() ? pick_double(in, 20.0) : kNaN;
    for (int k = 0; k < 6; ++k) vdb.box[k] = pick_double(in, k < 3 ? -10.0 : 10.0);
    vdb.tolerance = maybe(in, 1e-3);
    // A small dense limit keeps the sampling pass short (the auto voxel size follows it).
    vdb.max_dense_mb = in.ConsumeBool() ? in.ConsumeFloatingPointInRange<double>(-1.0, 2.0) : 0.5;
    vdb.tile_voxels = airmass::fuzz::pick_int(in, -1, 64);

    if (status_ok(airmass_analytic_density_json(&spec, &vdb, &json, msg, message_size))) {
        require(nlohmann::json::accept(json), "returned JSON does not parse");
    }
    if (json) airmass_string_free(json), json = nullptr;

    if (!valid || !in.ConsumeBool()) return 0;
    if (status_ok(airmass_vdb_plan(&spec, &vdb, nullptr, nullptr, &json, msg, message_size))) {
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
            block.min[k] = lo + in.ConsumeIntegralInRange<int>(-2, 4);
            block.max[k] = block.min[k] + in.ConsumeIntegralInRange<int>(-1, 7);
        }
        block.threads = 1;
        int64_t n = 1;
        for (int k = 0; k < 3; ++k) n *= std::max<int64_t>(0, int64_t(block.max[k]) - block.min[k] + 1);
        std::vector<float> values(size_t(n) + 1, -1.0f);
        if (status_ok(airmass_vdb_grid_values(&spec, &vdb, &block, values.data(), size_t(n), nullptr, msg,
                                              message_size)))
            airmass::fuzz::require_finite_non_negative<float>(std::span(values.data(), size_t(n)), "vdb value");
    }
    if (json) airmass_string_free(json);
    return 0;
}
