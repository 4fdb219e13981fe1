// vdb_export: round trips through OpenVDB files, regions, tiling, metadata, analytic
// descriptions and bad input; the OpenVDB-free volume layer's plan and dense blocks against
// the OpenVDB writer's grids. Small regions and coarse voxels keep this fast.
#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/tools/Dense.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "airmass/progress.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/vdb_export.hpp"
#include "airmass/vdb_grids.hpp"
#include "airmass/vdb_trade.hpp"
#include "airmass/volume.hpp"
#include "volume/voxel_average.hpp"

namespace fs = std::filesystem;
using namespace airmass;
using openvdb::Coord;
using openvdb::Vec3d;

namespace {

class TempDir {
public:
    TempDir() {
        path_ = fs::temp_directory_path() /
                ("airmass_test_vdb_" + std::to_string(::getpid()) + "_" + std::to_string(counter_++));
        fs::remove_all(path_);
        fs::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ec;
        fs::permissions(path_, fs::perms::owner_all, fs::perm_options::add, ec);
        fs::remove_all(path_, ec);
    }
    const fs::path& path() const { return path_; }
    fs::path operator/(const std::string& name) const { return path_ / name; }
    std::vector<std::string> entries() const {
        std::vector<std::string> out;
        for (const auto& e : fs::directory_iterator(path_)) out.push_back(e.path().filename().string());
        return out;
    }

private:
    fs::path path_;
    static inline int counter_ = 0;
};

struct ReadBack {
    openvdb::MetaMap::Ptr file_meta;
    std::map<std::string, openvdb::FloatGrid::Ptr> grids;
};

ReadBack read_vdb(const fs::path& path) {
    openvdb::initialize();
    openvdb::io::File file(path.string());
    file.open();
    ReadBack r;
    r.file_meta = file.getMetadata();
    for (auto it = file.beginName(); it != file.endName(); ++it)
        r.grids[it.gridName()] = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid(it.gridName()));
    file.close();
    return r;
}

// Independent altitude of a world point for the earth preset in km, origin on the surface.
double altitude_km(const Vec3d& p, const Vec3d& center = Vec3d(0, 0, -6360)) { return (p - center).length() - 6360.0; }

const Constituent& constituent(const Scene& s, const std::string& name) {
    for (const auto& c : s.constituents)
        if (c.name == name) return c;
    throw std::runtime_error("no constituent " + name);
}

// A small box through the whole atmosphere above the origin, 2-km voxels.
VdbOptions small_box(VoxelValues values = VoxelValues::automatic) {
    VdbOptions o;
    o.region = VdbRegion::box;
    o.box = {-10, -10, -1, 10, 10, 62};
    o.voxel_size = 2.0;
    o.voxel_values = values;
    return o;
}

}  // namespace

TEST(Vdb, RoundTripPointValuesAtVoxelCentresEqualTheAnalyticDensity) {
    const Scene scene = load_preset("earth");
    TempDir dir;
    const fs::path out = dir / "a.vdb";
    const VdbStats stats = export_vdb(scene, small_box(VoxelValues::point), out);
    ASSERT_EQ(stats.files.size(), 1u);
    EXPECT_EQ(stats.files[0], out);
    EXPECT_EQ(stats.file_bytes, fs::file_size(out));
    const ReadBack rb = read_vdb(out);
    ASSERT_EQ(rb.grids.size(), 3u);
    std::size_t checked = 0;
    for (const char* name : {"rayleigh", "mie", "ozone"}) {
        SCOPED_TRACE(name);
        ASSERT_TRUE(rb.grids.count(name));
        const auto& g = rb.grids.at(name);
        EXPECT_EQ(g->getGridClass(), openvdb::GRID_FOG_VOLUME);
        EXPECT_GT(g->activeVoxelCount(), 0u);
        const DensityProfile& prof = constituent(scene, name).profile;
        for (auto it = g->cbeginValueOn(); it; ++it) {
            const Vec3d p = g->indexToWorld(it.getCoord());
            const double h_km = altitude_km(p);
            const double expected = prof.at(h_km * 1000.0);
            // float storage: relative error ≤ 2^-23 of the stored value, plus the double→float rounding
            EXPECT_NEAR(*it, expected, 2e-7 * expected + 1e-30) << "at " << p;
            ++checked;
        }
    }
    EXPECT_GT(checked, 1000u);
    // Spot values by hand: Rayleigh exp(−h/8 km) and the ozone tent 10–25–40 km on the axis.
    auto ray = rb.grids.at("rayleigh")->getConstAccessor();
    EXPECT_FLOAT_EQ(ray.getValue(Coord(0, 0, 0)), 1.0f);
    EXPECT_FLOAT_EQ(ray.getValue(Coord(0, 0, 4)), float(std::exp(-1.0)));
    auto oz = rb.grids.at("ozone")->getConstAccessor();
    EXPECT_FLOAT_EQ(oz.getValue(Coord(0, 0, 10)), float(10.0 / 15.0));  // 20 km
    EXPECT_FALSE(oz.isValueOn(Coord(0, 0, 4)));                          // 8 km: below the tent
}

// The default values: each voxel the mean of its constituent's profile over its trilinear hat
// (voxel_average, checked against a brute force in test_voxel_average.cpp) at the voxel's own
// altitude and vertical — the file holds what that function gives, rounded to float.
TEST(Vdb, RoundTripAverageValuesAreEachVoxelsHatMean) {
    const Scene scene = load_preset("earth");
    TempDir dir;
    const fs::path out = dir / "a.vdb";
    export_vdb(scene, small_box(VoxelValues::average), out);
    const ReadBack rb = read_vdb(out);
    std::size_t checked = 0;
    for (const char* name : {"rayleigh", "mie", "ozone"}) {
        SCOPED_TRACE(name);
        const auto& g = rb.grids.at(name);
        EXPECT_EQ(g->metaValue<std::string>("airmass:voxel_values"), "average");
        const auto pieces = airmass::detail::DensityPieces::of(constituent(scene, name).profile, 60e3);
        for (auto it = g->cbeginValueOn(); it; ++it) {
            const Vec3d p = g->indexToWorld(it.getCoord());
            const Vec3d up = (p - Vec3d(0, 0, -6360.0)).unit();
            const double expected =
                airmass::detail::voxel_average(pieces, altitude_km(p) * 1000.0, {up[0], up[1], up[2]}, 2000.0);
            EXPECT_NEAR(*it, expected, 2e-7 * expected + 1e-30) << "at " << p;
            ++checked;
        }
    }
    EXPECT_GT(checked, 1000u);
    // By hand on the axis (the vertical is z: the hat's mean of exp(−h/H) is exp(−h/H) times
    // the triangle's moment generating function (sinh y / y)², y = Δ/2H): Rayleigh at 8 km,
    // 2-km voxels: e^{−1} (sinh(1/8)/(1/8))²; the ozone tent is linear around 20 km: its value.
    auto ray = rb.grids.at("rayleigh")->getConstAccessor();
    const double y = 1.0 / 8.0;
    EXPECT_FLOAT_EQ(ray.getValue(Coord(0, 0, 4)), float(std::exp(-1.0) * std::pow(std::sinh(y) / y, 2)));
    auto oz = rb.grids.at("ozone")->getConstAccessor();
    EXPECT_FLOAT_EQ(oz.getValue(Coord(0, 0, 10)), float(10.0 / 15.0));  // 20 km
    // At the tent's foot (10 km) the hat [8, 12] km sees the flank (h − 10)/15 above it with the
    // triangle's weight (2 − |x|)/4: ∫₀² x/15 · (2 − x)/4 dx = 1/45 (a point value would be 0);
    // at 8 km the hat ends where the tent begins: 0, inactive.
    EXPECT_FLOAT_EQ(oz.getValue(Coord(0, 0, 5)), float(1.0 / 45.0));
    EXPECT_FALSE(oz.isValueOn(Coord(0, 0, 4)));
}

// The default (automatic): the mean for a constituent whose thinnest layer is under two voxels,
// the density at the index point otherwise — said per grid in the metadata.
TEST(Vdb, AutomaticValuesFollowEachConstituentsThinnestLayer) {
    const Scene scene = load_preset("earth");
    VdbOptions o = small_box();  // 2-km voxels: Mie (1.2 km) averaged, Rayleigh (8 km) and the ozone tent (15 km) not
    EXPECT_EQ(o.voxel_values, VoxelValues::automatic);
    std::map<std::string, VoxelValues> want = {
        {"rayleigh", VoxelValues::point}, {"mie", VoxelValues::average}, {"ozone", VoxelValues::point}};
    for (const auto& c : resolve_vdb_layout(scene, o).constituents) EXPECT_EQ(c.values, want.at(c.name)) << c.name;
    TempDir dir;
    export_vdb(scene, o, dir / "a.vdb");
    const ReadBack rb = read_vdb(dir / "a.vdb");
    for (const auto& [name, v] : want)
        EXPECT_EQ(rb.grids.at(name)->metaValue<std::string>("airmass:voxel_values"), voxel_values_name(v)) << name;
    o.voxel_size = 0.5;  // finer than half of every layer: points throughout
    for (const auto& c : resolve_vdb_layout(scene, o).constituents) EXPECT_EQ(c.values, VoxelValues::point) << c.name;
    // A view: the means only for layers its camera is above (it looks across them); from inside
    // a layer it looks along it, where points keep the density at the ground.
    Scene viewed = scene;
    viewed.camera = Camera{};  // on the ground, looking along it
    VdbOptions v;
    v.region = VdbRegion::view;
    v.voxel_size = 8.0;  // coarser than half of every layer
    for (const auto& c : resolve_vdb_layout(viewed, v).constituents) EXPECT_EQ(c.values, VoxelValues::point) << c.name;
    viewed.camera->position_m[2] = 20e3;  // above the aerosol (1.2 km: its layer ends at 6 km), inside the rest
    viewed.camera->max_distance_m = 400e3;
    want = {{"rayleigh", VoxelValues::point}, {"mie", VoxelValues::average}, {"ozone", VoxelValues::point}};
    for (const auto& c : resolve_vdb_layout(viewed, v).constituents) EXPECT_EQ(c.values, want.at(c.name)) << c.name;
    viewed.camera->position_m[2] = 400e3;  // above them all
    for (const auto& c : resolve_vdb_layout(viewed, v).constituents) EXPECT_EQ(c.values, VoxelValues::average) << c.name;
}

