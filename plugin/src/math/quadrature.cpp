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

std::vector<double> unit_gauss_legendre(int n) {
    if (n < 1) throw std::invalid_argument("Gauss-Legendre rule: n = " + std::to_string(n) + ": must be >= 1");
    std::vector<double> out;
    out.reserve(2 * std::size_t(n));
    const int panels = (n + kMaxGaussPanelNodes - 1) / kMaxGaussPanelNodes;
    const int base = n / panels, extra = n % panels;  // the first `extra` panels take one more node
    const auto small = rule(base);
    const auto large = extra > 0 ? rule(base + 1) : small;
    int done = 0;
    for (int k = 0; k < panels; ++k) {
        const auto& r = k < extra ? large : small;
        const int p = int(r.size());
        const double a = double(done) / n, width = double(p) / n;
        for (const auto& [x, w] : r) {
            out.push_back(a + width * x);
            out.push_back(width * w);
        }
        done += p;
    }
    return out;
}

}  // namespace airmass
