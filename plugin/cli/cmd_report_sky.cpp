// `airmass report sky --out DIR`: the sky texture's speed-vs-accuracy trade, measured in one
// run against a converged reference the command computes itself (docs/sky.md).
//
// Knobs traded: Chapman method (sun rays and view segments) × view samples × spectral basis
// (Schüler's 615/535/445 nm RGB basis, or N wavelengths with the CIE 1931 CMFs).
// Reference: exact Chapman, `--reference-samples` view samples, 2.5-nm spectral sampling
// (189 wavelengths, 360–830 nm, or the part of it the scene's tables cover), no sun disc. Its own convergence is measured too: against
// twice the samples, and at a few directions against the evaluator's brute-force nested
// quadrature (single_scattering_reference).
//
// Error of a pixel: ‖rgb − rgb_ref‖∞ / Y_ref (channel error relative to the reference
// luminance Y = 0.2126 R + 0.7152 G + 0.0722 B), statistics weighted by pixel solid angle,
// split above / below the horizon, pooled over the conditions (sun elevation × observer
// altitude). Pixels whose reference is black (space) count as exact when the config is black too.
//
// Writes to DIR:
//   sky_trade.csv             one row per configuration: errors and ms per megapixel
//   sky_trade_conditions.csv  per configuration and condition
//   sky_reference.csv         the reference's self-checks
//   sky_trade.md              Markdown tables (and the default-settings ≤ 1 % check)
//   sky_ms_view.csv / .md     the multiple-scattering view's knobs (--ms-grid, --ms-samples)
//                             against the same tables integrated along every pixel's ray
// scripts/plot_sky_trade.py draws the Pareto plot from sky_trade.csv.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <tbb/info.h>

#include "airmass/atmosphere.hpp"
#include "airmass/chapman.hpp"
#include "airmass/color.hpp"
#include "airmass/progress.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/single_scattering.hpp"
#include "airmass/sky.hpp"
#include "airmass/sky_grid.hpp"
#include "airmass/terminal.hpp"
#include "airmass/vdb_export.hpp"  // write_text_atomic
#include "commands.hpp"
#include "csv.hpp"

namespace airmass::cli {

namespace {

namespace fs = std::filesystem;

struct Condition {
    double elevation_deg;
    double altitude_m;
    bool in_check;  // part of the "default ≤ 1 %" population (sun ≤ 85° zenith, observer 0–10 km)
};

struct Basis {
    std::string label;
    SpectralBasis basis;
};

struct Config {
    ChapmanMethod chapman;
    int samples;
    std::size_t basis;  // index into the basis list
    int grid = 0;       // SkySettings::grid (0: every pixel evaluated)
};

std::vector<double> range_nm(double first, double last, double step) {
    std::vector<double> v;
    for (int i = 0; first + step * i <= last + 1e-9; ++i) v.push_back(first + step * i);
    return v;
}

SpectralBasis spectral(std::vector<double> nm) {
    SpectralBasis b;
    b.kind = SpectralBasis::Kind::spectral;
    b.wavelengths_nm = std::move(nm);
    return b;
}

SpectralBasis rgb_basis() {
    SpectralBasis b;
    b.kind = SpectralBasis::Kind::rgb_schuler;
    return b;
}

// [lo, hi] ∩ the wavelengths every table of the scene covers (its sun irradiance, its constituents'
// coefficients): the range its spectra may be sampled in.
std::pair<double, double> tabulated_range_nm(const Scene& scene, double lo, double hi) {
    const auto clip = [&](const std::vector<std::pair<double, double>>& table) {
        if (table.empty()) return;
        lo = std::max(lo, table.front().first);
        hi = std::min(hi, table.back().first);
    };
    clip(scene.sun.irradiance_table);
    for (const Constituent& c : scene.constituents) {
        if (c.scattering.law == SpectralCoefficient::Law::table) clip(c.scattering.table);
        if (c.absorption.law == SpectralCoefficient::Law::table) clip(c.absorption.table);
    }
    if (!(hi > lo)) throw CliError("report sky: the scene's tables share no wavelengths in [360, 830] nm");
    return {lo, hi};
}

std::string num_nm(double nm) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", nm);
    return b;
}

double luminance(const float* p) { return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]; }

// Solid-angle-weighted error samples of one region (above or below the horizon).
struct Errors {
    std::vector<std::pair<double, double>> err_weight;
    void add(double e, double w) { err_weight.emplace_back(e, w); }
    void append(const Errors& o) { err_weight.insert(err_weight.end(), o.err_weight.begin(), o.err_weight.end()); }
    struct Stats {
        double max = 0, mean = 0, p95 = 0;
        bool empty = true;
    };
    Stats stats() const {
        Stats s;
        if (err_weight.empty()) return s;
        s.empty = false;
        auto v = err_weight;
        std::sort(v.begin(), v.end());
        double total = 0, sum = 0;
        for (auto [e, w] : v) total += w, sum += e * w;
        s.mean = sum / total;
        s.max = v.back().first;
        double acc = 0;
        for (auto [e, w] : v) {
            acc += w;
            if (acc >= 0.95 * total) {
                s.p95 = e;
                break;
            }
        }
        return s;
    }
};

struct ImageErrors {
    Errors above, below;
};

