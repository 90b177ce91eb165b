// A sweep's members (sweep.hpp): which are complete from an earlier run (resume), running one in this process or in
// a forked one (its own process group, stdout and stderr to its log, signals, the message pipe), on MPI ranks, and
// why one failed.
#include "output/provenance.hpp"
#include "run/mpi.hpp"
#include "sweep/sweep_internal.hpp"
#include <geobarrier/cancel.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>

#include "experiment/resources.hpp"

#include <omp.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;
using nlohmann::json;

namespace geobarrier::detail::sweeps {

namespace {

// Why the files of a finished member cannot be reused, or "" when they can: every file its manifest lists must be
// there (a folder it lists, with its own manifest, is checked the same way: the two directions of a tangle), with
// the size and SHA-256 the manifest's "provenance"/"output_files" records (manifests written before those were
// recorded are checked for presence only).
std::string member_files_problem(const fs::path &folder, const json &manifest, int depth = 0) {
    std::error_code ec;
    for (const json &item : manifest.value("files", json::array())) {
        if (!item.is_string()) continue;
        const std::string name = item.get<std::string>();
        if (name.empty() || name == "manifest.json" || name.find('/') != std::string::npos) continue;
        const fs::path path = folder / name;
        if (!fs::exists(path, ec)) return name + " is missing";
        if (!fs::is_directory(path, ec) || depth > 0) continue;
        if (!fs::is_regular_file(path / "manifest.json", ec)) return name + "/manifest.json is missing";
        try {
            const std::string problem =
                member_files_problem(path, json::parse(read_text(path / "manifest.json", "a manifest")), depth + 1);
            if (!problem.empty()) return name + "/" + problem;
        } catch (const std::exception &) {
            return name + "/manifest.json cannot be read";
        }
    }
    const json provenance = manifest.value("provenance", json::object());
    if (!provenance.is_object()) return "";
    for (const json &entry : provenance.value("output_files", json::array())) {
        if (!entry.is_object() || !entry.value("file", json()).is_string()) continue;
        const std::string name = entry["file"].get<std::string>();
        if (name.empty() || name.find('/') != std::string::npos || name[0] == '.') continue;
        const fs::path path = folder / name;
        if (!fs::is_regular_file(path, ec)) return name + " is missing";
        const std::uintmax_t bytes = fs::file_size(path, ec);
        if (entry.value("bytes", json()).is_number_unsigned() && (ec || bytes != entry["bytes"].get<std::uintmax_t>()))
            return name + " has " + std::to_string(bytes) + " bytes where the manifest records " +
                   std::to_string(entry["bytes"].get<std::uintmax_t>()) + " (cut short or changed)";
        if (entry.value("sha256", json()).is_string()) {
            std::string digest;
            try {
                digest = detail::sha256_file(path);
            } catch (const IoError &) {
                return name + " cannot be read";
            }
            if (digest != entry["sha256"].get<std::string>())
                return name + " does not have the SHA-256 its manifest records (changed since it was written)";
        }
    }
    return "";
}

extern "C" void record_stop_signal(int signal) { request_cancel(signal); }

// The sweep process a forked member belongs to (set in the member right after the fork).
pid_t member_supervisor = 0;

// SIGINT/SIGTERM in a member. From the sweep (which forwards the signals it gets) it stops the member cleanly. The
// kernel sends SIGTERM as well when the sweep process dies (PR_SET_PDEATHSIG), however it died, SIGKILL included:
// then the member's parent has changed, and the member ends at once with its whole process group, any compiler it
// started included, so that nothing of a dead sweep keeps running (or keeps its folder locked). What it leaves, a
// staging folder, is removed by the next run into the folder.
extern "C" void member_stop_signal(int signal) {
    if (::getppid() != member_supervisor) ::kill(0, SIGKILL);
    request_cancel(signal);
}

// Runs one member in this process with stdout and stderr going to `log`; returns the exit code `geobarrier run`
// would give, and its error message in `error` (on one line). The member's output folder is written by the runner's
// staging: whole or not at all.
int run_member_here(const Sweep &s, const SweepMember &m, const fs::path &folder, const fs::path &log, int threads,
                    std::string &error) {
    std::fflush(nullptr);
    const int saved_out = ::dup(1), saved_err = ::dup(2);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd >= 0) {
        ::dup2(fd, 1);
        ::dup2(fd, 2);
        ::close(fd);
    }
    int code = member_ok;
    error.clear();
    try {
        const ResolvedExperiment r = resolve_experiment(parse_experiment(m.experiment, s.relative_to));
        RunOptions options;
        options.output_dir = folder;
        options.threads = threads;
        options.quiet = true;
        run_experiment(r, options);
    } catch (const Cancelled &e) {
        code = 128 + e.signal();
        error = e.what();
    } catch (const ConfigError &e) {
        code = member_bad_input;
        error = e.what();
    } catch (const OutputBusyError &e) { // another writer's folder: exit 2, as `geobarrier run` would
        code = member_bad_input;
        error = e.what();
    } catch (const std::exception &e) {
        code = cancel_requested() ? 128 + cancel_requested() : member_failed;
        error = e.what();
    }
    if (!error.empty()) {
        std::replace(error.begin(), error.end(), '\n', ' ');
        std::fprintf(stderr, "geobarrier: error: %s\n", error.c_str());
    }
    std::fflush(nullptr);
    if (saved_out >= 0) ::dup2(saved_out, 1), ::close(saved_out);
    if (saved_err >= 0) ::dup2(saved_err, 2), ::close(saved_err);
    return code;
}

// The last line the member wrote (its error message), for the report.
std::string last_line(const fs::path &log) {
    std::ifstream in(log);
    std::string line, last;
    while (std::getline(in, line))
        if (!line.empty()) last = line;
    const std::string prefix = "geobarrier: error: ";
    if (last.rfind(prefix, 0) == 0) last = last.substr(prefix.size());
    return last;
}

} // namespace