TEST(Vdb, EveryVoxelOfTheRegionAboveTheThresholdIsActive) {
    const Scene scene = load_preset("earth");
    const VdbOptions opt = small_box(VoxelValues::point);
    const VdbVolume vol = build_vdb_volume(scene, opt);
    ASSERT_EQ(vol.tiles.size(), 1u);
    const VdbLayout& L = vol.layout;
    for (std::size_t c = 0; c < L.constituents.size(); ++c) {
        SCOPED_TRACE(L.constituents[c].name);
        auto acc = vol.tiles[0].grids[c]->getConstAccessor();
        std::size_t expected_on = 0;
        // Voxel centres inside the box (no margin needed for this check) and the shell.
        for (int i = -5; i <= 5; ++i)
            for (int j = -5; j <= 5; ++j)
                for (int k = 0; k <= 31; ++k) {
                    const Vec3d p(2.0 * i, 2.0 * j, 2.0 * k);
                    const double h = altitude_km(p);
                    if (h < 0 || h > 60) continue;
                    const double rho = L.constituents[c].source->profile.at(h * 1000);
                    if (rho > 0 && rho >= L.constituents[c].density_threshold) {
                        EXPECT_TRUE(acc.isValueOn(Coord(i, j, k))) << p;
                        ++expected_on;
                    } else {
                        EXPECT_FALSE(acc.isValueOn(Coord(i, j, k))) << p;
                    }
                }
        EXPECT_GT(expected_on, 0u);
    }
}

TEST(Vdb, MetadataIsCompleteAndDescribesTheScene) {
    const Scene scene = load_preset("earth");
    TempDir dir;
    export_vdb(scene, small_box(), dir / "m.vdb");
    const ReadBack rb = read_vdb(dir / "m.vdb");
    for (const auto& [name, g] : rb.grids) {
        SCOPED_TRACE(name);
        EXPECT_EQ(g->metaValue<std::string>("airmass:length_unit"), "km");
        EXPECT_DOUBLE_EQ(g->metaValue<double>("airmass:planet_radius"), 6360.0);
        EXPECT_EQ(g->metaValue<Vec3d>("airmass:planet_center"), Vec3d(0, 0, -6360.0));
        EXPECT_DOUBLE_EQ(g->metaValue<double>("airmass:atmosphere_top"), 6420.0);
        EXPECT_EQ(g->metaValue<std::string>("airmass:spectral_basis"), "rgb_bruneton_680_550_440");
        EXPECT_EQ(g->metaValue<Vec3d>("airmass:rgb_wavelengths_nm"), Vec3d(680, 550, 440));
        EXPECT_EQ(g->metaValue<std::string>("airmass:version"), "0.1.0");
        EXPECT_DOUBLE_EQ(g->metaValue<double>("airmass:voxel_size"), 2.0);
        const Constituent& c = constituent(scene, name);
        const Vec3d s = g->metaValue<Vec3d>("airmass:scattering_rgb"), a = g->metaValue<Vec3d>("airmass:absorption_rgb");
        const double lambdas[3] = {680, 550, 440};
        for (int i = 0; i < 3; ++i) {
            EXPECT_NEAR(s[i], c.scattering.at(lambdas[i]) * 1000.0, 1e-12 * std::abs(s[i]) + 1e-30);
            EXPECT_NEAR(a[i], c.absorption.at(lambdas[i]) * 1000.0, 1e-12 * std::abs(a[i]) + 1e-30);
        }
        EXPECT_DOUBLE_EQ(g->metaValue<double>("airmass:g"), c.phase.g);
        EXPECT_FALSE(g->metaValue<std::string>("airmass:phase").empty());
        const auto profile = nlohmann::json::parse(g->metaValue<std::string>("airmass:profile"));
        if (name == "rayleigh") {
            EXPECT_EQ(profile["type"], "exponential");
            EXPECT_DOUBLE_EQ(profile["scale_height"].get<double>(), 8.0);
            EXPECT_EQ(g->metaValue<std::string>("airmass:phase"), "rayleigh");
            EXPECT_NEAR(s[1], 1.24062e-6 * std::pow(0.55, -4.0) * 1000.0, 1e-12);
        } else if (name == "ozone") {
            EXPECT_EQ(profile["type"], "tent");
            EXPECT_DOUBLE_EQ(profile["peak"].get<double>(), 25.0);
            EXPECT_EQ(s, Vec3d(0, 0, 0));
            EXPECT_GT(a[0], 0.0);
        } else {
            EXPECT_EQ(name, "mie");
            EXPECT_DOUBLE_EQ(profile["scale_height"].get<double>(), 1.2);
            EXPECT_DOUBLE_EQ(g->metaValue<double>("airmass:g"), 0.8);
        }
    }
    EXPECT_EQ(rb.file_meta->metaValue<std::string>("airmass:length_unit"), "km");
    const auto scene_json = nlohmann::json::parse(rb.file_meta->metaValue<std::string>("airmass:scene"));
    EXPECT_TRUE(scene_json.is_object());
}

TEST(Vdb, TransformPlacesThePlanetCentreWhereTheSceneSays) {
    const Scene scene = load_preset("earth");
    for (const PlanetOrigin origin : {PlanetOrigin::surface, PlanetOrigin::center}) {
        for (const LengthUnit unit : {LengthUnit::km, LengthUnit::m}) {
            SCOPED_TRACE(std::string(length_unit_name(unit)) + (origin == PlanetOrigin::center ? " center" : " surface"));
            const double L = metres_per_unit(unit);
            const double zc = origin == PlanetOrigin::surface ? -6360e3 / L : 0.0;
            const double zs = zc + 6360e3 / L;  // the surface point above the centre
            VdbOptions o;
            o.unit = unit;
            o.origin = origin;
            o.region = VdbRegion::box;
            o.voxel_size = 500.0 / L;  // 500 m
            o.voxel_values = VoxelValues::point;  // the density at the index points: exact values to place
            o.box = {-1000 / L, -1000 / L, zs - 1000 / L, 1000 / L, 1000 / L, zs + 3000 / L};
            TempDir dir;
            export_vdb(scene, o, dir / "t.vdb");
            const ReadBack rb = read_vdb(dir / "t.vdb");
            const auto& g = rb.grids.at("rayleigh");
            EXPECT_NEAR(g->voxelSize()[0], 500.0 / L, 1e-12);
            EXPECT_EQ(g->metaValue<Vec3d>("airmass:planet_center"), Vec3d(0, 0, zc));
            // The voxel at the surface point holds density 1; 1 km higher, exp(−1/8).
            const Coord surface = g->transform().worldToIndexCellCentered(Vec3d(0, 0, zs));
            EXPECT_NEAR(g->indexToWorld(surface)[2], zs, 1e-9 * std::abs(zs) + 1e-12);
            auto acc = g->getConstAccessor();
            EXPECT_NEAR(acc.getValue(surface), 1.0f, 1e-6f);
            EXPECT_NEAR(acc.getValue(surface.offsetBy(0, 0, 2)), std::exp(-1.0 / 8.0), 1e-6);
        }
    }
}

TEST(Vdb, ViewRegionHoldsOnlyWhatTheCameraCanSee) {
    Scene scene = load_preset("earth");
    scene.camera = Camera{};  // ground, +X, 60° over 640 px, 640×360, 200 km
    VdbOptions o;
    o.region = VdbRegion::view;
    o.voxel_size = 4.0;
    const VdbVolume vol = build_vdb_volume(scene, o);
    const VdbLayout& L = vol.layout;
    ASSERT_TRUE(L.view);
    const double m = std::sqrt(3.0) * 4.0;  // the interpolation margin
    const double tan_h = std::tan(M_PI / 6), tan_v = tan_h * 360.0 / 640.0;
    const Vec3d cam(0, 0, 0.002);
    std::size_t n = 0;
    for (const auto& tile : vol.tiles)
        for (const auto& g : tile.grids) {
            if (!g) continue;
            for (auto it = g->cbeginValueOn(); it; ++it, ++n) {
                const Vec3d p = g->indexToWorld(it.getCoord());
                const Vec3d d = p - cam;
                ASSERT_LE(d.length(), 200.0 + m) << p;
                // |y| ≤ x tan_h and |z| ≤ x tan_v, with the plane margins (≤ √3 · voxel)
                ASSERT_LE(std::abs(d[1]) - d[0] * tan_h, m * std::sqrt(1 + tan_h * tan_h)) << p;
                ASSERT_LE(std::abs(d[2]) - d[0] * tan_v, m * std::sqrt(1 + tan_v * tan_v)) << p;
                ASSERT_GE(altitude_km(p), -m - 1e-9) << p;
                ASSERT_LE(altitude_km(p), 60.0 + 1e-9) << p;
            }
        }
    EXPECT_GT(n, 1000u);
    // What the camera sees is there: points on the view axis and up the frustum.
    auto ray = vol.tiles.size() == 1 ? vol.tiles[0].grids[0]->getConstAccessor()
                                     : openvdb::FloatGrid::create()->getConstAccessor();
    if (vol.tiles.size() == 1) {
        for (double x : {20.0, 100.0, 180.0}) EXPECT_TRUE(ray.isValueOn(Coord(int(x / 4), 0, 1))) << x;
        EXPECT_TRUE(ray.isValueOn(Coord(40, 0, 10)));   // 160 km out, 40 km up (inside the 17.6° half-height)
        EXPECT_FALSE(ray.isValueOn(Coord(-10, 0, 2)));  // behind the camera
        EXPECT_FALSE(ray.isValueOn(Coord(25, 20, 2)));  // 100 km out, 80 km aside: outside 30°
    }
}

