// The multiple-scattering options `airmass sky`, `airmass eval` and `airmass render` share
// (docs/multiple_scattering.md): one definition of the flags, their ranges and messages.
#pragma once

#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "airmass/multiple_scattering.hpp"
#include "airmass/table_cache.hpp"

namespace airmass::cli {

struct MsCliOptions {
    std::string mode = std::string(ms_mode_name(MsSettings{}.mode));
    int orders = MsSettings{}.max_order;
    int samples = MultipleScatteringOptions{}.view_samples;  // quadrature intervals per view ray
    std::string table;  // "ALTITUDE,VIEW,SUN,AZIMUTH" node counts; empty: MsTableSize's defaults
    bool no_cache = false;  // --no-cache: neither read nor write the table cache
    // The disk cache the command's tables go through (set by apply_ms_options unless
    // --no-cache); its last_load() says whether the tables were read from it.
    std::shared_ptr<DiskTableStore> store;
};

// "tables from the cache", "tables computed and cached", "tables computed (--no-cache)": for
// the commands' summary lines.
std::string table_cache_summary(const MsCliOptions& options);

// --ms-mode, --ms-orders, --ms-samples (in [1, max_samples]), --ms-table, --no-cache.
void add_ms_options(CLI::App* cmd, MsCliOptions& options, int max_samples);

// Checks the options and writes them into `settings.tables` and `settings.view_samples`
// (settings.tables.store: the disk cache, airmass/table_cache.hpp, unless --no-cache; the
// command sets settings.enabled from its own flag); throws CliError naming
// "<command>: --option", the value and the allowed range.
void apply_ms_options(const std::string& command, MsCliOptions& options, MultipleScatteringOptions& settings,
                      int max_samples);

}  // namespace airmass::cli
