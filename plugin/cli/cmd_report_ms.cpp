// `airmass report ms --out DIR`: the multiple-scattering trade — error against the Monte
// Carlo reference versus precompute time and table memory, for K = 1 … N orders, table sizes,
// parameterisations, ray samples and the two modes (orders of scattering, Hillaire's
// isotropic table). Writes
//   ms_reference.csv   the reference: per case and wavelength, single scattering (the
//                      single-scattering module) and the Monte Carlo multiple scattering with
//                      its standard error (reused with --reuse-reference)
//   ms_trade.csv       one row per configuration: cost (precompute seconds and table MB for
//                      the `earth` preset's 48 wavelengths on --threads threads) and error
//   ms_cases.csv       per configuration, case and wavelength: the relative error of the total
//   ms_trade.md        the Markdown table (docs/multiple_scattering.md, README)
//   ms_presets.{csv,md} the other presets (atmosphere-plus, blender-nishita, earth-hazy, mars) at
//                      the default settings against the Monte Carlo, a few cases each
// scripts/plot_ms_trade.py turns ms_trade.csv into ms_trade.png.
//
// The error of a configuration is that of the total radiance L = single + multiple, with the
// single scattering exact on both sides, so it measures the multiple scattering alone:
//   e = (L_ss + L_ms,tables) / (L_ss + L_ms,MC) − 1 over the reference cases and wavelengths
// (max and RMS), and the part no Monte Carlo noise explains: max(|Δ| − 3σ, 0) / L.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "airmass/atmosphere.hpp"
#include "airmass/monte_carlo.hpp"
#include "airmass/multiple_scattering.hpp"
#include "airmass/progress.hpp"
#include "airmass/terminal.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/single_scattering.hpp"
#include "airmass/vdb_export.hpp"  // write_text_atomic
#include "commands.hpp"
#include "csv.hpp"