ImageErrors compare(const FloatImage& img, const FloatImage& ref) {
    ImageErrors out;
    double max_y = 0;
    for (int y = 0; y < ref.height; ++y)
        for (int x = 0; x < ref.width; ++x) max_y = std::max(max_y, luminance(ref.at(x, y)));
    for (int y = 0; y < ref.height; ++y) {
        const double w = equirect_pixel_solid_angle(y, ref.width, ref.height);
        const bool above = 2 * y + 1 < ref.height;
        for (int x = 0; x < ref.width; ++x) {
            const float *a = img.at(x, y), *r = ref.at(x, y);
            const double yr = luminance(r);
            double e = 0;
            if (yr > 1e-12 * max_y) {
                for (int c = 0; c < 3; ++c)
                    e = std::max(e, std::abs(double(a[c]) - double(r[c])) / std::max(double(r[c]), yr));
            } else {
                for (int c = 0; c < 3; ++c)
                    if (a[c] != r[c]) e = std::numeric_limits<double>::infinity();
            }
            (above ? out.above : out.below).add(e, w);
        }
    }
    return out;
}

std::string pct(double v) {
    char b[32];
    if (!std::isfinite(v)) return "inf";
    if (v >= 0.1) std::snprintf(b, sizeof b, "%.0f %%", v * 100);
    else if (v >= 0.001) std::snprintf(b, sizeof b, "%.2f %%", v * 100);
    else std::snprintf(b, sizeof b, "%.1e", v);
    return b;
}

// Progress and Ctrl-C for one run: on a terminal a bar per stage, its units the stage's images
// or configurations; with stderr elsewhere a line per stage and configuration (none with
// --quiet). Every render takes hooks() (cancellable: Cancelled, caught in add_report_sky).
struct Reporter {
    const CancelFlag& cancel;
    bool quiet = false;
    bool bar_on() const { return stderr_is_terminal() && !quiet; }
    RenderHooks hooks() const {
        RenderHooks h;
        h.cancel = &cancel;
        return h;
    }
    void check() const {
        if (cancel.requested()) throw Cancelled("report sky: cancelled");
    }
    // A line for a log (no bar drawn, not --quiet).
    void line(const std::string& text) const {
        if (!quiet && !bar_on()) std::fprintf(stderr, "report sky: %s\n", text.c_str());
    }
};


// ---- the multiple-scattering view's knobs ---------------------------------------------------
//
// The sky adds multiple scattering by integrating the tables along the rays of a coarse
// sun-aligned view (SkySettings::multiple_grid, --ms-grid M) with multiple.view_samples
// intervals per ray (--ms-samples N), then interpolating (docs/sky.md). Both are knobs of the
// image, not of the tables (whose own error against Monte Carlo is `airmass report ms`), so
// they are measured against the same tables integrated along every pixel's own ray with
// kMsReferenceSamples intervals. The single scattering is evaluated per pixel in every image
// (grid 0), identically, so the differences are the view's alone; one extra row renders as
// `airmass sky` does large images (the sky grid too), whose error then includes the grid's
// interpolation of both parts.
constexpr int kMsReferenceSamples = 256;

struct MsViewConfig {
    int ms_grid;     // SkySettings::multiple_grid (0: the tables along every evaluated ray)
    int ms_samples;  // multiple.view_samples
    int grid = 0;    // SkySettings::grid of the accuracy images
};

