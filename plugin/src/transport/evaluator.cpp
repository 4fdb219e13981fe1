// The evaluator (evaluator.hpp): single scattering, plus the multiple-scattering tables'
// radiance added once here, the sun light through the one sun-ray computation, and the
// tables' precompute with the library's progress/cancel hooks.
#include "airmass/evaluator.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "airmass/optical_depth.hpp"
#include "airmass/parallel.hpp"
#include "airmass/spectrum.hpp"
#include "airmass/table_store.hpp"

namespace airmass {

namespace {

void check_tables(const Atmosphere& atm, const MultipleScattering& ms) {
    if (ms.empty() || ms.wavelength_count != atm.wavelength_count() || ms.slot.size() != atm.constituents.size())
        throw std::invalid_argument(
            "multiple-scattering tables: computed for " + std::to_string(ms.wavelength_count) + " wavelengths and " +
            std::to_string(ms.slot.size()) + " constituents, the atmosphere has " +
            std::to_string(atm.wavelength_count()) + " and " + std::to_string(atm.constituents.size()) +
            " (compute them for the same scene, wavelengths and settings)");
}

// Per-call scratch for the multiple-scattering parts: on the stack up to 64 wavelengths.
struct MsScratch {
    static constexpr std::size_t kStack = 64;
    double stack[3 * kStack];
    std::vector<double> heap;
    std::span<double> rayleigh, mie, total;
    explicit MsScratch(std::size_t nw) {
        double* p = stack;
        if (nw > kStack) {
            heap.resize(3 * nw);
            p = heap.data();
        }
        rayleigh = {p, nw};
        mie = {p + nw, nw};
        total = {p + 2 * nw, nw};
    }
};

}  // namespace

Evaluator::Evaluator(Atmosphere atmosphere) : atmosphere_(std::move(atmosphere)) {}

Evaluator::Evaluator(Atmosphere atmosphere, std::shared_ptr<const MultipleScattering> tables, int ms_view_samples)
    : atmosphere_(std::move(atmosphere)), tables_(std::move(tables)), ms_view_samples_(ms_view_samples) {
    if (tables_) check_tables(atmosphere_, *tables_);
    if (ms_view_samples_ < 1 || ms_view_samples_ > 100000)
        throw std::invalid_argument("multiple.view_samples = " + std::to_string(ms_view_samples_) +
                                    ": must be in [1, 100000]");
}

void Evaluator::radiance(const ViewRay& ray, RadianceOut out, const MsRadianceOut* multiple) const {
    single_scattering(atmosphere_, ray, out);
    const std::size_t nw = wavelength_count();
    if (!tables_) {
        if (multiple) {
            std::fill_n(multiple->multiple_rayleigh.begin(), nw, 0.0);
            std::fill_n(multiple->multiple_mie.begin(), nw, 0.0);
            std::fill_n(multiple->multiple.begin(), nw, 0.0);
        }
        return;
    }
    MsScratch scratch(multiple ? 0 : nw);
    const MsRadianceOut parts = multiple ? *multiple : MsRadianceOut{scratch.rayleigh, scratch.mie, scratch.total};
    multiple_scattering_radiance(atmosphere_, *tables_, ray, parts, ms_view_samples_);
    SpectrumView<double>(out.radiance.first(nw)) += parts.multiple.first(nw);
}

void Evaluator::radiance(double altitude_m, Vec3<double> sun, std::span<const Vec3<double>> dirs,
                         RadianceOut out, const MsView* view, std::span<double> multiple_inscatter) const {
    single_scattering_batch(atmosphere_, altitude_m, sun, dirs, out);
    if (!multiple_inscatter.empty()) std::fill_n(multiple_inscatter.begin(), dirs.size() * wavelength_count(), 0.0);
    if (!tables_) return;
    const std::size_t nw = wavelength_count();
    if (view && (view->altitude_m != altitude_m || view->sun.x != sun.x || view->sun.y != sun.y ||
                 view->sun.z != sun.z || std::size_t(view->grid.channels) != 2 * nw))
        throw std::invalid_argument("multiple-scattering view: made for another observer, sun or wavelength count");
    MsScratch scratch(nw);
    for (std::size_t k = 0; k < dirs.size(); ++k) {
        const std::span<double> inscatter =
            multiple_inscatter.empty() ? std::span<double>{} : multiple_inscatter.subspan(k * nw, nw);
        if (view) {
            view->lookup(dirs[k], out.transmittance.subspan(k * nw, nw), scratch.total, inscatter);
        } else {
            multiple_scattering_radiance(atmosphere_, *tables_, ViewRay{altitude_m, dirs[k], sun},
                                         {scratch.rayleigh, scratch.mie, scratch.total}, ms_view_samples_);
            if (!inscatter.empty()) add(inscatter, scratch.rayleigh, scratch.mie);
        }
        SpectrumView<double>(out.radiance.subspan(k * nw, nw)) += scratch.total;
    }
}

void MsView::lookup(Vec3<double> d, std::span<const double> T, std::span<double> out,
                    std::span<double> inscatter) const {
    const std::size_t nw = std::size_t(grid.channels) / 2;
    SkyGrid::Cell cell;
    const double theta = std::acos(std::clamp(d.z / std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z), -1.0, 1.0));
    if (!grid.cell(theta, std::atan2(d.y, d.x), cell)) {
        std::fill_n(out.begin(), nw, 0.0);
        std::fill(inscatter.begin(), inscatter.end(), 0.0);
        return;
    }
    double stack[2 * 64];
    std::vector<double> heap;
    double* v = stack;
    if (nw > 64) {
        heap.resize(2 * nw);
        v = heap.data();
    }
    grid.interpolate(cell, std::span<double>(v, 2 * nw));
    for (std::size_t w = 0; w < 2 * nw; ++w) v[w] = std::max(v[w], 0.0);  // a cubic's overshoot is no light
    for (std::size_t w = 0; w < nw; ++w) out[w] = v[w] * (1.0 - T[w]) + v[nw + w] * T[w];
    for (std::size_t w = 0; w < inscatter.size(); ++w) inscatter[w] = v[w] * (1.0 - T[w]);
}

