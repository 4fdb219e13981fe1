/* The C ABI's own tests, in C (the header must be plain C), built for every platform the
 * add-on ships: natively on Linux, under qemu-x86_64 -cpu Nehalem (a CPU without AVX), and
 * cross-built for Windows and run under wine64 (tests/capi/CMakeLists.txt, docs/portable.md).
 *
 *   capi_selftest [--pixels FILE] [--expect-simd NAME] [--quick]
 *
 * Prints one line per check and finally "N passed, M failed"; exits nonzero on any failure.
 * --pixels writes the small test sky (64 x 32 RGBA floats, earth preset, sun at 20 degrees)
 * as text, one value per line with 9 significant digits, so that a Linux and a Windows run
 * can be compared value by value (tests/portable/run_windows_selftest.sh); --expect-simd checks
 * that airmass_build_info names the kernels NAME ("baseline" under a pre-AVX CPU). --quick leaves
 * out the sky-session checks (their own multiple-scattering tables, the slowest part): for the
 * emulated old-CPU run, which is ≈ 75x slower than native and needs only the kernels and the
 * pixels (tests/portable/run_old_cpu_selftest.sh). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <time.h>

#include "airmass/airmass_c.h"

static int passed = 0, failed = 0;

static void check(int ok, const char* what, const char* detail) {
    if (ok) {
        ++passed;
        printf("ok   %s\n", what);
    } else {
        ++failed;
        printf("FAIL %s%s%s\n", what, detail && detail[0] ? ": " : "", detail ? detail : "");
    }
    fflush(stdout);
}

static int contains(const char* haystack, const char* needle) { return haystack && strstr(haystack, needle) != NULL; }

enum { W = 64, H = 32 };

static int progress_calls = 0;
static double last_fraction = -1.0;
static int32_t on_progress(void* user, double fraction) {
    (void)user;
    ++progress_calls;
    last_fraction = fraction;
    return 0;
}
static int32_t cancel_at_once(void* user, double fraction) {
    (void)user, (void)fraction;
    return 1;
}
static int cancel_calls = 0;
static int32_t count_and_cancel(void* user, double fraction) {
    (void)user, (void)fraction;
    ++cancel_calls;
    return 1;
}

int main(int argc, char** argv) {
    const char* pixels_path = NULL;
    const char* expect_simd = NULL;
    int quick = 0;
    for (int i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--pixels") == 0 && i + 1 < argc) pixels_path = argv[++i];
        else if (strcmp(argv[i], "--expect-simd") == 0 && i + 1 < argc) expect_simd = argv[++i];
        else if (strcmp(argv[i], "--quick") == 0) quick = 1;
        else {
            fprintf(stderr, "usage: capi_selftest [--pixels FILE] [--expect-simd baseline|avx2] [--quick]\n");
            return 2;
        }
    }
    char msg[1024];
    char detail[1400];

    /* ---- version ---- */
    check(airmass_abi_version() == AIRMASS_C_ABI_VERSION, "abi version matches the header", "");
    check(airmass_version_string() && airmass_version_string()[0] != '\0', "version string", "");
    check(strcmp(airmass_status_name(AIRMASS_SCENE_ERROR), "AIRMASS_SCENE_ERROR") == 0, "status names", "");
    {
        char* info = NULL;
        const int32_t s = airmass_build_info(&info, msg, sizeof msg);
        check(s == AIRMASS_OK && contains(info, "\"simd\""), "build info names the SIMD kernels in use", msg);
        if (info) printf("     build info: %s\n", info);
        if (expect_simd) check(contains(info, expect_simd), "the expected kernels run", info);
        airmass_string_free(info);
    }

    /* ---- presets ---- */
    {
        char* names = NULL;
        const int32_t s = airmass_preset_names(&names, msg, sizeof msg);
        check(s == AIRMASS_OK && contains(names, "earth\n") && contains(names, "mars\n"), "preset names", msg);
        airmass_string_free(names);
    }

    /* ---- scene validation names the field ---- */
    airmass_scene_spec spec;
    spec.struct_size = sizeof spec; /* ABI 4: the host sets it, init checks it */
    spec.struct_size = sizeof spec;
    airmass_scene_spec_init(&spec);
    spec.preset = "earth";
    spec.planet_radius_m = -1.0;
    {
        const int32_t s = airmass_validate_scene(&spec, NULL, msg, sizeof msg);
        snprintf(detail, sizeof detail, "status %d, message '%s'", (int)s, msg);
        check(s == AIRMASS_SCENE_ERROR && contains(msg, "planet.radius_km"), "bad planet radius refused, field named",
              detail);
    }
    spec.struct_size = sizeof spec;
    airmass_scene_spec_init(&spec);
    spec.preset = "earth";
    spec.struct_size -= 8;
    {
        const int32_t s = airmass_validate_scene(&spec, NULL, msg, sizeof msg);
        check(s == AIRMASS_INVALID_ARGUMENT && contains(msg, "struct_size"), "stale struct_size refused", msg);
    }
    {
        /* ABI 4: *_init reads the host's struct_size and refuses (writing nothing) a wrong one. */
        airmass_scene_spec stale;
        memset(&stale, 0x5A, sizeof stale);
        stale.struct_size = (uint32_t)sizeof stale - 8;
        const int32_t s = airmass_scene_spec_init(&stale);
        check(s == AIRMASS_INVALID_ARGUMENT && stale.struct_size == sizeof stale - 8 && stale.preset != NULL,
              "scene_spec_init refuses a stale struct_size and writes nothing", "");
        airmass_vdb_block block;
        block.struct_size = sizeof block;
        check(airmass_vdb_block_init(&block) == AIRMASS_OK && block.max[0] == -1 && airmass_vdb_block_init(NULL) != 0,
              "vdb_block_init takes the right struct_size, refuses NULL", "");
    }
    spec.struct_size = sizeof spec;
    airmass_scene_spec_init(&spec);
    spec.preset = "no-such-preset";
    {
        const int32_t s = airmass_validate_scene(&spec, NULL, msg, sizeof msg);
        check(s == AIRMASS_SCENE_ERROR && contains(msg, "no-such-preset") && contains(msg, "earth"),
              "unknown preset refused, the available ones listed", msg);
    }

    /* ---- the sky into a buffer ---- */
    spec.struct_size = sizeof spec;
    airmass_scene_spec_init(&spec);
    /* The earth preset at 14 wavelengths instead of 48: the multiple-scattering tables are almost
     * all of this test's time (under qemu's Nehalem and under the sanitizers, minutes), and 14
     * (= 3 x 4 + 2) still runs every vector kernel's full lanes and its remainder. */
    spec.toml = "preset = \"earth\"\n[spectrum]\nbasis = \"spectral\"\n"
                "wavelengths_nm = [380, 410, 440, 470, 500, 530, 560, 590, 620, 650, 680, 710, 740, 770]\n";
    spec.source_name = "<earth at 14 wavelengths>";
    spec.sun_elevation_deg = 20.0;
    spec.sun_rotation_deg = 0.0;
    airmass_sky_options opt;
    opt.struct_size = sizeof opt;
    airmass_sky_options_init(&opt);
    opt.width = W;
    opt.height = H;
    opt.threads = 2;
    const size_t n = (size_t)W * H * 4;
    float* rgba = (float*)malloc(n * sizeof(float));
    if (!rgba) return 3;
    {
        const int32_t s = airmass_render_sky(&spec, &opt, rgba, n - 4, NULL, NULL, msg, sizeof msg);
        check(s == AIRMASS_INVALID_ARGUMENT && contains(msg, "float_count"), "wrong float_count refused", msg);
    }
    {
        const int32_t s = airmass_render_sky(&spec, &opt, NULL, n, NULL, NULL, msg, sizeof msg);
        check(s == AIRMASS_INVALID_ARGUMENT && contains(msg, "rgba"), "NULL buffer refused", msg);
    }
    {
        airmass_sky_options bad = opt;
        bad.width = -3;
        const int32_t s = airmass_render_sky(&spec, &bad, rgba, n, NULL, NULL, msg, sizeof msg);
        check(s != AIRMASS_OK && contains(msg, "width"), "negative width refused, field named", msg);
    }
    {
        airmass_job job;
        memset(&job, 0, sizeof job);
        job.struct_size = sizeof job;
        job.progress = on_progress;
        char* meta = NULL;
        const int32_t s = airmass_render_sky(&spec, &opt, rgba, n, &job, &meta, msg, sizeof msg);
        check(s == AIRMASS_OK, "render_sky 64x32", msg);
        check(progress_calls >= 1 && last_fraction == 1.0, "progress reported, ending at 1", "");
        check(contains(meta, "airmass:version"), "metadata carries airmass:version", meta ? meta : "(null)");
        airmass_string_free(meta);
        int finite = 1, alpha = 1;
        for (size_t i = 0; i < n; ++i) {
            if (!isfinite(rgba[i]) || rgba[i] < 0.0f) finite = 0;
            if (i % 4 == 3 && rgba[i] != 1.0f) alpha = 0;
        }
        check(finite, "every value finite and non-negative", "");
        check(alpha, "alpha is 1", "");
        /* The zenith row (top) is blue: B > G > R; the ground half is darker than the sky near the sun. */
        const float* zenith = rgba + ((size_t)0 * W + W / 4) * 4;
        snprintf(detail, sizeof detail, "zenith rgb %g %g %g", zenith[0], zenith[1], zenith[2]);
        check(zenith[2] > zenith[1] && zenith[1] > zenith[0] && zenith[0] > 0.0f, "zenith is blue", detail);
    }
    /* ---- sky sessions (ABI 6): one atmosphere, many suns; the pixels of a session render equal
     * airmass_render_sky's for the same sun (the one render path), bit for bit ---- */
    if (!quick) {
        airmass_scene_spec other = spec;
        other.sun_elevation_deg = 55.0; /* the session's default sun differs from the view's */
        other.sun_rotation_deg = 140.0;
        airmass_sky_session* session = NULL;
        int32_t s = airmass_sky_session_create(&other, &opt, NULL, &session, msg, sizeof msg);
        check(s == AIRMASS_OK && session != NULL, "sky session created", msg);
        airmass_sky_view view;
        view.struct_size = sizeof view;
        check(airmass_sky_view_init(&view) == AIRMASS_OK && isnan(view.sun_elevation_deg) && isnan(view.altitude_m),
              "sky_view_init: NaN keeps the session's values", "");
        float* buf = (float*)malloc(n * sizeof(float));
        if (!buf) return 3;
        /* first another sun, then the one-shot call's sun: the second image must not depend on the first */
        view.sun_elevation_deg = -4.0;
        view.sun_rotation_deg = 300.0;
        s = airmass_sky_session_render(session, &view, NULL, buf, n, NULL, NULL, msg, sizeof msg);
        check(s == AIRMASS_OK, "session render, sun -4 deg", msg);
        view.sun_elevation_deg = 20.0;
        view.sun_rotation_deg = 0.0;
        airmass_job job;
        memset(&job, 0, sizeof job);
        job.struct_size = sizeof job;
        job.progress = on_progress;
        progress_calls = 0;
        last_fraction = -1.0;
        char* meta = NULL;
        s = airmass_sky_session_render(session, &view, &opt, buf, n, &job, &meta, msg, sizeof msg);
        check(s == AIRMASS_OK, "session render, sun 20 deg", msg);
        check(progress_calls >= 1 && last_fraction == 1.0, "session render: progress ends at 1", "");
        check(contains(meta, "sun_elevation_deg\\\":20"), "session render: metadata carries the view's sun",
              meta ? meta : "(null)");
        airmass_string_free(meta);
        size_t differ = 0;
        for (size_t i = 0; i < n; ++i) differ += buf[i] != rgba[i];
        snprintf(detail, sizeof detail, "%zu of %zu values differ", differ, n);
        check(differ == 0, "session render equals airmass_render_sky for the same sun", detail);
        /* a preview quality: other size, samples and grid from the same session */
        airmass_sky_options small = opt;
        small.width = 32;
        small.height = 16;
        small.view_samples = 4;
        small.grid = 8; /* 9 × 9 × 2 = 162 nodes < 512 rays: the grid is used */
        small.multiple_grid = 8;
        s = airmass_sky_session_render(session, &view, &small, buf, (size_t)32 * 16 * 4, NULL, NULL, msg, sizeof msg);
        check(s == AIRMASS_OK, "session render at a preview quality", msg);
        airmass_sky_options exact = opt;
        exact.chapman = "exact";
        s = airmass_sky_session_render(session, &view, &exact, buf, n, NULL, NULL, msg, sizeof msg);
        check(s == AIRMASS_SETTINGS_ERROR && contains(msg, "chapman"), "session render: another chapman is refused, named",
              msg);
        airmass_sky_options no_ms = opt;
        no_ms.multiple_scattering = 0;
        s = airmass_sky_session_render(session, &view, &no_ms, buf, n, NULL, NULL, msg, sizeof msg);
        check(s == AIRMASS_SETTINGS_ERROR && contains(msg, "multiple_scattering"),
              "session render: multiple_scattering off is refused, named", msg);
        view.sun_elevation_deg = 95.0;
        s = airmass_sky_session_render(session, &view, NULL, buf, n, NULL, NULL, msg, sizeof msg);
        check(s == AIRMASS_SCENE_ERROR && contains(msg, "elevation"), "session render: sun elevation 95 refused, named",
              msg);
        view.sun_elevation_deg = 20.0;
        view.altitude_m = -5.0;
        s = airmass_sky_session_render(session, &view, NULL, buf, n, NULL, NULL, msg, sizeof msg);
        check(s == AIRMASS_SCENE_ERROR && contains(msg, "altitude"), "session render: negative altitude refused, named",
              msg);
        view.altitude_m = NAN;
        s = airmass_sky_session_render(session, &view, NULL, buf, n - 4, NULL, NULL, msg, sizeof msg);
        check(s == AIRMASS_INVALID_ARGUMENT && contains(msg, "float_count"), "session render: wrong float_count", msg);
        view.struct_size = 8;
        s = airmass_sky_session_render(session, &view, NULL, buf, n, NULL, NULL, msg, sizeof msg);
        check(s == AIRMASS_INVALID_ARGUMENT && contains(msg, "struct_size"), "session render: stale sky_view refused", msg);
        s = airmass_sky_session_render(NULL, NULL, NULL, buf, n, NULL, NULL, msg, sizeof msg);
        check(s == AIRMASS_INVALID_ARGUMENT && contains(msg, "session"), "session render: NULL session refused", msg);
        airmass_sky_session_free(session);
        airmass_sky_session_free(NULL);
        /* a cancelled create returns no session */
        memset(&job, 0, sizeof job);
        job.struct_size = sizeof job;
        job.cancel = airmass_cancel_token_new();
        airmass_cancel_token_request(job.cancel);
        session = (airmass_sky_session*)&job; /* must be reset to NULL */
        s = airmass_sky_session_create(&other, &opt, &job, &session, msg, sizeof msg);
        check(s == AIRMASS_CANCELLED && session == NULL, "a cancelled session create returns no session", msg);
        airmass_cancel_token_free(job.cancel);
        airmass_sky_options bad = opt;
        bad.multiple_grid = 1;
        s = airmass_sky_session_create(&other, &bad, NULL, &session, msg, sizeof msg);
        check(s == AIRMASS_SETTINGS_ERROR && contains(msg, "multiple_grid") && session == NULL,
              "session create: multiple_grid 1 refused, named", msg);
        free(buf);
    }
    if (pixels_path) {
        FILE* f = fopen(pixels_path, "w");
        check(f != NULL, "pixels file opened", pixels_path);
        if (f) {
            for (size_t i = 0; i < n; ++i) fprintf(f, "%.9g\n", rgba[i]);
            fclose(f);
        }
    }

    /* ---- cancellation ---- */
    {
        airmass_job job;
        memset(&job, 0, sizeof job);
        job.struct_size = sizeof job;
        job.cancel = airmass_cancel_token_new();
        airmass_cancel_token_request(job.cancel);
        const int32_t s = airmass_render_sky(&spec, &opt, rgba, n, &job, NULL, msg, sizeof msg);
        check(s == AIRMASS_CANCELLED, "a requested token cancels", msg);
        airmass_cancel_token_free(job.cancel);
        airmass_sky_options big = opt;
        big.width = 512;
        big.height = 256;
        float* buf = (float*)malloc((size_t)512 * 256 * 4 * sizeof(float));
        memset(&job, 0, sizeof job);
        job.struct_size = sizeof job;
        job.progress = cancel_at_once;
        const int32_t s2 = buf ? airmass_render_sky(&spec, &big, buf, (size_t)512 * 256 * 4, &job, NULL, msg, sizeof msg)
                               : -1;
        check(s2 == AIRMASS_CANCELLED || s2 == AIRMASS_OK, "a progress callback returning 1 stops the render", msg);
        free(buf);
    }

    /* ---- a long VDB plan (a 2000 x 2000 x 20 km box at 0.5 km voxels, 3.2e8 voxels: 11 s of
     * sampling on 2 threads when not cancelled; the first report comes after 50 ms) cancelled by the
     * progress callback at its first report: AIRMASS_CANCELLED, no plan, and no report after the
     * one that cancelled (the final 1.0 is not sent). Not under --quick; only where the library
     * has the volume functions. ---- */
    if (!quick && airmass_has_vdb()) {
        airmass_scene_spec vs;
        vs.struct_size = sizeof vs;
        airmass_scene_spec_init(&vs);
        vs.preset = "earth";
        airmass_vdb_options vo;
        vo.struct_size = sizeof vo;
        airmass_vdb_options_init(&vo);
        const double box[6] = {-1000.0, -1000.0, 0.0, 1000.0, 1000.0, 20.0};
        vo.region = "box";
        memcpy(vo.box, box, sizeof box);
        vo.voxel_size = 0.5;
        vo.max_dense_mb = 1e9;
        airmass_job job;
        memset(&job, 0, sizeof job);
        job.struct_size = sizeof job;
        job.progress = count_and_cancel;
        char* plan = NULL;
        const clock_t t0 = clock();
        const int32_t s = airmass_vdb_plan(&vs, &vo, NULL, &job, &plan, msg, sizeof msg);
        snprintf(detail, sizeof detail, "status %d (%s), plan %s, %d progress calls, %.2f s CPU", (int)s, msg,
                 plan ? "returned" : "NULL", cancel_calls, (double)(clock() - t0) / CLOCKS_PER_SEC);
        check(s == AIRMASS_CANCELLED && plan == NULL && cancel_calls == 1,
              "a long VDB plan cancelled at its first progress report: cancelled, no plan, no later report", detail);
        if (plan) airmass_string_free(plan);
    }

    /* ---- the sun's columns (ABI 7): at the ground, straight up, each constituent's vertical column
     * in km — closed forms of the earth preset's profiles: Rayleigh 8 (1 − e^−7.5), Mie 1.2
     * (1 − e^−50), the ozone tent 10–25–40 km 15 — and sizes outside [2, 4096] refused by name. ---- */
    if (airmass_has_vdb()) {
        airmass_scene_spec cs;
        cs.struct_size = sizeof cs;
        airmass_scene_spec_init(&cs);
        cs.preset = "earth";
        airmass_vdb_options co;
        co.struct_size = sizeof co;
        airmass_vdb_options_init(&co);
        co.unit = "km";
        float columns[8 * 4 * 3];
        const int32_t s = airmass_sun_column_table(&cs, &co, 8, 4, columns, 8 * 4 * 3, msg, sizeof msg);
        const double want[3] = {8.0 * (1.0 - exp(-7.5)), 1.2 * (1.0 - exp(-50.0)), 15.0};
        snprintf(detail, sizeof detail, "status %d %s, %.7g %.7g %.7g", (int)s, msg, columns[0], columns[1], columns[2]);
        check(s == AIRMASS_OK && fabs(columns[0] - want[0]) < 1e-5 * want[0] &&
                  fabs(columns[1] - want[1]) < 1e-5 * want[1] && fabs(columns[2] - want[2]) < 1e-5 * want[2],
              "sun columns straight up from the ground: the profiles' vertical columns", detail);
        const int32_t s2 = airmass_sun_column_table(&cs, &co, 1, 4, columns, 12, msg, sizeof msg);
        check(s2 == AIRMASS_SETTINGS_ERROR && contains(msg, "mu_size") && contains(msg, "[2, 4096]"),
              "sun columns: mu_size 1 refused, naming the field and range", msg);
        const int32_t s3 = airmass_sun_column_table(&cs, &co, 8, 4, columns, 95, msg, sizeof msg);
        check(s3 == AIRMASS_INVALID_ARGUMENT && contains(msg, "float_count"), "sun columns: a short buffer refused",
              msg);
        double mu_s_min = 0.0;
        float psi[8 * 4 * 3];
        const int32_t s4 = airmass_sun_ms_table(&cs, &co, 8, 4, psi, 8 * 4 * 3, &mu_s_min, msg, sizeof msg);
        int finite = 1;
        for (int k = 0; k < 8 * 4 * 3; ++k) finite = finite && isfinite(psi[k]) && psi[k] >= 0.0f;
        snprintf(detail, sizeof detail, "status %d %s, mu_s_min %g, psi at the ground, sun up: %g %g %g", (int)s4, msg,
                 mu_s_min, psi[7 * 3], psi[7 * 3 + 1], psi[7 * 3 + 2]);
        check(s4 == AIRMASS_OK && finite && mu_s_min > -1.0 && mu_s_min < 0.0 && psi[7 * 3 + 2] > psi[7 * 3] &&
                  psi[7 * 3] > 0.0f,
              "sun multiple scattering: finite, non-negative, bluer than red at the ground by day", detail);
        const int32_t s5 = airmass_sun_ms_table(&cs, &co, 8, 4, psi, 8 * 4 * 3, NULL, msg, sizeof msg);
        check(s5 == AIRMASS_INVALID_ARGUMENT && contains(msg, "mu_s_min"), "sun multiple scattering: NULL mu_s_min",
              msg);
    }

    /* ---- voxel values (ABI 8): "auto" by default; each grid's metadata says what its voxels hold —
     * in a box of 4-km voxels, auto averages the aerosol (a 1.2-km layer) and keeps point values for
     * Rayleigh (8 km); "point" and "average" apply to every grid; any other name is refused by name. ---- */
    if (airmass_has_vdb()) {
        airmass_scene_spec ws;
        ws.struct_size = sizeof ws;
        airmass_scene_spec_init(&ws);
        ws.preset = "earth";
        airmass_vdb_options wo;
        wo.struct_size = sizeof wo;
        airmass_vdb_options_init(&wo);
        check(wo.voxel_values != NULL && strcmp(wo.voxel_values, "auto") == 0, "vdb options: voxel values auto by default",
              wo.voxel_values ? wo.voxel_values : "NULL");
        const double box[6] = {-20.0, -20.0, 0.0, 20.0, 20.0, 20.0};
        wo.region = "box";
        memcpy(wo.box, box, sizeof box);
        wo.voxel_size = 4.0;
        const char* names[3] = {"auto", "point", "average"};
        const int want_average[3] = {1, 0, 1}, want_point[3] = {1, 1, 0};
        for (int k = 0; k < 3; ++k) {
            wo.voxel_values = names[k];
            char* plan = NULL;
            const int32_t s = airmass_vdb_plan(&ws, &wo, NULL, NULL, &plan, msg, sizeof msg);
            const int has_average = plan && contains(plan, "\"airmass:voxel_values\":\"average\"");
            const int has_point = plan && contains(plan, "\"airmass:voxel_values\":\"point\"");
            snprintf(detail, sizeof detail, "%s: status %d %s, grids averaged %d, point %d", names[k], (int)s, msg,
                     has_average, has_point);
            check(s == AIRMASS_OK && has_average == want_average[k] && has_point == want_point[k],
                  "vdb plan: the grids' voxel values follow the option", detail);
            if (plan) airmass_string_free(plan);
        }
        wo.voxel_values = "mean";
        char* bad = NULL;
        const int32_t s = airmass_vdb_plan(&ws, &wo, NULL, NULL, &bad, msg, sizeof msg);
        check(s == AIRMASS_INVALID_ARGUMENT && bad == NULL && contains(msg, "voxel-values") &&
                  contains(msg, "auto, average or point"),
              "vdb plan: an unknown voxel_values name refused, naming the field and the choices", msg);
        airmass_vdb_session* bad_session = (airmass_vdb_session*)&ws;  /* must come back NULL */
        const int32_t sb = airmass_vdb_session_create(&ws, &wo, &bad_session, msg, sizeof msg);
        check(sb == AIRMASS_INVALID_ARGUMENT && bad_session == NULL && contains(msg, "voxel-values"),
              "vdb session: an unknown voxel_values name refused, no session", msg);

        /* A session (ABI 8) gives the stateless calls' plan and values: the aerosol's means over a
         * block of the box, from the session after its plan and from airmass_vdb_grid_values. */
        wo.voxel_values = "average";
        airmass_vdb_session* session = NULL;
        const int32_t sc = airmass_vdb_session_create(&ws, &wo, &session, msg, sizeof msg);
        check(sc == AIRMASS_OK && session != NULL, "vdb session: created", msg);
        if (session) {
            char* plan = NULL;
            const int32_t sp = airmass_vdb_session_plan(session, "box", NULL, &plan, msg, sizeof msg);
            check(sp == AIRMASS_OK && plan && contains(plan, "\"airmass:voxel_values\":\"average\"") &&
                      contains(plan, "box.vdb"),
                  "vdb session: the plan (file stem, voxel values)", sp == AIRMASS_OK ? "ok" : msg);
            if (plan) airmass_string_free(plan);
            airmass_vdb_block block;
            block.struct_size = sizeof block;
            airmass_vdb_block_init(&block);
            block.grid = "mie";
            const int32_t lo[3] = {-5, -5, 0}, hi[3] = {5, 5, 5};
            memcpy(block.min, lo, sizeof lo);
            memcpy(block.max, hi, sizeof hi);
            enum { N = 11 * 11 * 6 };
            static float a[N], b[N];
            const int32_t s1 = airmass_vdb_session_grid_values(session, &block, a, N, NULL, msg, sizeof msg);
            const int32_t s2 = airmass_vdb_grid_values(&ws, &wo, &block, b, N, NULL, msg, sizeof msg);
            int nonzero = 0;
            for (int k = 0; k < N; ++k) nonzero += a[k] != 0.0f;
            snprintf(detail, sizeof detail, "status %d / %d (%s), %d nonzero of %d", (int)s1, (int)s2, msg, nonzero, N);
            check(s1 == AIRMASS_OK && s2 == AIRMASS_OK && nonzero > 0 && memcmp(a, b, sizeof a) == 0,
                  "vdb session: a block's values are the stateless call's, bit for bit", detail);
            block.grid = "dust";
            const int32_t s3 = airmass_vdb_session_grid_values(session, &block, a, N, NULL, msg, sizeof msg);
            check(s3 == AIRMASS_INVALID_ARGUMENT && contains(msg, "dust"), "vdb session: an unknown grid refused", msg);
            airmass_vdb_session_free(session);
        }
        char* none = NULL;
        const int32_t sn = airmass_vdb_session_plan(NULL, NULL, NULL, &none, msg, sizeof msg);
        check(sn == AIRMASS_INVALID_ARGUMENT && none == NULL && contains(msg, "session"),
              "vdb session: a NULL session refused", msg);
        airmass_vdb_session_free(NULL);
    }

    /* ---- the sun lamp ---- */
    {
        airmass_sun_light sun;
        memset(&sun, 0, sizeof sun);
        sun.struct_size = sizeof sun;
        const int32_t s = airmass_sun_light_at_observer(&spec, NULL, &sun, msg, sizeof msg);
        snprintf(detail, sizeof detail, "status %d, rgb %g %g %g, top %g", (int)s, sun.irradiance_rgb[0],
                 sun.irradiance_rgb[1], sun.irradiance_rgb[2], sun.irradiance_top_rgb[0]);
        check(s == AIRMASS_OK && sun.irradiance_rgb[0] > sun.irradiance_rgb[2] && sun.irradiance_rgb[2] > 0.0 &&
                  sun.irradiance_rgb[0] < sun.irradiance_top_rgb[0] && !sun.below_horizon,
              "sunlight at 20 degrees: reddened, below the top-of-atmosphere value", detail);
        spec.sun_elevation_deg = -10.0;
        const int32_t s2 = airmass_sun_light_at_observer(&spec, NULL, &sun, msg, sizeof msg);
        check(s2 == AIRMASS_OK && sun.below_horizon && sun.irradiance_rgb[0] == 0.0, "sun below the horizon: no light",
              msg);
        spec.sun_elevation_deg = 20.0;
    }
    /* ---- the solar position: the SPA report's worked example (Reda & Andreas, NREL/TP-560-34302,
     * its worked example): 17 October 2003 12:30:30 at UT-7, 39.742476 N 105.1786 W, 1830.14 m, dT 67 s;
     * topocentric elevation without refraction e0 = 39.872046 deg, azimuth 194.340241 deg (to 2e-6 and
     * 1e-5 deg: the printed tables' truncation moves the azimuth by 3e-6 deg, tests/test_solar_position.cpp). */
    {
        airmass_solar_query q;
        memset(&q, 0, sizeof q);
        q.struct_size = sizeof q;
        const int32_t si = airmass_solar_query_init(&q);
        check(si == AIRMASS_OK && isnan(q.delta_t_s) && q.utc == NULL, "solar_query_init: defaults", NULL);
        q.latitude_deg = 39.742476;
        q.longitude_deg = -105.1786;
        q.utc = "2003-10-17T12:30:30-07:00";
        q.site_elevation_m = 1830.14;
        q.delta_t_s = 67.0;
        airmass_sun_position pos;
        memset(&pos, 0, sizeof pos);
        pos.struct_size = sizeof pos;
        const int32_t s = airmass_solar_position(&q, &pos, msg, sizeof msg);
        snprintf(detail, sizeof detail, "status %d %s, elevation %.7f, azimuth %.7f", (int)s, msg, pos.elevation_deg,
                 pos.azimuth_deg);
        check(s == AIRMASS_OK && fabs(pos.elevation_deg - 39.872046) < 2e-6 && fabs(pos.azimuth_deg - 194.340241) < 1e-5 &&
                  fabs(pos.zenith_deg + pos.elevation_deg - 90.0) < 1e-9 && pos.delta_t_s == 67.0 &&
                  fabs(pos.julian_day - 2452930.312847) < 1e-6 && pos.blender_rotation_deg == pos.azimuth_deg,
              "solar position: the SPA report's example", detail);
        q.latitude_deg = 91.0;
        const int32_t s2 = airmass_solar_position(&q, &pos, msg, sizeof msg);
        check(s2 == AIRMASS_INVALID_ARGUMENT && contains(msg, "latitude_deg") && contains(msg, "[-90, 90]"),
              "solar position: a latitude of 91 is refused, naming the field and range", msg);
        q.latitude_deg = 0.0;
        q.utc = "2026-02-30T00:00Z";
        const int32_t s3 = airmass_solar_position(&q, &pos, msg, sizeof msg);
        check(s3 == AIRMASS_INVALID_ARGUMENT && contains(msg, "utc"), "solar position: a bad date is refused", msg);
        q.utc = NULL;
        const int32_t s4 = airmass_solar_position(&q, &pos, msg, sizeof msg);
        check(s4 == AIRMASS_INVALID_ARGUMENT && contains(msg, "utc"), "solar position: a NULL utc is refused", msg);
        pos.struct_size = 8;
        q.utc = "2026-06-21T12:00:00Z";
        const int32_t s5 = airmass_solar_position(&q, &pos, msg, sizeof msg);
        check(s5 == AIRMASS_INVALID_ARGUMENT && contains(msg, "struct_size"), "solar position: a stale struct is refused",
              msg);
    }
    free(rgba);

    printf("%d passed, %d failed\n", passed, failed);
    return failed == 0 ? 0 : 1;
}
