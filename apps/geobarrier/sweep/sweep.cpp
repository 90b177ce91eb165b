// Parameter sweeps (see sweep.hpp): parsing and checking the sweep file, running the members in forked processes
// (or in-process on MPI ranks), resuming, and the summary table and picture.
#include "sweep/sweep.hpp"
#include "output/folder_lock.hpp"
#include "output/provenance.hpp"
#include "run/mpi.hpp"
#include "sweep/continuation.hpp"
#include <geobarrier/cancel.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/output.hpp>

#include "experiment/json_reader.hpp"
#include "experiment/resources.hpp"

#include <netcdf.h>
#include <omp.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <thread>

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;
using nlohmann::json;

namespace geobarrier {

namespace {

using detail::ObjectReader;
using detail::short_dump;
using detail::type_name;

constexpr std::size_t max_members = 100000;
constexpr double not_available = std::numeric_limits<double>::quiet_NaN();

std::string read_text(const fs::path &file, const std::string &what) {
    std::error_code ec;
    if (fs::is_directory(file, ec)) throw IoError(file.string() + ": is a folder, not " + what);
    std::ifstream in(file, std::ios::binary);
    if (!in) throw IoError(file.string() + ": cannot open " + what);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) throw IoError(file.string() + ": cannot read " + what);
    return text;
}

// Where a swept pointer meets an array of the base, it must name an element of it, and it cannot go through a value
// that is neither object nor array. Keys absent from an object are created (a plugin's "params" left out, a parameter
// at its default); a misspelt key is caught when the members are checked as experiments, with a hint.
void check_pointer_in_base(const json &base, const std::string &pointer, const std::string &at) {
    const json::json_pointer ptr(pointer);
    const json *node = &base;
    std::string walked;
    std::vector<std::string> tokens;
    for (json::json_pointer p = ptr; !p.empty(); p.pop_back()) tokens.insert(tokens.begin(), p.back());
    for (std::size_t k = 0; k < tokens.size(); ++k) {
        const std::string &token = tokens[k];
        if (node->is_object()) {
            if (!node->contains(token)) return;
            node = &node->at(token);
        } else if (node->is_array()) {
            const bool digits = !token.empty() && std::all_of(token.begin(), token.end(), ::isdigit);
            if (!digits || token.size() > 9 || std::stoul(token) >= node->size())
                throw ConfigError(at, "\"" + pointer + "\": \"" + walked + "\" is an array of " +
                                          std::to_string(node->size()) + " elements; \"" + token +
                                          "\" is not the index of one");
            node = &node->at(std::stoul(token));
        } else {
            throw ConfigError(at, "\"" + pointer + "\": \"" + walked + "\" is " + type_name(*node) +
                                      ", not an object or array to set \"" + token + "\" in");
        }
        walked += "/" + token;
    }
}

// n values from `from` to `to`, both included, evenly spaced; integers where the base holds an integer there and
// every value is one.
std::vector<json> range_values(double from, double to, std::size_t count, bool integer) {
    std::vector<json> values;
    bool all_integral = integer;
    std::vector<double> numbers;
    for (std::size_t k = 0; k < count; ++k) {
        const double v =
            k + 1 == count ? to : from + (to - from) * static_cast<double>(k) / static_cast<double>(count - 1);
        numbers.push_back(v);
        all_integral = all_integral && std::nearbyint(v) == v && std::abs(v) < 9e15;
    }
    for (const double v : numbers) values.push_back(all_integral ? json(static_cast<long long>(v)) : json(v));
    return values;
}

std::string value_text(const json &v) { return v.is_string() ? v.get<std::string>() : v.dump(); }

// "amplitude = 0.08, omega = 1"
std::string describe_member(const Sweep &s, const SweepMember &m) {
    std::string text;
    for (std::size_t p = 0; p < s.parameters.size(); ++p)
        text += (p ? ", " : "") + s.parameters[p].name + " = " + value_text(s.parameters[p].values[m.choice[p]]);
    return text;
}

bool is_figure_pointer(const std::string &figure) { return !figure.empty() && figure[0] == '/'; }

// A base experiment run in both directions: its members' fields.nc lie in forward/ and backward/, so their FTLE
// figures are per direction (ftle_mean_forward, ...).
bool runs_both_directions(const json &base) {
    return base.contains("time") && base["time"].is_object() && base["time"].value("directions", json()) == "both";
}

// The figures the base experiment can give when the sweep names none.
std::vector<std::string> default_figures(const json &base) {
    std::vector<std::string> figures;
    if (base.contains("extractors") && base["extractors"].is_array())
        for (const json &x : base["extractors"])
            if (x.is_object() && x.value("plugin", json()).is_string() && x["plugin"] == "elliptic") {
                figures.push_back("outermost_elliptic_area");
                figures.push_back("elliptic_barriers");
                break;
            }
    if (base.contains("products") && base["products"].is_array())
        for (const json &p : base["products"])
            if (p == "ftle") {
                if (runs_both_directions(base)) {
                    figures.insert(figures.end(), {"ftle_mean_forward", "ftle_max_forward", "ftle_mean_backward",
                                                   "ftle_max_backward"});
                } else {
                    figures.push_back("ftle_mean");
                    figures.push_back("ftle_max");
                }
            }
    // An open system's safe basin: its share of the grid, member by member (an erosion curve over the forcing).
    if (base.contains("bounds") && base["bounds"].is_object() && base["bounds"].value("exits", "stop") == "stop")
        figures.push_back("captured_fraction");
    figures.push_back("masked_fraction");
    return figures;
}

} // namespace

