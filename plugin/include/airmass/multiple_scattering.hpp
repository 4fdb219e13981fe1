// Multiple scattering: light that reaches a point of the atmosphere after at least one
// scattering event or ground reflection, tabulated once per atmosphere and then added
// along view rays as an extra in-scattering source.
//
// Equations (seed 004 §2.2, Bruneton & Neyret 2008 / Bruneton 2017, Golubev Eq. 7), per
// wavelength and per unit top-of-atmosphere solar irradiance. Directions are *look*
// directions: L(x, v) is the radiance seen from x looking along v (it travels along −v);
// mu = cos(view zenith), mu_s = cos(sun zenith), nu = v·s; the phase argument is the cosine
// between the look directions, as in phase.hpp.
//
//   order 1   J¹(y, v) = Σ_i σs_i ρ_i(y) P_i(v·s) T_sun(y)                           (single scattering)
//   order k   L^k(x, v) = ∫_0^{t_end} T(x, y) J^k(y, v) dt  +  [ground] T(x, g) a/π E^{k−1}(g)   (transport)
//             E^k(g)    = ∫_{μ>0} L^k(g, ω) μ dω,   E⁰(g) = μ_s T_sun(g)                 (ground irradiance)
//             G_i^{k+1}(x, v) = ∫_{4π} P_i(ω·v) L^k(x, ω) dω                             (gather)
//             J^{k+1}(y, v) = Σ_i σs_i ρ_i(y) G_i^{k+1}(y, v)
//
// What the tables hold, and what a view-ray integrator adds:
//
//   G_i(x, v) = Σ_{k≥2} G_i^k(x, v)    [sr⁻¹, per unit irradiance]   (ms_phase_radiance)
//   E_ms(μs)  = Σ_{k≥1} E^k(ground)    [per unit irradiance]         (ms_ground_irradiance)
//
// G_i takes exactly the place of the single-scattering factor P_i(ν)·T_sun(x): a sample of
// constituent i at x along a view ray contributes
//
//   E_sun(λ) σs_i(λ) ρ_i(h) T(x0 → x) · [P_i(ν) T_sun(x) + G_i(h, μ, μ_s, ν)] dt,
//
// over the *whole* view segment (multiple scattering also lights Earth's shadow), and a view
// ray that ends on the ground adds E_sun a/π E_ms(μ_s at the ground) T(x0 → ground).
// `multiple_scattering_radiance` does exactly that integral for one view ray.
//
// Two modes (MsMode):
//   * orders — the orders of scattering above, on a 4-D grid (altitude, view zenith, sun
//     zenith, sun–view azimuth), up to order K (or until the next order adds < `tolerance`),
//     optionally completed by the geometric tail G^K q/(1 − q). The gather is a circular
//     convolution in azimuth, done per Fourier mode with a phase matrix integrated over the
//     cells of the grid (docs/multiple_scattering.md).
//   * isotropic_lut — Hillaire 2020 (EGSR, "A Scalable and Production Ready Sky and
//     Atmosphere Rendering Technique" §5.5): a 2-D table Ψ(altitude, sun zenith) of the
//     infinite-order isotropic multiple scattering, Ψ = L₂/(1 − f_ms), with L₂ the mean over
//     the sphere of single-scattered light (and the sunlit ground) and f_ms the fraction of
//     an isotropic unit source that scatters again; G_i = Ψ for every constituent.
//
// Tables are parameterised per seed 004 (altitude, view zenith, sun zenith, azimuth) with a
// choice of non-linear mappings (MsParameterisation); transmittance is the Chapman /
// closed-form optical depth of optical_depth.hpp everywhere. Nothing is Earth-specific:
// the mappings depend only on the planet radius and the top of the atmosphere.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "airmass/atmosphere.hpp"
#include "airmass/geometry.hpp"
#include "airmass/progress.hpp"
#include "airmass/single_scattering.hpp"

