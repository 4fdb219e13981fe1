// The C ABI (airmass_c.h): a thin, exception-proof shell over the C++ library.
//
// Every exported function is `guarded`: the body runs inside one try block that maps
// each library exception type to a status code and copies its message into the caller's
// buffer. Long calls run on a worker thread while the calling thread reports progress,
// so a host's callback always runs on the thread that called us (Python's GIL and
// Blender's main-thread rules both need that).
#include "airmass/solar_position.hpp"
#include "airmass/sun_light.hpp"
#include "airmass/version.hpp"
#include "airmass/airmass_c.h"

#include "capi_internal.hpp"

#include "airmass/simd.hpp"

#include <memory>


namespace airmass::capi {

// ---- scenes ---------------------------------------------------------------------------------

void scale_coefficient(airmass::SpectralCoefficient& c, double f) {
    c.value_per_m *= f;
    for (auto& entry : c.table) entry.second *= f;
}

void apply_constituent_override(Scene& scene, const airmass_constituent_override& o, std::size_t index) {
    const std::string path = "constituents[" + std::to_string(index) + "]";
    if (!o.name) throw AbiError(AIRMASS_INVALID_ARGUMENT, path + ".name: NULL");
    const std::string name = o.name;
    auto it = std::find_if(scene.constituents.begin(), scene.constituents.end(),
                           [&](const airmass::Constituent& c) { return c.name == name; });
    if (it == scene.constituents.end()) {
        std::string names;
        for (const auto& c : scene.constituents) names += (names.empty() ? "" : ", ") + ("\"" + c.name + "\"");
        throw airmass::SceneError("constituent \"" + name + "\": the scene has no constituent of that name (it has " +
                                  (names.empty() ? std::string("none") : names) + ")");
    }
    if (!o.enabled) {
        scene.constituents.erase(it);
        return;
    }
    if (given(o.density_scale)) {
        if (!(std::isfinite(o.density_scale) && o.density_scale >= 0.0 && o.density_scale <= 1e6))
            throw airmass::SceneError("constituent \"" + name + "\".density_scale = " + number(o.density_scale) +
                                      ": must be in [0, 1e6]");
        scale_coefficient(it->scattering, o.density_scale);
        scale_coefficient(it->absorption, o.density_scale);
    }
    if (given(o.scale_height_m)) {
        if (it->profile.kind != airmass::DensityProfile::Kind::exponential)
            throw airmass::SceneError("constituent \"" + name +
                                      "\".scale_height_km: only exponential profiles have a scale height");
        if (!(std::isfinite(o.scale_height_m) && o.scale_height_m > 0.0))
            throw airmass::SceneError("constituent \"" + name + "\".profile.scale_height_km = " +
                                      number(o.scale_height_m / 1000.0) + ": must be > 0");
        it->profile.scale_height_m = o.scale_height_m;
    }
}

Scene build_scene(const airmass_scene_spec* spec) {
    require_struct(spec, "scene_spec");
    const bool has_toml = spec->toml != nullptr;
    const bool has_preset = spec->preset != nullptr && spec->preset[0] != '\0';
    if (has_toml == has_preset)
        throw AbiError(AIRMASS_INVALID_ARGUMENT, "scene_spec: set exactly one of toml and preset");
    Scene scene;
    if (has_toml) {
        scene = airmass::parse_scene_toml(spec->toml, spec->source_name ? spec->source_name : "<scene>");
    } else {
        const auto names = airmass::preset_names();
        if (std::find(names.begin(), names.end(), spec->preset) == names.end()) {
            std::string list;
            for (const auto& n : names) list += (list.empty() ? "" : ", ") + ("\"" + n + "\"");
            throw airmass::SceneError(std::string("preset = \"") + spec->preset + "\": unknown preset (available: " +
                                      list + ")");
        }
        scene = airmass::load_preset(spec->preset);
    }
    // Overrides use the scene file's field names in messages (validate() below checks ranges).
    if (given(spec->sun_elevation_deg)) scene.sun.elevation_deg = spec->sun_elevation_deg;
    if (given(spec->sun_rotation_deg)) {
        // Rotation is periodic: fold into [-360, 360] so any angle a UI produces is accepted.
        if (!std::isfinite(spec->sun_rotation_deg))
            throw airmass::SceneError("sun.azimuth_deg = " + number(spec->sun_rotation_deg) + ": must be finite");
        scene.sun.azimuth_deg = std::fmod(spec->sun_rotation_deg, 360.0);
    }
    if (given(spec->altitude_m)) scene.observer.altitude_m = spec->altitude_m;
    if (given(spec->planet_radius_m)) scene.planet.radius_m = spec->planet_radius_m;
    if (given(spec->atmosphere_top_m)) scene.planet.atmosphere_top_m = spec->atmosphere_top_m;
    if (given(spec->ground_albedo)) scene.planet.ground_albedo = spec->ground_albedo;
    switch (spec->basis) {
        case -1: break;
        case 0:
            if (scene.basis.kind != airmass::SpectralBasis::Kind::spectral || scene.basis.wavelengths_nm.empty()) {
                scene.basis.kind = airmass::SpectralBasis::Kind::spectral;
                scene.basis.wavelengths_nm.clear();
                for (int i = 0; i <= 47; ++i) scene.basis.wavelengths_nm.push_back(360.0 + 10.0 * i);
            }
            break;
        case 1:
            scene.basis.kind = airmass::SpectralBasis::Kind::rgb_schuler;
            scene.basis.wavelengths_nm.assign(airmass::kSchulerWavelengthsNm.begin(),
                                              airmass::kSchulerWavelengthsNm.end());
            break;
        default:
            throw AbiError(AIRMASS_INVALID_ARGUMENT,
                           "scene_spec.basis = " + std::to_string(spec->basis) + ": must be -1, 0 or 1");
    }
    if (spec->constituent_count > 0 && !spec->constituents)
        throw AbiError(AIRMASS_INVALID_ARGUMENT, "scene_spec.constituents: NULL with constituent_count > 0");
    for (uint32_t i = 0; i < spec->constituent_count; ++i) apply_constituent_override(scene, spec->constituents[i], i);
    if (spec->has_camera) {
        airmass::Camera c;
        std::copy(spec->camera_position_m, spec->camera_position_m + 3, c.position_m);
        std::copy(spec->camera_direction, spec->camera_direction + 3, c.direction);
        std::copy(spec->camera_up, spec->camera_up + 3, c.up);
        c.fov_deg = spec->camera_fov_deg;
        c.max_distance_m = spec->camera_max_distance_m;
        c.width = spec->camera_width;
        c.height = spec->camera_height;
        scene.camera = c;
    }
    airmass::validate(scene);
    return scene;
}

airmass::ChapmanMethod chapman_from(const char* name, airmass::ChapmanMethod fallback, const char* field) {
    if (!name || name[0] == '\0') return fallback;
    const auto m = airmass::chapman_method_from_name(name);
    if (!m) {
        std::string list;
        for (const auto& info : airmass::chapman_methods())
            list += (list.empty() ? "" : ", ") + std::string(info.name);
        throw AbiError(AIRMASS_INVALID_ARGUMENT,
                       std::string(field) + " = \"" + name + "\": unknown Chapman method (one of " + list + ")");
    }
    return *m;
}

airmass::SkySettings sky_settings_from(const airmass_sky_options& o) {
    airmass::SkySettings settings;
    settings.width = o.width;
    settings.height = o.height > 0 ? o.height : std::max(2, o.width / 2);
    settings.view.view_samples = o.view_samples;
    settings.view.chapman = chapman_from(o.chapman, settings.view.chapman, "sky_options.chapman");
    settings.view.sun_disc = o.sun_disc != 0;
    settings.region = o.upper_only ? airmass::SkyRegion::upper : airmass::SkyRegion::full;
    settings.threads = o.threads;
    settings.grid = o.grid;
    settings.multiple.enabled = o.multiple_scattering != 0;
    settings.multiple_grid = o.multiple_grid;
    settings.multiple.view_samples = o.multiple_samples;
    airmass::validate(settings);
    return settings;
}

void check_float_count(const airmass::SkySettings& settings, std::size_t float_count) {
    const std::size_t expected = std::size_t(settings.width) * std::size_t(settings.height) * 4;
    if (float_count != expected)
        throw AbiError(AIRMASS_INVALID_ARGUMENT, "float_count = " + std::to_string(float_count) +
                                                     ": must be width x height x 4 = " + std::to_string(expected));
}

airmass::RenderHooks progress_hooks(const airmass::CancelFlag& cancel, std::atomic<double>& fraction) {
    airmass::RenderHooks hooks;
    hooks.cancel = &cancel;
    auto units = std::make_shared<std::atomic<std::size_t>>(0);
    hooks.work_done = [units, &fraction](std::size_t n, std::size_t total) {
        const std::size_t done = units->fetch_add(n, std::memory_order_relaxed) + n;
        if (total > 0) fraction.store(std::min(1.0, double(done) / double(total)), std::memory_order_relaxed);
    };
    return hooks;
}

void deliver_sky(const Scene& scene, const airmass::SkySettings& settings, const airmass::FloatImage& image,
                 float* rgba, char** metadata_json) {
    if (image.width != settings.width || image.height != settings.height || image.channels < 3)
        throw std::runtime_error("render_sky returned an image of an unexpected size");
    std::string meta;
    if (metadata_json) {
        nlohmann::ordered_json j = nlohmann::ordered_json::object();
        for (const auto& [key, value] : airmass::sky_metadata(scene, settings)) j[key] = value;
        meta = j.dump();
    }
    const std::size_t pixels = std::size_t(image.width) * image.height;
    for (std::size_t i = 0; i < pixels; ++i) {
        const float* px = image.pixels.data() + i * std::size_t(image.channels);
        float* out = rgba + i * 4;
        out[0] = px[0];
        out[1] = px[1];
        out[2] = px[2];
        out[3] = 1.0f;
    }
    if (metadata_json) *metadata_json = duplicate(meta);
}

}  // namespace airmass::capi

