// The geobarrier command-line program: run and validate experiments, list plugins.
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/plugin.hpp>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

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
    std::cout << ")\n";
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

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError &e) {
        return app.exit(e);
    }
    setup_logging(quiet, verbose);
    try {
        if (*run) return command_run(run_file, run_out.empty() ? std::nullopt : std::optional<fs::path>(run_out), threads, quiet);
        if (*validate) return command_validate(validate_file);
        if (*plugins) return command_plugins(as_json, plugin_paths);
    } catch (const ConfigError &e) {
        std::cerr << "geobarrier: error: " << e.what() << "\n";
        return exit_bad_input;
    } catch (const std::bad_alloc &) {
        std::cerr << "geobarrier: error: out of memory (try a smaller grid)\n";
        return exit_failure;
    } catch (const std::exception &e) {
        std::cerr << "geobarrier: error: " << e.what() << "\n";
        return exit_failure;
    }
    return 0;
}
