// voxel_average.hpp: the mean of a density profile over a voxel's trilinear hat.
#include "voxel_average.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>

namespace airmass::detail {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Gauss–Legendre, 4 nodes on [−1, 1]: exact for degree 7, so for U's density (cubic) times what a
// linear piece gives (cubic); exponentials on parts at most 2 scale heights long (< 1e-5).
constexpr double kGlX[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526};
constexpr double kGlW[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538};

// The triangle of half-width w > 0 (the hat along one axis, projected): (w − |t|)₊ / w².
double triangle(double t, double w) { return std::max(0.0, w - std::abs(t)) / (w * w); }

// Density of T0 + T1 at u, T_i triangles of half-widths 0 ≤ w0 ≤ w1, w1 > 0. Each triangle is
// the second difference of the ramp, (x + w)₊ − 2x₊ + (x − w)₊ over w², so their convolution is
// the second difference in both of x₊³/6: nine terms. Where w0 < 1e-3 w1 the narrow one is
// taken as a point (the density changes by < 1e-6 of its peak; the differences would cancel).
double sum_density(double u, double w0, double w1) {
    if (!(w0 > 1e-3 * w1)) return triangle(u, w1);
    constexpr double a[3] = {1.0, -2.0, 1.0};
    double s = 0.0;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            const double x = u + (i - 1) * w0 + (j - 1) * w1;
            if (x > 0.0) s += a[i] * a[j] * x * x * x;
        }
    return std::max(0.0, s / (6.0 * w0 * w0 * w1 * w1));
}

// ∫_0^1 e^{−zσ} dσ and ∫_0^1 σ e^{−zσ} dσ for z ≥ 0, without cancellation near 0.
// Both at once (one exponential).
void e12(double z, double& e1, double& e2) {
    if (z < 1e-3) {
        e1 = 1.0 - z * (0.5 - z * (1.0 / 6.0 - z / 24.0));
        e2 = 0.5 - z * (1.0 / 3.0 - z * (1.0 / 8.0 - z / 30.0));
        return;
    }
    const double ez = std::exp(-z);
    e1 = (1.0 - ez) / z;
    e2 = (1.0 - (1.0 + z) * ez) / (z * z);
}

// log(sinh y / y), y ≥ 0.
double log_sinhc(double y) {
    if (y < 0.25) {
        const double y2 = y * y;
        return y2 * (1.0 / 6.0 - y2 * (1.0 / 180.0 - y2 * (1.0 / 2835.0 - y2 / 37800.0)));
    }
    return y + std::log1p(-std::exp(-2.0 * y)) - std::log(2.0 * y);
}

// One half of the triangle of half-width w, weight (w − s t) on [t0, t1] (s = +1: t ≥ 0;
// s = −1: t ≤ 0), times a piece of the profile at altitude h0 + t. Unnormalised (the 1/w²
// cancels in the ratio voxel_average takes).
double half_integral(const DensityPieces::Piece& p, double h0, double w, double s, double t0, double t1) {
    if (!(t1 > t0)) return 0.0;
    const double L = t1 - t0;
    if (p.exponential) {
        const double r0 = std::exp(-(h0 + t0 - p.ref) / p.H);  // the piece's densest point here
        double f1, f2;
        e12(L / p.H, f1, f2);
        return r0 * ((w - s * t0) * L * f1 - s * L * L * f2);
    }
    const double C0 = p.c0 + p.c1 * h0, C1 = p.c1;
    const double sum1 = L * (t1 + t0), sum2 = L * (t1 * t1 + t1 * t0 + t0 * t0);
    return C0 * w * L + (C1 * w - s * C0) * 0.5 * sum1 - s * C1 * sum2 / 3.0;
}

