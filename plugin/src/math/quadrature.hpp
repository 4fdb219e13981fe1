// Gauss–Legendre rules on [0, 1] (the view-ray quadrature of single scattering).
#pragma once

#include <vector>

namespace airmass {

// The 4-point Gauss–Legendre rule on [−1, 1] for kernels that need it at compile time: nodes
// ±kGauss4Node[i], weights kGauss4Weight[i] (unit_gauss_legendre(4) is the same rule on [0, 1];
// tests/test_quadrature.cpp checks the two agree).
inline constexpr double kGauss4Node[2] = {0.339981043584856265, 0.861136311594052575};
inline constexpr double kGauss4Weight[2] = {0.652145154862546143, 0.347854845137453857};

// The largest Gauss–Legendre rule used whole; more nodes are split into panels.
inline constexpr int kMaxGaussPanelNodes = 16;

// n ≥ 1 nodes on [0, 1] as interleaved (node, weight) pairs, nodes increasing, weights summing
// to 1. n ≤ kMaxGaussPanelNodes: the n-point Gauss–Legendre rule (exact for polynomials of degree
// 2n − 1). Larger n: ⌈n/16⌉ panels whose node counts differ by at most one, each as wide as its
// share of the nodes (so the node density stays even) and each its own Gauss–Legendre rule — the
// work stays O(n) and the error falls as the 2p-th power of the panel width (p ≥ 8 points).
// Throws std::invalid_argument for n < 1.
std::vector<double> unit_gauss_legendre(int n);

// The Gauss–Legendre rules of 1 … kMaxGaussPanelNodes nodes on [0, 1], flattened: the p-point
// rule's (node, weight) pairs start at element p(p − 1). What for_each_unit_gauss_node reads.
std::vector<double> unit_gauss_rule_table();

// The nodes of unit_gauss_legendre(n) (n ≥ 1), in order, as fn(node, weight), from a
// unit_gauss_rule_table without allocating: the same panels, the same values.
template <class Fn>
void for_each_unit_gauss_node(const double* table, int n, Fn&& fn) {
    const int panels = (n + kMaxGaussPanelNodes - 1) / kMaxGaussPanelNodes;
    const int base = n / panels, extra = n % panels;  // the first `extra` panels take one more node
    int done = 0;
    for (int k = 0; k < panels; ++k) {
        const int p = k < extra ? base + 1 : base;
        const double* r = table + p * (p - 1);
        const double a = double(done) / n, width = double(p) / n;
        for (int i = 0; i < p; ++i) fn(a + width * r[2 * i], width * r[2 * i + 1]);
        done += p;
    }
}

}  // namespace airmass