namespace airmass::cli {

namespace {

struct Case {
    const char* name;
    double altitude_m, sun_elevation_deg, elevation_deg, azimuth_deg;
};

// Twilight (sun 2° and −4°), day, noon and from 400 km; views toward, across and away from
// the sun, up, near the horizon and down.
constexpr Case kCases[] = {
    {"sun2_zenith", 0, 2, 90, 0},          {"sun2_toward_10", 0, 2, 10, 0},    {"sun2_away_10", 0, 2, 10, 180},
    {"sun2_side_30", 0, 2, 30, 90},        {"sun-4_zenith", 0, -4, 90, 0},     {"sun-4_toward_10", 0, -4, 10, 0},
    {"sun-4_away_20", 0, -4, 20, 180},     {"sun15_away_3", 0, 15, 3, 180},    {"sun15_side_45", 0, 15, 45, 90},
    {"noon_zenith", 0, 70, 90, 0},         {"noon_away_30", 0, 70, 30, 180},   {"noon_ground_-30", 0, 70, -30, 90},
    {"space400_nadir", 400e3, 45, -90, 0}, {"space400_limb", 400e3, 45, -19, 180},
    {"space400_twilight", 400e3, -5, -60, 0},
};
constexpr int kCaseCount = int(sizeof kCases / sizeof kCases[0]);
const std::vector<double> kWavelengths = {440.0, 550.0, 680.0};

ViewRay view_of(const Case& c) {
    return {c.altitude_m, direction_from_elevation_azimuth_deg<double>(c.elevation_deg, c.azimuth_deg),
            direction_from_elevation_azimuth_deg<double>(c.sun_elevation_deg, 0.0)};
}

struct Reference {
    // [case][λ]
    std::vector<std::vector<double>> single, mc, se;
    std::uint64_t paths = 0, seed = 0;
};


bool load_reference(const std::filesystem::path& path, std::uint64_t paths, std::uint64_t seed, Reference& ref) {
    std::ifstream f(path);
    if (!f) return false;
    std::string line;
    std::getline(f, line);  // header
    ref.single.assign(kCaseCount, std::vector<double>(kWavelengths.size(), -1.0));
    ref.mc = ref.se = ref.single;
    int n = 0;
    while (std::getline(f, line)) {
        std::istringstream in(line);
        std::string name, field;
        std::getline(in, name, ',');
        std::vector<double> v;
        while (std::getline(in, field, ',')) v.push_back(std::stod(field));
        // case, altitude, sun, elevation, azimuth, wavelength, single, mc, se, paths, seed
        if (v.size() != 10) return false;
        if (std::uint64_t(v[8]) != paths || std::uint64_t(v[9]) != seed) return false;
        for (int c = 0; c < kCaseCount; ++c)
            if (name == kCases[c].name)
                for (std::size_t w = 0; w < kWavelengths.size(); ++w)
                    if (v[4] == kWavelengths[w]) {
                        ref.single[c][w] = v[5];
                        ref.mc[c][w] = v[6];
                        ref.se[c][w] = v[7];
                        ++n;
                    }
    }
    ref.paths = paths;
    ref.seed = seed;
    return n == kCaseCount * int(kWavelengths.size());
}

Reference compute_reference(const Atmosphere& atm, std::uint64_t paths, std::uint64_t seed, int threads,
                            const CancelFlag& cancel, bool bar_on) {
    Reference ref;
    ref.paths = paths;
    ref.seed = seed;
    const std::size_t nw = atm.wavelength_count();
    ProgressBar bar("report ms: Monte Carlo reference", kCaseCount, bar_on);
    for (int c = 0; c < kCaseCount; ++c) {
        const ViewRay ray = view_of(kCases[c]);
        std::vector<double> T(nw), Lr(nw), Lm(nw), L(nw);
        single_scattering(atm, ray, {T, Lr, Lm, L});
        McSettings mc;
        mc.paths = paths;
        mc.seed = seed + std::uint64_t(c);
        mc.min_order = 2;
        mc.threads = threads;
        mc.cancel = &cancel;
        const McResult r = monte_carlo_radiance(atm, ray, mc);
        ref.single.push_back(L);
        ref.mc.push_back(r.value);
        ref.se.push_back(r.standard_error);
        bar.advance();
        if (!bar_on) std::fprintf(stderr, "report ms: reference %d/%d (%s) %.1f s\n", c + 1, kCaseCount, kCases[c].name, r.seconds);
    }
    return ref;
}

struct Config {
    std::string group, name;
    MsSettings settings;
    bool single_only = false;
};

std::vector<Config> configs() {
    std::vector<Config> out;
    const auto add = [&](std::string group, std::string name, MsSettings s) { out.push_back({group, name, s, false}); };
    out.push_back({"orders K", "K=1 (single scattering only)", {}, true});
    for (int K : {2, 3, 4, 5, 6, 8, 12}) {
        MsSettings s;
        s.max_order = K;
        s.geometric_tail = false;
        add("orders K", "K=" + std::to_string(K), s);
    }
    {
        MsSettings s;
        s.max_order = 4;
        add("orders K", "K=4 + geometric tail", s);
        s.max_order = 0;
        s.geometric_tail = false;
        add("orders K", "auto (next order < 0.1 %)", s);
        add("orders K", "auto + geometric tail (default)", MsSettings{});
    }
    const auto table = [&](std::string name, MsTableSize t) {
        MsSettings s;
        s.table = t;
        add("table", name, s);
    };
    // around the default 12 × 32 × 24 × 6 (altitude × view zenith × sun zenith × azimuth)
    table("8x16x8x4", {8, 16, 8, 4});
    table("8x24x16x4", {8, 24, 16, 4});
    table("12x32x16x6", {12, 32, 16, 6});
    table("12x32x24x1 (azimuth-averaged, 3-D)", {12, 32, 24, 1});
    table("12x32x24x4", {12, 32, 24, 4});
    table("12x32x32x6", {12, 32, 32, 6});
    table("12x32x24x8", {12, 32, 24, 8});
    table("16x32x32x6", {16, 32, 32, 6});
    table("24x48x32x8", {24, 48, 32, 8});
    for (auto p : {MsParameterisation::bruneton, MsParameterisation::seed004}) {
        MsSettings s;
        s.parameterisation = p;
        add("mapping", std::string(ms_parameterisation_name(p)), s);
    }
    for (const auto& [n1, n] : {std::pair{16, 16}, std::pair{64, 16}}) {
        MsSettings s;
        s.order1_ray_samples = n1;
        s.ray_samples = n;
        add("ray samples", std::to_string(n1) + " / " + std::to_string(n) + " ray samples (order 1 / later)", s);
    }
    const auto iso = [&](std::string name, MsTableSize t) {
        MsSettings s;
        s.mode = MsMode::isotropic_lut;
        s.table = t;
        add("isotropic LUT", name, s);
    };
    iso("Psi 16x16, 8x2 directions", {16, 8, 16, 2});
    iso("Psi 32x32, 16x4 directions (Hillaire)", {32, 16, 32, 4});
    iso("Psi 64x64, 16x4 directions", {64, 16, 64, 4});
    return out;
}

// CPU seconds of the whole process (all threads): the cost of a precompute even when other
// jobs share the machine and the wall clock is not representative.
double process_cpu_seconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

std::string fmt(const char* f, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, f, v);
    return buf;
}

struct Options {
    std::string out;
    std::uint64_t paths = 200000;
    std::uint64_t seed = 1;
    int threads = 2;
    bool reuse = false;
    bool quick = false;
    bool quiet = false;
};

void run_report(const Options& o) {
    const std::filesystem::path dir(o.out);
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) throw CliError("report ms: cannot create --out directory '" + o.out + "': " + ec.message());
    CancelFlag cancel;
    InterruptGuard guard(cancel);
    const bool bar_on = stderr_is_terminal() && !o.quiet;