struct airmass_sky_session {
    airmass::SkySession session;
};

using namespace airmass::capi;

extern "C" {


int32_t airmass_abi_version(void) { return AIRMASS_C_ABI_VERSION; }

const char* airmass_version_string(void) { return airmass::version_string(); }

const char* airmass_status_name(int32_t status) {
    switch (status) {
        case AIRMASS_OK: return "AIRMASS_OK";
        case AIRMASS_INVALID_ARGUMENT: return "AIRMASS_INVALID_ARGUMENT";
        case AIRMASS_SCENE_ERROR: return "AIRMASS_SCENE_ERROR";
        case AIRMASS_SETTINGS_ERROR: return "AIRMASS_SETTINGS_ERROR";
        case AIRMASS_IO_ERROR: return "AIRMASS_IO_ERROR";
        case AIRMASS_CANCELLED: return "AIRMASS_CANCELLED";
        case AIRMASS_UNSUPPORTED: return "AIRMASS_UNSUPPORTED";
        case AIRMASS_INTERNAL_ERROR: return "AIRMASS_INTERNAL_ERROR";
        default: return "AIRMASS_UNKNOWN_STATUS";
    }
}

int32_t airmass_has_vdb(void) { return 1; }  // the volume functions are always built (airmass_volume)

void airmass_string_free(char* s) { std::free(s); }

int32_t airmass_build_info(char** out, char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
        if (!out) throw AbiError(AIRMASS_INVALID_ARGUMENT, "out: NULL pointer");
#if defined(_WIN32)
        const char* platform = "windows-x64";
#elif defined(__APPLE__) && defined(__aarch64__)
        const char* platform = "macos-arm64";
#elif defined(__APPLE__)
        const char* platform = "macos-x64";
#else
        const char* platform = "linux-x64";
#endif
        nlohmann::ordered_json j;
        j["version"] = airmass::version_string();
        j["abi"] = AIRMASS_C_ABI_VERSION;
        j["platform"] = platform;
        j["simd"] = std::string(airmass::simd_target_name(airmass::simd_target()));
#if defined(__clang__)
        j["compiler"] = std::string("clang ") + __clang_version__;
#elif defined(__GNUC__)
        j["compiler"] = std::string("gcc ") + __VERSION__;
#else
        j["compiler"] = "unknown";
#endif
        *out = duplicate(j.dump());
    });
}

