// libairmass_vdb_module.so: the OpenVDB writer's entry points for the CLI (vdb_module.hpp).
#include "vdb_module.hpp"

extern "C" __attribute__((visibility("default"))) const airmass::cli::VdbModule* airmass_vdb_module_v1() {
    static const airmass::cli::VdbModule module{
        airmass::cli::kVdbModuleVersion,
        [](const airmass::Scene& s, const airmass::VdbOptions& o, const std::filesystem::path& p,
           const airmass::VdbRunOptions& r) { return airmass::export_vdb(s, o, p, r); },
        [](const airmass::Scene& s, const airmass::VdbOptions& o, const std::filesystem::path& p,
           const airmass::VdbRunOptions& r) { return airmass::export_df3(s, o, p, r); },
        [](const airmass::Scene& s, const airmass::VdbTradeOptions& o) { return airmass::run_vdb_trade(s, o); },
    };
    return &module;
}
