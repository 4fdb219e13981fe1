// A sun-aligned grid of view directions for one observer: the mapping behind the sky image's
// grid (SkySettings::grid) and the multiple-scattering view (evaluator.hpp MsView).
//
// Rows: pieces of zenith angle, none interpolated across another — the sky above the horizon
// and the ground below it, node 0 of each next to the horizon; the fraction f ∈ [0, 1] of a
// piece's span away from the horizon is f = x (x + c)/(1 + c) at node x = i/(n − 1): the row
// spacing next to the horizon is c/(1 + c) of an even one's (SkyGridLayout::row_concentration
// c: 0.2 of it for c = 0.25, 0.038 for c = 0.04). Seen from above a layer — an observer above
// a profile's knot or above the atmosphere — the sky is split further at the zenith angles of
// the rays tangent to the knots' spheres (Horizon::kinks), and each piece whose far end is
// such a kink or the limb of the top is crowded at both ends (half the piece each way). An
// observer whose horizon dips at least 0.25° below the horizontal has the sky split at the
// horizontal too (Horizon::kinks: the ray tangent to the observer's own sphere).
// Columns: azimuth from the sun ψ ∈ [0, π] in `intervals` steps (the sky of a spherically
// symmetric atmosphere is mirror-symmetric about the vertical plane through the sun), equal
// or, with a column concentration c' > 0, ψ/π = x (|x| + c')/(1 + c') at x = j/G: the
// spacing at the sun c'/(1 + c') of an even one's (odd in x, so the mirror at ψ = 0 stays
// exact). Each node holds `channels`
// values (RGB parts for the image, one per wavelength for the multiple-scattering view).
//
// The two layouts (SkyGridLayout): the multiple-scattering view's (M intervals, M/2 + 1 rows
// per piece, c = 0.04 above the horizon and 0.01 below it, equal columns), and the sky image's
// (G intervals, G + 1 rows per piece, c = 0.04, c' = 1). The view's ground rows crowd at the
// horizon because, seen from above the ground at twilight, the radiance of the ground rays
// changes fastest just below the Earth's limb (earth, 10 km, sun −4°, 256 × 128 against every
// ray: max 34 % with c = 0.25 there, 6.1 % with 0.04, 1.3 % with 0.01; the sky rows and the
// other conditions of docs/sky.md's view table no worse). Its sky rows crowd there too: the
// worst pixel of every image was in the first row above the horizon (blender-nishita 512 × 256,
// sun 60° / 15° / 2° / −4°: max 0.72 / 1.04 / 2.35 / 3.10 % with c = 0.25, 0.14 / 0.31 / 0.71 /
// 1.21 % with 0.04, p95 lower too; docs/sky.md "Sky rows for every observer"). Columns crowded
// toward the sun (c' = 0.5 or 1) move the worst pixel to the side opposite it, no better.
// The kinks: `earth` 1024 × 512 from 50 km, sun 10°, against every pixel, the image grid's
// worst pixel was 51 % off (the ozone tent's top, 40 km, seen edge-on), 3.5 % split there;
// from 400 km 19 % at the limb, 6.9 % (docs/sky.md). The horizontal: `earth` 1024 × 512 from
// 20 km, sun −4°, 12.6 % → 6.8 % (a band of rows next to it, the light of rays that skim the
// observer's layer for hundreds of kilometres through sunlight grazing the ground); from
// 300 m, sun 10°, 0.63 → 0.18 %. An image of the sky only (an upper hemisphere) is not split:
// its one piece ends at the horizontal when that is a kink (crowded toward it), else at the
// horizon. The image holds its single scattering over each column's phase function
// (sky.cpp), so what it interpolates has no aureole; what is left sharp is the zenith angle
// next to the horizon — hence its rows: twice as many, their spacing there 0.038 of an even
// one's (docs/sky.md measures both). Where neither rows nor columns follow the light (a
// shadow's edge across the limb seen from orbit), rough_cells finds the cells and the image
// evaluates their pixels (sky.cpp).
//
// Interpolation is Catmull–Rom (cubic, C¹) in both grid coordinates: columns mirror at ψ = 0
// and π (the sky's own symmetry: exact at ψ = 0; at π exact for even columns and, with a
// column concentration, right in value and slope with a third-order ghost node), rows stay inside their piece
// with the node missing beyond a piece's end extrapolated linearly (v₋₁ = 2v₀ − v₁). Against
// bilinear it takes the grid's p95 error down 5–7× at the same grid (docs/sky.md); a cubic may
// overshoot below 0 next to a sharp feature, so callers clamp what must not be negative.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numbers>
#include <span>
#include <vector>

