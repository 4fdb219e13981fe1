// A dense D-dimensional grid of spectra (the multiple-scattering tables; model: pbrt-v4's
// MajorantGrid::Lookup, with the multilinear interpolation of Bruneton's texture lookups).
//
// Node (i_0, …, i_{D−1}) holds `channels` values starting at
//     index(i) = ((i_0 · n_1 + i_1) · n_2 + … + i_{D−1}) · channels,
// the wavelengths innermost, so a spectrum is contiguous and every per-node loop runs over
// wavelengths (vectorisable; spectrum.hpp). A node may hold several spectra side by side
// (the G table: one per scattering slot); lookups take the offset of the one they read.
//
// Coordinates: a TableCoord {i0, f} on one axis is the lower node and the fraction toward
// i0 + 1 (table_coord clamps a continuous coordinate into a node range). `lookup` visits the
// 2^D corners in lexicographic order (axis 0 outermost), weight = Π (1 − f or f) multiplied
// from axis 0 on, skips corners of zero weight (so the clamped upper node of a degenerate
// axis is never read) and accumulates weight · spectrum in that order.
//
// Header-only and inline on purpose: the transport kernels are compiled once per instruction
// set (airmass/simd.hpp) and each copy inlines and vectorises these loops for its target.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>

#include "airmass/spectrum.hpp"

namespace airmass {

// Lower node and fraction on one axis.
struct TableCoord {
    int i0;
    float f;
};

// The TableCoord of continuous coordinate s on the node range [lo, hi]: s clamped to it,
// i0 ≤ hi − 1 (so i0 + 1 is a node) unless the range is a single node (then {lo, 0}).
inline TableCoord table_coord(double s, int lo, int hi) {
    if (hi <= lo) return {lo, 0.0f};
    s = std::clamp(s, double(lo), double(hi));
    const int i = std::min(int(std::floor(s)), hi - 1);
    return {i, float(s - i)};
}

template <class T, std::size_t D>
class SpectralTableView {
public:
    using Index = std::array<int, D>;

    SpectralTableView() = default;
    // `data` has Π shape × channels elements.
    SpectralTableView(T* data, const Index& shape, std::size_t channels)
        : data_(data), shape_(shape), channels_(channels) {}
    // Over a vector, checking its size (a clear error naming both sizes).
    template <class Vec>
    SpectralTableView(Vec& values, const Index& shape, std::size_t channels)
        : SpectralTableView(values.data(), shape, channels) {
        if (values.size() != node_count() * channels_)
            throw std::length_error("spectral table: " + std::to_string(values.size()) + " values for " +
                                    std::to_string(node_count()) + " nodes × " + std::to_string(channels_) +
                                    " channels");
    }

    const Index& shape() const { return shape_; }
    std::size_t channels() const { return channels_; }
    T* data() const { return data_; }
    std::size_t node_count() const {
        std::size_t n = 1;
        for (int s : shape_) n *= std::size_t(s);
        return n;
    }

    // Offset of node i's first channel.
    std::size_t index(const Index& i) const {
        std::size_t n = 0;
        for (std::size_t d = 0; d < D; ++d) n = n * std::size_t(shape_[d]) + std::size_t(i[d]);
        return n * channels_;
    }
    // The `count` channels of node i from channel `offset` (one spectrum of a node).
    SpectrumView<T> at(const Index& i, std::size_t offset, std::size_t count) const {
        return {data_ + index(i) + offset, count};
    }
    SpectrumView<T> at(const Index& i) const { return at(i, 0, channels_); }

    // out = multilinear interpolation of channels [offset, offset + out.size()) at the
    // coordinates (see the header comment for the order of operations).
    template <class Out>
    void lookup(const std::array<TableCoord, D>& x, Out&& dst, std::size_t offset = 0) const {
        const auto out = as_view(dst);
        using V = typename decltype(out)::value_type;
        fill(out, V(0));
        Index node{};
        accumulate<0>(x, out, offset, node, 1.0f);
    }

private:
    template <std::size_t A, class V>
    void accumulate(const std::array<TableCoord, D>& x, SpectrumView<V> out, std::size_t offset, Index& node,
                    float weight) const {
        for (int corner = 0; corner < 2; ++corner) {
            const float w = A == 0 ? (corner ? x[A].f : 1 - x[A].f) : weight * (corner ? x[A].f : 1 - x[A].f);
            if (w == 0.0f) continue;
            node[A] = std::min(x[A].i0 + corner, shape_[A] - 1);
            if constexpr (A + 1 < D) {
                accumulate<A + 1>(x, out, offset, node, w);
            } else {
                const T* p = data_ + index(node) + offset;
                V* o = out.data();
                const V wv = V(w);
                for (std::size_t c = 0; c < out.size(); ++c) o[c] += wv * V(p[c]);
            }
        }
    }

    T* data_ = nullptr;
    Index shape_{};
    std::size_t channels_ = 0;
};

}  // namespace airmass
