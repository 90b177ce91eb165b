// One writer per output folder (docs/robustness.md, "One writer per folder"): a run, a sweep, rank 0 of an MPI run and
// every Python thread hold an exclusive lock on the folder they write, from before their staging folder is made to
// after their last rename. A second writer is refused at once with OutputBusyError (the program exits with 2), so that
// a folder never pairs one run's manifest.json with another run's files.
#ifndef GEOBARRIER_FOLDER_LOCK_HPP
#define GEOBARRIER_FOLDER_LOCK_HPP

#include <filesystem>
#include <optional>
#include <string>

namespace geobarrier::detail {

// The lock file inside a locked folder; it exists only while its folder is locked (see FolderLock).
inline constexpr const char *folder_lock_name = ".geobarrier-lock";

// An exclusive flock(2) on `<folder>/.geobarrier-lock`, taken without waiting. The lock file is removed (while still
// locked) when the lock is released, so a finished folder holds no trace of it; a writer that opened the file just
// before it was removed notices that the name now leads elsewhere and tries again. Within one process the folders held
// are also kept in a table, so that two threads are refused on file systems whose flock is per process (NFS).
// Where the file system cannot lock (flock fails with ENOLCK, EOPNOTSUPP...), acquire warns and goes ahead, keeping
// the folder apart only within this process; the test hook GEOBARRIER_TEST_LOCK_FAILS=ENOLCK (or EOPNOTSUPP) makes
// flock fail so. Sweep members are forked with the sweep's lock descriptor: a sweep killed with SIGKILL keeps its
// folder locked until its last member has ended.
class FolderLock {
  public:
    // Locks `folder`, which must exist; `what` says what will write there ("run", "sweep"), for the refusal of others.
    // Returns nullopt when the folder has disappeared (a failed writer removed the folder it had created): create it
    // again and retry. Throws OutputBusyError when another writer holds it, IoError when the lock file cannot be made.
    static std::optional<FolderLock> acquire(const std::filesystem::path &folder, const std::string &what);

    FolderLock(FolderLock &&other) noexcept;
    FolderLock &operator=(FolderLock &&other) noexcept;
    FolderLock(const FolderLock &) = delete;
    FolderLock &operator=(const FolderLock &) = delete;
    ~FolderLock();

    const std::filesystem::path &folder() const { return m_folder; }

  private:
    FolderLock(std::filesystem::path folder, int fd, std::string key);
    std::filesystem::path m_folder;
    int m_fd = -1;
    std::string m_key; // the folder's device and inode, in the process's table
};

// Removes what dead writers left in a folder this process has locked: staging folders (".geobarrier-partial-*") and
// atomic writes' temporary files (".NAME.tmp-PID-N"). Under the lock no one else can be writing them; on a file system
// that cannot lock (acquire's fallback) another process may be, so nothing is removed there.
void remove_stale_leftovers(const std::filesystem::path &folder);

// A test hook, for tests that must force an interleaving (tests/test_concurrency.cpp): where the environment names
// `point` in GEOBARRIER_TEST_PAUSE_AT, the first writer of the process tree to reach it creates
// `$GEOBARRIER_TEST_PAUSE_DIR/<point>.reached` (with its pid) and waits until `<point>.go` appears there (at most
// 10 minutes); later writers pass. Points: "locked" (folder locked, staging folder made, nothing computed),
// "staged" (every file written into the staging folder, manifest.json included, nothing moved), "publishing" (the
// earlier run's manifest and files removed, this run's files moved, its manifest not yet), "sweep-locked".
void test_pause(const char *point);

} // namespace geobarrier::detail

#endif // GEOBARRIER_FOLDER_LOCK_HPP
