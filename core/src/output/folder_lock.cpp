// One writer per output folder: the lock a run or a sweep holds on the folder it writes (folder_lock.hpp).
#include "output/folder_lock.hpp"

#include <geobarrier/errors.hpp>

#include <spdlog/spdlog.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <regex>
#include <set>
#include <system_error>
#include <thread>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

namespace fs = std::filesystem;

namespace geobarrier::detail {

namespace {

// The folders this process holds, by device and inode, with the description of their holder; and those of them
// held without a lock of the file system (see flock_folder), which other processes may be writing too.
std::mutex g_table_mutex;
std::map<std::string, std::string> g_table;
std::set<std::string> g_unlocked;

void unreserve(const std::string &key) {
    const std::lock_guard<std::mutex> guard(g_table_mutex);
    g_table.erase(key);
    g_unlocked.erase(key);
}

std::string folder_key(const struct stat &dir) { return std::to_string(dir.st_dev) + ":" + std::to_string(dir.st_ino); }

// flock(LOCK_EX | LOCK_NB), or, where GEOBARRIER_TEST_LOCK_FAILS names ENOLCK or EOPNOTSUPP, that failure: a test
// hook for the fallback on file systems that cannot lock (NFS without its lock service, some FUSE file systems),
// which no test machine has.
int flock_folder(int fd) {
    if (const char *fails = std::getenv("GEOBARRIER_TEST_LOCK_FAILS")) {
        if (std::strcmp(fails, "ENOLCK") == 0) return errno = ENOLCK, -1;
        if (std::strcmp(fails, "EOPNOTSUPP") == 0) return errno = EOPNOTSUPP, -1;
    }
    return ::flock(fd, LOCK_EX | LOCK_NB);
}

// What the lock file says of its holder ("geobarrier run (pid 123)"), printable characters only, or "".
std::string holder_of(int fd) {
    char buffer[160] = {};
    const ssize_t n = ::pread(fd, buffer, sizeof buffer - 1, 0);
    std::string text;
    for (ssize_t k = 0; k < n; ++k)
        if (buffer[k] >= 0x20 && buffer[k] < 0x7f) text += buffer[k];
    return text;
}

OutputBusyError busy(const fs::path &folder, const std::string &holder) {
    return OutputBusyError(folder.string() + ": another " +
                           (holder.empty() ? std::string("geobarrier run or sweep") : holder) +
                           " is writing into this output folder; refused, so that the folder never mixes the files of "
                           "two runs: wait until it has finished, or choose another output folder");
}

} // namespace

std::optional<FolderLock> FolderLock::acquire(const fs::path &folder, const std::string &what) {
    const fs::path file = folder / folder_lock_name;
    const std::string holder = "geobarrier " + what + " (pid " + std::to_string(static_cast<long>(::getpid())) + ")";
    for (int attempt = 0; attempt < 1000; ++attempt) {
        struct stat dir {};
        if (::stat(folder.c_str(), &dir) != 0) {
            const int err = errno;
            if (err == ENOENT) return std::nullopt;
            throw IoError(folder.string() + ": cannot lock the output folder (" + std::strerror(err) + ")");
        }
        const std::string key = folder_key(dir);
        {
            const std::lock_guard<std::mutex> guard(g_table_mutex);
            if (const auto it = g_table.find(key); it != g_table.end()) throw busy(folder, it->second);
            g_table[key] = holder;
        }
        const int fd = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
        if (fd < 0) {
            const int err = errno;
            unreserve(key);
            if (err == ENOENT) return std::nullopt; // the folder went away since stat
            throw IoError(folder.string() + ": cannot create the lock file " + folder_lock_name +
                          " in the output folder (" + std::strerror(err) + ")");
        }
        if (flock_folder(fd) != 0) {
            const int err = errno;
            if (err == ENOLCK || err == EOPNOTSUPP || err == ENOSYS || err == EINVAL) {
                // A file system that cannot lock (NFS without its lock service, some FUSE file systems): runs there
                // worked before the lock existed, so they still do, kept apart only within this process; and what
                // looks like a dead writer's staging folder may be a live one's, so it is left
                // (remove_stale_leftovers).
                spdlog::warn("{}: the file system cannot lock files ({}); two geobarrier processes writing this "
                             "folder at once are not kept apart, and what earlier runs left there is not removed",
                             folder.string(), std::strerror(err));
                const std::lock_guard<std::mutex> guard(g_table_mutex);
                g_unlocked.insert(key);
                return FolderLock(folder, fd, key);
            }
            const std::string other = holder_of(fd);
            ::close(fd);
            unreserve(key);
            if (err == EWOULDBLOCK) throw busy(folder, other);
            throw IoError(folder.string() + ": cannot lock the output folder (" + std::strerror(err) + ")");
        }
        // Locked; but the holder before us may have removed the file after we opened it (its release): then the name
        // leads to a new file, or to none, and this lock protects nothing.
        struct stat mine {
        }, named{};
        if (::fstat(fd, &mine) == 0 && ::lstat(file.c_str(), &named) == 0 && mine.st_dev == named.st_dev &&
            mine.st_ino == named.st_ino) {
            const std::string text = holder + "\n";
            if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, text.data(), text.size(), 0) < 0) {
                // The holder's name is a courtesy to the refused; the lock holds without it.
            }
            return FolderLock(folder, fd, key);
        }
        ::close(fd);
        unreserve(key);
    }
    throw IoError(folder.string() + ": cannot lock the output folder: its lock file " + folder_lock_name +
                  " kept being replaced");
}

