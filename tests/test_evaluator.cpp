// The evaluator (evaluator.hpp) and its consumers. First the object itself: its radiance
// is single scattering plus the tables' view-ray radiance, added once; its sun light is
// E_sun·exp(−τ) with τ from brute-force quadrature of the densities (independent of the
// Chapman path); foreign tables are refused by name. Then the consumers over it —
// `airmass eval` (its radiance column) and the sky texture (render_sky / sky_radiance_rgb /
// `airmass sky`) — each checked end to end against single_scattering and
// multiple_scattering_radiance called directly on an independently compiled atmosphere with
// independently computed tables. (The tables themselves are tested against Monte Carlo in
// test_multiple_scattering.cpp.)
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "test_cli.hpp"
#include "airmass/atmosphere.hpp"
#include "airmass/color.hpp"
#include "airmass/evaluator.hpp"
#include "airmass/optical_depth.hpp"
#include "airmass/geometry.hpp"
#include "airmass/multiple_scattering.hpp"
#include "airmass/progress.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/single_scattering.hpp"
#include "airmass/sky.hpp"

namespace airmass {
namespace {

// ---- the evaluator ---------------------------------------------------------------------------

Atmosphere earth_at(std::vector<double> wavelengths) {
    EvalSettings es;
    es.sun_disc = false;
    return compile_atmosphere(load_preset("earth"), wavelengths, es);
}

TEST(Evaluator, RadianceIsSingleScatteringPlusTheTablesOnce) {
    const Atmosphere atm = earth_at({680.0, 550.0, 440.0});
    MsSettings ms_settings;
    ms_settings.table = {6, 16, 12, 1};
    auto tables = std::make_shared<const MultipleScattering>(precompute_multiple_scattering(atm, ms_settings));
    const Evaluator single(atm), both(atm, tables, 24);
    const std::size_t nw = atm.wavelength_count();
    for (const ViewRay& ray : {ViewRay{0.0, direction_from_zenith_azimuth_deg<double>(60.0, 0.0),
                                       direction_from_zenith_azimuth_deg<double>(96.0, 0.0)},
                               ViewRay{2000.0, direction_from_zenith_azimuth_deg<double>(120.0, 0.0),
                                       direction_from_zenith_azimuth_deg<double>(30.0, 45.0)}}) {
        std::vector<double> t(nw), r(nw), m(nw), l(nw), t1(nw), r1(nw), m1(nw), l1(nw), mr(nw), mm(nw), mt(nw);
        std::vector<double> er(nw), em(nw), et(nw);
        single_scattering(atm, ray, {t, r, m, l});
        multiple_scattering_radiance(atm, *tables, ray, {er, em, et}, 24);
        const MsRadianceOut parts{mr, mm, mt};
        both.radiance(ray, {t1, r1, m1, l1}, &parts);
        for (std::size_t w = 0; w < nw; ++w) {
            EXPECT_EQ(t1[w], t[w]);
            EXPECT_EQ(r1[w], r[w]);  // the single-scattering columns stay single scattering
            EXPECT_EQ(mt[w], et[w]);
            EXPECT_EQ(l1[w], l[w] + et[w]) << w;
            EXPECT_GT(et[w], 0.0) << w;
        }
        // Without tables: single scattering, and the parts are zero.
        single.radiance(ray, {t1, r1, m1, l1}, &parts);
        for (std::size_t w = 0; w < nw; ++w) {
            EXPECT_EQ(l1[w], l[w]);
            EXPECT_EQ(mt[w], 0.0);
        }
        // The batch form gives the same numbers.
        std::vector<double> bt(nw), br(nw), bm(nw), bl(nw);
        both.radiance(ray.altitude_m, ray.sun_direction, std::span<const Vec3<double>>(&ray.view_direction, 1),
                      {bt, br, bm, bl});
        for (std::size_t w = 0; w < nw; ++w) EXPECT_NEAR(bl[w], l[w] + et[w], 1e-12 * bl[w]) << w;
    }
}

TEST(Evaluator, SunLightIsTheIrradianceThroughTheQuadratureOpticalDepth) {
    const Scene scene = load_preset("earth");
    const Atmosphere atm = earth_at({680.0, 550.0, 440.0});
    const Evaluator ev(atm);
    const std::size_t nw = atm.wavelength_count();
    std::vector<double> e(nw);
    // On the ground, in the air, above the top (space), with the sun high, low and just
    // below the geometric horizon of a raised point.
    for (const auto& [h, zenith_deg] : std::vector<std::pair<double, double>>{
             {0.0, 0.0}, {0.0, 60.0}, {0.0, 89.0}, {0.0, 90.0}, {5000.0, 91.0}, {30e3, 93.0}, {400e3, 100.0}, {400e3, 30.0}}) {
        const ZenithAngle<double> chi = ZenithAngle<double>::from_degrees(zenith_deg);
        ASSERT_TRUE(ev.sun_light(h, chi, e)) << h << " " << zenith_deg;
        const PlanetRay<double> ray{atm.planet_radius_m, h, chi};
        for (std::size_t w = 0; w < nw; ++w) {
            double tau = 0.0;
            for (std::size_t i = 0; i < atm.constituents.size(); ++i)
                tau += atm.constituents[i].extinction_per_m[w] *
                       profile_segment_mass_reference(scene.constituents[atm.constituents[i].scene_index].profile, ray,
                                                      atm.top_altitude_m, 0.0, std::numeric_limits<double>::infinity());
            const double expected = atm.sun_irradiance[w] * std::exp(-tau);
            EXPECT_NEAR(e[w], expected, 1e-6 * expected + 1e-300) << h << " m, " << zenith_deg << " deg, w " << w;
            EXPECT_TRUE(std::isfinite(e[w]) && e[w] >= 0.0);
        }
    }
    // Behind the planet: false and zeros.
    EXPECT_FALSE(ev.sun_light(0.0, ZenithAngle<double>::from_degrees(90.5), e));
    for (double v : e) EXPECT_EQ(v, 0.0);
    EXPECT_FALSE(ev.sun_light(400e3, ZenithAngle<double>::from_degrees(180.0), e));
}

TEST(Evaluator, ForeignTablesAndBadSamplesAreRefusedByName) {
    const Atmosphere three = earth_at({680.0, 550.0, 440.0});
    MsSettings ms_settings;
    ms_settings.table = {4, 8, 8, 1};
    auto tables = std::make_shared<const MultipleScattering>(precompute_multiple_scattering(three, ms_settings));
    try {
        Evaluator(earth_at({450.0, 550.0}), tables);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("multiple-scattering tables"), std::string::npos) << e.what();
    }
    try {
        Evaluator(three, tables, 0);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("multiple.view_samples = 0"), std::string::npos) << e.what();
    }
}

