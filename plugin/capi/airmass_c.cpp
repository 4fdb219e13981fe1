// The C ABI (airmass_c.h): a thin, exception-proof shell over the C++ library.
//
// Every exported function is `guarded`: the body runs inside one try block that maps
// each library exception type to a status code and copies its message into the caller's
// buffer. Long calls run on a worker thread while the calling thread reports progress,
// so a host's callback always runs on the thread that called us (Python's GIL and
// Blender's main-thread rules both need that).
#include "airmass/airmass_c.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <future>
#include <limits>
#include <new>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "airmass/atmosphere.hpp"
#include "airmass/chapman.hpp"
#include "airmass/color.hpp"
#include "airmass/geometry.hpp"
#include "airmass/image_io.hpp"
#include "airmass/optical_depth.hpp"
#include "airmass/progress.hpp"
#include "airmass/scene.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/sky.hpp"
#if AIRMASS_C_HAVE_VDB
#include "airmass/vdb_export.hpp"
#endif

#ifndef AIRMASS_VERSION_STRING
#define AIRMASS_VERSION_STRING "unknown"
#endif

struct airmass_cancel_token {
    airmass::CancelFlag flag;
};

namespace {

using airmass::Scene;

// An error detected by this shell itself, with the status it maps to.
struct AbiError : std::runtime_error {
    AbiError(airmass_status s, const std::string& what) : std::runtime_error(what), status(s) {}
    airmass_status status;
};

void write_message(char* message, std::size_t size, const std::string& text) noexcept {
    if (!message || size == 0) return;
    const std::size_t n = std::min(size - 1, text.size());
    std::memcpy(message, text.data(), n);
    message[n] = '\0';
}

// Runs `body` (returning nothing) and converts whatever it throws into a status + message.
template <class Body>
int32_t guarded(char* message, std::size_t message_size, Body&& body) noexcept {
    try {
        write_message(message, message_size, "");
        body();
        return AIRMASS_OK;
    } catch (const AbiError& e) {
        write_message(message, message_size, e.what());
        return e.status;
    } catch (const airmass::Cancelled& e) {
        write_message(message, message_size, e.what());
        return AIRMASS_CANCELLED;
    } catch (const airmass::SceneError& e) {
        write_message(message, message_size, e.what());
        return AIRMASS_SCENE_ERROR;
    } catch (const airmass::SkyError& e) {
        write_message(message, message_size, e.what());
        return AIRMASS_SETTINGS_ERROR;
    } catch (const airmass::ImageWriteError& e) {
        write_message(message, message_size, e.what());
        return AIRMASS_IO_ERROR;
#if AIRMASS_C_HAVE_VDB
    } catch (const airmass::VdbError& e) {
        // vdb_export reports bad options, limits and unwritable outputs with one type; an
        // output problem names the path and says "write"/"directory".
        const std::string what = e.what();
        const bool io = what.find("cannot") != std::string::npos &&
                        (what.find("write") != std::string::npos || what.find("director") != std::string::npos ||
                         what.find("create") != std::string::npos || what.find("rename") != std::string::npos);
        write_message(message, message_size, what);
        return io ? AIRMASS_IO_ERROR : AIRMASS_SETTINGS_ERROR;
#endif
    } catch (const std::filesystem::filesystem_error& e) {
        write_message(message, message_size, e.what());
        return AIRMASS_IO_ERROR;
    } catch (const std::invalid_argument& e) {
        write_message(message, message_size, e.what());
        return AIRMASS_SETTINGS_ERROR;
    } catch (const std::bad_alloc&) {
        write_message(message, message_size, "out of memory");
        return AIRMASS_INTERNAL_ERROR;
    } catch (const std::exception& e) {
        write_message(message, message_size, std::string("internal error: ") + e.what());
        return AIRMASS_INTERNAL_ERROR;
    } catch (...) {
        write_message(message, message_size, "internal error: unknown exception");
        return AIRMASS_INTERNAL_ERROR;
    }
}

char* duplicate(const std::string& s) {
    char* out = static_cast<char*>(std::malloc(s.size() + 1));
    if (!out) throw std::bad_alloc();
    std::memcpy(out, s.c_str(), s.size() + 1);
    return out;
}

template <class Struct>
void require_struct(const Struct* p, const char* what) {
    if (!p) throw AbiError(AIRMASS_INVALID_ARGUMENT, std::string(what) + ": NULL pointer");
    if (p->struct_size != sizeof(Struct))
        throw AbiError(AIRMASS_INVALID_ARGUMENT,
                       std::string(what) + ".struct_size = " + std::to_string(p->struct_size) + ": this library (ABI " +
                           std::to_string(AIRMASS_C_ABI_VERSION) + ") expects " + std::to_string(sizeof(Struct)) +
                           " — host and library versions differ");
}

std::string number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

bool given(double v) { return !std::isnan(v); }

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

// The scene a spec describes: parsed, overridden and validated (SceneError names the field).
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

// ---- long calls -----------------------------------------------------------------------------

// Runs `work(cancel, done_fraction)` on a worker thread; the calling thread reports progress
// through the job's callback and turns a nonzero return, or the host's cancel token, into a
// request on the worker's own flag (the host's token is only read, never written, so it can
// be reused). `work` polls the flag and stores its progress (0..1) in the atomic. The call
// counts as cancelled only if the work stopped (threw Cancelled); work that finished before
// it saw the request succeeds.
template <class Work>
void run_job(const airmass_job* job, Work&& work) {
    if (job) require_struct(job, "job");
    const airmass::CancelFlag* host = job && job->cancel ? &job->cancel->flag : nullptr;
    if (host && host->requested()) throw airmass::Cancelled("cancelled before it started");
    std::atomic<double> fraction{0.0};
    if (!job || !job->progress) {
        airmass::CancelFlag own;
        work(host ? *host : own, fraction);
        return;
    }
    airmass::CancelFlag worker_cancel;
    auto future = std::async(std::launch::async, [&] { work(worker_cancel, fraction); });
    double reported = -1.0;
    bool stop = false;
    while (future.wait_for(std::chrono::milliseconds(50)) != std::future_status::ready) {
        const double f = fraction.load(std::memory_order_relaxed);
        if (f != reported && !stop) {
            reported = f;
            if (job->progress(job->user, f) != 0) stop = true;
        }
        if (stop || (host && host->requested())) worker_cancel.request();
    }
    future.get();  // rethrows the worker's exception (Cancelled when it stopped)
    job->progress(job->user, 1.0);
}

#if AIRMASS_C_HAVE_VDB
airmass::VdbOptions vdb_options_from(const airmass_vdb_options* o) {
    require_struct(o, "vdb_options");
    airmass::VdbOptions v;
    const std::string region = o->region ? o->region : "planet";
    if (region == "planet") v.region = airmass::VdbRegion::planet;
    else if (region == "view") v.region = airmass::VdbRegion::view;
    else if (region == "box") v.region = airmass::VdbRegion::box;
    else throw AbiError(AIRMASS_INVALID_ARGUMENT, "--region = \"" + region + "\": must be planet, view or box");
    const std::string unit = o->unit ? o->unit : "km";
    if (unit == "km") v.unit = airmass::LengthUnit::km;
    else if (unit == "m") v.unit = airmass::LengthUnit::m;
    else throw AbiError(AIRMASS_INVALID_ARGUMENT, "--units = \"" + unit + "\": must be km or m");
    v.origin = o->origin_center ? airmass::PlanetOrigin::center : airmass::PlanetOrigin::surface;
    if (given(o->voxel_size) && o->voxel_size > 0.0) v.voxel_size = o->voxel_size;
    else if (given(o->voxel_size) && o->voxel_size < 0.0)
        throw airmass::VdbError("--voxel-size " + number(o->voxel_size) + ": must be > 0 (or 0 for automatic)");
    std::copy(o->box, o->box + 6, v.box.begin());
    if (given(o->tolerance)) v.tolerance = o->tolerance;
    if (given(o->max_dense_mb)) v.max_dense_mb = o->max_dense_mb;
    v.tile_voxels = o->tile_voxels;
    return v;
}
#endif

#if !AIRMASS_C_HAVE_VDB
[[noreturn]] void no_vdb() {
    throw AbiError(AIRMASS_UNSUPPORTED, "this libairmass_c was built without vdb_export (no OpenVDB support)");
}
#endif

}  // namespace