namespace airmass {

class TableStore;  // table_store.hpp

enum class MsMode {
    orders,         // orders of scattering on a 4-D table
    isotropic_lut,  // Hillaire 2020: 2-D isotropic table, infinite orders by 1/(1 − f_ms)
};

// How grid nodes are placed (docs/multiple_scattering.md compares them):
enum class MsParameterisation {
    // altitude: ρ = sqrt(r² − R²) uniform (Bruneton; ≈ seed 004's sqrt(h));
    // view zenith: split at the horizon μ_h(r) = −sqrt(1 − R²/r²), each half quadratic in
    // its distance to the horizon (nodes dense at the horizon, never degenerate at the
    // ground); sun zenith: Bruneton 2017's mapping with this planet's μs_min.
    horizon,
    // as `horizon` but the view zenith uses Bruneton 2017's distance-to-boundary mapping.
    bruneton,
    // seed 004 as printed: u = sqrt(h/h_top), v = ½(1 + sign(μ)|μ|^⅓), w likewise for μs
    // over [−1, 1]; no horizon split.
    seed004,
};

std::string_view ms_mode_name(MsMode m);
std::string_view ms_parameterisation_name(MsParameterisation p);

// Grid sizes. Orders: altitude × view_zenith × sun_zenith × azimuth nodes (view_zenith
// even for the split mappings; azimuth 1 = azimuth-averaged, a 3-D table; azimuth 0 =
// automatic: 12 when some constituent's forward scattering matters — g·τ_s > 0.05 for its
// vertical scattering optical depth τ_s at some wavelength and |g| > 0.3 — else 6; measured
// in docs/multiple_scattering.md).
struct MsTableSize {
    int altitude = 12;
    int view_zenith = 32;
    int sun_zenith = 24;
    int azimuth = 0;
};

// The azimuth node count `azimuth = 0` resolves to for this atmosphere.
int ms_automatic_azimuth_nodes(const Atmosphere& atmosphere);

struct MsSettings {
    MsMode mode = MsMode::orders;
    MsParameterisation parameterisation = MsParameterisation::horizon;
    // orders: the 4-D table; isotropic_lut: altitude × sun_zenith is the Ψ table and
    // view_zenith × azimuth the directions its sphere integral uses.
    MsTableSize table{};
    // Highest scattering order K in the result (≥ 2), or 0: automatic, at most `max_auto_order`.
    // The automatic rule works on sums over the grid's nodes (max over wavelengths):
    //   with geometric_tail — stop after the first order K ≥ 4 at which, for every sun-zenith
    //     node c (those with more than 1e-9 of the brightest node's light), the tail-corrected
    //     total S_K = Σ_{k≤K} L^k + L^K q/(1 − q), q = L^K/L^{K−1} summed over c's nodes, changes
    //     by less than `tolerance` of itself from S_{K−1}. The orders fall geometrically (ratio
    //     0.5–0.7 in the presets), so S_K settles in fewer orders than the plain sum does (Earth
    //     at 48 wavelengths: 8 instead of 11), within 0.06 % of the converged sum down to sun
    //     −12° (docs/multiple_scattering.md). The tail's q is likewise per sun-zenith node;
    //   without it — stop after the first order whose radiance adds less than `tolerance` of the
    //     total so far (over all nodes).
    int max_order = 0;
    double tolerance = 2e-4;
    int max_auto_order = 60;
    // Add the geometric remainder Σ_{k>K} ≈ G^K q/(1 − q), q the per-wavelength ratio of the
    // last two orders (≥ 3 orders computed).
    bool geometric_tail = true;
    // Quadrature intervals along each table ray: for order 1 (the sunlight, which changes
    // fastest along a ray at twilight; transport_order1) and for the transport of every later
    // order. Their error against 128 for both (`bench_ms`: earth, 48 λ, 288 view rays from the
    // ground to 400 km, sun 60° … −12°; |Δ multiple| / total; docs/multiple_scattering.md):
    // 16 / 16 with order 1 at each interval's midpoint (before 2026-12-03) 7.3 % p95, 20 % max;
    // 32 / 8 2.2 % p95, 4.4 % max, and 12 % less CPU time.
    int order1_ray_samples = 32;
    int ray_samples = 8;
    // Sun transmittance table used by order 1 (altitude × sun zenith nodes).
    int transmittance_altitude = 32;
    int transmittance_sun = 128;
    // Sub-cells per grid cell and axis when integrating peaked phase functions (|g| > 0.3)
    // over the direction cells of the gather.
    int phase_subsamples = 4;
    // 0: all hardware threads. Read by precompute_multiple_scattering; compute_tables (every
    // consumer's path, evaluator.hpp) sets it from the consumer's own `threads`.
    int threads = 0;
    // Keep Σ_k L^k on the grid (diagnostics: flux balance). Costs one more table.
    bool keep_radiance = false;
    // Orders that repeat the previous one bit for bit (MultipleScattering::repeats_after_order)
    // are added without being recomputed; false computes every order (the same values, slower:
    // the check that they are the same).
    bool skip_repeated_orders = true;
    // Called from the calling thread between stages: (fraction done estimate, current order).
    std::function<void(double fraction, int order)> progress;
    const CancelFlag* cancel = nullptr;  // polled per ray; Cancelled is thrown
    // Where the host keeps tables between calls (table_store.hpp: the CLI's disk cache, the
    // add-on's memory), or null. compute_tables (evaluator.hpp) asks it before computing and
    // gives it what it computed; precompute_multiple_scattering itself never looks at it.
    TableStore* store = nullptr;
};

// The grid: node positions and the mappings between physical parameters and continuous
// node coordinates (0 … n−1). All functions are pure.
struct MsGrid {
    MsParameterisation parameterisation = MsParameterisation::horizon;
    MsTableSize size{};
    double planet_radius_m = 6360e3;
    double top_radius_m = 6420e3;
    double mu_s_min = -0.2;  // lowest tabulated sun zenith cosine (below it: no light)