// ---- `airmass eval` ------------------------------------------------------------------------

using test::run_command;

struct Csv {
    std::vector<std::string> header;
    std::vector<std::map<std::string, double>> rows;
};

Csv parse_csv(const std::string& text) {
    Csv csv;
    std::stringstream lines(text);
    std::string line;
    bool first = true;
    while (std::getline(lines, line)) {
        std::vector<std::string> cells;
        std::stringstream ls(line);
        std::string cell;
        while (std::getline(ls, cell, ',')) cells.push_back(cell);
        if (first) {
            csv.header = cells;
            first = false;
            continue;
        }
        std::map<std::string, double> row;
        for (std::size_t i = 0; i < cells.size() && i < csv.header.size(); ++i)
            row[csv.header[i]] = std::stod(cells[i]);  // g17: the exact double
        csv.rows.push_back(row);
    }
    return csv;
}

// Geometries: noon, twilight (sun −6°) looking 30° up toward and away from the sun, exactly
// horizontal (90°), the nadir (180°, ground), the zenith at night (sun −10°: the whole
// 60-km atmosphere above the observer is in the Earth's shadow), the sun at the nadir
// (−90°), the observer in space looking at the limb and at the planet, the sun on the
// horizon, the zenith at twilight (sun −6°).
const char* kRows =
    "altitude_m,view_zenith_deg,sun_zenith_deg,azimuth_deg\\n"
    "0,45,30,0\\n"
    "0,60,96,0\\n"
    "0,60,96,180\\n"
    "0,90,60,90\\n"
    "0,180,30,0\\n"
    "0,0,100,0\\n"
    "0,45,180,0\\n"
    "400000,100,60,0\\n"
    "400000,180,60,0\\n"
    "1000,120,90,45\\n"
    "0,0,96,0\\n";
constexpr std::size_t kRowCount = 11;
constexpr int kNoon = 0, kTwilightToward = 1, kTwilightAway = 2, kNightZenith = 5, kTwilightZenith = 10;

