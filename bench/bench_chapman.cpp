// Google Benchmark for the Chapman family: ns per evaluation, scalar and batch, float
// and double, above and below the horizon. `airmass report chapman` times every method in
// one run for the README's trade table; this file is for profiling single methods:
//   build/bench/bench_chapman --benchmark_filter=airmass
// and for issue 14 goal 5. After the runs it prints the `airmass` method's times as ratios to
// schuler2012's scalar double time above the horizon, measured in the same run (when the
// filter ran both): scalar above and below against the goal's absolute 20 ns (a ratio would
// move with the machine: 20 ns was 5.6× schuler2012 at the 3.6 ns the issue measured, 7×
// at the 2.85 ns of the 2-core Xeon of December 2026) and batch above and below against
// ≤ 1.5× schuler2012. With
// --benchmark_repetitions the medians are used. CPU time, since the machine is shared.
//   build/bench/bench_chapman --benchmark_filter='double/(airmass|schuler2012)/'
//       --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// AIRMASS_SIMD=baseline times the baseline x86-64 batch kernel instead of the AVX2/FMA one.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "airmass/chapman.hpp"
#include "airmass/simd.hpp"
#include "run_times.hpp"

namespace {

using airmass::ChapmanMethod;

constexpr int kInputs = 4096;

template <class T>
struct Inputs {
    std::vector<T> x, c, s, m, e;
    Inputs(bool below_horizon) {
        for (int i = 0; i < kInputs; ++i) {
            const double u = (i * 0.6180339887498949) - std::floor(i * 0.6180339887498949);
            const double v = (i * 0.7548776662466927) - std::floor(i * 0.7548776662466927);
            const auto chi = airmass::ZenithAngle<T>::from_degrees(below_horizon ? 90.0 + 90.0 * v : 90.0 * v);
            x.push_back(T(std::pow(10.0, -2.0 + 9.0 * u)));
            c.push_back(chi.cos_chi);
            s.push_back(chi.sin_chi);
        }
        m.resize(x.size());
        e.resize(x.size());
    }
};

template <class T>
void BM_scalar(benchmark::State& state, ChapmanMethod method, bool below) {
    Inputs<T> in(below);
    for (auto _ : state)
        for (size_t i = 0; i < in.x.size(); ++i)
            benchmark::DoNotOptimize(airmass::chapman_scaled(method, in.x[i], airmass::ZenithAngle<T>{in.c[i], in.s[i]}));
    state.SetItemsProcessed(state.iterations() * int64_t(in.x.size()));
}

template <class T>
void BM_batch(benchmark::State& state, ChapmanMethod method, bool below) {
    Inputs<T> in(below);
    for (auto _ : state) {
        airmass::chapman_scaled_batch<T>(method, in.x, in.c, in.s, in.m, in.e);
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations() * int64_t(in.x.size()));
}

void register_all() {
    for (const auto& info : airmass::chapman_methods()) {
        if (info.method == ChapmanMethod::exact) continue;
        const std::string n(info.name);
        for (bool below : {false, true}) {
            const std::string where = below ? "/below" : "/above";
            benchmark::RegisterBenchmark(("scalar_double/" + n + where).c_str(), BM_scalar<double>, info.method, below);
            benchmark::RegisterBenchmark(("scalar_float/" + n + where).c_str(), BM_scalar<float>, info.method, below);
            benchmark::RegisterBenchmark(("batch_double/" + n + where).c_str(), BM_batch<double>, info.method, below);
            benchmark::RegisterBenchmark(("batch_float/" + n + where).c_str(), BM_batch<float>, info.method, below);
        }
    }
}

// Keeps ns per evaluation (CPU) of each benchmark: the median when there are repetitions,
// else the one run.
void print_goal_ratios(const std::map<std::string, double>& t) {
    const auto get = [&](const std::string& n) { auto it = t.find(n); return it == t.end() ? -1.0 : it->second; };
    const double base = get("scalar_double/schuler2012/above");
    if (base <= 0) return;
    std::printf("\nIssue 14 goal 5 (CPU ns per evaluation, double; batch kernel: %s)\n",
                std::string(airmass::simd_target_name(airmass::simd_target())).c_str());
    std::printf("  %-34s %8.2f ns  (baseline of the ratios)\n", "schuler2012 scalar above", base);
    struct Row { const char* label; const char* name; double goal_ratio; double goal_ns; };
    const Row rows[] = {
        {"airmass scalar above", "scalar_double/airmass/above", 0, 20.0},
        {"airmass scalar below", "scalar_double/airmass/below", 0, 20.0},
        {"airmass batch above", "batch_double/airmass/above", 1.5, 0},
        {"airmass batch below", "batch_double/airmass/below", 1.5, 0},
        {"schuler2012 scalar below", "scalar_double/schuler2012/below", 0, 0},
        {"schuler2012 batch above", "batch_double/schuler2012/above", 0, 0},
    };
    for (const auto& r : rows) {
        const double v = get(r.name);
        if (v <= 0) continue;
        if (r.goal_ns > 0)
            std::printf("  %-34s %8.2f ns  %5.2fx schuler2012 scalar above  (goal <= %.0f ns: %s)\n", r.label, v, v / base,
                        r.goal_ns, v <= r.goal_ns ? "met" : "NOT met");
        else if (r.goal_ratio > 0)
            std::printf("  %-34s %8.2f ns  %5.2fx schuler2012 scalar above  (goal <= %.2fx: %s)\n", r.label, v, v / base,
                        r.goal_ratio, v / base <= r.goal_ratio ? "met" : "NOT met");
        else
            std::printf("  %-34s %8.2f ns  %5.2fx\n", r.label, v, v / base);
    }
}

}  // namespace

int main(int argc, char** argv) {
    register_all();
    benchmark::Initialize(&argc, argv);
    // CPU ns per evaluation: each iteration evaluates kInputs points
    airmass::bench::RunTimes reporter([](const auto& run) { return run.GetAdjustedCPUTime() / kInputs; });
    benchmark::RunSpecifiedBenchmarks(&reporter);
    print_goal_ratios(reporter.all());
    benchmark::Shutdown();
    return 0;
}