int32_t airmass_preset_names(char** out, char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
        if (!out) throw AbiError(AIRMASS_INVALID_ARGUMENT, "out: NULL pointer");
        std::string text;
        for (const auto& n : airmass::preset_names()) text += n + "\n";
        *out = duplicate(text);
    });
}

int32_t airmass_chapman_method_names(char** out, char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
        if (!out) throw AbiError(AIRMASS_INVALID_ARGUMENT, "out: NULL pointer");
        std::string text;
        for (const auto& info : airmass::chapman_methods()) text += std::string(info.name) + "\n";
        *out = duplicate(text);
    });
}

int32_t airmass_scene_spec_init(airmass_scene_spec* spec) {
    if (!init_size_ok(spec)) return AIRMASS_INVALID_ARGUMENT;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    *spec = airmass_scene_spec{};
    spec->struct_size = sizeof(airmass_scene_spec);
    spec->sun_elevation_deg = spec->sun_rotation_deg = spec->altitude_m = nan;
    spec->planet_radius_m = spec->atmosphere_top_m = spec->ground_albedo = nan;
    spec->basis = -1;
    spec->camera_direction[0] = 1.0;
    spec->camera_up[2] = 1.0;
    spec->camera_fov_deg = 60.0;
    spec->camera_max_distance_m = 200e3;
    spec->camera_width = 640;
    spec->camera_height = 360;
    return AIRMASS_OK;
}

