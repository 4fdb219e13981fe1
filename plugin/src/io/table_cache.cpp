// The CLI's disk cache of multiple-scattering tables (table_cache.hpp).
#include "airmass/table_cache.hpp"

#include "airmass/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>
#ifndef _WIN32
#include <sys/mman.h>
#include <sys/stat.h>
#endif

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <optional>
#include <span>
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

// A file's bytes for reading: mapped read-only where the platform can (the page cache itself,
// nothing copied or zeroed: a 10 MB entry costs its checksum pass, and the tables read G in
// place), else read whole into a buffer. The cache replaces an entry only by renaming a new
// file over it (atomic_file.hpp), so a mapped entry's file is never truncated under it: the
// tables of a mapping stay valid after the entry is replaced or removed.
class FileBytes {
public:
    explicit FileBytes(const fs::path& path) {
#ifndef _WIN32
        const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0) return;
        struct stat st {};
        if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode)) {
            size_ = std::size_t(st.st_size);
            ok_ = true;
            if (size_ > 0) {
                int flags = MAP_PRIVATE;
#ifdef MAP_POPULATE
                flags |= MAP_POPULATE;  // the pages mapped now, not one fault at a time
#endif
                void* p = ::mmap(nullptr, size_, PROT_READ, flags, fd, 0);
                if (p != MAP_FAILED) map_ = p;
                else ok_ = read_all(path);
            }
        }
        ::close(fd);
#else
        std::error_code ec;
        size_ = std::size_t(fs::file_size(path, ec));
        ok_ = !ec && read_all(path);
#endif
    }
    ~FileBytes() {
#ifndef _WIN32
        if (map_) ::munmap(map_, size_);
#endif
    }
    FileBytes(const FileBytes&) = delete;
    FileBytes& operator=(const FileBytes&) = delete;

    bool ok() const { return ok_; }
    std::span<const std::byte> bytes() const {
        if (map_) return {static_cast<const std::byte*>(map_), size_};
        return {buffer_.get(), buffer_ ? size_ : 0};
    }

private:
    // One read into an uninitialised buffer.
    bool read_all(const fs::path& path) {
        std::ifstream in(path, std::ios::binary);
        if (!in) return false;
        buffer_.reset(new std::byte[size_]);
        in.read(reinterpret_cast<char*>(buffer_.get()), std::streamsize(size_));
        return in.gcount() == std::streamsize(size_);
    }

    std::size_t size_ = 0;
    bool ok_ = false;
    void* map_ = nullptr;
    std::unique_ptr<std::byte[]> buffer_;
};

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
    std::optional<MultipleScattering> tables;
    {
        // Tables of 48 wavelengths are ≈ 40 MB. G is read in place: the tables keep the file's
        // bytes (the mapping, or the buffer it was read into) alive as long as they live.
        auto file = std::make_shared<const FileBytes>(path);
        if (!file->ok()) return nullptr;  // missing or unreadable: a miss
        tables = deserialize_tables(file->bytes(), key, file);
    }
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
    // The record's arrays go to the file from where they lie (no 10 MB copy).
    const TableRecord record = table_record(tables, key);
    if (record.size() > max_bytes_) return;  // would be evicted at once
    const fs::path path = entry_path(key);
    try {
        // The one atomic writer (a reader never sees a part; a killed run's temporary is
        // removed by the next store of the same entry), without fsync: an entry a crash left
        // empty or partial fails its length or checksum and is rebuilt, like any corrupt one.
        AtomicOutputs out(nullptr, AtomicOutputs::Sync::none);
        out.write(path, record.pieces);
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
