// Colour: CIE 1931 table integrals, the Δλ weighting rule, XYZ → Rec.709, Schüler's basis.
// References are independent numbers: published white points, Schüler's own worked example,
// Planck's law, and sums written out in the comments.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <numeric>
#include <vector>

#include "airmass/color.hpp"

namespace {

using airmass::SpectralBasis;
using airmass::Vec3d;

// Planck spectral radiance B_λ(T) in W m⁻² sr⁻¹ nm⁻¹ (CODATA 2018 exact constants).
double planck_w_m2_sr_nm(double wavelength_nm, double temperature_k) {
    const double h = 6.62607015e-34, c = 299792458.0, k = 1.380649e-23;
    const double l = wavelength_nm * 1e-9;
    return 2.0 * h * c * c / std::pow(l, 5) / std::expm1(h * c / (l * k * temperature_k)) * 1e-9;
}

std::vector<double> range_nm(double first, double last, double step) {
    std::vector<double> v;
    for (double l = first; l <= last + 1e-9; l += step) v.push_back(l);
    return v;
}

// Luminance of linear Rec.709 (the Y row of the RGB→XYZ matrix).
double luminance(const Vec3d& rgb) { return 0.2126729 * rgb[0] + 0.7151522 * rgb[1] + 0.0721750 * rgb[2]; }

TEST(ColorCmf, TableShapeAndPeak) {
    const auto t = airmass::cie1931_cmf_table();
    ASSERT_EQ(t.size(), 95u);  // 360..830 nm every 5 nm
    // Row 39 is 555 nm, where ȳ = 1 by definition of the photopic luminosity function.
    EXPECT_EQ(t[39].y_bar, 1.0);
    EXPECT_EQ(airmass::cie1931_cmf(555.0).y_bar, 1.0);
    // Linear interpolation: ȳ(557.5) = (1 + 0.995)/2.
    EXPECT_NEAR(airmass::cie1931_cmf(557.5).y_bar, 0.9975, 1e-12);
    // Ends are in the table, outside is dark.
    EXPECT_DOUBLE_EQ(airmass::cie1931_cmf(360.0).z_bar, 0.0006061);
    EXPECT_DOUBLE_EQ(airmass::cie1931_cmf(830.0).x_bar, 1.251141e-06);
    EXPECT_EQ(airmass::cie1931_cmf(359.9).x_bar, 0.0);
    EXPECT_EQ(airmass::cie1931_cmf(830.1).y_bar, 0.0);
    EXPECT_EQ(airmass::cie1931_cmf(std::nan("")).y_bar, 0.0);
}

TEST(ColorCmf, IntegralsAndEqualEnergyWhite) {
    // 5·Σȳ over the table = 106.857 nm (docs/research/bruneton_demo.md §4; CIE's ∫ȳ dλ ≈ 106.86).
    EXPECT_NEAR(airmass::cie1931_y_integral_nm(), 106.857, 1e-3);
    // The three functions integrate to (nearly) the same area, so the equal-energy spectrum E has
    // chromaticity x = y = 1/3.
    const auto wl = range_nm(360, 830, 5);
    const std::vector<double> flat(wl.size(), 1.0);
    const Vec3d xyz = airmass::spectrum_to_xyz(wl, flat);
    const double sum = xyz[0] + xyz[1] + xyz[2];
    EXPECT_NEAR(xyz[1], 106.857, 1e-3);  // uniform 5 nm: every Δλ is 5 nm
    EXPECT_NEAR(xyz[0] / sum, 1.0 / 3.0, 1e-3);
    EXPECT_NEAR(xyz[1] / sum, 1.0 / 3.0, 1e-3);
}

TEST(ColorWeights, MidpointCellsLikeBlender) {
    // Uniform sampling: every weight is the step (Blender: step_lambda = 20 nm for all 21 samples).
    for (double w : airmass::wavelength_weights_nm(range_nm(380, 780, 20))) EXPECT_EQ(w, 20.0);
    // Non-uniform: cells end half-way to the neighbours, end cells mirrored:
    // [400, 410, 440] → [10, (440−400)/2 = 20, 30].
    const std::vector<double> w = airmass::wavelength_weights_nm(std::vector<double>{400, 410, 440});
    ASSERT_EQ(w.size(), 3u);
    EXPECT_EQ(w[0], 10.0);
    EXPECT_EQ(w[1], 20.0);
    EXPECT_EQ(w[2], 30.0);
    // One sample: a 1-nm line.
    EXPECT_EQ(airmass::wavelength_weights_nm(std::vector<double>{550}).front(), 1.0);
    EXPECT_TRUE(airmass::wavelength_weights_nm(std::vector<double>{}).empty());
}

// Weights need strictly increasing, finite, positive wavelengths: otherwise a cell has a
// negative or zero width (a negative weight in every spectrum_to_xyz).
TEST(ColorWeights, RefuseUnorderedWavelengths) {
    const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
    for (const std::vector<double>& bad : {std::vector<double>{550, 440}, std::vector<double>{440, 550, 500},
                                           std::vector<double>{440, 440, 550}, std::vector<double>{440, nan, 680},
                                           std::vector<double>{440, 550, inf}, std::vector<double>{-10, 550},
                                           std::vector<double>{nan}, std::vector<double>{0}}) {
        try {
            (void)airmass::wavelength_weights_nm(bad);
            ADD_FAILURE() << "accepted " << bad.size() << " wavelengths starting " << bad[0];
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find("wavelengths_nm"), std::string::npos) << e.what();
        }
    }
    const std::vector<double> xs{440, nan};
    const std::vector<double> ys{1.0, 1.0};
    EXPECT_THROW((void)airmass::spectrum_to_xyz(xs, ys), std::invalid_argument);
}