Horizon Evaluator::horizon(double altitude_m) const {
    if (!(std::isfinite(altitude_m) && altitude_m >= 0.0))
        throw std::invalid_argument("observer altitude_m = " + std::to_string(altitude_m) +
                                    ": must be finite and >= 0 (above the ground)");
    return Horizon::of(atmosphere_.planet_radius_m, atmosphere_.top_altitude_m, altitude_m, atmosphere_.knots_m);
}

MsView Evaluator::ms_view(double altitude_m, Vec3<double> sun, int intervals, int threads,
                          const RenderHooks& hooks) const {
    if (intervals < 2 || intervals > 16384)
        throw std::invalid_argument("multiple-scattering view: intervals = " + std::to_string(intervals) +
                                    ": must be in [2, 16384]");
    const std::size_t nw = wavelength_count();
    const Horizon hz = horizon(altitude_m);
    MsView view{altitude_m, sun,
                SkyGrid::make(SkyGridLayout::view(intervals), hz, sun, int(2 * nw), false)};
    if (!tables_) return view;
    SkyGrid& g = view.grid;
    // A row at the zenith or the nadir is one direction in every column (to 1e-16 at the
    // nadir, whose sin θ rounds to 1.2e-16): its column 0 is integrated and copied.
    std::vector<unsigned char> polar(std::size_t(g.rows()), 0);
    for (int k = 0; k < g.rows(); ++k) polar[std::size_t(k)] = std::abs(std::sin(g.row_theta(k))) < 1e-12;
    // A row's rays share their zenith angle, so one quadrature serves the row
    // (multiple_scattering_radiance_row) and one view transmittance T (T depends on the
    // zenith angle alone).
    parallel_for(0, std::size_t(g.rows()), 1, threads, [&](std::size_t b, std::size_t e, int) {
        const std::size_t cols = std::size_t(g.columns());
        std::vector<Vec3<double>> dirs(cols);
        std::vector<double> T(nw), rayleigh(cols * nw), mie(cols * nw), total(cols * nw);
        for (std::size_t kk = b; kk < e; ++kk) {
            if (hooks.cancel && hooks.cancel->requested()) return;
            const int k = int(kk);
            const std::size_t n = polar[kk] ? 1 : cols;
            for (std::size_t j = 0; j < n; ++j) dirs[j] = g.node_direction(k, int(j));
            // Its view transmittance only (the numbers single scattering would give, without
            // the in-scatter it would also integrate).
            view_transmittance_batch(atmosphere_, altitude_m, std::span<const Vec3<double>>(dirs.data(), 1), T);
            multiple_scattering_radiance_row(atmosphere_, *tables_, altitude_m,
                                             std::span<const Vec3<double>>(dirs.data(), n), sun,
                                             {rayleigh, mie, total}, ms_view_samples_);
            for (std::size_t j = 0; j < n; ++j) {
                double* node = g.at(k, int(j));
                const std::size_t o = j * nw;
                for (std::size_t w = 0; w < nw; ++w) {
                    const double inscatter = rayleigh[o + w] + mie[o + w];
                    const double ground = total[o + w] - inscatter;
                    node[w] = 1.0 - T[w] > 1e-12 ? inscatter / (1.0 - T[w]) : 0.0;
                    node[nw + w] = T[w] > 1e-300 ? ground / T[w] : 0.0;
                }
            }
        }
    });
    if (hooks.cancel && hooks.cancel->requested()) throw Cancelled("multiple-scattering view: cancelled");
    for (int k = 0; k < g.rows(); ++k)
        if (polar[std::size_t(k)])
            for (int j = 1; j < g.columns(); ++j) std::copy_n(g.at(k, 0), 2 * nw, g.at(k, j));
    return view;
}