// For the closed-form axis, a triangle of half-width w whose centre the voxel's other axes moved
// to altitude h0: its mass above the ground (inner_mass) and a profile's integral against it
// over the air (inner_density). Unnormalised (the 1/w² cancels in the ratio).
double inner_mass(double h0, double w) {
    const double g = std::max(-h0, -w);  // mass on [max(−h0, −w), w]
    if (!(g < w)) return 0.0;
    DensityPieces::Piece one;  // density 1
    one.c0 = 1.0;
    return half_integral(one, 0.0, w, -1.0, g, 0.0) + half_integral(one, 0.0, w, 1.0, std::max(g, 0.0), w);
}
double inner_density(const DensityPieces& prof, double h0, double w) {
    const auto& P = prof.pieces;
    double num = 0.0;
    // the first piece that can reach the triangle
    auto it = std::lower_bound(P.begin(), P.end(), h0 - w,
                               [](const DensityPieces::Piece& p, double x) { return p.hi <= x; });
    for (; it != P.end() && it->lo < h0 + w; ++it) {
        const double lo = std::max(std::max(it->lo, 0.0) - h0, -w);
        const double hi = std::min(std::min(it->hi, prof.top_m) - h0, w);
        if (!(hi > lo)) continue;
        num += half_integral(*it, h0, w, -1.0, lo, std::min(hi, 0.0)) +
               half_integral(*it, h0, w, 1.0, std::max(lo, 0.0), hi);
    }
    return num;
}

// The closed form where the hat lies inside [0, top] and inside one piece; false otherwise.
bool closed_form(const DensityPieces& prof, double h, double reach, const double* w, double& v) {
    if (!(h - reach >= 0.0 && h + reach <= prof.top_m)) return false;
    const auto& P = prof.pieces;
    auto it = std::lower_bound(P.begin(), P.end(), h - reach,
                               [](const DensityPieces::Piece& p, double x) { return p.hi <= x; });
    if (it == P.end() || it->lo >= h + reach) {  // no piece meets the hat
        v = 0.0;
        return true;
    }
    if (!(it->lo <= h - reach && it->hi >= h + reach)) return false;
    if (!it->exponential) {
        v = std::max(0.0, it->c0 + it->c1 * h);
        return true;
    }
    const double k = 0.5 / it->H;
    v = std::exp(-(h - it->ref) / it->H + 2.0 * (log_sinhc(k * w[0]) + log_sinhc(k * w[1]) + log_sinhc(k * w[2])));
    return true;
}

}  // namespace

DensityPieces DensityPieces::of(const DensityProfile& p, double top_m) {
    DensityPieces out;
    out.top_m = top_m;
    auto linear = [&](double a, double da, double b, double db) {
        if (!(b > a)) return;  // a jump (equal altitudes) has no extent
        Piece q;
        q.lo = a;
        q.hi = b;
        q.c1 = (db - da) / (b - a);
        q.c0 = da - q.c1 * a;
        out.pieces.push_back(q);
    };
    switch (p.kind) {
        case DensityProfile::Kind::exponential: {
            Piece q;
            q.lo = -kInf;
            q.hi = kInf;
            q.exponential = true;
            q.ref = p.reference_altitude_m;
            q.H = p.scale_height_m;
            out.pieces.push_back(q);
            break;
        }
        case DensityProfile::Kind::tent:
            linear(p.bottom_m, 0.0, p.peak_m, 1.0);
            linear(p.peak_m, 1.0, p.top_m, 0.0);
            break;
        case DensityProfile::Kind::piecewise_linear:
            for (std::size_t i = 1; i < p.knots.size(); ++i)
                linear(p.knots[i - 1].first, std::max(0.0, p.knots[i - 1].second), p.knots[i].first,
                       std::max(0.0, p.knots[i].second));
            break;
        case DensityProfile::Kind::constant: {
            Piece q;
            q.lo = p.bottom_m;
            q.hi = p.top_m > p.bottom_m ? p.top_m : kInf;
            q.c0 = p.value;
            out.pieces.push_back(q);
            break;
        }
    }
    return out;
}