TEST(Vdb, ViewFromOrbitSkipsThePlanetsHiddenSide) {
    Scene scene = load_preset("earth");
    Camera cam;
    cam.position_m[2] = 2000e3;  // 2000 km up
    cam.direction[0] = 0;
    cam.direction[2] = -1;  // looking straight down
    cam.up[0] = 1;
    cam.up[2] = 0;
    cam.fov_deg = 120;
    cam.width = cam.height = 64;
    cam.max_distance_m = 30000e3;
    scene.camera = cam;
    VdbOptions o;
    o.region = VdbRegion::view;
    o.voxel_size = 60.0;
    o.tile_voxels = -1;
    const VdbVolume vol = build_vdb_volume(scene, o);
    const auto& L = vol.layout;
    const Vec3d c = to_openvdb(L.planet_center), eye = to_openvdb(L.view->position);
    const double occluder = 6360.0 - std::sqrt(3.0) * 60.0;
    std::size_t n = 0;
    for (const auto& g : vol.tiles[0].grids) {
        if (!g) continue;
        for (auto it = g->cbeginValueOn(); it; ++it, ++n) {
            const Vec3d p = g->indexToWorld(it.getCoord());
            // the segment eye → p does not pass through the (margin-shrunk) planet
            const Vec3d d = p - eye, f = eye - c;
            const double t = std::clamp(-f.dot(d) / d.dot(d), 0.0, 1.0);
            ASSERT_GE((f + d * t).length(), occluder - 1e-9) << p;
            ASSERT_GT(p[2], -6360.0) << p;  // nothing on the far hemisphere
        }
    }
    EXPECT_GT(n, 100u);
}

namespace {

// A tiled grid on the common lattice: its voxel q is voxel q + o there (o: the tile's index
// offset, VolumePlan::index_offset). Checks first that the grid's transform puts voxel q where
// the common transform (`common`) puts q + o, and that its metadata records o.
openvdb::FloatGrid::Ptr to_common_lattice(const openvdb::FloatGrid& g, const VoxelCoord& o,
                                          const openvdb::math::Transform& common) {
    const Coord d(o[0], o[1], o[2]);
    if (o != VoxelCoord{0, 0, 0}) {
        EXPECT_EQ(g.metaValue<openvdb::Vec3i>("airmass:index_offset"), openvdb::Vec3i(o[0], o[1], o[2]));
    }
    for (const Coord q : {Coord(0, 0, 0), Coord(-37, 5, 1001), Coord(8, -8, 7)}) {
        const Vec3d a = g.indexToWorld(q), b = common.indexToWorld(q + d);
        EXPECT_NEAR((a - b).length(), 0.0, 1e-12 * (1.0 + b.length())) << q;
    }
    auto out = openvdb::FloatGrid::create(0.0f);
    auto acc = out->getAccessor();
    for (auto it = g.cbeginValueOn(); it; ++it) acc.setValueOn(it.getCoord() + d, *it);
    return out;
}

}  // namespace

TEST(Vdb, TilesPartitionTheVoxelsOfTheSingleGrid) {
    const Scene scene = load_preset("earth");
    VdbOptions o;
    o.region = VdbRegion::planet;
    o.voxel_size = 50.0;
    o.tile_voxels = -1;
    const VdbVolume one = build_vdb_volume(scene, o);
    o.tile_voxels = 64;
    TempDir dir;
    const VdbStats tiled = export_vdb(scene, o, dir / "shell.vdb");
    ASSERT_GT(tiled.tiles, 1u);
    EXPECT_LT(tiled.dense_bytes, one.stats.dense_bytes);
    EXPECT_EQ(tiled.dense_bytes_untiled, one.stats.dense_bytes);
    EXPECT_EQ(tiled.active_voxels, one.stats.active_voxels);
    // Files: <stem>.NNN.tile.vdb (no digits before the extension) and the manifest.
    ASSERT_EQ(tiled.files.size(), tiled.tiles + 1);
    EXPECT_EQ(tiled.files[0].filename(), "shell.000.tile.vdb");
    EXPECT_EQ(tiled.files.back().filename(), "shell.tiles.json");
    EXPECT_FALSE(fs::exists(dir / "shell.vdb"));
    const auto manifest = nlohmann::json::parse(std::ifstream(tiled.files.back()));
    EXPECT_EQ(manifest["tiles"].size(), tiled.tiles);
    // Union of the tiles = the single grid, and no voxel twice.
    for (std::size_t c = 0; c < one.layout.constituents.size(); ++c) {
        const std::string name = one.layout.constituents[c].name;
        SCOPED_TRACE(name);
        auto seen = openvdb::BoolGrid::create(false);
        auto seen_acc = seen->getAccessor();
        for (std::size_t t = 0; t < tiled.tiles; ++t) {
            const ReadBack rb = read_vdb(tiled.files[t]);
            if (!rb.grids.count(name)) continue;
            // On the common lattice (the manifest's boxes): the file's grid is on the tile's own.
            const auto& file_grid = rb.grids.at(name);
            EXPECT_EQ(file_grid->metaValue<int>("airmass:tile"), int(t));
            const auto& mo = manifest["tiles"][t]["index_offset"];
            const VoxelCoord offset{mo[0].get<int>(), mo[1].get<int>(), mo[2].get<int>()};
            EXPECT_EQ(offset, tiled.index_offsets.at(t));
            const auto g = to_common_lattice(*file_grid, offset, one.tiles[0].grids[c]->transform());
            auto ref = one.tiles[0].grids[c]->getConstAccessor();
            // Guard voxels (kVolumeGuardValue): the single grid's active voxels just outside this
            // tile's values (26 neighbours), inside the plan's dense box; not counted as values.
            std::uint64_t guards = 0;
            const auto pg = std::find_if(tiled.grids.begin(), tiled.grids.end(),
                                         [&](const VdbGridStats& s) { return s.tile == t && s.name == name; });
            ASSERT_NE(pg, tiled.grids.end());
            const VoxelBox dense_box{{pg->dense_bbox[0], pg->dense_bbox[1], pg->dense_bbox[2]},
                                     {pg->dense_bbox[3], pg->dense_bbox[4], pg->dense_bbox[5]}};
            const VoxelBox value_box{{pg->bbox[0], pg->bbox[1], pg->bbox[2]}, {pg->bbox[3], pg->bbox[4], pg->bbox[5]}};
            for (auto it = g->cbeginValueOn(); it; ++it) {
                const Coord q = it.getCoord();
                ASSERT_TRUE(dense_box.contains(VoxelCoord{q.x(), q.y(), q.z()})) << q;
                if (*it != kVolumeGuardValue) continue;
                ++guards;
                ASSERT_FALSE(value_box.contains(VoxelCoord{q.x(), q.y(), q.z()})) << "guard among the values: " << q;
                ASSERT_TRUE(ref.isValueOn(q)) << "guard where the single grid has no value: " << q;
                bool next_to_value = false;
                for (int dx = -1; dx <= 1; ++dx)
                    for (int dy = -1; dy <= 1; ++dy)
                        for (int dz = -1; dz <= 1; ++dz) {
                            const Coord n = q.offsetBy(dx, dy, dz);
                            next_to_value |= g->tree().isValueOn(n) && g->tree().getValue(n) != kVolumeGuardValue;
                        }
                ASSERT_TRUE(next_to_value) << "guard away from the values: " << q;
            }
            EXPECT_GT(guards, 0u);
            EXPECT_EQ(manifest["tiles"][t]["grids"][name]["active_voxels"].get<std::uint64_t>(),
                      g->activeVoxelCount() - guards);
            for (auto it = g->cbeginValueOn(); it; ++it) {
                if (*it == kVolumeGuardValue) continue;
                ASSERT_FALSE(seen_acc.isValueOn(it.getCoord())) << "twice: " << it.getCoord();
                seen_acc.setValueOn(it.getCoord(), true);
                ASSERT_EQ(*it, ref.getValue(it.getCoord()));
            }
        }
        EXPECT_EQ(seen->activeVoxelCount(), one.tiles[0].grids[c]->activeVoxelCount());
    }
}