#include "airmass/geometry.hpp"

namespace airmass {

// Zenith angles that split the sphere for an observer at altitude h: rays with
// θ < theta_space miss the atmosphere (0 inside it), rays with θ > theta_horizon hit the
// ground. Written without subtracting radii: acos(R/r0) = atan2(sqrt(h(2R + h)), R).
//
// kinks: the zenith angles of the descending rays tangent to the spheres of the profiles'
// knots (profile_knots_m) below the observer, θ = π − asin((R + a)/(R + h)) for 0 < a < h and
// a < top. Along such rays the light is not smooth in θ: the path below a knot's sphere grows
// as the square root of the ray's dip below it (the optical depth has a kink: a √ for a jump
// of the density, as at the top; a power 3/2 for a jump of its slope, as at the ozone tent's
// knots), so a sky seen from above a layer has its sharpest gradients there (SkyGrid splits
// its rows at them). The horizontal (θ = π/2, the ray tangent to the observer's own sphere) is
// one too, for an observer inside the atmosphere whose horizon dips at least kMinHorizontalDip
// below it: no density jumps there, but a ray just below it skims the observer's layer for
// hundreds of kilometres and one just above leaves it, so the light changes over a fraction
// of a degree (from 20 km at twilight, by a quarter within 0.7°) where the rows, crowded at
// the horizon 4.5° lower, are a degree apart. Ascending, each at least 1e-6 rad from the next
// and from the sky's ends; none for an observer on the ground.
struct Horizon {
    // 0.25° (≈ 60 m up on Earth): lower, the horizontal lies among the horizon's crowded rows
    // and the split buys little for its cost, a quarter more rays (from 10 m nothing
    // measurable; from 50 m p95 unchanged, the worst pixel at sun 10° 0.48 → 0.26 %; from
    // 300 m 0.63 → 0.18 %; docs/sky.md "The horizontal").
    static constexpr double kMinHorizontalDip = 0.25 * std::numbers::pi / 180.0;

    double theta_space = 0.0;
    double theta_horizon = std::numbers::pi / 2;
    std::vector<double> kinks;

    static Horizon of(double planet_radius_m, double top_altitude_m, double altitude_m,
                      std::span<const double> knots_m = {}) {
        const double R = planet_radius_m, top = top_altitude_m, h = altitude_m;
        Horizon hz;
        hz.theta_horizon = std::numbers::pi / 2 + std::atan2(std::sqrt(h * (2 * R + h)), R);
        if (h > top) hz.theta_space = std::numbers::pi / 2 + std::atan2(std::sqrt((h - top) * (2 * R + top + h)), R + top);
        constexpr double kMinGap = 1e-6;
        std::vector<double> theta;
        for (const double a : knots_m)
            if (a > 0.0 && a < h && a < top) theta.push_back(std::numbers::pi - std::asin(std::min((R + a) / (R + h), 1.0)));
        if (h <= top && hz.theta_horizon - std::numbers::pi / 2 >= kMinHorizontalDip) theta.push_back(std::numbers::pi / 2);
        std::sort(theta.begin(), theta.end());
        for (const double t : theta)
            if (t >= std::numbers::pi / 2 && t > hz.theta_space + kMinGap && t < hz.theta_horizon - kMinGap &&
                (hz.kinks.empty() || t > hz.kinks.back() + kMinGap))
                hz.kinks.push_back(t);
        return hz;
    }
};

// The shape of a grid: G azimuth intervals, the rows per piece, and where they concentrate.
struct SkyGridLayout {
    int intervals = 0;
    int rows_per_piece = 0;
    double row_concentration = 0.25;    // c: the row spacing at the horizon is c/(1 + c) of an even one's
    double column_concentration = 0.0;  // c': the column spacing at the sun c'/(1 + c') of it; 0: even
    double ground_row_concentration = 0.25;  // c of the ground piece's rows (below the horizon)

