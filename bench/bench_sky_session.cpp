// Issue 14 goal 3: a 1024 × 512 sky for a new sun direction over the same atmosphere, in
// process, through the C ABI's sky session (airmass_c.h, ABI 6) — against the one-shot
// airmass_render_sky call measured in the same run, with the preview's error against the
// full-quality image of the same sun.
//
//   bench_sky_session [--preset earth] [--width 1024] [--threads 2] [--suns 8]
//                     [--preview-samples 16] [--preview-grid 32] [--preview-ms-grid 16] [--preview-ms-samples 32]
//                     [--profile full|preview]  (only a session and --suns renders: for perf)
//
// Prints wall-clock times (std::chrono::steady_clock, median over the suns or repeats):
//   one-shot airmass_render_sky (the baseline: atmosphere, tables, image on every call);
//   session create, cold (tables computed) through the C ABI; and, through the C++ SkySession
//     the C ABI wraps, cold and warm with a table cache on disk (a temporary folder:
//     DiskTableStore, as the CLI's cache) — the C ABI itself keeps no cache (it writes no files):
//     a host keeps the session;
//   per sun direction: the session's render at full quality (the session's options, the
//     library's defaults) and at the preview quality;
//   the preview's error against the full-quality image of the same sun: per pixel
//     max over R, G, B of |Δ| / Y_full (Y the Rec.709 luminance), weighted by the pixel's
//     solid angle: mean, 95th percentile and max over the image, the worst of the suns.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <string>
#include <vector>

#include <unistd.h>

#include "airmass/airmass_c.h"
#include "airmass/scene_io.hpp"
#include "airmass/sky.hpp"
#include "airmass/table_cache.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// CPU time of the whole process (every thread), seconds: on a shared machine the wall clock
// includes other people's work; CPU / threads is what a quiet machine's wall clock would be
// for perfectly parallel work.
double cpu_now() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

void require(int32_t status, const char* what, const char* msg) {
    if (status != AIRMASS_OK) {
        std::fprintf(stderr, "bench_sky_session: %s failed (%s): %s\n", what, airmass_status_name(status), msg);
        std::exit(1);
    }
}

struct Error {
    double mean = 0, p95 = 0, max = 0;
};