TEST(ColorXyz, BlenderRuleOnItsTwentyOneSamples) {
    // Blender: xyz = 20 nm · Σ cmf(λ_i)·L(λ_i). For L = 1 the sum of ȳ at 380, 400, …, 780 nm is
    // 0.000039 + 0.000396 + 0.004 + 0.023 + 0.06 + 0.13902 + 0.323 + 0.71 + 0.954 + 0.995 + 0.87
    // + 0.631 + 0.381 + 0.175 + 0.061 + 0.017 + 0.004102 + 0.001047 + 0.0002492 + 0.00006
    // + 0.00001499 = 5.34892819, so Y = 106.9785638.
    const auto wl = range_nm(380, 780, 20);
    const Vec3d xyz = airmass::spectrum_to_xyz(wl, std::vector<double>(wl.size(), 1.0));
    EXPECT_NEAR(xyz[1], 106.9785638, 1e-9);
    EXPECT_THROW(airmass::spectrum_to_xyz(wl, std::vector<double>(3, 1.0)), std::invalid_argument);
}

TEST(ColorMatrix, D65WhiteIsRgbOne) {
    // The D65 white point (0.9505, 1, 1.089) → (1, 1, 1).
    const Vec3d rgb = airmass::xyz_to_linear_rec709({0.9505, 1.0, 1.089});
    for (double c : rgb) EXPECT_NEAR(c, 1.0, 1e-3);
    // And with the 5-digit white point (0.95047, 1, 1.08883) to 1e-4.
    for (double c : airmass::xyz_to_linear_rec709({0.95047, 1.0, 1.08883})) EXPECT_NEAR(c, 1.0, 1e-4);
}

TEST(ColorSchuler, HisSunlightExample) {
    // Seed 001: sunlight normalised to unit luminance is (0.9420, 1.0269, 1.0241) in the
    // 615/535/445 nm basis and (1.0997, 0.9771, 0.9329) in linear sRGB.
    const Vec3d rgb = airmass::multiply(airmass::kSchulerToLinearRec709, {0.9420, 1.0269, 1.0241});
    EXPECT_NEAR(rgb[0], 1.0997, 1e-3);
    EXPECT_NEAR(rgb[1], 0.9771, 1e-3);
    EXPECT_NEAR(rgb[2], 0.9329, 1e-3);
    EXPECT_NEAR(luminance(rgb), 1.0, 2e-3);
}

TEST(ColorBasis, SchulerBasisMatrixAndWavelengths) {
    SpectralBasis b;
    b.kind = SpectralBasis::Kind::rgb_schuler;  // wavelengths need not be filled in
    const auto m = airmass::spectrum_to_rgb(b);
    ASSERT_EQ(m.size(), 3u);
    EXPECT_EQ(m.wavelengths_nm, (std::vector<double>{615, 535, 445}));
    // Schüler's matrix scaled by ∫ȳdλ = 106.857 nm (so both bases share one unit).
    EXPECT_NEAR(m.matrix[0][0], 1.6218 * 106.857, 1e-2);
    EXPECT_NEAR(m.matrix[2][1], -0.1119 * 106.857, 1e-2);
}