extern "C" {

int32_t airmass_abi_version(void) { return AIRMASS_C_ABI_VERSION; }

const char* airmass_version_string(void) { return AIRMASS_VERSION_STRING; }

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

int32_t airmass_has_vdb(void) { return AIRMASS_C_HAVE_VDB ? 1 : 0; }

void airmass_string_free(char* s) { std::free(s); }

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

void airmass_scene_spec_init(airmass_scene_spec* spec) {
    if (!spec) return;
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

void airmass_sky_options_init(airmass_sky_options* options) {
    if (!options) return;
    const airmass::SkySettings d;
    *options = airmass_sky_options{};
    options->struct_size = sizeof(airmass_sky_options);
    options->width = d.width;
    options->height = 0;
    options->view_samples = d.view_samples;
    options->chapman = nullptr;
    options->sun_disc = d.sun_disc ? 1 : 0;
    options->upper_only = d.region == airmass::SkyRegion::upper ? 1 : 0;
    options->threads = d.threads;
    options->grid = d.grid;
    options->multiple_scattering = d.multiple_scattering ? 1 : 0;
}

int32_t airmass_write_sky_exr(const airmass_scene_spec* spec, const airmass_sky_options* options, const char* path,
                              const airmass_job* job, char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
        require_struct(options, "sky_options");
        if (!path || path[0] == '\0') throw AbiError(AIRMASS_INVALID_ARGUMENT, "path: empty");
        const Scene scene = build_scene(spec);
        airmass::SkySettings settings;
        settings.width = options->width;
        settings.height = options->height > 0 ? options->height : std::max(2, options->width / 2);
        settings.view_samples = options->view_samples;
        settings.chapman = chapman_from(options->chapman, settings.chapman, "sky_options.chapman");
        settings.sun_disc = options->sun_disc != 0;
        settings.region = options->upper_only ? airmass::SkyRegion::upper : airmass::SkyRegion::full;
        settings.threads = options->threads;
        settings.grid = options->grid;
        settings.multiple_scattering = options->multiple_scattering != 0;
        airmass::validate(settings);
        // Fail on an unwritable destination before the render, not after it.
        airmass::check_exr_destination(path);
        airmass::FloatImage image;
        run_job(job, [&](const airmass::CancelFlag& cancel, std::atomic<double>& fraction) {
            std::atomic<std::size_t> units{0};
            airmass::RenderHooks hooks;
            hooks.cancel = &cancel;
            hooks.work_done = [&](std::size_t n, std::size_t total) {
                const std::size_t done = units.fetch_add(n, std::memory_order_relaxed) + n;
                if (total > 0) fraction.store(std::min(1.0, double(done) / double(total)), std::memory_order_relaxed);
            };
            image = airmass::render_sky(scene, settings, hooks);
            if (cancel.requested()) throw airmass::Cancelled("sky: cancelled; no file written");
        });
        airmass::write_exr_atomic(path, image, airmass::sky_metadata(scene, settings));
    });
}

