// Colour matching functions, spectrum → XYZ → linear Rec.709, Schüler's basis (see color.hpp).
#include "airmass/color.hpp"
#include "support/message_format.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace airmass {

namespace {

// CIE 1931 2° colour matching functions x̄, ȳ, z̄, 360–830 nm every 5 nm (CVRL ciexyz31;
// transcribed in docs/research/bruneton_demo.md §4, which checked it against Blender's cmf_xyz).
constexpr CmfSample kCie1931[] = {
    {0.0001299, 0.000003917, 0.0006061},   // 360
    {0.0002321, 0.000006965, 0.001086},    // 365
    {0.0004149, 0.00001239, 0.001946},     // 370
    {0.0007416, 0.00002202, 0.003486},     // 375
    {0.001368, 0.000039, 0.006450001},     // 380
    {0.002236, 0.000064, 0.01054999},      // 385
    {0.004243, 0.00012, 0.02005001},       // 390
    {0.00765, 0.000217, 0.03621},          // 395
    {0.01431, 0.000396, 0.06785001},       // 400
    {0.02319, 0.00064, 0.1102},            // 405
    {0.04351, 0.00121, 0.2074},            // 410
    {0.07763, 0.00218, 0.3713},            // 415
    {0.13438, 0.004, 0.6456},              // 420
    {0.21477, 0.0073, 1.0390501},          // 425
    {0.2839, 0.0116, 1.3856},              // 430
    {0.3285, 0.01684, 1.62296},            // 435
    {0.34828, 0.023, 1.74706},             // 440
    {0.34806, 0.0298, 1.7826},             // 445
    {0.3362, 0.038, 1.77211},              // 450
    {0.3187, 0.048, 1.7441},               // 455
    {0.2908, 0.06, 1.6692},                // 460
    {0.2511, 0.0739, 1.5281},              // 465
    {0.19536, 0.09098, 1.28764},           // 470
    {0.1421, 0.1126, 1.0419},              // 475
    {0.09564, 0.13902, 0.8129501},         // 480
    {0.05795001, 0.1693, 0.6162},          // 485
    {0.03201, 0.20802, 0.46518},           // 490
    {0.0147, 0.2586, 0.3533},              // 495
    {0.0049, 0.323, 0.272},                // 500
    {0.0024, 0.4073, 0.2123},              // 505
    {0.0093, 0.503, 0.1582},               // 510
    {0.0291, 0.6082, 0.1117},              // 515
    {0.06327, 0.71, 0.07824999},           // 520
    {0.1096, 0.7932, 0.05725001},          // 525
    {0.1655, 0.862, 0.04216},              // 530
    {0.2257499, 0.9148501, 0.02984},       // 535
    {0.2904, 0.954, 0.0203},               // 540
    {0.3597, 0.9803, 0.0134},              // 545
    {0.4334499, 0.9949501, 0.008749999},   // 550
    {0.5120501, 1.0, 0.005749999},         // 555
    {0.5945, 0.995, 0.0039},               // 560
    {0.6784, 0.9786, 0.002749999},         // 565
    {0.7621, 0.952, 0.0021},               // 570
    {0.8425, 0.9154, 0.0018},              // 575
    {0.9163, 0.87, 0.001650001},           // 580
    {0.9786, 0.8163, 0.0014},              // 585
    {1.0263, 0.757, 0.0011},               // 590
    {1.0567, 0.6949, 0.001},               // 595
    {1.0622, 0.631, 0.0008},               // 600
    {1.0456, 0.5668, 0.0006},              // 605
    {1.0026, 0.503, 0.00034},              // 610
    {0.9384, 0.4412, 0.00024},             // 615
    {0.8544499, 0.381, 0.00019},           // 620
    {0.7514, 0.321, 0.0001},               // 625
    {0.6424, 0.265, 0.00004999999},        // 630
    {0.5419, 0.217, 0.00003},              // 635
    {0.4479, 0.175, 0.00002},              // 640
    {0.3608, 0.1382, 0.00001},             // 645
    {0.2835, 0.107, 0.0},                  // 650
    {0.2187, 0.0816, 0.0},                 // 655
    {0.1649, 0.061, 0.0},                  // 660
    {0.1212, 0.04458, 0.0},                // 665
    {0.0874, 0.032, 0.0},                  // 670
    {0.0636, 0.0232, 0.0},                 // 675
    {0.04677, 0.017, 0.0},                 // 680
    {0.0329, 0.01192, 0.0},                // 685
    {0.0227, 0.00821, 0.0},                // 690
    {0.01584, 0.005723, 0.0},              // 695
    {0.01135916, 0.004102, 0.0},           // 700
    {0.008110916, 0.002929, 0.0},          // 705
    {0.005790346, 0.002091, 0.0},          // 710
    {0.004109457, 0.001484, 0.0},          // 715
    {0.002899327, 0.001047, 0.0},          // 720
    {0.00204919, 0.00074, 0.0},            // 725
    {0.001439971, 0.00052, 0.0},           // 730
    {0.0009999493, 0.0003611, 0.0},        // 735
    {0.0006900786, 0.0002492, 0.0},        // 740
    {0.0004760213, 0.0001719, 0.0},        // 745
    {0.0003323011, 0.00012, 0.0},          // 750
    {0.0002348261, 0.0000848, 0.0},        // 755
    {0.0001661505, 0.00006, 0.0},          // 760
    {0.000117413, 0.0000424, 0.0},         // 765
    {0.00008307527, 0.00003, 0.0},         // 770
    {0.00005870652, 0.0000212, 0.0},       // 775
    {0.00004150994, 0.00001499, 0.0},      // 780
    {0.00002935326, 0.0000106, 0.0},       // 785
    {0.00002067383, 0.0000074657, 0.0},    // 790
    {0.00001455977, 0.0000052578, 0.0},    // 795
    {0.00001025398, 0.0000037029, 0.0},    // 800
    {0.000007221456, 0.0000026078, 0.0},   // 805
    {0.000005085868, 0.0000018366, 0.0},   // 810
    {0.000003581652, 0.0000012934, 0.0},   // 815
    {0.000002522525, 0.00000091093, 0.0},  // 820
    {0.000001776509, 0.00000064153, 0.0},  // 825
    {0.000001251141, 0.00000045181, 0.0},  // 830
};
constexpr std::size_t kCmfRows = sizeof(kCie1931) / sizeof(kCie1931[0]);
static_assert(kCmfRows == 95, "CIE table: 360..830 nm every 5 nm");

}  // namespace

