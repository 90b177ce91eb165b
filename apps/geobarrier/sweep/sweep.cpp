// Running a parameter sweep (sweep.hpp): the sweep's folder locked, the members not yet complete run in forked
// processes (sweep_members.cpp) or on MPI ranks, then the summary (sweep_summary.cpp) and the continuation across the
// parameter (continuation.cpp). Reading the sweep file is sweep_file.cpp's job.
#include "sweep/sweep.hpp"
#include "output/folder_lock.hpp"
#include "run/mpi.hpp"
#include "sweep/continuation.hpp"
#include "sweep/sweep_internal.hpp"
#include <geobarrier/cancel.hpp>
#include <geobarrier/errors.hpp>

#include <omp.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <map>
#include <optional>
#include <thread>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;
using nlohmann::json;

namespace geobarrier {

namespace {

using namespace detail::sweeps;

// One sweep per folder at a time (and no run into it meanwhile): rank 0 holds the folder until the summary is
// written; the members' processes inherit the lock, and each member's run claims its own folder as well. What dead
// writers left in the folder is removed under the lock.
std::optional<detail::FolderLock> lock_sweep_folder(const fs::path &out) {
    if (mpi::rank() != 0) return std::nullopt;
    for (int attempt = 0;; ++attempt) {
        std::error_code ec;
        fs::create_directories(out, ec);
        if (ec) throw IoError(out.string() + ": cannot create the sweep's folder (" + ec.message() + ")");
        if (std::optional<detail::FolderLock> lock = detail::FolderLock::acquire(out, "sweep")) {
            detail::remove_stale_leftovers(out);
            return lock;
        }
        if (attempt == 100) throw IoError(out.string() + ": cannot create the sweep's folder (it kept being removed)");
    }
}

} // namespace

SweepResult run_sweep(const Sweep &s, const SweepOptions &options) {
    check_sweep_members(s); // every member valid before anything is computed
    SweepResult result;
    result.output_dir = options.output_dir ? *options.output_dir : s.output_dir;
    const fs::path &out = result.output_dir;
    std::error_code ec;
    const std::optional<detail::FolderLock> lock = lock_sweep_folder(out);
    detail::test_pause("sweep-locked");
    fs::create_directories(out / "logs", ec);
    if (ec) throw IoError((out / "logs").string() + ": cannot create the sweep's folders (" + ec.message() + ")");

    std::vector<std::size_t> pending = members_to_run(s, out, options.quiet, result.members);

    if (mpi::size() > 1) {
        // One member at a time per rank, with the rank's threads (mpirun's binding decides how many cores).
        const int threads = options.threads > 0 ? options.threads : s.threads > 0 ? s.threads : omp_get_max_threads();
        if (!options.quiet && mpi::rank() == 0 && !pending.empty())
            spdlog::info("sweep: {} of {} members to run on {} MPI ranks, {} thread(s) each; logs in {}",
                         pending.size(), s.members.size(), mpi::size(), threads, (out / "logs").string());
        run_members_on_ranks(s, out, pending, threads, options.quiet, result.members);
        pending.clear(); // the local loop below has nothing left to do
    }
    const int cores = std::max(1, omp_get_num_procs());
    int processes = options.processes > 0 ? options.processes : s.processes > 0 ? s.processes : cores;
    processes = std::max(1, std::min<int>(processes, static_cast<int>(std::max<std::size_t>(pending.size(), 1))));
    const int threads = options.threads > 0 ? options.threads
                        : s.threads > 0     ? s.threads
                                            : std::max(1, cores / processes);
    if (!options.quiet && !pending.empty())
        spdlog::info("sweep: {} of {} members to run, {} at a time, {} thread(s) each; logs in {}", pending.size(),
                     s.members.size(), processes, threads, (out / "logs").string());

    struct Running {
        std::size_t member;
        std::chrono::steady_clock::time_point start;
        int message_fd;
    };
    std::map<pid_t, Running> running;
    std::size_t next = 0;
    int forwarded = 0;
    while (next < pending.size() || !running.empty()) {
        const int signal = cancel_requested();
        if (signal && !forwarded) {
            for (const auto &item : running) ::killpg(item.first, signal); // the member and its compiler
            forwarded = signal;
        }
        while (!signal && next < pending.size() && running.size() < static_cast<std::size_t>(processes)) {
            const std::size_t k = pending[next++];
            const SweepMember &m = s.members[k];
            int message_fd = -1;
            const pid_t pid = start_member(s, m, out / m.name, out / "logs" / (m.name + ".log"), threads, message_fd);
            running[pid] = {k, std::chrono::steady_clock::now(), message_fd};
            if (!options.quiet) spdlog::info("{} ({}): started", m.name, describe_member(s, m));
        }
        if (running.empty()) break;
        int status = 0;
        const pid_t pid = ::waitpid(-1, &status, WNOHANG);
        if (pid == 0 || (pid < 0 && errno == EINTR)) {
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
            continue;
        }
        if (pid < 0) throw Error(std::string("sweep: waiting for the members failed: ") + std::strerror(errno));
        const auto it = running.find(pid);
        if (it == running.end()) continue;
        const std::size_t k = it->second.member;
        SweepMemberResult &r = result.members[k];
        r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - it->second.start).count();
        const std::string message = read_member_message(it->second.message_fd);
        running.erase(it);
        const SweepMember &m = s.members[k];
        const fs::path log = out / "logs" / (m.name + ".log");
        const bool ok = WIFEXITED(status) && WEXITSTATUS(status) == member_ok;
        const bool interrupted = WIFEXITED(status) && WEXITSTATUS(status) > 128 && cancel_requested();
        if (ok) {
            r.status = "done";
            if (!options.quiet)
                spdlog::info("{} ({}): done in {:.1f} s", m.name, describe_member(s, m), r.wall_seconds);
        } else if (interrupted) {
            r.status = "interrupted";
        } else {
            r.status = "failed";
            r.message = exit_description(status) + ": " + failure_reason(message, log);
            spdlog::error("{} ({}) failed, {} (log: {})", m.name, describe_member(s, m), r.message, log.string());
        }
    }
    if (const int signal = cancel_requested()) {
        if (mpi::rank() != 0) throw Cancelled(signal, "during the sweep");
        std::size_t complete = 0;
        for (const SweepMemberResult &r : result.members) complete += r.status == "done" || r.status == "reused";
        throw Cancelled(signal, "during the sweep: " + std::to_string(complete) + " of " +
                                    std::to_string(s.members.size()) + " members are complete in " + out.string() +
                                    ", the others left as they were; run the sweep again to resume");
    }

    if (mpi::rank() != 0) return result; // rank 0 writes the summary
    for (std::size_t k = 0; k < s.members.size(); ++k) {
        SweepMemberResult &r = result.members[k];
        if (r.status == "failed") {
            ++result.failed;
            continue;
        }
        const fs::path folder = out / s.members[k].name;
        const std::optional<json> manifest = finished_manifest(folder, s.members[k].experiment);
        if (!manifest) { // it said it finished, yet left no manifest of its experiment
            r.status = "failed";
            r.message = "no manifest.json of this member's experiment in " + folder.string();
            ++result.failed;
            continue;
        }
        r.wall_seconds = manifest->value("wall_seconds", r.wall_seconds);
        r.figures = member_figures(s, folder, *manifest);
    }
    throw_if_cancelled("before writing the sweep's summary");
    result.files = write_summary(s, out, result.members);
    for (const fs::path &file : write_continuation(s, out, result.members)) result.files.push_back(file);
    return result;
}

} // namespace geobarrier
