// Atomic file writing: every output goes to a uniquely named temporary file beside its target and is renamed
// into place only when complete, so a crash or a failed writer never leaves a half-written file that looks whole.
#include <geobarrier/errors.hpp>
#include <geobarrier/output.hpp>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <system_error>

#include <fcntl.h>
#include <unistd.h>

namespace geobarrier {

namespace {

std::string quoted(const std::filesystem::path &path) { return "'" + path.string() + "'"; }

// ".<name>.tmp-<pid>-<counter>": hidden, recognisably ours, and unique across the threads of this process (the
// counter) and across concurrent processes writing the same target (the pid).
std::filesystem::path temporary_path_for(const std::filesystem::path &target) {
    static std::atomic<unsigned long> counter{0};
    const unsigned long n = counter.fetch_add(1, std::memory_order_relaxed);
    const std::string name = "." + target.filename().string() + ".tmp-" +
                             std::to_string(static_cast<long>(::getpid())) + "-" + std::to_string(n);
    return target.parent_path() / name;
}

// Flushes the temporary file's data to disk before the rename, so that after a power loss the target is either
// the old file or the complete new one, never an empty file with the new name.
void sync_file(const std::filesystem::path &target, const std::filesystem::path &temp) {
    const int fd = ::open(temp.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        const int err = errno;
        throw IoError(quoted(target) + ": the writer left no temporary file " + quoted(temp) + ": " +
                      std::strerror(err));
    }
    if (::fsync(fd) != 0) {
        const int err = errno;
        // Some file systems (pipes, certain FUSE mounts) cannot fsync; that is not a reason to lose the output.
        if (err != EINVAL && err != EROFS && err != ENOTSUP) {
            ::close(fd);
            throw IoError(quoted(target) + ": cannot flush " + quoted(temp) + " to disk: " + std::strerror(err));
        }
    }
    ::close(fd);
}

// Best effort: makes the rename itself durable. A failure here cannot be acted on, so it is ignored.
void sync_directory(const std::filesystem::path &dir) {
    const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0) {
        ::fsync(fd);
        ::close(fd);
    }
}

void remove_quietly(const std::filesystem::path &path) {
    std::error_code ignored;
    std::filesystem::remove(path, ignored);
}

} // namespace

void write_file_atomically(const std::filesystem::path &target,
                           const std::function<void(const std::filesystem::path &temp)> &write) {
    if (target.filename().empty()) throw IoError(quoted(target) + ": not a file name");
    const std::filesystem::path dir = target.parent_path();
    std::error_code ec;
    if (!dir.empty() && !std::filesystem::is_directory(dir, ec))
        throw IoError(quoted(target) + ": the folder " + quoted(dir) + " does not exist");

    const std::filesystem::path temp = temporary_path_for(target);
    try {
        write(temp);
        sync_file(target, temp);
    } catch (...) {
        remove_quietly(temp);
        throw;
    }
    std::filesystem::rename(temp, target, ec);
    if (ec) {
        remove_quietly(temp);
        throw IoError(quoted(target) + ": cannot rename " + quoted(temp) + " to it: " + ec.message());
    }
    sync_directory(dir);
}

void write_text_file(const std::filesystem::path &target, const std::string &text) {
    write_file_atomically(target, [&](const std::filesystem::path &temp) {
        std::FILE *file = std::fopen(temp.c_str(), "wb");
        if (file == nullptr) {
            const int err = errno;
            throw IoError(quoted(target) + ": cannot create " + quoted(temp) + ": " + std::strerror(err));
        }
        const std::size_t written = std::fwrite(text.data(), 1, text.size(), file);
        const int write_err = errno;
        if (written != text.size()) {
            std::fclose(file);
            throw IoError(quoted(target) + ": cannot write " + quoted(temp) + ": " + std::strerror(write_err));
        }
        // fclose flushes the stdio buffer; a full disk often shows up only here.
        if (std::fclose(file) != 0) {
            const int err = errno;
            throw IoError(quoted(target) + ": cannot write " + quoted(temp) + ": " + std::strerror(err));
        }
    });
}

} // namespace geobarrier
