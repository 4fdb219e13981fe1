// Extremes swept (issue 17, item 3): every numeric field of a scene file (docs/scene.md), at
// its bounds, just inside, just outside and at the far ends of double (denormals, 1e±30,
// 1e±300, ±inf, nan). Each value is either refused with a SceneError naming the field and its
// allowed range, or gives a finite, non-negative sky (render_sky at 32x16, single scattering;
// with multiple scattering for the profile fields) and finite, non-negative transmittance and
// radiance along a few view rays (the `airmass eval` path). Values just inside a documented
// range must be accepted and values just outside must be refused, so the sweep also pins the
// documented ranges.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "airmass/atmosphere.hpp"
#include "airmass/chapman.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/single_scattering.hpp"
#include "airmass/sky.hpp"

namespace airmass {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kDenorm = std::numeric_limits<double>::denorm_min();

enum class Expect { accept, refuse, either };

std::string toml_number(double v) {
    if (std::isnan(v)) return "nan";
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;  // "6360" reads as a TOML integer, which number fields take too
}

double up(double v) { return std::nextafter(v, kInf); }
double down(double v) { return std::nextafter(v, -kInf); }

struct Outcome {
    bool refused = false;
    std::string message;
};

// Every pixel finite and >= 0 (the RGB basis: Schüler's matrix keeps sky spectra non-negative).
void expect_image_ok(const FloatImage& img, const std::string& what) {
    ASSERT_EQ(img.pixels.size(), std::size_t(img.width) * img.height * img.channels) << what;
    std::size_t bad = 0;
    float first = 0.0f;
    for (float v : img.pixels)
        if (!std::isfinite(v) || v < 0.0f) {
            if (bad++ == 0) first = v;
        }
    EXPECT_EQ(bad, 0u) << what << ": " << bad << " pixels non-finite or negative (first " << first << ")";
}

// Parses `toml`; on success renders the sky and evaluates view rays. A SceneError or SkyError
// (parse, compile or render) is a refusal.
Outcome run(const std::string& toml, const std::string& what, bool multiple) {
    Outcome out;
    try {
        const Scene scene = parse_scene_toml(toml, "extreme.toml");
        SkySettings s;
        s.width = 32;
        s.height = 16;
        s.view.view_samples = 4;
        s.grid = 0;
        s.threads = 2;  // the tables' too
        s.multiple.enabled = multiple;
        expect_image_ok(render_sky(scene, s), what + " (sky)");
        // The same through the grids (sky_grid.hpp: pieces split at the horizon, the knots'
        // tangent rays, the horizontal and the limb), as a large image uses them: grid 4 and a
        // view of 2 intervals have fewer rays than these 256 pixel rays.
        s.grid = 4;
        s.multiple_grid = 2;
        EXPECT_EQ(effective_sky_grid(scene, s), 4) << what;
        expect_image_ok(render_sky(scene, s), what + " (sky through the grids)");
        s.grid = 0;

        const double wl[] = {680.0, 550.0, 440.0};
        EvalSettings es;
        es.view_samples = 8;
        const Atmosphere atm = compile_atmosphere(scene, wl, es);
        for (double vz : {0.0, 60.0, 89.9, 90.0, 90.1, 120.0, 180.0}) {
            double T[3], R[3], M[3], L[3];
            const ViewRay ray{scene.observer.altitude_m, direction_from_zenith_azimuth_deg<double>(vz, 0.0),
                              direction_from_zenith_azimuth_deg<double>(90.0 - scene.sun.elevation_deg, 30.0)};
            single_scattering(atm, ray, RadianceOut{T, R, M, L});
            for (int w = 0; w < 3; ++w) {
                EXPECT_TRUE(std::isfinite(T[w]) && T[w] >= 0.0 && T[w] <= 1.0)
                    << what << ": transmittance " << T[w] << " at view zenith " << vz;
                EXPECT_TRUE(std::isfinite(L[w]) && L[w] >= 0.0) << what << ": radiance " << L[w] << " at " << vz;
                EXPECT_TRUE(std::isfinite(R[w]) && R[w] >= 0.0) << what << ": rayleigh " << R[w];
                EXPECT_TRUE(std::isfinite(M[w]) && M[w] >= 0.0) << what << ": mie " << M[w];
            }
        }
    } catch (const SceneError& e) {
        out.refused = true;
        out.message = e.what();
    } catch (const SkyError& e) {
        out.refused = true;
        out.message = e.what();
    }
    return out;
}

struct Sweep {
    std::string field;  // the name the refusal must carry, e.g. "planet.radius_km"
    // The TOML for one value (a preset override; RGB basis unless the field is spectral).
    std::string (*toml)(const std::string& value);
    std::vector<std::pair<double, Expect>> values;
    bool multiple = false;
};

const std::string kBase = "preset = \"earth\"\n[spectrum]\nbasis = \"rgb-schuler\"\n";

void sweep(const Sweep& s) {
    for (const auto& [v, expect] : s.values) {
        const std::string text = s.toml(toml_number(v));
        const std::string what = s.field + " = " + toml_number(v);
        SCOPED_TRACE(what);
        const Outcome o = run(text, what, s.multiple);
        if (o.refused) {
            EXPECT_NE(expect, Expect::accept) << what << " refused: " << o.message;
            EXPECT_NE(o.message.find(s.field), std::string::npos) << what << ": the refusal does not name the field: "
                                                                  << o.message;
            EXPECT_NE(o.message.find("must"), std::string::npos) << what << ": no allowed range in: " << o.message;
        } else {
            EXPECT_NE(expect, Expect::refuse) << what << " was accepted (outside the documented range)";
        }
    }
}

using E = Expect;

// A tiny planet (radius_km near 1e-30 or a denormal, atmosphere_top_km = 2e6) sent a NaN zenith angle into the
// airmass Chapman table (UBSan: float-cast-overflow; Release: a segfault): radius_km >= 1 km now.
TEST(Extremes, Planet) {
    sweep({"planet.radius_km",
           [](const std::string& v) { return kBase + "[planet]\nradius_km = " + v + "\natmosphere_top_km = 2e6\n"; },
           {{0.0, E::refuse}, {-1.0, E::refuse}, {kDenorm, E::refuse}, {1e-30, E::refuse}, {down(1.0), E::refuse},
            {1.0, E::accept},
            {6360.0, E::accept}, {1e6, E::accept}, {up(1e6), E::refuse}, {1e300, E::refuse}, {kInf, E::refuse},
            {kNaN, E::refuse}}});
    sweep({"planet.ground_albedo",
           [](const std::string& v) { return kBase + "[planet]\nground_albedo = " + v + "\n"; },
           {{down(0.0), E::refuse}, {0.0, E::accept}, {kDenorm, E::accept}, {0.5, E::accept}, {1.0, E::accept},
            {up(1.0), E::refuse}, {kInf, E::refuse}, {kNaN, E::refuse}}});
}

// An atmosphere top just above the ground (6360.001 km on the earth preset) was refused by ozone's
// column_du ("needs a profile with a non-zero, finite column below the atmosphere top"), naming
// neither planet.atmosphere_top_km nor a range. Ozone's tent starts 10 km up and its column_du is
// spread over the part below the top: the top must now be > 6370 km, and the refusal says so.
TEST(Extremes, PlanetAtmosphereTop) {
    sweep({"planet.atmosphere_top_km",
           [](const std::string& v) { return kBase + "[planet]\nradius_km = 6360\natmosphere_top_km = " + v + "\n"; },
           {{6360.0, E::refuse}, {up(6360.0), E::refuse}, {6360.001, E::refuse}, {6370.0, E::refuse},
            {up(6370.0), E::either}, {6370.001, E::accept}, {6420.0, E::accept}, {2e6, E::accept},
            {up(2e6), E::refuse}, {1e300, E::refuse}, {kInf, E::refuse}, {kNaN, E::refuse}, {-6420.0, E::refuse}}});
    // Without ozone (Rayleigh and Mie are exponential: density from the ground up) a top 1 m above
    // the ground is a valid, nearly transparent atmosphere.
    sweep({"planet.atmosphere_top_km",
           [](const std::string& v) {
               return "[planet]\nradius_km = 6360\natmosphere_top_km = " + v +
                      "\n[sun]\nelevation_deg = 15\nirradiance = { type = \"constant\", value_w_m2_nm = 1.5 }\n"
                      "[spectrum]\nbasis = \"rgb-schuler\"\n"
                      "[[constituent]]\nname = \"rayleigh\"\nprofile = { type = \"exponential\", scale_height_km = 8 }\n"
                      "scattering = { law = \"rayleigh\", value_per_m_at_1um = 1.24062e-6 }\nphase = { type = \"rayleigh\" }\n"
                      "[[constituent]]\nname = \"mie\"\nprofile = { type = \"exponential\", scale_height_km = 1.2 }\n"
                      "extinction = { law = \"angstrom\", beta = 5.328e-3, alpha = 0.0 }\nsingle_scattering_albedo = 0.9\n"
                      "phase = { type = \"cornette-shanks\", g = 0.8 }\n";
           },
           {{6360.0, E::refuse}, {up(6360.0), E::either}, {6360.001, E::accept}, {6360.1, E::accept}}});
}

// sun.distance_au of 1e-300 or a denormal was refused naming the scaled irradiance (= inf), and
// irradiance value_w_m2_nm = 1e300 was accepted and rendered +inf pixels: both fields now have
// bounds checked as written ([1e-3, 1000] AU; [0, 1e6] W m^-2 nm^-1 at 1 AU).
TEST(Extremes, Sun) {
    sweep({"sun.elevation_deg", [](const std::string& v) { return kBase + "[sun]\nelevation_deg = " + v + "\n"; },
           {{down(-90.0), E::refuse}, {-90.0, E::accept}, {-89.9999, E::accept}, {-1e-4, E::accept},
            {-kDenorm, E::accept}, {0.0, E::accept}, {1e-4, E::accept}, {89.9999, E::accept}, {90.0, E::accept},
            {up(90.0), E::refuse}, {kInf, E::refuse}, {kNaN, E::refuse}}});
    sweep({"sun.azimuth_deg", [](const std::string& v) { return kBase + "[sun]\nazimuth_deg = " + v + "\n"; },
           {{down(-360.0), E::refuse}, {-360.0, E::accept}, {0.0, E::accept}, {359.999, E::accept},
            {360.0, E::accept}, {up(360.0), E::refuse}, {kInf, E::refuse}, {kNaN, E::refuse}}});
    sweep({"sun.angular_radius_deg",
           [](const std::string& v) { return kBase + "[sun]\nangular_radius_deg = " + v + "\n"; },
           {{0.0, E::refuse}, {kDenorm, E::either}, {1e-9, E::accept}, {5.0, E::accept}, {up(5.0), E::refuse},
            {kInf, E::refuse}, {kNaN, E::refuse}}});
    sweep({"sun.distance_au", [](const std::string& v) { return kBase + "[sun]\ndistance_au = " + v + "\n"; },
           {{0.0, E::refuse}, {kDenorm, E::refuse}, {1e-300, E::refuse}, {down(1e-3), E::refuse}, {1e-3, E::accept},
            {1000.0, E::accept}, {up(1000.0), E::refuse}, {kInf, E::refuse}, {kNaN, E::refuse}}});
    sweep({"sun.irradiance.value_w_m2_nm",
           [](const std::string& v) {
               return kBase + "[sun]\nirradiance = { type = \"constant\", value_w_m2_nm = " + v + " }\n";
           },
           {{down(0.0), E::refuse}, {0.0, E::accept}, {kDenorm, E::accept}, {1.0, E::accept}, {1e6, E::accept},
            {up(1e6), E::refuse}, {1e30, E::refuse}, {1e300, E::refuse}, {kInf, E::refuse}, {kNaN, E::refuse}}});
    // The largest irradiance at the nearest distance: 1e12 at the planet, a finite sky.
    sweep({"sun.irradiance.value_w_m2_nm",
           [](const std::string& v) {
               return kBase + "[sun]\ndistance_au = 1e-3\nirradiance = { type = \"constant\", value_w_m2_nm = " + v +
                      " }\n";
           },
           {{1e6, E::accept}, {up(1e6), E::refuse}}});
    sweep({"sun.irradiance.values_w_m2_nm[1]",
           [](const std::string& v) {
               return kBase + "[sun]\nirradiance = { type = \"table\", wavelengths_nm = [360, 830], values_w_m2_nm = "
                              "[1, " + v + "] }\n";
           },
           {{1e6, E::accept}, {up(1e6), E::refuse}, {1e300, E::refuse}, {kInf, E::refuse}}});
}

TEST(Extremes, Observer) {
    sweep({"observer.altitude_km", [](const std::string& v) { return kBase + "[observer]\naltitude_km = " + v + "\n"; },
           {{down(0.0), E::refuse}, {0.0, E::accept}, {kDenorm, E::accept}, {1e-3, E::accept},
            {0.0606, E::accept} /* the horizontal's split starts (0.25° dip) */, {25.0, E::accept} /* a knot */,
            {59.999, E::accept},
            {60.0, E::accept}, {60.001, E::accept}, {1e6, E::accept}, {up(1e6), E::refuse}, {kInf, E::refuse},
            {kNaN, E::refuse}}});
}

TEST(Extremes, Camera) {
    // The camera is not used by the sky; its fields are validated with the scene.
    sweep({"camera.fov_deg", [](const std::string& v) { return kBase + "[camera]\nfov_deg = " + v + "\n"; },
           {{0.0, E::refuse}, {kDenorm, E::either}, {1e-6, E::accept}, {179.999, E::accept}, {180.0, E::refuse},
            {kInf, E::refuse}, {kNaN, E::refuse}}});
    sweep({"camera.max_distance_km",
           [](const std::string& v) { return kBase + "[camera]\nmax_distance_km = " + v + "\n"; },
           {{0.0, E::refuse}, {kDenorm, E::either}, {1e-6, E::accept}, {1e6, E::accept}, {1e300, E::either},
            {kInf, E::refuse}, {kNaN, E::refuse}}});
    sweep({"camera.width", [](const std::string& v) { return kBase + "[camera]\nwidth = " + v + "\n"; },
           {{0.0, E::refuse}, {1.0, E::accept}, {65536.0, E::accept}, {65537.0, E::refuse}, {-1.0, E::refuse},
            {1e18, E::refuse}}});
    sweep({"camera.height", [](const std::string& v) { return kBase + "[camera]\nheight = " + v + "\n"; },
           {{0.0, E::refuse}, {1.0, E::accept}, {65536.0, E::accept}, {65537.0, E::refuse}}});
    sweep({"camera.position_km",
           [](const std::string& v) { return kBase + "[camera]\nposition_km = [0.0, 0.0, " + v + "]\n"; },
           {{0.0, E::accept}, {1e7, E::accept}, {1.000001e7, E::refuse}, {-1e7, E::accept}, {-1.000001e7, E::refuse},
            {-1e300, E::refuse}, {1e300, E::refuse}, {kInf, E::refuse}, {kNaN, E::refuse}}});
    sweep({"camera.direction",
           [](const std::string& v) { return kBase + "[camera]\ndirection = [" + v + ", 0.0, 0.0]\n"; },
           {{0.0, E::refuse}, {kDenorm, E::either}, {1e-300, E::either}, {1.0, E::accept}, {1e300, E::either},
            {kInf, E::refuse}, {kNaN, E::refuse}}});
}

TEST(Extremes, Spectrum) {
    sweep({"spectrum.wavelengths_nm",
           [](const std::string& v) {
               return "preset = \"earth\"\n[spectrum]\nbasis = \"spectral\"\nwavelengths_nm = [" + v + "]\n";
           },
           {{down(360.0), E::refuse}, {360.0, E::accept}, {550.0, E::accept}, {830.0, E::accept},
            {up(830.0), E::refuse}, {0.0, E::refuse}, {kInf, E::refuse}, {kNaN, E::refuse}}});
}

// Profiles: the known bug of issue 17 (scale_height_km = 1e-30 rendered non-finite pixels) and
// every other scale. Multiple scattering on: its tables integrate the same profiles.
std::string mie_profile(const std::string& profile) {
    return kBase + "[[constituent]]\nname = \"mie\"\nprofile = " + profile + "\n";
}

TEST(Extremes, ExponentialScaleHeight) {
    const auto toml = [](const std::string& v) {
        return mie_profile("{ type = \"exponential\", scale_height_km = " + v + " }");
    };
    sweep({"profile.scale_height_km", toml,
           {{0.0, E::refuse}, {-1.0, E::refuse}, {kDenorm, E::refuse}, {1e-300, E::refuse}, {1e-30, E::refuse},
            {1e-12, E::refuse}, {1e-6, E::refuse}, {down(1e-3), E::refuse}, {1e-3, E::accept}, {1.2, E::accept},
            {1e3, E::accept}, {1e6, E::accept}, {1e9, E::accept}, {up(1e9), E::refuse}, {1e30, E::refuse},
            {1e300, E::refuse}, {kInf, E::refuse}, {kNaN, E::refuse}}});
}

// Issue 17's known bug: scale_height_km = 1e-30 rendered a sky with non-finite pixels (exit 0).
// First cause: the multiple-scattering kernels' fast_exp(x) (multiple_scattering_kernels.inc)
// for x below about -1.2e7 overflowed int32 (UB; UBSan: signed integer overflow); fixed. With
// that fixed the sky still had +inf pixels (half of them for mie, 1/12 for rayleigh at 32x16):
// a layer of 1e-27 m carries optical depths and (Angstrom law) coefficients ~1e30, beyond float.
// Scale heights below 1 m are now refused naming the field and the bound; from 1 m up the sky
// with multiple scattering (as the CLI renders) is finite and non-negative.
TEST(Extremes, TinyScaleHeightWithMultipleScattering) {
    for (const char* name : {"mie", "rayleigh"}) {
        SCOPED_TRACE(name);
        static std::string n;
        n = name;
        sweep({"profile.scale_height_km",
               [](const std::string& v) {
                   return kBase + "[[constituent]]\nname = \"" + n + "\"\nprofile = { type = \"exponential\", " +
                          "scale_height_km = " + v + " }\n";
               },
               {{kDenorm, E::refuse}, {1e-300, E::refuse}, {1e-30, E::refuse}, {down(1e-3), E::refuse},
                {1e-3, E::accept}, {1e-2, E::accept}},
               true});
    }
}

// |reference_altitude_km| >= 1000 was refused by the Angstrom law (extinction.beta needs a profile with a
// non-zero, finite column), naming beta and no range: the field is now bounded by ±50 scale heights.
TEST(Extremes, ExponentialReferenceAltitude) {
    const auto toml = [](const std::string& v) {
        return mie_profile("{ type = \"exponential\", scale_height_km = 1.2, reference_altitude_km = " + v + " }");
    };
    sweep({"profile.reference_altitude_km", toml,
           {{0.0, E::accept}, {-10.0, E::accept}, {10.0, E::accept}, {60.0, E::accept}, {-60.0, E::accept},
            {up(60.0), E::refuse}, {down(-60.0), E::refuse}, {1e3, E::refuse}, {-1e3, E::refuse}, {1e30, E::refuse},
            {-1e30, E::refuse}, {1e300, E::refuse}, {-1e300, E::refuse}, {kInf, E::refuse}, {kNaN, E::refuse}}});
}

// Were open (issue 17): a denormal tent peak_km (knots closer than rounding) gave NaN transmittance and
// radiance along a horizontal ray (the piecewise-linear mass: an infinite slope times a rounded 0);
// altitudes_km[1] = 10 was refused naming only altitudes_km[2]; a constant profile of value 0 under
// the Angstrom law (beta spread over the column) was refused naming only extinction.beta, no range.
TEST(Extremes, OtherProfiles) {
    sweep({"profile.peak_km",
           [](const std::string& v) {
               return mie_profile("{ type = \"tent\", bottom_km = 0, peak_km = " + v + ", top_km = 40 }");
           },
           {{0.0, E::refuse}, {kDenorm, E::either}, {1e-9, E::either}, {20.0, E::accept}, {down(40.0), E::either},
            {40.0, E::refuse}, {kNaN, E::refuse}}});
    sweep({"profile.densities[1]",
           [](const std::string& v) {
               return mie_profile("{ type = \"piecewise-linear\", altitudes_km = [0, 5, 10], densities = [1, " + v +
                                  ", 0] }");
           },
           {{down(0.0), E::refuse}, {0.0, E::accept}, {1.0, E::accept}, {1e6, E::either}, {1e30, E::either},
            {1e300, E::either}, {kInf, E::refuse}, {kNaN, E::refuse}}});
    sweep({"profile.altitudes_km[1]",
           [](const std::string& v) {
               return mie_profile("{ type = \"piecewise-linear\", altitudes_km = [0, " + v +
                                  ", 10], densities = [1, 1, 0] }");
           },
           {{0.0, E::refuse}, {kDenorm, E::either}, {1e-12, E::either}, {5.0, E::accept}, {down(10.0), E::either},
            {10.0, E::refuse}, {kNaN, E::refuse}}});
    sweep({"profile.value",
           [](const std::string& v) { return mie_profile("{ type = \"constant\", value = " + v + ", top_km = 2 }"); },
           {{down(0.0), E::refuse}, {0.0, E::refuse}, {kDenorm, E::either}, {1.0, E::accept}, {1e30, E::either},
            {1e300, E::either}, {kInf, E::refuse}, {kNaN, E::refuse}}});
}

std::string mie_coefficient(const std::string& key, const std::string& table) {
    return kBase + "[[constituent]]\nname = \"mie\"\n" + key + " = " + table + "\n";
}

// Was open (issue 17): reference_nm = 1e300 (exponent 10) was refused naming only the derived
// "scattering at 615 nm = inf"; reference_nm now has a range that keeps the law finite.
TEST(Extremes, Coefficients) {
    sweep({"scattering.value_per_m",
           [](const std::string& v) {
               return mie_coefficient("scattering", "{ law = \"constant\", value_per_m = " + v + " }");
           },
           {{down(0.0), E::refuse}, {0.0, E::accept}, {kDenorm, E::accept}, {1e-5, E::accept}, {1.0, E::accept},
            {1e30, E::either}, {1e300, E::either}, {kInf, E::refuse}, {kNaN, E::refuse}}});
    sweep({"exponent",
           [](const std::string& v) {
               return mie_coefficient("extinction", "{ law = \"power-law\", value_per_m = 4e-6, reference_nm = 550, "
                                                    "exponent = " + v + " }");
           },
           {{down(-10.0), E::refuse}, {-10.0, E::accept}, {0.0, E::accept}, {10.0, E::accept}, {up(10.0), E::refuse},
            {kNaN, E::refuse}}});
    sweep({"reference_nm",
           [](const std::string& v) {
               return mie_coefficient("extinction", "{ law = \"power-law\", value_per_m = 4e-6, reference_nm = " + v +
                                                    ", exponent = 10 }");
           },
           {{0.0, E::refuse}, {kDenorm, E::either}, {1e-30, E::either}, {550.0, E::accept}, {1e30, E::either},
            {4.4e32, E::accept}, {4.5e32, E::refuse}, {1e300, E::refuse}, {kInf, E::refuse}, {kNaN, E::refuse}}});
    // The bound: (reference / 445 nm)^10 <= 1e300 (445 nm, the RGB basis' shortest wavelength),
    // and for exponent -10, (615 nm / reference)^10 <= 1e300.
    sweep({"reference_nm",
           [](const std::string& v) {
               return mie_coefficient("extinction", "{ law = \"power-law\", value_per_m = 4e-6, reference_nm = " + v +
                                                    ", exponent = -10 }");
           },
           {{0.0, E::refuse}, {kDenorm, E::refuse}, {6.1e-28, E::refuse}, {6.2e-28, E::accept}, {550.0, E::accept},
            {1e300, E::either}, {kInf, E::refuse}}});
    sweep({"alpha",
           [](const std::string& v) {
               return mie_coefficient("extinction", "{ law = \"angstrom\", beta = 0.1, alpha = " + v + " }");
           },
           {{down(-10.0), E::refuse}, {-10.0, E::accept}, {10.0, E::accept}, {up(10.0), E::refuse}}});
    sweep({"beta",
           [](const std::string& v) {
               return mie_coefficient("extinction", "{ law = \"angstrom\", beta = " + v + ", alpha = 1.3 }");
           },
           {{down(0.0), E::refuse}, {0.0, E::accept}, {10.0, E::accept}, {1e30, E::either}, {1e300, E::either},
            {kInf, E::refuse}}});
    sweep({"single_scattering_albedo",
           [](const std::string& v) {
               return kBase + "[[constituent]]\nname = \"mie\"\nsingle_scattering_albedo = " + v + "\n";
           },
           {{down(0.0), E::refuse}, {0.0, E::accept}, {1.0, E::accept}, {up(1.0), E::refuse}, {kNaN, E::refuse}}});
}

TEST(Extremes, Phase) {
    for (const char* type : {"cornette-shanks", "henyey-greenstein"}) {
        SCOPED_TRACE(type);
        static std::string t;
        t = type;
        sweep({"phase.g",
               [](const std::string& v) {
                   return kBase + "[[constituent]]\nname = \"mie\"\nphase = { type = \"" + t + "\", g = " + v + " }\n";
               },
               {{-1.0, E::refuse}, {up(-1.0), E::either}, {-0.999999, E::accept}, {0.0, E::accept},
                {0.999999, E::accept}, {down(1.0), E::either}, {1.0, E::refuse}, {kNaN, E::refuse}}});
    }
}

}  // namespace
}  // namespace airmass

