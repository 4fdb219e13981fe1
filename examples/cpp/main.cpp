// Uses an installed Airmass two ways (examples/cpp/CMakeLists.txt):
//   * the C++ library (airmass::airmass): a Chapman function value and a small sky;
//   * the C ABI (airmass::airmass_c, airmass/airmass_c.h): the same sky through the plain C calls.
// Prints `key value` lines; tests/install/check_consumer.cmake compares them to known numbers.
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "airmass/airmass_c.h"
#include "airmass/chapman.hpp"
#include "airmass/scene_io.hpp"
#include "airmass/sky.hpp"

namespace {

constexpr int kWidth = 32, kHeight = 16;
constexpr double kSunElevationDeg = 20.0;

// The mean of each RGB channel over the image (RGB or RGBA rows).
void print_means(const char* what, const float* pixels, int channels) {
    double sum[3] = {0, 0, 0};
    for (int i = 0; i < kWidth * kHeight; ++i)
        for (int c = 0; c < 3; ++c) sum[c] += pixels[i * channels + c];
    std::printf("%s_mean_rgb %.9g %.9g %.9g\n", what, sum[0] / (kWidth * kHeight), sum[1] / (kWidth * kHeight),
                sum[2] / (kWidth * kHeight));
    std::printf("%s_zenith_rgb %.9g %.9g %.9g\n", what, pixels[0], pixels[1], pixels[2]);
}

}  // namespace

int main() {
    // ---- C++: the Chapman function, exactly (quadrature) and by the airmass method -------------
    const auto grazing = airmass::ZenithAngle<double>::from_degrees(90.0);
    std::printf("chapman_exact_x500_chi90 %.15g\n", airmass::chapman(airmass::ChapmanMethod::exact, 500.0, grazing));
    std::printf("chapman_airmass_x500_chi90 %.15g\n",
                airmass::chapman(airmass::ChapmanMethod::airmass, 500.0, grazing));

    // ---- C++: a 32 x 16 sky of the built-in Earth, sun 20 degrees up ----------------------------
    airmass::Scene scene = airmass::load_preset("earth");
    scene.sun.elevation_deg = kSunElevationDeg;
    airmass::SkySettings settings;
    settings.width = kWidth;
    settings.height = kHeight;
    settings.threads = 1;
    const airmass::FloatImage sky = airmass::render_sky(scene, settings);
    print_means("cpp_sky", sky.pixels.data(), sky.channels);

    // ---- C: the same sky through the C ABI ------------------------------------------------------
    if (airmass_abi_version() != AIRMASS_C_ABI_VERSION) {
        std::fprintf(stderr, "C ABI %d, header %d\n", int(airmass_abi_version()), AIRMASS_C_ABI_VERSION);
        return 1;
    }
    std::printf("c_version %s\n", airmass_version_string());
    airmass_scene_spec spec;
    spec.struct_size = sizeof spec;
    airmass_sky_options options;
    options.struct_size = sizeof options;
    if (airmass_scene_spec_init(&spec) != AIRMASS_OK || airmass_sky_options_init(&options) != AIRMASS_OK) {
        std::fprintf(stderr, "init refused the struct sizes\n");
        return 1;
    }
    spec.preset = "earth";
    spec.sun_elevation_deg = kSunElevationDeg;
    options.width = kWidth;
    options.height = kHeight;
    options.threads = 1;
    std::vector<float> rgba(std::size_t(kWidth) * kHeight * 4);
    char message[1024];
    const int32_t status =
        airmass_render_sky(&spec, &options, rgba.data(), rgba.size(), nullptr, nullptr, message, sizeof message);
    if (status != AIRMASS_OK) {
        std::fprintf(stderr, "airmass_render_sky: %s: %s\n", airmass_status_name(status), message);
        return 1;
    }
    print_means("c_sky", rgba.data(), 4);
    return 0;
}