const std::vector<std::string> &sweep_figure_names() {
    static const std::vector<std::string> names = {
        "outermost_elliptic_area", "elliptic_barriers", "barriers",           "ftle_mean",         "ftle_max",
        "ftle_mean_forward",       "ftle_max_forward",  "ftle_mean_backward", "ftle_max_backward", "captured_fraction",
        "masked_fraction",         "wall_seconds"};
    return names;
}

bool is_sweep_json(const json &j) { return j.is_object() && j.contains("base"); }

bool is_sweep_file(const fs::path &file) {
    try {
        return is_sweep_json(parse_json_text(read_text(file, "a sweep file"), file.string()));
    } catch (const Error &) {
        return false;
    }
}

namespace {

// The sections of a sweep file, one reader each, in the order parse_sweep reads them.

// "base": the experiment itself, or the path of its file (relative to the sweep file's `folder`).
void read_base(const json &base, const fs::path &file, const fs::path &folder, Sweep &s) {
    if (base.is_string()) {
        fs::path path = base.get<std::string>();
        if (path.empty()) throw ConfigError("/base", "\"\" is empty; expected the path of an experiment file");
        if (path.is_relative()) path = (folder / path).lexically_normal();
        std::string text;
        try {
            text = read_text(path, "the base experiment file");
        } catch (const IoError &e) {
            throw ConfigError("/base", e.what());
        }
        s.base = parse_json_text(text, path.string());
        s.relative_to = path;
    } else if (base.is_object()) {
        s.base = base;
        s.relative_to = file;
    } else {
        throw ConfigError("/base", short_dump(base) + " is " + type_name(base) +
                                       "; expected an experiment (an object) or the path of an experiment file");
    }
    if (!s.base.is_object())
        throw ConfigError("/base", short_dump(s.base) + " is " + type_name(s.base) + "; expected an experiment object");
    if (is_sweep_json(s.base)) throw ConfigError("/base", "is a sweep itself; sweeps do not nest");
    // Frames (frames.hpp) write their fields and barriers into frames/NNN, where no figure looks: refused, not empty.
    const json *t0 = s.base.contains("time") && s.base["time"].is_object() && s.base["time"].contains("t0")
                         ? &s.base["time"]["t0"]
                         : nullptr;
    if (t0 && (t0->is_array() || t0->is_object()))
        throw ConfigError("/base/time/t0", "several initial times (frames) are not supported in a sweep; sweep a "
                                           "single t0, or run the frames of each member as its own experiment");
}

// One entry of "parameters" (at JSON path `at`): its path into the base experiment, name and values. `earlier` are
// the entries before it.
SweepParameter read_parameter(const json &entry, const std::string &at, const json &base,
                              const std::vector<SweepParameter> &earlier) {
    ObjectReader p(entry, at);
    SweepParameter parameter;
    parameter.path = p.string("path", std::nullopt);
    json::json_pointer pointer;
    try {
        pointer = json::json_pointer(parameter.path);
    } catch (const json::exception &) {
        throw ConfigError(p.child("path"),
                          "\"" + parameter.path + "\" is not a JSON pointer (e.g. \"/forcing/params/amplitude\")");
    }
    if (pointer.empty())
        throw ConfigError(p.child("path"), "\"\" is the whole experiment; name a value in it (e.g. "
                                           "\"/forcing/params/amplitude\")");
    if (parameter.path.rfind("/output", 0) == 0)
        throw ConfigError(p.child("path"), "\"" + parameter.path +
                                               "\": each member writes into its own folder "
                                               "of the sweep's output; sweep \"output\" in the sweep file instead");
    check_pointer_in_base(base, parameter.path, p.child("path"));
    for (const SweepParameter &other : earlier)
        if (other.path == parameter.path)
            throw ConfigError(p.child("path"), "\"" + parameter.path + "\" is swept twice");
    parameter.name = p.string("name", pointer.back());
    if (parameter.name.empty()) throw ConfigError(p.child("name"), "\"\" is empty; expected a column name");
    const bool has_values = p.has("values"), has_range = p.has("range");
    if (has_values == has_range)
        throw ConfigError(at, has_values ? "give either \"values\" or \"range\", not both"
                                         : "missing \"values\" (a list) or \"range\" ({\"from\", \"to\", \"count\"})");
    if (has_values) {
        const json &values = p.get("values");
        if (!values.is_array() || values.empty())
            throw ConfigError(p.child("values"), short_dump(values) + " must be a non-empty array of values");
        for (const json &v : values) parameter.values.push_back(v);
    } else {
        ObjectReader r(p.get("range"), p.child("range"));
        const double from = r.number("from"), to = r.number("to");
        r.get("count");
        const std::size_t count = r.count("count", 2, 2, max_members);
        r.finish();
        const bool integer = base.contains(pointer) && base.at(pointer).is_number_integer();
        parameter.values = range_values(from, to, count, integer);
    }
    p.finish();
    return parameter;
}

std::vector<SweepParameter> read_parameters(const json &params, const json &base) {
    if (!params.is_array() || params.empty())
        throw ConfigError("/parameters", short_dump(params) + " must be a non-empty array of {\"path\": \"/...\", "
                                                              "\"values\": [...]} or {\"path\": ..., \"range\": ...}");
    std::vector<SweepParameter> parameters;
    for (std::size_t i = 0; i < params.size(); ++i)
        parameters.push_back(read_parameter(params[i], "/parameters/" + std::to_string(i), base, parameters));
    return parameters;
}

// The members: every combination of the values ("grid"), or the k-th values together ("zip"), in the order of
// nested loops over the parameters as listed (the last one fastest).
std::vector<SweepMember> make_members(const Sweep &s) {
    std::size_t count = 1;
    if (s.combine == "zip") {
        count = s.parameters[0].values.size();
        for (std::size_t i = 1; i < s.parameters.size(); ++i)
            if (s.parameters[i].values.size() != count)
                throw ConfigError("/parameters/" + std::to_string(i),
                                  std::to_string(s.parameters[i].values.size()) + " values, but /parameters/0 has " +
                                      std::to_string(count) + "; \"combine\": \"zip\" pairs the k-th values");
    } else {
        for (const SweepParameter &p : s.parameters) {
            count *= p.values.size();
            if (count > max_members)
                throw ConfigError("/parameters", "more than " + std::to_string(max_members) + " members");
        }
    }
    const std::size_t digits = std::max<std::size_t>(3, std::to_string(count - 1).size());
    std::vector<SweepMember> members;
    for (std::size_t k = 0; k < count; ++k) {
        SweepMember m;
        m.choice.resize(s.parameters.size());
        std::size_t rest = k;
        for (std::size_t p = s.parameters.size(); p-- > 0;) {
            if (s.combine == "zip") {
                m.choice[p] = k;
            } else {
                m.choice[p] = rest % s.parameters[p].values.size();
                rest /= s.parameters[p].values.size();
            }
        }
        const std::string number = std::to_string(k);
        m.name = "member-" + std::string(digits - number.size(), '0') + number;
        m.experiment = s.base;
        for (std::size_t p = 0; p < s.parameters.size(); ++p)
            m.experiment[json::json_pointer(s.parameters[p].path)] = s.parameters[p].values[m.choice[p]];
        members.push_back(std::move(m));
    }
    return members;
}

// FTLE figures and the base's directions: a member run in both directions has no fields.nc of its own (an empty
// column before), one run in one direction no forward/ or backward/.
void check_direction_figures(const std::vector<std::string> &figures, const json &base) {
    const bool both = runs_both_directions(base);
    for (std::size_t i = 0; i < figures.size(); ++i) {
        const std::string &f = figures[i];
        const bool per_direction = f.rfind("ftle_", 0) == 0 && (f.find("_forward") != std::string::npos ||
                                                                f.find("_backward") != std::string::npos);
        if (both && (f == "ftle_mean" || f == "ftle_max"))
            throw ConfigError("/figures/" + std::to_string(i),
                              "\"" + f +
                                  "\": the members run both directions (/base/time/directions), each with its "
                                  "own FTLE field; name \"" +
                                  f + "_forward\" or \"" + f + "_backward\"");
        if (!both && per_direction)
            throw ConfigError("/figures/" + std::to_string(i),
                              "\"" + f +
                                  "\" is a figure of members run in both directions, and /base/time/directions "
                                  "is not \"both\"; name \"" +
                                  f.substr(0, f.rfind('_')) + "\"");
    }
}

std::vector<std::string> read_figures(const json &figures) {
    if (!figures.is_array()) throw ConfigError("/figures", short_dump(figures) + " must be an array of figure names");
    const auto &names = sweep_figure_names();
    std::vector<std::string> out;
    for (std::size_t i = 0; i < figures.size(); ++i) {
        const std::string at = "/figures/" + std::to_string(i);
        if (!figures[i].is_string()) throw ConfigError(at, short_dump(figures[i]) + " must be a figure name");
        const std::string name = figures[i].get<std::string>();
        if (is_figure_pointer(name)) {
            try {
                json::json_pointer{name};
            } catch (const json::exception &) {
                throw ConfigError(at, "\"" + name + "\" is not a JSON pointer into manifest.json");
            }
        } else if (std::find(names.begin(), names.end(), name) == names.end()) {
            std::string msg = "unknown figure \"" + name + "\"";
            const std::string hint = did_you_mean(name, names);
            if (!hint.empty()) msg += "; did you mean \"" + hint + "\"?";
            msg += " (known:";
            for (const auto &n : names) msg += " " + n;
            throw ConfigError(at, msg + ", or a JSON pointer into the member's manifest.json)");
        }
        out.push_back(name);
    }
    return out;
}

bool numeric(const SweepParameter &p) {
    return std::all_of(p.values.begin(), p.values.end(), [](const json &v) { return v.is_number(); });
}

// "plot": true/false, or {"figure", "parameter"}; by default the first figure against the first parameter when its
// values are numbers.
void read_plot(const ObjectReader &root, Sweep &s) {
    if (root.has("plot") && root.get("plot").is_boolean()) {
        if (root.boolean("plot", true)) {
            if (s.figures.empty()) throw ConfigError("/plot", "true, but there is no figure to draw");
            s.plot_figure = s.figures.front();
        }
        return;
    }
    if (!root.has("plot")) {
        if (!s.figures.empty() && numeric(s.parameters.front())) s.plot_figure = s.figures.front();
        return;
    }
    ObjectReader pl(root.get("plot"), "/plot");
    s.plot_figure = pl.string("figure", s.figures.empty() ? std::string() : s.figures.front(), s.figures);
    if (s.plot_figure.empty()) throw ConfigError("/plot/figure", "there is no figure to draw");
    if (pl.has("parameter")) {
        const std::string which = pl.string("parameter", std::nullopt);
        std::vector<std::string> choices;
        bool found = false;
        for (std::size_t i = 0; i < s.parameters.size() && !found; ++i) {
            if (s.parameters[i].path == which || s.parameters[i].name == which) {
                s.plot_parameter = i;
                found = true;
            }
            choices.push_back(s.parameters[i].name);
        }
        if (!found) {
            std::string msg = "\"" + which + "\" is not a swept parameter's path or name";
            const std::string hint = did_you_mean(which, choices);
            if (!hint.empty()) msg += "; did you mean \"" + hint + "\"?";
            throw ConfigError(pl.child("parameter"), msg);
        }
    }
    pl.finish();
    if (!numeric(s.parameters[s.plot_parameter]))
        throw ConfigError("/plot/parameter", "\"" + s.parameters[s.plot_parameter].path +
                                                 "\" has values that are not numbers; a picture needs an axis");
}

} // namespace

