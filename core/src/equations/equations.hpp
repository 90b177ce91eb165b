// The `equations` system: a vector field written in the experiment file, e.g.
//   "system": {"plugin": "equations",
//              "params": {"state": ["x", "v"], "rhs": ["v", "x - x^3 - d*v + f"], "constants": {"d": 0.15}}}
// compiled once into an ordinary SDK plugin (per-lane `field`, exact `field_jacobian`, so the fused Runge-Kutta step
// of <geobarrier/sdk.hpp>) and cached per user; docs/experiment-format.md ("Equations") has the grammar.
//
// Why in the core and not a plugin: the parameters are structured (names, expressions, an object of constants), which
// the C ABI's parameter values cannot carry; errors are ConfigErrors naming the JSON path and column (exit 2), which a
// plugin's create() cannot raise; and the toolchain to compile with (this build's compiler, flags and headers) is a
// fact of the core's build. What is loaded is a plain plugin library through the ordinary loader, so everything
// downstream (System, check-plugin, the fused step) treats it like any other.
#ifndef GEOBARRIER_EQUATIONS_EQUATIONS_HPP
#define GEOBARRIER_EQUATIONS_EQUATIONS_HPP

#include <geobarrier/plugin.hpp>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace geobarrier::equations {

// The name an experiment gives as "plugin" (it is not looked up in the plugin folders).
inline constexpr const char *plugin_name = "equations";

// What `geobarrier plugins` prints: a one-line doc and the parameters (name, type, doc).
std::string doc();
nlohmann::json schema();

// Checked equations and the plugin source generated from their parsed trees.
struct Definition {
    std::vector<std::string> state;                        // names of the state components
    std::vector<std::string> rhs;                          // the expressions as written (for the manifest)
    std::vector<std::pair<std::string, double>> constants; // in the order the source numbers them
    bool uses_forcing = false;
    std::string source; // the C++ plugin: no text of the experiment file appears in it
};

// Checks `params` (the system's "params" object) and generates the source. Throws ConfigError at
// "<json_path>/rhs/1, column 9" and the like; compiles and writes nothing.
Definition define(const nlohmann::json &params, const std::string &json_path);

// How generated plugins are compiled: the compiler and code-generation flags this geobarrier was built with
// (recorded at configure time; GEOBARRIER_EQUATIONS_CXX names another compiler) against its own headers (the
// installed ones beside the library, else the source tree's).
struct Toolchain {
    std::string compiler;           // path, or a name looked up in PATH
    std::string identity;           // e.g. "GNU 12.2.0" (of the recorded compiler), for the cache key and the manifest
    std::string package;            // the Debian package that provides it, for the message when it is missing
    std::vector<std::string> flags; // every argument but the files
    std::filesystem::path include_dir;
};
Toolchain toolchain();

// $GEOBARRIER_EQUATIONS_CACHE, else $XDG_CACHE_HOME/geobarrier/equations, else ~/.cache/geobarrier/equations.
std::filesystem::path cache_folder();

// The cache key: a hash of the generated source, the toolchain, the SDK headers' text and the geobarrier version.
std::string cache_key(const Definition &definition, const Toolchain &toolchain);

struct Compiled {
    // The generated plugin, loaded. Its info carries the experiment's names: the state names, and the constants as
    // the real parameters (their values the defaults), so validate_params and check-plugin work as for any plugin.
    PluginHandle handle;
    ParamValues values;    // the constants' values
    nlohmann::json record; // for the manifest: hash, compiler, flags, library, whether it was cached, compile time
};

// define(), then loads <cache>/<key>.so, compiling it first when absent: into temporary files in the cache folder,
// published by rename so that concurrent runs never see a partial library. Throws Error when no compiler is there
// (naming the package to install) or when it fails (naming the log; its diagnostics are never the only message).
Compiled compile(const nlohmann::json &params, const std::string &json_path);

} // namespace geobarrier::equations

#endif // GEOBARRIER_EQUATIONS_EQUATIONS_HPP
