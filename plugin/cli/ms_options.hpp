// The multiple-scattering options `airmass sky`, `airmass eval` and `airmass render` share
// (docs/multiple_scattering.md): one definition of the flags, their ranges and messages.
#pragma once

#include <string>

#include <CLI/CLI.hpp>

#include "airmass/multiple_scattering.hpp"

namespace airmass::cli {

struct MsCliOptions {
    std::string mode = std::string(ms_mode_name(MsSettings{}.mode));
    int orders = MsSettings{}.max_order;
    int samples = 32;   // quadrature intervals per view ray (RenderSettings / SkySettings default)
    std::string table;  // "ALTITUDE,VIEW,SUN,AZIMUTH" node counts; empty: MsTableSize's defaults
};

// --ms-mode, --ms-orders, --ms-samples, --ms-table.
void add_ms_options(CLI::App* cmd, MsCliOptions& options);

// Checks the options and writes them into `settings` and `samples`; throws CliError naming
// "<command>: --option", the value and the allowed range.
void apply_ms_options(const std::string& command, const MsCliOptions& options, MsSettings& settings, int& samples,
                      int max_samples);

}  // namespace airmass::cli