// Per pixel max_channel |a − ref| / Y_ref, weighted by solid angle.
Error image_error(const std::vector<float>& a, const std::vector<float>& ref, int W, int H) {
    std::vector<std::pair<double, double>> e;  // (error, weight)
    e.reserve(std::size_t(W) * H);
    double wsum = 0.0, sum = 0.0;
    for (int y = 0; y < H; ++y) {
        const double w = airmass::equirect_pixel_solid_angle(y, W, H);
        for (int x = 0; x < W; ++x) {
            const float* r = &ref[(std::size_t(y) * W + x) * 4];
            const float* p = &a[(std::size_t(y) * W + x) * 4];
            const double Y = 0.2126 * r[0] + 0.7152 * r[1] + 0.0722 * r[2];
            if (!(Y > 0.0)) continue;
            double d = 0.0;
            for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(double(p[c]) - double(r[c])) / Y);
            e.emplace_back(d, w);
            wsum += w;
            sum += w * d;
        }
    }
    Error out;
    if (e.empty()) return out;
    std::sort(e.begin(), e.end());
    out.mean = sum / wsum;
    out.max = e.back().first;
    double acc = 0.0;
    for (const auto& [d, w] : e) {
        acc += w;
        if (acc >= 0.95 * wsum) {
            out.p95 = d;
            break;
        }
    }
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    std::string preset = "earth";
    std::string profile;  // "full" or "preview": only a session and --suns renders of that quality (for perf)
    int width = 1024, threads = 2, suns = 8, pv_samples = 16, pv_grid = 32, pv_ms_grid = 16, pv_ms_samples = 32;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string k = argv[i];
        const char* v = argv[i + 1];
        if (k == "--preset") preset = v;
        else if (k == "--width") width = std::atoi(v);
        else if (k == "--threads") threads = std::atoi(v);
        else if (k == "--suns") suns = std::atoi(v);
        else if (k == "--preview-samples") pv_samples = std::atoi(v);
        else if (k == "--preview-grid") pv_grid = std::atoi(v);
        else if (k == "--preview-ms-grid") pv_ms_grid = std::atoi(v);
        else if (k == "--preview-ms-samples") pv_ms_samples = std::atoi(v);
        else if (k == "--profile") profile = v;
        else {
            std::fprintf(stderr, "bench_sky_session: unknown option %s\n", k.c_str());
            return 2;
        }
    }
    const int H = width / 2;
    const std::size_t n = std::size_t(width) * H * 4;
    char msg[1024];

    airmass_scene_spec spec;
    spec.struct_size = sizeof spec;
    airmass_scene_spec_init(&spec);
    spec.preset = preset.c_str();
    airmass_sky_options full;
    full.struct_size = sizeof full;
    airmass_sky_options_init(&full);
    full.width = width;
    full.height = H;
    full.threads = threads;
    airmass_sky_options preview = full;
    preview.view_samples = pv_samples;
    preview.grid = pv_grid;
    preview.multiple_grid = pv_ms_grid;
    preview.multiple_samples = pv_ms_samples;

    std::printf("bench_sky_session: preset %s, %d x %d, %d threads, %d sun directions, C ABI %d\n", preset.c_str(),
                width, H, threads, suns, airmass_abi_version());
    std::printf("full quality: the library's defaults (view samples %d, grid %d = auto, multiple-scattering view %d)\n",
                full.view_samples, full.grid, full.multiple_grid);
    std::printf("preview:      view samples %d, grid %d, multiple-scattering view %d, %d intervals per ray\n\n",
                pv_samples, pv_grid, pv_ms_grid, pv_ms_samples);

    std::vector<float> a(n), b(n);
    if (!profile.empty()) {
        airmass_sky_session* session = nullptr;
        require(airmass_sky_session_create(&spec, &full, nullptr, &session, msg, sizeof msg), "session_create", msg);
        airmass_sky_view view;
        view.struct_size = sizeof view;
        airmass_sky_view_init(&view);
        const double c0 = cpu_now();
        for (int k = 0; k < suns; ++k) {
            view.sun_elevation_deg = -4.0 + std::fmod(3.7 * k, 74.0);
            view.sun_rotation_deg = 13.0 + 47.0 * k;
            require(airmass_sky_session_render(session, &view, profile == "full" ? &full : &preview, a.data(), n,
                                               nullptr, nullptr, msg, sizeof msg),
                    "session_render", msg);
        }
        std::printf("%s: %.4f s CPU per sun\n", profile.c_str(), (cpu_now() - c0) / suns);
        airmass_sky_session_free(session);
        return 0;
    }
    // Sun directions a drag might visit: elevations from −4° to 70°, rotations all round.
    std::vector<std::pair<double, double>> sun;
    for (int k = 0; k < suns; ++k) sun.emplace_back(-4.0 + 74.0 * k / std::max(1, suns - 1), 13.0 + 47.0 * k);

    // Baseline: the one-shot call (atmosphere, tables and image each time), twice.
    std::vector<double> t_oneshot, c_oneshot;
    for (int r = 0; r < 2; ++r) {
        spec.sun_elevation_deg = sun[std::size_t(r)].first;
        spec.sun_rotation_deg = sun[std::size_t(r)].second;
        const auto t0 = Clock::now();
        const double c0 = cpu_now();
        require(airmass_render_sky(&spec, &full, a.data(), n, nullptr, nullptr, msg, sizeof msg), "render_sky", msg);
        t_oneshot.push_back(seconds_since(t0));
        c_oneshot.push_back(cpu_now() - c0);
    }
    spec.sun_elevation_deg = spec.sun_rotation_deg = std::nan("");

    // Session create through the C ABI (tables computed: the C ABI keeps no cache).
    airmass_sky_session* session = nullptr;
    auto t0 = Clock::now();
    const double c_create0 = cpu_now();
    require(airmass_sky_session_create(&spec, &full, nullptr, &session, msg, sizeof msg), "session_create", msg);
    const double t_create = seconds_since(t0), c_create = cpu_now() - c_create0;

    // The same session in C++ with a table cache on disk: cold (computed, stored), warm (read).
    const auto dir = std::filesystem::temp_directory_path() / ("airmass-bench-cache-" + std::to_string(::getpid()));
    double t_cpp_cold = 0, t_cpp_warm = 0, c_cpp_cold = 0, c_cpp_warm = 0;
    {
        airmass::DiskTableStore store(dir, std::uintmax_t(1) << 30);
        airmass::SkySettings s;
        s.width = width;
        s.height = H;
        s.threads = threads;
        s.multiple.tables.store = &store;
        const airmass::Scene scene = airmass::load_preset(preset);
        t0 = Clock::now();
        double c0 = cpu_now();
        { const airmass::SkySession cold(scene, s); }
        t_cpp_cold = seconds_since(t0);
        c_cpp_cold = cpu_now() - c0;
        t0 = Clock::now();
        c0 = cpu_now();
        { const airmass::SkySession warm(scene, s); }
        t_cpp_warm = seconds_since(t0);
        c_cpp_warm = cpu_now() - c0;
        std::error_code ec;
        std::filesystem::remove_all(dir, ec);
    }

    // Per sun direction: full quality and preview from the session; the preview's error.
    std::vector<double> t_full, t_preview, c_full, c_preview;
    Error worst;
    airmass_sky_view view;
    view.struct_size = sizeof view;
    airmass_sky_view_init(&view);
    for (const auto& [e, r] : sun) {
        view.sun_elevation_deg = e;
        view.sun_rotation_deg = r;
        t0 = Clock::now();
        double c0 = cpu_now();
        require(airmass_sky_session_render(session, &view, &full, a.data(), n, nullptr, nullptr, msg, sizeof msg),
                "session_render full", msg);
        t_full.push_back(seconds_since(t0));
        c_full.push_back(cpu_now() - c0);
        t0 = Clock::now();
        c0 = cpu_now();
        require(airmass_sky_session_render(session, &view, &preview, b.data(), n, nullptr, nullptr, msg, sizeof msg),
                "session_render preview", msg);
        t_preview.push_back(seconds_since(t0));
        c_preview.push_back(cpu_now() - c0);
        const Error err = image_error(b, a, width, H);
        worst.mean = std::max(worst.mean, err.mean);
        worst.p95 = std::max(worst.p95, err.p95);
        worst.max = std::max(worst.max, err.max);
    }
    airmass_sky_session_free(session);

    const double base = median(t_oneshot), cbase = median(c_oneshot);
    double load[3] = {0, 0, 0};
    if (getloadavg(load, 3) < 0) load[0] = -1;
    std::printf("load average %.2f (wall times on a shared machine include other work; CPU is this process's)\n\n",
                load[0]);
    std::printf("| what | wall s | CPU s (all threads) | one-shot / this (wall, CPU) |\n|---|---:|---:|---:|\n");
    std::printf("| one-shot airmass_render_sky (baseline; atmosphere + tables + image per call) | %.3f | %.3f | 1.0x, 1.0x |\n",
                base, cbase);
    std::printf("| session create, C ABI (tables computed) | %.3f | %.3f | |\n", t_create, c_create);
    std::printf("| session create, C++ with a disk table cache: cold (computed, stored) | %.3f | %.3f | |\n", t_cpp_cold,
                c_cpp_cold);
    std::printf("| same, warm (tables read from the cache) | %.3f | %.3f | |\n", t_cpp_warm, c_cpp_warm);
    std::printf("| per sun direction, full quality (median of %d) | %.4f | %.4f | %.1fx, %.1fx |\n", suns,
                median(t_full), median(c_full), base / median(t_full), cbase / median(c_full));
    std::printf("| per sun direction, preview (median of %d) | %.4f | %.4f | %.1fx, %.1fx |\n", suns,
                median(t_preview), median(c_preview), base / median(t_preview), cbase / median(c_preview));
    std::printf("\npreview vs full quality, same sun (worst of the %d suns): mean %.3f %%, p95 %.3f %%, max %.2f %%\n",
                suns, 100 * worst.mean, 100 * worst.p95, 100 * worst.max);
    std::printf("goal 3 (issue 14): preview <= 50 ms on %d threads: wall %s (%.1f ms); CPU / threads %s (%.1f ms)\n",
                threads, median(t_preview) <= 0.050 ? "yes" : "NO", 1e3 * median(t_preview),
                median(c_preview) / threads <= 0.050 ? "yes" : "NO", 1e3 * median(c_preview) / threads);
    return 0;
}