const std::vector<double> kWavelengths = {680.0, 550.0, 440.0};

std::string eval_cli(const std::string& extra, int& status) {
    return run_command(std::string("printf '") + kRows + "' | " AIRMASS_CLI +
                   " eval --preset earth --wavelengths 680,550,440 --solar-irradiance 1 " + extra + " 2>&1",
               status);
}

// The atmosphere `airmass eval` compiles with its defaults, at unit irradiance.
Atmosphere eval_atmosphere() {
    EvalSettings es;
    es.sun_disc = false;
    es.ground = true;
    Atmosphere atm = compile_atmosphere(load_preset("earth"), kWavelengths, es);
    set_constant_irradiance(atm, 1.0);
    return atm;
}

ViewRay eval_ray(const std::map<std::string, double>& r) {
    return {r.at("altitude_m"), direction_from_zenith_azimuth_deg<double>(r.at("view_zenith_deg"), 0.0),
            direction_from_zenith_azimuth_deg<double>(r.at("sun_zenith_deg"), r.at("azimuth_deg"))};
}

TEST(EvaluatorInEval, RadianceIsSingleScatteringPlusTheTablesViewRayRadiance) {
    int status = 0;
    const std::string with_text = eval_cli("--ms-columns", status);
    ASSERT_EQ(status, 0) << with_text;
    const std::string plain_text = eval_cli("", status);
    ASSERT_EQ(status, 0) << plain_text;
    const std::string single_text = eval_cli("--no-multiple --ms-columns", status);
    ASSERT_EQ(status, 0) << single_text;
    const Csv with = parse_csv(with_text), plain = parse_csv(plain_text), single = parse_csv(single_text);

    // The default columns are unchanged (readers of the single-scattering output keep
    // working); --ms-columns appends the multiple-scattering parts.
    const std::vector<std::string> base = {"altitude_m",   "view_zenith_deg", "sun_zenith_deg",
                                           "azimuth_deg",  "wavelength_nm",   "transmittance",
                                           "radiance_rayleigh", "radiance_mie", "radiance"};
    EXPECT_EQ(plain.header, base);
    std::vector<std::string> extended = base;
    for (const char* c : {"multiple_rayleigh", "multiple_mie", "multiple"}) extended.push_back(c);
    EXPECT_EQ(with.header, extended);
    ASSERT_EQ(with.rows.size(), 3 * kRowCount);
    ASSERT_EQ(plain.rows.size(), 3 * kRowCount);
    ASSERT_EQ(single.rows.size(), 3 * kRowCount);

    // Independent: the same atmosphere, tables computed here, the two integrators called directly.
    const Atmosphere atm = eval_atmosphere();
    const MultipleScattering ms = precompute_multiple_scattering(atm, MsSettings{});
    const std::size_t nw = kWavelengths.size();
    std::vector<double> T(nw), R(nw), M(nw), L(nw), mr(nw), mm(nw), mt(nw);
    for (std::size_t k = 0; k < with.rows.size() / nw; ++k) {
        const ViewRay ray = eval_ray(with.rows[k * nw]);
        single_scattering(atm, ray, {T, R, M, L});
        multiple_scattering_radiance(atm, ms, ray, {mr, mm, mt}, 32);
        for (std::size_t w = 0; w < nw; ++w) {
            const auto &a = with.rows[k * nw + w], &p = plain.rows[k * nw + w], &s = single.rows[k * nw + w];
            const std::string where = "row " + std::to_string(k) + " wavelength " + std::to_string(kWavelengths[w]);
            for (const auto* r : {&a, &s})
                for (const auto& [name, v] : *r) EXPECT_TRUE(std::isfinite(v) && v >= 0.0) << where << " " << name;
            // --no-multiple is single scattering exactly, and multiple scattering changes
            // nothing but `radiance` (and the appended columns).
            EXPECT_EQ(s.at("radiance"), L[w]) << where;
            EXPECT_EQ(s.at("multiple"), 0.0) << where;
            for (const char* c : {"transmittance", "radiance_rayleigh", "radiance_mie"}) {
                EXPECT_EQ(a.at(c), s.at(c)) << where << " " << c;
                EXPECT_EQ(p.at(c), s.at(c)) << where << " " << c;
            }
            EXPECT_EQ(p.at("radiance"), a.at("radiance")) << where;  // columns do not change values
            // The appended columns are the tables' view-ray radiance...
            EXPECT_EQ(a.at("multiple_rayleigh"), mr[w]) << where;
            EXPECT_EQ(a.at("multiple_mie"), mm[w]) << where;
            EXPECT_EQ(a.at("multiple"), mt[w]) << where;
            // ...and radiance(with) − radiance(without) is that radiance to 1e-12 of itself
            // (plus the rounding of the sum: half an ulp of the total).
            const double diff = a.at("radiance") - s.at("radiance");
            EXPECT_LE(std::abs(diff - mt[w]), 1e-12 * mt[w] + 2.3e-16 * a.at("radiance")) << where;
        }
    }
    // Multiple scattering adds light by day (measured share of the radiance at noon, view
    // 45°: 11–26 %) and, relatively, much more where the view ray runs through the Earth's
    // shadow: the twilight sky away from the sun and at the zenith (measured 69–98 % and
    // 38–69 %), and the night zenith, which single scattering leaves exactly black. Toward
    // the sun at twilight the lit upper layers' forward scattering dominates (16–36 %).
    for (std::size_t w = 0; w < nw; ++w) {
        const auto share = [&](int k) {
            const auto& a = with.rows[k * nw + w];
            return a.at("multiple") / a.at("radiance");
        };
        EXPECT_GT(share(kNoon), 0.05) << w;
        EXPECT_GT(share(kTwilightToward), 0.05) << w;
        EXPECT_GT(share(kTwilightAway), 2.0 * share(kNoon)) << w;
        EXPECT_GT(share(kTwilightZenith), 1.3 * share(kNoon)) << w;
        EXPECT_EQ(single.rows[kNightZenith * nw + w].at("radiance"), 0.0) << w;
        EXPECT_GT(with.rows[kNightZenith * nw + w].at("radiance"), 0.0) << w;
    }
}