// A member's folder holds a finished run of exactly this experiment (resume): its manifest, written last by the
// runner, records the experiment as given.
std::optional<json> finished_manifest(const fs::path &folder, const json &experiment) {
    std::error_code ec;
    if (!fs::is_regular_file(folder / "manifest.json", ec)) return std::nullopt;
    try {
        json manifest = json::parse(read_text(folder / "manifest.json", "a manifest"));
        if (manifest.is_object() && manifest.contains("experiment") && manifest["experiment"] == experiment)
            return manifest;
    } catch (const std::exception &) {
    }
    return std::nullopt;
}

// Starts a member in a child process. The child records SIGINT/SIGTERM without the program's "second signal kills"
// rule, because the sweep forwards the signal to it even when it got one itself (a terminal's Ctrl-C, a scheduler
// signalling every process of the job): it must still stop cleanly.
//
// The member runs in a process group of its own (so that a signal reaches the compiler an `equations` member may run
// too) and ends with the sweep process: see member_stop_signal.
//
// The member's error message comes back through a pipe (`message_fd`, read end, non-blocking), not only through its
// log: the log lies in the sweep's folder, and when that folder's disk is full the log stays empty, which left the
// failed member's reason empty in the report.
pid_t start_member(const Sweep &s, const SweepMember &m, const fs::path &folder, const fs::path &log, int threads,
                   int &message_fd) {
    std::fflush(nullptr);
    int message[2] = {-1, -1};
    if (::pipe2(message, O_CLOEXEC | O_NONBLOCK) != 0)
        throw IoError(std::string("cannot start a process for ") + m.name + ": " + std::strerror(errno));
    const pid_t supervisor = ::getpid();
    const pid_t pid = ::fork();
    if (pid < 0) {
        const int err = errno;
        ::close(message[0]), ::close(message[1]);
        throw IoError(std::string("cannot start a process for ") + m.name + ": " + std::strerror(err));
    }
    if (pid > 0) {
        ::setpgid(pid, pid); // here as well as in the child: whichever runs first, the group exists on return
        ::close(message[1]);
        message_fd = message[0];
        return pid;
    }
    ::close(message[0]);
    ::setpgid(0, 0);
    member_supervisor = supervisor;
    struct sigaction action {};
    action.sa_handler = member_stop_signal;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESTART;
    sigaction(SIGINT, &action, nullptr);
    sigaction(SIGTERM, &action, nullptr);
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != supervisor) std::_Exit(128 + SIGKILL); // the sweep died before the line above
    omp_set_num_threads(threads);
    std::string error;
    const int code = run_member_here(s, m, folder, log, threads, error);
    // At most what a pipe takes without blocking (PIPE_BUF): the supervisor reads only once the member has ended.
    if (error.size() > 4000) error.resize(4000);
    if (!error.empty() && ::write(message[1], error.data(), error.size()) < 0) {
        // The log still has the message, where its disk allows.
    }
    std::_Exit(code);
}

// What a member that ended sent through its message pipe (start_member); closes it.
std::string read_member_message(int fd) {
    std::string text;
    char buffer[4096];
    for (ssize_t n; (n = ::read(fd, buffer, sizeof buffer)) > 0;) text.append(buffer, static_cast<std::size_t>(n));
    ::close(fd);
    return text;
}