namespace airmass {
namespace {

// Found by fuzz_csv (`airmass chapman` with the row "1e300, 45"): the `airmass` method's shared
// division a·b·q overflowed, the table coordinates became 0·inf = NaN and their int conversion
// was undefined behaviour (UBSan: float-cast-overflow). Ch(x, chi) → 1/cos chi as x → inf.
TEST(Extremes, ChapmanAirmassHugeX) {
    for (double chi : {0.0, 45.0, 80.0, 89.0}) {
        const double expect = 1.0 / std::cos(chi * 3.14159265358979323846 / 180.0);
        for (double x : {1e200, 1e250, 1e300, std::numeric_limits<double>::max()}) {
            const double ch = chapman(ChapmanMethod::airmass, x, ZenithAngle<double>::from_degrees(chi));
            EXPECT_NEAR(ch, expect, 1e-6 * expect) << "x = " << x << ", chi = " << chi;
        }
        for (float x : {1e25f, 1e30f, 1e38f, std::numeric_limits<float>::max()}) {
            const float ch = chapman(ChapmanMethod::airmass, x, ZenithAngle<float>::from_degrees(chi));
            EXPECT_NEAR(ch, float(expect), 1e-4f * float(expect)) << "float x = " << x << ", chi = " << chi;
        }
    }
    // Below the horizon the value is huge but the scaled form stays a number.
    const auto s = chapman_scaled(ChapmanMethod::airmass, 1e300, ZenithAngle<double>::from_degrees(135.0));
    EXPECT_TRUE(std::isfinite(s.mantissa) && s.mantissa > 0.0) << s.mantissa;
    EXPECT_TRUE(std::isfinite(s.log_scale) && s.log_scale > 0.0) << s.log_scale;
}

// A NaN x below the horizon (or a NaN cos chi) went through the careful path's table cell as
// static_cast<int>(NaN), INT_MIN with GCC: a read ~16 GiB before the table, a crash (found by
// comparing batch and scalar over random inputs). NaN in, NaN out, scalar and batch.
TEST(Extremes, ChapmanAirmassNaNBelowTheHorizon) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const auto below = ZenithAngle<double>::from_degrees(120.0);
    EXPECT_TRUE(std::isnan(chapman_scaled(ChapmanMethod::airmass, nan, below).mantissa));
    EXPECT_TRUE(std::isnan(chapman_scaled(ChapmanMethod::airmass, 2.0, ZenithAngle<double>{nan, 0.5}).mantissa));
    EXPECT_TRUE(std::isnan(chapman_scaled(ChapmanMethod::airmass, float(nan), ZenithAngle<float>::from_degrees(120.0f)).mantissa));
    std::vector<double> x{2.0, nan, 3.0, 4.0, 5.0}, c(5, below.cos_chi), s(5, below.sin_chi), m(5), e(5);
    chapman_scaled_batch<double>(ChapmanMethod::airmass, x, c, s, m, e);
    for (size_t i = 0; i < x.size(); ++i) {
        const auto one = chapman_scaled(ChapmanMethod::airmass, x[i], below);
        if (i == 1) EXPECT_TRUE(std::isnan(m[i])) << m[i];
        else EXPECT_NEAR(m[i], one.mantissa, 1e-12 * one.mantissa) << "x = " << x[i];
    }
}

// A NaN or infinite cos χ in one lane of the batch's 64-lane chunk must not change the others
// (the chunk's "all above the horizon" test once ORed the lanes' bits: NaN | −0.5 is NaN, not
// negative, and a lane below the horizon got Ch(x, 180° − χ)); negative x is NaN, not a read
// outside the table (scalar fast path).
TEST(Extremes, ChapmanAirmassBatchOddLanesDoNotLeak) {
    const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
    for (const double odd : {nan, inf, -inf, 1.5, -2.0}) {
        const std::size_t n = 131;  // two full chunks and a tail of three lanes
        std::vector<double> x(n), c(n), s(n), m(n), e(n);
        for (std::size_t i = 0; i < n; ++i) {
            const auto chi = ZenithAngle<double>::from_degrees(i % 3 == 0 ? 120.0 : i % 3 == 1 ? 95.0 : 60.0);
            x[i] = 1.0 + double(i % 17) * 40.0;
            c[i] = chi.cos_chi, s[i] = chi.sin_chi;
        }
        // One odd lane in every position of a block (mod 4), so the bits of every position ORed over
        // the chunk are NaN, in both chunks.
        for (const std::size_t i : {0, 1, 2, 3, 64, 65, 66, 67}) c[i] = odd;
        chapman_scaled_batch<double>(ChapmanMethod::airmass, x, c, s, m, e);
        for (std::size_t i = 0; i < n; ++i) {
            if (i < 4 || (i >= 64 && i < 68)) continue;
            const auto one = chapman_scaled(ChapmanMethod::airmass, x[i], ZenithAngle<double>{c[i], s[i]});
            EXPECT_NEAR(m[i] * std::exp(-e[i] + one.log_scale), one.mantissa, 1e-11 * one.mantissa)
                << "lane " << i << " beside cos chi = " << odd;
        }
    }
    for (const double chi : {60.0, 120.0})
        for (const double x : {-1.0, -std::numeric_limits<double>::infinity()})
            EXPECT_TRUE(std::isnan(chapman_scaled(ChapmanMethod::airmass, x, ZenithAngle<double>::from_degrees(chi)).mantissa))
                << "x = " << x << ", chi = " << chi;
}

// fuzz_csv (`airmass chapman --method exact`, row `1e308,45`): the quadrature's (x mu / t)² overflowed,
// giving Ch = 0 from x ≈ 1e200 and a NaN (Boost's evaluation_error, an uncaught exception in the
// fuzz target) at 1e308. Over the horizon Ch tends to 1 / cos chi, and horizontally to
// sqrt(pi x / 2) (1 + 1 / (8x) + ...).
TEST(Extremes, ChapmanExactHugeX) {
    for (double chi : {0.0, 45.0, 80.0, 89.0}) {
        const double expect = 1.0 / std::cos(chi * 3.14159265358979323846 / 180.0);
        for (double x : {1e99, 1e101, 1e160, 1e200, 1e250, 1e300, 1e308, std::numeric_limits<double>::max()}) {
            const double ch = chapman(ChapmanMethod::exact, x, ZenithAngle<double>::from_degrees(chi));
            EXPECT_NEAR(ch, expect, 1e-9 * expect) << "x = " << x << ", chi = " << chi;
        }
    }
    for (double x : {1e99, 1e101, 1e200, 1e308}) {
        const double ch = chapman_horizontal_exact(x);
        const double expect = std::sqrt(3.14159265358979323846 / 2.0) * std::sqrt(x);  // pi x overflows at 1e308
        EXPECT_NEAR(ch / expect, 1.0, 1e-9) << "x = " << x;
    }
    for (double chi : {91.0, 135.0, 180.0}) {
        const auto s = chapman_scaled(ChapmanMethod::exact, 1e308, ZenithAngle<double>::from_degrees(chi));
        EXPECT_TRUE(std::isfinite(s.mantissa) && s.mantissa > 0.0) << chi << ": " << s.mantissa;
        EXPECT_TRUE(std::isfinite(s.log_scale) && s.log_scale > 0.0) << chi << ": " << s.log_scale;
    }
}

}  // namespace
}  // namespace airmass