int32_t airmass_validate_scene(const airmass_scene_spec* spec, char** scene_json, char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
        const Scene scene = build_scene(spec);
        if (scene_json) *scene_json = duplicate(airmass::scene_to_json(scene));
    });
}

airmass_cancel_token* airmass_cancel_token_new(void) { return new (std::nothrow) airmass_cancel_token(); }
void airmass_cancel_token_request(airmass_cancel_token* token) {
    if (token) token->flag.request();
}
void airmass_cancel_token_reset(airmass_cancel_token* token) {
    if (token) token->flag.reset();
}
int32_t airmass_cancel_token_requested(const airmass_cancel_token* token) {
    return token && token->flag.requested() ? 1 : 0;
}
void airmass_cancel_token_free(airmass_cancel_token* token) { delete token; }

int32_t airmass_sky_options_init(airmass_sky_options* options) {
    if (!init_size_ok(options)) return AIRMASS_INVALID_ARGUMENT;
    const airmass::SkySettings d;
    *options = airmass_sky_options{};
    options->struct_size = sizeof(airmass_sky_options);
    options->width = d.width;
    options->height = 0;
    options->view_samples = d.view.view_samples;
    options->chapman = nullptr;
    options->sun_disc = d.view.sun_disc ? 1 : 0;
    options->upper_only = d.region == airmass::SkyRegion::upper ? 1 : 0;
    options->threads = d.threads;
    options->grid = d.grid;
    options->multiple_scattering = d.multiple.enabled ? 1 : 0;
    options->multiple_grid = d.multiple_grid;
    options->multiple_samples = d.multiple.view_samples;
    return AIRMASS_OK;
}

