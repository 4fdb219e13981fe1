// Output files written atomically (airmass/atomic_file.hpp).
#include "airmass/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <system_error>

namespace airmass {

namespace fs = std::filesystem;

namespace {

constexpr std::string_view kTag = ".airmass-tmp-";

fs::path folder_of(const fs::path& dest) { return dest.has_parent_path() ? dest.parent_path() : fs::path("."); }

std::string errno_text(int e) { return std::strerror(e); }

// "<dir>/.<stem>.airmass-tmp-<pid>-<n><ext>": unique within and across processes.
fs::path temporary_for(const fs::path& dest) {
    static std::atomic<unsigned> counter{0};
    return folder_of(dest) / ("." + dest.stem().string() + std::string(kTag) + std::to_string(::getpid()) + "-" +
                              std::to_string(counter.fetch_add(1)) + dest.extension().string());
}

bool all_digits(std::string_view s) {
    if (s.empty()) return false;
    for (char c : s)
        if (c < '0' || c > '9') return false;
    return true;
}

// The pid in `name` if it is a temporary of `dest` (".<stem>.airmass-tmp-<pid>-<n><ext>"), else -1.
long temporary_pid(const fs::path& dest, const std::string& name) {
    const std::string head = "." + dest.stem().string() + std::string(kTag);
    const std::string ext = dest.extension().string();
    if (name.size() <= head.size() + ext.size() || name.compare(0, head.size(), head) != 0 ||
        name.compare(name.size() - ext.size(), ext.size(), ext) != 0)
        return -1;
    const std::string_view mid(name.data() + head.size(), name.size() - head.size() - ext.size());
    const auto dash = mid.find('-');
    if (dash == std::string_view::npos || !all_digits(mid.substr(0, dash)) || !all_digits(mid.substr(dash + 1)) ||
        dash > 9)
        return -1;
    return std::stol(std::string(mid.substr(0, dash)));
}

// Writes all of `pieces`, one after the other, to a new file `path` (O_EXCL), closes it;
// errno on failure (0: ok).
int write_new_file(const fs::path& path, std::span<const std::span<const std::byte>> pieces) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) return errno;
    int err = 0;
    for (const auto& bytes : pieces) {
        std::size_t done = 0;
        while (err == 0 && done < bytes.size()) {
            const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
            if (n < 0) {
                if (errno == EINTR) continue;
                err = errno;
                break;
            }
            done += std::size_t(n);
        }
    }
    if (::close(fd) != 0 && err == 0) err = errno;
    return err;
}

// fsync(2) of a closed file (errno on failure, 0: ok).
int sync_file(const fs::path& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return errno;
    int err = 0;
    while (::fsync(fd) != 0) {
        if (errno == EINTR) continue;
        // Filesystems that cannot sync (some FUSE/special ones) report EINVAL/ENOTSUP: not a write failure.
        if (errno != EINVAL && errno != ENOTSUP && errno != EROFS) err = errno;
        break;
    }
    ::close(fd);
    return err;
}

}  // namespace

void check_output_destination(const fs::path& dest) {
    if (dest.empty()) throw FileWriteError("output path is empty");
    const fs::path dir = folder_of(dest);
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
        throw FileWriteError("cannot write '" + dest.string() + "': directory '" + dir.string() + "' does not exist");
    if (fs::is_directory(dest, ec)) throw FileWriteError("cannot write '" + dest.string() + "': it is a directory");
    const fs::path probe = temporary_for(dest);
    const int err = write_new_file(probe, std::span<const std::span<const std::byte>>());  // empty
    if (err != 0)
        throw FileWriteError("cannot write '" + dest.string() + "': directory '" + dir.string() +
                             "' is not writable (" + errno_text(err) + ")");
    fs::remove(probe, ec);
}

std::vector<fs::path> temporaries_of(const fs::path& dest) {
    std::vector<fs::path> out;
    std::error_code ec;
    for (fs::directory_iterator it(folder_of(dest), ec), end; !ec && it != end; it.increment(ec))
        if (temporary_pid(dest, it->path().filename().string()) > 0) out.push_back(it->path());
    return out;
}

std::size_t remove_stale_temporaries(const fs::path& dest) {
    std::size_t removed = 0;
    for (const fs::path& p : temporaries_of(dest)) {
        const long pid = temporary_pid(dest, p.filename().string());
        // Gone for certain only when kill(pid, 0) says no such process (EPERM: alive, not ours).
        if (pid == long(::getpid()) || pid > 0x7fffffffL || ::kill(pid_t(pid), 0) == 0 || errno != ESRCH) continue;
        std::error_code ec;
        if (fs::remove(p, ec)) ++removed;
    }
    return removed;
}

AtomicOutputs::~AtomicOutputs() {
    if (!done_) discard();
}

void AtomicOutputs::discard() noexcept {
    std::error_code ec;
    for (const auto& f : files_) fs::remove(f.first, ec);
    done_ = true;
}

void AtomicOutputs::check_cancel() {
    if (cancel_ && cancel_->requested()) {
        discard();
        throw Cancelled("cancelled; no file written");
    }
}

fs::path AtomicOutputs::add(const fs::path& dest) {
    remove_stale_temporaries(dest);
    files_.emplace_back(temporary_for(dest), dest);
    return files_.back().first;
}

void AtomicOutputs::write(const fs::path& dest, std::string_view bytes) {
    const std::span<const std::byte> piece(reinterpret_cast<const std::byte*>(bytes.data()), bytes.size());
    write(dest, std::span<const std::span<const std::byte>>(&piece, 1));
}

