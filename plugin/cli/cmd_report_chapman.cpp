// `airmass report chapman --out DIR`: the Chapman speed-vs-accuracy trade, measured in
// one run against the exact method (itself held to 1e-10 by tests against an mpmath
// reference). Writes
//   chapman_trade.csv     method, precision, region, max/median relative error, invalid count
//   chapman_timing.csv    method, ns per evaluation: scalar double/float, batch double/float
//   chapman_trade.md      the two Markdown tables README shows
//   chapman_curves.csv    relative error vs chi at x = 10, 100, 760, 1e4 (for the plot)
// scripts/plot_chapman.py turns chapman_curves.csv into chapman_error.png.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "airmass/chapman.hpp"
#include "airmass/vdb_export.hpp"  // write_text_atomic
#include "commands.hpp"
#include "csv.hpp"

namespace airmass::cli {

namespace {

struct Band {
    double lo, hi;
    const char* label;
};
constexpr Band kXBands[] = {{1e-2, 10, "x<10"}, {10, 100, "10-100"}, {100, 1000, "100-1000"}, {1000, 1e7, ">1000"}};
constexpr Band kChiBands[] = {{0, 90, "chi<=90"}, {90, 95, "90-95"}, {95, 180, "chi>95"}};

struct Sample {
    double x, chi_deg;
    double ln_ref;        // exact ln Ch at the double inputs
    double ln_ref_float;  // exact ln Ch at the inputs rounded to float (what a float caller asked for)
    int region;           // xband * 3 + chiband
};

double halton(unsigned i, unsigned base) {
    double f = 1, r = 0;
    while (i > 0) {
        f /= base;
        r += f * (i % base);
        i /= base;
    }
    return r;
}

double ln_ch(ChapmanMethod m, double x, double chi_deg) {
    const auto s = chapman_scaled(m, x, ZenithAngle<double>::from_degrees(chi_deg));
    return std::log(s.mantissa) + s.log_scale;
}

// Relative error of a method's value given its scaled form, against ln of the reference.
// NaN marks an invalid result (NaN, ±inf mantissa, or a value ≤ 0).
template <class T>
double rel_error(ScaledChapman<T> s, double ln_ref) {
    const double m = static_cast<double>(s.mantissa), e = static_cast<double>(s.log_scale);
    if (!std::isfinite(m) || !std::isfinite(e) || !(m > 0)) return std::nan("");
    return std::abs(std::expm1(std::log(m) + e - ln_ref));
}

std::vector<Sample> make_samples(int per_region) {
    std::vector<Sample> out;
    for (int bx = 0; bx < 4; ++bx)
        for (int bc = 0; bc < 3; ++bc) {
            const Band X = kXBands[bx], C = kChiBands[bc];
            std::vector<std::pair<double, double>> pts;
            for (int i = 0; i < per_region; ++i) {
                const double x = X.lo * std::pow(X.hi / X.lo, halton(i + 1, 2));
                const double chi = C.lo + (C.hi - C.lo) * halton(i + 1, 3);
                pts.push_back({x, chi});
            }
            // The edges, where methods break: chi exactly at the band ends and just beside 90°.
            for (double x : {X.lo, std::sqrt(X.lo * X.hi), X.hi})
                for (double chi : {C.lo, C.hi, 90.0 - 1e-7, 90.0 + 1e-7})
                    if (chi >= C.lo && chi <= C.hi) pts.push_back({x, chi});
            for (auto [x, chi] : pts) {
                const auto a = ZenithAngle<float>::from_degrees(chi);
                const auto s = chapman_scaled(ChapmanMethod::exact, double(float(x)),
                                              ZenithAngle<double>{double(a.cos_chi), double(a.sin_chi)});
                out.push_back({x, chi, ln_ch(ChapmanMethod::exact, x, chi), std::log(s.mantissa) + s.log_scale,
                               bx * 3 + bc});
            }
        }
    return out;
}

// ns per evaluation of `fn(i)` over n inputs, best of 5 runs of at least 20 ms each.
template <class Fn>
double time_ns(size_t n, Fn fn) {
    double best = 1e300;
    for (int rep = 0; rep < 5; ++rep) {
        size_t evals = 0;
        const auto t0 = std::chrono::steady_clock::now();
        double elapsed = 0;
        do {
            fn();
            evals += n;
            elapsed = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
        } while (elapsed < 2e7);
        best = std::min(best, elapsed / double(evals));
    }
    return best;
}

volatile double g_sink;  // defeats dead-code elimination of the timed loops

template <class T>
struct Inputs {
    std::vector<T> x, c, s, m, e;
    explicit Inputs(const std::vector<Sample>& samples) {
        for (const auto& p : samples) {
            const auto chi = ZenithAngle<T>::from_degrees(p.chi_deg);
            x.push_back(static_cast<T>(p.x));
            c.push_back(chi.cos_chi);
            s.push_back(chi.sin_chi);
        }
        m.resize(x.size());
        e.resize(x.size());
    }
    double scalar_ns(ChapmanMethod method) {
        return time_ns(x.size(), [&] {
            T acc = 0;
            for (size_t i = 0; i < x.size(); ++i) {
                const auto r = chapman_scaled(method, x[i], ZenithAngle<T>{c[i], s[i]});
                acc += r.mantissa + r.log_scale;
            }
            g_sink = acc;
        });
    }
    double batch_ns(ChapmanMethod method) {
        return time_ns(x.size(), [&] {
            chapman_scaled_batch<T>(method, x, c, s, m, e);
            g_sink = m[x.size() / 2];
        });
    }
};

struct Stats {
    double max = 0, median = 0;
    size_t invalid = 0, n = 0;
};

Stats stats(std::vector<double> errs) {
    Stats st;
    st.n = errs.size();
    std::vector<double> valid;
    for (double e : errs) {
        if (std::isnan(e)) ++st.invalid;
        else valid.push_back(e);
    }
    if (!valid.empty()) {
        std::sort(valid.begin(), valid.end());
        st.max = valid.back();
        st.median = valid[valid.size() / 2];
    }
    return st;
}

std::string fmt_err(const Stats& s) {
    char buf[64];
    if (s.invalid > 0) std::snprintf(buf, sizeof buf, "%.1e (%zu invalid)", s.max, s.invalid);
    else std::snprintf(buf, sizeof buf, "%.1e", s.max);
    return buf;
}


void run_report(const std::filesystem::path& out_dir, int per_region) {
    std::error_code ec;
    std::filesystem::create_directories(out_dir, ec);
    if (ec) throw CliError("report chapman: cannot create --out directory '" + out_dir.string() + "': " + ec.message());
    std::fprintf(stderr, "report chapman: computing the exact reference at %d points per region...\n", per_region);
    const auto samples = make_samples(per_region);

    Inputs<double> in_d(samples);
    Inputs<float> in_f(samples);
    const auto methods = chapman_methods();

    struct MethodResult {
        std::string_view name;
        Stats overall[2];       // [double, float]
        Stats region[12];       // double
        double ns[4];           // scalar double, scalar float, batch double, batch float
    };
    std::vector<MethodResult> results;
    std::ostringstream trade;
    trade << "method,precision,x_band,chi_band,max_rel_err,median_rel_err,invalid,n\n";
    for (const auto& info : methods) {
        MethodResult res{info.name, {}, {}, {}};
        for (int prec = 0; prec < 2; ++prec) {
            std::vector<double> per_region_errs[12], all;
            for (size_t i = 0; i < samples.size(); ++i) {
                // Float is judged where its result is representable (Ch ≤ FLT_MAX, ln Ch < 88.7):
                // beyond, ln Ch itself carries an ulp of x·6e-8 in float, which is the type's limit,
                // not the method's. Its reference is taken at the float-rounded inputs.
                if (prec == 1 && samples[i].ln_ref_float > 88.0) continue;
                const double err =
                    prec == 0
                        ? rel_error(chapman_scaled(info.method, in_d.x[i], ZenithAngle<double>{in_d.c[i], in_d.s[i]}),
                                    samples[i].ln_ref)
                        : rel_error(chapman_scaled(info.method, in_f.x[i], ZenithAngle<float>{in_f.c[i], in_f.s[i]}),
                                    samples[i].ln_ref_float);
                per_region_errs[samples[i].region].push_back(err);
                all.push_back(err);
            }
            for (int r = 0; r < 12; ++r) {
                const Stats st = stats(per_region_errs[r]);
                if (prec == 0) res.region[r] = st;
                trade << info.name << "," << (prec == 0 ? "double" : "float") << "," << kXBands[r / 3].label << ","
                      << kChiBands[r % 3].label << "," << format_g17(st.max) << "," << format_g17(st.median) << ","
                      << st.invalid << "," << st.n << "\n";
            }
            res.overall[prec] = stats(all);
        }
        // Timing, measured in this run for every method so the ratios compare like with like.
        std::fprintf(stderr, "report chapman: timing %.*s...\n", int(info.name.size()), info.name.data());
        res.ns[0] = in_d.scalar_ns(info.method);
        res.ns[1] = in_f.scalar_ns(info.method);
        res.ns[2] = in_d.batch_ns(info.method);
        res.ns[3] = in_f.batch_ns(info.method);
        results.push_back(res);
    }
    double baseline_ns = 1;
    for (const auto& r : results)
        if (r.name == "schuler2012") baseline_ns = r.ns[0];

    std::ostringstream timing, md;
    timing << "method,scalar_double_ns,scalar_float_ns,batch_double_ns,batch_float_ns,ratio_to_schuler2012\n";
    md << "Measured by `airmass report chapman` against the `exact` method (" << samples.size()
       << " points: Halton samples in every region plus the band edges, chi = 90° ± 1e-7 among them). "
          "Relative error |Ch/Ch_exact − 1|; \"invalid\" counts NaN, ±inf or non-positive results. "
          "Float errors are over the points where Ch fits in a float (ln Ch < 88), against the exact value at "
          "the float-rounded inputs. "
          "Times are ns per evaluation on one core over the same input set (two thirds below the "
          "horizon, since the three chi bands are sampled equally), best of 5; the last column is scalar double time relative to `schuler2012`, measured in "
          "the same run.\n\n"
       << "| method | max rel. error (double) | max rel. error (float) | ns scalar double | ns scalar float | ns "
          "batch double | ns batch float | × schuler2012 |\n|---|---|---|---|---|---|---|---|\n";
    char line[512];
    for (const auto& r : results) {
        std::snprintf(line, sizeof line, "%.*s,%.2f,%.2f,%.2f,%.2f,%.3f\n", int(r.name.size()), r.name.data(), r.ns[0],
                      r.ns[1], r.ns[2], r.ns[3], r.ns[0] / baseline_ns);
        timing << line;
        std::snprintf(line, sizeof line, "| `%.*s` | %s | %s | %.1f | %.1f | %.1f | %.1f | %.2f |\n",
                      int(r.name.size()), r.name.data(), fmt_err(r.overall[0]).c_str(), fmt_err(r.overall[1]).c_str(),
                      r.ns[0], r.ns[1], r.ns[2], r.ns[3], r.ns[0] / baseline_ns);
        md << line;
    }
    md << "\nPer region, double precision (max / median relative error):\n\n"
          "| method | x band | χ ≤ 90° | 90° < χ ≤ 95° | χ > 95° |\n|---|---|---|---|---|\n";
    for (const auto& r : results) {
        for (int bx = 0; bx < 4; ++bx) {
            md << "| `" << r.name << "` | " << kXBands[bx].label;
            for (int bc = 0; bc < 3; ++bc) {
                const auto& st = r.region[bx * 3 + bc];
                std::snprintf(line, sizeof line, " | %s / %.1e", fmt_err(st).c_str(), st.median);
                md << line;
            }
            md << " |\n";
        }
    }
    write_text_atomic(out_dir / "chapman_trade.csv", trade.str());
    write_text_atomic(out_dir / "chapman_timing.csv", timing.str());
    write_text_atomic(out_dir / "chapman_trade.md", md.str());

    // Curves for the plot: relative error vs chi at four x.
    std::ostringstream curves;
    curves << "method,x,chi_deg,rel_err\n";
    std::vector<double> chis;
    for (int i = 0; i <= 1800; ++i) chis.push_back(i * 0.1);
    for (int i = 1; i < 1000; ++i) chis.push_back(85.0 + i * 0.01);
    std::sort(chis.begin(), chis.end());
    for (double x : {10.0, 100.0, 760.0, 1e4}) {
        std::vector<double> ref;
        for (double chi : chis) ref.push_back(ln_ch(ChapmanMethod::exact, x, chi));
        for (const auto& info : methods) {
            if (info.method == ChapmanMethod::exact) continue;
            for (size_t k = 0; k < chis.size(); ++k) {
                const double err = rel_error(chapman_scaled(info.method, x, ZenithAngle<double>::from_degrees(chis[k])),
                                             ref[k]);
                curves << info.name << "," << x << "," << chis[k] << "," << format_g17(err) << "\n";
            }
        }
    }
    write_text_atomic(out_dir / "chapman_curves.csv", curves.str());
    std::fputs(md.str().c_str(), stdout);
}

}  // namespace

void add_report_chapman(CLI::App& report) {
    auto* chapman = report.add_subcommand("chapman", "Chapman methods: error per region and ns per evaluation");
    auto out = std::make_shared<std::string>("out/chapman");
    auto per_region = std::make_shared<int>(1500);
    chapman->add_option("--out", *out, "Output directory");
    chapman->add_option("--points", *per_region, "Samples per (x band, chi band) region")
        ->check(int_in(10, 1000000));
    chapman->callback([=] { run_report(*out, *per_region); });
}

}  // namespace airmass::cli
