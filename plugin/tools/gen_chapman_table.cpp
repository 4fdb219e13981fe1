// Generates the `airmass` Chapman method's correction table R(w, v) = Ch / B from the
// exact quadrature (see plugin/src/math/chapman_airmass.hpp for the coordinates), and with
// --check measures the interpolated method against the exact one on a dense set (exit status 1
// if the Ch∥ table's error exceeds 1e-8).
//
//   gen_chapman_table --w 65 --v 65 --out chapman_airmass_table.cpp [--check]
#include <cerf.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "math/chapman_airmass.hpp"

using namespace airmass;
using namespace airmass::detail;

namespace {

// R at w = 0 (x → ∞, y = mu sqrt(x/2) fixed): Ch → sqrt(pi x / 2) erfcx(y) and
// B → sqrt(pi x / 2) / (sqrt(pi) y + 1), so R → erfcx(y) (1 + sqrt(pi) y), v = y / (1 + y).
double flat_limit(double v) {
    if (v >= 1.0) return 1.0;
    const double y = v / (1.0 - v);
    return erfcx(y) * (1.0 + std::sqrt(M_PI) * y);
}

std::vector<double> make_table(int n_w, int n_v) {
    std::vector<double> t(static_cast<size_t>(n_w) * n_v);
    for (int i = 0; i < n_w; ++i) {
        const double w = double(i) / (n_w - 1);
        for (int j = 0; j < n_v; ++j) {
            const double v = double(j) / (n_v - 1);
            double r;
            if (i == 0) {
                r = flat_limit(v);
            } else {
                double x, mu;
                airmass_table_point(w, v, x, mu);
                const double c = airmass_base_horizontal(std::sqrt(x));
                r = chapman_upper_exact(x, mu) / (c / ((c - 1.0) * mu + 1.0));
            }
            t[static_cast<size_t>(i) * n_v + j] = r;
        }
    }
    return t;
}

// Per-cell bicubic coefficients of the nodes' Lagrange interpolant: sample it on a 4×4
// grid of local coordinates and solve the (exactly invertible) Vandermonde system.
std::vector<double> make_coefficients(const std::vector<double>& nodes, int n_w, int n_v) {
    const AirmassNodes interp{nodes.data(), n_w, n_v};
    // Inverse of the Vandermonde matrix V[k][a] = (k/3)^a, k, a = 0..3.
    static constexpr double inv[4][4] = {{1, 0, 0, 0},
                                         {-5.5, 9, -4.5, 1},
                                         {9, -22.5, 18, -4.5},
                                         {-4.5, 13.5, -13.5, 4.5}};
    std::vector<double> coef(static_cast<size_t>(n_w - 1) * (n_v - 1) * 16);
    for (int i = 0; i < n_w - 1; ++i)
        for (int j = 0; j < n_v - 1; ++j) {
            double f[4][4];
            for (int k = 0; k < 4; ++k)
                for (int l = 0; l < 4; ++l)
                    f[k][l] = interp.interpolate((i + k / 3.0) / (n_w - 1), (j + l / 3.0) / (n_v - 1));
            double* c = &coef[(static_cast<size_t>(i) * (n_v - 1) + j) * 16];
            for (int a = 0; a < 4; ++a)
                for (int b = 0; b < 4; ++b) {
                    double sum = 0;
                    for (int k = 0; k < 4; ++k)
                        for (int l = 0; l < 4; ++l) sum += inv[a][k] * inv[b][l] * f[k][l];
                    c[4 * a + b] = sum;
                }
        }
    return coef;
}

// Ch∥ per cell of the x0-bits table (chapman_airmass.hpp, airmass_parallel_cell): the cubic in τ
// through the exact values at the cell's ends (shared with the neighbours, so the table is
// continuous) and at a quarter and three quarters of it.
std::vector<double> make_parallel() {
    constexpr double width = 1.0 / (1 << kParallelCellBits);  // of τ
    static constexpr double nodes[4] = {0.0, 0.25 * width, 0.75 * width, width};
    std::vector<double> coef(static_cast<size_t>(kParallelCells + 1) * 4);  // cell 0: zeros
    for (int k = 0; k < kParallelCells; ++k) {
        const int e = kParallelExpLo + (k >> kParallelCellBits), sub = k & ((1 << kParallelCellBits) - 1);
        long double a[4][5];
        for (int r = 0; r < 4; ++r) {
            const double x0 = std::ldexp(1.0 + sub * width + nodes[r], e);
            long double p = 1;
            for (int c = 0; c < 4; ++c, p *= nodes[r]) a[r][c] = p;
            a[r][4] = chapman_upper_exact(x0, 0.0);
        }
        for (int c = 0; c < 4; ++c)  // Gauss–Jordan (the nodes' Vandermonde matrix is well conditioned)
            for (int r = 0; r < 4; ++r)
                if (r != c) {
                    const long double f = a[r][c] / a[c][c];
                    for (int q = c; q < 5; ++q) a[r][q] -= f * a[c][q];
                }
        for (int c = 0; c < 4; ++c) coef[4 * static_cast<size_t>(k + 1) + c] = static_cast<double>(a[c][4] / a[c][c]);
    }
    return coef;
}

int check(const AirmassTable& table, const double* parallel) {
    double max_up = 0, max_h = 0, at_x = 0, at_mu = 0, at_hx = 0;
    const int nx = 400, nmu = 400;
    for (int a = 0; a <= nx; ++a) {
        const double x = std::pow(10.0, -2.0 + 9.0 * a / nx);
        for (int b = 0; b <= nmu; ++b) {
            // dense near the horizon: mu = (b/nmu)^3
            const double s = double(b) / nmu;
            const double mu = s * s * s;
            const double ex = chapman_upper_exact(x, mu);
            const double ap = table.upper(x, mu);
            const double e = std::abs(ap / ex - 1.0);
            if (e > max_up) { max_up = e; at_x = x; at_mu = mu; }
        }
    }
    for (int a = 0; a <= 4000; ++a) {
        const double x = a == 0 ? 0.0 : std::pow(10.0, -8.0 + 15.0 * a / 4000);
        const double e = std::abs(table.horizontal(x) / chapman_upper_exact(x, 0.0) - 1.0);
        if (e > max_h) { max_h = e; at_hx = x; }
    }
    std::printf("max rel err upper %.3e at x=%g mu=%g; horizontal %.3e at x=%g\n", max_up, at_x, at_mu, max_h,
                at_hx);
    // The Ch∥ table, x0 from 0 over the table's octaves (the fast paths take x0 < 2^40).
    double max_p = 0, at_px = 0;
    for (int a = 0; a <= 20000; ++a) {
        const double x0 = a == 0 ? 0.0 : std::pow(2.0, -40.0 + 80.0 * a / 20000);
        if (!(x0 < kParallelEnd)) break;
        const double e = std::abs(airmass_parallel(parallel, x0) / chapman_upper_exact(x0, 0.0) - 1.0);
        if (e > max_p) { max_p = e; at_px = x0; }
    }
    std::printf("max rel err Ch_par table %.3e at x0=%g (x0 in [0, 2^40))\n", max_p, at_px);
    // docs/chapman.md and chapman_airmass.hpp claim 8.2e-9 for the Ch∥ table (it does not depend on
    // --w/--v): a change that makes it worse than 1e-8 fails here (tests/test_chapman_reference.cpp
    // checks the built-in table against Boost's K1 at the same bound).
    constexpr double kParallelMaxError = 1e-8;
    if (!(max_p <= kParallelMaxError)) {
        std::fprintf(stderr, "gen_chapman_table --check: Ch_par table error %.3e exceeds %.0e\n", max_p, kParallelMaxError);
        return 1;
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    int n_w = 65, n_v = 65;
    std::string out;
    bool do_check = false;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--w" && i + 1 < argc) n_w = std::atoi(argv[++i]);
        else if (a == "--v" && i + 1 < argc) n_v = std::atoi(argv[++i]);
        else if (a == "--out" && i + 1 < argc) out = argv[++i];
        else if (a == "--check") do_check = true;
        else { std::fprintf(stderr, "usage: gen_chapman_table --w N --v N [--out FILE] [--check]\n"); return 2; }
    }
    if (n_w < 4 || n_v < 4) { std::fprintf(stderr, "gen_chapman_table: --w and --v must be >= 4\n"); return 2; }
    const std::vector<double> nodes = make_table(n_w, n_v);
    const std::vector<double> t = make_coefficients(nodes, n_w, n_v);
    const std::vector<double> parallel = make_parallel();
    if (do_check && check(AirmassTable{t.data(), n_w, n_v}, parallel.data()) != 0) return 1;
    if (!out.empty()) {
        const std::string tmp = out + ".tmp";
        {
            std::ofstream f(tmp);
            f << "// Generated by plugin/tools/gen_chapman_table.cpp from the exact Chapman quadrature. Do not edit.\n"
              << "#include \"math/chapman_airmass.hpp\"\n\nnamespace airmass::detail {\nnamespace {\nconstexpr int kW = " << n_w
              << ", kV = " << n_v << ";\n// Per-cell bicubic coefficients, (kW − 1)(kV − 1) cells × 16.\nalignas(64) constexpr double kTable[(kW - 1) * (kV - 1) * 16] = {\n";
            char buf[64];
            for (size_t k = 0; k < t.size(); ++k) {
                std::snprintf(buf, sizeof buf, "%.17g,%s", t[k], (k + 1) % 4 == 0 ? "\n" : " ");
                f << buf;
            }
            f << "};\n// Ch∥ by the bits of x0 (airmass_parallel_cell): a cell of zeros, then kParallelCells cells × 4.\n"
                 "alignas(64) constexpr double kParallel[(kParallelCells + 1) * 4] = {\n";
            for (size_t k = 0; k < parallel.size(); ++k) {
                std::snprintf(buf, sizeof buf, "%.17g,%s", parallel[k], (k + 1) % 4 == 0 ? "\n" : " ");
                f << buf;
            }
            f << "};\n}  // namespace\n\nconst AirmassTable& airmass_table() {\n"
                 "    static constexpr AirmassTable table{kTable, kW, kV};\n    return table;\n}\n\n"
                 "const double* airmass_parallel_table() { return kParallel; }\n\n}  // namespace airmass::detail\n";
            if (!f) { std::fprintf(stderr, "gen_chapman_table: cannot write %s\n", tmp.c_str()); return 1; }
        }
        std::filesystem::rename(tmp, out);
    }
    return 0;
}
