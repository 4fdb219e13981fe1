// Opening the OpenVDB writer module (vdb_module.hpp).
#include "vdb_module.hpp"

#include <dlfcn.h>

#include <mutex>
#include <stdexcept>
#include <string>
#include <system_error>

namespace airmass::cli {

namespace {

std::filesystem::path module_path() {
    std::error_code ec;
    const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
    if (ec) throw std::runtime_error("cannot find the airmass executable's folder (/proc/self/exe: " + ec.message() + ")");
    return exe.parent_path() / kVdbModuleFile;
}

const VdbModule* open_module() {
    const std::filesystem::path path = module_path();
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
        const char* why = dlerror();
        throw std::runtime_error("cannot load the OpenVDB writer " + path.string() + ": " +
                                 (why ? why : "unknown reason") + " (it is built beside the airmass executable)");
    }
    using Entry = const VdbModule* (*)();
    const auto entry = reinterpret_cast<Entry>(dlsym(handle, kVdbModuleEntry));
    const VdbModule* m = entry ? entry() : nullptr;
    if (!m || m->version != kVdbModuleVersion)
        throw std::runtime_error("the OpenVDB writer " + path.string() + " is of another airmass build (expected " +
                                 std::string(kVdbModuleEntry) + " version " + std::to_string(kVdbModuleVersion) +
                                 "): rebuild airmass");
    return m;  // the handle stays open for the process's life
}

}  // namespace

const VdbModule& vdb_module() {
    static std::once_flag once;
    static const VdbModule* module = nullptr;
    std::call_once(once, [] { module = open_module(); });
    return *module;
}

}  // namespace airmass::cli