std::string ms_view_report(const std::string& out_dir, const std::string& preset, const Scene& base, bool quick,
                           int threads, const Reporter& rep) {
    // 256 × 128: 16 384 rays with the mirror, more than the largest view measured (M = 64:
    // 65 × 66 rays), so every view is built, and more than the default sky grid's 3 362 nodes.
    const int W = quick ? 128 : 256, H = W / 2;
    struct Cond {
        double elevation_deg, altitude_m;
    };
    std::vector<Cond> conditions = {{60, 0}, {15, 0}, {2, 0}, {-4, 0}, {60, 10e3}, {2, 10e3}, {-4, 10e3}, {30, 400e3}};
    std::vector<int> grids = {0, 8, 16, kSkyDefaultMultipleGrid, 64}, samples = {8, 16, 32, 64};
    if (quick) {
        conditions = {{15, 0}, {-4, 0}};
        grids = {0, kSkyDefaultMultipleGrid};
        samples = {16, 32};
    }
    const SkySettings defaults;
    std::vector<MsViewConfig> configs;
    for (int m : grids)
        for (int n : samples) configs.push_back({m, n});
    configs.push_back({kSkyDefaultMultipleGrid, defaults.multiple.view_samples, -1});  // as `airmass sky` renders
    auto settings_for = [&](const MsViewConfig& c, int w, int h) {
        SkySettings s;
        s.width = w;
        s.height = h;
        s.view.sun_disc = false;
        s.grid = c.grid;
        s.multiple_grid = c.ms_grid;
        s.multiple.view_samples = c.ms_samples;
        s.threads = threads;
        return s;
    };
    // One session: the tables once (the preset's own basis), every image a render of it.
    rep.line("multiple-scattering view: tables, " + std::to_string(conditions.size()) + " references, " +
             std::to_string(configs.size()) + " configurations");
    ProgressBar bar("report sky: multiple-scattering view", 1 + conditions.size() + configs.size(), rep.bar_on());
    const SkySession session(base, settings_for({0, kMsReferenceSamples}, W, H), rep.hooks());
    bar.advance();
    const auto render = [&](const Cond& c, const MsViewConfig& cfg, int w, int h) {
        return session.render(sun_direction(c.elevation_deg, 0.0), c.altitude_m, settings_for(cfg, w, h), rep.hooks());
    };
    std::vector<FloatImage> refs;
    for (const Cond& c : conditions) {
        refs.push_back(render(c, {0, kMsReferenceSamples}, W, H));
        bar.advance();
    }
    // The reference's own convergence: twice its intervals, at twilight and by day.
    std::ostringstream self;
    for (const Cond& c : {conditions.front(), conditions[quick ? 1 : 3]}) {
        const ImageErrors e = compare(render(c, {0, kMsReferenceSamples}, W / 2, H / 2),
                                      render(c, {0, 2 * kMsReferenceSamples}, W / 2, H / 2));
        const auto a = e.above.stats(), b = e.below.stats();
        char line[256];
        std::snprintf(line, sizeof line, "%s%d vs %d intervals at sun %g°, observer %g km: p95 %s / max %s above, "
                      "p95 %s / max %s below", self.tellp() > 0 ? "; " : "", kMsReferenceSamples,
                      2 * kMsReferenceSamples, c.elevation_deg, c.altitude_m / 1e3, pct(a.p95).c_str(),
                      pct(a.max).c_str(), pct(b.p95).c_str(), pct(b.max).c_str());
        self << line;
    }

    std::ostringstream csv;
    csv << "ms_grid,ms_samples,grid,ms_per_image,relative_time,threads,p95_above,mean_above,max_above,p95_below,"
           "mean_below,max_below,worst_condition_p95\n";
    struct Row {
        MsViewConfig cfg;
        double seconds;
        Errors::Stats above, below;
        double worst;
    };
    std::vector<Row> rows;
    // Time: a 1024 × 512 image at the defaults otherwise (sky grid auto), sun 30°, ground
    // observer, the tables held (the add-on's per-sun path), best of 3; and without multiple
    // scattering at all, for scale.
    const int TW = quick ? 256 : 1024;
    const auto time_of = [&](const SkySession& ses, const SkySettings& st) {
        double best = 1e300;
        for (int k = 0; k < 3; ++k) {
            const auto t0 = std::chrono::steady_clock::now();
            ses.render(sun_direction(30.0, 0.0), 0.0, st, rep.hooks());
            best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        }
        return best;
    };
    for (std::size_t i = 0; i < configs.size(); ++i) {
        const MsViewConfig& cfg = configs[i];
        rep.line("multiple-scattering view " + std::to_string(i + 1) + "/" + std::to_string(configs.size()) +
                 ": --ms-grid " + std::to_string(cfg.ms_grid) + " --ms-samples " + std::to_string(cfg.ms_samples));
        Errors above, below;
        double worst = 0;
        for (std::size_t ci = 0; ci < conditions.size(); ++ci) {
            const ImageErrors e = compare(render(conditions[ci], cfg, W, H), refs[ci]);
            above.append(e.above);
            below.append(e.below);
            worst = std::max({worst, e.above.stats().p95, e.below.stats().p95});
        }
        // Timed as `airmass sky` renders (sky grid auto): the last row is the same render as the
        // default knobs' row, timed once.
        double seconds = std::nan("");
        for (const Row& r : rows)
            if (r.cfg.ms_grid == cfg.ms_grid && r.cfg.ms_samples == cfg.ms_samples) seconds = r.seconds;
        if (std::isnan(seconds)) {
            MsViewConfig timed = cfg;
            timed.grid = -1;
            seconds = time_of(session, settings_for(timed, TW, TW / 2));
        }
        rows.push_back({cfg, seconds, above.stats(), below.stats(), worst});
        bar.advance();
    }
    bar.finish();
    SkySettings off = settings_for({kSkyDefaultMultipleGrid, defaults.multiple.view_samples, -1}, TW, TW / 2);
    off.multiple.enabled = false;
    const double seconds_off = time_of(SkySession(base, off, rep.hooks()), off);
    double seconds_default = 0;
    for (const Row& r : rows)
        if (r.cfg.grid == -1) seconds_default = r.seconds;

    std::ostringstream md;
    md << "Measured by `airmass report sky` (preset `" << preset << "`, its tables at their defaults, "
       << W << "×" << H << " full-sphere images, sun rotation 0°, no sun disc; sun elevation × observer: ";
    for (std::size_t i = 0; i < conditions.size(); ++i)
        md << (i ? ", " : "") << conditions[i].elevation_deg << "° × " << conditions[i].altitude_m / 1e3 << " km";
    md << ") against the same tables integrated along every pixel's own ray with " << kMsReferenceSamples
       << " intervals (" << self.str()
       << "). Single scattering per pixel in every image (the same in all, so the error is the view's); the last row "
          "renders as `airmass sky` does large images, the sky grid interpolating both parts. Error of a pixel as in "
          "the sky trade (max over R, G, B of |c − c_ref| / max(c_ref, Y_ref)), statistics weighted by solid angle, "
          "pooled over the conditions (below the horizon an observer on the ground sees the ground at zero distance, "
          "the same in every image); \"worst\" = the largest p95 of one condition and half-sphere. Time (the same "
          "for a row's knobs with either sky grid): one "
       << TW << "×" << TW / 2 << " image (sky grid auto), sun 30°, ground observer, the tables held (a session's new "
       << "sun, the add-on's path), best of 3, " << threads << " threads, this run; without multiple scattering the "
          "same image takes "
       << std::lround(seconds_off * 1e3) << " ms.\n\n"
       << "| `--ms-grid` | `--ms-samples` | ms per image | × default | p95 above | mean above | max above | p95 below | "
          "mean below | max below | worst p95 |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const Row& r : rows) {
        const bool is_default = r.cfg.ms_grid == kSkyDefaultMultipleGrid &&
                                r.cfg.ms_samples == defaults.multiple.view_samples;
        std::string grid_label = r.cfg.ms_grid == 0 ? "0 (every ray)" : std::to_string(r.cfg.ms_grid);
        if (r.cfg.grid == -1) grid_label += ", sky grid auto";
        const double rel = seconds_default > 0 ? r.seconds / seconds_default : std::nan("");
        char line[512];
        std::snprintf(line, sizeof line, "| %s%s%s | %d | %.1f | %.2f | %s | %s | %s | %s | %s | %s | %s |\n",
                      is_default ? "**" : "", grid_label.c_str(), is_default ? "**" : "", r.cfg.ms_samples,
                      r.seconds * 1e3, rel, pct(r.above.p95).c_str(), pct(r.above.mean).c_str(),
                      pct(r.above.max).c_str(), pct(r.below.p95).c_str(), pct(r.below.mean).c_str(),
                      pct(r.below.max).c_str(), pct(r.worst).c_str());
        md << line;
        csv << r.cfg.ms_grid << "," << r.cfg.ms_samples << "," << r.cfg.grid << "," << format_g17(r.seconds * 1e3)
            << "," << format_g17(rel) << "," << threads << "," << format_g17(r.above.p95) << ","
            << format_g17(r.above.mean) << "," << format_g17(r.above.max) << "," << format_g17(r.below.p95) << ","
            << format_g17(r.below.mean) << "," << format_g17(r.below.max) << "," << format_g17(r.worst) << "\n";
    }
    write_text_atomic(fs::path(out_dir) / "sky_ms_view.csv", csv.str());
    write_text_atomic(fs::path(out_dir) / "sky_ms_view.md", md.str());
    return md.str();
}

