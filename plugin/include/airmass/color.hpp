// Colour: from radiance sampled at a few wavelengths to linear Rec.709 RGB.
//
//   * CIE 1931 2° colour matching functions x̄, ȳ, z̄ (5-nm table, 360–830 nm);
//   * spectrum → CIE XYZ by a weighted sum over the samples, XYZ = Σ_i L(λ_i)·cmf(λ_i)·Δλ_i,
//     with no 683 lm/W factor — the rule of Blender's Nishita sky (docs/research/blender_nishita.md §5);
//   * XYZ → linear Rec.709 (sRGB primaries, D65 white);
//   * Schüler's three-wavelength basis (seed 001): radiance at 615, 535, 445 nm → linear sRGB.
//
// Both bases give RGB in the same unit: a spectral radiance of 1 W m⁻² sr⁻¹ nm⁻¹ at every
// wavelength has luminance-like Y = ∫ȳ dλ ≈ 106.857 in either basis (see spectrum_to_rgb).
#pragma once

#include <array>
#include <span>
#include <vector>

#include "airmass/scene.hpp"

namespace airmass {

using Vec3d = std::array<double, 3>;
using Mat3d = std::array<std::array<double, 3>, 3>;  // row-major: m[row][column]

// One row of the colour matching function table.
struct CmfSample {
    double x_bar, y_bar, z_bar;
};

// The CIE 1931 2° standard observer every 5 nm from 360 to 830 nm (95 rows; CVRL ciexyz31,
// as transcribed in docs/research/bruneton_demo.md §4).
inline constexpr double kCmfFirstNm = 360.0;
inline constexpr double kCmfLastNm = 830.0;
inline constexpr double kCmfStepNm = 5.0;
std::span<const CmfSample> cie1931_cmf_table();

// x̄, ȳ, z̄ at any wavelength: linear interpolation between the 5-nm rows (as Bruneton's
// model.cc does), 0 outside [360, 830] nm.
CmfSample cie1931_cmf(double wavelength_nm);

// ∫ȳ dλ over the table by the rectangle rule on its 5-nm grid: 5·Σȳ = 106.857 nm.
double cie1931_y_integral_nm();

// Quadrature weights Δλ_i (nm) for a spectrum sampled at strictly increasing wavelengths λ_i.
// Each sample stands for the cell between the midpoints to its neighbours; the end cells are
// mirrored, so Δλ_0 = λ_1 − λ_0 and Δλ_{N−1} = λ_{N−1} − λ_{N−2}:
//     Δλ_i = (λ_{i+1} − λ_{i−1}) / 2   (interior samples).
// For uniform sampling every weight equals the step, which is exactly Blender's Nishita rule
// (xyz = step_lambda · Σ cmf(λ_i)·L(λ_i), step 20 nm). A single sample gets Δλ = 1 nm (the XYZ
// of a 1-nm-wide line). Σ Δλ_i = λ_{N−1} − λ_0 + (Δλ_0 + Δλ_{N−1})/2.
// Throws std::invalid_argument naming the first wavelength that is not finite, positive and
// greater than the one before.
std::vector<double> wavelength_weights_nm(std::span<const double> wavelengths_nm);

// XYZ = Σ_i values_i · cmf(λ_i) · Δλ_i (weights above). Radiance in W m⁻² sr⁻¹ nm⁻¹ gives
// "XYZ" in W m⁻² sr⁻¹ (no 683 lm/W; divide Y by ∫ȳ dλ for a mean-radiance-like scale).
Vec3d spectrum_to_xyz(std::span<const double> wavelengths_nm, std::span<const double> values);

// CIE XYZ (D65 white) → linear Rec.709 / sRGB primaries. Cycles' default matrix
// (shader.cpp init_xyz_transforms, 7 decimals; blender_nishita.md §9), so our spectral basis
// matches Blender's Nishita sky. D65 (0.95047, 1, 1.08883) → (1, 1, 1) to 1e-4.
inline constexpr Mat3d kXyzToLinearRec709 = {{
    {3.2404542, -1.5371385, -0.4985314},
    {-0.9692660, 1.8760108, 0.0415560},
    {0.0556434, -0.2040259, 1.0572252},
}};

// Schüler's basis (seed 001, "Followup to Atmospheric Scattering – Part 1"): spectral point samples
// at 615, 535, 445 nm (in that order) → linear sRGB, derived by him from the CIE 2012 CMFs. A flat
// spectrum of 1 maps to luminance Y ≈ 1 (row sums 1.2050, 0.9482, 0.9089).
inline constexpr std::array<double, 3> kSchulerWavelengthsNm = {615.0, 535.0, 445.0};
inline constexpr Mat3d kSchulerToLinearRec709 = {{
    {1.6218, -0.4493, 0.0325},
    {-0.0374, 1.0598, -0.0742},
    {-0.0283, -0.1119, 1.0491},
}};

Vec3d multiply(const Mat3d& m, const Vec3d& v);
Vec3d xyz_to_linear_rec709(const Vec3d& xyz);

// The linear map from per-wavelength radiance to linear Rec.709 RGB for a spectral basis:
// rgb[c] = Σ_i matrix[c][i] · L(wavelengths_nm[i]).
//   spectral:    matrix = kXyzToLinearRec709 · [cmf(λ_i)·Δλ_i]  (3×N, weights as above);
//   rgb_schuler: wavelengths 615, 535, 445 nm; matrix = ∫ȳdλ · kSchulerToLinearRec709, the
//                factor 106.857 nm putting both bases in the same unit (flat spectrum → same Y).
struct SpectrumToRgb {
    std::vector<double> wavelengths_nm;
    std::array<std::vector<double>, 3> matrix;  // matrix[c][i], c = R, G, B

    std::size_t size() const { return wavelengths_nm.size(); }
    Vec3d apply(std::span<const double> radiance) const;  // radiance.size() == size()
};
SpectrumToRgb spectrum_to_rgb(const SpectralBasis& basis);

// The wavelengths a basis asks the evaluator for (spectral: its list; rgb_schuler: 615, 535, 445).
std::vector<double> basis_wavelengths_nm(const SpectralBasis& basis);

}  // namespace airmass