TEST(EvaluatorInEval, TableOptionsAreUsedAndCheckedByName) {
    int status = 0;
    std::string out = eval_cli("--ms-orders 1", status);
    EXPECT_NE(status, 0);
    EXPECT_NE(out.find("--ms-orders 1"), std::string::npos) << out;
    EXPECT_NE(out.find("[2, 1000]"), std::string::npos) << out;
    out = eval_cli("--ms-samples 0", status);
    EXPECT_NE(status, 0);
    EXPECT_NE(out.find("--ms-samples"), std::string::npos) << out;
    out = eval_cli("--ms-mode lut", status);
    EXPECT_NE(status, 0);
    EXPECT_NE(out.find("--ms-mode"), std::string::npos) << out;
    out = eval_cli("--ms-table 12,33,24,0", status);
    EXPECT_NE(status, 0);
    EXPECT_NE(out.find("table.view_zenith = 33"), std::string::npos) << out;
    out = eval_cli("--ms-table 12,32,24", status);
    EXPECT_NE(status, 0);
    EXPECT_NE(out.find("--ms-table '12,32,24'"), std::string::npos) << out;

    // --ms-orders K and --ms-mode isotropic_lut reach the tables: the column equals the
    // tables built here with the same settings.
    const Atmosphere atm = eval_atmosphere();
    const std::size_t nw = kWavelengths.size();
    std::vector<double> mr(nw), mm(nw), mt(nw);
    for (const auto& [flags, mode, order, table] :
         {std::tuple{std::string("--ms-orders 3"), MsMode::orders, 3, MsTableSize{}},
          std::tuple{std::string("--ms-mode isotropic_lut"), MsMode::isotropic_lut, 0, MsTableSize{}},
          std::tuple{std::string("--ms-table 8,16,12,4"), MsMode::orders, 0, MsTableSize{8, 16, 12, 4}}}) {
        out = eval_cli("--ms-columns " + flags, status);
        ASSERT_EQ(status, 0) << out;
        const Csv csv = parse_csv(out);
        MsSettings m;
        m.mode = mode;
        m.max_order = order;
        m.table = table;
        const MultipleScattering ms = precompute_multiple_scattering(atm, m);
        for (std::size_t k = 0; k < csv.rows.size() / nw; ++k) {
            multiple_scattering_radiance(atm, ms, eval_ray(csv.rows[k * nw]), {mr, mm, mt}, 32);
            for (std::size_t w = 0; w < nw; ++w) EXPECT_EQ(csv.rows[k * nw + w].at("multiple"), mt[w]) << flags;
        }
    }
}