// Cycles before Blender 5.0 bounds each Volume object by a mesh on its grid's 8³ leaf
// boundaries, and loses one of two tiles where their meshes' faces coincide (docs/vdb.md
// "Tiling"). Each tile's grids are on a lattice shifted by its index offset: in world space, the
// leaf boundaries of tiles whose lattice cubes touch (26 neighbours) lie on different planes on
// every axis, while every voxel keeps its world position (TilesPartitionTheVoxelsOfTheSingleGrid).
TEST(Vdb, NeighbouringTilesLeafBoundariesDifferOnEveryAxis) {
    const Scene scene = load_preset("earth");
    VdbOptions o;
    o.region = VdbRegion::planet;
    o.voxel_size = 50.0;
    o.tile_voxels = 64;
    const VdbVolume vol = build_vdb_volume(scene, o);
    const std::size_t n = vol.tiles.size();
    ASSERT_GT(n, 8u);
    const auto common = openvdb::math::Transform::createLinearTransform(vol.layout.voxel_size);
    const int T = vol.plan.tiling.tile_voxels;
    ASSERT_EQ(T, 64);
    // Per tile: its leaves' origins on the common lattice, mod 8 (all the same), and its cube.
    std::vector<VoxelCoord> residue(n), cube(n);
    for (std::size_t t = 0; t < n; ++t) {
        bool first = true;
        for (const auto& g : vol.tiles[t].grids) {
            if (!g) continue;
            for (auto leaf = g->tree().cbeginLeaf(); leaf; ++leaf) {
                const Vec3d w = g->indexToWorld(leaf->origin());  // world space
                const Vec3d i = common->worldToIndex(w);
                VoxelCoord r{};
                for (int a = 0; a < 3; ++a) {
                    const double k = std::round(i[a]);
                    ASSERT_NEAR(i[a], k, 1e-6) << "a leaf origin off the common lattice";
                    r[a] = int(((long long)k % 8 + 8) % 8);
                }
                if (first) residue[t] = r, first = false;
                ASSERT_EQ(r, residue[t]) << "tile " << t << ": leaves on different lattices";
            }
        }
        ASSERT_FALSE(first) << "tile " << t << " has no leaf";
        const auto s = std::find_if(vol.stats.grids.begin(), vol.stats.grids.end(),
                                    [&](const VdbGridStats& g) { return g.tile == t; });
        for (int a = 0; a < 3; ++a) cube[t][a] = (s->bbox[a] - vol.plan.tiling.base[a]) / T;
    }
    std::size_t pairs = 0, faces = 0;
    for (std::size_t t = 0; t < n; ++t)
        for (std::size_t u = t + 1; u < n; ++u) {
            int far = 0, same = 0;
            for (int a = 0; a < 3; ++a) far = std::max(far, std::abs(cube[t][a] - cube[u][a]));
            if (far != 1) continue;
            ++pairs;
            for (int a = 0; a < 3; ++a) same += cube[t][a] == cube[u][a];
            faces += same == 2;
            for (int a = 0; a < 3; ++a)
                EXPECT_NE(residue[t][a], residue[u][a]) << "tiles " << t << " and " << u << ", axis " << a;
        }
    EXPECT_GT(pairs, n);
    EXPECT_GT(faces, n / 2);
}

TEST(Vdb, AutomaticTilingSkipsTheEmptyInteriorOfTheShell) {
    const Scene scene = load_preset("earth");
    VdbOptions o;
    o.region = VdbRegion::planet;
    o.voxel_size = 30.0;  // the shell is 2 voxels thick: one box is mostly empty
    o.voxel_values = VoxelValues::point;  // (a mean reaches √3 voxels further: 4 voxels thick)
    VdbRunOptions run;
    run.dry_run = true;
    const VdbStats s = export_vdb(scene, o, "unused.vdb", run);
    EXPECT_GT(s.tiles, 1u);
    EXPECT_LE(s.tiles, std::size_t(o.max_tiles));
    EXPECT_LT(s.dense_bytes, s.dense_bytes_untiled * 6 / 10);
}

TEST(Vdb, AutomaticVoxelSizeFollowsScaleHeightsAndTheCamera) {
    Scene scene = load_preset("earth");
    scene.camera = Camera{};
    VdbOptions o;
    o.region = VdbRegion::view;
    EXPECT_NEAR(auto_voxel_size(scene, o), 0.6, 1e-12);  // half the Mie scale height, km
    o.unit = LengthUnit::m;
    EXPECT_NEAR(auto_voxel_size(scene, o), 600.0, 1e-9);
    // From 10 000 km up a 640-px, 60° camera resolves 2·tan30°/640 · (10000 − 60) km ≈ 17.9 km.
    scene.camera->position_m[2] = 10000e3;
    o.unit = LengthUnit::km;
    EXPECT_NEAR(auto_voxel_size(scene, o), 2 * std::tan(M_PI / 6) / 640 * (16360.0 - 6420.0), 1e-9);
    // The whole shell: coarse enough for the dense-box budget, finer when the budget grows.
    VdbOptions p;
    p.region = VdbRegion::planet;
    const double v_planet = auto_voxel_size(scene, p);
    EXPECT_GT(v_planet, 10.0);
    EXPECT_LT(v_planet, 30.0);
    // Rounded up so that 2R is a whole number of voxels (the centre, at (0, 0, −R), then on the
    // lattice's symmetry planes: SymmetricAverages), by less than v²/2R.
    const double twice_r = 2 * 6360.0;
    EXPECT_NEAR(twice_r / v_planet, std::round(twice_r / v_planet), 1e-9);
    p.max_dense_mb *= 8;
    const double v_finer = auto_voxel_size(scene, p);
    EXPECT_NEAR(twice_r / v_finer, std::round(twice_r / v_finer), 1e-9);
    EXPECT_NEAR(v_finer, v_planet / 2, v_planet * v_planet / twice_r);  // dense ∝ v⁻³
    p.origin = PlanetOrigin::center;  // the centre at the origin: nothing to round
    EXPECT_NEAR(auto_voxel_size(scene, p), v_finer, v_planet * v_planet / twice_r);
    // 2R/v even (the centre on the lattice along z: 48 voxels a class, not 16) for a preset whose
    // size before rounding gives an odd quotient (earth-hazy: 627.x).
    VdbOptions q;
    q.region = VdbRegion::planet;
    const Scene hazy = load_preset("earth-hazy");
    const double twice_hazy = 2e-3 * hazy.planet.radius_m, v_hazy = auto_voxel_size(hazy, q);
    EXPECT_NEAR(twice_hazy / v_hazy, 2.0 * std::round(twice_hazy / v_hazy / 2.0), 1e-9) << v_hazy;
    // The rounding never changes what a constituent's voxels hold: a planet whose size is set by the
    // aerosol's layer (radius 40 km, top 100 km, scale height 7 km: half a layer, 3.5 km, is the
    // automatic voxel; 80/3.5 = 22.9) keeps 3.5 km and point values — rounded to 80/22 = 3.64 km
    // it would have averaged the aerosol (a review's finding).
    Scene small = load_preset("earth");
    small.planet.radius_m = 40e3;
    small.planet.atmosphere_top_m = 100e3;
    for (auto& c : small.constituents)
        if (c.name == "mie") c.profile.scale_height_m = 7e3;
    EXPECT_NEAR(auto_voxel_size(small, q), 3.5, 1e-12);
    for (const auto& c : resolve_vdb_layout(small, q).constituents)
        EXPECT_EQ(c.values, VoxelValues::point) << c.name;
}

TEST(Vdb, ThresholdFollowsTheToleranceOnOpticalDepth) {
    const Scene scene = load_preset("earth");
    VdbOptions o = small_box();
    const VdbLayout L = resolve_vdb_layout(scene, o);
    // Means reach (1 + √3) voxels past the top (the nodes above it and their interpolant): the
    // chord of that sphere, not the top's.
    for (const auto& c : L.constituents) {
        const double top = 6420.0 + (c.values == VoxelValues::average ? (1.0 + std::sqrt(3.0)) * L.voxel_size : 0.0);
        const double chord = 2 * std::sqrt(top * top - 6360.0 * 6360.0);
        const double ext = std::max({c.scattering_rgb[0] + c.absorption_rgb[0], c.scattering_rgb[1] + c.absorption_rgb[1],
                                     c.scattering_rgb[2] + c.absorption_rgb[2]});
        EXPECT_NEAR(c.density_threshold * ext * chord, 1e-4, 1e-16) << c.name;
    }
    bool any_average = false;
    for (const auto& c : L.constituents) any_average |= c.values == VoxelValues::average;
    EXPECT_TRUE(any_average) << "the box should average a constituent (the means' chord untested)";
    o.tolerance = 0;
    for (const auto& c : resolve_vdb_layout(scene, o).constituents) EXPECT_EQ(c.density_threshold, 0.0);
}

// ---- bad input: clear errors, no file left behind -------------------------------------------

