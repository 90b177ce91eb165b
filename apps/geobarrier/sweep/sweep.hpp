// Parameter sweeps: one base experiment run once per combination of parameter values, each value set at a JSON
// pointer of the experiment (e.g. /forcing/params/amplitude). Every member gets its own output folder (written as
// atomically as a single run: a folder with manifest.json is a finished member), members spread over local processes
// or MPI ranks, a failed member is reported while the others finish, and a re-run skips the members already
// complete. The format is in docs/sweeps.md; running on clusters in docs/cluster.md.
#ifndef GEOBARRIER_SWEEP_SWEEP_HPP
#define GEOBARRIER_SWEEP_SWEEP_HPP

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace geobarrier {

// One swept parameter: the JSON pointer into the experiment, a short name for tables, and its values.
struct SweepParameter {
    std::string path; // e.g. "/forcing/params/amplitude"
    std::string name; // e.g. "amplitude" (the pointer's last token unless given)
    std::vector<nlohmann::json> values;
};

// One member: its folder name, the index of its value of each parameter, and its whole experiment.
struct SweepMember {
    std::string name;                // "member-003"
    std::vector<std::size_t> choice; // per parameter, the index into its values
    nlohmann::json experiment;       // the base with the member's values set
};

struct Sweep {
    std::filesystem::path file; // the sweep file ("" in memory)
    std::string description;
    std::filesystem::path relative_to; // what the members' relative paths are relative to (the base's file)
    nlohmann::json base;
    std::vector<SweepParameter> parameters;
    std::string combine = "grid"; // "grid": every combination; "zip": the k-th value of each
    std::vector<SweepMember> members;
    std::filesystem::path output_dir;
    std::vector<std::string> figures; // summary columns, see sweep_figure_names()
    std::string plot_figure;          // the figure drawn against plot_parameter ("" = no picture)
    std::size_t plot_parameter = 0;
    int processes = 0; // local processes (0: as many as cores, at most one per member)
    int threads = 0;   // threads per member (0: cores / processes)
};

// The named summary figures (besides a JSON pointer into the member's manifest.json).
const std::vector<std::string> &sweep_figure_names();

// Whether a JSON document is a sweep (it has "base") rather than an experiment.
bool is_sweep_json(const nlohmann::json &json);
// Reads the file and says whether it holds a sweep; false too when it is not valid JSON (the experiment reader then
// gives the error).
bool is_sweep_file(const std::filesystem::path &file);

// Parses and checks a sweep: structure, values, pointers (each must name a key of an object, or an element of an
// array, present in the base). Errors are ConfigErrors naming the JSON path in the sweep file. The members'
// experiments are checked by check_sweep_members.
Sweep parse_sweep(const nlohmann::json &json, const std::filesystem::path &file = {});
Sweep load_sweep(const std::filesystem::path &file);

// Checks every member as `validate` checks an experiment (its plugins and their parameters included). A member's
// error is a ConfigError at the parameter value that caused it ("/parameters/0/values/3"), or at /base.
void check_sweep_members(const Sweep &sweep);

struct SweepOptions {
    std::optional<std::filesystem::path> output_dir; // overrides output.dir
    int processes = 0;                               // overrides the sweep's
    int threads = 0;                                 // overrides the sweep's
    bool quiet = false;
};

struct SweepMemberResult {
    std::string name;
    std::string status;  // "done", "reused" (complete from an earlier run), "failed"
    std::string message; // why it failed (the member's last error line)
    double wall_seconds = 0.0;
    std::vector<double> figures; // per sweep.figures; NaN where not available
};

struct SweepResult {
    std::filesystem::path output_dir;
    std::vector<SweepMemberResult> members;
    std::vector<std::filesystem::path> files; // the summary files
    std::size_t failed = 0;
};

// Runs the members not yet complete and writes the summary (summary.csv, summary.md and, with a plot figure,
// summary.png). Throws Cancelled after SIGINT/SIGTERM once the running members have stopped (each leaves its folder
// as it was); no summary is written then. Under mpirun the members are shared by the ranks and rank 0 writes the
// summary (the others return an empty result).
SweepResult run_sweep(const Sweep &sweep, const SweepOptions &options);

} // namespace geobarrier

#endif // GEOBARRIER_SWEEP_SWEEP_HPP