    const Scene earth = load_preset("earth");
    Atmosphere atm = compile_atmosphere(earth, kWavelengths);
    set_constant_irradiance(atm, 1.0);
    // the preset's own spectral sampling (48 wavelengths) for the cost columns
    std::vector<double> wl48;
    for (int i = 0; i < 48; ++i) wl48.push_back(360.0 + 10.0 * i);
    const Atmosphere atm48 = compile_atmosphere(earth, wl48);

    Reference ref;
    const auto ref_path = dir / "ms_reference.csv";
    if (!(o.reuse && load_reference(ref_path, o.paths, o.seed, ref))) {
        if (!o.quiet)
            std::fprintf(stderr, "report ms: Monte Carlo reference, %d cases × %zu wavelengths × %llu paths\n",
                         kCaseCount, kWavelengths.size(), static_cast<unsigned long long>(o.paths));
        ref = compute_reference(atm, o.paths, o.seed, o.threads, cancel, bar_on);
        std::ostringstream csv;
        csv << "case,altitude_m,sun_elevation_deg,view_elevation_deg,view_azimuth_deg,wavelength_nm,single,mc_multiple,"
               "mc_standard_error,paths,seed\n";
        for (int c = 0; c < kCaseCount; ++c)
            for (std::size_t w = 0; w < kWavelengths.size(); ++w)
                csv << kCases[c].name << "," << kCases[c].altitude_m << "," << kCases[c].sun_elevation_deg << ","
                    << kCases[c].elevation_deg << "," << kCases[c].azimuth_deg << "," << kWavelengths[w] << ","
                    << format_g17(ref.single[c][w]) << "," << format_g17(ref.mc[c][w]) << ","
                    << format_g17(ref.se[c][w]) << "," << o.paths << "," << o.seed << "\n";
        write_text_atomic(ref_path, csv.str());
    } else if (!o.quiet) {
        std::fprintf(stderr, "report ms: reusing %s\n", ref_path.string().c_str());
    }