struct Options {
    std::string out = "out/sky";
    std::string preset = "earth";
    int width = 128;
    int reference_samples = 128;
    bool quick = false;
    bool multiple_view = true;
    bool quiet = false;
};

void run_report(const Options& opt, const Reporter& rep) {
    std::error_code ec;
    fs::create_directories(opt.out, ec);
    if (ec) throw CliError("report sky: cannot create --out directory '" + opt.out + "': " + ec.message());
    const Scene base = load_preset(opt.preset);
    const int W = opt.width, H = opt.width / 2;

    // Conditions: the ≤ 1 % population (sun elevation 5°..90°, i.e. zenith ≤ 85°; observer
    // 0–10 km), plus twilight and orbit, reported separately.
    std::vector<Condition> conditions;
    for (double alt : {0.0, 5e3, 10e3})
        for (double e : {5.0, 15.0, 30.0, 60.0, 90.0}) conditions.push_back({e, alt, true});
    conditions.push_back({-3.0, 0.0, false});
    conditions.push_back({2.0, 0.0, false});
    conditions.push_back({30.0, 400e3, false});
    if (opt.quick) conditions = {{5.0, 0.0, true}, {30.0, 10e3, true}, {-3.0, 0.0, false}};

    // The spectral bases span 360–830 nm, or the part of it the scene's tables cover (a table
    // is never extrapolated: `blender-nishita`'s are 380–780 nm); the default basis is the
    // preset's own (`earth`'s 48 wavelengths, Blender's 21), added to the list when it is none
    // of these.
    const std::pair<double, double> covered = tabulated_range_nm(base, 360.0, 830.0);
    const double lo_nm = covered.first, hi_nm = covered.second;  // (a lambda below reads them)
    const auto spectral_every = [&](double step) {
        const std::vector<double> nm = range_nm(std::ceil(lo_nm / step) * step, hi_nm, step);
        return Basis{"spectral-" + std::to_string(nm.size()), spectral(nm)};
    };
    std::vector<Basis> bases = {
        {"rgb-schuler", rgb_basis()},
        {"spectral-21", spectral(range_nm(380, 780, 20))},
        spectral_every(10.0),
        spectral_every(5.0),
    };
    if (lo_nm > 380.0 || hi_nm < 780.0) bases.erase(bases.begin() + 1);  // Blender's grid needs 380–780 nm
    std::size_t default_basis = bases.size();
    for (std::size_t b = 0; b < bases.size(); ++b)
        if (bases[b].basis.kind == base.basis.kind &&
            basis_wavelengths_nm(bases[b].basis) == basis_wavelengths_nm(base.basis))
            default_basis = b;
    if (default_basis == bases.size()) {
        const std::size_t n = basis_wavelengths_nm(base.basis).size();
        bases.push_back({"preset-" + std::to_string(n), base.basis});
    }
    const Basis reference_basis = spectral_every(2.5);

    // The sweeps: every Chapman method × view samples with the preset's basis;
    // every basis × view samples with the default method; the sky grid at the defaults.
    // All per pixel (grid 0) except the grid sweep.
    const SkySettings defaults;
    std::vector<int> sample_counts = {2, 4, 8, 16, 32, 64};
    std::vector<ChapmanMethod> methods;
    for (const auto& m : chapman_methods()) methods.push_back(m.method);
    std::vector<int> grids = {24, 32, kSkyDefaultGrid, 64, 128, 256};
    if (opt.quick) {
        sample_counts = {4, 16};
        methods = {defaults.view.chapman, ChapmanMethod::schuler2012_rigged};
        grids = {kSkyDefaultGrid, 64};
    }
    std::vector<Config> configs;
    for (auto m : methods)
        for (int n : sample_counts)
            // The exact method (~10 µs per evaluation, ~500× the others) has the same error as
            // `airmass` at every sample count; up to 16 samples is enough to place its cost.
            if (m != ChapmanMethod::exact || n <= 16) configs.push_back({m, n, default_basis, 0});
    for (std::size_t b = 0; b < bases.size(); ++b)
        if (b != default_basis)
            for (int n : sample_counts) configs.push_back({defaults.view.chapman, n, b, 0});
    for (int g : grids) configs.push_back({defaults.view.chapman, defaults.view.view_samples, default_basis, g});
    if (!opt.quick) configs.push_back({defaults.view.chapman, defaults.view.view_samples, 0, kSkyDefaultGrid});

    auto scene_for = [&](const Condition& c, const SpectralBasis& basis) {
        Scene s = base;
        s.sun.elevation_deg = c.elevation_deg;
        s.sun.azimuth_deg = 0.0;
        s.observer.altitude_m = c.altitude_m;
        s.basis = basis;
        return s;
    };
    auto settings_for = [&](ChapmanMethod m, int samples, int w, int h, int grid = 0) {
        SkySettings s;
        s.width = w;
        s.height = h;
        s.view.chapman = m;
        s.view.view_samples = samples;
        s.view.sun_disc = false;
        s.grid = grid;
        // The knobs measured here (Chapman method, view samples, basis, grid) are those of
        // the single-scattering evaluator, against a single-scattering reference; multiple
        // scattering (on by default in SkySettings) has its own trade against Monte Carlo
        // (`airmass report ms`) and its cost in the sky is in docs/sky.md. Leaving it on here
        // would add the same table error to every configuration and the reference would
        // need 189-wavelength tables.
        s.multiple.enabled = false;
        return s;
    };

    // ---- the reference, and its own convergence ------------------------------------------
    rep.line("reference (exact Chapman, " + std::to_string(opt.reference_samples) + " samples, " +
             std::to_string(reference_basis.basis.wavelengths_nm.size()) + " wavelengths) for " +
             std::to_string(conditions.size()) + " conditions");
    std::vector<FloatImage> refs;
    // the references, then their self-check: twice the samples at two conditions (4 images)
    ProgressBar ref_bar("report sky: reference", conditions.size() + 4, rep.bar_on());
    for (const auto& c : conditions) {
        refs.push_back(render_sky(scene_for(c, reference_basis.basis),
                                  settings_for(ChapmanMethod::exact, opt.reference_samples, W, H), rep.hooks()));
        ref_bar.advance();
    }

    std::ostringstream ref_csv;
    ref_csv << "check,condition,p95_above,max_above,p95_below,max_below\n";
    std::ostringstream ref_md;
    {
        // (a) Twice the view samples, at a quarter of the pixels, two conditions.
        for (std::size_t ci : {std::size_t(0), conditions.size() - 1}) {
            const auto& c = conditions[ci];
            const Scene s = scene_for(c, reference_basis.basis);
            const FloatImage a =
                render_sky(s, settings_for(ChapmanMethod::exact, opt.reference_samples, W / 2, H / 2), rep.hooks());
            ref_bar.advance();
            const FloatImage b =
                render_sky(s, settings_for(ChapmanMethod::exact, 2 * opt.reference_samples, W / 2, H / 2), rep.hooks());
            ref_bar.advance();
            const ImageErrors e = compare(a, b);
            const auto sa = e.above.stats(), sb = e.below.stats();
            char label[64];
            std::snprintf(label, sizeof label, "sun %g deg alt %g m", c.elevation_deg, c.altitude_m);
            ref_csv << "samples_vs_2x," << label << "," << format_g17(sa.p95) << "," << format_g17(sa.max) << ","
                    << format_g17(sb.p95) << "," << format_g17(sb.max) << "\n";
            ref_md << "| " << opt.reference_samples << " vs " << 2 * opt.reference_samples << " view samples | "
                   << label << " | " << pct(sa.p95) << " | " << pct(sa.max) << " | " << pct(sb.p95) << " | "
                   << pct(sb.max) << " |\n";
        }
        // (b) Brute-force nested quadrature at a few directions (sun 5°, ground).
        const Condition& c = conditions[0];
        const Scene s = scene_for(c, reference_basis.basis);
        const SpectrumToRgb to_rgb = spectrum_to_rgb(s.basis);
        EvalSettings eval;
        eval.chapman = ChapmanMethod::exact;
        eval.view_samples = opt.reference_samples;
        eval.sun_disc = false;
        const Atmosphere atm = compile_atmosphere(s, to_rgb.wavelengths_nm, eval);
        const std::size_t nw = atm.wavelength_count();
        Errors brute_above, brute_below;
        const int ys[] = {1, H / 8, H / 4, H / 2 - 2, H / 2 - 1, H / 2, H / 2 + 1, H - 3};
        const int xs[] = {0, W / 4, W / 4 + 3, W / 2 + 5};
        std::vector<double> t(nw), r(nw), m(nw), rad(nw);
        for (int y : ys)
            for (int x : xs) {
                const glm::dvec3 d = equirect_pixel_direction(x, y, W, H);
                ViewRay ray;
                ray.altitude_m = c.altitude_m;
                ray.view_direction = Vec3<double>(d);
                ray.sun_direction = Vec3<double>(sun_direction(c.elevation_deg, 0.0));
                single_scattering_reference(s, atm, ray, RadianceOut{t, r, m, rad}, 1e-7);
                const Vec3d rgb = to_rgb.apply(rad);
                float px[3];
                for (int k = 0; k < 3; ++k) px[k] = static_cast<float>(std::max(rgb[k], 0.0));
                const float* q = refs[0].at(x, y);
                double diff = 0;
                for (int k = 0; k < 3; ++k) diff = std::max(diff, std::abs(double(q[k]) - px[k]));
                (2 * y + 1 < H ? brute_above : brute_below).add(diff / std::max(luminance(px), 1e-30), 1.0);
            }
        const auto sa = brute_above.stats(), sb = brute_below.stats();
        ref_csv << "brute_force_quadrature,sun 5 deg alt 0 m," << format_g17(sa.p95) << "," << format_g17(sa.max)
                << "," << format_g17(sb.p95) << "," << format_g17(sb.max) << "\n";
        ref_md << "| brute-force nested quadrature (" << std::size(ys) * std::size(xs)
               << " directions, rel. tol. 1e-7) | sun 5° alt 0 m | " << pct(sa.p95) << " | " << pct(sa.max) << " | "
               << pct(sb.p95) << " | " << pct(sb.max) << " |\n";
    }
    ref_bar.finish();

    // ---- every configuration -------------------------------------------------------------
    const int threads = tbb::info::default_concurrency();
    std::ostringstream csv, cond_csv;
    csv << "chapman,samples,basis,grid,wavelengths,ms_per_mpix,threads,p95_above,mean_above,max_above,p95_below,"
           "mean_below,max_below,p95_check_above,p95_check_all,worst_condition_p95_above,near_sun_max_grid_vs_pixel\n";
    cond_csv << "chapman,samples,basis,grid,sun_elevation_deg,altitude_m,in_check,p95_above,mean_above,max_above,"
                "p95_below,mean_below,max_below\n";
    struct Row {
        Config cfg;
        double ms_per_mpix;
        Errors::Stats above, below, check_above, check_all;
        double worst_p95_above;
        double near_sun;  // grid only: max error within 10° of the sun, grid vs per pixel
    };
    std::vector<Row> rows;
    std::size_t done = 0;
    ProgressBar bar("report sky: configurations", configs.size(), rep.bar_on());
    for (const auto& cfg : configs) {
        ++done;
        const std::string_view mname = chapman_method_name(cfg.chapman);
        rep.line(std::to_string(done) + "/" + std::to_string(configs.size()) + " " + std::string(mname) + ", " +
                 std::to_string(cfg.samples) + " samples, " + bases[cfg.basis].label + ", grid " +
                 std::to_string(cfg.grid));
        Errors all_above, all_below, check_above, check_all;
        double worst = 0;
        for (std::size_t ci = 0; ci < conditions.size(); ++ci) {
            const auto& c = conditions[ci];
            const FloatImage img = render_sky(scene_for(c, bases[cfg.basis].basis),
                                              settings_for(cfg.chapman, cfg.samples, W, H, cfg.grid), rep.hooks());
            const ImageErrors e = compare(img, refs[ci]);
            const auto sa = e.above.stats(), sb = e.below.stats();
            cond_csv << mname << "," << cfg.samples << "," << bases[cfg.basis].label << "," << cfg.grid << ","
                     << c.elevation_deg << ","
                     << c.altitude_m << "," << (c.in_check ? 1 : 0) << "," << format_g17(sa.p95) << ","
                     << format_g17(sa.mean) << "," << format_g17(sa.max) << "," << format_g17(sb.p95) << ","
                     << format_g17(sb.mean) << "," << format_g17(sb.max) << "\n";
            if (c.in_check) {
                all_above.append(e.above);
                all_below.append(e.below);
                check_above.append(e.above);
                check_all.append(e.above);
                check_all.append(e.below);
                worst = std::max(worst, sa.p95);
            }
        }
        // Time per megapixel: a 2:1 full-sphere image at sun 30°, ground observer, all threads,
        // best of 2. Per pixel: sized to take ≥ 0.1 s; with a grid: 2048×1024, its use case.
        const Scene ts = scene_for({30.0, 0.0, true}, bases[cfg.basis].basis);
        int tw = cfg.grid > 0 ? (opt.quick ? 512 : 2048) : (opt.quick ? 64 : 256);
        double best = 1e300;
        for (;;) {
            const auto t0 = std::chrono::steady_clock::now();
            render_sky(ts, settings_for(cfg.chapman, cfg.samples, tw, tw / 2, cfg.grid), rep.hooks());
            const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            if (sec < (opt.quick ? 0.02 : 0.1) && tw < 4096 && cfg.grid == 0) {
                tw *= 2;
                continue;
            }
            best = std::min(best, sec);
            const auto t1 = std::chrono::steady_clock::now();
            render_sky(ts, settings_for(cfg.chapman, cfg.samples, tw, tw / 2, cfg.grid), rep.hooks());
            best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count());
            break;
        }
        const double ms_per_mpix = best * 1e3 / (double(tw) * (tw / 2) / 1e6);
        // Grid only: its interpolation error where the sky varies fastest — every pixel of a
        // 1024×512 image within 10° of the sun (above the horizon), grid against the same
        // settings evaluated per pixel, sun at 5°, 30°, 60°, 90°, ground observer.
        double near_sun = std::nan("");
        if (cfg.grid > 0) {
            near_sun = 0;
            const int NW = opt.quick ? 256 : 1024, NH = NW / 2;
            for (double e : {5.0, 30.0, 60.0, 90.0}) {
                const Scene sc = scene_for({e, 0.0, true}, bases[cfg.basis].basis);
                const FloatImage img =
                    render_sky(sc, settings_for(cfg.chapman, cfg.samples, NW, NH, cfg.grid), rep.hooks());
                const glm::dvec3 sun = sun_direction(e, 0.0);
                std::vector<glm::dvec3> dirs;
                std::vector<std::pair<int, int>> where;
                for (int y = 0; 2 * y + 1 < NH; ++y)
                    for (int x = 0; x < NW; ++x) {
                        const glm::dvec3 d = equirect_pixel_direction(x, y, NW, NH);
                        if (glm::dot(d, sun) < std::cos(10.0 * std::numbers::pi / 180)) continue;
                        dirs.push_back(d);
                        where.push_back({x, y});
                    }
                rep.check();
                const auto exact = sky_radiance_rgb(sc, settings_for(cfg.chapman, cfg.samples, NW, NH, 0), dirs);
                for (std::size_t k = 0; k < dirs.size(); ++k) {
                    const float* p = img.at(where[k].first, where[k].second);
                    const float q[3] = {float(exact[k].x), float(exact[k].y), float(exact[k].z)};
                    const double yq = luminance(q);
                    for (int c = 0; c < 3; ++c)
                        near_sun = std::max(near_sun, std::abs(double(p[c]) - q[c]) / std::max(double(q[c]), yq));
                }
            }
        }
        Row row{cfg,   ms_per_mpix, all_above.stats(), all_below.stats(), check_above.stats(), check_all.stats(),
                worst, near_sun};
        csv << mname << "," << cfg.samples << "," << bases[cfg.basis].label << "," << cfg.grid << ","
            << spectrum_to_rgb(bases[cfg.basis].basis).size() << "," << format_g17(ms_per_mpix) << "," << threads
            << "," << format_g17(row.above.p95) << "," << format_g17(row.above.mean) << "," << format_g17(row.above.max)
            << "," << format_g17(row.below.p95) << "," << format_g17(row.below.mean) << "," << format_g17(row.below.max)
            << "," << format_g17(row.check_above.p95) << "," << format_g17(row.check_all.p95) << ","
            << format_g17(worst) << "," << format_g17(near_sun) << "\n";
        rows.push_back(row);
        bar.advance();
    }
    bar.finish();

    // ---- Markdown --------------------------------------------------------------------------
    std::ostringstream md;
    // The sweep's grids that the accuracy images evaluate per pixel (sky.hpp: a grid only when it
    // has fewer nodes than the image's rays; sun rotation 0°, so the mirror halves them), for
    // each observer altitude of the pooled conditions: its horizon's pieces (the knots below it,
    // the horizontal from 60 m up: sky_grid.hpp Horizon::kinks) set the grid's rows.
    const double R = base.planet.radius_m, top = base.planet.atmosphere_top_m - base.planet.radius_m;
    const std::vector<double> knots = profile_knots_m(base);
    const auto per_pixel = [&](double altitude_m) {  // "40, 64"
        const Horizon hz = Horizon::of(R, top, altitude_m, knots);
        std::string list;
        for (int g : grids)
            if (SkyGridLayout::image(g).rays(hz, false) >= double(W) * H / 2)
                list += (list.empty() ? "" : ", ") + std::to_string(g);
        return list.empty() ? std::string("none") : list;
    };
    std::vector<std::pair<std::string, std::string>> by_list;  // (list, "0 km, 5 km")
    for (const Condition& c : conditions) {
        if (!c.in_check) continue;
        const std::string list = per_pixel(c.altitude_m), where = std::to_string(std::lround(c.altitude_m / 1e3)) + " km";
        auto it = std::find_if(by_list.begin(), by_list.end(), [&](const auto& p) { return p.first == list; });
        if (it == by_list.end()) by_list.emplace_back(list, where);
        else if (it->second.find(where) == std::string::npos) it->second += ", " + where;
    }
    std::string per_pixel_grids = "the grids evaluated per pixel are";
    for (std::size_t k = 0; k < by_list.size(); ++k)
        per_pixel_grids += (k ? "; " : " ") + by_list[k].first + (by_list.size() > 1 ? " from " + by_list[k].second : "");
    md << "Measured by `airmass report sky` (preset `" << opt.preset << "`, " << W << "×" << H
       << " full-sphere images, sun rotation 0°, no sun disc) against a converged reference computed in the same run: "
          "exact Chapman, "
       << opt.reference_samples << " view samples per constituent, " << reference_basis.basis.wavelengths_nm.size()
       << " wavelengths (" << num_nm(lo_nm) << "–" << num_nm(hi_nm) << " nm every 2.5 nm), every pixel evaluated. Error of a pixel = max over R, G, B of "
          "|c − c_ref| / max(c_ref, Y_ref) (relative per channel; a channel darker than the pixel's luminance Y is "
          "judged against Y). Statistics weighted by solid angle and pooled over sun elevations 5°, 15°, 30°, 60°, "
          "90° × observer altitudes 0, 5, 10 km (sun ≤ 85° from the zenith); \"above\"/\"below\" = view "
          "directions above/below the horizontal. Time: ms per megapixel of a full-sphere render (sun 30°, ground "
          "observer; per pixel: an image sized to take ≥ 0.1 s; grid: 2048×1024), "
       << threads << " threads, best of 2, this machine, this run. grid 0 = every pixel evaluated (the mirror "
          "symmetry about the sun's vertical halves the work); grid G = evaluated on the sky grid and interpolated; "
          "\"grid: max near sun\" = the largest error of the grid against the same settings evaluated per pixel, "
          "over every pixel of a 1024×512 image within 10° of the sun (sun at 5°, 30°, 60°, 90°), where the "
          "aureole makes the sky vary fastest. A grid is used only when it has fewer nodes than the image has rays "
          "(sky.hpp): on the "
       << W << "×" << H << " accuracy images (" << W * H / 2 << " rays with the mirror) " << per_pixel_grids
       << ", so their accuracy columns equal grid 0's, and their own error is the last column's.\n\n";
    // The default-settings check: `airmass sky` uses grid 0 for small images and the default
    // grid for large ones (SkySettings::grid = −1), so both must pass.
    bool all_pass = true, any = false;
    std::ostringstream check;
    for (const auto& r : rows) {
        if (r.cfg.chapman != defaults.view.chapman || r.cfg.samples != defaults.view.view_samples ||
            r.cfg.basis != default_basis || (r.cfg.grid != 0 && r.cfg.grid != kSkyDefaultGrid))
            continue;
        any = true;
        const bool pass = r.check_all.p95 <= 0.01;
        all_pass = all_pass && pass;
        // A grid is used when it has fewer nodes than the image has rays (sky.hpp SkySettings::grid).
        const long ground_nodes = long(SkyGridLayout::image(kSkyDefaultGrid).rays(Horizon::of(R, top, 0.0, knots), false));
        check << "* grid " << r.cfg.grid
              << (r.cfg.grid == 0 ? " (images of ≤ " + std::to_string(ground_nodes) + " rays on the ground, more above it)"
                                  : std::string(" (larger images)"))
              << ": 95th percentile **" << pct(r.check_above.p95) << "** above the horizon, **" << pct(r.check_all.p95)
              << "** over the full sphere; worst single condition " << pct(r.worst_p95_above) << " above the horizon; "
              << (pass ? "≤ 1 %" : "**> 1 %**") << "\n";
    }
    if (any)
        md << "**Default settings** (`" << chapman_method_name(defaults.view.chapman) << "`, "
           << defaults.view.view_samples
           << " view samples, the preset's " << bases[default_basis].label
           << " basis) against the converged reference, 95th-percentile relative error over sky directions "
              "(sun ≤ 85° zenith, observer 0–10 km) — requirement ≤ 1 %: **"
           << (all_pass ? "met" : "NOT met") << "**\n\n"
           << check.str() << "\n";
    md << "| Chapman | samples | basis | grid | ms / Mpx | p95 above | mean above | max above | p95 below | mean below | "
          "max below | grid: max near sun |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    char line[512];
    for (const auto& r : rows) {
        const std::string_view mname = chapman_method_name(r.cfg.chapman);
        std::snprintf(line, sizeof line, "| `%.*s` | %d | %s | %d | %.0f | %s | %s | %s | %s | %s | %s | %s |\n",
                      int(mname.size()), mname.data(), r.cfg.samples, bases[r.cfg.basis].label.c_str(), r.cfg.grid,
                      r.ms_per_mpix, pct(r.above.p95).c_str(), pct(r.above.mean).c_str(), pct(r.above.max).c_str(),
                      pct(r.below.p95).c_str(), pct(r.below.mean).c_str(), pct(r.below.max).c_str(),
                      r.cfg.grid > 0 ? pct(r.near_sun).c_str() : "–");
        md << line;
    }
    md << "\nTwilight (sun −3°, 2°) and orbit (400 km) conditions are in `sky_trade_conditions.csv`; they are not "
          "pooled above.\n\nThe reference's own convergence (same error measure):\n\n| check | condition | p95 above | "
          "max above | p95 below | max below |\n|---|---|---|---|---|---|\n"
       << ref_md.str();

    write_text_atomic(fs::path(opt.out) / "sky_trade.csv", csv.str());
    write_text_atomic(fs::path(opt.out) / "sky_trade_conditions.csv", cond_csv.str());
    write_text_atomic(fs::path(opt.out) / "sky_reference.csv", ref_csv.str());
    write_text_atomic(fs::path(opt.out) / "sky_trade.md", md.str());
    std::fputs(md.str().c_str(), stdout);
}

}  // namespace