Sweep parse_sweep(const json &j, const fs::path &file) {
    Sweep s;
    s.file = file;
    ObjectReader root(j, "");
    const fs::path folder = file.empty() ? fs::current_path() : fs::absolute(file).parent_path();

    s.description = root.string("description", std::string());
    read_base(root.get("base"), file, folder, s);
    s.parameters = read_parameters(root.get("parameters"), s.base);
    s.combine = root.string("combine", s.combine, {"grid", "zip"});
    s.members = make_members(s);

    const std::string stem = file.empty() ? std::string("sweep") : file.stem().string();
    s.output_dir = "out/" + stem;
    if (root.has("output")) {
        ObjectReader o(root.get("output"), "/output");
        s.output_dir = o.string("dir", s.output_dir.string());
        if (s.output_dir.empty()) throw ConfigError("/output/dir", "\"\" is empty; expected a folder path");
        o.finish();
    }
    s.figures = root.has("figures") ? read_figures(root.get("figures")) : default_figures(s.base);
    check_direction_figures(s.figures, s.base);
    read_plot(root, s);
    s.processes = static_cast<int>(root.count("processes", 0, 1, 4096));
    s.threads = static_cast<int>(root.count("threads", 0, 1, max_threads));
    root.finish();
    return s;
}

Sweep load_sweep(const fs::path &file) {
    const json j = parse_json_text(read_text(file, "the sweep file"), file.string());
    try {
        return parse_sweep(j, file);
    } catch (const ConfigError &e) {
        throw ConfigError(file.string() + ": " + e.json_path(), std::string(e.what()).substr(e.json_path().size() + 2));
    }
}