FolderLock::FolderLock(fs::path folder, int fd, std::string key)
    : m_folder(std::move(folder)), m_fd(fd), m_key(std::move(key)) {}

FolderLock::FolderLock(FolderLock &&other) noexcept
    : m_folder(std::move(other.m_folder)), m_fd(other.m_fd), m_key(std::move(other.m_key)) {
    other.m_fd = -1;
}

FolderLock &FolderLock::operator=(FolderLock &&other) noexcept {
    std::swap(m_folder, other.m_folder);
    std::swap(m_fd, other.m_fd);
    std::swap(m_key, other.m_key);
    return *this; // what this held is released by `other`
}

FolderLock::~FolderLock() {
    if (m_fd < 0) return;
    // Removed while still locked, and only if the name still leads to our file; then unlocked by the close.
    const fs::path file = m_folder / folder_lock_name;
    struct stat mine {
    }, named{};
    if (::fstat(m_fd, &mine) == 0 && ::lstat(file.c_str(), &named) == 0 && mine.st_dev == named.st_dev &&
        mine.st_ino == named.st_ino)
        ::unlink(file.c_str());
    ::close(m_fd);
    unreserve(m_key);
}

void remove_stale_leftovers(const fs::path &folder) {
    static const std::regex temporary(R"(\..+\.tmp-[0-9]+-[0-9]+)");
    struct stat dir {};
    if (::stat(folder.c_str(), &dir) != 0) return;
    {
        const std::lock_guard<std::mutex> guard(g_table_mutex);
        if (g_unlocked.count(folder_key(dir)) != 0) return; // not locked: another process may be writing them
    }
    std::error_code ec;
    std::vector<fs::path> stale;
    for (const auto &entry : fs::directory_iterator(folder, ec)) {
        const std::string name = entry.path().filename().string();
        if (name.rfind(".geobarrier-partial-", 0) == 0 || std::regex_match(name, temporary))
            stale.push_back(entry.path());
    }
    for (const fs::path &p : stale) fs::remove_all(p, ec);
}

void test_pause(const char *point) {
    const char *at = std::getenv("GEOBARRIER_TEST_PAUSE_AT");
    const char *dir = std::getenv("GEOBARRIER_TEST_PAUSE_DIR");
    if (at == nullptr || dir == nullptr || std::strcmp(at, point) != 0) return;
    const fs::path reached = fs::path(dir) / (std::string(point) + ".reached");
    const fs::path go = fs::path(dir) / (std::string(point) + ".go");
    // The pid is written into a file of this process's own and linked to the hook's name: the name appears with its
    // content (a test reads the pid as soon as it sees the file), and only the first writer's link succeeds.
    const std::string pid = std::to_string(static_cast<long>(::getpid()));
    const fs::path claim = fs::path(dir) / (std::string(point) + ".claim-" + pid);
    const int fd = ::open(claim.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return;
    const std::string text = pid + "\n";
    const bool written = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
    ::close(fd);
    const bool first = written && ::link(claim.c_str(), reached.c_str()) == 0;
    ::unlink(claim.c_str());
    if (!first) return; // another writer paused here first
    std::error_code ec;
    for (int k = 0; k < 120000 && !fs::exists(go, ec); ++k) std::this_thread::sleep_for(std::chrono::milliseconds(5));
}

} // namespace geobarrier::detail