    // The multiple-scattering view of M intervals (evaluator.hpp MsView).
    static SkyGridLayout view(int M) { return {M, std::max(M / 2, 2) + 1, 0.04, 0.0, 0.01}; }
    // The sky image's grid of G intervals (sky.hpp SkySettings::grid).
    static SkyGridLayout image(int G) { return {G, G + 1, 0.04, 1.0, 0.04}; }
    // The sky's piece edges from the horizon up: θ_h, the horizon's kinks descending (none for
    // an image of the sky only, which reads no row below the horizontal), then the zenith or
    // the limb (θ_space).
    static std::vector<double> sky_edges(const Horizon& hz, bool sky_only) {
        if (sky_only) {  // one piece, down to the horizontal where that is a kink, else the horizon
            const bool horizontal = !hz.kinks.empty() && hz.kinks.front() == std::numbers::pi / 2;
            return {horizontal ? std::numbers::pi / 2 : hz.theta_horizon, hz.theta_space};
        }
        std::vector<double> edges{hz.theta_horizon};
        if (!sky_only) edges.insert(edges.end(), hz.kinks.rbegin(), hz.kinks.rend());
        edges.push_back(hz.theta_space);
        return edges;
    }
    // Rows of a sky piece: the top one (reaching the zenith or the limb) the layout's, each
    // below a kink half as many plus one.
    int piece_rows(bool top_piece) const {
        const int rows = std::max(rows_per_piece, 2);
        return top_piece ? rows : std::max(rows / 2 + 1, 4);
    }
    // Rows below the horizon: none for an image of the sky only when the horizon is at or
    // below 90° (an upper hemisphere).
    int ground_rows(const Horizon& hz, bool sky_only) const {
        return sky_only && hz.theta_horizon >= std::numbers::pi / 2 ? 0 : std::max(rows_per_piece, 2);
    }
    // Its rows for an observer (SkyGrid::make's grid: every piece's, sky and ground).
    int rows(const Horizon& hz, bool sky_only) const {
        const std::size_t pieces = sky_edges(hz, sky_only).size() - 1;
        return piece_rows(true) + int(pieces - 1) * piece_rows(false) + ground_rows(hz, sky_only);
    }
    // Its rays for an observer: columns × rows.
    double rays(const Horizon& hz, bool sky_only) const { return double(intervals + 1) * double(rows(hz, sky_only)); }
};

struct SkyGrid {
    // Nodes next to the horizon — and, for an observer above the atmosphere, at its limb
    // (θ = theta_space, a ray tangent to the top) — sit this far inside their piece so that
    // the evaluator sees an unambiguous sky or ground ray, or one that meets the atmosphere
    // (the radiance is continuous up to the edge; exactly on the limb, rounding decided
    // whether a ray met the shell, and a whole row of the multiple-scattering view, which
    // shares one quadrature, could come out zero).
    static constexpr double kEdge = 1e-7;
    // A piece of rows: `rows` nodes from θ `near` (its horizon end, its first row) to `far`,
    // the fraction of the way f = f_of_x(x, c) at x = i/(rows − 1) — or, `both_ends`, crowded
    // at both ends (half the piece each way, C¹ in the middle).
    struct Piece {
        int first = 0, rows = 0;
        double near = 0.0, far = 0.0;
        double c = 0.25;
        bool both_ends = false;
        double theta(double x) const {
            const double f = both_ends ? (x <= 0.5 ? 0.5 * f_of_x(2.0 * x, c) : 1.0 - 0.5 * f_of_x(2.0 - 2.0 * x, c))
                                       : f_of_x(x, c);
            return near + f * (far - near);
        }
        // The continuous row (first + x (rows − 1)) of a θ inside the piece.
        double row(double theta) const {
            const double f = std::clamp((theta - near) / (far - near), 0.0, 1.0);
            const double x = both_ends ? (f <= 0.5 ? 0.5 * x_of_f(2.0 * f, c) : 1.0 - 0.5 * x_of_f(2.0 - 2.0 * f, c))
                                       : x_of_f(f, c);
            return first + x * (rows - 1);
        }
        int last() const { return first + rows - 1; }
    };

    int intervals = 0;  // ψ intervals (G)
    int rows_sky = 0, rows_ground = 0;
    int channels = 0;
    double column_c = 0.0;  // SkyGridLayout::column_concentration
    Horizon hz;
    // The sky's pieces from the horizon up (one, or split at tangent kinks), then the ground's
    // (none when the grid has no ground rows).
    std::vector<Piece> pieces;
    double sun_phi = 0.0;        // azimuth of the sun, atan2(s.y, s.x)
    std::vector<double> values;  // (rows_sky + rows_ground) × (G + 1) × channels
    std::vector<double> log_values;        // ln values (take_logs), or empty: blend_row blends the values only
    std::vector<unsigned char> log_cells;  // per row cell and column-channel: blended in the logarithm (take_logs)