int32_t airmass_sun_light_at_observer(const airmass_scene_spec* spec, const char* chapman, airmass_sun_light* out,
                                      char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
        require_struct(out, "sun_light");
        const Scene scene = build_scene(spec);
        airmass::EvalSettings settings;
        settings.chapman = chapman_from(chapman, settings.chapman, "chapman");
        const std::vector<double> wavelengths = airmass::basis_wavelengths_nm(scene.basis);
        const airmass::Atmosphere atmosphere = airmass::compile_atmosphere(scene, wavelengths, settings);

        // Direct sunlight at the observer: E(λ)·T(λ) with T along the ray toward the sun
        // (0 when the planet is in the way), mapped to RGB exactly as the sky's sun disc is.
        const glm::dvec3 sun = airmass::sun_direction(scene.sun.elevation_deg, scene.sun.azimuth_deg);
        const double r0 = scene.planet.radius_m + scene.observer.altitude_m;
        const auto ray = airmass::PlanetRay<double>::from_vectors(scene.planet.radius_m, airmass::Vec3<double>(0, 0, r0),
                                                                  airmass::Vec3<double>(sun.x, sun.y, sun.z));
        std::vector<double> transmittance(wavelengths.size(), 1.0);
        const bool blocked = airmass::hits_ground(ray);
        if (blocked)
            std::fill(transmittance.begin(), transmittance.end(), 0.0);
        else
            airmass::transmittance(atmosphere, ray, 0.0, std::numeric_limits<double>::infinity(), transmittance);
        std::vector<double> top(wavelengths.size()), bottom(wavelengths.size());
        for (std::size_t w = 0; w < wavelengths.size(); ++w) {
            top[w] = atmosphere.sun_irradiance[w];
            bottom[w] = top[w] * transmittance[w];
        }
        const airmass::SpectrumToRgb to_rgb = airmass::spectrum_to_rgb(scene.basis);
        const airmass::Vec3d rgb = to_rgb.apply(bottom);
        const airmass::Vec3d rgb_top = to_rgb.apply(top);

        airmass_sun_light result{};
        result.struct_size = sizeof(airmass_sun_light);
        result.direction[0] = sun.x;
        result.direction[1] = sun.y;
        result.direction[2] = sun.z;
        for (int c = 0; c < 3; ++c) {
            // Clip the tiny negative values a wide-gamut spectrum can give after the matrix.
            result.irradiance_rgb[c] = std::max(0.0, rgb[c]);
            result.irradiance_top_rgb[c] = std::max(0.0, rgb_top[c]);
            result.transmittance_rgb[c] =
                result.irradiance_top_rgb[c] > 0.0 ? result.irradiance_rgb[c] / result.irradiance_top_rgb[c] : 0.0;
        }
        result.angular_diameter_deg = 2.0 * scene.sun.angular_radius_deg;
        result.below_horizon = blocked ? 1 : 0;
        *out = result;
    });
}