    static MsGrid make(const Atmosphere& atmosphere, MsParameterisation p, MsTableSize size);

    bool split_view() const { return parameterisation != MsParameterisation::seed004; }
    double horizon_mu(double r_m) const;  // −sqrt(1 − R²/r²), 0 at and below the ground

    double altitude_node_m(int a) const;
    double altitude_coord(double altitude_m) const;  // continuous, clamped to [0, n−1]
    double view_node_mu(int a, int b) const;         // μ of node b at altitude node a
    // μ at continuous coordinate s (inside one half for the split mappings) and radius r.
    double view_mu(double r_m, double s) const;
    // Continuous coordinate of μ at radius r; `ground` says which half (split mappings).
    double view_coord(double r_m, double mu, bool ground) const;
    double sun_node_mu(int c) const;
    double sun_coord(double mu_s) const;
    double azimuth_node_rad(int d) const;
    double azimuth_coord(double phi_rad) const;

    std::size_t node_count() const {
        return std::size_t(size.altitude) * size.view_zenith * size.sun_zenith * size.azimuth;
    }
};

struct MsOrderInfo {
    int order = 0;
    // Per wavelength: Σ_nodes L^k / Σ_nodes Σ_{j≤k} L^j (the order's share of the radiance
    // on the grid), and its maximum over wavelengths.
    std::vector<double> relative;
    double max_relative = 0.0;
    // max over wavelengths of |S_K − S_{K−1}| / S_K, S the tail-corrected total (MsSettings::
    // max_order); 0 where it is not defined (K < 4 or no tail).
    double tail_corrected_change = 0.0;
};

// An immutable array of floats whose memory is shared by every copy: the G table of
// MultipleScattering. Either its own (made from a vector: a precompute) or memory another
// object owns and this array keeps alive — a table-cache entry mapped from disk, read in place
// rather than copied into fresh pages (table_store.hpp deserialize_tables): a 10 MB table is
// then one checksum pass, not also a copy and the kernel's zeroing of 10 MB of new pages.
class SharedFloats {
public:
    using value_type = float;
    using iterator = const float*;
    using const_iterator = const float*;

