// The geobarrier command-line program: run and validate experiments, list plugins.
#include "openmp_wait.hpp"
#include "run/mpi.hpp"
#include "sweep/sweep.hpp"

#include "equations/equations.hpp"
#include <geobarrier/cancel.hpp>
#include <geobarrier/conformance.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/plugin.hpp>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <new>
#include <optional>

namespace fs = std::filesystem;
using namespace geobarrier;

namespace {

// Exit codes: 0 success, 1 the computation failed, 2 bad input (experiment, command line, a damaged plugin library).
constexpr int exit_failure = 1;
constexpr int exit_bad_input = 2;

void setup_logging(bool quiet, bool verbose) {
    auto logger = spdlog::stderr_color_mt("geobarrier");
    logger->set_pattern("%^[%l]%$ %v");
    spdlog::set_default_logger(logger);
    spdlog::set_level(quiet ? spdlog::level::warn : verbose ? spdlog::level::debug : spdlog::level::info);
}

// Every input error names the file: the parser's own errors do ("exp.json:3:7: ..."), and those found later, in
// the plugins' parameters or while running, carry only the JSON path ("/system/params/omega0: ..."), so the
// experiment's file name goes in front of them here.
template <class Step> auto naming_the_file(const fs::path &file, Step &&step) -> decltype(step()) {
    try {
        return step();
    } catch (const ConfigError &e) {
        if (e.json_path().empty() || e.json_path()[0] != '/') throw;
        throw ConfigError(file.string() + ": " + e.json_path(), std::string(e.what()).substr(e.json_path().size() + 2));
    }
}

int command_run(const fs::path &file, const std::optional<fs::path> &out, int threads, bool quiet) {
    const Experiment experiment = load_experiment(file);
    const ResolvedExperiment resolved = naming_the_file(file, [&] { return resolve_experiment(experiment); });
    spdlog::info("{}: {} + {} on a {} x {} grid, t = {} to {}", file.string(), resolved.system.info().name,
                 resolved.forcing.info().name, experiment.grid.nx, experiment.grid.ny, experiment.t0, experiment.t1);
    RunOptions options;
    options.output_dir = out;
    options.threads = threads;
    options.quiet = quiet;
    const RunSummary summary = naming_the_file(file, [&] { return run_experiment(resolved, options); });
    // A signal that came while the finished files were being moved into place (renames, finished once begun): the
    // result is whole, but the run was asked to stop, so it does not exit 0.
    if (const int signal = cancel_requested()) {
        std::cerr << "geobarrier: interrupted by " << signal_name(signal) << " while moving the finished files into "
                  << "place; they were all moved first: " << summary.output_dir.string()
                  << " holds this run's complete result\n";
        return 128 + signal;
    }
    if (!quiet) {
        std::cout << "wrote " << summary.files.size() << " files to " << summary.output_dir.string() << ":\n";
        for (const auto &f : summary.files) std::cout << "  " << f.string() << "\n";
        // "convergence": how many barriers persist under every changed run (the warnings named the others).
        if (const auto c = summary.manifest.find("convergence"); c != summary.manifest.end() && c->is_object())
            std::cout << "convergence: " << c->at("converged") << " of " << c->at("barriers")
                      << " barriers persist under every change (at least " << c->at("threshold").get<double>()
                      << " of their length within " << c->at("spacings").get<double>()
                      << " grid spacings of each changed run's "
                      << "barriers); barriers.json gives each one's \"persistence\"\n";
    }
    return 0;
}

// A sweep file (docs/sweeps.md): checked as strictly as an experiment, every member included.
int command_validate_sweep(const fs::path &file) {
    const Sweep sweep = load_sweep(file);
    check_sweep_members(sweep);
    std::cout << file.string() << ": valid sweep (" << sweep.members.size() << " members over";
    for (const auto &p : sweep.parameters) std::cout << " " << p.path << " (" << p.values.size() << " values)";
    std::cout << ", " << sweep.combine << "; figures:";
    for (const auto &f : sweep.figures) std::cout << " " << f;
    std::cout << ")\n";
    return 0;
}

int command_sweep(const fs::path &file, const SweepOptions &options) {
    const Sweep sweep = load_sweep(file);
    SweepResult result;
    try {
        result = run_sweep(sweep, options);
    } catch (const Cancelled &e) { // finished members stay (each is whole), so not the run's message
        std::cerr << "geobarrier: " << e.what() << "\n";
        return 128 + e.signal();
    }
    if (result.files.empty()) return 0; // an MPI rank other than 0: rank 0 reports
    if (!options.quiet) {
        std::cout << "swept " << result.members.size() << " members into " << result.output_dir.string() << ":\n";
        for (const auto &f : result.files) std::cout << "  " << f.string() << "\n";
    }
    if (result.failed == 0) return 0;
    std::cerr << "geobarrier: error: " << result.failed << " of " << result.members.size() << " members failed:";
    for (const auto &m : result.members)
        if (m.status == "failed") std::cerr << " " << m.name << " (" << m.message << ");";
    std::cerr << " the others are complete; see " << (result.output_dir / "summary.md").string() << "\n";
    return exit_failure;
}

int command_validate(const fs::path &file) {
    if (is_sweep_file(file)) return command_validate_sweep(file);
    const Experiment experiment = load_experiment(file);
    const ResolvedExperiment resolved = naming_the_file(file, [&] { return resolve_experiment(experiment); });
    std::cout << file.string() << ": valid (" << resolved.system.info().name << " + " << resolved.forcing.info().name
              << ", " << experiment.grid.nx << " x " << experiment.grid.ny << " grid, products:";
    for (const auto &p : experiment.products) std::cout << " " << p;
    for (const auto &x : resolved.extractors) std::cout << " extractor:" << x.info().name;
    const nlohmann::json validation = validation_to_json(experiment.validation, experiment.t0, experiment.t1);
    for (const auto &item : validation.items()) std::cout << " validation:" << item.key();
    std::cout << ")\n";
    // Every library the experiment maps (its code runs), and only those: the registry loads on demand.
    std::vector<fs::path> listed;
    for (const LoadedLibrary &l : resolved.registry.libraries()) {
        std::cout << "  loads " << l.file.string() << " (";
        for (std::size_t i = 0; i < l.plugins.size(); ++i) std::cout << (i ? ", " : "") << l.plugins[i];
        std::cout << (l.plugins.empty() ? "no plugin" : "") << "; " << l.reason << ")\n";
        listed.push_back(l.file);
    }
    const fs::path &system_file = resolved.system.info().file;
    if (std::find(listed.begin(), listed.end(), system_file) == listed.end())
        std::cout << "  loads " << system_file.string() << " (system '" << resolved.system.info().name
                  << "'; compiled from the experiment)\n";
    // Warnings on stderr (e.g. a clamped rtol, a plugin folder's library skipped, a plugin shadowing another of its
    // name): stdout holds only the verdict.
    for (const auto &w : resolved.registry.warnings()) std::cerr << "geobarrier: warning: " << w << "\n";
    for (const auto &w : experiment.warnings)
        std::cerr << "geobarrier: warning: " << file.string() << ": " << w << "\n";
    return 0;
}

int command_plugins(bool as_json, const std::vector<std::string> &extra) {
    std::vector<fs::path> folders(extra.begin(), extra.end());
    const PluginRegistry registry(PluginRegistry::default_folders(folders));
    if (as_json) {
        nlohmann::json j;
        j["folders"] = nlohmann::json::array();
        for (const auto &f : registry.folders()) j["folders"].push_back(f.string());
        j["plugins"] = nlohmann::json::array();
        for (const auto &h : registry.plugins()) j["plugins"].push_back(plugin_info_to_json(h.info));
        // Systems of the core itself, not plugin files: their parameters are structured, not a plugin schema.
        j["built_in"] = nlohmann::json::array({equations::schema()});
        j["warnings"] = registry.warnings();
        std::cout << j.dump(2) << "\n";
        return 0;
    }
    for (const PluginKind kind : {PluginKind::system, PluginKind::forcing, PluginKind::extractor}) {
        std::cout << to_string(kind) << "s:\n";
        bool any = false;
        if (kind == PluginKind::system) {
            any = true;
            const nlohmann::json schema = equations::schema();
            std::cout << "  " << equations::plugin_name << " (built in) - " << equations::doc() << "\n";
            for (const auto &p : schema["params"])
                std::cout << "      " << p["name"].get<std::string>() << " (" << p["type"].get<std::string>()
                          << "): " << p["doc"].get<std::string>() << "\n";
        }
        for (const auto &h : registry.plugins()) {
            if (h.info.kind != kind) continue;
            any = true;
            std::cout << "  " << h.info.name << " " << h.info.version << " - " << h.info.doc << "\n";
            if (h.info.composite())
                std::cout << "      (composite: combines "
                          << (h.info.max_terms == 1
                                  ? std::string("1 forcing, given as \"base\"")
                                  : std::to_string(h.info.min_terms) + " to " + std::to_string(h.info.max_terms) +
                                        " forcings, given as \"terms\"")
                          << ")\n";
            if (!h.info.domain_min.empty()) {
                std::cout << "      (domain";
                for (std::size_t i = 0; i < h.info.domain_min.size(); ++i)
                    std::cout << (i ? " x [" : " [") << h.info.domain_min[i] << ", " << h.info.domain_max[i] << "]";
                std::cout << ")\n";
            }
            for (const auto &p : h.info.params) {
                std::cout << "      " << p.name << " (" << to_string(p.type);
                if (p.type == ParamType::string)
                    std::cout << ", default \"" << p.default_string << "\"";
                else if (p.type == ParamType::boolean)
                    std::cout << ", default " << (p.default_value ? "true" : "false");
                else
                    std::cout << ", default " << p.default_value << ", range [" << p.min_value << ", " << p.max_value
                              << "]";
                if (!p.unit.empty()) std::cout << ", " << p.unit;
                std::cout << "): " << p.doc << "\n";
            }
        }
        if (!any) std::cout << "  (none)\n";
    }
    for (const auto &w : registry.warnings()) std::cerr << "geobarrier: warning: " << w << "\n";
    return 0;
}

struct CheckPluginOptions {
    std::vector<std::string> targets; // plugin files, or names of plugins the registry finds
    bool all = false;
    std::string params;
    std::vector<double> state_min, state_max;
    double t_min = -10.0, t_max = 10.0;
    std::vector<std::string> plugin_paths;
};

// check-plugin NAME needs a library named after NAME in the folders (geobarrier-NAME.so, libNAME.so, NAME.so: what
// run and validate look for first). Without one it refuses, naming what it looked for and where, instead of mapping
// every library of the folders to look inside them (run's and validate's fallback, PluginRegistry), which for a
// misspelt name ran the code of them all; a library that declares several plugins is checked by its path.
void require_library_named_after(const PluginRegistry &registry, const std::string &name) {
    const std::vector<std::string> files = {"geobarrier-" + name + ".so", "lib" + name + ".so", name + ".so"};
    std::vector<std::string> stems; // what the folders' libraries are named after, for "did you mean"
    std::string folders;
    for (const fs::path &folder : registry.folders()) {
        std::error_code ec;
        for (const std::string &file : files)
            if (fs::is_regular_file(folder / file, ec)) return;
        folders += " " + folder.string();
        for (const auto &entry : fs::directory_iterator(folder, ec)) {
            std::string stem = entry.path().filename().string();
            if (stem.size() <= 3 || stem.compare(stem.size() - 3, 3, ".so") != 0) continue;
            stem.resize(stem.size() - 3);
            for (const std::string prefix : {"geobarrier-", "lib"})
                if (stem.rfind(prefix, 0) == 0) {
                    stem = stem.substr(prefix.size());
                    break;
                }
            stems.push_back(stem);
        }
    }
    std::string message = "no library in the plugin folders is named after '" + name + "' (looked for " + files[0] +
                          ", " + files[1] + ", " + files[2] + " in" + folders + ")";
    const std::string hint = did_you_mean(name, stems);
    if (!hint.empty()) message += "; did you mean '" + hint + "'?";
    throw ConfigError(name, message + "; a library that declares several plugins is checked by its path: "
                                      "geobarrier check-plugin PATH");
}

// Every plugin of any kind called `name` (one library may declare a system and a forcing of one name), found as run
// and validate find them; a ConfigError listing what the folders hold when there is none.
std::vector<PluginHandle> plugins_named(const PluginRegistry &registry, const std::string &name) {
    require_library_named_after(registry, name);
    std::vector<PluginHandle> found;
    std::string missing;
    const std::size_t warned = registry.warnings().size();
    for (const PluginKind kind : {PluginKind::system, PluginKind::forcing, PluginKind::extractor}) {
        try {
            found.push_back(registry.find(kind, name, name));
        } catch (const ConfigError &e) {
            // Each lookup lists what the folders hold of its kind (or why the file named after NAME is refused): the
            // first that has a "did you mean" for a misspelt name, else the system lookup's.
            std::string text = e.what();
            if (text.rfind(name + ": ", 0) == 0) text = text.substr(name.size() + 2);
            const bool hint = text.find("did you mean") != std::string::npos;
            if (missing.empty() || (hint && missing.find("did you mean") == std::string::npos)) missing = text;
        }
    }
    for (std::size_t k = warned; k < registry.warnings().size(); ++k) spdlog::warn("{}", registry.warnings()[k]);
    if (found.empty()) throw ConfigError(name, missing + " (give a file path to check a plugin elsewhere)");
    return found;
}

// Runs the conformance checks of <geobarrier/conformance.hpp> (the same ones the plugins' own tests run) on every
// plugin of each target and prints one table per plugin, then a summary. Exit 0 when every check passed, 1 if not.
int command_check_plugin(const CheckPluginOptions &o) {
    ConformanceOptions options;
    if (!o.params.empty()) {
        try {
            options.params = nlohmann::json::parse(o.params);
        } catch (const nlohmann::json::parse_error &e) {
            throw ConfigError("--params", "not valid JSON: " + std::string(e.what()));
        }
        if (!options.params.is_object()) throw ConfigError("--params", o.params + " must be a JSON object");
    }
    // Parameter values are never objects: an object of objects gives each named plugin its own parameters,
    // e.g. {"data": {"file": "f.csv"}} with --all.
    const nlohmann::json given_params = options.params;
    const bool per_plugin = !given_params.empty() && std::all_of(given_params.begin(), given_params.end(),
                                                                 [](const nlohmann::json &v) { return v.is_object(); });
    options.state_min = o.state_min;
    options.state_max = o.state_max;
    options.t_min = o.t_min;
    options.t_max = o.t_max;

    struct Target {
        std::string label;
        std::vector<PluginHandle> handles;
        std::string load_error;
        std::optional<nlohmann::json> params; // the target's own parameters (the equations' constants)
    };
    std::vector<Target> targets;
    std::vector<fs::path> folders(o.plugin_paths.begin(), o.plugin_paths.end());
    // Only --all maps every library of the folders; a plugin named is looked up as run and validate do (its library
    // found by its file name), so that checking one plugin runs no other library's code.
    const PluginRegistry registry(PluginRegistry::default_folders(folders),
                                  o.all ? PluginLoading::all : PluginLoading::on_demand);
    if (o.all) {
        if (registry.plugins().empty()) throw ConfigError("--all", "no plugins found in the plugin folders");
        for (const auto &h : registry.plugins()) targets.push_back({h.info.file.string(), {h}, "", std::nullopt});
    }
    for (const std::string &name : o.targets) {
        Target t{name, {}, "", std::nullopt};
        const bool is_file = name.find('/') != std::string::npos || fs::path(name).extension() == ".so";
        if (is_file) {
            try {
                t.handles = load_plugin_library(name);
            } catch (const PluginError &e) {
                t.load_error = e.what();
            }
        } else if (name == equations::plugin_name) {
            // The plugin generated from --params {"state": [...], "rhs": [...], "constants": {...}}, checked as the
            // library declares itself (constants k0, k1, ... in the alphabetical order of their names), at their
            // values.
            const equations::Compiled compiled = equations::compile(given_params, "--params");
            t.label = compiled.handle.info.file.string();
            t.handles = load_plugin_library(compiled.handle.info.file);
            t.params = nlohmann::json::object();
            for (std::size_t i = 0; i < compiled.handle.info.params.size(); ++i)
                (*t.params)["k" + std::to_string(i)] = compiled.values.value(i);
        } else {
            t.handles = plugins_named(registry, name);
        }
        targets.push_back(std::move(t));
    }
    if (targets.empty()) throw ConfigError("check-plugin", "name a plugin file or plugin, or give --all");
    if (per_plugin)
        for (const auto &item : given_params.items()) {
            bool known = false;
            for (const Target &t : targets)
                for (const PluginHandle &h : t.handles) known = known || h.info.name == item.key();
            if (!known) throw ConfigError("--params/" + item.key(), "no plugin of that name among those checked");
        }

    struct Row {
        bool passed;
        std::string kind, name, counts;
    };
    std::vector<Row> summary;
    for (const Target &t : targets) {
        if (!t.load_error.empty()) {
            std::cout << t.label << "\n"
                      << format_checks({ConformanceCheck{"load", false, t.load_error, false}}) << "\n";
            summary.push_back({false, "?", t.label, "could not be loaded"});
            continue;
        }
        for (const PluginHandle &h : t.handles) {
            std::vector<ConformanceCheck> checks;
            if (per_plugin) options.params = given_params.value(h.info.name, nlohmann::json::object());
            if (t.params) options.params = *t.params;
            try {
                checks = check_plugin(h, options);
            } catch (const Error &e) { // unusable options, e.g. a box of the wrong dimension
                throw ConfigError("check-plugin " + h.info.name, e.what());
            }
            std::cout << h.info.name << " " << h.info.version << " (" << to_string(h.info.kind) << ", "
                      << h.info.file.string() << ")\n"
                      << format_checks(checks) << "\n";
            summary.push_back({all_passed(checks), to_string(h.info.kind), h.info.name, count_checks(checks)});
        }
    }
    bool ok = true;
    std::size_t kind_width = 0, name_width = 0;
    for (const Row &r : summary) {
        kind_width = std::max(kind_width, r.kind.size());
        name_width = std::max(name_width, r.name.size());
    }
    std::cout << "summary:\n";
    for (const Row &r : summary) {
        ok = ok && r.passed;
        std::cout << (r.passed ? "PASS  " : "FAIL  ") << r.kind << std::string(kind_width - r.kind.size() + 2, ' ')
                  << r.name << std::string(name_width - r.name.size() + 2, ' ') << r.counts << "\n";
    }
    return ok ? 0 : exit_failure;
}

// Failures leave without the exit handlers: HDF5's (Debian 12: HDF5 1.10, netCDF 4.9) crashes with SIGSEGV when a
// NetCDF file failed to close on a full disk. Every file of ours is closed or removed by then. `alike`: every MPI rank
// stops with this error (bad input: every rank read the same file); else the others are aborted.
[[noreturn]] void fail(int code, bool alike) {
    std::cout.flush();
    std::cerr.flush();
    std::fflush(nullptr);
    mpi::end_before_exit(code, alike);
    std::_Exit(code);
}

// A command line CLI11 refused: one line naming the word it could not use, with a did-you-mean, for exit code 2.
// A misspelt subcommand ("rnu") or option ("--quite") is looked up among those that exist; anything else keeps
// CLI11's own message. Negative numbers ("--t-min -5") are values, not options.
std::string command_line_error(const CLI::App &app, const CLI::ParseError &error, int argc, char **argv) {
    const auto names_of = [](const std::vector<const CLI::App *> &apps) {
        std::vector<std::string> names;
        for (const CLI::App *a : apps) names.push_back(a->get_name());
        return names;
    };
    const auto option_names = [](const CLI::App &a) {
        std::vector<std::string> names;
        for (const CLI::Option *o : a.get_options()) {
            for (const auto &l : o->get_lnames()) names.push_back("--" + l);
            for (const auto &n : o->get_snames()) names.push_back("-" + n);
        }
        return names;
    };
    const auto is_number = [](const std::string &word) {
        char *end = nullptr;
        std::strtod(word.c_str(), &end);
        return !word.empty() && end == word.c_str() + word.size();
    };
    const std::vector<std::string> commands = names_of(app.get_subcommands([](const CLI::App *) { return true; }));
    const CLI::App *command = nullptr;
    for (int i = 1; i < argc && !command; ++i) {
        const std::string word = argv[i];
        if (word.empty() || word[0] == '-') continue;
        if (std::find(commands.begin(), commands.end(), word) == commands.end()) {
            std::string message = "'" + word + "' is not a geobarrier command";
            const std::string hint = did_you_mean(word, commands);
            if (!hint.empty()) message += "; did you mean '" + hint + "'?";
            std::string list;
            for (const auto &c : commands) list += (list.empty() ? "" : ", ") + c;
            return message + " (commands: " + list + ")";
        }
        command = app.get_subcommand(word);
    }
    std::vector<std::string> known = option_names(app);
    if (command) {
        const std::vector<std::string> own = option_names(*command);
        known.insert(known.end(), own.begin(), own.end());
    }
    for (int i = 1; i < argc; ++i) {
        const std::string word = std::string(argv[i]).substr(0, std::string(argv[i]).find('='));
        if (word.size() < 2 || word[0] != '-' || is_number(word) || word == "--") continue;
        if (std::find(known.begin(), known.end(), word) != known.end()) continue;
        const std::string where = command ? "geobarrier " + command->get_name() : std::string("geobarrier");
        std::string message = "unknown option '" + word + "' for " + where;
        const std::string hint = did_you_mean(word, known);
        if (!hint.empty()) message += "; did you mean '" + hint + "'?";
        return message + " (see " + where + " --help)";
    }
    std::string message = error.what();
    std::replace(message.begin(), message.end(), '\n', ' ');
    return message + " (see " + (command ? "geobarrier " + command->get_name() : std::string("geobarrier")) +
           " --help)";
}

// Every error is one line on stderr, whatever a plugin's message holds.
std::string one_line(std::string text) {
    std::replace(text.begin(), text.end(), '\n', ' ');
    return text;
}

} // namespace