int32_t airmass_render_sky(const airmass_scene_spec* spec, const airmass_sky_options* options, float* rgba,
                           size_t float_count, const airmass_job* job, char** metadata_json, char* message,
                           size_t message_size) {
    return guarded(message, message_size, [&] {
        require_struct(options, "sky_options");
        if (!rgba) throw AbiError(AIRMASS_INVALID_ARGUMENT, "rgba: NULL pointer");
        const Scene scene = build_scene(spec);
        const airmass::SkySettings settings = sky_settings_from(*options);
        check_float_count(settings, float_count);
        airmass::FloatImage image;
        run_job(job, [&](const airmass::CancelFlag& cancel, std::atomic<double>& fraction) {
            image = airmass::render_sky(scene, settings, progress_hooks(cancel, fraction));
            if (cancel.requested()) throw airmass::Cancelled("sky: cancelled");
        });
        deliver_sky(scene, settings, image, rgba, metadata_json);
    });
}

int32_t airmass_sky_view_init(airmass_sky_view* view) {
    if (!init_size_ok(view)) return AIRMASS_INVALID_ARGUMENT;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    *view = airmass_sky_view{};
    view->struct_size = sizeof(airmass_sky_view);
    view->sun_elevation_deg = view->sun_rotation_deg = view->altitude_m = nan;
    return AIRMASS_OK;
}

int32_t airmass_sky_session_create(const airmass_scene_spec* spec, const airmass_sky_options* options,
                                   const airmass_job* job, airmass_sky_session** out, char* message,
                                   size_t message_size) {
    if (out) *out = nullptr;
    return guarded(message, message_size, [&] {
        if (!out) throw AbiError(AIRMASS_INVALID_ARGUMENT, "out: NULL pointer");
        if (options) require_struct(options, "sky_options");
        const Scene scene = build_scene(spec);
        airmass::SkySettings settings;
        if (options) {
            settings = sky_settings_from(*options);
        } else {
            settings.height = settings.width / 2;
            airmass::validate(settings);
        }
        std::unique_ptr<airmass_sky_session> session;
        run_job(job, [&](const airmass::CancelFlag& cancel, std::atomic<double>& fraction) {
            session = std::make_unique<airmass_sky_session>(
                airmass_sky_session{airmass::SkySession(scene, settings, progress_hooks(cancel, fraction))});
            if (cancel.requested()) throw airmass::Cancelled("sky session: cancelled");
        });
        *out = session.release();
    });
}

int32_t airmass_sky_session_render(const airmass_sky_session* session, const airmass_sky_view* view,
                                   const airmass_sky_options* options, float* rgba, size_t float_count,
                                   const airmass_job* job, char** metadata_json, char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
        if (!session) throw AbiError(AIRMASS_INVALID_ARGUMENT, "session: NULL pointer");
        if (view) require_struct(view, "sky_view");
        if (options) require_struct(options, "sky_options");
        if (!rgba) throw AbiError(AIRMASS_INVALID_ARGUMENT, "rgba: NULL pointer");
        const airmass::SkySession& ss = session->session;
        // The scene of this render: the session's, with the view's sun and observer (validated
        // as a scene file's fields: their names in messages).
        Scene scene = ss.scene();
        if (view && given(view->sun_elevation_deg)) scene.sun.elevation_deg = view->sun_elevation_deg;
        if (view && given(view->sun_rotation_deg)) {
            if (!std::isfinite(view->sun_rotation_deg))
                throw airmass::SceneError("sun.azimuth_deg = " + number(view->sun_rotation_deg) + ": must be finite");
            scene.sun.azimuth_deg = std::fmod(view->sun_rotation_deg, 360.0);
        }
        if (view && given(view->altitude_m)) scene.observer.altitude_m = view->altitude_m;
        airmass::validate(scene);
        airmass::SkySettings settings = ss.settings();
        if (options) {
            const airmass::SkySettings asked = sky_settings_from(*options);
            if (asked.view.chapman != settings.view.chapman)
                throw airmass::SkyError("sky_options.chapman = \"" +
                                        std::string(airmass::chapman_method_name(asked.view.chapman)) +
                                        "\": the session was made with \"" +
                                        std::string(airmass::chapman_method_name(settings.view.chapman)) +
                                        "\" (its atmosphere and tables depend on it); create another session");
            if (asked.multiple.enabled != settings.multiple.enabled)
                throw airmass::SkyError("sky_options.multiple_scattering = " +
                                        std::to_string(options->multiple_scattering) + ": the session was made with " +
                                        (settings.multiple.enabled ? "1" : "0") + "; create another session");
            settings = asked;
        }
        check_float_count(settings, float_count);
        const glm::dvec3 sun = airmass::sun_direction(scene.sun.elevation_deg, scene.sun.azimuth_deg);
        airmass::FloatImage image;
        run_job(job, [&](const airmass::CancelFlag& cancel, std::atomic<double>& fraction) {
            image = ss.render(sun, scene.observer.altitude_m, settings, progress_hooks(cancel, fraction));
            if (cancel.requested()) throw airmass::Cancelled("sky: cancelled");
        });
        deliver_sky(scene, settings, image, rgba, metadata_json);
    });
}

