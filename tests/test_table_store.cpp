// Multiple-scattering tables kept between runs (table_store.hpp, table_cache.hpp) and the
// multiple-scattering view (evaluator.hpp MsView).
//
// The store: a record read back is the record written, bit for bit; the key changes with
// every input the precompute reads and with nothing else; a record with another key, a
// flipped byte or a missing byte is refused; compute_tables asks a store before computing and
// gives it what it computed; the disk store replaces a bad entry and keeps its folder under
// its size bound.
// The view: the sky with multiple scattering interpolated from the view against the same sky
// with the tables integrated along every ray (an independent path: multiple_scattering_radiance
// per ray), over all directions of a ground observer and an observer at 10 km.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <string>
#include <tuple>
#include <vector>

#include "airmass/atmosphere.hpp"
#include "airmass/evaluator.hpp"
#include "airmass/multiple_scattering.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/sky.hpp"
#include "airmass/table_cache.hpp"
#include "airmass/table_store.hpp"

namespace airmass {
namespace {

namespace fs = std::filesystem;

Atmosphere small_earth(double albedo = 0.1) {
    Scene scene = load_preset("earth");
    scene.planet.ground_albedo = albedo;
    EvalSettings es;
    es.sun_disc = false;
    return compile_atmosphere(scene, std::vector<double>{680.0, 550.0, 440.0}, es);
}

MsSettings small_tables() {
    MsSettings s;
    s.table = {6, 16, 12, 4};
    return s;
}

void expect_same_tables(const MultipleScattering& a, const MultipleScattering& b) {
    EXPECT_EQ(a.mode, b.mode);
    EXPECT_EQ(a.grid.size.altitude, b.grid.size.altitude);
    EXPECT_EQ(a.grid.size.azimuth, b.grid.size.azimuth);
    EXPECT_EQ(a.grid.mu_s_min, b.grid.mu_s_min);
    EXPECT_EQ(a.wavelength_count, b.wavelength_count);
    EXPECT_EQ(a.slot, b.slot);
    EXPECT_EQ(a.phase_radiance, b.phase_radiance);
    EXPECT_EQ(a.ground_irradiance, b.ground_irradiance);
    EXPECT_EQ(a.highest_order, b.highest_order);
    EXPECT_EQ(a.tail_added, b.tail_added);
    EXPECT_EQ(a.repeats_after_order, b.repeats_after_order);
    EXPECT_EQ(a.tail_ratio, b.tail_ratio);
    ASSERT_EQ(a.orders.size(), b.orders.size());
    for (std::size_t k = 0; k < a.orders.size(); ++k) EXPECT_EQ(a.orders[k].relative, b.orders[k].relative);
}

// A record read back is the record written, bit for bit. The record the disk cache writes is
// pieces: joined, they are serialize_tables' bytes; G goes to the file from the tables
// themselves (no copy); and the checksum taken piece by piece — over pieces whose sizes are
// not multiples of its 32-byte blocks — is the one a reader computes over the whole payload.
TEST(TableStore, RecordRoundTripsBitForBit) {
    const Atmosphere atm = small_earth();
    const MsSettings s = small_tables();
    const MultipleScattering ms = precompute_multiple_scattering(atm, s);
    const std::string key = ms_table_key(atm, s);
    const auto bytes = serialize_tables(ms, key);
    const auto back = deserialize_tables(bytes, key);
    ASSERT_TRUE(back.has_value());
    expect_same_tables(ms, *back);

    const TableRecord record = table_record(ms, key);
    ASSERT_GE(record.pieces.size(), 3u);
    std::vector<std::byte> joined;
    bool in_place = false, odd_size = false;
    for (const auto& piece : record.pieces) {
        joined.insert(joined.end(), piece.begin(), piece.end());
        in_place |= piece.data() == reinterpret_cast<const std::byte*>(ms.phase_radiance.data()) &&
                    piece.size() == ms.phase_radiance.size() * sizeof(float);
        odd_size |= piece.size() % 32 != 0;
    }
    EXPECT_TRUE(in_place);
    EXPECT_TRUE(odd_size);
    EXPECT_EQ(record.size(), joined.size());
    EXPECT_EQ(joined, bytes);
}

TEST(TableStore, KeyFollowsEveryInputOfThePrecomputeAndNothingElse) {
    const Atmosphere atm = small_earth();
    const MsSettings s = small_tables();
    const std::string key = ms_table_key(atm, s);
    // Not part of the tables: threads, the sun's spectrum, the view-ray knobs.
    {
        MsSettings t = s;
        t.threads = 7;
        EXPECT_EQ(ms_table_key(atm, t), key);
        Atmosphere a = atm;
        set_constant_irradiance(a, 1.0);
        a.settings.view_samples = 99;
        a.settings.sun_disc = true;
        EXPECT_EQ(ms_table_key(a, s), key);
    }
    // Part of them: each one changes the key.
    std::vector<std::string> changed;
    {
        Atmosphere a = atm;
        a.ground_albedo = 0.3;
        changed.push_back(ms_table_key(a, s));
    }
    {
        Atmosphere a = atm;
        a.constituents[0].scattering_per_m[1] *= 1.0 + 1e-15;
        changed.push_back(ms_table_key(a, s));
    }
    {
        Atmosphere a = atm;
        a.constituents[1].phase.g = 0.7;
        changed.push_back(ms_table_key(a, s));
    }
    {
        Atmosphere a = atm;
        a.settings.chapman = ChapmanMethod::exact;
        changed.push_back(ms_table_key(a, s));
    }
    {
        Atmosphere a = atm;
        a.top_altitude_m += 1.0;
        changed.push_back(ms_table_key(a, s));
    }
    {
        MsSettings t = s;
        t.table.sun_zenith = 13;
        changed.push_back(ms_table_key(atm, t));
    }
    {
        MsSettings t = s;
        t.max_order = 5;
        changed.push_back(ms_table_key(atm, t));
    }
    {
        MsSettings t = s;
        t.mode = MsMode::isotropic_lut;
        changed.push_back(ms_table_key(atm, t));
    }
    for (std::size_t i = 0; i < changed.size(); ++i) {
        EXPECT_NE(changed[i], key) << "change " << i;
        for (std::size_t j = 0; j < i; ++j) EXPECT_NE(changed[i], changed[j]) << i << " vs " << j;
    }
}

TEST(TableStore, ForeignTruncatedOrCorruptRecordsAreRefused) {
    const Atmosphere atm = small_earth();
    const MsSettings s = small_tables();
    const MultipleScattering ms = precompute_multiple_scattering(atm, s);
    const std::string key = ms_table_key(atm, s);
    const auto bytes = serialize_tables(ms, key);
    MsSettings other = s;
    other.max_order = 4;
    EXPECT_FALSE(deserialize_tables(bytes, ms_table_key(atm, other)).has_value());
    // Every truncation point in the header, and a few in the payload.
    for (std::size_t n : {std::size_t(0), std::size_t(7), std::size_t(16), key.size(), bytes.size() / 2,
                          bytes.size() - 1})
        EXPECT_FALSE(deserialize_tables(std::span(bytes).first(n), key).has_value()) << n;
    auto longer = bytes;
    longer.push_back(std::byte{0});
    EXPECT_FALSE(deserialize_tables(longer, key).has_value());
    // One flipped bit anywhere (magic, key, lengths, checksum, payload) is caught.
    for (std::size_t at : {std::size_t(3), std::size_t(20), key.size() + 24, key.size() + 40, bytes.size() / 2,
                           bytes.size() - 3}) {
        auto bad = bytes;
        bad[at] ^= std::byte{0x10};
        EXPECT_FALSE(deserialize_tables(bad, key).has_value()) << "bit flipped at " << at;
    }
}

// A store in memory that counts what it was asked.
struct CountingStore final : TableStore {
    std::map<std::string, std::shared_ptr<const MultipleScattering>> kept;
    int loads = 0, stores = 0, hits = 0;
    std::shared_ptr<const MultipleScattering> load(std::string_view key) override {
        ++loads;
        auto it = kept.find(std::string(key));
        if (it == kept.end()) return nullptr;
        ++hits;
        return it->second;
    }
    void store(std::string_view key, const MultipleScattering& t) override {
        ++stores;
        kept[std::string(key)] = std::make_shared<const MultipleScattering>(t);
    }
};

TEST(TableStore, ComputeTablesAsksTheStoreFirstAndFillsIt) {
    const Atmosphere atm = small_earth();
    CountingStore store;
    MultipleScatteringOptions options;
    options.tables = small_tables();
    options.tables.store = &store;
    const auto first = compute_tables(atm, options, 2);
    EXPECT_EQ(store.loads, 1);
    EXPECT_EQ(store.stores, 1);
    EXPECT_EQ(store.hits, 0);
    const auto second = compute_tables(atm, options, 2);
    EXPECT_EQ(store.hits, 1);
    EXPECT_EQ(store.stores, 1);
    EXPECT_EQ(second.get(), store.kept.begin()->second.get());  // the store's tables, not a recomputation
    expect_same_tables(*first, *second);
    // Another atmosphere is another entry.
    compute_tables(small_earth(0.5), options, 2);
    EXPECT_EQ(store.stores, 2);
    EXPECT_EQ(store.kept.size(), 2u);
    // Diagnostics are never kept nor read.
    options.tables.keep_radiance = true;
    compute_tables(atm, options, 2);
    EXPECT_EQ(store.loads, 3);
}

struct TempDir {
    fs::path path;
    TempDir() {
        path = fs::temp_directory_path() / ("airmass-table-cache-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "-" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(path);
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(path, ec);
    }
};

std::size_t entries_in(const fs::path& dir) {
    std::size_t n = 0;
    for (const auto& e : fs::directory_iterator(dir)) n += e.path().extension() == ".amt" ? 1 : 0;
    return n;
}

TEST(DiskTableStore, KeepsReadsReplacesBadEntriesAndStaysUnderItsBound) {
    TempDir dir;
    const Atmosphere atm = small_earth();
    const MsSettings s = small_tables();
    const MultipleScattering ms = precompute_multiple_scattering(atm, s);
    const std::string key = ms_table_key(atm, s);
    DiskTableStore store(dir.path / "nested", std::uintmax_t(1) << 30);
    EXPECT_EQ(store.load(key), nullptr);
    EXPECT_EQ(store.last_load(), DiskTableStore::Outcome::miss);
    store.store(key, ms);  // creates the folder
    ASSERT_TRUE(fs::exists(store.entry_path(key)));
    for (const auto& e : fs::directory_iterator(dir.path / "nested"))
        EXPECT_EQ(e.path().extension(), ".amt") << "stray file " << e.path();
    auto back = store.load(key);
    ASSERT_NE(back, nullptr);
    EXPECT_EQ(store.last_load(), DiskTableStore::Outcome::hit);
    expect_same_tables(ms, *back);

    // G is read in place, from the entry's mapped file (Linux: the mapping that holds it in
    // /proc/self/maps), and the tables stay whole after the entry is removed and replaced
    // (the cache only ever renames over or unlinks an entry: the mapping keeps its file).
    {
        std::ifstream maps("/proc/self/maps");
        const auto at = reinterpret_cast<std::uintptr_t>(back->phase_radiance.data());
        std::string line, holder;
        while (std::getline(maps, line)) {
            unsigned long long lo = 0, hi = 0;
            if (std::sscanf(line.c_str(), "%llx-%llx", &lo, &hi) == 2 && at >= lo && at < hi) holder = line;
        }
        EXPECT_NE(holder.find(store.entry_path(key).filename().string()), std::string::npos)
            << "G is not in the entry's mapping: " << holder;
        const auto kept = store.load(key);
        ASSERT_NE(kept, nullptr);
        fs::remove(store.entry_path(key));
        MsSettings s3 = s;
        s3.max_order = 3;
        store.store(key, precompute_multiple_scattering(atm, s3));  // another file under the same name
        expect_same_tables(ms, *kept);
    }
    store.store(key, ms);

    // A corrupted entry is refused, removed, and not trusted. The byte is flipped, not set: the
    // record ends with the precompute's wall time, whose bytes differ from run to run (a byte
    // set to a fixed value was already that value in one CI run in 256).
    {
        std::fstream f(store.entry_path(key), std::ios::in | std::ios::out | std::ios::binary);
        f.seekg(-5, std::ios::end);
        const int was = f.get();
        ASSERT_NE(was, std::char_traits<char>::eof());
        f.seekp(-5, std::ios::end);
        f.put(static_cast<char>(was ^ 0xff));
        ASSERT_TRUE(f.good());
    }
    EXPECT_EQ(store.load(key), nullptr);
    EXPECT_EQ(store.last_load(), DiskTableStore::Outcome::rejected);
    EXPECT_FALSE(fs::exists(store.entry_path(key)));

    // The size bound: with room for about one record, storing a second removes the older.
    const std::uintmax_t one = serialize_tables(ms, key).size();
    DiskTableStore small(dir.path / "small", one + one / 2);
    small.store(key, ms);
    MsSettings s2 = s;
    s2.max_order = 3;
    const std::string key2 = ms_table_key(atm, s2);
    small.store(key2, precompute_multiple_scattering(atm, s2));
    EXPECT_EQ(entries_in(dir.path / "small"), 1u);
    EXPECT_TRUE(fs::exists(small.entry_path(key2)));
    // A record larger than the bound is not written at all.
    DiskTableStore none(dir.path / "none", 16);
    none.store(key, ms);
    EXPECT_FALSE(fs::exists(none.entry_path(key)));
}

TEST(DiskTableStore, AnUnwritableFolderIsNoCacheNotAnError) {
    const Atmosphere atm = small_earth();
    const MsSettings s = small_tables();
    const MultipleScattering ms = precompute_multiple_scattering(atm, s);
    DiskTableStore store("/proc/airmass-no-such-folder", std::uintmax_t(1) << 30);
    store.store(ms_table_key(atm, s), ms);
    EXPECT_FALSE(store.last_problem().empty());
    EXPECT_EQ(store.load(ms_table_key(atm, s)), nullptr);
}

// ---- the multiple-scattering view -----------------------------------------------------------

// Error of the sky's radiance with the view's multiple scattering against per-ray integration,
// per direction max_λ |ΔL| / max_λ L (the image metric of docs/sky.md, a channel's error
// relative to the pixel's brightness): p95 over directions uniform in solid angle (cos θ in
// 180 steps × azimuth every 15°), max over those and bands of 0.05° steps within 2.5° of the
// astronomical horizon and of the ground's (the Earth's limb, 3.2° below it from 10 km).
struct ViewError {
    double p95 = 0.0, max = 0.0;
};

ViewError view_error(const Evaluator& ev, double altitude_m, double sun_elevation_deg, int intervals) {
    const Vec3<double> sun(std::cos(sun_elevation_deg * M_PI / 180.0), 0.0, std::sin(sun_elevation_deg * M_PI / 180.0));
    const MsView view = ev.ms_view(altitude_m, sun, intervals, 2);
    std::vector<double> zenith;
    for (int i = 0; i < 180; ++i) zenith.push_back(std::acos(1.0 - (i + 0.5) / 90.0) * 180.0 / M_PI);
    const std::size_t uniform = zenith.size();
    const double ground_deg = Horizon::of(ev.atmosphere().planet_radius_m, ev.atmosphere().top_altitude_m, altitude_m)
                                  .theta_horizon * 180.0 / M_PI;
    for (double z = 87.5; z < 92.5; z += 0.05) zenith.push_back(z);
    if (ground_deg > 92.5)
        for (double z = ground_deg - 2.5; z < ground_deg + 2.5; z += 0.05) zenith.push_back(z);
    std::vector<Vec3<double>> dirs;
    for (double z : zenith)
        for (double a = 0.0; a <= 180.0; a += 15.0) {
            const double zr = z * M_PI / 180.0, ar = a * M_PI / 180.0;
            dirs.push_back({std::sin(zr) * std::cos(ar), std::sin(zr) * std::sin(ar), std::cos(zr)});
        }
    const std::size_t nw = ev.wavelength_count(), n = dirs.size(), per_zenith = dirs.size() / zenith.size();
    std::vector<double> t(n * nw), r(n * nw), m(n * nw), with_view(n * nw), per_ray(n * nw);
    ev.radiance(altitude_m, sun, dirs, RadianceOut{t, r, m, with_view}, &view);
    ev.radiance(altitude_m, sun, dirs, RadianceOut{t, r, m, per_ray}, nullptr);
    std::vector<double> e;
    ViewError out;
    for (std::size_t k = 0; k < n; ++k) {
        double diff = 0.0, scale = 0.0;
        for (std::size_t w = 0; w < nw; ++w) {
            diff = std::max(diff, std::abs(with_view[k * nw + w] - per_ray[k * nw + w]));
            scale = std::max(scale, per_ray[k * nw + w]);
        }
        if (!(scale > 0.0)) continue;
        out.max = std::max(out.max, diff / scale);
        if (k < uniform * per_zenith) e.push_back(diff / scale);
    }
    std::sort(e.begin(), e.end());
    out.p95 = e[std::size_t(0.95 * double(e.size() - 1))];
    return out;
}

TEST(MsView, SkyWithTheViewMatchesPerRayIntegration) {
    const Atmosphere atm = small_earth();
    MultipleScatteringOptions options;
    options.tables = small_tables();
    const Evaluator ev(atm, compute_tables(atm, options, 2), 16);
    // Total radiance (single + multiple) at the view's default resolution. The sky images of
    // docs/sky.md measure p95 0.08–0.21 %, max 0.7–1.7 % for sun 2° and −4° at 512 × 256. Without
    // the view's normalisation by the ray's transmittance, 1 m below the horizon was 10× off.
    // From 10 km at sun −4° the ground rays just below the Earth's limb (twilight: the radiance
    // falls 25× across it) were 39 % off here and 34 % in earth's 256 × 128 image while the
    // ground piece's rows were spaced as the sky's (c = 0.25); with c = 0.01 there
    // (SkyGridLayout::view) 6.7 % here, 1.3 % in that image. The sky rows crowd at the horizon
    // as much (c = 0.04): the worst direction from 2 m at sun 30° 0.41 → 0.066 %, from 10 km at
    // 20° 0.58 → 0.26 %. From above the ozone (50 km) and from orbit the sky is split at the
    // rays tangent to the profiles' knots and crowded at the kinks and the limb (Horizon::kinks):
    // 7.0 → 0.17 % and 1.5 → 0.13 % (0.75 % with the orbit's rows at c = 0.25 before).
    for (const auto& [altitude, elevation, max_error] : std::vector<std::tuple<double, double, double>>{
             {2.0, 30.0, 0.002}, {2.0, 2.0, 0.03}, {2.0, -4.0, 0.03}, {10000.0, 20.0, 0.004}, {10000.0, -4.0, 0.1},
             {50e3, 10.0, 0.005}, {400e3, 30.0, 0.003}}) {
        const ViewError e = view_error(ev, altitude, elevation, kSkyDefaultMultipleGrid);
        EXPECT_LT(e.p95, 0.003) << "altitude " << altitude << " m, sun " << elevation << " deg";
        EXPECT_LT(e.max, max_error) << "altitude " << altitude << " m, sun " << elevation << " deg";
    }
    // A finer view is closer.
    EXPECT_LT(view_error(ev, 2.0, 10.0, 64).p95, view_error(ev, 2.0, 10.0, 8).p95);
}

// From orbit the view's last sky row lies on the limb, a ray tangent to the top of the
// atmosphere, and all of a row's rays share one quadrature: on the tangent itself rounding
// decided whether the row met the shell, and the whole row came out 0 for 145 of 360 sun
// azimuths (24.9 % off next to the limb). Inside it by SkyGrid::kEdge, every node holds light.
TEST(MsView, TheLimbRowFromOrbitHoldsLightForEverySunAzimuth) {
    const Atmosphere atm = small_earth();
    MultipleScatteringOptions options;
    options.tables = small_tables();
    const Evaluator ev(atm, compute_tables(atm, options, 2), 16);
    const std::size_t nw = atm.wavelength_count();
    for (int a = 0; a < 72; ++a) {
        const double az = 5.0 * a * std::numbers::pi / 180.0, el = 30.0 * std::numbers::pi / 180.0;
        const Vec3<double> sun(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
        const MsView view = ev.ms_view(400e3, sun, kSkyDefaultMultipleGrid, 1);
        const int limb = view.grid.rows_sky - 1;
        for (int j = 0; j < view.grid.columns(); ++j)
            EXPECT_GT(view.grid.at(limb, j)[nw / 2], 0.0) << "sun azimuth " << 5 * a << " deg, column " << j;
    }
}

TEST(MsView, RefusedForAnotherObserverAndZeroWithoutTables) {
    const Atmosphere atm = small_earth();
    MultipleScatteringOptions options;
    options.tables = small_tables();
    const Evaluator ev(atm, compute_tables(atm, options, 2), 16);
    const Vec3<double> sun(0.6, 0.0, 0.8), dir(1.0, 0.0, 0.0);
    const MsView view = ev.ms_view(2.0, sun, 16, 1);
    std::vector<double> t(3), r(3), m(3), l(3);
    EXPECT_THROW(ev.radiance(3.0, sun, std::span(&dir, 1), RadianceOut{t, r, m, l}, &view), std::invalid_argument);
    EXPECT_THROW(ev.ms_view(2.0, sun, 1, 1), std::invalid_argument);
    // below the ground or not a number: refused, not a view of NaN zenith angles
    for (const double bad : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()})
        EXPECT_THROW(ev.ms_view(bad, sun, 16, 1), std::invalid_argument) << bad;
    const Evaluator single(atm);
    const MsView empty = single.ms_view(2.0, sun, 16, 1);
    for (double v : empty.grid.values) EXPECT_EQ(v, 0.0);
}

}  // namespace
}  // namespace airmass