int main(int argc, char **argv) {
    // Idle OpenMP threads sleep rather than spin (openmp_wait.cpp says why); before MPI or any thread starts.
    geobarrier::prefer_passive_openmp_wait(argv);
    // MPI only when launched by mpirun (docs/cluster.md); started directly, the program is one process as ever.
    mpi::Session mpi_session(argc, argv);
    CLI::App app{"geobarrier: invariant manifolds, attractors and generalized KAM tori of forced mechanical systems\n"
                 "from the geometry of the finite-time flow map."};
    app.set_version_flag("--version", std::string("geobarrier ") + GEOBARRIER_VERSION);
    app.require_subcommand(1);
    bool quiet = false, verbose = false;

    std::string run_file;
    std::string run_out;
    int threads = 0;
    auto *run = app.add_subcommand("run", "Run an experiment file and write its data and pictures");
    run->add_option("file", run_file, "experiment JSON file")->required();
    run->add_option("--out", run_out, "output folder (overrides output.dir)");
    run->add_option("--threads", threads, "worker threads (default: all cores)")->check(CLI::Range(1, max_threads));
    run->add_flag("--quiet,-q", quiet, "no progress bar, warnings and errors only");
    run->add_flag("--verbose,-v", verbose, "debug logging");

    std::string validate_file;
    auto *validate = app.add_subcommand("validate", "Check an experiment file completely; compute nothing");
    validate->add_option("file", validate_file, "experiment JSON file")->required();

    std::string sweep_file, sweep_out;
    SweepOptions sweep_options;
    auto *sweep = app.add_subcommand("sweep", "Run an experiment over lists or ranges of parameter values");
    sweep->add_option("file", sweep_file, "sweep JSON file")->required();
    sweep->add_option("--out", sweep_out, "output folder (overrides output.dir)");
    sweep->add_option("--processes", sweep_options.processes, "members run at once (default: the sweep's, else cores)")
        ->check(CLI::Range(1, 4096));
    sweep->add_option("--threads", sweep_options.threads, "threads per member (default: cores / processes)")
        ->check(CLI::Range(1, max_threads));
    sweep->add_flag("--quiet,-q", quiet, "warnings and errors only");

    bool as_json = false;
    std::vector<std::string> plugin_paths;
    auto *plugins = app.add_subcommand("plugins", "List the plugins found, with their parameter schemas");
    plugins->add_flag("--json", as_json, "machine-readable output");
    plugins->add_option("--plugin-path", plugin_paths, "extra folders to search first");

    CheckPluginOptions check_options;
    auto *check = app.add_subcommand("check-plugin", "Run the conformance checks on plugins; print a pass/fail table");
    check->add_option("plugins", check_options.targets,
                      "plugin files (.so), or names of plugins found in the folders, or equations (the plugin "
                      "generated from --params '{\"state\": [...], \"rhs\": [...], \"constants\": {...}}')");
    check->add_flag("--all", check_options.all, "check every plugin found in the plugin folders");
    check->add_option("--params", check_options.params,
                      "parameters as a JSON object, or {\"plugin\": {...}, ...} per plugin (default: the defaults)");
    check->add_option("--state-min", check_options.state_min,
                      "lower corner of the sampled states, one value or one per component "
                      "(default: the system's documented domain, else -2)");
    check->add_option("--state-max", check_options.state_max, "upper corner (default: the domain, else 2)");
    check->add_option("--t-min", check_options.t_min, "earliest sampled time (default -10)");
    check->add_option("--t-max", check_options.t_max, "latest sampled time (default 10)");
    check->add_option("--plugin-path", check_options.plugin_paths, "extra folders to search first");

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError &e) {
        if (e.get_exit_code() == 0) return app.exit(e); // --help, --version
        std::cerr << "geobarrier: error: " << command_line_error(app, e, argc, argv) << "\n";
        return exit_bad_input;
    }
    // Under mpirun, `run` shares its flow map's tiles among the ranks (a sweep shares whole members); rank 0 reports.
    mpi::share_tiles(static_cast<bool>(*run));
    if (mpi::rank() != 0) quiet = true;
    setup_logging(quiet, verbose);
    install_signal_handlers(); // SIGINT/SIGTERM stop a run cleanly, exit code 128 + signal (cancel.hpp)
    const auto interrupted = [&](int signal, const std::string &what) -> int {
        std::cerr << "geobarrier: " << one_line(what) << "; stopped: no file of this run was put in the output "
                  << "folder, which is as it was before the run\n";
        fail(128 + signal, false);
    };
    try {
        if (*run)
            return command_run(run_file, run_out.empty() ? std::nullopt : std::optional<fs::path>(run_out), threads,
                               quiet);
        if (*validate) return command_validate(validate_file);
        if (*sweep) {
            if (!sweep_out.empty()) sweep_options.output_dir = sweep_out;
            sweep_options.quiet = quiet;
            return command_sweep(sweep_file, sweep_options);
        }
        if (*plugins) return command_plugins(as_json, plugin_paths);
        if (*check) return command_check_plugin(check_options);
    } catch (const Cancelled &e) {
        return interrupted(e.signal(), e.what());
    } catch (const OutputBusyError &e) { // the output folder is another writer's: only rank 0 knows
        std::cerr << "geobarrier: error: " << one_line(e.what()) << "\n";
        fail(exit_bad_input, false);
    } catch (const ConfigError &e) {
        if (mpi::rank() == 0) std::cerr << "geobarrier: error: " << one_line(e.what()) << "\n";
        fail(exit_bad_input, true);
    } catch (const LibraryFileError &e) { // a truncated or foreign library in a plugin folder: bad input too
        if (mpi::rank() == 0) std::cerr << "geobarrier: error: " << one_line(e.what()) << "\n";
        fail(exit_bad_input, true);
    } catch (const std::bad_alloc &) {
        std::cerr << "geobarrier: error: out of memory (try a smaller grid)\n";
        fail(exit_failure, false);
    } catch (const std::exception &e) {
        // A cancellation that reached us wrapped (e.g. inside an extractor's failed host call) is still one.
        if (const int signal = cancel_requested()) return interrupted(signal, "interrupted by " + signal_name(signal));
        std::cerr << "geobarrier: error: " << one_line(e.what()) << "\n";
        fail(exit_failure, false);
    } catch (...) {
        std::cerr << "geobarrier: error: an exception of unknown type (not std::exception) was thrown, probably by a "
                     "plugin\n";
        fail(exit_failure, false);
    }
    return 0;
}