namespace {

void expect_error_and_no_file(const Scene& scene, const VdbOptions& o, const std::string& fragment,
                              const fs::path& out = {}) {
    TempDir dir;
    const fs::path path = out.empty() ? dir / "x.vdb" : out;
    try {
        export_vdb(scene, o, path);
        ADD_FAILURE() << "no error; expected one mentioning '" << fragment << "'";
    } catch (const std::exception& e) {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
    EXPECT_TRUE(dir.entries().empty()) << "left " << dir.entries().front();
}

}  // namespace

TEST(VdbBadInput, VoxelSizeMustBePositive) {
    const Scene scene = load_preset("earth");
    for (double v : {0.0, -1.0, std::nan(""), double(INFINITY)}) {
        VdbOptions o = small_box();
        o.voxel_size = v;
        expect_error_and_no_file(scene, o, "--voxel-size");
    }
}

// Fix 22 (docs/reliability.md): a voxel many scale heights across extrapolates the density
// below the ground past a float grid's range. The earth preset's haze (H = 1.2 km): a voxel of
// 50 km extrapolates it by exp(sqrt(3) 50 / 1.2) = 2e31 (kept), one of 70 km by 7e43 (refused,
// naming the option, the constituent and the float range); the automatic voxel size of a tiny
// dense limit (the fuzz input, 311 km) is refused the same way.
TEST(VdbBadInput, VoxelTooCoarseForAFloatGrid) {
    const Scene scene = load_preset("earth");
    VdbOptions o;
    o.region = VdbRegion::planet;
    // A voxel's mean is at most the profile's largest value in the air (1 here): any voxel size
    // is accepted.
    o.voxel_size = 70.0;
    for (const auto& c : resolve_vdb_layout(scene, o).constituents)
        EXPECT_LE(c.density_max, 1.0) << c.name;
    // Point values extrapolate the profile below the ground: refused where that leaves floats.
    o.voxel_values = VoxelValues::point;
    o.voxel_size = 50.0;
    const VdbLayout kept = resolve_vdb_layout(scene, o);
    for (const auto& c : kept.constituents)
        EXPECT_LE(c.source->profile.at(c.band_min_m), double(std::numeric_limits<float>::max())) << c.name;
    o.voxel_size = 70.0;
    try {
        resolve_vdb_layout(scene, o);
        ADD_FAILURE() << "a 70 km voxel was accepted";
    } catch (const VdbError& e) {
        const std::string what = e.what();
        for (const char* part : {"--voxel-size = 70 km", "too coarse for constituent 'mie'", "3.4e38"})
            EXPECT_NE(what.find(part), std::string::npos) << part << " not in: " << what;
    }
    o.voxel_size.reset();
    o.max_dense_mb = 0.27;
    o.tolerance = 0.0100942;
    try {
        resolve_vdb_layout(scene, o);
        ADD_FAILURE() << "the automatic voxel size of a 0.27 MB dense limit was accepted";
    } catch (const VdbError& e) {
        const std::string what = e.what();
        for (const char* part : {"(automatic)", "--max-dense-mb"})
            EXPECT_NE(what.find(part), std::string::npos) << part << " not in: " << what;
    }
}

TEST(VdbBadInput, RegionOutsideTheAtmosphere) {
    const Scene scene = load_preset("earth");
    VdbOptions o = small_box();
    o.box = {0, 0, 100, 10, 10, 110};  // 100–110 km up: above the 60-km top
    expect_error_and_no_file(scene, o, "region outside the atmosphere");
    o.box = {-10, -10, -500, 10, 10, -400};  // inside the planet
    expect_error_and_no_file(scene, o, "region outside the atmosphere");
    // A camera in space looking away from the planet.
    Scene s2 = scene;
    s2.camera = Camera{};
    s2.camera->position_m[2] = 1000e3;
    s2.camera->direction[0] = 0;
    s2.camera->direction[2] = 1;
    s2.camera->up[0] = 1;
    s2.camera->up[2] = 0;
    s2.camera->max_distance_m = 5000e3;
    VdbOptions v;
    v.region = VdbRegion::view;
    v.voxel_size = 20.0;
    expect_error_and_no_file(s2, v, "region outside the atmosphere");
}

TEST(VdbBadInput, CameraInsideThePlanetOrMissing) {
    Scene scene = load_preset("earth");
    VdbOptions o;
    o.region = VdbRegion::view;
    o.voxel_size = 4.0;
    expect_error_and_no_file(scene, o, "[camera]");
    scene.camera = Camera{};
    scene.camera->position_m[2] = -10.0;
    expect_error_and_no_file(scene, o, "camera inside the planet");
}

TEST(VdbBadInput, UnwritableOutput) {
    const Scene scene = load_preset("earth");
    expect_error_and_no_file(scene, small_box(), "does not exist", "/nonexistent-airmass-dir/x.vdb");
    {
        TempDir dir;
        fs::create_directory(dir / "sub.vdb");
        try {
            export_vdb(scene, small_box(), dir / "sub.vdb");
            ADD_FAILURE() << "writing over a directory succeeded";
        } catch (const VdbError& e) {
            EXPECT_NE(std::string(e.what()).find("directory"), std::string::npos) << e.what();
        }
    }
    if (::geteuid() != 0) {  // root writes anywhere
        TempDir dir;
        fs::create_directory(dir / "ro");
        fs::permissions(dir / "ro", fs::perms::owner_read | fs::perms::owner_exec);
        expect_error_and_no_file(scene, small_box(), "not writable", dir / "ro" / "x.vdb");
        fs::permissions(dir / "ro", fs::perms::owner_all);
        EXPECT_TRUE(fs::is_empty(dir / "ro"));
    }
}

TEST(VdbBadInput, DenseBoxLimitRefusesWithASuggestion) {
    const Scene scene = load_preset("earth");
    VdbOptions o = small_box();
    o.max_dense_mb = 0.01;
    expect_error_and_no_file(scene, o, "--max-dense-mb");
    try {
        build_vdb_volume(scene, o);
    } catch (const VdbError& e) {
        EXPECT_NE(std::string(e.what()).find("use --voxel-size"), std::string::npos) << e.what();
    }
    o.max_dense_mb = 1024;
    o.max_memory_mb = 0.01;
    expect_error_and_no_file(scene, o, "--max-memory-mb");
}

TEST(VdbBadInput, CancelledBeforeWritingLeavesNothing) {
    const Scene scene = load_preset("earth");
    TempDir dir;
    CancelFlag cancel;
    cancel.request();
    VdbRunOptions run;
    run.cancel = &cancel;
    EXPECT_THROW(export_vdb(scene, small_box(), dir / "c.vdb", run), Cancelled);
    EXPECT_TRUE(dir.entries().empty());
}

TEST(VdbBadInput, OtherOptions) {
    const Scene scene = load_preset("earth");
    VdbOptions o = small_box();
    o.box = {10, -10, 0, -10, 10, 60};
    expect_error_and_no_file(scene, o, "--box: xmin");
    o = small_box();
    o.tolerance = -1;
    expect_error_and_no_file(scene, o, "--tolerance");
    o = small_box();
    o.tile_voxels = 12;
    expect_error_and_no_file(scene, o, "--tile-voxels");
    TempDir dir;
    EXPECT_THROW(export_vdb(scene, small_box(), dir / "x.exr"), VdbError);
}

// ---- analytic descriptions ---------------------------------------------------------------------

TEST(VdbAnalytic, JsonDescribesEveryActiveConstituentInTheChosenUnit) {
    const Scene scene = load_preset("earth");
    VdbOptions o;
    const auto j = nlohmann::json::parse(analytic_density_json(scene, o));
    EXPECT_EQ(j["length_unit"], "km");
    EXPECT_DOUBLE_EQ(j["planet_radius"].get<double>(), 6360.0);
    ASSERT_EQ(j["constituents"].size(), 3u);
    for (const auto& c : j["constituents"]) {
        const Constituent& sc = constituent(scene, c["name"]);
        const double lambdas[3] = {680, 550, 440};
        for (int i = 0; i < 3; ++i)
            EXPECT_NEAR(c["extinction_rgb"][i].get<double>(),
                        (sc.scattering.at(lambdas[i]) + sc.absorption.at(lambdas[i])) * 1000.0, 1e-15);
    }
    EXPECT_DOUBLE_EQ(j["constituents"][1]["profile"]["scale_height"].get<double>(), 1.2);
    o.unit = LengthUnit::m;
    const auto jm = nlohmann::json::parse(analytic_density_json(scene, o));
    EXPECT_DOUBLE_EQ(jm["constituents"][0]["profile"]["scale_height"].get<double>(), 8000.0);
}

TEST(VdbAnalytic, PovIncludeDeclaresDensityFunctionsAndMedia) {
    const Scene scene = load_preset("earth");
    const std::string inc = pov_include(scene, VdbOptions{});
    for (const char* s : {"#declare Airmass_rayleigh_Density = function(x, y, z)", "#declare Airmass_ozone_Pattern",
                          "#macro Airmass_mie_Media()", "scattering { 4, Airmass_rayleigh_ScatteringColour * DensityMax extinction",
                          "eccentricity Airmass_mie_G", "absorption Airmass_ozone_Absorption",
                          "#declare Airmass_PlanetCenter = <0, -6360, 0>;", "#declare Airmass_Container"})
        EXPECT_NE(inc.find(s), std::string::npos) << s;
}

TEST(VdbAnalytic, Df3IsBigEndian32BitWithAZeroBorder) {
    const Scene scene = load_preset("earth");
    VdbOptions o = small_box();
    TempDir dir;
    const auto files = export_df3(scene, o, dir / "atm");
    ASSERT_EQ(files.size(), 4u);  // three grids + the include
    std::ifstream f(dir / "atm.rayleigh.df3", std::ios::binary);
    std::vector<unsigned char> d((std::istreambuf_iterator<char>(f)), {});
    ASSERT_GE(d.size(), 6u);
    const int nx = d[0] << 8 | d[1], ny = d[2] << 8 | d[3], nz = d[4] << 8 | d[5];
    ASSERT_EQ(d.size(), 6u + std::size_t(nx) * ny * nz * 4);
    auto at = [&](int i, int j, int k) {
        const std::size_t o4 = 6 + 4 * (std::size_t(k) * ny * nx + std::size_t(j) * nx + i);
        return std::uint32_t(d[o4]) << 24 | std::uint32_t(d[o4 + 1]) << 16 | std::uint32_t(d[o4 + 2]) << 8 | d[o4 + 3];
    };
    std::uint32_t vmax = 0;
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) {
                const bool border = i == 0 || j == 0 || k == 0 || i == nx - 1 || j == ny - 1 || k == nz - 1;
                if (border) {
                    ASSERT_EQ(at(i, j, k), 0u) << i << "," << j << "," << k;
                }
                vmax = std::max(vmax, at(i, j, k));
            }
    EXPECT_EQ(vmax, 0xffffffffu);
}

// ---- the volume layer: the plan and the dense blocks a host copies into its own grids ---------

