// The one atomic-write helper (airmass/atomic_file.hpp): a failure or a cancel before commit()
// keeps the previous file and leaves no temporary; a killed process's temporary is removed by
// the next write of the same destination, a live process's is not. (End to end, every CLI
// writer against real faults: tests/python/test_faults.py.) A folder published whole (compare's
// output set): the staging folder swapped in, with and without RENAME_EXCHANGE.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <span>
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

TEST(AtomicFile, PiecesAreWrittenInOrderWithOrWithoutTheFlushToDisk) {
    Folder d;
    const fs::path out = d.path / "t.amt";
    const std::string a = "head", b(5000, 'x'), c = "tail";
    const auto bytes = [](const std::string& s) { return std::as_bytes(std::span<const char>(s.data(), s.size())); };
    const std::span<const std::byte> pieces[] = {bytes(a), {}, bytes(b), bytes(c)};
    for (const auto sync : {AtomicOutputs::Sync::to_disk, AtomicOutputs::Sync::none}) {
        write_file_atomic(out, "previous");
        AtomicOutputs o(nullptr, sync);
        o.write(out, pieces);
        EXPECT_EQ(read(out), "previous");  // nothing replaced before commit()
        o.commit();
        EXPECT_EQ(read(out), a + b + c);
        EXPECT_EQ(d.entries(), 1u);  // no temporary left
    }
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

// A folder published whole (`airmass compare -o DIR`): the staging folder becomes DIR in one
// rename, by RENAME_EXCHANGE or by the fallback (DIR renamed aside first); nothing of the
// previous set stays, no staging or old folder is left.
TEST(AtomicFolder, PublishReplacesTheWholeSet) {
    for (const bool exchange : {true, false}) {
        Folder d;
        const fs::path dest = d.path / "cmp";
        for (const char* run : {"first", "second"}) {
            const fs::path stage = staging_folder_for(dest);
            EXPECT_EQ(stage.parent_path(), d.path);
            EXPECT_EQ(stage.filename().string(), ".cmp.airmass-stage-" + std::to_string(::getpid()));
            fs::create_directories(stage / "png");
            std::ofstream(stage / "job.json") << run;
            if (std::string(run) == "first") std::ofstream(stage / "atmosphere.vdb") << "only in the first";
            EXPECT_EQ(publish_folder(stage, dest, exchange), fs::path());
            EXPECT_EQ(read(dest / "job.json"), run) << exchange;
            EXPECT_EQ(d.entries(), 1u) << exchange;  // DIR alone
        }
        EXPECT_FALSE(fs::exists(dest / "atmosphere.vdb")) << exchange;
        EXPECT_TRUE(fs::is_directory(dest / "png"));
    }
}

TEST(AtomicFolder, TheNextPublisherRemovesStagingOfDeadProcessesOnly) {
    Folder d;
    const fs::path dest = d.path / "cmp";
    fs::create_directories(dest);
    std::ofstream(dest / "job.json") << "previous";
    const fs::path dead = d.path / (".cmp.airmass-stage-" + std::to_string(dead_pid()));
    const fs::path live = d.path / (".cmp.airmass-stage-" + std::to_string(::getppid()));
    const fs::path other = d.path / (".other.airmass-stage-" + std::to_string(dead_pid()));
    for (const auto& p : {dead, live, other}) fs::create_directories(p / "png");
    EXPECT_EQ(remove_stale_staging(dest), 1u);
    EXPECT_FALSE(fs::exists(dead));
    EXPECT_TRUE(fs::exists(live));   // another run may be writing it now
    EXPECT_TRUE(fs::exists(other));  // not this destination's
    EXPECT_EQ(read(dest / "job.json"), "previous");
    // Killed between the fallback's two renames: DIR is missing, its previous set is the old folder.
    const fs::path old = d.path / (".cmp.airmass-old-" + std::to_string(dead_pid()));
    fs::rename(dest, old);
    remove_stale_staging(dest);
    EXPECT_FALSE(fs::exists(old));
    EXPECT_EQ(read(dest / "job.json"), "previous");
}

}  // namespace
}  // namespace airmass
