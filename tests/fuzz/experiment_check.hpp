// What the experiment fuzzer checks on each input, shared by the libFuzzer target (fuzz_experiment.cpp) and by the
// regression test that replays the corpus and every input the fuzzer ever crashed on (test_fuzz_regressions.cpp):
// parse and validate the text as an experiment file, then validate each plugin's parameters against its schema.
// Rejections are geobarrier::Error (ConfigError, PluginError, ...); anything else that escapes, or a crash, is a bug.
#ifndef GEOBARRIER_TESTS_FUZZ_EXPERIMENT_CHECK_HPP
#define GEOBARRIER_TESTS_FUZZ_EXPERIMENT_CHECK_HPP

#include "equations/equations.hpp"
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/plugin.hpp>

#include <string>

namespace geobarrier::fuzz {

// Plugins are looked up by name only: an input never makes the checker load a file it names (a path as a plugin
// name, or plugin_paths), since loading a library runs its code.
inline bool names_a_file(const std::string &plugin) {
    return plugin.find('/') != std::string::npos ||
           (plugin.size() >= 3 && plugin.compare(plugin.size() - 3, 3, ".so") == 0);
}

inline void check_plugin_use(const PluginRegistry &registry, PluginKind kind, const PluginUse &use) {
    if (kind == PluginKind::system && use.plugin == equations::plugin_name) {
        // The equations' grammar and code generator, without compiling (which would run the compiler per input).
        try {
            equations::define(use.params, use.json_path + "/params");
        } catch (const Error &) {
        }
    } else if (!names_a_file(use.plugin)) {
        try {
            const PluginHandle &h = registry.find(kind, use.plugin, use.json_path + "/plugin");
            validate_params(h.info, use.params, use.json_path + "/params");
        } catch (const Error &) {
        }
    }
    for (const PluginUse &term : use.terms) check_plugin_use(registry, PluginKind::forcing, term);
}

// Returns true when the text is a valid experiment (structure and plugin parameters).
inline bool check_experiment_text(const std::string &text, const PluginRegistry &registry) {
    Experiment e;
    try {
        e = parse_experiment_text(text);
    } catch (const Error &) {
        return false;
    }
    check_plugin_use(registry, PluginKind::system, e.system);
    check_plugin_use(registry, PluginKind::forcing, e.forcing);
    for (const PluginUse &x : e.extractors) check_plugin_use(registry, PluginKind::extractor, x);
    return true;
}

} // namespace geobarrier::fuzz

#endif // GEOBARRIER_TESTS_FUZZ_EXPERIMENT_CHECK_HPP