// Why a member failed: its own message, else the last line of its log, else that there is none.
std::string failure_reason(const std::string &message, const fs::path &log) {
    if (!message.empty()) return message;
    const std::string logged = last_line(log);
    if (!logged.empty()) return logged;
    return "it gave no message (its log " + log.string() + " is empty" + storage_hint(log.parent_path()) + ")";
}

std::string exit_description(int status) {
    if (WIFEXITED(status)) {
        const int code = WEXITSTATUS(status);
        if (code == member_bad_input) return "bad input (exit 2)";
        return "exit " + std::to_string(code);
    }
    if (WIFSIGNALED(status)) return "killed by signal " + std::to_string(WTERMSIG(status));
    return "status " + std::to_string(status);
}

// Under mpirun: each rank takes members from the shared queue and runs them in its own process (an MPI process
// should not fork), then rank 0 collects every rank's outcomes. After SIGINT/SIGTERM a rank drains the queue without
// running more members.
void run_members_on_ranks(const Sweep &s, const fs::path &out, std::vector<std::size_t> pending, int threads,
                          bool quiet, std::vector<SweepMemberResult> &results) {
    // Rank 0's list of the members to run is everyone's: a rank that looked later could see members finished since.
    std::vector<std::uint64_t> shared(pending.begin(), pending.end());
    if (mpi::rank() == 0)
        for (int to = 1; to < mpi::size(); ++to) mpi::send_vector(to, shared);
    else
        shared = mpi::receive_vector<std::uint64_t>(0);
    pending.assign(shared.begin(), shared.end());
    json mine = json::array();
    {
        mpi::WorkQueue queue(pending.size());
        while (const auto next = queue.next()) {
            if (cancel_requested()) continue;
            const std::size_t k = pending[*next];
            const SweepMember &m = s.members[k];
            const fs::path log = out / "logs" / (m.name + ".log");
            if (!quiet) spdlog::info("{} ({}): started on rank {}", m.name, describe_member(s, m), mpi::rank());
            const auto start = std::chrono::steady_clock::now();
            omp_set_num_threads(threads);
            std::string error;
            const int code = run_member_here(s, m, out / m.name, log, threads, error);
            const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            json outcome = {{"member", k}, {"code", code}, {"wall_seconds", seconds}};
            if (code != member_ok && !(code > 128 && cancel_requested())) {
                outcome["message"] = "exit " + std::to_string(code) + ": " + failure_reason(error, log);
                spdlog::error("{} ({}) failed on rank {}, {} (log: {})", m.name, describe_member(s, m), mpi::rank(),
                              outcome["message"].get<std::string>(), log.string());
            } else if (code == member_ok && !quiet) {
                spdlog::info("{} ({}): done in {:.1f} s", m.name, describe_member(s, m), seconds);
            }
            mine.push_back(outcome);
        }
    }
    const auto record = [&](const json &outcomes) {
        for (const json &o : outcomes) {
            SweepMemberResult &r = results.at(o.at("member").get<std::size_t>());
            const int code = o.at("code").get<int>();
            r.wall_seconds = o.at("wall_seconds").get<double>();
            r.status = code == member_ok ? "done" : o.contains("message") ? "failed" : "interrupted";
            r.message = o.value("message", "");
        }
    };
    if (mpi::rank() != 0) {
        const std::string text = mine.dump();
        mpi::send_vector(0, std::vector<char>(text.begin(), text.end()));
        return;
    }
    record(mine);
    for (int from = 1; from < mpi::size(); ++from) {
        const std::vector<char> text = mpi::receive_vector<char>(from);
        record(json::parse(text.begin(), text.end()));
    }
}

// Names every member's result; members already complete from an earlier run (a manifest of the same experiment in
// their folder) are "reused", and the others' indices are returned, in order.
std::vector<std::size_t> members_to_run(const Sweep &s, const fs::path &out, bool quiet,
                                        std::vector<SweepMemberResult> &results) {
    results.resize(s.members.size());
    std::vector<std::size_t> pending;
    for (std::size_t k = 0; k < s.members.size(); ++k) {
        results[k].name = s.members[k].name;
        const fs::path folder = out / s.members[k].name;
        const std::optional<json> manifest = finished_manifest(folder, s.members[k].experiment);
        const std::string problem = manifest ? member_files_problem(folder, *manifest) : std::string();
        if (manifest && problem.empty()) {
            results[k].status = "reused";
            if (!quiet)
                spdlog::info("{} ({}): complete from an earlier run, skipped", s.members[k].name,
                             describe_member(s, s.members[k]));
        } else {
            if (manifest)
                spdlog::warn("{} ({}): not reused: {} holds a finished run of it, but its {}; running it again",
                             s.members[k].name, describe_member(s, s.members[k]), folder.string(), problem);
            pending.push_back(k);
        }
    }
    return pending;
}

} // namespace geobarrier::detail::sweeps