// ---- the sky texture ------------------------------------------------------------------------

Scene earth_rgb() {
    Scene scene = load_preset("earth");
    scene.basis.kind = SpectralBasis::Kind::rgb_schuler;
    scene.basis.wavelengths_nm.clear();
    return scene;
}

SkySettings sky_settings(int w, int h) {
    SkySettings s;
    s.width = w;
    s.height = h;
    s.view.view_samples = 8;
    s.view.sun_disc = false;
    return s;
}

double luminance(const float* p) { return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]; }

TEST(EvaluatorInSky, PixelIsTheSingleScatteringPixelPlusTheTablesRadianceInRgb) {
    Scene scene = earth_rgb();
    scene.sun.elevation_deg = 8.0;
    scene.sun.azimuth_deg = 33.0;  // no mirror: every pixel evaluated
    SkySettings s = sky_settings(32, 16);
    s.grid = 0;
    s.multiple_grid = 0;  // the tables along every ray (the interpolated view: test_table_store.cpp)
    const FloatImage with = render_sky(scene, s);  // tables computed inside
    SkySettings off = s;
    off.multiple.enabled = false;
    const FloatImage without = render_sky(scene, off);

    // Independent: the atmosphere at the basis' wavelengths, tables computed here.
    EvalSettings es;
    es.chapman = s.view.chapman;
    es.view_samples = s.view.view_samples;
    es.sun_disc = false;
    es.ground = true;
    const SpectrumToRgb to_rgb = spectrum_to_rgb(scene.basis);
    const Atmosphere atm = compile_atmosphere(scene, to_rgb.wavelengths_nm, es);
    const MultipleScattering ms = precompute_multiple_scattering(atm, MsSettings{});
    const glm::dvec3 sun = sun_direction(scene.sun.elevation_deg, scene.sun.azimuth_deg);
    const std::size_t nw = atm.wavelength_count();
    std::vector<double> mr(nw), mm(nw), mt(nw);
    int compared = 0;
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x) {
            const glm::dvec3 d = equirect_pixel_direction(x, y, s.width, s.height);
            multiple_scattering_radiance(atm, ms, ViewRay{0.0, Vec3<double>(d), Vec3<double>(sun)}, {mr, mm, mt}, 32);
            const Vec3d m = to_rgb.apply(mt);
            const float *a = with.at(x, y), *b = without.at(x, y);
            // Where no channel was clamped at 0, the colour conversion is linear.
            if (!(std::min({a[0], a[1], a[2], b[0], b[1], b[2]}) > 0.0f)) continue;
            ++compared;
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(double(a[c]) - double(b[c]), m[c], 2e-7 * double(a[c]) + 1e-12)
                    << "pixel " << x << "," << y << " channel " << c;
            EXPECT_GT(luminance(a), luminance(b)) << x << "," << y;
        }
    EXPECT_GT(compared, s.width * s.height * 3 / 4);

    // Tables passed by the caller give the same image bit for bit.
    const MultipleScattering tables = sky_multiple_scattering(scene, s);
    EXPECT_EQ(render_sky(scene, s, {}, &tables).pixels, with.pixels);
    // And sky_radiance_rgb (per direction) is the same radiance as the pixels.
    const std::vector<glm::dvec3> dirs = {equirect_pixel_direction(3, 4, s.width, s.height),
                                          equirect_pixel_direction(20, 12, s.width, s.height)};
    const std::vector<glm::dvec3> rgb = sky_radiance_rgb(scene, s, dirs, &tables);
    for (int c = 0; c < 3; ++c) {
        EXPECT_FLOAT_EQ(float(rgb[0][c]), with.at(3, 4)[c]);
        EXPECT_FLOAT_EQ(float(rgb[1][c]), with.at(20, 12)[c]);
    }
}