namespace {

// The widest axis in closed form (inner_*); the other two enter through their sum U, whose
// density is known exactly (sum_density): one dimension of Gauss–Legendre over U, split wherever
// the integrand is not smooth — U's density's breakpoints, and where the widest axis' triangle
// meets the ground, the top or a piece's edge with an end or its peak — and into parts growing
// from 2 scale heights at the dense end.
double general(const DensityPieces& prof, double h, const double* w, double reach) {
    const double span = w[0] + w[1];
    if (!(span > 0.0)) {
        const double den = inner_mass(h, w[2]);
        return den > 0.0 ? std::max(0.0, inner_density(prof, h, w[2]) / den) : 0.0;
    }
    double cut[64];
    int nc = 0;
    const auto add = [&](double u) {
        if (u > -span && u < span && nc < 64) cut[nc++] = u;
    };
    cut[nc++] = -span;
    cut[nc++] = span;
    for (double u : {w[0] - w[1], w[1] - w[0], -w[0], w[0], -w[1], w[1], 0.0}) add(u);  // U's density's
    double kmax = 0.0;  // the steepest exponential within reach (1/m)
    const auto kinks_at = [&](double k) {  // altitude k: where the inner triangle's ends and peak meet it
        for (double d : {-w[2], 0.0, w[2]}) add(k - h + d);
    };
    kinks_at(0.0);
    kinks_at(prof.top_m);
    for (const auto& p : prof.pieces) {
        if (p.hi < h - reach || p.lo > h + reach) continue;
        if (std::isfinite(p.lo)) kinks_at(p.lo);
        if (std::isfinite(p.hi)) kinks_at(p.hi);
        if (p.exponential) kmax = std::max(kmax, 1.0 / p.H);
    }
    std::sort(cut, cut + nc);
    double num = 0.0, den = 0.0;
    for (int i = 1; i < nc; ++i) {
        const double a = cut[i - 1], b = cut[i];
        if (!(b > a)) continue;
        // Parts at most 2 scale heights long near the dense (lower) end of U's range, then as
        // long as their distance from it: the exponential has fallen by e⁻² more at each, so a
        // part's share of the error shrinks as fast as its width grows (a 100-km voxel over a
        // 1.2-km layer: ~7 parts across U's range, not 70).
        for (double lo = a; lo < b;) {
            const double step = kmax > 0.0 ? std::max(2.0 / kmax, lo - cut[0]) : b - a;
            const double hi = std::min(b, lo + step);
            const double mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
            lo = hi;
            for (int k = 0; k < 4; ++k) {
                const double u = mid + half * kGlX[k];
                const double wt = half * kGlW[k] * sum_density(u, w[0], w[1]);
                if (!(wt > 0.0)) continue;
                den += wt * inner_mass(h + u, w[2]);
                num += wt * inner_density(prof, h + u, w[2]);
            }
        }
    }
    return den > 0.0 ? std::max(0.0, num / den) : 0.0;
}

}  // namespace

namespace {

struct Hat {
    double w[3];  // the projected half-widths, w[2] the widest
    double reach;
};
Hat hat_of(const Vec3<double>& n, double voxel_m) {
    Hat hat{{std::abs(n.x) * voxel_m, std::abs(n.y) * voxel_m, std::abs(n.z) * voxel_m}, 0.0};
    std::sort(hat.w, hat.w + 3);
    hat.reach = hat.w[0] + hat.w[1] + hat.w[2];
    return hat;
}

// The whole hat where the profile is 0: below the ground, above the top, or outside the pieces
// (the ozone tent's air above 40 km; the nodes above the top that a footprint's reach enumerates).
bool hat_outside(const DensityPieces& prof, double h, double reach) {
    if (!(h + reach > 0.0) || !(h - reach < prof.top_m) || prof.pieces.empty()) return true;
    return !(h + reach > prof.pieces.front().lo) || !(h - reach < prof.pieces.back().hi);
}

}  // namespace

double voxel_average(const DensityPieces& prof, double h, const Vec3<double>& n, double voxel_m) {
    const Hat hat = hat_of(n, voxel_m);
    if (hat_outside(prof, h, hat.reach)) return 0.0;
    double v = 0.0;
    return closed_form(prof, h, hat.reach, hat.w, v) ? v : general(prof, h, hat.w, hat.reach);
}