void Evaluator::aerial_perspective(Vec3<double> from_m, Vec3<double> to_m, Vec3<double> sun, bool to_infinity,
                                   std::span<double> T, std::span<double> S) const {
    airmass::aerial_perspective(atmosphere_, from_m, to_m, sun, to_infinity, T, S);
}

void Evaluator::transmittance(const PlanetRay<double>& ray, double t0, double t1, std::span<double> out) const {
    airmass::transmittance(atmosphere_, ray, t0, t1, out);
}

bool Evaluator::sun_light(double altitude_m, ZenithAngle<double> sun_zenith, std::span<double> out) const {
    const bool lit = sun_transmittance(atmosphere_, altitude_m, sun_zenith, out);
    SpectrumView<double>(out.first(wavelength_count())) *= atmosphere_.sun_irradiance;
    return lit;
}

std::shared_ptr<const MultipleScattering> compute_tables(const Atmosphere& atmosphere,
                                                         const MultipleScatteringOptions& options, int threads,
                                                         const RenderHooks& hooks, std::size_t units,
                                                         std::size_t total) {
    MsSettings m = options.tables;
    m.threads = threads;  // the consumer's one thread count
    if (!m.cancel) m.cancel = hooks.cancel;
    // Called from the calling thread only (multiple_scattering.hpp), so plain state is enough.
    std::size_t reported = 0;
    const auto user = options.tables.progress;
    m.progress = [&, user](double fraction, int order) {
        if (user) user(fraction, order);
        const auto now = static_cast<std::size_t>(std::clamp(fraction, 0.0, 1.0) * double(units));
        if (now > reported && hooks.work_done) hooks.work_done(now - reported, total);
        reported = std::max(reported, now);
    };
    // A store keeps the tables between calls; diagnostics (keep_radiance) are never kept.
    TableStore* store = m.keep_radiance ? nullptr : m.store;
    std::string key;
    if (store) {
        key = ms_table_key(atmosphere, m);
        if (auto kept = store->load(key)) {
            if (units > 0 && hooks.work_done) hooks.work_done(units, total);
            return kept;
        }
    }
    auto ms = std::make_shared<MultipleScattering>(precompute_multiple_scattering(atmosphere, m));
    if (units > reported && hooks.work_done) hooks.work_done(units - reported, total);
    if (store) store->store(key, *ms);
    return ms;
}

Evaluator make_evaluator(Atmosphere atmosphere, const MultipleScatteringOptions& options, int threads,
                         const RenderHooks& hooks, std::shared_ptr<const MultipleScattering> tables, std::size_t units,
                         std::size_t total) {
    if (!options.enabled) return Evaluator(std::move(atmosphere));
    if (!tables) tables = compute_tables(atmosphere, options, threads, hooks, units, total);
    return Evaluator(std::move(atmosphere), std::move(tables), options.view_samples);
}

}  // namespace airmass
