// A voxel's mean over its trilinear hat (vdb_export/src/volume/voxel_average.hpp) against an
// independent brute force: nested adaptive Gauss–Kronrod over the three axes of the hat, each
// split where the integrand has a kink (the hat's peak, the ground, the profile's knots, the
// top), of DensityProfile::at in the same flat-ground model h(x) = h + n·x.
#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <cmath>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "airmass/scene.hpp"
#include "volume/voxel_average.hpp"

namespace {

using airmass::DensityProfile;
using airmass::Vec3;

constexpr double kTop = 60e3;  // m

// ∫ over the hat [−Δ, Δ]³ of φ(x) g(h + n·x), with g(h) = ρ(h) (num) or 1 (den), restricted to
// 0 ≤ h (ground) and, for ρ, h ≤ top.
double brute(const DensityProfile& p, double h, Vec3<double> n, double d, bool density) {
    using GK = boost::math::quadrature::gauss_kronrod<double, 15>;
    std::vector<double> knots = {0.0, kTop};
    switch (p.kind) {
        case DensityProfile::Kind::tent: knots.insert(knots.end(), {p.bottom_m, p.peak_m, p.top_m}); break;
        case DensityProfile::Kind::piecewise_linear:
            for (const auto& k : p.knots) knots.push_back(k.first);
            break;
        case DensityProfile::Kind::constant: knots.insert(knots.end(), {p.bottom_m, p.top_m}); break;
        default: break;
    }
    const auto g = [&](double a) {
        if (a < 0.0) return 0.0;
        if (!density) return 1.0;
        return a > kTop ? 0.0 : p.at(a);
    };
    const auto hat = [d](double x) { return std::max(0.0, 1.0 - std::abs(x) / d); };
    // pieces of [−Δ, Δ] for the innermost axis (z), where the altitude crosses a knot
    const auto inner = [&](double x, double y) {
        std::vector<double> cut = {-d, 0.0, d};
        const double base = h + n.x * x + n.y * y;
        if (n.z != 0.0)
            for (double k : knots) {
                const double z = (k - base) / n.z;
                if (z > -d && z < d) cut.push_back(z);
            }
        std::sort(cut.begin(), cut.end());
        double s = 0.0;
        for (std::size_t i = 1; i < cut.size(); ++i)
            if (cut[i] > cut[i - 1])
                s += GK::integrate([&](double z) { return hat(z) * g(base + n.z * z); }, cut[i - 1], cut[i], 8, 1e-10);
        return s;
    };
    const auto middle = [&](double x) {
        return hat(x) * (GK::integrate([&](double y) { return hat(y) * inner(x, y); }, -d, 0.0, 8, 1e-9) +
                         GK::integrate([&](double y) { return hat(y) * inner(x, y); }, 0.0, d, 8, 1e-9));
    };
    return GK::integrate(middle, -d, 0.0, 8, 1e-8) + GK::integrate(middle, 0.0, d, 8, 1e-8);
}

DensityProfile exponential(double H) {
    DensityProfile p;
    p.kind = DensityProfile::Kind::exponential;
    p.scale_height_m = H;
    return p;
}

struct Case {
    std::string name;
    DensityProfile profile;
};

std::vector<Case> cases() {
    DensityProfile tent;
    tent.kind = DensityProfile::Kind::tent;
    tent.bottom_m = 10e3, tent.peak_m = 25e3, tent.top_m = 40e3;
    DensityProfile box;
    box.kind = DensityProfile::Kind::constant;
    box.bottom_m = 2e3, box.top_m = 5e3, box.value = 0.7;
    DensityProfile haze;  // a jump at 3 km and a kink at 1 km
    haze.kind = DensityProfile::Kind::piecewise_linear;
    haze.knots = {{0.0, 1.0}, {1e3, 2.0}, {3e3, 0.5}, {3e3, 0.1}, {8e3, 0.0}};
    DensityProfile full;  // constant up to the top
    full.kind = DensityProfile::Kind::constant;
    full.bottom_m = 0.0, full.top_m = 0.0, full.value = 1.0;
    return {{"mie", exponential(1.2e3)}, {"rayleigh", exponential(8e3)}, {"ozone tent", tent},
            {"box", box},                {"haze", haze},                  {"to the top", full}};
}

TEST(VoxelAverage, EqualsTheHatsMeanByBruteForce) {
    const std::vector<Vec3<double>> dirs = {
        {0, 0, 1}, glm::normalize(Vec3<double>(1, 1, 1)), glm::normalize(Vec3<double>(0.3, -0.5, 0.8)),
        glm::normalize(Vec3<double>(1, 0.2, 0.05))};
    double worst = 0.0;
    std::string where;
    int closed = 0, total = 0;
    std::map<std::string, double> worst_of;
    for (const Case& c : cases()) {
        const auto pieces = airmass::detail::DensityPieces::of(c.profile, kTop);
        for (double d : {600.0, 2e3, 7.86e3}) {
            std::vector<double> hs = {-1.5 * d, -0.4 * d, 0.0, 0.3 * d, 1.1 * d, 2.5 * d, kTop - 0.5 * d, 20e3};
            for (const auto& k : {1e3, 2e3, 3e3, 5e3, 10e3, 25e3, 40e3}) {
                hs.push_back(k - 0.3 * d);
                hs.push_back(k + 0.45 * d);
            }
            for (const auto& n : dirs)
                for (double h : hs) {
                    const double den = brute(c.profile, h, n, d, false);
                    const double want = den > 0.0 ? brute(c.profile, h, n, d, true) / den : 0.0;
                    const double got = airmass::detail::voxel_average(pieces, h, n, d);
                    ASSERT_TRUE(std::isfinite(got));
                    // scale: the profile's largest value near the voxel (a mean is at most that)
                    double scale = 0.0;
                    for (double a = std::max(0.0, h - 2 * d); a <= std::min(kTop, h + 2 * d); a += d / 64)
                        scale = std::max(scale, c.profile.at(a));
                    // relative where the mean is ≥ 1 % of the profile's nearby largest value, else
                    // absolute against that value (what a ray's optical depth feels)
                    const double err = scale > 0.0 ? std::abs(got - want) / std::max(want, 1e-2 * scale) : got;
                    double& w = worst_of[c.name + ", voxel " + std::to_string(int(d)) + " m"];
                    w = std::max(w, err);
                    ++total;
                    if (err < 1e-12) ++closed;
                    if (err > worst) {
                        worst = err;
                        where = c.name + ", voxel " + std::to_string(d) + " m, h " + std::to_string(h) + " m, n (" +
                                std::to_string(n.x) + ", " + std::to_string(n.y) + ", " + std::to_string(n.z) +
                                "): " + std::to_string(got) + " vs " + std::to_string(want);
                    }
                }
        }
    }
    std::printf("voxel_average vs brute force: worst relative error %.3g (%s); %d of %d cases within 1e-12\n", worst,
                where.c_str(), closed, total);
    for (const auto& [name, e] : worst_of) std::printf("  %-12s worst %.3g\n", name.c_str(), e);
    EXPECT_LT(worst, 1e-4) << where;  // measured 5.3e-6 (7.86 km voxels at a tent knot); the brute force is good to ~1e-8
}

}  // namespace

