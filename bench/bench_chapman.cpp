// Google Benchmark for the Chapman family: ns per evaluation, scalar and batch, float
// and double, above and below the horizon. The ratio against schuler2012 (the cheapest
// published form) is printed by `airmass report chapman`, which times every method in
// one run; this file is for profiling single methods:
//   build/bench/bench_chapman --benchmark_filter=airmass
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "airmass/chapman.hpp"

namespace {

using airmass::ChapmanMethod;

template <class T>
struct Inputs {
    std::vector<T> x, c, s, m, e;
    Inputs(bool below_horizon) {
        for (int i = 0; i < 4096; ++i) {
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
    state.SetItemsProcessed(state.iterations() * in.x.size());
}

template <class T>
void BM_batch(benchmark::State& state, ChapmanMethod method, bool below) {
    Inputs<T> in(below);
    for (auto _ : state) {
        airmass::chapman_scaled_batch<T>(method, in.x, in.c, in.s, in.m, in.e);
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations() * in.x.size());
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

}  // namespace

int main(int argc, char** argv) {
    register_all();
    benchmark::Initialize(&argc, argv);
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