namespace airmass {
namespace {

// Found by fuzz_scene_toml (corpus/scene_toml/crash-tomlplusplus-parse_key-header-line-break.toml):
// a table header whose '[' is followed by a line break reached toml++ 3.3's parser::parse_key()
// against its precondition — an assert() abort with assertions on, __builtin_assume (undefined
// behaviour) in a clang release build. Now a TOML syntax error with the line, like any other.
TEST(Extremes, TomlHeaderLineBreak) {
    for (const char* text : {"preset = \"earth\"\n[\nsun]\nelevation_deg = 1.5\n", "[\n", "[[\nconstituent]]\n",
                             "[ \t\nplanet]\n", "[planet]\nradius_km = 6360\n[\n"}) {
        SCOPED_TRACE(text);
        try {
            (void)parse_scene_toml(text, "header.toml");
            ADD_FAILURE() << "accepted";
        } catch (const SceneError& e) {
            const std::string m = e.what();
            EXPECT_NE(m.find("header.toml:"), std::string::npos) << m;
            EXPECT_NE(m.find("TOML syntax error"), std::string::npos) << m;
        }
    }
}

}  // namespace
}  // namespace airmass

namespace airmass {
namespace {

// Found by fuzz_scene_toml (corpus/scene_toml/crash-tomlplusplus-non-ascii-whitespace-unreachable.toml):
// toml++ 3.3 asks is_non_ascii_horizontal_whitespace() about characters outside strings and
// comments, and that function reaches __builtin_unreachable (UB) for most code points from U+00A1
// ('µ' in a table header). TOML allows non-ASCII only in strings and comments: elsewhere it is now a
// TOML syntax error with line and column, before toml++ sees it; strings and comments keep it.
TEST(Extremes, TomlNonAsciiOutsideStrings) {
    for (const char* text : {"preset = \"earth\"\n[pla\xc2\xb5m]\n", "preset = \"earth\"\nx\xc3\xa9 = 1\n",
                             "preset = \"earth\"\n[sun]\nelevation_deg = 1\xc2\xb5\n",
                             "name = \"\"\"a \\\xc2\xb5\"\"\"\n", "name = \"\"\"a \\\n  \xc2\xb5\"\"\"\n"}) {
        SCOPED_TRACE(text);
        try {
            (void)parse_scene_toml(text, "u.toml");
            ADD_FAILURE() << "accepted";
        } catch (const SceneError& e) {
            const std::string m = e.what();
            EXPECT_NE(m.find("u.toml:"), std::string::npos) << m;
            EXPECT_NE(m.find("TOML syntax error: a non-ASCII character"), std::string::npos) << m;
        }
    }
    // In comments and strings (single-line, multi-line, literal) they stay allowed.
    const Scene s = parse_scene_toml("# \xc2\xb5 \xe2\x86\x92 \xc2\xb0\npreset = \"earth\" # \xc2\xb5\n"
                                     "name = \"\"\"sky \xc2\xb5\n\xc3\xa9\"\"\"\n",
                                     "u.toml");
    EXPECT_EQ(s.name, "sky \xc2\xb5\n\xc3\xa9");
    EXPECT_EQ(parse_scene_toml("preset = \"earth\"\nname = '\xc2\xb5 \xc3\xa9'\n", "u.toml").name, "\xc2\xb5 \xc3\xa9");
}

}  // namespace
}  // namespace airmass