bool voxel_average_closed_form(const DensityPieces& prof, double h, const Vec3<double>& n, double voxel_m,
                               double& value) {
    const Hat hat = hat_of(n, voxel_m);
    if (hat_outside(prof, h, hat.reach)) {
        value = 0.0;
        return true;
    }
    return closed_form(prof, h, hat.reach, hat.w, value);
}

// ---------------------------------------------------------------------------------------------
// SymmetricAverages

namespace {

constexpr std::uint64_t kEmpty = ~std::uint64_t(0);  // no key: a key has bit 63 clear
constexpr int kKeyBits = 21;
constexpr std::int64_t kKeyRange = std::int64_t(1) << kKeyBits;
constexpr int kShardBits = 6;

std::uint64_t mix(std::uint64_t x) {  // splitmix64's finaliser
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ull;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

}  // namespace

struct alignas(64) SymmetricAverages::Shard {  // a cache line of its own: no false sharing of the locks
    std::mutex mutex;
    std::vector<std::uint64_t> keys;  // kEmpty or a key; linear probing
    std::vector<double> values;       // per slot, one per profile; NaN: not computed yet
    std::size_t size = 0;
};

SymmetricAverages::SymmetricAverages(const Lattice& lattice, const std::vector<DensityPieces>& profiles,
                                     std::size_t max_bytes)
    : lattice_(lattice), profiles_(profiles), max_bytes_(max_bytes), shards_(new Shard[std::size_t(1) << kShardBits]) {
    for (int a = 0; a < 3; ++a) {
        // Whole to rounding (an automatic planet voxel is 2R/k: its quotient may miss k by an
        // ulp); the reflection's offset is then wrong by < 1e-9 voxel, far below the means' error.
        const double m = 2.0 * lattice.centre[a] / lattice.voxel;
        if (std::isfinite(m) && std::abs(m) < double(kKeyRange) && std::abs(m - std::nearbyint(m)) <= 1e-9) {
            symmetric_[std::size_t(a)] = true;
            twice_centre_[std::size_t(a)] = std::int64_t(std::nearbyint(m));
            ++symmetric_axes_;
        }
    }
}

SymmetricAverages::~SymmetricAverages() = default;

std::size_t SymmetricAverages::stored() const {
    std::size_t n = 0;
    for (std::size_t s = 0; s < (std::size_t(1) << kShardBits); ++s) {
        std::lock_guard<std::mutex> lock(shards_[s].mutex);
        n += shards_[s].size;
    }
    return n;
}

void SymmetricAverages::compute(const std::array<std::int64_t, 3>& ijk, std::uint64_t which, double* out) const {
    const Lattice::Voxel x = lattice_.at(lattice_.point(ijk[0], ijk[1], ijk[2]));
    for (std::size_t c = 0; c < profiles_.size(); ++c)
        if (which >> c & 1)
            out[c] = voxel_average(profiles_[c], x.altitude_m, x.up, lattice_.voxel * lattice_.metres_per_unit);
}

void SymmetricAverages::get(const std::array<std::int32_t, 3>& ijk, std::uint64_t which, double* out) {
    which &= profiles_.size() >= 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << profiles_.size()) - 1;
    std::array<std::int64_t, 3> canonical{ijk[0], ijk[1], ijk[2]};
    if (symmetric_axes_ == 0 || which == 0) return compute(canonical, which, out);
    // Reflect each symmetric axis onto its upper half (offset d = |2i − m| ≥ 0, twice the
    // distance from the centre in voxels), then sort the offsets down within each class of
    // axes that a swap maps onto each other (equal parity of m: the same offsets).
    std::array<std::int64_t, 3> d{};
    for (std::size_t a = 0; a < 3; ++a)
        if (symmetric_[a]) d[a] = std::abs(2 * canonical[a] - twice_centre_[a]);
    for (std::int64_t parity = 0; parity < 2; ++parity) {
        std::size_t axes[3];
        std::int64_t vals[3];
        int n = 0;
        for (std::size_t a = 0; a < 3; ++a)
            if (symmetric_[a] && (twice_centre_[a] & 1) == parity) {
                axes[n] = a;
                vals[n++] = d[a];
            }
        std::sort(vals, vals + n, [](std::int64_t x, std::int64_t y) { return x > y; });
        for (int k = 0; k < n; ++k) d[axes[k]] = vals[k];
    }
    std::uint64_t key = 0;
    for (std::size_t a = 0; a < 3; ++a) {
        std::int64_t part;
        if (symmetric_[a]) {
            canonical[a] = (twice_centre_[a] + d[a]) / 2;  // exact: d ≡ m (mod 2)
            part = d[a];
        } else {
            part = canonical[a] + kKeyRange / 2;
        }
        if (part < 0 || part >= kKeyRange) return compute({ijk[0], ijk[1], ijk[2]}, which, out);  // beyond the key
        key |= std::uint64_t(part) << (kKeyBits * int(a));
    }