    std::ostringstream trade, cases, md;
    trade << "group,config,mode,parameterisation,table,max_order,tail,ray_samples,order1_ray_samples,orders,precompute_s_earth48,"
             "cpu_s_earth48,table_mb_earth48,precompute_s_3wl,max_err_pct,rms_err_pct,max_unexplained_pct,rms_ms_err_pct,"
             "mean_mc_sigma_pct\n";
    cases << "config,case,wavelength_nm,single,multiple,mc_multiple,mc_standard_error,rel_err_total\n";
    md << "| group | configuration | precompute wall (CPU) — earth, 48 λ, " << o.threads
       << " threads | table | orders (48 λ) | max error "
       << "| RMS error | beyond 3σ (max) | RMS error of the multiple part |\n";
    md << "|---|---|---:|---:|---:|---:|---:|---:|---:|\n";
    const auto cfgs = configs();
    ProgressBar bar("report ms: configurations", cfgs.size(), bar_on);
    double sigma_sum = 0.0;
    int sigma_n = 0;
    for (int c = 0; c < kCaseCount; ++c)
        for (std::size_t w = 0; w < kWavelengths.size(); ++w) {
            sigma_sum += ref.se[c][w] / (ref.single[c][w] + ref.mc[c][w]);
            ++sigma_n;
        }
    const double mean_sigma_pct = 100.0 * sigma_sum / sigma_n;
    for (const Config& cfg : cfgs) {
        MsSettings s = cfg.settings;
        s.threads = o.threads;
        s.cancel = &cancel;
        double seconds48 = 0.0, cpu48 = 0.0, mb48 = 0.0, seconds3 = 0.0;
        int orders = 1, repeats_after = 0;
        bool tail = false;
        MultipleScattering ms;
        if (!cfg.single_only) {
            if (!o.quick) {
                const double cpu0 = process_cpu_seconds();
                const MultipleScattering big = precompute_multiple_scattering(atm48, s);
                cpu48 = process_cpu_seconds() - cpu0;
                seconds48 = big.precompute_seconds;
                orders = big.highest_order;
                repeats_after = big.repeats_after_order;
                tail = big.tail_added;
                mb48 = double(big.table_bytes()) / (1024.0 * 1024.0);
            }
            ms = precompute_multiple_scattering(atm, s);
            seconds3 = ms.precompute_seconds;
            if (o.quick) {
                orders = ms.highest_order;
                repeats_after = ms.repeats_after_order;
                tail = ms.tail_added;
            }
        }
        double max_err = 0.0, sq = 0.0, max_unexplained = 0.0, sq_ms = 0.0;
        int n = 0;
        for (int c = 0; c < kCaseCount; ++c) {
            const std::size_t nw = kWavelengths.size();
            std::vector<double> mr(nw, 0.0), mm(nw, 0.0), mt(nw, 0.0);
            if (!cfg.single_only) multiple_scattering_radiance(atm, ms, view_of(kCases[c]), {mr, mm, mt}, 64);
            for (std::size_t w = 0; w < nw; ++w) {
                const double total_ref = ref.single[c][w] + ref.mc[c][w];
                const double total = ref.single[c][w] + mt[w];
                const double e = total / total_ref - 1.0;
                max_err = std::max(max_err, std::abs(e));
                sq += e * e;
                max_unexplained =
                    std::max(max_unexplained, std::max(std::abs(total - total_ref) - 3.0 * ref.se[c][w], 0.0) / total_ref);
                const double ems = ref.mc[c][w] > 0.0 ? mt[w] / ref.mc[c][w] - 1.0 : 0.0;
                sq_ms += ems * ems;
                ++n;
                cases << '"' << cfg.name << "\"," << kCases[c].name << "," << kWavelengths[w] << ","
                      << format_g17(ref.single[c][w]) << "," << format_g17(mt[w]) << "," << format_g17(ref.mc[c][w])
                      << "," << format_g17(ref.se[c][w]) << "," << format_g17(e) << "\n";
            }
        }
        const double rms = std::sqrt(sq / n), rms_ms = std::sqrt(sq_ms / n);
        const MsTableSize t = cfg.single_only ? s.table : ms.grid.size;
        const std::string table = cfg.single_only ? "-"
                                                  : std::to_string(t.altitude) + "x" + std::to_string(t.view_zenith) +
                                                        "x" + std::to_string(t.sun_zenith) + "x" + std::to_string(t.azimuth);
        trade << cfg.group << ",\"" << cfg.name << "\"," << (cfg.single_only ? "none" : ms_mode_name(s.mode)) << ","
              << ms_parameterisation_name(s.parameterisation) << "," << table << "," << s.max_order << ","
              << (s.geometric_tail ? 1 : 0) << "," << s.ray_samples << "," << s.order1_ray_samples << "," << orders << "," << format_g17(seconds48)
              << "," << format_g17(cpu48) << "," << format_g17(mb48) << "," << format_g17(seconds3) << "," << format_g17(100 * max_err) << ","
              << format_g17(100 * rms) << "," << format_g17(100 * max_unexplained) << "," << format_g17(100 * rms_ms)
              << "," << format_g17(mean_sigma_pct) << "\n";
        const std::string orders_text = cfg.single_only ? "1"
                                        : s.mode == MsMode::isotropic_lut ? "∞ (series)"
                                                                          : std::to_string(orders) +
                                                                                (tail ? " + tail" : "") +
                                                                                (repeats_after > 0
                                                                                     ? " (orders after " +
                                                                                           std::to_string(repeats_after) +
                                                                                           " repeat it: added, not "
                                                                                           "recomputed)"
                                                                                     : "");
        md << "| " << cfg.group << " | " << cfg.name << " | "
           << (cfg.single_only ? std::string("—")
               : o.quick       ? std::string("(--quick)")
                               : fmt("%.2f s", seconds48) + fmt(" (%.2f s)", cpu48))
           << " | " << (cfg.single_only ? std::string("—") : o.quick ? std::string("—") : fmt("%.2f MB", mb48)) << " | "
           << orders_text << " | " << fmt("%.2f %%", 100 * max_err) << " | " << fmt("%.2f %%", 100 * rms) << " | "
           << fmt("%.2f %%", 100 * max_unexplained) << " | " << fmt("%.1f %%", 100 * rms_ms) << " |\n";
        bar.advance();
        if (!bar_on && !o.quiet)
            std::fprintf(stderr, "report ms: %-40s max %.2f %%  rms %.2f %%  %.3f s\n", cfg.name.c_str(), 100 * max_err,
                         100 * rms, seconds48);
    }
    bar.finish();
    // Other planets and atmospheres at the default settings, a few cases each.
    std::ostringstream pcsv, pmd;
    pcsv << "preset,table,case,wavelength_nm,single,multiple,mc_multiple,mc_standard_error,rel_err_total\n";
    pmd << "| preset | table | precompute wall (CPU), 3 λ | max error | beyond 3σ (max) | multiple / total |\n";
    pmd << "|---|---:|---:|---:|---:|---:|\n";
    constexpr Case kPresetCases[] = {{"sun30_zenith", 0, 30, 90, 0},
                                     {"sun5_away_20", 0, 5, 20, 120},
                                     {"sun30_toward_10", 0, 30, 10, 0},
                                     {"sun30_side_30", 0, 30, 30, 90}};
    for (const char* name : {"atmosphere-plus", "blender-nishita", "earth-hazy", "mars"}) {
        Atmosphere pa = compile_atmosphere(load_preset(name), kWavelengths);
        set_constant_irradiance(pa, 1.0);
        const std::size_t nw = kWavelengths.size();
        // The Monte Carlo reference and the exact single scattering, once per case.
        std::vector<McResult> refs;
        std::vector<std::vector<double>> singles;
        for (const Case& c : kPresetCases) {
            const ViewRay ray = view_of(c);
            std::vector<double> T(nw), Lr(nw), Lm(nw), L(nw);
            single_scattering(pa, ray, {T, Lr, Lm, L});
            singles.push_back(L);
            McSettings mc;
            mc.paths = std::max<std::uint64_t>(o.paths / 4, 100);
            mc.seed = o.seed + 1000;
            mc.min_order = 2;
            mc.threads = o.threads;
            mc.cancel = &cancel;
            refs.push_back(monte_carlo_radiance(pa, ray, mc));
        }
        // The default tables; for the thick forward-scattering atmospheres (automatic azimuth
        // 12) also the finer table `--ms-table 24,32,24,24` that halves their error.
        std::vector<MsTableSize> tables{MsTableSize{}};
        if (ms_automatic_azimuth_nodes(pa) > 6) tables.push_back({24, 32, 24, 24});
        for (const MsTableSize& table : tables) {
            MsSettings s;
            s.table = table;
            s.threads = o.threads;
            s.cancel = &cancel;
            const double cpu0 = process_cpu_seconds();
            const MultipleScattering ms = precompute_multiple_scattering(pa, s);
            const double cpu = process_cpu_seconds() - cpu0;
            double max_err = 0.0, max_unexplained = 0.0, share = 0.0;
            int n = 0;
            const MsTableSize t = ms.grid.size;
            const std::string size = std::to_string(t.altitude) + "x" + std::to_string(t.view_zenith) + "x" +
                                     std::to_string(t.sun_zenith) + "x" + std::to_string(t.azimuth);
            for (std::size_t i = 0; i < std::size(kPresetCases); ++i) {
                const ViewRay ray = view_of(kPresetCases[i]);
                std::vector<double> mr(nw), mm(nw), mt(nw);
                multiple_scattering_radiance(pa, ms, ray, {mr, mm, mt}, 64);
                const McResult& r = refs[i];
                for (std::size_t w = 0; w < nw; ++w) {
                    const double total_ref = singles[i][w] + r.value[w], total = singles[i][w] + mt[w];
                    const double e = total / total_ref - 1.0;
                    max_err = std::max(max_err, std::abs(e));
                    max_unexplained = std::max(
                        max_unexplained, std::max(std::abs(total - total_ref) - 3.0 * r.standard_error[w], 0.0) / total_ref);
                    share += r.value[w] / total_ref;
                    ++n;
                    pcsv << name << "," << size << "," << kPresetCases[i].name << "," << kWavelengths[w] << ","
                         << format_g17(singles[i][w]) << "," << format_g17(mt[w]) << "," << format_g17(r.value[w]) << ","
                         << format_g17(r.standard_error[w]) << "," << format_g17(e) << "\n";
                }
            }
            pmd << "| " << name << " | " << size << (table.azimuth == 0 ? " (default)" : " (`--ms-table`)") << " | "
                << fmt("%.2f s", ms.precompute_seconds) << fmt(" (%.2f s)", cpu) << " | " << fmt("%.2f %%", 100 * max_err)
                << " | " << fmt("%.2f %%", 100 * max_unexplained) << " | " << fmt("%.0f %%", 100 * share / n) << " |\n";
            if (!o.quiet) std::fprintf(stderr, "report ms: preset %-16s %s max %.2f %%\n", name, size.c_str(), 100 * max_err);
        }
    }
    pmd << "\nCases: sun 30° zenith, sun 5° view 20° at 120° from the sun, sun 30° view 10° toward it and 30° "
           "across; Monte Carlo " << std::max<std::uint64_t>(o.paths / 4, 100) << " paths, orders ≥ 2.\n";
    write_text_atomic(dir / "ms_presets.csv", pcsv.str());
    write_text_atomic(dir / "ms_presets.md", pmd.str());

