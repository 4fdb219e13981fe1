#include "ms_options.hpp"

#include <cmath>
#include <stdexcept>

#include "commands.hpp"
#include "csv.hpp"

namespace airmass::cli {

void add_ms_options(CLI::App* cmd, MsCliOptions& o, int max_samples) {
    cmd->add_option("--ms-mode", o.mode, "Multiple-scattering tables: orders or isotropic_lut")
        ->check(CLI::IsMember({"orders", "isotropic_lut"}))
        ->capture_default_str();
    cmd->add_option("--ms-orders", o.orders,
                    "Highest scattering order K of the orders tables, in [2, 1000]; 0: until an order adds < 0.1 %")
        ->check(int_in(0, 1000))  // and not 1: apply_ms_options
        ->capture_default_str();
    cmd->add_option("--ms-samples", o.samples, "Multiple-scattering quadrature intervals per view ray")
        ->check(int_in(1, max_samples))
        ->capture_default_str();
    cmd->add_option("--ms-table", o.table,
                    "Table nodes ALTITUDE,VIEW_ZENITH,SUN_ZENITH,AZIMUTH (azimuth 0: automatic) "
                    "[default: 12,32,24,0; the error and cost of others: docs/multiple_scattering.md]");
    cmd->add_flag("--no-cache", o.no_cache,
                  "Compute the multiple-scattering tables afresh and do not keep them (the cache: "
                  "$AIRMASS_CACHE_DIR, else $XDG_CACHE_HOME/airmass or ~/.cache/airmass; docs/sky.md)");
}

std::string table_cache_summary(const MsCliOptions& o) {
    if (!o.store) return "tables computed (--no-cache)";
    switch (o.store->last_load()) {
        case DiskTableStore::Outcome::hit: return "tables from the cache";
        case DiskTableStore::Outcome::rejected: return "tables computed, a bad cache entry replaced";
        case DiskTableStore::Outcome::miss:
            return o.store->last_problem().empty() ? "tables computed and cached"
                                                   : "tables computed, not cached: " + o.store->last_problem();
        case DiskTableStore::Outcome::none: break;
    }
    return "tables not used";
}

void apply_ms_options(const std::string& command, MsCliOptions& o, MultipleScatteringOptions& options,
                      int max_samples) {
    MsSettings& s = options.tables;
    s.mode = o.mode == "isotropic_lut" ? MsMode::isotropic_lut : MsMode::orders;
    if (!(o.orders == 0 || (o.orders >= 2 && o.orders <= 1000)))
        throw CliError(command + ": --ms-orders " + std::to_string(o.orders) + ": must be 0 (automatic) or in [2, 1000]");
    s.max_order = o.orders;
    if (o.samples < 1 || o.samples > max_samples)
        throw CliError(command + ": --ms-samples " + std::to_string(o.samples) + ": must be in [1, " +
                       std::to_string(max_samples) + "]");
    options.view_samples = o.samples;
    if (!o.table.empty()) {
        const auto n = parse_number_list(o.table, command + ": --ms-table", "a whole number of nodes",
                                         [](double v) { return v >= 0.0 && v <= 1e6 && v == std::floor(v); });
        if (n.size() != 4)
            throw CliError(command + ": --ms-table '" + o.table +
                           "': give four node counts ALTITUDE,VIEW_ZENITH,SUN_ZENITH,AZIMUTH");
        s.table = {int(n[0]), int(n[1]), int(n[2]), int(n[3])};
    }
    try {
        validate(s);
    } catch (const std::invalid_argument& e) {
        throw CliError(command + ": --ms-table: " + e.what());  // --ms-orders is checked above
    }
    o.store = o.no_cache ? nullptr
                         : std::make_shared<DiskTableStore>(default_table_cache_dir(), default_table_cache_max_bytes());
    s.store = o.store.get();
}

}  // namespace airmass::cli