    // A grid of the layout's intervals and rows per piece (no ground rows when `sky_only` and
    // the horizon is at or below 90°, i.e. an upper-hemisphere image of a ground observer).
    // The horizon's kinks split the sky (SkyGridLayout::sky_edges, piece_rows: the piece above
    // the highest kink keeps the layout's rows, each below it half as many plus one; an image
    // of the sky only is not split, as it reads no row below the horizontal). A piece whose far end is a kink —
    // or the limb of the top, for an observer above the atmosphere — is crowded at both ends,
    // the piece that reaches the zenith at its near end only, as the sky of an observer below
    // every knot (one piece) and the ground always are.
    static SkyGrid make(const SkyGridLayout& layout, const Horizon& hz, Vec3<double> sun, int channels, bool sky_only) {
        SkyGrid g;
        g.column_c = layout.column_concentration;
        g.intervals = layout.intervals;
        g.hz = hz;
        g.channels = channels;
        g.sun_phi = std::atan2(sun.y, sun.x);
        const std::vector<double> edges = SkyGridLayout::sky_edges(hz, sky_only);
        const bool split = edges.size() > 2 || hz.theta_space > 0.0;
        int first = 0;
        for (std::size_t p = 0; p + 1 < edges.size(); ++p) {
            const bool top_piece = p + 2 == edges.size();
            const int n = layout.piece_rows(top_piece);
            // crowded at the far end too where that is a kink or the limb (not the zenith)
            const bool both_ends = split && !(top_piece && hz.theta_space == 0.0);
            g.pieces.push_back({first, n, edges[p], edges[p + 1], layout.row_concentration, both_ends});
            first += n;
        }
        g.rows_sky = first;
        g.rows_ground = layout.ground_rows(hz, sky_only);
        if (g.rows_ground > 0)
            g.pieces.push_back({first, g.rows_ground, hz.theta_horizon, std::numbers::pi,
                                layout.ground_row_concentration, false});
        g.values.assign(std::size_t(g.rows()) * g.columns() * channels, 0.0);
        return g;
    }

    int rows() const { return rows_sky + rows_ground; }
    int columns() const { return intervals + 1; }
    // The piece that holds row k.
    const Piece& piece_of_row(int k) const {
        for (const Piece& p : pieces)
            if (k <= p.last()) return p;
        return pieces.back();
    }

    static double f_of_x(double x, double c) { return x * (x + c) / (1.0 + c); }
    static double x_of_f(double f, double c) { return 0.5 * (-c + std::sqrt(c * c + 4.0 * (1.0 + c) * f)); }

    // ψ/π of grid column coordinate x = j/G, and its inverse: odd in x (ψ(−x) = −ψ(x)), so the
    // mirror at ψ = 0 is exact in grid coordinates.
    double psi_fraction(double x) const {
        return column_c > 0.0 ? x * (std::abs(x) + column_c) / (1.0 + column_c) : x;
    }
    double column_of_fraction(double f) const {
        return column_c > 0.0 ? 0.5 * (-column_c + std::sqrt(column_c * column_c + 4.0 * (1.0 + column_c) * f)) : f;
    }
    double sky_span() const { return hz.theta_horizon - hz.theta_space; }
    // Zenith angle of grid row k (sky rows first).
    double row_theta(int k) const {
        const double theta = row_theta_raw(k);
        // kEdge, or a quarter of the row's spacing where a piece is so narrow (far from the
        // planet, a knot just below the observer) that kEdge would pass the next row
        const auto edge = [&](int next) { return std::min(kEdge, 0.25 * std::abs(row_theta_raw(next) - theta)); };
        if (k < rows_sky)
            return theta - (k == 0 ? edge(1) : 0.0) + (k == rows_sky - 1 && hz.theta_space > 0.0 ? edge(k - 1) : 0.0);
        return theta + (k == rows_sky ? edge(k + 1) : 0.0);
    }
    double row_theta_raw(int k) const {
        const Piece& p = piece_of_row(k);
        return std::clamp(p.theta(double(k - p.first) / (p.rows - 1)), 0.0, std::numbers::pi);
    }
    // Continuous grid row of a zenith angle; −1 for directions that miss the atmosphere.
    double row_of(double theta) const {
        if (theta <= hz.theta_horizon) {
            if (theta < hz.theta_space || sky_span() <= 0.0) return -1.0;
            // the sky's pieces from the horizon up: the first that reaches down to θ
            for (const Piece& p : pieces)
                if (theta >= p.far || p.last() == rows_sky - 1) return p.row(theta);
        }
        if (rows_ground == 0) return -1.0;
        return pieces.back().row(theta);
    }
    // The unit direction of node (row k, column j).
    Vec3<double> node_direction(int k, int j) const {
        const double theta = row_theta(k), phi = sun_phi + std::numbers::pi * psi_fraction(double(j) / intervals);
        const double st = std::sin(theta);
        return {st * std::cos(phi), st * std::sin(phi), std::cos(theta)};
    }
    double* at(int row, int col) { return values.data() + (std::size_t(row) * columns() + col) * channels; }
    const double* at(int row, int col) const {
        return values.data() + (std::size_t(row) * columns() + col) * channels;
    }