TEST(EvaluatorInSky, GridWithMultipleScatteringWithinTheDocumentedTolerance) {
    // docs/sky.md: the default grid against per-pixel evaluation, 95th percentile < 0.2 %,
    // worst pixel < 1 % (the same measure as test_sky.cpp's SkyGrid test), now with the
    // multiple-scattering radiance on the grid nodes.
    Scene scene = earth_rgb();
    scene.sun.azimuth_deg = 33.0;
    // 512 × 256: more pixels than the default grid's 41 × 41 × 2 nodes, so the grid is used.
    SkySettings s = sky_settings(512, 256);
    const MultipleScattering tables = sky_multiple_scattering(scene, s);
    for (double elevation : {20.0, -4.0}) {
        scene.sun.elevation_deg = elevation;
        s.grid = 0;
        const FloatImage exact = render_sky(scene, s, {}, &tables);
        s.grid = -1;
        ASSERT_EQ(effective_sky_grid(scene, s), kSkyDefaultGrid);
        const FloatImage grid = render_sky(scene, s, {}, &tables);
        std::vector<double> errs;
        for (int y = 0; y < s.height; ++y)
            for (int x = 0; x < s.width; ++x) {
                const float *a = grid.at(x, y), *b = exact.at(x, y);
                const double yb = luminance(b);
                double e = 0;
                for (int c = 0; c < 3; ++c)
                    if (yb > 0.0) e = std::max(e, std::abs(double(a[c]) - b[c]) / std::max(double(b[c]), yb));
                errs.push_back(e);
            }
        std::sort(errs.begin(), errs.end());
        // Measured at the default grid (40): p95 3.4e-5 / 1.1e-4, max 2.4e-4 / 3.0e-3 (sun 20° / −4°).
        EXPECT_LT(errs[errs.size() * 95 / 100], 2e-3) << "sun " << elevation;
        EXPECT_LT(errs.back(), 1e-2) << "sun " << elevation;
    }
}

TEST(EvaluatorInSky, MultipleScatteringMattersMostInTheEarthsShadow) {
    // The half of the sky away from the sun (sun rotation 0°: toward +Y; that half is y < 0),
    // above the horizon: multiple scattering brightens it by day and far more, relatively,
    // at twilight, when the low sky there lies in the Earth's shadow.
    Scene scene = earth_rgb();
    scene.sun.azimuth_deg = 0.0;
    SkySettings s = sky_settings(64, 32);
    const MultipleScattering tables = sky_multiple_scattering(scene, s);
    SkySettings off = s;
    off.multiple.enabled = false;
    std::map<double, double> ratio;
    for (double elevation : {45.0, -6.0}) {
        scene.sun.elevation_deg = elevation;
        const FloatImage a = render_sky(scene, s, {}, &tables), b = render_sky(scene, off);
        double ya = 0, yb = 0;
        for (int y = 0; y < s.height / 2; ++y)
            for (int x = 0; x < s.width; ++x)
                if (equirect_pixel_direction(x, y, s.width, s.height).y < 0.0)
                    ya += luminance(a.at(x, y)), yb += luminance(b.at(x, y));
        ratio[elevation] = ya / yb;
    }
    EXPECT_GT(ratio[45.0], 1.1);
    EXPECT_GT(ratio[-6.0], 2.0 * ratio[45.0]) << ratio[45.0];
}

TEST(EvaluatorInSky, FiniteAndNonNegativeAtTheExtremes) {
    for (const char* preset : {"earth", "mars"}) {
        Scene scene = load_preset(preset);
        scene.basis.kind = SpectralBasis::Kind::rgb_schuler;
        scene.basis.wavelengths_nm.clear();
        SkySettings s = sky_settings(64, 32);
        s.view.sun_disc = true;
        const MultipleScattering tables = sky_multiple_scattering(scene, s);
        // Exactly the zenith, the horizontal (view zenith 90°, two azimuths), the nadir (180°).
        const std::vector<glm::dvec3> dirs = {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}, {0, 0, -1}, {1, 0, -1e-9}};
        for (double elevation : {-90.0, -10.0, -0.3, 0.0, 5.0, 90.0})
            for (double altitude : {0.0, 10e3, 400e3, 1e6}) {
                scene.sun.elevation_deg = elevation;
                scene.observer.altitude_m = altitude;
                const std::string where = std::string(preset) + " sun " + std::to_string(elevation) + " altitude " +
                                          std::to_string(altitude);
                // grid 8: 9 × 9 × 2 = 162 nodes — 297 from above the ozone, the sky split at its
                // three knots (sky_grid.hpp) — fewer than the 64 × 32 image's rays even when the
                // mirror halves them (otherwise every pixel is evaluated: sky.hpp).
                for (int grid : {0, 8}) {
                    s.grid = grid;
                    EXPECT_EQ(effective_sky_grid(scene, s), grid) << where;
                    const FloatImage img = render_sky(scene, s, {}, &tables);
                    for (float v : img.pixels) ASSERT_TRUE(std::isfinite(v) && v >= 0.0f) << where;
                }
                for (const glm::dvec3& c : sky_radiance_rgb(scene, s, dirs, &tables))
                    for (int k = 0; k < 3; ++k) ASSERT_TRUE(std::isfinite(c[k]) && c[k] >= 0.0) << where;
            }
    }
}