    const std::size_t nc = profiles_.size();
    const std::uint64_t hash = mix(key);
    Shard& shard = shards_[hash >> (64 - kShardBits)];
    // The slot of `key` in the shard, inserted if `insert` and there is room; npos if not there.
    constexpr std::size_t npos = ~std::size_t(0);
    const auto find = [&](bool insert) -> std::size_t {
        if (shard.keys.empty() || (insert && 10 * (shard.size + 1) > 7 * shard.keys.size())) {
            if (!insert) return npos;
            const std::size_t old_cap = shard.keys.size(), cap = std::max<std::size_t>(64, 2 * old_cap);
            const std::size_t add = (cap - old_cap) * (sizeof(std::uint64_t) + nc * sizeof(double));
            if (bytes_.fetch_add(add) + add > max_bytes_) {  // no room: compute without storing
                bytes_.fetch_sub(add);
                if (shard.keys.empty()) return npos;
            } else {
                std::vector<std::uint64_t> keys;
                std::vector<double> values;
                try {
                    keys.assign(cap, kEmpty);
                    values.assign(cap * nc, std::numeric_limits<double>::quiet_NaN());
                } catch (...) {
                    bytes_.fetch_sub(add);
                    throw;
                }
                for (std::size_t s = 0; s < old_cap; ++s) {
                    if (shard.keys[s] == kEmpty) continue;
                    std::size_t t = mix(shard.keys[s]) & (cap - 1);
                    while (keys[t] != kEmpty) t = (t + 1) & (cap - 1);
                    keys[t] = shard.keys[s];
                    std::copy_n(shard.values.begin() + std::ptrdiff_t(s * nc), nc, values.begin() + std::ptrdiff_t(t * nc));
                }
                shard.keys.swap(keys);
                shard.values.swap(values);
            }
        }
        const std::size_t cap = shard.keys.size();
        std::size_t s = hash & (cap - 1);
        while (shard.keys[s] != key) {
            if (shard.keys[s] == kEmpty) {
                if (!insert || 10 * (shard.size + 1) > 9 * cap) return npos;  // full at the byte limit
                shard.keys[s] = key;
                ++shard.size;
                return s;
            }
            s = (s + 1) & (cap - 1);
        }
        return s;
    };
    std::uint64_t missing = 0;
    {
        std::lock_guard<std::mutex> lock(shard.mutex);
        std::size_t s = find(false);  // a hit neither grows the shard nor counts bytes
        if (s == npos) s = find(true);
        if (s == npos) {
            missing = which;
        } else {
            for (std::size_t c = 0; c < nc; ++c)
                if (which >> c & 1) {
                    const double v = shard.values[s * nc + c];
                    if (std::isnan(v)) missing |= std::uint64_t(1) << c;
                    else out[c] = v;
                }
        }
    }
    if (missing == 0) return;
    compute(canonical, missing, out);  // outside the lock: the quadrature is the cost
    std::lock_guard<std::mutex> lock(shard.mutex);
    if (const std::size_t s = find(false); s != npos)
        for (std::size_t c = 0; c < nc; ++c)
            if (missing >> c & 1) shard.values[s * nc + c] = out[c];
}

}  // namespace airmass::detail
