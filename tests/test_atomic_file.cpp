// The one atomic-write helper (airmass/atomic_file.hpp): a failure or a cancel before commit()
// keeps the previous file and leaves no temporary; a killed process's temporary is removed by
// the next write of the same destination, a live process's is not. (End to end, every CLI
// writer against real faults: tests/python/test_faults.py.)
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "airmass/atomic_file.hpp"

namespace airmass {
namespace {

namespace fs = std::filesystem;

struct Folder {
    fs::path path;
    Folder() {
        path = fs::temp_directory_path() / ("airmass-atomic-" + std::to_string(::getpid()) + "-" +
                                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(path);
        fs::create_directories(path);
    }
    ~Folder() { fs::remove_all(path); }
    std::size_t entries() const { return std::size_t(std::distance(fs::directory_iterator(path), {})); }
};

std::string read(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), {}};
}

// A pid that existed and no longer does: a child that exited and was reaped.
pid_t dead_pid() {
    const pid_t pid = ::fork();
    if (pid == 0) ::_exit(0);
    int status = 0;
    ::waitpid(pid, &status, 0);
    return pid;
}

TEST(AtomicFile, ReplacesWholeAndLeavesNoTemporary) {
    Folder d;
    const fs::path out = d.path / "a.json";
    write_file_atomic(out, "previous");
    write_file_atomic(out, "new");
    EXPECT_EQ(read(out), "new");
    EXPECT_EQ(d.entries(), 1u);
}

TEST(AtomicFile, FailureOrCancelBeforeCommitKeepsThePreviousFile) {
    Folder d;
    const fs::path a = d.path / "a.vdb", b = d.path / "b.json";
    write_file_atomic(a, "previous a");
    {
        AtomicOutputs set;
        set.write(a, "new a");
        set.write(b, "new b");
        EXPECT_EQ(temporaries_of(a).size(), 1u);
        // destroyed without commit(): an exception between the writes and the renames
    }
    EXPECT_EQ(read(a), "previous a");
    EXPECT_FALSE(fs::exists(b));
    EXPECT_EQ(d.entries(), 1u);

    CancelFlag cancel;
    AtomicOutputs set(&cancel);
    set.write(a, "new a");
    cancel.request();
    EXPECT_THROW(set.commit(), Cancelled);
    EXPECT_EQ(read(a), "previous a");
    EXPECT_EQ(d.entries(), 1u);
    EXPECT_THROW(write_file_atomic(a, "x", &cancel), Cancelled);
    EXPECT_EQ(read(a), "previous a");
}

TEST(AtomicFile, TheNextWriteRemovesTemporariesOfDeadProcessesOnly) {
    Folder d;
    const fs::path out = d.path / "sky.exr";
    const fs::path dead = d.path / (".sky.airmass-tmp-" + std::to_string(dead_pid()) + "-0.exr");
    const fs::path live = d.path / (".sky.airmass-tmp-" + std::to_string(::getppid()) + "-0.exr");
    const fs::path other = d.path / (".other.airmass-tmp-" + std::to_string(dead_pid()) + "-0.exr");
    for (const auto& p : {dead, live, other}) std::ofstream(p) << "partial";
    EXPECT_EQ(temporaries_of(out).size(), 2u);
    write_file_atomic(out, "new");
    EXPECT_FALSE(fs::exists(dead));
    EXPECT_TRUE(fs::exists(live));   // another process may be writing it now
    EXPECT_TRUE(fs::exists(other));  // not this destination's
    EXPECT_EQ(read(out), "new");
}

TEST(AtomicFile, UnwritableDestinationsAreRefusedBeforeAnyWork) {
    Folder d;
    EXPECT_THROW(check_output_destination(d.path / "missing" / "x.vdb"), FileWriteError);
    EXPECT_THROW(check_output_destination(d.path), FileWriteError);  // a directory
    EXPECT_THROW(check_output_destination("/proc/airmass-x.json"), FileWriteError);  // even for root
    EXPECT_THROW(check_output_destination(""), FileWriteError);
    EXPECT_EQ(d.entries(), 0u);
}

}  // namespace
}  // namespace airmass