namespace {

enum class LayerCase { planet, view, box, tiled };

std::string layer_case_name(LayerCase c) {
    switch (c) {
        case LayerCase::planet: return "planet";
        case LayerCase::view: return "view";
        case LayerCase::box: return "box";
        case LayerCase::tiled: return "tiled";
    }
    return "?";
}

void PrintTo(LayerCase c, std::ostream* os) { *os << layer_case_name(c); }

Scene layer_scene(LayerCase c) {
    Scene s = load_preset("earth");
    if (c == LayerCase::view) s.camera = Camera{};  // ground, +X, 60°, 640×360, 200 km
    return s;
}

VdbOptions layer_options(LayerCase c) {
    VdbOptions o;
    switch (c) {
        case LayerCase::planet:
            o.region = VdbRegion::planet;
            o.voxel_size = 50.0;  // 100 km held +inf below the ground (fix 22: refused now)
            o.tile_voxels = -1;
            o.voxel_values = VoxelValues::point;  // the plumbing, at a tenth of the means' cost
            break;
        case LayerCase::view:
            o.region = VdbRegion::view;
            o.voxel_size = 4.0;
            break;
        case LayerCase::box: o = small_box(); break;
        case LayerCase::tiled:
            o.region = VdbRegion::planet;
            o.voxel_size = 50.0;  // 100 km held +inf below the ground (fix 22: refused now)
            o.tile_voxels = 64;   // 32 at 100 km (32 at 50 km: 314 tiles > --max-tiles)
            o.voxel_values = VoxelValues::point;  // the plumbing, at a tenth of the means' cost
            break;
    }
    return o;
}

VoxelBox box_of(const VdbGridStats& g) {
    return VoxelBox{{g.bbox[0], g.bbox[1], g.bbox[2]}, {g.bbox[3], g.bbox[4], g.bbox[5]}};
}

// The i-slabs [lo, hi] of a box, cut where (i − box.min.x) % step == 0 (step 8 and a box min
// on a multiple of 8: whole OpenVDB leaves; any other step: leaves cut in two).
std::vector<VoxelBox> i_slabs(const VoxelBox& box, int step, bool leaf_aligned) {
    std::vector<VoxelBox> out;
    int lo = box.min[0];
    while (lo <= box.max[0]) {
        int hi = leaf_aligned ? (lo >= 0 ? lo / 8 * 8 : -((-lo + 7) / 8) * 8) + step - 1 : lo + step - 1;
        hi = std::min(hi, box.max[0]);
        VoxelBox b = box;
        b.min[0] = lo;
        b.max[0] = hi;
        out.push_back(b);
        lo = hi + 1;
    }
    return out;
}

std::size_t dense_index(const VoxelBox& box, int x, int y, int z) {
    return (std::size_t(x - box.min[0]) * std::size_t(box.dim(1)) + std::size_t(y - box.min[1])) * std::size_t(box.dim(2)) +
           std::size_t(z - box.min[2]);
}

// What OpenVDB's Python copyFromArray(array, ijk=box.min, tolerance=0) does with a dense block.
void copy_like_python(openvdb::FloatGrid& grid, const VoxelBox& box, std::vector<float>& values) {
    openvdb::tools::Dense<float> dense(to_openvdb(box), values.data());
    openvdb::tools::copyFromDense(dense, grid, 0.0f);
}

// Every active voxel of `a` is active in `b` with the same value, and they have as many.
void expect_same_grid(const openvdb::FloatGrid& a, const openvdb::FloatGrid& b, const std::string& what) {
    EXPECT_EQ(a.activeVoxelCount(), b.activeVoxelCount()) << what;
    auto acc = b.getConstAccessor();
    std::size_t bad = 0;
    for (auto it = a.cbeginValueOn(); it; ++it) {
        for (auto c = it.getBoundingBox().begin(); c; ++c) {  // a tile covers several voxels
            if (!acc.isValueOn(*c) || acc.getValue(*c) != *it) {
                if (bad++ == 0) ADD_FAILURE() << what << ": voxel " << *c << " is " << *it << " vs " << acc.getValue(*c);
            }
        }
    }
    EXPECT_EQ(bad, 0u) << what;
}

}  // namespace

class VdbVolumeLayer : public ::testing::TestWithParam<LayerCase> {};

TEST_P(VdbVolumeLayer, DenseBlocksEqualTheWriterGridsVoxelForVoxel) {
    const Scene scene = layer_scene(GetParam());
    const VdbOptions o = layer_options(GetParam());
    const VdbVolume vol = build_vdb_volume(scene, o);  // the OpenVDB writer's grids
    const VdbLayout layout = resolve_vdb_layout(scene, o);
    const VolumePlan plan = plan_volume(layout);  // a separate sampling pass, no OpenVDB
    if (GetParam() == LayerCase::tiled) {
        EXPECT_GT(plan.stats.tiles, 4u);
    }
    if (GetParam() == LayerCase::planet) {
        EXPECT_EQ(plan.stats.tiles, 1u);  // --tile-voxels -1
    }
    // The plan lists exactly the writer's grids: tiles, names, boxes, counts, dense sizes.
    ASSERT_EQ(plan.stats.tiles, vol.tiles.size());
    ASSERT_EQ(plan.stats.grids.size(), vol.stats.grids.size());
    ASSERT_EQ(plan.grid_constituent.size(), plan.stats.grids.size());
    EXPECT_EQ(plan.stats.active_voxels, vol.stats.active_voxels);
    EXPECT_EQ(plan.stats.dense_bytes, vol.stats.dense_bytes);
    EXPECT_EQ(plan.stats.dense_bytes_untiled, vol.stats.dense_bytes_untiled);
    const VoxelBox bounds = volume_request_bounds(layout);
    const VolumeSampler sampler(layout);
    std::uint64_t compared = 0, guards_seen = 0;
    for (std::size_t i = 0; i < plan.stats.grids.size(); ++i) {
        const VdbGridStats& pg = plan.stats.grids[i];
        const VdbGridStats& wg = vol.stats.grids[i];
        SCOPED_TRACE(pg.name + " tile " + std::to_string(pg.tile));
        ASSERT_EQ(pg.name, wg.name);
        ASSERT_EQ(pg.tile, wg.tile);
        EXPECT_EQ(pg.bbox, wg.bbox);
        EXPECT_EQ(pg.active_voxels, wg.active_voxels);
        EXPECT_EQ(pg.dense_voxels, wg.dense_voxels);
        const std::size_t c = plan.grid_constituent[i];
        ASSERT_EQ(layout.constituents[c].name, pg.name);
        ASSERT_TRUE(vol.tiles[pg.tile].grids[c]);
        const VoxelBox box = box_of(pg);
        // The file's grid = the values + guard voxels (several tiles only: docs/vdb.md "Tiling"),
        // all within the plan's dense box; the rest compares the values.
        // In the common lattice (the plan's boxes): the tile's grid is on its own, shifted one.
        const VoxelCoord offset = plan.index_offset(pg.tile);
        if (GetParam() != LayerCase::tiled) {
            EXPECT_EQ(offset, (VoxelCoord{0, 0, 0}));
        }
        EXPECT_EQ(vol.plan.index_offset(pg.tile), offset);
        const auto g = to_common_lattice(*vol.tiles[pg.tile].grids[c], offset,
                                         *openvdb::math::Transform::createLinearTransform(layout.voxel_size));
        std::uint64_t guards = 0;
        for (auto it = g->beginValueOn(); it; ++it) {
            const Coord q = it.getCoord();
            EXPECT_TRUE(q.x() >= pg.dense_bbox[0] && q.y() >= pg.dense_bbox[1] && q.z() >= pg.dense_bbox[2] &&
                        q.x() <= pg.dense_bbox[3] && q.y() <= pg.dense_bbox[4] && q.z() <= pg.dense_bbox[5])
                << q;
            if (*it != kVolumeGuardValue) continue;
            ++guards;
            EXPECT_FALSE(box.contains(VoxelCoord{q.x(), q.y(), q.z()})) << q;
            it.setValueOff();
            it.setValue(0.0f);
        }
        if (GetParam() != LayerCase::tiled) {
            EXPECT_EQ(guards, 0u);
            EXPECT_EQ(pg.dense_bbox, pg.bbox);
        }
        guards_seen += guards;
        ASSERT_TRUE(bounds.contains(box));
        // The metadata the plan carries is the grid's, key for key and type for type.
        const auto& written = *vol.tiles[pg.tile].grids[c];
        for (const auto& m : volume_grid_metadata(layout, c, pg.tile, plan.stats.tiles, offset)) {
            const auto meta = written[m.key];
            ASSERT_TRUE(meta) << m.key;
            std::visit(
                [&](const auto& v) {
                    using T = std::decay_t<decltype(v)>;
                    if constexpr (std::is_same_v<T, std::array<double, 3>>) {
                        EXPECT_EQ(written.metaValue<Vec3d>(m.key), Vec3d(v[0], v[1], v[2])) << m.key;
                    } else if constexpr (std::is_same_v<T, std::array<std::int32_t, 3>>) {
                        EXPECT_EQ(written.metaValue<openvdb::Vec3i>(m.key), openvdb::Vec3i(v[0], v[1], v[2])) << m.key;
                    } else {
                        EXPECT_EQ(written.metaValue<T>(m.key), v) << m.key;
                    }
                },
                m.value);
        }
        // The dense block over the grid's box, voxel for voxel: a[i][j][k] = voxel min + (i, j, k).
        std::vector<float> dense(box.volume());
        sample_volume_box(sampler, c, box, dense);
        auto acc = g->getConstAccessor();
        std::size_t bad = 0;
        std::uint64_t nonzero = 0;
        for (int x = box.min[0]; x <= box.max[0]; ++x)
            for (int y = box.min[1]; y <= box.max[1]; ++y)
                for (int z = box.min[2]; z <= box.max[2]; ++z) {
                    const float d = dense[dense_index(box, x, y, z)];
                    const Coord ijk(x, y, z);
                    nonzero += d != 0.0f;
                    if (d != acc.getValue(ijk) || (d != 0.0f) != acc.isValueOn(ijk)) {
                        if (bad++ == 0) ADD_FAILURE() << "voxel " << ijk << ": dense " << d << ", grid " << acc.getValue(ijk);
                    }
                }
        EXPECT_EQ(bad, 0u);
        EXPECT_EQ(nonzero, g->activeVoxelCount());  // nothing of the grid lies outside its box
        compared += box.volume();
        // The host's path: copyFromArray of the whole block, and of leaf-aligned slabs into one
        // grid (what vdb_host does), each give the writer's grid.
        auto whole = openvdb::FloatGrid::create(0.0f);
        copy_like_python(*whole, box, dense);
        expect_same_grid(*g, *whole, "whole block");
        auto parts = openvdb::FloatGrid::create(0.0f);
        for (const VoxelBox& slab : i_slabs(box, 8, true)) {
            std::vector<float> v(slab.volume());
            sample_volume_box(sampler, c, slab, v);
            copy_like_python(*parts, slab, v);
        }
        expect_same_grid(*g, *parts, "leaf-aligned slabs");
        // Any split gives the same values as the whole block (here: slabs of 3 planes).
        for (const VoxelBox& slab : i_slabs(box, 3, false)) {
            std::vector<float> v(slab.volume());
            sample_volume_box(sampler, c, slab, v);
            for (int x = slab.min[0]; x <= slab.max[0]; ++x)
                for (int y = slab.min[1]; y <= slab.max[1]; ++y)
                    for (int z = slab.min[2]; z <= slab.max[2]; ++z)
                        ASSERT_EQ(v[dense_index(slab, x, y, z)], dense[dense_index(box, x, y, z)])
                            << "slab voxel " << Coord(x, y, z);
        }
    }
    EXPECT_GT(compared, 1000u);
    if (GetParam() == LayerCase::tiled) {
        EXPECT_GT(guards_seen, 0u);
    }
}