void check_sweep_members(const Sweep &s) {
    const std::string prefix = s.file.empty() ? std::string() : s.file.string() + ": ";
    for (const SweepMember &m : s.members) {
        try {
            resolve_experiment(parse_experiment(m.experiment, s.relative_to));
        } catch (const ConfigError &e) {
            // Blame the swept value whose pointer holds the error's path, or the pointer itself when the error is
            // above it (a misspelt key on the way), else the base.
            const auto within = [](const std::string &path, const std::string &prefix) {
                return path.rfind(prefix, 0) == 0 && (path.size() == prefix.size() || path[prefix.size()] == '/');
            };
            std::string at = "/base";
            for (std::size_t p = 0; p < s.parameters.size(); ++p) {
                const std::string here = "/parameters/" + std::to_string(p);
                if (within(e.json_path(), s.parameters[p].path)) {
                    at = here + "/values/" + std::to_string(m.choice[p]);
                    break;
                }
                if (within(s.parameters[p].path, e.json_path())) {
                    at = here + "/path";
                    break;
                }
            }
            throw ConfigError(prefix + at, m.name + " (" + describe_member(s, m) + "): " + e.what());
        }
    }
}

namespace {

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

// The exit codes of `geobarrier run`, for a member run here or in a forked process.
constexpr int member_ok = 0, member_failed = 1, member_bad_input = 2;

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

// Mean and maximum of the FTLE over the unmasked points of a member's fields.nc.
std::pair<double, double> ftle_mean_max(const fs::path &file) {
    int ncid = -1;
    if (nc_open(file.c_str(), NC_NOWRITE, &ncid) != NC_NOERR) return {not_available, not_available};
    int ftle_id = -1, mask_id = -1;
    std::pair<double, double> result{not_available, not_available};
    if (nc_inq_varid(ncid, "ftle", &ftle_id) == NC_NOERR && nc_inq_varid(ncid, "mask", &mask_id) == NC_NOERR) {
        int dims[2];
        int ndims = 0;
        std::size_t n = 1;
        if (nc_inq_varndims(ncid, ftle_id, &ndims) == NC_NOERR && ndims == 2 &&
            nc_inq_vardimid(ncid, ftle_id, dims) == NC_NOERR) {
            for (int d : dims) {
                std::size_t len = 0;
                nc_inq_dimlen(ncid, d, &len);
                n *= len;
            }
            std::vector<double> ftle(n);
            std::vector<unsigned char> mask(n);
            if (nc_get_var_double(ncid, ftle_id, ftle.data()) == NC_NOERR &&
                nc_get_var_uchar(ncid, mask_id, mask.data()) == NC_NOERR) {
                double sum = 0.0, max = -std::numeric_limits<double>::infinity();
                std::size_t used = 0;
                for (std::size_t k = 0; k < n; ++k) {
                    if (mask[k] & mask_trajectory_bits || !std::isfinite(ftle[k])) continue;
                    sum += ftle[k];
                    max = std::max(max, ftle[k]);
                    ++used;
                }
                if (used > 0) result = {sum / static_cast<double>(used), max};
            }
        }
    }
    nc_close(ncid);
    return result;
}

// The sweep's figures of one finished member, from its manifest, barriers.json and fields.nc.
std::vector<double> member_figures(const Sweep &s, const fs::path &folder, const json &manifest) {
    std::optional<json> barriers;
    std::optional<std::pair<double, double>> ftle;
    std::vector<double> values;
    for (const std::string &figure : s.figures) {
        double v = not_available;
        if (is_figure_pointer(figure)) {
            const json::json_pointer ptr(figure);
            if (manifest.contains(ptr) && manifest.at(ptr).is_number()) v = manifest.at(ptr).get<double>();
        } else if (figure == "wall_seconds") {
            v = manifest.value("wall_seconds", not_available);
        } else if (figure == "captured_fraction") {
            const json escape = manifest.value("escape", json::object());
            v = escape.value("captured_fraction", not_available);
        } else if (figure == "masked_fraction") {
            const json stats = manifest.value("integrator_stats", json::object());
            const double trajectories = stats.value("trajectories", 0.0);
            if (trajectories > 0) v = stats.value("masked", 0.0) / trajectories;
        } else if (figure == "ftle_mean" || figure == "ftle_max") {
            if (!ftle) ftle = ftle_mean_max(folder / "fields.nc");
            v = figure == "ftle_mean" ? ftle->first : ftle->second;
        } else if (figure.rfind("ftle_", 0) == 0) { // ftle_{mean,max}_{forward,backward}: that direction's run
            const std::string direction = figure.substr(figure.rfind('_') + 1);
            const auto value = ftle_mean_max(folder / direction / "fields.nc");
            v = figure.rfind("ftle_mean", 0) == 0 ? value.first : value.second;
        } else {
            if (!barriers) {
                try {
                    barriers = json::parse(read_text(folder / "barriers.json", "barriers.json")).at("barriers");
                } catch (const std::exception &) {
                    barriers = json();
                }
            }
            if (barriers->is_array()) {
                double count = 0, elliptic = 0, area = not_available;
                for (const json &b : *barriers) {
                    ++count;
                    if (b.value("kind", "") != "elliptic") continue;
                    ++elliptic;
                    if (b.value("outermost", false) && b.contains("enclosed_area") && b["enclosed_area"].is_number()) {
                        const double a = b["enclosed_area"].get<double>();
                        area = std::isnan(area) ? a : std::max(area, a);
                    }
                }
                v = figure == "barriers" ? count : figure == "elliptic_barriers" ? elliptic : area;
            }
        }
        values.push_back(v);
    }
    return values;
}

std::string number_text(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string(); }

std::string csv_field(std::string text) {
    if (text.find_first_of(",\"\n") == std::string::npos) return text;
    for (std::size_t at = text.find('"'); at != std::string::npos; at = text.find('"', at + 2)) text.insert(at, "\"");
    return "\"" + text + "\"";
}

std::string markdown_cell(std::string text) {
    for (std::size_t at = text.find('|'); at != std::string::npos; at = text.find('|', at + 2)) text.insert(at, "\\");
    std::replace(text.begin(), text.end(), '\n', ' ');
    return text;
}

// summary.csv, summary.md and (with a plot figure) summary.png in `out`.
std::vector<fs::path> write_summary(const Sweep &s, const fs::path &out,
                                    const std::vector<SweepMemberResult> &results) {
    std::vector<std::string> header = {"member"};
    for (const SweepParameter &p : s.parameters) header.push_back(p.name);
    header.push_back("status");
    for (const std::string &f : s.figures) header.push_back(f);
    header.push_back("wall_seconds");
    header.push_back("message");
    std::vector<std::vector<std::string>> rows;
    for (std::size_t k = 0; k < s.members.size(); ++k) {
        const SweepMember &m = s.members[k];
        const SweepMemberResult &r = results[k];
        std::vector<std::string> row = {m.name};
        for (std::size_t p = 0; p < s.parameters.size(); ++p)
            row.push_back(value_text(s.parameters[p].values[m.choice[p]]));
        row.push_back(r.status);
        for (std::size_t f = 0; f < s.figures.size(); ++f)
            row.push_back(f < r.figures.size() ? number_text(r.figures[f]) : std::string());
        row.push_back(r.wall_seconds > 0 ? fmt::format("{:.2f}", r.wall_seconds) : std::string());
        row.push_back(r.message);
        rows.push_back(std::move(row));
    }
    std::string csv, md;
    for (std::size_t c = 0; c < header.size(); ++c) {
        csv += (c ? "," : "") + csv_field(header[c]);
        md += "| " + markdown_cell(header[c]) + " ";
    }
    csv += "\n";
    md += "|\n";
    for (std::size_t c = 0; c < header.size(); ++c) md += "|---";
    md += "|\n";
    for (const auto &row : rows) {
        for (std::size_t c = 0; c < row.size(); ++c) {
            csv += (c ? "," : "") + csv_field(row[c]);
            md += "| " + markdown_cell(row[c].empty() ? std::string("-") : row[c]) + " ";
        }
        csv += "\n";
        md += "|\n";
    }
    std::vector<fs::path> files = {out / "summary.csv", out / "summary.md"};
    write_text_file(files[0], csv);
    write_text_file(files[1], md);

    if (!s.plot_figure.empty()) {
        const std::size_t f =
            static_cast<std::size_t>(std::find(s.figures.begin(), s.figures.end(), s.plot_figure) - s.figures.begin());
        const std::size_t x = s.plot_parameter;
        // One series per combination of the other parameters' values, in member order.
        std::map<std::vector<std::size_t>, std::size_t> series_of;
        XYPlot plot;
        plot.title = s.plot_figure + " against " + s.parameters[x].name;
        plot.x_label = s.parameters[x].name + " (" + s.parameters[x].path + ")";
        plot.y_label = s.plot_figure;
        static const char *colors[] = {"blue", "red", "green", "black", "magenta", "cyan", "orange", "brown"};
        for (std::size_t k = 0; k < s.members.size(); ++k) {
            std::vector<std::size_t> others = s.members[k].choice;
            others[x] = 0;
            auto [it, inserted] = series_of.emplace(others, plot.series.size());
            if (inserted) {
                PlotSeries series;
                series.style = PlotSeries::Style::line_points;
                series.color = colors[plot.series.size() % (sizeof colors / sizeof *colors)];
                for (std::size_t p = 0; p < s.parameters.size(); ++p)
                    if (p != x)
                        series.label += (series.label.empty() ? "" : ", ") + s.parameters[p].name + " = " +
                                        value_text(s.parameters[p].values[others[p]]);
                plot.series.push_back(series);
            }
            const double value = f < results[k].figures.size() ? results[k].figures[f] : not_available;
            auto &xy = plot.series[it->second].xy;
            xy.push_back(s.parameters[x].values[s.members[k].choice[x]].get<double>());
            xy.push_back(value); // NaN (failed, or no such barrier) leaves a gap
        }
        bool any = false;
        for (const auto &series : plot.series)
            for (std::size_t k = 1; k < series.xy.size(); k += 2) any = any || std::isfinite(series.xy[k]);
        if (any) {
            files.push_back(out / "summary.png");
            plot_xy_png(files.back(), plot);
        } else {
            spdlog::warn("sweep: no member has a value of {}; summary.png not drawn", s.plot_figure);
        }
    }
    return files;
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
