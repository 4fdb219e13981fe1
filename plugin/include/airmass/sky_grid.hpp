// A sun-aligned grid of view directions for one observer: the mapping behind the sky image's
// grid (SkySettings::grid) and the multiple-scattering view (evaluator.hpp MsView).
//
// Rows: two pieces of zenith angle meeting at the horizon — the sky above it, the ground
// below — node 0 of each next to the horizon; the fraction f ∈ [0, 1] of a piece's span away
// from the horizon is f = x (x + c)/(1 + c) at node x = i/(n − 1), i.e. rows 5× denser at the
// horizon than at the far end (c = 0.25). Nothing is interpolated across the horizon.
// Columns: azimuth from the sun ψ ∈ [0, π] in `intervals` equal steps (the sky of a
// spherically symmetric atmosphere is mirror-symmetric about the vertical plane through the
// sun). Each node holds `channels` values (RGB for the image, one per wavelength for the
// multiple-scattering view).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <numbers>
#include <span>
#include <vector>

#include "airmass/geometry.hpp"

namespace airmass {

// Zenith angles that split the sphere for an observer at altitude h: rays with
// θ < theta_space miss the atmosphere (0 inside it), rays with θ > theta_horizon hit the
// ground. Written without subtracting radii: acos(R/r0) = atan2(sqrt(h(2R + h)), R).
struct Horizon {
    double theta_space = 0.0;
    double theta_horizon = std::numbers::pi / 2;

    static Horizon of(double planet_radius_m, double top_altitude_m, double altitude_m) {
        const double R = planet_radius_m, top = top_altitude_m, h = altitude_m;
        Horizon hz;
        hz.theta_horizon = std::numbers::pi / 2 + std::atan2(std::sqrt(h * (2 * R + h)), R);
        if (h > top) hz.theta_space = std::numbers::pi / 2 + std::atan2(std::sqrt((h - top) * (2 * R + top + h)), R + top);
        return hz;
    }
};

struct SkyGrid {
    static constexpr double kC = 0.25;
    // Nodes next to the horizon sit this far inside their piece so that the evaluator sees
    // an unambiguous sky or ground ray (the radiance is continuous up to the edge).
    static constexpr double kEdge = 1e-7;
    int intervals = 0;  // ψ intervals (G)
    int rows_sky = 0, rows_ground = 0;
    int channels = 0;
    Horizon hz;
    double sun_phi = 0.0;        // azimuth of the sun, atan2(s.y, s.x)
    std::vector<double> values;  // (rows_sky + rows_ground) × (G + 1) × channels

    // A grid of G azimuth intervals and G/2 + 1 rows per piece (no ground rows when `sky_only`
    // and the horizon is at or below 90°, i.e. an upper-hemisphere image of a ground observer).
    static SkyGrid make(int G, const Horizon& hz, Vec3<double> sun, int channels, bool sky_only) {
        SkyGrid g;
        g.intervals = G;
        g.hz = hz;
        g.channels = channels;
        g.sun_phi = std::atan2(sun.y, sun.x);
        g.rows_sky = std::max(G / 2, 2) + 1;
        g.rows_ground = sky_only && hz.theta_horizon >= std::numbers::pi / 2 ? 0 : std::max(G / 2, 2) + 1;
        g.values.assign(std::size_t(g.rows()) * g.columns() * channels, 0.0);
        return g;
    }

    int rows() const { return rows_sky + rows_ground; }
    int columns() const { return intervals + 1; }

    static double f_of_x(double x) { return x * (x + kC) / (1.0 + kC); }
    static double x_of_f(double f) { return 0.5 * (-kC + std::sqrt(kC * kC + 4.0 * (1.0 + kC) * f)); }

    double sky_span() const { return hz.theta_horizon - hz.theta_space; }
    double ground_span() const { return std::numbers::pi - hz.theta_horizon; }
    // Zenith angle of grid row k (sky rows first).
    double row_theta(int k) const {
        if (k < rows_sky) {
            const double f = f_of_x(double(k) / (rows_sky - 1));
            return std::max(hz.theta_horizon - f * sky_span(), 0.0) - (k == 0 ? kEdge : 0.0);
        }
        const double f = f_of_x(double(k - rows_sky) / (rows_ground - 1));
        return std::min(hz.theta_horizon + f * ground_span(), std::numbers::pi) + (k == rows_sky ? kEdge : 0.0);
    }
    // Continuous grid row of a zenith angle; −1 for directions that miss the atmosphere.
    double row_of(double theta) const {
        if (theta <= hz.theta_horizon) {
            if (theta < hz.theta_space || sky_span() <= 0.0) return -1.0;
            return x_of_f(std::clamp((hz.theta_horizon - theta) / sky_span(), 0.0, 1.0)) * (rows_sky - 1);
        }
        if (rows_ground == 0) return -1.0;
        return rows_sky +
               x_of_f(std::clamp((theta - hz.theta_horizon) / ground_span(), 0.0, 1.0)) * (rows_ground - 1);
    }
    // The unit direction of node (row k, column j).
    Vec3<double> node_direction(int k, int j) const {
        const double theta = row_theta(k), phi = sun_phi + std::numbers::pi * j / intervals;
        const double st = std::sin(theta);
        return {st * std::cos(phi), st * std::sin(phi), std::cos(theta)};
    }
    double* at(int row, int col) { return values.data() + (std::size_t(row) * columns() + col) * channels; }
    const double* at(int row, int col) const {
        return values.data() + (std::size_t(row) * columns() + col) * channels;
    }

    // Bilinear weights of a direction given by its zenith angle θ and azimuth φ: false for a
    // direction that misses the atmosphere (nothing to interpolate).
    struct Cell {
        int r0, r1, c0;
        double wr, wc;
    };
    bool cell(double theta, double phi, Cell& c) const {
        const double fr = row_of(theta);
        if (fr < 0.0) return false;
        c.r0 = std::min(static_cast<int>(fr), rows() - 2);
        // never interpolate across the horizon: clamp to the piece's last row
        const int piece_end = c.r0 < rows_sky ? rows_sky - 1 : rows() - 1;
        c.r1 = std::min(c.r0 + 1, piece_end);
        c.wr = c.r1 > c.r0 ? fr - c.r0 : 0.0;
        column(phi, c.c0, c.wc);
        return true;
    }
    // The column part of cell(): it depends on the azimuth only (an image row shares its
    // row part, an image column its column part).
    void column(double phi, int& c0, double& wc) const {
        const double psi = std::abs(std::remainder(phi - sun_phi, 2.0 * std::numbers::pi));
        const double fc = std::min(psi / std::numbers::pi, 1.0) * intervals;
        c0 = std::min(static_cast<int>(fc), intervals - 1);
        wc = fc - c0;
    }
    // The interpolated values of a cell (out.size() == channels).
    void interpolate(const Cell& c, std::span<double> out) const {
        const double *a = at(c.r0, c.c0), *b = at(c.r0, c.c0 + 1), *d = at(c.r1, c.c0), *e = at(c.r1, c.c0 + 1);
        for (int ch = 0; ch < channels; ++ch)
            out[ch] = (1 - c.wr) * ((1 - c.wc) * a[ch] + c.wc * b[ch]) + c.wr * ((1 - c.wc) * d[ch] + c.wc * e[ch]);
    }
};

}  // namespace airmass
