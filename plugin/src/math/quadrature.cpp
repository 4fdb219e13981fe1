// Gauss–Legendre rules on [0, 1] from Boost.Math's Legendre zeros (quadrature.hpp).
#include "math/quadrature.hpp"

#include <boost/math/special_functions/legendre.hpp>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

namespace airmass {

namespace {

// The p-point Gauss–Legendre rule on [0, 1] as (node, weight) pairs, nodes increasing.
// legendre_p_zeros gives the non-negative zeros of P_p in increasing order (0 first when p is
// odd); each zero x > 0 stands for ±x. Weights on [−1, 1]: 2 / ((1 − x²) P_p'(x)²).
std::vector<std::pair<double, double>> rule(int p) {
    std::vector<std::pair<double, double>> nodes;
    for (double x : boost::math::legendre_p_zeros<double>(p)) {
        const double d = boost::math::legendre_p_prime<double>(p, x);
        const double w = 2.0 / ((1.0 - x * x) * d * d);
        nodes.emplace_back(0.5 * (1.0 + x), 0.5 * w);
        if (x > 0.0) nodes.emplace_back(0.5 * (1.0 - x), 0.5 * w);
    }
    std::sort(nodes.begin(), nodes.end());
    return nodes;
}

}  // namespace

std::vector<double> unit_gauss_rule_table() {
    std::vector<double> table;
    table.reserve(std::size_t(kMaxGaussPanelNodes) * (kMaxGaussPanelNodes + 1));
    for (int p = 1; p <= kMaxGaussPanelNodes; ++p)
        for (const auto& [x, w] : rule(p)) {
            table.push_back(x);
            table.push_back(w);
        }
    return table;
}

std::vector<double> unit_gauss_legendre(int n) {
    if (n < 1) throw std::invalid_argument("Gauss-Legendre rule: n = " + std::to_string(n) + ": must be >= 1");
    std::vector<double> out;
    out.reserve(2 * std::size_t(n));
    const std::vector<double> table = unit_gauss_rule_table();
    for_each_unit_gauss_node(table.data(), n, [&](double x, double w) {
        out.push_back(x);
        out.push_back(w);
    });
    return out;
}

}  // namespace airmass