    md << "\nReference: Monte Carlo (" << ref.paths << " paths per case and wavelength, orders ≥ 2) plus the exact "
       << "single scattering, " << kCaseCount << " cases × 440/550/680 nm (ms_reference.csv); mean Monte Carlo "
       << "standard error " << fmt("%.2f %%", mean_sigma_pct) << " of the total. Errors are of the total radiance.\n";
    write_text_atomic(dir / "ms_trade.csv", trade.str());
    write_text_atomic(dir / "ms_cases.csv", cases.str());
    write_text_atomic(dir / "ms_trade.md", md.str());
    if (!o.quiet) std::fprintf(stderr, "report ms: wrote %s/ms_trade.{csv,md}, ms_cases.csv, ms_reference.csv\n", o.out.c_str());
}

}  // namespace

void add_report_ms(CLI::App& report) {
    auto o = std::make_shared<Options>();
    auto* cmd = report.add_subcommand(
        "ms", "Multiple scattering: error against a Monte Carlo reference vs precompute time and table memory");
    cmd->add_option("--out", o->out, "Output directory")->required();
    cmd->add_option("--paths", o->paths, "Monte Carlo paths per case and wavelength")->check(int_in(100, 100000000));
    cmd->add_option("--seed", o->seed, "Monte Carlo seed")->check(int_in(0, INT64_MAX));
    cmd->add_option("--threads", o->threads, "Threads for the precompute timings and the Monte Carlo (0: all)")
        ->check(int_in(0, 4096));
    cmd->add_flag("--reuse-reference", o->reuse,
                  "Reuse OUT/ms_reference.csv when it was made with the same --paths and --seed");
    cmd->add_flag("--quick", o->quick, "Skip the 48-wavelength precompute timings");
    cmd->add_flag("--quiet", o->quiet, "No progress output");
    cmd->callback([o] { run_report(*o); });
}

}  // namespace airmass::cli