    SharedFloats() = default;
    explicit SharedFloats(std::vector<float> values);
    // `count` floats at `data`, which stay valid while `owner` lives.
    SharedFloats(const float* data, std::size_t count, std::shared_ptr<const void> owner)
        : owner_(std::move(owner)), data_(data), size_(count) {}

    const float* data() const { return data_; }
    std::size_t size() const { return size_; }
    bool empty() const { return size_ == 0; }
    const float& operator[](std::size_t i) const { return data_[i]; }
    const float* begin() const { return data_; }
    const float* end() const { return data_ + size_; }
    // Element by element (not the same memory).
    friend bool operator==(const SharedFloats& a, const SharedFloats& b);

private:
    std::shared_ptr<const void> owner_;
    const float* data_ = nullptr;
    std::size_t size_ = 0;
};

// The precomputed multiple scattering of one Atmosphere (same wavelengths). A value type;
// lookups are const and thread-safe.
struct MultipleScattering {
    MsMode mode = MsMode::orders;
    MsGrid grid;
    std::size_t wavelength_count = 0;
    double ground_albedo = 0.0;
    // For each constituent of the Atmosphere: its slot in the G table, or −1 if it does not scatter.
    std::vector<int> slot;
    std::size_t slot_count = 0;
    // orders: G[node][slot][λ]; isotropic_lut: Ψ[altitude][sun][λ] (one slot). ln of the values.
    SharedFloats phase_radiance;
    std::vector<float> ground_irradiance;  // E_ms[sun][λ]
    std::vector<float> radiance;           // Σ L^k[node][λ] when MsSettings::keep_radiance
    std::vector<MsOrderInfo> orders;        // orders 2 … K computed (order 1 is exact)
    int highest_order = 1;                  // K
    // 0, or k: order k's gather gave back, bit for bit, the state order k started from (ln G^k
    // and E^{k−1}: every G at the floor of the logarithm, E settled), so orders k + 1 … K
    // repeat order k exactly and were added without being recomputed (the result is the same,
    // value for value; fixed max_order only stops being slow).
    int repeats_after_order = 0;
    bool tail_added = false;
    std::vector<double> tail_ratio;         // q per sun-zenith node and wavelength ([c · nw + λ]) when the tail was added
    double precompute_seconds = 0.0;

    bool empty() const { return phase_radiance.empty(); }
    // Bytes of the tables a renderer keeps (G or Ψ, and E_ms).
    std::size_t table_bytes() const {
        return (phase_radiance.size() + ground_irradiance.size()) * sizeof(float);
    }
};

// Throws std::invalid_argument naming the field, value and allowed range.
void validate(const MsSettings& settings);

// How a consumer adds the multiple-scattering part (evaluator.hpp make_evaluator): whether at
// all, its tables and the quadrature along each view ray. The one struct every consumer holds
// (SkySettings::multiple, RenderSettings::multiple, `airmass eval`, the C ABI); each consumer
// keeps its own default for `enabled` (sky on, render off). The consumer's `threads` runs the
// table precompute too (tables.threads is for precompute_multiple_scattering called directly).
struct MultipleScatteringOptions {
    bool enabled = true;
    MsSettings tables{};
    int view_samples = 32;  // quadrature intervals per view ray (multiple_scattering_radiance)
};

// Thread-safe (no shared state); TBB-parallel. Throws Cancelled if settings.cancel is set.
MultipleScattering precompute_multiple_scattering(const Atmosphere& atmosphere, const MsSettings& settings = {});

// Diagnostic: power leaving through the top of the atmosphere over the intercepted solar
// power π r_top² E_sun, per wavelength: (2/E_sun) ∫ F_out(μs) dμs, F_out the outward flux
// of scattered and reflected light at the top node (from the radiance kept on the grid:
// orders mode with MsSettings::keep_radiance), plus — when `atmosphere` is given — the
// sunlight that crosses the shell without any event, (2/r_top²) ∫_R^{r_top} T_line(p) p dp.
// With it, exactly 1 for a purely scattering atmosphere over an albedo-1 ground.
std::vector<double> ms_energy_balance(const MultipleScattering& ms, const Atmosphere* atmosphere = nullptr);

// ---- per-sample lookups ---------------------------------------------------------------------

// Where and how a view sample looks: altitude above the ground and the three cosines at
// that point (view zenith, sun zenith, view·sun).
struct MsPoint {
    double altitude_m = 0.0;
    double mu = 1.0;
    double mu_s = 1.0;
    double nu = 1.0;