void AtomicOutputs::write(const fs::path& dest, std::span<const std::span<const std::byte>> pieces) {
    check_cancel();
    const fs::path tmp = add(dest);
    if (const int err = write_new_file(tmp, pieces); err != 0) {
        discard();
        throw FileWriteError("cannot write '" + dest.string() + "': " + errno_text(err));
    }
}

void AtomicOutputs::commit() {
    check_cancel();
    for (const auto& [tmp, dest] : files_)
        if (const int err = sync_ == Sync::to_disk ? sync_file(tmp) : 0; err != 0) {
            discard();
            throw FileWriteError("cannot write '" + dest.string() + "': " + errno_text(err));
        }
    check_cancel();
    for (std::size_t i = 0; i < files_.size(); ++i) {
        std::error_code ec;
        fs::rename(files_[i].first, files_[i].second, ec);
        if (ec) {
            const std::string why = ec.message();
            for (std::size_t j = i; j < files_.size(); ++j) fs::remove(files_[j].first, ec);
            done_ = true;
            throw FileWriteError("cannot move '" + files_[i].first.string() + "' to '" + files_[i].second.string() +
                                 "': " + why);
        }
    }
    done_ = true;
    if (sync_ == Sync::none) return;
    // The renames themselves reach the disk with the folder (best effort: some refuse it).
    fs::path synced;
    for (const auto& f : files_) {
        if (folder_of(f.second) == synced) continue;
        synced = folder_of(f.second);
        const int fd = ::open(synced.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (fd >= 0) {
            ::fsync(fd);
            ::close(fd);
        }
    }
}

namespace {

constexpr std::string_view kStageTag = ".airmass-stage-";
constexpr std::string_view kOldTag = ".airmass-old-";

fs::path sibling_for(const fs::path& dest, std::string_view tag, long pid) {
    return folder_of(dest) / ("." + dest.filename().string() + std::string(tag) + std::to_string(pid));
}

// The pid in `name` if it is "<.name><tag><pid>" of `dest`, else -1.
long sibling_pid(const fs::path& dest, std::string_view tag, const std::string& name) {
    const std::string head = "." + dest.filename().string() + std::string(tag);
    if (name.size() <= head.size() || name.compare(0, head.size(), head) != 0) return -1;
    const std::string_view rest(name.data() + head.size(), name.size() - head.size());
    if (!all_digits(rest) || rest.size() > 9) return -1;
    return std::stol(std::string(rest));
}

bool process_gone(long pid) { return pid > 0 && ::kill(pid_t(pid), 0) != 0 && errno == ESRCH; }

void sync_folder(const fs::path& dir) {
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0) {
        ::fsync(fd);
        ::close(fd);
    }
}

}  // namespace

fs::path staging_folder_for(const fs::path& dest) { return sibling_for(dest, kStageTag, long(::getpid())); }

std::size_t remove_stale_staging(const fs::path& dest) {
    std::size_t removed = 0;
    std::error_code ec;
    std::vector<fs::path> stage, old;
    for (fs::directory_iterator it(folder_of(dest), ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        const long s = sibling_pid(dest, kStageTag, name), o = sibling_pid(dest, kOldTag, name);
        // Our own pid: left by an earlier process that had it (this one has not made it yet).
        if (s > 0 && (s == long(::getpid()) || process_gone(s))) stage.push_back(it->path());
        if (o > 0 && (o == long(::getpid()) || process_gone(o))) old.push_back(it->path());
    }
    for (const fs::path& p : old) {
        std::error_code e;
        // Killed between the fallback's two renames: DIR is missing, and this is its previous set.
        if (!fs::exists(dest, e) && (fs::rename(p, dest, e), !e)) continue;
        if (fs::remove_all(p, e) != static_cast<std::uintmax_t>(-1) && !e) ++removed;
    }
    for (const fs::path& p : stage) {
        std::error_code e;
        if (fs::remove_all(p, e) != static_cast<std::uintmax_t>(-1) && !e) ++removed;
    }
    return removed;
}

fs::path publish_folder(const fs::path& staging, const fs::path& dest, bool exchange) {
    std::error_code ec;
    const bool had = fs::exists(fs::symlink_status(dest, ec));
    fs::path previous;  // where the previous set is once the new one is in place
    auto fail = [&](const std::string& why) {
        throw FileWriteError("cannot publish '" + staging.string() + "' as '" + dest.string() + "': " + why);
    };
    if (!had) {
        if (::rename(staging.c_str(), dest.c_str()) != 0) fail(errno_text(errno));
    } else {
        bool swapped = false;
#if defined(__linux__) && defined(RENAME_EXCHANGE)
        if (exchange) {
            if (::renameat2(AT_FDCWD, staging.c_str(), AT_FDCWD, dest.c_str(), RENAME_EXCHANGE) == 0) {
                swapped = true;
                previous = staging;
            } else if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP) {
                fail(errno_text(errno));
            }
        }
#else
        (void)exchange;
#endif
        if (!swapped) {
            const fs::path old = sibling_for(dest, kOldTag, long(::getpid()));
            fs::remove_all(old, ec);
            if (::rename(dest.c_str(), old.c_str()) != 0) fail(errno_text(errno));
            if (::rename(staging.c_str(), dest.c_str()) != 0) {
                const int err = errno;
                ::rename(old.c_str(), dest.c_str());  // the previous set back
                fail(errno_text(err));
            }
            previous = old;
        }
    }
    sync_folder(folder_of(dest));
    if (previous.empty()) return {};
    fs::remove_all(previous, ec);
    return ec || fs::exists(previous, ec) ? previous : fs::path();
}

void write_file_atomic(const fs::path& path, std::string_view bytes, const CancelFlag* cancel) {
    check_output_destination(path);
    AtomicOutputs out(cancel);
    out.write(path, bytes);
    out.commit();
}

}  // namespace airmass