TEST(ColorBasis, FlatSpectrumSameRgbInBothBases) {
    // E (a flat spectrum of 1) through the CIE path: XYZ = (106.8657, 106.8570, 106.8933) →
    // Rec.709 (128.750, 101.326, 97.155). Schüler's matrix rows sum to (1.2050, 0.9482, 0.9089),
    // × 106.857 = (128.763, 101.322, 97.122). They agree to 4e-4 relative: his matrix carries no
    // hidden white balance, so the two bases can be mixed.
    SpectralBasis spectral;
    spectral.kind = SpectralBasis::Kind::spectral;
    spectral.wavelengths_nm = range_nm(360, 830, 5);
    SpectralBasis schuler;
    schuler.kind = SpectralBasis::Kind::rgb_schuler;
    const Vec3d a = airmass::spectrum_to_rgb(spectral).apply(std::vector<double>(95, 1.0));
    const Vec3d b = airmass::spectrum_to_rgb(schuler).apply(std::vector<double>(3, 1.0));
    const Vec3d expected{128.750, 101.326, 97.155};
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(a[c], expected[c], 2e-3);
        EXPECT_NEAR(b[c] / a[c], 1.0, 5e-4) << "channel " << c;
    }
}

TEST(ColorBasis, BlackbodiesAgreeBetweenBases) {
    // Planck spectra near daylight colour temperatures: the 95-sample CIE path and Schüler's three
    // point samples give the same unit-luminance colour within 0.02 per channel (measured:
    // 5778 K (1.112, 0.975, 0.914) vs (1.103, 0.979, 0.908); 6504 K (1.043, 0.984, 1.036) vs
    // (1.028, 0.988, 1.038)).
    SpectralBasis spectral;
    spectral.kind = SpectralBasis::Kind::spectral;
    spectral.wavelengths_nm = range_nm(360, 830, 5);
    SpectralBasis schuler;
    schuler.kind = SpectralBasis::Kind::rgb_schuler;
    const auto ms = airmass::spectrum_to_rgb(spectral);
    const auto mr = airmass::spectrum_to_rgb(schuler);
    for (double t : {5000.0, 5778.0, 6504.0, 7000.0}) {
        std::vector<double> ls, lr;
        for (double l : ms.wavelengths_nm) ls.push_back(planck_w_m2_sr_nm(l, t));
        for (double l : mr.wavelengths_nm) lr.push_back(planck_w_m2_sr_nm(l, t));
        Vec3d a = ms.apply(ls), b = mr.apply(lr);
        const double ya = luminance(a), yb = luminance(b);
        EXPECT_NEAR(yb / ya, 1.0, 0.01) << t << " K";
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c] / ya, b[c] / yb, 0.02) << t << " K, channel " << c;
    }
    // 5778 K through the CIE path, normalised to Y = 1 (numpy reference, same table and matrix).
    std::vector<double> l5778;
    for (double l : ms.wavelengths_nm) l5778.push_back(planck_w_m2_sr_nm(l, 5778.0));
    const Vec3d a = ms.apply(l5778);
    const double y = luminance(a);
    EXPECT_NEAR(a[0] / y, 1.11193, 2e-4);
    EXPECT_NEAR(a[1] / y, 0.97539, 2e-4);
    EXPECT_NEAR(a[2] / y, 0.91400, 2e-4);
}

TEST(ColorBasis, SpectralMatrixIsCmfTimesWeights) {
    // Column i of the 3×N matrix is M_709 · cmf(λ_i) · Δλ_i; check one column by hand at 555 nm
    // in a [545, 555, 575] sampling (Δλ = (575 − 545)/2 = 15 nm): cmf(555) = (0.5120501, 1, 0.005749999).
    SpectralBasis b;
    b.wavelengths_nm = {545, 555, 575};
    const auto m = airmass::spectrum_to_rgb(b);
    const double x = 0.5120501 * 15, y = 1.0 * 15, z = 0.005749999 * 15;
    EXPECT_NEAR(m.matrix[0][1], 3.2404542 * x - 1.5371385 * y - 0.4985314 * z, 1e-9);
    EXPECT_NEAR(m.matrix[1][1], -0.9692660 * x + 1.8760108 * y + 0.0415560 * z, 1e-9);
    EXPECT_NEAR(m.matrix[2][1], 0.0556434 * x - 0.2040259 * y + 1.0572252 * z, 1e-9);
    EXPECT_THROW(m.apply(std::vector<double>(2, 1.0)), std::invalid_argument);
}

}  // namespace