void add_report_sky(CLI::App& report) {
    auto* cmd = report.add_subcommand("sky",
                                      "Sky texture: error vs time per megapixel for Chapman × samples × basis × "
                                      "grid, and the multiple-scattering view (--ms-grid × --ms-samples)");
    auto opt = std::make_shared<Options>();
    cmd->add_option("--out", opt->out, "Output directory")->capture_default_str();
    cmd->add_option("--preset", opt->preset, "Scene preset")->capture_default_str();
    cmd->add_option("--width", opt->width, "Width of the error images (height = width/2)")
        ->check(int_in(16, 4096))
        ->capture_default_str();
    cmd->add_option("--reference-samples", opt->reference_samples, "View samples of the reference")
        ->check(int_in(16, 65536))
        ->capture_default_str();
    cmd->add_flag("--quick", opt->quick, "A small subset (smoke test): 2 methods × 2 sample counts, 3 conditions");
    cmd->add_flag("!--no-multiple-view", opt->multiple_view,
                  "Leave out the multiple-scattering view's trade (--ms-grid × --ms-samples, sky_ms_view.md)");
    cmd->add_flag("-q,--quiet", opt->quiet, "No progress output (the tables still go to stdout)");
    cmd->callback([opt] {
        CancelFlag cancel;
        InterruptGuard guard(cancel);  // Ctrl-C: the render under way stops, nothing more is written
        const Reporter rep{cancel, opt->quiet};
        try {
            run_report(*opt, rep);
        } catch (const Cancelled&) {
            throw Cancelled("report sky: cancelled; nothing written");
        }
        if (!opt->multiple_view) return;
        try {
            const std::string view = ms_view_report(opt->out, opt->preset, load_preset(opt->preset), opt->quick,
                                                    tbb::info::default_concurrency(), rep);
            std::fputs(("\n" + view).c_str(), stdout);
        } catch (const Cancelled&) {
            throw Cancelled("report sky: cancelled; sky_trade.* written to " + opt->out + ", sky_ms_view.* not");
        }
    });
}

}  // namespace airmass::cli