    // From a planet-centred position (metres) and unit view / sun directions.
    static MsPoint from_vectors(double planet_radius_m, Vec3<double> position_m, Vec3<double> view,
                                Vec3<double> sun);
};

// G_i at the point, per wavelength (out.size() = wavelength_count): the phase-weighted
// multiply-scattered radiance per unit solar irradiance, sr⁻¹ — the term that goes beside
// P_i(ν)·T_sun. Zero for a constituent that does not scatter. `constituent` indexes
// Atmosphere::constituents.
void ms_phase_radiance(const MultipleScattering& ms, std::size_t constituent, const MsPoint& point,
                       std::span<double> out);

// E_ms per wavelength at a ground point whose sun zenith cosine is mu_s (per unit irradiance).
void ms_ground_irradiance(const MultipleScattering& ms, double mu_s, std::span<double> out);

// ---- along a view ray ---------------------------------------------------------------------

// Outputs per wavelength (E_sun applied, W m⁻² sr⁻¹ nm⁻¹ for E_sun in W m⁻² nm⁻¹).
struct MsRadianceOut {
    std::span<double> multiple_rayleigh;  // ∫ T σs_i ρ_i G_i dt over Rayleigh-like constituents
    std::span<double> multiple_mie;       // … over the others
    std::span<double> multiple;           // both + [ground] T a/π E_ms
    // Optional (may be empty): order 1 by the same quadrature (in-scatter + directly lit
    // ground), for cross-checks against single_scattering.
    std::span<double> single = {};
};

// Multiple scattering seen along one view ray (observer anywhere: on the ground, inside, or
// above the atmosphere). `samples` quadrature intervals along the ray (≥ 1).
void multiple_scattering_radiance(const Atmosphere& atmosphere, const MultipleScattering& ms, const ViewRay& ray,
                                  MsRadianceOut out, int samples = 32);

// The same for n view rays from one observer that share one view zenith angle — a row of a
// sun-aligned grid (Evaluator::ms_view). The quadrature along a ray depends on the altitude and
// the zenith angle alone, so it is built once for the row (from its first ray) and each ray adds
// only its own lookups: per ray about half the work of multiple_scattering_radiance (docs/sky.md).
// Every ray's cos(zenith) must equal that of the first ray of finite, non-zero length to
// 1e-12 (std::invalid_argument naming the ray otherwise; a ray of zero, infinite or NaN
// length gets 0, as alone); out spans hold n × wavelength_count() values, ray-major. The
// values are those of n calls of multiple_scattering_radiance, but for the rounding of the
// directions (≤ 2e-7 relative measured: the weights are float).
void multiple_scattering_radiance_row(const Atmosphere& atmosphere, const MultipleScattering& ms, double altitude_m,
                                      std::span<const Vec3<double>> view_directions, Vec3<double> sun_direction,
                                      MsRadianceOut out, int samples = 32);

}  // namespace airmass