std::span<const CmfSample> cie1931_cmf_table() { return {kCie1931, kCmfRows}; }

CmfSample cie1931_cmf(double wavelength_nm) {
    // Outside the table (and for NaN) the observer does not respond.
    if (!(wavelength_nm >= kCmfFirstNm && wavelength_nm <= kCmfLastNm)) return {0.0, 0.0, 0.0};
    const double u = (wavelength_nm - kCmfFirstNm) / kCmfStepNm;
    const auto row = std::min(static_cast<std::size_t>(u), kCmfRows - 2);
    const double f = u - static_cast<double>(row);
    const CmfSample& a = kCie1931[row];
    const CmfSample& b = kCie1931[row + 1];
    return {a.x_bar + f * (b.x_bar - a.x_bar), a.y_bar + f * (b.y_bar - a.y_bar), a.z_bar + f * (b.z_bar - a.z_bar)};
}

double cie1931_y_integral_nm() {
    double sum = 0.0;
    for (const CmfSample& s : kCie1931) sum += s.y_bar;
    return kCmfStepNm * sum;
}

std::vector<double> wavelength_weights_nm(std::span<const double> wavelengths_nm) {
    const std::size_t n = wavelengths_nm.size();
    for (std::size_t i = 0; i < n; ++i) {
        const double l = wavelengths_nm[i];
        if (!(l > 0.0 && l < std::numeric_limits<double>::infinity()) || (i > 0 && !(l > wavelengths_nm[i - 1])))
            throw std::invalid_argument("wavelength_weights_nm: wavelengths_nm[" + std::to_string(i) + "] = " +
                                        detail::message_number(l) +
                                        ": the wavelengths must be finite, positive and strictly increasing");
    }
    std::vector<double> w(n, 1.0);
    if (n < 2) return w;  // one sample: a 1-nm line (see color.hpp)
    for (std::size_t i = 0; i < n; ++i) {
        // Cell edges at the midpoints to the neighbours; the end cells mirrored about their sample.
        const double left = i == 0 ? wavelengths_nm[1] - wavelengths_nm[0] : wavelengths_nm[i] - wavelengths_nm[i - 1];
        const double right =
            i + 1 == n ? wavelengths_nm[n - 1] - wavelengths_nm[n - 2] : wavelengths_nm[i + 1] - wavelengths_nm[i];
        w[i] = 0.5 * (left + right);
    }
    return w;
}