INSTANTIATE_TEST_SUITE_P(VdbRegions, VdbVolumeLayer,
                         ::testing::Values(LayerCase::planet, LayerCase::view, LayerCase::box, LayerCase::tiled),
                         [](const auto& info) { return layer_case_name(info.param); });

TEST(VdbVolumeLayerBadInput, BlockRequestsAreRefusedWithNamedMessages) {
    const Scene scene = load_preset("earth");
    const VdbLayout layout = resolve_vdb_layout(scene, small_box());
    const VolumeSampler sampler(layout);
    const VoxelBox bounds = volume_request_bounds(layout);
    ASSERT_FALSE(bounds.empty());
    ASSERT_TRUE(bounds.contains(layout.index_bounds));
    const auto expect_refused = [&](std::size_t c, const VoxelBox& box, std::size_t count, const std::string& fragment) {
        std::vector<float> v(count);
        try {
            sample_volume_box(sampler, c, box, v);
            ADD_FAILURE() << "no error; expected one mentioning '" << fragment << "'";
        } catch (const VdbError& e) {
            EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
        }
    };
    VoxelBox ok{{0, 0, 0}, {1, 2, 3}};
    expect_refused(0, ok, 23, "values: 23 floats for a box of 2 x 3 x 4 = 24 voxels");
    expect_refused(3, ok, 24, "constituent index 3: must be < 3");
    VoxelBox empty_y = ok;
    empty_y.max[1] = -1;
    expect_refused(0, empty_y, 0, "box: min.y = 0 must be <= max.y = -1");
    VoxelBox outside = ok;
    outside.max[0] = bounds.max[0] + 1;
    expect_refused(0, outside, std::size_t(outside.volume()), "must lie within the region's index bounds");
    VoxelBox below = ok;
    below.min[2] = bounds.min[2] - 1;
    expect_refused(0, below, std::size_t(below.volume()), "must lie within the region's index bounds");
    // A good request right at the bounds' corner works, and the plan refuses what the writer refuses.
    VoxelBox corner{bounds.max, bounds.max};
    std::vector<float> one(1, -1.0f);
    sample_volume_box(sampler, 0, corner, one);
    EXPECT_EQ(one[0], 0.0f);  // above the atmosphere top: inactive
    VdbOptions tight = small_box();
    tight.max_dense_mb = 0.01;
    EXPECT_THROW(
        {
            try {
                plan_volume(resolve_vdb_layout(scene, tight));
            } catch (const VdbError& e) {
                EXPECT_NE(std::string(e.what()).find("--max-dense-mb"), std::string::npos) << e.what();
                throw;
            }
        },
        VdbError);
    CancelFlag cancel;
    cancel.request();
    VolumeRunOptions run;
    run.cancel = &cancel;
    EXPECT_THROW(plan_volume(layout, run), Cancelled);
    std::vector<float> v(ok.volume());
    EXPECT_THROW(sample_volume_box(sampler, 0, ok, v, run), Cancelled);
}

// A sampler that keeps the sampling pass's blocks (a C ABI session's) serves every grid's dense
// box with the values a fresh sampler computes, bit for bit — all of them kept, or only the first
// few under a small limit (the rest sampled again); without keep_bytes nothing is kept.
TEST(Vdb, KeptBlocksServeTheBoxesWithTheSampledValues) {
    const Scene scene = load_preset("earth");
    VdbOptions o;
    o.region = VdbRegion::planet;
    o.voxel_size = 100.0;  // means for every constituent, a few thousand blocks
    const VdbLayout layout = resolve_vdb_layout(scene, o);
    const VolumeSampler fresh(layout);
    for (const std::size_t keep : {std::size_t(64) << 20, std::size_t(40000)}) {
        SCOPED_TRACE(keep);
        const VolumeSampler sampler(layout, keep);
        EXPECT_EQ(sampler.kept_bytes(), 0u);
        const VolumePlan plan = plan_volume(sampler);
        EXPECT_GT(sampler.kept_bytes(), 0u);
        EXPECT_LE(sampler.kept_bytes(), keep);
        ASSERT_GE(plan.stats.grids.size(), 3u);
        std::size_t kept_leaves = 0, leaves = 0;
        for (std::size_t g = 0; g < plan.stats.grids.size(); ++g) {
            const auto& b = plan.stats.grids[g].dense_bbox;
            const VoxelBox box{{b[0], b[1], b[2]}, {b[3], b[4], b[5]}};
            const std::size_t c = plan.grid_constituent[g];
            std::vector<float> want(box.volume()), got(box.volume());
            sample_volume_box(fresh, c, box, want);
            sample_volume_box(sampler, c, box, got);
            ASSERT_EQ(std::memcmp(want.data(), got.data(), want.size() * sizeof(float)), 0) << plan.stats.grids[g].name;
            for (const VolumeBlock& block : fresh.blocks(&box)) {
                const float* values = nullptr;
                ++leaves;
                if (sampler.kept(block.origin, c, values)) ++kept_leaves;
            }
        }
        if (keep > 40000) EXPECT_EQ(kept_leaves, leaves);  // every block the boxes meet was kept
        else EXPECT_LT(kept_leaves, leaves / 2);            // a few: the rest sampled again
        EXPECT_GT(kept_leaves, 0u);
    }
    const float* values = nullptr;
    EXPECT_FALSE(fresh.kept(layout.index_bounds.min, 0, values));
    EXPECT_EQ(fresh.kept_bytes(), 0u);
    // The box request serves what was kept, not a fresh sample: a block handed to keep() with
    // stand-in values comes back with them; a block kept without the constituent comes back 0.
    const VolumeSampler injected(layout, std::size_t(1) << 20);
    const std::vector<VolumeBlock> blocks = injected.blocks();
    ASSERT_GE(blocks.size(), 2u);
    std::vector<VolumeBlockValues> stand_in(layout.constituents.size());
    stand_in[0].value.fill(42.0f);
    injected.keep(blocks[0], 1, stand_in);
    injected.keep(blocks[1], 0, stand_in);
    for (int k = 0; k < 2; ++k) {
        const VoxelBox box{blocks[std::size_t(k)].origin,
                           {blocks[std::size_t(k)].origin[0] + 7, blocks[std::size_t(k)].origin[1] + 7,
                            blocks[std::size_t(k)].origin[2] + 7}};
        std::vector<float> got(box.volume());
        sample_volume_box(injected, 0, box, got);
        for (const float f : got) ASSERT_EQ(f, k == 0 ? 42.0f : 0.0f) << k;
    }
}

// ---- the voxel-size trade --------------------------------------------------------------------

TEST(VdbTrade, GridOpticalDepthConvergesToTheAnalyticValue) {
    const Scene scene = load_preset("earth");
    VdbTradeOptions t;
    t.voxel_sizes = {8.0, 2.0};
    t.voxel_values = {VoxelValues::average, VoxelValues::point};
    t.measure_view_region = false;
    t.tolerances.clear();
    const auto rows = run_vdb_trade(scene, t).rays;
    const std::size_t n = vdb_trade_rays(scene).size();
    ASSERT_EQ(rows.size(), 4 * n);  // (8 km, average), (8, point), (2, average), (2, point)
    for (const auto& r : rows) {
        SCOPED_TRACE(r.ray + " @ " + std::to_string(r.voxel_size) + " " + std::string(voxel_values_name(r.voxel_values)));
        EXPECT_TRUE(std::isfinite(r.tau_vdb[1]) && std::isfinite(r.tau_ref[1]));
        EXPECT_GT(r.tau_ref[1], 0.0);
        EXPECT_LT(r.tau_rel_error_max, 0.5);
    }
    // Each ray's error shrinks with the voxel (trilinear: O(v²) on smooth profiles), both ways.
    for (std::size_t i = 0; i < 2 * n; ++i) {
        const auto& coarse = rows[i];
        const auto& fine = rows[i + 2 * n];
        ASSERT_EQ(coarse.ray, fine.ray);
        ASSERT_EQ(coarse.voxel_values, fine.voxel_values);
        EXPECT_LT(fine.tau_rel_error_max, coarse.tau_rel_error_max) << coarse.ray;
    }
    // The trade between them at 8 km: across the layer (zenith, slant) the means keep the mass —
    // measured 7.1e-6 and 2.6e-3 against 26 % and 27 % — while along the ground (horizon) the
    // points keep the density there: 2.4e-5 against 20 %.
    const auto at = [&](VoxelValues v, const std::string& ray) {
        for (std::size_t i = 0; i < 2 * n; ++i)
            if (rows[i].voxel_values == v && rows[i].ray == ray) return rows[i].tau_rel_error_max;
        ADD_FAILURE() << ray;
        return 0.0;
    };
    for (const char* ray : {"zenith", "slant-75"}) {
        EXPECT_LT(at(VoxelValues::average, ray), 0.01) << ray;
        EXPECT_GT(at(VoxelValues::point, ray), 0.1) << ray;
    }
    EXPECT_LT(at(VoxelValues::point, "horizon"), 1e-3);
    EXPECT_GT(at(VoxelValues::average, "horizon"), 0.1);
}

