// The view-ray march (transport/view_march.inc), through both of its consumers: the full
// shell (single_scattering_batch: the importance-map midpoints) and the medium cut to a box
// (box_limited_radiance: adaptive Gauss–Legendre panels). A fan of 64 view rays from a
// camera 2 m above the ground (ground-noon's sun, 60° elevation) and at sunset, 48
// wavelengths. Build this file against two revisions and compare items/s of the same
// benchmark (issue 13: the march must not be > 5 % slower than the two loops it replaced).
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "airmass/atmosphere.hpp"
#include "airmass/render.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/single_scattering.hpp"

namespace {

using namespace airmass;

const Atmosphere& earth48() {
    static const Atmosphere atm = [] {
        std::vector<double> wl;
        for (int i = 0; i < 48; ++i) wl.push_back(360.0 + 10.0 * i);
        return compile_atmosphere(load_preset("earth"), wl);
    }();
    return atm;
}

glm::dvec3 sun_at(double elevation_deg) {
    const double e = elevation_deg * std::numbers::pi / 180.0;
    return {0.0, std::cos(e), std::sin(e)};
}

// 64 directions along +X, from 20° below to 60° above the horizon.
std::vector<glm::dvec3> fan() {
    std::vector<glm::dvec3> d;
    for (int k = 0; k < 64; ++k) {
        const double a = (-20.0 + 80.0 * k / 63.0) * std::numbers::pi / 180.0;
        d.push_back({std::cos(a), 0.05, std::sin(a)});
    }
    return d;
}

void BM_Shell(benchmark::State& state) {
    const Atmosphere& atm = earth48();
    const auto dirs = fan();
    std::vector<Vec3<double>> v(dirs.begin(), dirs.end());
    const std::size_t n = v.size() * atm.wavelength_count();
    std::vector<double> T(n), Lr(n), Lm(n), L(n);
    const glm::dvec3 sun = sun_at(double(state.range(0)));
    for (auto _ : state) {
        single_scattering_batch(atm, 2.0, Vec3<double>(sun), v, {T, Lr, Lm, L});
        benchmark::DoNotOptimize(L.data());
    }
    state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(v.size()));
}
BENCHMARK(BM_Shell)->Arg(60)->Arg(-2)->Unit(benchmark::kMicrosecond);

// range(0): sun elevation (deg); range(1): the box's extent (km), 40 = ground-noon's view box.
void BM_Box(benchmark::State& state) {
    const Atmosphere& atm = earth48();
    const auto dirs = fan();
    const double x = 1e3 * double(state.range(1));
    const MediumBox box{{-x, -x, 0.0}, {x, x, std::min(x, 100e3)}};
    const glm::dvec3 origin(0.0, 0.0, 2.0), sun = sun_at(double(state.range(0)));
    std::vector<double> L(atm.wavelength_count());
    for (auto _ : state) {
        for (const auto& d : dirs) {
            box_limited_radiance(atm, box, origin, d, sun, L);
            benchmark::DoNotOptimize(L.data());
        }
    }
    state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(dirs.size()));
}
BENCHMARK(BM_Box)->Args({60, 40})->Args({-2, 40})->Args({60, 2})->Args({60, 2000})->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