    // The cell (row and column, and the fractions in them) of a direction given by its zenith angle θ and azimuth φ: false for a
    // direction that misses the atmosphere (nothing to interpolate).
    struct Cell {
        int r0, r1, c0;
        double wr, wc;
    };
    bool cell(double theta, double phi, Cell& c) const {
        const double fr = row_of(theta);
        if (fr < 0.0) return false;
        c.r0 = std::min(static_cast<int>(fr), rows() - 2);
        // never interpolate across the horizon or a kink: clamp to the piece's last row
        c.r1 = std::min(c.r0 + 1, piece_of_row(c.r0).last());
        c.wr = c.r1 > c.r0 ? fr - c.r0 : 0.0;
        column(phi, c.c0, c.wc);
        return true;
    }
    // The column part of cell(): it depends on the azimuth only (an image row shares its
    // row part, an image column its column part).
    void column(double phi, int& c0, double& wc) const {
        const double psi = std::abs(std::remainder(phi - sun_phi, 2.0 * std::numbers::pi));
        const double fc = column_of_fraction(std::min(psi / std::numbers::pi, 1.0)) * intervals;
        c0 = std::min(static_cast<int>(fc), intervals - 1);
        wc = fc - c0;
    }
    // Catmull–Rom weights at t ∈ [0, 1] for the nodes −1, 0, 1, 2.
    static void catmull_rom(double t, double w[4]) {
        const double t2 = t * t, t3 = t2 * t;
        w[0] = 0.5 * (-t3 + 2.0 * t2 - t);
        w[1] = 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0);
        w[2] = 0.5 * (-3.0 * t3 + 4.0 * t2 + t);
        w[3] = 0.5 * (t3 - t2);
    }
    // The 4 rows and weights of a cell's row part, inside its piece.
    void row_stencil(const Cell& c, int rows_out[4], double w[4]) const {
        if (c.r1 == c.r0) {  // on a piece's last row
            for (int k = 0; k < 4; ++k) rows_out[k] = c.r0, w[k] = k == 1 ? 1.0 : 0.0;
            return;
        }
        const Piece& p = piece_of_row(c.r0);
        const int lo = p.first, hi = p.last();
        catmull_rom(c.wr, w);
        for (int k = 0; k < 4; ++k) rows_out[k] = std::clamp(c.r0 - 1 + k, lo, hi);
        if (c.r0 - 1 < lo) {  // w₀ v₋₁ = w₀ (2 v₀ − v₁)
            w[1] += 2.0 * w[0];
            w[2] -= w[0];
            w[0] = 0.0;
        }
        if (c.r0 + 2 > hi) {  // w₃ v₂ = w₃ (2 v₁ − v₀)
            w[2] += 2.0 * w[3];
            w[1] -= w[3];
            w[3] = 0.0;
        }
    }
    // The 4 columns and weights of a column part (column()), mirrored at ψ = 0 and π.
    void column_stencil(int c0, double wc, int cols[4], double w[4]) const {
        catmull_rom(wc, w);
        for (int k = 0; k < 4; ++k) {
            int j = c0 - 1 + k;
            if (j < 0) j = -j;
            if (j > intervals) j = 2 * intervals - j;
            cols[k] = std::clamp(j, 0, intervals);
        }
    }
    // The row part of a cell blended for every column at once: line[j · channels + ch]
    // (line.size() == columns() · channels). An image row shares it; each pixel then needs
    // only its column stencil (interpolate_line).
    //
    // After take_logs, each column's channel is blended in the domain where its
    // four rows are smoother: the value, or its logarithm where all four are positive. The
    // cubic's error is of the size of its stencil's third difference; in the logarithm that is
    // a relative error, in the value an absolute one, so the two compare as |Δ³ ln v| against
    // |Δ³ v| / min(v₀, v₁) over the cell's own rows (a row beyond the piece's end extrapolated
    // in each domain as the stencil does). Light that grows by an e-fold or more per row — the
    // sky next to the horizon seen through haze with the sun low, where the cubic in the value
    // was 8 % off between rows — is exponential in θ, exact for the logarithm's cubic; light
    // that turns sharply (a shadow's edge, a flat run ending in a drop) stays in the value,
    // where the logarithm's cubic would overshoot. Both give the nodes' own values at the nodes,
    // so the image stays continuous where neighbouring cells choose differently. The logarithm
    // is taken only where its own third difference is at most kMaxLogThirdDifference (its
    // cubic then within a few per cent): where both domains are rough (the Earth's shadow
    // rising in the antisolar sky), the value's cubic overshoots less.
    static constexpr double kMaxLogThirdDifference = 1.0;
    void blend_row(const Cell& c, std::span<double> line) const {
        int rr[4];
        double wr[4];
        row_stencil(c, rr, wr);
        const std::size_t n = std::size_t(columns()) * channels;
        std::fill(line.begin(), line.begin() + std::ptrdiff_t(n), 0.0);
        for (int a = 0; a < 4; ++a) {
            if (wr[a] == 0.0) continue;
            const double* v = at(rr[a], 0);
            for (std::size_t x = 0; x < n; ++x) line[x] += wr[a] * v[x];
        }
        if (log_cells.empty() || c.r1 == c.r0) return;
        double w[4];
        catmull_rom(c.wr, w);
        const unsigned char* in_log = log_cells.data() + std::size_t(c.r0) * n;
        const Piece& p = piece_of_row(c.r0);
        for (std::size_t x = 0; x < n; ++x) {
            if (!in_log[x]) continue;
            double l[4];
            stencil(log_values, p, c.r0, x, l);
            line[x] = std::exp(w[0] * l[0] + w[1] * l[1] + w[2] * l[2] + w[3] * l[3]);
        }
    }
    // ln of every value (NaN where it is not positive) and, for every cell of rows (r, r + 1)
    // inside a piece, the columns' channels blend_row takes in the logarithm. Call once the
    // values are final.
    void take_logs() {
        log_values.resize(values.size());
        for (std::size_t i = 0; i < values.size(); ++i)
            log_values[i] = values[i] > 0.0 ? std::log(values[i]) : std::numeric_limits<double>::quiet_NaN();
        const std::size_t n = std::size_t(columns()) * channels;
        log_cells.assign(std::size_t(rows()) * n, 0);
        for (int r = 0; r + 1 < rows(); ++r) {
            const Piece& p = piece_of_row(r);
            if (r + 1 > p.last()) continue;  // across a piece's end: never blended
            for (std::size_t x = 0; x < n; ++x) {
                double v[4], l[4];
                stencil(values, p, r, x, v);
                stencil(log_values, p, r, x, l);
                const double d3_log = std::abs(l[3] - 3.0 * l[2] + 3.0 * l[1] - l[0]);  // NaN: a value ≤ 0
                const double d3_value = std::abs(v[3] - 3.0 * v[2] + 3.0 * v[1] - v[0]) / std::min(v[1], v[2]);
                log_cells[std::size_t(r) * n + x] = d3_log < d3_value && d3_log <= kMaxLogThirdDifference;
            }
        }
    }
    // The four rows r − 1 … r + 2 of cell (r, r + 1) of piece p at column-channel x of `of`
    // (values or log_values), a row beyond the piece's end extrapolated linearly as row_stencil does.
    void stencil(const std::vector<double>& of, const Piece& p, int r, std::size_t x, double out[4]) const {
        const std::size_t n = std::size_t(columns()) * channels;
        for (int t = 0; t < 4; ++t) out[t] = of[std::size_t(std::clamp(r - 1 + t, p.first, p.last())) * n + x];
        if (r - 1 < p.first) out[0] = 2.0 * out[1] - out[2];
        if (r + 2 > p.last()) out[3] = 2.0 * out[2] - out[1];
    }
    void interpolate_line(std::span<const double> line, const int cols[4], const double w[4],
                          std::span<double> out) const {
        for (int ch = 0; ch < channels; ++ch)
            out[ch] = w[0] * line[std::size_t(cols[0]) * channels + ch] + w[1] * line[std::size_t(cols[1]) * channels + ch] +
                      w[2] * line[std::size_t(cols[2]) * channels + ch] + w[3] * line[std::size_t(cols[3]) * channels + ch];
    }
    // Cells the cubic cannot follow: cell (r, c) — rows r and r + 1 of one piece, columns c and
    // c + 1 — is rough when, for some channel, the two quadratic estimates of its middle (from
    // nodes −1, 0, 1 and from 0, 1, 2, along the rows or along the columns) disagree by more
    // than `tolerance` of the channel's largest corner value plus `floor` of its largest value
    // anywhere on the grid: their difference is the stencil's third difference over 8, small
    // where the light is smooth (the cubic's own error is of the fourth order) and of the size
    // of the jump where it is not — a shadow's edge crossing the limb seen from orbit, which no
    // row or column of the grid follows. Ghost nodes as the stencils take them (a piece's end
    // extrapolated linearly; columns mirrored). Dilated by a cell each way (a cubic reaches one
    // cell beyond its own). (rows() − 1) × intervals flags; a row pair across a piece's end is
    // never rough (never interpolated across).
    //
    // With `shown` (the image's grid), the channels are parts of what a pixel shows — channel
    // ch is part ch / colours of colour ch % colours, and a node's pixel is Σ_parts
    // weight(node, part) × value — and a cell is also rough where the parts' disagreements in
    // the pixel's units, summed per colour, exceed `tolerance` of the corners' pixel luminance
    // plus shown.floor of the largest on the grid. The channels' own floor (`floor` of each
    // channel's largest value) leaves faint light interpolated however wrong: the Earth's
    // shadow rising in the antisolar sky at twilight is a thousandth of the sky toward the
    // sun. Judged in the pixel, a part's edge that other parts outshine (the single
    // scattering's shadow where the multiple scattering fills it) is not rough, and faint
    // light is judged against itself down to shown.floor.
    struct Shown {
        int parts = 1;
        double floor = 0.0;
        std::vector<double> weight;     // rows() × columns() × parts
        std::vector<double> luminance;  // rows() × columns(): the node's pixel
    };
    std::vector<unsigned char> rough_cells(double tolerance, double floor, const Shown* shown = nullptr) const {
        const int R = rows(), C = intervals;
        const std::size_t nc = std::size_t(channels), stride = std::size_t(columns()) * nc;
        std::vector<unsigned char> rough(std::size_t(std::max(R - 1, 0)) * std::size_t(C), 0);
        if (R < 2 || C < 1) return rough;
        std::vector<double> floor_of(nc, 0.0);  // floor × the channel's largest value
        for (std::size_t i = 0; i < values.size(); ++i) floor_of[i % nc] = std::max(floor_of[i % nc], std::abs(values[i]));
        for (double& f : floor_of) f *= floor;
        double brightest = 0.0;  // with `shown`: the largest pixel luminance of a node
        if (shown)
            for (const double y : shown->luminance) brightest = std::max(brightest, y);
        std::vector<double> colour_error(shown ? nc / std::size_t(shown->parts) : 0);
        const auto column = [&](int j) {  // mirrored at ψ = 0 and π, as column_stencil
            if (j < 0) j = -j;
            if (j > C) j = 2 * C - j;
            return std::size_t(std::clamp(j, 0, C));
        };
        // Along the columns, every row: d3c[k][c][ch] for the cells' columns c ∈ [0, C).
        std::vector<double> d3c(std::size_t(R) * std::size_t(C) * nc);
        for (int k = 0; k < R; ++k) {
            const double* row = values.data() + std::size_t(k) * stride;
            double* out = d3c.data() + std::size_t(k) * std::size_t(C) * nc;
            for (int c = 0; c < C; ++c) {
                const double *a = row + column(c - 1) * nc, *b = row + column(c) * nc, *d = row + column(c + 1) * nc,
                             *e = row + column(c + 2) * nc;
                for (std::size_t ch = 0; ch < nc; ++ch)
                    out[std::size_t(c) * nc + ch] = e[ch] - 3.0 * d[ch] + 3.0 * b[ch] - a[ch];
            }
        }
        // Along the rows, for each row pair (r, r + 1) of a piece: nodes r − 1 … r + 2, a node
        // beyond the piece extrapolated linearly (v(lo − 1) = 2 v(lo) − v(lo + 1)), written as
        // weights of the piece's own rows.
        std::vector<double> d3r(stride);
        std::vector<unsigned char> raw(rough.size(), 0);
        for (int r = 0; r + 1 < R; ++r) {
            const Piece& p = piece_of_row(r);
            if (r + 1 > p.last()) continue;  // across a piece's end
            const int lo = p.first, hi = p.last();
            double weight[4] = {0.0, 0.0, 0.0, 0.0};  // of rows r − 1 … r + 2 (clamped into the piece)
            int at_row[4] = {r - 1, r, r + 1, r + 2};
            const double d3[4] = {-1.0, 3.0, -3.0, 1.0};
            for (int t = 0; t < 4; ++t) {
                const int k = at_row[t];
                if (k < lo) {  // 2 v(lo) − v(lo + 1)
                    weight[1] += 2.0 * d3[t];
                    weight[2] -= d3[t];
                } else if (k > hi) {  // 2 v(hi) − v(hi − 1)
                    weight[2] += 2.0 * d3[t];
                    weight[1] -= d3[t];
                } else {
                    weight[t] += d3[t];
                }
            }
            // rows r and r + 1 always lie in the piece; r − 1 and r + 2 when weighted
            const double* rw[4] = {nullptr, values.data() + std::size_t(r) * stride,
                                   values.data() + std::size_t(r + 1) * stride, nullptr};
            if (r - 1 >= lo) rw[0] = values.data() + std::size_t(r - 1) * stride;
            if (r + 2 <= hi) rw[3] = values.data() + std::size_t(r + 2) * stride;
            std::fill(d3r.begin(), d3r.end(), 0.0);
            for (int t = 0; t < 4; ++t)
                if (weight[t] != 0.0 && rw[t])
                    for (std::size_t i = 0; i < stride; ++i) d3r[i] += weight[t] * rw[t][i];
            const double* c0 = d3c.data() + std::size_t(r) * std::size_t(C) * nc;
            const double* c1 = c0 + std::size_t(C) * nc;
            for (int c = 0; c < C; ++c) {
                const double *v00 = rw[1] + std::size_t(c) * nc, *v01 = v00 + nc, *v10 = rw[2] + std::size_t(c) * nc,
                             *v11 = v10 + nc;
                const double *r0 = d3r.data() + std::size_t(c) * nc, *r1 = r0 + nc;
                const double *a0 = c0 + std::size_t(c) * nc, *a1 = c1 + std::size_t(c) * nc;
                if (shown) {
                    const std::size_t np = std::size_t(shown->parts), colours = nc / np;
                    const std::size_t n00 = std::size_t(r) * columns() + std::size_t(c), n10 = n00 + columns();
                    const std::size_t corner[4] = {n00, n00 + 1, n10, n10 + 1};
                    double y = 0.0;
                    for (const std::size_t k : corner) y = std::max(y, shown->luminance[k]);
                    std::fill(colour_error.begin(), colour_error.end(), 0.0);
                    for (std::size_t ch = 0; ch < nc; ++ch) {
                        double w = 0.0;
                        for (const std::size_t k : corner) w = std::max(w, shown->weight[k * np + ch / colours]);
                        const double d = std::max(std::max(std::abs(a0[ch]), std::abs(a1[ch])),
                                                  std::max(std::abs(r0[ch]), std::abs(r1[ch])));
                        colour_error[ch % colours] += w * d;
                    }
                    const double scale = 8.0 * (tolerance * y + shown->floor * brightest);
                    raw[std::size_t(r) * C + c] =
                        *std::max_element(colour_error.begin(), colour_error.end()) > scale;
                    if (raw[std::size_t(r) * C + c]) continue;
                }
                bool is_rough = false;
                for (std::size_t ch = 0; ch < nc; ++ch) {
                    // the quadratic estimates disagree by |d3| / 8
                    const double scale = 8.0 * (tolerance * std::max(std::max(std::abs(v00[ch]), std::abs(v01[ch])),
                                                                     std::max(std::abs(v10[ch]), std::abs(v11[ch]))) +
                                                floor_of[ch]);
                    const double d = std::max(std::max(std::abs(a0[ch]), std::abs(a1[ch])),
                                              std::max(std::abs(r0[ch]), std::abs(r1[ch])));
                    is_rough |= d > scale;
                }
                raw[std::size_t(r) * C + c] = is_rough;
            }
        }
        for (int r = 0; r + 1 < R; ++r)
            for (int c = 0; c < C; ++c) {
                if (!raw[std::size_t(r) * C + c]) continue;
                for (int dr = -1; dr <= 1; ++dr)
                    for (int dc = -1; dc <= 1; ++dc) {
                        const int rr = r + dr, cc = c + dc;
                        if (rr >= 0 && rr + 1 < R && cc >= 0 && cc < C) rough[std::size_t(rr) * C + cc] = 1;
                    }
            }
        return rough;
    }

    // The interpolated values of a cell (out.size() == channels).
    void interpolate(const Cell& c, std::span<double> out) const {
        int rr[4], cc[4];
        double wr[4], wc[4];
        row_stencil(c, rr, wr);
        column_stencil(c.c0, c.wc, cc, wc);
        std::fill(out.begin(), out.begin() + channels, 0.0);
        for (int a = 0; a < 4; ++a) {
            if (wr[a] == 0.0) continue;
            for (int b = 0; b < 4; ++b) {
                const double w = wr[a] * wc[b];
                const double* v = at(rr[a], cc[b]);
                for (int ch = 0; ch < channels; ++ch) out[ch] += w * v[ch];
            }
        }
    }
};

}  // namespace airmass