TEST(EvaluatorInSky, MetadataRecordsWhetherAndHowMultipleScatteringWasIncluded) {
    const Scene scene = earth_rgb();
    SkySettings s = sky_settings(64, 32);
    s.multiple.tables.max_order = 5;
    s.multiple.view_samples = 24;
    nlohmann::json j = nlohmann::json::parse(sky_settings_to_json(scene, s));
    EXPECT_EQ(j.at("multiple_scattering"), true);
    EXPECT_EQ(j.at("multiple").at("mode"), "orders");
    EXPECT_EQ(j.at("multiple").at("max_order"), 5);
    EXPECT_EQ(j.at("multiple").at("view_ray_samples"), 24);
    EXPECT_EQ(j.at("multiple").at("table").at("altitude"), MsTableSize{}.altitude);
    EXPECT_GE(j.at("multiple").at("table").at("azimuth").get<int>(), 1);  // 0 (automatic) resolved
    s.multiple.enabled = false;
    j = nlohmann::json::parse(sky_settings_to_json(scene, s));
    EXPECT_EQ(j.at("multiple_scattering"), false);
    EXPECT_FALSE(j.contains("multiple"));
}

TEST(EvaluatorInSky, BadSettingsAndForeignTablesNameTheField) {
    SkySettings s;
    s.multiple.view_samples = 0;
    try {
        validate(s);
        FAIL();
    } catch (const SkyError& e) {
        EXPECT_NE(std::string(e.what()).find("multiple_samples = 0"), std::string::npos) << e.what();
    }
    s = {};
    s.multiple.tables.max_order = 1;
    try {
        validate(s);
        FAIL();
    } catch (const SkyError& e) {
        EXPECT_NE(std::string(e.what()).find("multiple.max_order"), std::string::npos) << e.what();
    }
    s.multiple.enabled = false;  // the table settings are not used, so not checked
    EXPECT_NO_THROW(validate(s));

    // Tables of another atmosphere (3 wavelengths) for a spectral sky.
    const Scene rgb = earth_rgb();
    SkySettings small = sky_settings(16, 8);
    const MultipleScattering tables = sky_multiple_scattering(rgb, small);
    Scene spectral = rgb;
    spectral.basis.kind = SpectralBasis::Kind::spectral;
    spectral.basis.wavelengths_nm = {450.0, 550.0, 650.0, 700.0};
    try {
        render_sky(spectral, small, {}, &tables);
        FAIL();
    } catch (const SkyError& e) {
        EXPECT_NE(std::string(e.what()).find("multiple-scattering tables"), std::string::npos) << e.what();
    }
}

TEST(EvaluatorInSky, PrecomputeReportsProgressAndCanBeCancelled) {
    const Scene scene = earth_rgb();
    SkySettings s = sky_settings(64, 32);
    s.grid = 0;
    // Progress: the precompute counts as much as the image, and every unit is reported once.
    std::atomic<std::size_t> done{0}, seen_total{0};
    RenderHooks hooks;
    hooks.work_done = [&](std::size_t n, std::size_t total) {
        done += n;
        seen_total = total;
    };
    render_sky(scene, s, hooks);
    const std::size_t image_rows = std::size_t(s.height);
    EXPECT_EQ(seen_total.load(), 2 * image_rows);
    EXPECT_EQ(done.load(), 2 * image_rows);
    // Cancelled during the precompute: nothing returned, the precompute stops early.
    CancelFlag flag;
    done = 0;
    hooks.cancel = &flag;
    hooks.work_done = [&](std::size_t n, std::size_t) {
        done += n;
        flag.request();
    };
    EXPECT_THROW(render_sky(scene, s, hooks), Cancelled);
    EXPECT_LE(done.load(), image_rows);  // the image rows never started
    flag.reset();
    flag.request();
    EXPECT_THROW(sky_multiple_scattering(scene, s, hooks), Cancelled);
}

}  // namespace
}  // namespace airmass