namespace {

// SymmetricAverages (the sampler's store of means shared by symmetric voxels) against
// voxel_average at each voxel's own geometry, on a small planet (radius 40 km, top 100 km,
// 9-km voxels: 25³ voxels), for three placements of its centre: every axis symmetric (the
// centre as origin), x and y only (the default surface origin: 2R/Δ not an integer), and a
// centre half a voxel off on x (an odd class of its own) with y and z whole.
TEST(VoxelAverage, SymmetricVoxelsShareOneMeanEqualToTheirOwn) {
    using airmass::detail::DensityPieces;
    using airmass::detail::SymmetricAverages;
    std::vector<DensityPieces> profiles;
    for (const Case& c : cases()) profiles.push_back(DensityPieces::of(c.profile, kTop));
    const double voxel = 9.0, radius = 40.0;  // km
    struct Placement {
        const char* name;
        Vec3<double> centre;
        std::size_t max_classes;  // ≈ voxels / the symmetry group's order (48, 8, 4), plus its fixed points
    };
    const int n = 12, count = (2 * n + 1) * (2 * n + 1) * (2 * n + 1);
    const std::vector<Placement> placements = {{"centre origin", {0, 0, 0}, std::size_t(count / 30)},  // 455 classes
                                               {"surface origin", {0, 0, -radius}, std::size_t(count / 6)},  // 2275
                                               {"x half a voxel off", {4.5, -9, 0}, std::size_t(count / 10)}};
    for (const auto& pl : placements) {
        SymmetricAverages store({voxel, pl.centre, radius, 1000.0}, profiles, std::size_t(64) << 20);
        SymmetricAverages unstored({voxel, pl.centre, radius, 1000.0}, profiles, 0);
        ASSERT_TRUE(store.useful()) << pl.name;
        double worst = 0.0;
        for (std::size_t c = 0; c < profiles.size(); ++c)
            for (int i = -n; i <= n; ++i)
                for (int j = -n; j <= n; ++j)
                    for (int k = -n; k <= n; ++k) {
                        const Vec3<double> p = Vec3<double>(i, j, k) * voxel;
                        const double r = glm::length(p - pl.centre);
                        const Vec3<double> up = r > 0.0 ? (p - pl.centre) / r : Vec3<double>(0, 0, 1);
                        const double want = airmass::detail::voxel_average(profiles[c], (r - radius) * 1000.0, up,
                                                                           voxel * 1000.0);
                        const double got = store.get(c, {i, j, k});
                        ASSERT_TRUE(std::isfinite(got));
                        worst = std::max(worst, std::abs(got - want) / std::max(want, 1e-300));
                        ASSERT_EQ(unstored.get(c, {i, j, k}), got) << pl.name;  // the same canonical member
                    }
        // every voxel's mean as its own geometry gives it, to rounding (the canonical member's
        // altitude and widths are the voxel's up to the order of a sum of squares)
        EXPECT_LT(worst, 1e-12) << pl.name;
        EXPECT_GT(store.stored(), 0u) << pl.name;
        EXPECT_LE(store.stored(), pl.max_classes) << pl.name << ": the symmetric voxels were not shared";
        EXPECT_EQ(unstored.stored(), 0u) << pl.name;  // no bytes: computed, never stored

        // mirrored and swapped voxels get bit-identical means
        const auto mirror = [&](int i, int a) { return int(std::lround(2.0 * pl.centre[a] / voxel)) - i; };
        for (std::size_t c = 0; c < profiles.size(); ++c)
            for (int i = -n + 2; i <= n - 2; i += 3)
                for (int j = -n + 2; j <= n - 2; j += 2) {
                    const double v = store.get(c, {i, j, 1});
                    EXPECT_EQ(store.get(c, {mirror(i, 0), j, 1}), v) << pl.name;
                    EXPECT_EQ(store.get(c, {i, mirror(j, 1), 1}), v) << pl.name;
                    if (pl.centre[0] == 0.0 && pl.centre[1] == 0.0) {
                        EXPECT_EQ(store.get(c, {j, i, 1}), v) << pl.name;
                    }
                }
    }
    // Without a symmetric axis the store is not used (the sampler then computes directly).
    SymmetricAverages none({voxel, {0.3, 0.4, 0.5}, radius, 1000.0}, profiles, std::size_t(1) << 20);
    EXPECT_FALSE(none.useful());
}

// Two workers asking at once get the single-threaded values.
TEST(VoxelAverage, SymmetricAveragesFromTwoThreadsMatchOne) {
    using airmass::detail::DensityPieces;
    using airmass::detail::SymmetricAverages;
    std::vector<DensityPieces> profiles;
    for (const Case& c : cases()) profiles.push_back(DensityPieces::of(c.profile, kTop));
    // 41³ voxels, ~9 000 classes: every shard grows past its first 64 slots while both ask.
    const SymmetricAverages::Lattice lattice{9.0, {0, 0, -40.0}, 40.0, 1000.0};
    const int n = 20;
    std::vector<double> one, two[2];
    SymmetricAverages a(lattice, profiles, std::size_t(64) << 20), b(lattice, profiles, std::size_t(64) << 20);
    for (int i = -n; i <= n; ++i)
        for (int j = -n; j <= n; ++j)
            for (int k = -n; k <= n; ++k) one.push_back(a.get(0, {i, j, k}));
    std::vector<std::thread> workers;
    for (int w = 0; w < 2; ++w)
        workers.emplace_back([&, w] {
            for (int i = -n; i <= n; ++i)  // the two in opposite orders, so they meet in the store
                for (int j = -n; j <= n; ++j)
                    for (int k = -n; k <= n; ++k) {
                        const int s = w == 0 ? 1 : -1;
                        two[w].push_back(b.get(0, {s * i, s * j, s * k}));
                    }
        });
    for (auto& t : workers) t.join();
    std::reverse(two[1].begin(), two[1].end());
    EXPECT_EQ(two[0], one);
    EXPECT_EQ(two[1], one);
}

}  // namespace