void airmass_sky_session_free(airmass_sky_session* session) { delete session; }

int32_t airmass_sun_light_at_observer(const airmass_scene_spec* spec, const char* chapman, airmass_sun_light* out,
                                      char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
        require_struct(out, "sun_light");
        const Scene scene = build_scene(spec);
        const airmass::SunLight light =
            airmass::sun_light_at_observer(scene, chapman_from(chapman, airmass::EvalSettings{}.chapman, "chapman"));
        airmass_sun_light result{};
        result.struct_size = sizeof(airmass_sun_light);
        for (int c = 0; c < 3; ++c) {
            result.direction[c] = light.direction[c];
            result.irradiance_rgb[c] = light.irradiance_rgb[c];
            result.irradiance_top_rgb[c] = light.irradiance_top_rgb[c];
            result.transmittance_rgb[c] =
                result.irradiance_top_rgb[c] > 0.0 ? result.irradiance_rgb[c] / result.irradiance_top_rgb[c] : 0.0;
        }
        result.angular_diameter_deg = light.angular_diameter_deg;
        result.below_horizon = light.below_horizon ? 1 : 0;
        *out = result;
    });
}


int32_t airmass_solar_query_init(airmass_solar_query* query) {
    if (!init_size_ok(query)) return AIRMASS_INVALID_ARGUMENT;
    *query = airmass_solar_query{};
    query->struct_size = sizeof(airmass_solar_query);
    query->utc = nullptr;
    query->site_elevation_m = 0.0;
    query->delta_t_s = std::numeric_limits<double>::quiet_NaN();
    query->delta_ut1_s = 0.0;
    return AIRMASS_OK;
}

int32_t airmass_solar_position(const airmass_solar_query* query, airmass_sun_position* out, char* message,
                               size_t message_size) {
    return guarded(message, message_size, [&] {
        require_struct(query, "solar_query");
        require_struct(out, "sun_position");
        if (!query->utc) throw AbiError(AIRMASS_INVALID_ARGUMENT, "solar_query.utc: NULL (an ISO 8601 time with zone)");
        try {
            airmass::SolarPositionInput input;
            input.latitude_deg = query->latitude_deg;
            input.longitude_deg = query->longitude_deg;
            input.time = airmass::parse_utc(query->utc, "utc");
            input.elevation_m = query->site_elevation_m;
            if (given(query->delta_t_s)) input.delta_t_s = query->delta_t_s;
            input.delta_ut1_s = query->delta_ut1_s;
            const airmass::SolarPosition p = airmass::solar_position(input);  // validates
            airmass_sun_position result{};
            result.struct_size = sizeof(airmass_sun_position);
            result.elevation_deg = p.elevation_deg;
            result.azimuth_deg = p.azimuth_deg;
            result.zenith_deg = p.zenith_deg;
            result.blender_elevation_deg = p.blender_elevation_deg;
            result.blender_rotation_deg = p.blender_rotation_deg;
            result.julian_day = p.julian_day;
            result.delta_t_s = p.delta_t_s;
            *out = result;
        } catch (const airmass::SolarPositionError& e) {
            throw AbiError(AIRMASS_INVALID_ARGUMENT, e.what());
        }
    });
}


}  // extern "C"
