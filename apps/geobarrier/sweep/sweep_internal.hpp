// The parts of a sweep's run that its files share (private to apps/geobarrier/sweep): the file's helpers
// (sweep_file.cpp), the members' processes and ranks (sweep_members.cpp), the summary (sweep_summary.cpp); run_sweep
// (sweep.cpp) puts them together.
#ifndef GEOBARRIER_SWEEP_SWEEP_INTERNAL_HPP
#define GEOBARRIER_SWEEP_SWEEP_INTERNAL_HPP

#include "sweep/sweep.hpp"

#include <nlohmann/json.hpp>

#include <sys/types.h>

#include <cstddef>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace geobarrier::detail::sweeps {

// A figure a member does not have (failed, or no such barrier): an empty cell, a gap in the picture.
inline constexpr double not_available = std::numeric_limits<double>::quiet_NaN();

// The exit codes of `geobarrier run`, for a member run here or in a forked process.
inline constexpr int member_ok = 0, member_failed = 1, member_bad_input = 2;

// sweep_file.cpp
// The whole file as text; IoError naming it as `what` when it is a folder or cannot be read.
std::string read_text(const std::filesystem::path &file, const std::string &what);
// A parameter value as a table shows it: a string without its quotes, anything else as JSON.
std::string value_text(const nlohmann::json &v);
// "amplitude = 0.08, omega = 1"
std::string describe_member(const Sweep &s, const SweepMember &m);
// A summary figure given as a JSON pointer into the member's manifest.json rather than by name.
bool is_figure_pointer(const std::string &figure);

// sweep_members.cpp
// A member's folder holds a finished run of exactly this experiment (resume): its manifest, written last by the
// runner, records the experiment as given.
std::optional<nlohmann::json> finished_manifest(const std::filesystem::path &folder, const nlohmann::json &experiment);
// Names every member's result; members already complete from an earlier run are "reused", and the others' indices
// are returned, in order.
std::vector<std::size_t> members_to_run(const Sweep &s, const std::filesystem::path &out, bool quiet,
                                        std::vector<SweepMemberResult> &results);
// Starts a member in a child process of its own process group; its error message comes back through `message_fd`.
pid_t start_member(const Sweep &s, const SweepMember &m, const std::filesystem::path &folder,
                   const std::filesystem::path &log, int threads, int &message_fd);
// What a member that ended sent through its message pipe (start_member); closes it.
std::string read_member_message(int fd);
// Why a member failed: its own message, else the last line of its log, else that there is none.
std::string failure_reason(const std::string &message, const std::filesystem::path &log);
// A member's wait status in words: "exit 1", "bad input (exit 2)", "killed by signal 9".
std::string exit_description(int status);
// Under mpirun: the pending members run on the ranks, one at a time per rank; rank 0 collects the outcomes.
void run_members_on_ranks(const Sweep &s, const std::filesystem::path &out, std::vector<std::size_t> pending,
                          int threads, bool quiet, std::vector<SweepMemberResult> &results);

// sweep_summary.cpp
// The sweep's figures of one finished member, from its manifest, barriers.json and fields.nc.
std::vector<double> member_figures(const Sweep &s, const std::filesystem::path &folder, const nlohmann::json &manifest);
// summary.csv, summary.md and (with a plot figure) summary.png in `out`; returns the files written.
std::vector<std::filesystem::path> write_summary(const Sweep &s, const std::filesystem::path &out,
                                                 const std::vector<SweepMemberResult> &results);

} // namespace geobarrier::detail::sweeps

#endif // GEOBARRIER_SWEEP_SWEEP_INTERNAL_HPP
