// The geobarrier command-line program: run and validate experiments, list plugins.
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

namespace fs = std::filesystem;
using namespace geobarrier;

namespace {

// Exit codes: 0 success, 1 the computation failed, 2 bad input (experiment or command line).
constexpr int exit_failure = 1;
constexpr int exit_bad_input = 2;

void setup_logging(bool quiet, bool verbose) {
    auto logger = spdlog::stderr_color_mt("geobarrier");
    logger->set_pattern("%^[%l]%$ %v");
    spdlog::set_default_logger(logger);
    spdlog::set_level(quiet ? spdlog::level::warn : verbose ? spdlog::level::debug : spdlog::level::info);
}

int command_run(const fs::path &file, const std::optional<fs::path> &out, int threads, bool quiet) {
    const Experiment experiment = load_experiment(file);
    const ResolvedExperiment resolved = resolve_experiment(experiment);
    for (const auto &w : resolved.registry.warnings()) spdlog::debug("{}", w);
    spdlog::info("{}: {} + {} on a {} x {} grid, t = {} to {}", file.string(), resolved.system.info().name,
                 resolved.forcing.info().name, experiment.grid.nx, experiment.grid.ny, experiment.t0, experiment.t1);
    RunOptions options;
    options.output_dir = out;
    options.threads = threads;
    options.quiet = quiet;
    const RunSummary summary = run_experiment(resolved, options);
    if (!quiet) {
        std::cout << "wrote " << summary.files.size() << " files to " << summary.output_dir.string() << ":\n";
        for (const auto &f : summary.files) std::cout << "  " << f.string() << "\n";
    }
    return 0;
}

int command_validate(const fs::path &file) {
    const Experiment experiment = load_experiment(file);
    const ResolvedExperiment resolved = resolve_experiment(experiment);
    std::cout << file.string() << ": valid (" << resolved.system.info().name << " + " << resolved.forcing.info().name
              << ", " << experiment.grid.nx << " x " << experiment.grid.ny << " grid, products:";
    for (const auto &p : experiment.products) std::cout << " " << p;
    for (const auto &x : resolved.extractors) std::cout << " extractor:" << x.info().name;
    const nlohmann::json validation = validation_to_json(experiment.validation, experiment.t0, experiment.t1);
    for (const auto &item : validation.items()) std::cout << " validation:" << item.key();
    std::cout << ")\n";
    for (const auto &w : experiment.warnings) std::cout << "warning: " << w << "\n"; // e.g. a clamped rtol
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
        j["warnings"] = registry.warnings();
        std::cout << j.dump(2) << "\n";
        return 0;
    }
    for (const PluginKind kind : {PluginKind::system, PluginKind::forcing, PluginKind::extractor}) {
        std::cout << to_string(kind) << "s:\n";
        bool any = false;
        for (const auto &h : registry.plugins()) {
            if (h.info.kind != kind) continue;
            any = true;
            std::cout << "  " << h.info.name << " " << h.info.version << " - " << h.info.doc << "\n";
            if (h.info.composite())
                std::cout << "      (composite: combines "
                          << (h.info.max_terms == 1 ? std::string("1 forcing, given as \"base\"")
                                                    : std::to_string(h.info.min_terms) + " to " +
                                                          std::to_string(h.info.max_terms) +
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
                if (p.type == ParamType::string) std::cout << ", default \"" << p.default_string << "\"";
                else if (p.type == ParamType::boolean) std::cout << ", default " << (p.default_value ? "true" : "false");
                else std::cout << ", default " << p.default_value << ", range [" << p.min_value << ", " << p.max_value << "]";
                if (!p.unit.empty()) std::cout << ", " << p.unit;
                std::cout << "): " << p.doc << "\n";
            }
        }
        if (!any) std::cout << "  (none)\n";
    }
    for (const auto &w : registry.warnings()) std::cout << "note: " << w << "\n";
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
    };
    std::vector<Target> targets;
    std::vector<fs::path> folders(o.plugin_paths.begin(), o.plugin_paths.end());
    const PluginRegistry registry(PluginRegistry::default_folders(folders));
    if (o.all) {
        if (registry.plugins().empty()) throw ConfigError("--all", "no plugins found in the plugin folders");
        for (const auto &h : registry.plugins()) targets.push_back({h.info.file.string(), {h}, ""});
    }
    for (const std::string &name : o.targets) {
        Target t{name, {}, ""};
        const bool is_file = name.find('/') != std::string::npos || fs::path(name).extension() == ".so";
        if (is_file) {
            try {
                t.handles = load_plugin_library(name);
            } catch (const PluginError &e) {
                t.load_error = e.what();
            }
        } else {
            for (const auto &h : registry.plugins())
                if (h.info.name == name) t.handles.push_back(h);
            if (t.handles.empty()) {
                std::vector<std::string> names;
                for (const auto &h : registry.plugins()) names.push_back(h.info.name);
                std::string msg = "no plugin named '" + name + "' in the plugin folders";
                const std::string hint = did_you_mean(name, names);
                if (!hint.empty()) msg += "; did you mean '" + hint + "'?";
                throw ConfigError(name, msg + " (give a file path to check a plugin elsewhere)");
            }
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

}  // namespace

int main(int argc, char **argv) {
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
    run->add_option("--threads", threads, "worker threads (default: all cores)")->check(CLI::Range(1, 1024));
    run->add_flag("--quiet,-q", quiet, "no progress bar, warnings and errors only");
    run->add_flag("--verbose,-v", verbose, "debug logging");

    std::string validate_file;
    auto *validate = app.add_subcommand("validate", "Check an experiment file completely; compute nothing");
    validate->add_option("file", validate_file, "experiment JSON file")->required();

    bool as_json = false;
    std::vector<std::string> plugin_paths;
    auto *plugins = app.add_subcommand("plugins", "List the plugins found, with their parameter schemas");
    plugins->add_flag("--json", as_json, "machine-readable output");
    plugins->add_option("--plugin-path", plugin_paths, "extra folders to search first");

    CheckPluginOptions check_options;
    auto *check = app.add_subcommand("check-plugin", "Run the conformance checks on plugins; print a pass/fail table");
    check->add_option("plugins", check_options.targets, "plugin files (.so), or names of plugins found in the folders");
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
        return app.exit(e);
    }
    setup_logging(quiet, verbose);
    install_signal_handlers(); // SIGINT/SIGTERM stop a run cleanly, exit code 128 + signal (cancel.hpp)
    // Every error is one line on stderr, whatever a plugin's message holds.
    const auto one_line = [](std::string text) {
        std::replace(text.begin(), text.end(), '\n', ' ');
        return text;
    };
    // Failures leave without the exit handlers: HDF5's (Debian 12: HDF5 1.10, netCDF 4.9) crashes with SIGSEGV when a
    // NetCDF file failed to close on a full disk. Every file of ours is closed or removed by then.
    const auto fail = [](int code) {
        std::cout.flush();
        std::cerr.flush();
        std::fflush(nullptr);
        std::_Exit(code);
        return code;
    };
    const auto interrupted = [&](int signal, const std::string &what) {
        std::cerr << "geobarrier: " << one_line(what) << "; stopped: no file of this run was put in the output "
                  << "folder, which is as it was before the run\n";
        return fail(128 + signal);
    };
    try {
        if (*run) return command_run(run_file, run_out.empty() ? std::nullopt : std::optional<fs::path>(run_out), threads, quiet);
        if (*validate) return command_validate(validate_file);
        if (*plugins) return command_plugins(as_json, plugin_paths);
        if (*check) return command_check_plugin(check_options);
    } catch (const Cancelled &e) {
        return interrupted(e.signal(), e.what());
    } catch (const ConfigError &e) {
        std::cerr << "geobarrier: error: " << one_line(e.what()) << "\n";
        return fail(exit_bad_input);
    } catch (const std::bad_alloc &) {
        std::cerr << "geobarrier: error: out of memory (try a smaller grid)\n";
        return fail(exit_failure);
    } catch (const std::exception &e) {
        // A cancellation that reached us wrapped (e.g. inside an extractor's failed host call) is still one.
        if (const int signal = cancel_requested()) return interrupted(signal, "interrupted by " + signal_name(signal));
        std::cerr << "geobarrier: error: " << one_line(e.what()) << "\n";
        return fail(exit_failure);
    } catch (...) {
        std::cerr << "geobarrier: error: an exception of unknown type (not std::exception) was thrown, probably by a "
                     "plugin\n";
        return fail(exit_failure);
    }
    return 0;
}