Vec3d spectrum_to_xyz(std::span<const double> wavelengths_nm, std::span<const double> values) {
    if (wavelengths_nm.size() != values.size())
        throw std::invalid_argument("spectrum_to_xyz: wavelengths and values differ in length");
    const std::vector<double> w = wavelength_weights_nm(wavelengths_nm);
    Vec3d xyz{0.0, 0.0, 0.0};
    for (std::size_t i = 0; i < values.size(); ++i) {
        const CmfSample c = cie1931_cmf(wavelengths_nm[i]);
        xyz[0] += values[i] * c.x_bar * w[i];
        xyz[1] += values[i] * c.y_bar * w[i];
        xyz[2] += values[i] * c.z_bar * w[i];
    }
    return xyz;
}

Vec3d multiply(const Mat3d& m, const Vec3d& v) {
    return {m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2], m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
            m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2]};
}

Vec3d xyz_to_linear_rec709(const Vec3d& xyz) { return multiply(kXyzToLinearRec709, xyz); }

std::vector<double> basis_wavelengths_nm(const SpectralBasis& basis) {
    if (basis.kind == SpectralBasis::Kind::rgb_schuler)
        return {kSchulerWavelengthsNm.begin(), kSchulerWavelengthsNm.end()};
    return basis.wavelengths_nm;
}

SpectrumToRgb spectrum_to_rgb(const SpectralBasis& basis) {
    SpectrumToRgb out;
    out.wavelengths_nm = basis_wavelengths_nm(basis);
    const std::size_t n = out.wavelengths_nm.size();
    for (auto& row : out.matrix) row.assign(n, 0.0);
    if (basis.kind == SpectralBasis::Kind::rgb_schuler) {
        // Schüler's matrix maps a flat unit spectrum to Y ≈ 1; the spectral path maps it to ∫ȳdλ.
        const double scale = cie1931_y_integral_nm();
        for (std::size_t c = 0; c < 3; ++c)
            for (std::size_t i = 0; i < 3; ++i) out.matrix[c][i] = scale * kSchulerToLinearRec709[c][i];
        return out;
    }
    const std::vector<double> w = wavelength_weights_nm(out.wavelengths_nm);
    for (std::size_t i = 0; i < n; ++i) {
        const CmfSample cmf = cie1931_cmf(out.wavelengths_nm[i]);
        const Vec3d xyz{cmf.x_bar * w[i], cmf.y_bar * w[i], cmf.z_bar * w[i]};
        const Vec3d rgb = xyz_to_linear_rec709(xyz);
        for (std::size_t c = 0; c < 3; ++c) out.matrix[c][i] = rgb[c];
    }
    return out;
}

Vec3d SpectrumToRgb::apply(std::span<const double> radiance) const {
    if (radiance.size() != wavelengths_nm.size())
        throw std::invalid_argument("SpectrumToRgb::apply: radiance has the wrong number of wavelengths");
    Vec3d rgb{0.0, 0.0, 0.0};
    for (std::size_t c = 0; c < 3; ++c)
        for (std::size_t i = 0; i < radiance.size(); ++i) rgb[c] += matrix[c][i] * radiance[i];
    return rgb;
}

}  // namespace airmass
