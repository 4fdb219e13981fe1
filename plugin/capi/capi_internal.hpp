// Internal to the C ABI (airmass_c.cpp, airmass_c_volume.cpp): the exception-proof shell every
// exported function runs in, the scene a spec describes, and the long-call runner.
#pragma once

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
#include "airmass/optical_depth.hpp"
#include "airmass/progress.hpp"
#include "airmass/scene.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/sky.hpp"
#include "airmass/vdb_export.hpp"


struct airmass_cancel_token {
    airmass::CancelFlag flag;
};

namespace airmass::capi {

using airmass::Scene;


// An error detected by this shell itself, with the status it maps to.
struct AbiError : std::runtime_error {
    AbiError(airmass_status s, const std::string& what) : std::runtime_error(what), status(s) {}
    airmass_status status;
};

inline void write_message(char* message, std::size_t size, const std::string& text) noexcept {
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
    } catch (const airmass::VdbError& e) {
        // vdb_export reports bad options, limits and unwritable outputs with one type; an
        // output problem names the path and says "write"/"directory".
        const std::string what = e.what();
        const bool io = what.find("cannot") != std::string::npos &&
                        (what.find("write") != std::string::npos || what.find("director") != std::string::npos ||
                         what.find("create") != std::string::npos || what.find("rename") != std::string::npos);
        write_message(message, message_size, what);
        return io ? AIRMASS_IO_ERROR : AIRMASS_SETTINGS_ERROR;
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

inline char* duplicate(const std::string& s) {
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

// For the *_init functions (ABI 4): the caller set struct_size; anything else is refused untouched.
template <class Struct>
bool init_size_ok(const Struct* p) {
    return p && p->struct_size == sizeof(Struct);
}

inline std::string number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

inline bool given(double v) { return !std::isnan(v); }

// The scene a spec describes: parsed, overridden and validated (SceneError names the field).
Scene build_scene(const airmass_scene_spec* spec);

airmass::ChapmanMethod chapman_from(const char* name, airmass::ChapmanMethod fallback, const char* field);

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

}  // namespace airmass::capi