void airmass_vdb_options_init(airmass_vdb_options* options) {
    if (!options) return;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    *options = airmass_vdb_options{};
    options->struct_size = sizeof(airmass_vdb_options);
    options->region = "planet";
    options->unit = "km";
    options->origin_center = 0;
    options->voxel_size = nan;
    options->tolerance = nan;
    options->max_dense_mb = nan;
    options->tile_voxels = 0;
}

int32_t airmass_write_vdb(const airmass_scene_spec* spec, const airmass_vdb_options* options, const char* path,
                          const airmass_job* job, char** stats_json, char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
#if AIRMASS_C_HAVE_VDB
        const airmass::VdbOptions vdb = vdb_options_from(options);
        if (!path || path[0] == '\0') throw AbiError(AIRMASS_INVALID_ARGUMENT, "path: empty");
        const Scene scene = build_scene(spec);
        airmass::VdbStats stats;
        run_job(job, [&](const airmass::CancelFlag& cancel, std::atomic<double>& fraction) {
            airmass::VdbRunOptions run;
            run.cancel = &cancel;
            run.progress = [&](double f) { fraction.store(std::clamp(f, 0.0, 1.0), std::memory_order_relaxed); };
            stats = airmass::export_vdb(scene, vdb, path, run);
        });
        if (stats_json) {
            nlohmann::json j;
            j["files"] = nlohmann::json::array();
            for (const auto& f : stats.files) j["files"].push_back(f.string());
            j["voxel_size"] = stats.voxel_size;
            j["unit"] = std::string(airmass::length_unit_name(stats.unit));
            j["tiles"] = stats.tiles;
            j["active_voxels"] = stats.active_voxels;
            j["dense_bytes"] = stats.dense_bytes;
            j["memory_bytes"] = stats.memory_bytes;
            j["file_bytes"] = stats.file_bytes;
            j["build_seconds"] = stats.build_seconds;
            j["summary"] = stats.summary();
            nlohmann::json grids = nlohmann::json::array();
            for (const auto& g : stats.grids)
                grids.push_back({{"name", g.name}, {"tile", g.tile}, {"active_voxels", g.active_voxels},
                                 {"dense_voxels", g.dense_voxels}});
            j["grids"] = grids;
            *stats_json = duplicate(j.dump());
        }
#else
        (void)spec, (void)options, (void)path, (void)job, (void)stats_json;
        no_vdb();
#endif
    });
}

int32_t airmass_analytic_density_json(const airmass_scene_spec* spec, const airmass_vdb_options* options,
                                      char** json, char* message, size_t message_size) {
    return guarded(message, message_size, [&] {
#if AIRMASS_C_HAVE_VDB
        const airmass::VdbOptions vdb = vdb_options_from(options);
        if (!json) throw AbiError(AIRMASS_INVALID_ARGUMENT, "json: NULL pointer");
        const Scene scene = build_scene(spec);
        *json = duplicate(airmass::analytic_density_json(scene, vdb));
#else
        (void)spec, (void)options, (void)json;
        no_vdb();
#endif
    });
}

}  // extern "C"
