// The CLI's disk cache of multiple-scattering tables (table_cache.hpp).
#include "airmass/table_cache.hpp"

#include "airmass/atomic_file.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <system_error>
#include <vector>

namespace airmass {

namespace fs = std::filesystem;

namespace {

const char* env(const char* name) {
    const char* v = std::getenv(name);
    return v && *v ? v : nullptr;
}

constexpr const char* kPrefix = "ms-";
constexpr const char* kSuffix = ".amt";

bool is_entry(const fs::path& p) {
    const std::string name = p.filename().string();
    return name.rfind(kPrefix, 0) == 0 && p.extension() == kSuffix;
}

}  // namespace

fs::path default_table_cache_dir() {
    if (const char* d = env("AIRMASS_CACHE_DIR")) return fs::path(d);
#ifdef _WIN32
    if (const char* d = env("LOCALAPPDATA")) return fs::path(d) / "airmass" / "cache";
#endif
    if (const char* d = env("XDG_CACHE_HOME")) return fs::path(d) / "airmass";
    if (const char* d = env("HOME")) return fs::path(d) / ".cache" / "airmass";
    return {};
}

std::uintmax_t default_table_cache_max_bytes() {
    if (const char* v = env("AIRMASS_CACHE_MAX_MB")) {
        char* end = nullptr;
        const double mb = std::strtod(v, &end);
        if (end != v && *end == '\0' && mb >= 0.0 && mb < 1e9) return static_cast<std::uintmax_t>(mb * 1024 * 1024);
    }
    return std::uintmax_t(1024) * 1024 * 1024;
}

DiskTableStore::DiskTableStore(fs::path dir, std::uintmax_t max_bytes) : dir_(std::move(dir)), max_bytes_(max_bytes) {}

fs::path DiskTableStore::entry_path(std::string_view key) const {
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(fnv1a64(key)));
    return dir_ / (std::string(kPrefix) + hex + kSuffix);
}

std::shared_ptr<const MultipleScattering> DiskTableStore::load(std::string_view key) {
    last_load_ = Outcome::miss;
    if (dir_.empty()) return nullptr;
    const fs::path path = entry_path(key);
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(path, ec);
    if (ec) return nullptr;
    std::ifstream in(path, std::ios::binary);
    if (!in) return nullptr;
    // One read into an uninitialised buffer (tables of 48 wavelengths are ≈ 40 MB).
    std::unique_ptr<std::byte[]> raw(new std::byte[std::size_t(size)]);
    in.read(reinterpret_cast<char*>(raw.get()), std::streamsize(size));
    const bool whole = in.gcount() == std::streamsize(size);
    in.close();
    auto tables = whole ? deserialize_tables(std::span<const std::byte>(raw.get(), std::size_t(size)), key)
                        : std::nullopt;
    if (!tables) {
        // Foreign, truncated or corrupt: never trusted, removed so the fresh tables replace it.
        last_load_ = Outcome::rejected;
        fs::remove(path, ec);
        return nullptr;
    }
    last_load_ = Outcome::hit;
    fs::last_write_time(path, fs::file_time_type::clock::now(), ec);  // recently used
    return std::make_shared<const MultipleScattering>(std::move(*tables));
}

void DiskTableStore::store(std::string_view key, const MultipleScattering& tables) {
    if (dir_.empty()) return;
    std::error_code ec;
    fs::create_directories(dir_, ec);
    if (ec) {
        problem_ = "cannot create the table cache folder '" + dir_.string() + "': " + ec.message();
        return;
    }
    const std::vector<std::byte> bytes = serialize_tables(tables, key);
    if (bytes.size() > max_bytes_) return;  // would be evicted at once
    const fs::path path = entry_path(key);
    try {
        // The one atomic writer (a reader never sees a part; a killed run's temporary is
        // removed by the next store of the same entry).
        AtomicOutputs out;
        out.write(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
        out.commit();
    } catch (const FileWriteError& e) {
        problem_ = std::string("table cache: ") + e.what();
        return;
    }
    evict();
}

void DiskTableStore::evict() {
    struct Entry {
        fs::path path;
        std::uintmax_t size;
        fs::file_time_type time;
    };
    std::vector<Entry> entries;
    std::uintmax_t total = 0;
    std::error_code ec;
    for (fs::directory_iterator it(dir_, ec), end; !ec && it != end; it.increment(ec)) {
        if (!is_entry(it->path())) continue;
        std::error_code e1, e2;
        const auto size = it->file_size(e1);
        const auto time = it->last_write_time(e2);
        if (e1 || e2) continue;
        entries.push_back({it->path(), size, time});
        total += size;
    }
    std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.time < b.time; });
    for (const Entry& e : entries) {
        if (total <= max_bytes_) break;
        if (fs::remove(e.path, ec)) total -= e.size;
    }
}

}  // namespace airmass