// The means keep the mass at the top of the atmosphere too. A layer of constant density up to the
// top (60 km), 7-km voxels: the top lies between the nodes at 56 and 63 km. The node above the top
// holds its hat's share of the air below it; left out (as before), the reconstruction fell to 0 a
// voxel early and the zenith's optical depth came out 1.9 % short (measured 1.9e-2; now 5e-6).
// Point values stay 0 above the top: the model has no density there.
TEST(VdbTrade, MeansKeepTheMassAtTheTopOfTheAtmosphere) {
    const Scene scene = parse_scene_toml(R"(
name = "top-layer"
[planet]
radius_km = 6360.0
atmosphere_top_km = 6420.0
ground_albedo = 0.0
[spectrum]
basis = "rgb-schuler"
[[constituent]]
name = "haze"
profile = { type = "constant", value = 1.0, bottom_km = 0.0 }
scattering = { law = "constant", value_per_m = 1e-6 }
phase = { type = "isotropic" }
)",
                                         "top-layer.toml");
    VdbTradeOptions t;
    t.voxel_sizes = {7.0};
    t.voxel_values = {VoxelValues::average, VoxelValues::point};
    t.measure_view_region = false;
    t.tolerances.clear();
    const auto rows = run_vdb_trade(scene, t).rays;
    const auto at = [&](VoxelValues v, const std::string& ray) {
        for (const auto& r : rows)
            if (r.voxel_values == v && r.ray == ray) return r.tau_rel_error_max;
        ADD_FAILURE() << ray;
        return 0.0;
    };
    EXPECT_LT(at(VoxelValues::average, "zenith"), 1e-4);
    // Point values fall linearly from 1 at 56 km to 0 at 63 km: 3.5 of the top voxel's 4 km of
    // air, 0.5 km of the column's 60 short (the trade the means remove).
    EXPECT_NEAR(at(VoxelValues::point, "zenith"), 0.5 / 60.0, 0.05 * 0.5 / 60.0);
    // Where the nodes above the top are, and what they hold: a box over the zenith column.
    VdbOptions o;
    o.region = VdbRegion::box;
    o.voxel_size = 7.0;
    o.box = {-1.0, -1.0, 50.0, 1.0, 1.0, 70.0};
    o.voxel_values = VoxelValues::average;
    const VdbLayout layout = resolve_vdb_layout(scene, o);
    const VolumeSampler sampler(layout);
    const VoxelBox column{{0, 0, 8}, {0, 0, 9}};  // 56 and 63 km
    std::vector<float> v(2);
    sample_volume_box(sampler, 0, column, v);
    // 63 km: ∫ of the hat (1 − |h − 63|/7)/7 over the air below 60 km, i.e. over [56, 60]:
    // ∫₀⁴ u/7 du / 7 = 8/49. 56 km: 1 minus the hat's share above 60 km, (3/7)²/2.
    EXPECT_NEAR(v[1], 8.0 / 49.0, 1e-6);
    EXPECT_NEAR(v[0], 1.0 - 0.5 * (3.0 / 7.0) * (3.0 / 7.0), 1e-6);
    o.voxel_values = VoxelValues::point;
    const VdbLayout point_layout = resolve_vdb_layout(scene, o);
    const VolumeSampler point_sampler(point_layout);
    sample_volume_box(point_sampler, 0, column, v);
    EXPECT_EQ(v[0], 1.0f);
    EXPECT_EQ(v[1], 0.0f);
}

// The activity threshold's trade: what the inactive cells remove along each ray (through grids
// on one lattice) stays within the bound VdbOptions::tolerance promises per constituent, grows
// with the tolerance, and is not zero (the threshold acts); the grids shrink.
TEST(VdbTrade, InactiveCellsRemoveAtMostTheTolerancePerConstituent) {
    const Scene scene = load_preset("earth");
    VdbTradeOptions t;
    t.voxel_sizes.clear();
    t.measure_view_region = false;
    t.tolerances = {1e-2, 1e-3, 1e-3};  // unsorted, repeated: measured once each, 0 added first
    t.tolerance_voxel_size = 4.0;
    const auto r = run_vdb_trade(scene, t);
    const std::size_t n_rays = vdb_trade_rays(scene).size();
    ASSERT_EQ(r.tolerance_rays.size(), 3 * n_rays);
    ASSERT_EQ(r.tolerance_costs.size(), 3u);
    EXPECT_EQ(r.constituents, 3u);  // Rayleigh, Mie, ozone
    EXPECT_EQ(r.tolerance_voxel_size, 4.0);
    double removed_most = 0;
    for (std::size_t i = 0; i < n_rays; ++i) {
        const auto& all = r.tolerance_rays[i];
        const auto& mid = r.tolerance_rays[n_rays + i];
        const auto& coarse = r.tolerance_rays[2 * n_rays + i];
        SCOPED_TRACE(all.ray);
        EXPECT_EQ(all.tolerance, 0.0);
        EXPECT_EQ(mid.tolerance, 1e-3);
        EXPECT_EQ(coarse.tolerance, 1e-2);
        EXPECT_EQ(all.tau_removed_max, 0.0);
        for (const auto* row : {&mid, &coarse}) {
            EXPECT_TRUE(std::isfinite(row->tau_rel_error_max));
            EXPECT_GE(row->tau_removed_max, -1e-12);
            EXPECT_LE(row->tau_removed_max, row->tolerance * 3.0);
        }
        EXPECT_GE(coarse.tau_removed_max, mid.tau_removed_max - 1e-12);
        removed_most = std::max(removed_most, coarse.tau_removed_max);
    }
    EXPECT_GT(removed_most, 1e-5);  // the threshold removes something measurable at 1e-2
    EXPECT_GT(r.tolerance_costs[0].active_voxels, r.tolerance_costs[1].active_voxels);
    EXPECT_GT(r.tolerance_costs[1].active_voxels, r.tolerance_costs[2].active_voxels);
    // The text: every tolerance row of the table, the bound in its column.
    const std::string md = vdb_tolerance_markdown(r, "earth");
    EXPECT_NE(md.find("| 0 (all) | 0.00e+00 |"), std::string::npos) << md;
    EXPECT_NE(md.find("| 0.01 | 3.00e-02 |"), std::string::npos) << md;
    EXPECT_EQ(vdb_tolerance_rays_csv(r).find("tolerance,voxel_size_km,ray,"), 0u);
}

// The tolerances the trade measures and the steps its progress counts (what `airmass report vdb`
// sizes its bar by): 0 once and first, repeats once; the run reports exactly those steps. The
// slab the voxel-size part built at the trade's voxel size and tolerance is the tolerance part's
// row at that tolerance: the same optical depths and the same grids' cost.
TEST(VdbTrade, ProgressCountsTheMeasuredTolerancesOnce) {
    const Scene scene = load_preset("earth");
    VdbTradeOptions t;
    t.voxel_sizes = {8.0};
    t.voxel_values = {VdbOptions{}.voxel_values};  // the tolerance part's (shared)
    t.measure_view_region = false;
    t.tolerances = {1e-2, t.tolerance, 1e-2, 0.0};  // unsorted, repeated, 0 listed
    t.tolerance_voxel_size = 8.0;
    const std::vector<double> want{0.0, t.tolerance, 1e-2};
    EXPECT_EQ(vdb_trade_tolerances(t), want);
    EXPECT_EQ(vdb_trade_steps(t), 4u);  // 1 voxel size + 3 tolerances (not 1 + 4 + 1)
    std::vector<double> seen;
    t.progress = [&](double f) { seen.push_back(f); };
    const auto r = run_vdb_trade(scene, t);
    EXPECT_EQ(seen, (std::vector<double>{0.25, 0.5, 0.75, 1.0}));
    const std::size_t n_rays = vdb_trade_rays(scene).size();
    ASSERT_EQ(r.rays.size(), n_rays);
    ASSERT_EQ(r.tolerance_rays.size(), 3 * n_rays);
    ASSERT_EQ(r.costs.size(), 1u);
    ASSERT_EQ(r.tolerance_costs.size(), 3u);
    for (std::size_t i = 0; i < n_rays; ++i) {
        SCOPED_TRACE(r.rays[i].ray);
        EXPECT_EQ(r.tolerance_rays[n_rays + i].tolerance, t.tolerance);
        EXPECT_EQ(r.tolerance_rays[n_rays + i].tau_vdb, r.rays[i].tau_vdb);
    }
    EXPECT_EQ(r.tolerance_costs[1].active_voxels, r.costs[0].active_voxels);
    EXPECT_GT(r.tolerance_costs[0].active_voxels, r.tolerance_costs[1].active_voxels);
    t.tolerances.clear();
    EXPECT_TRUE(vdb_trade_tolerances(t).empty());
    EXPECT_EQ(vdb_trade_steps(t), 1u);
}

TEST(VdbTrade, ToleranceTradeRefusesBadInputWithTheFieldName) {
    const Scene scene = load_preset("earth");
    VdbTradeOptions t;
    t.voxel_sizes.clear();
    t.measure_view_region = false;
    t.tolerances = {-1e-3};
    try {
        run_vdb_trade(scene, t);
        ADD_FAILURE() << "a negative tolerance was accepted";
    } catch (const VdbError& e) {
        EXPECT_NE(std::string(e.what()).find("--tolerances"), std::string::npos) << e.what();
    }
    t.tolerances = {1e-3};
    t.tolerance_voxel_size = 0.0;
    try {
        run_vdb_trade(scene, t);
        ADD_FAILURE() << "a zero voxel size was accepted";
    } catch (const VdbError& e) {
        EXPECT_NE(std::string(e.what()).find("--tolerance-voxel-size"), std::string::npos) << e.what();
    }
}
