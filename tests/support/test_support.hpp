// Helpers shared by the test programs: where the built plugins are, and
// one-line creation of plugin objects from JSON parameters.
#ifndef GEOBARRIER_TEST_SUPPORT_HPP
#define GEOBARRIER_TEST_SUPPORT_HPP

#include <geobarrier/plugin.hpp>

#include <filesystem>
#include <string>

namespace geobarrier::test {

// Built-in plugins (build/lib/geobarrier/plugins), test-only plugins, the
// source tree and the program, as the build placed them (see CMakeLists.txt).
inline std::filesystem::path plugin_dir() { return GEOBARRIER_PLUGIN_DIR; }
inline std::filesystem::path test_plugin_dir() { return GEOBARRIER_TEST_PLUGIN_DIR; }
inline std::filesystem::path source_dir() { return GEOBARRIER_SOURCE_DIR; }
inline std::filesystem::path geobarrier_program() { return GEOBARRIER_BIN; }

// One registry over both folders, built once per test program.
inline const PluginRegistry &registry() {
    static const PluginRegistry r({plugin_dir(), test_plugin_dir()});
    return r;
}

inline System make_system(const std::string &name, const nlohmann::json &params = nlohmann::json::object()) {
    const PluginHandle &h = registry().find(PluginKind::system, name, "/system/plugin");
    return System(h, validate_params(h.info, params, "/system/params"));
}
inline Forcing make_forcing(const std::string &name, const nlohmann::json &params = nlohmann::json::object()) {
    const PluginHandle &h = registry().find(PluginKind::forcing, name, "/forcing/plugin");
    return Forcing(h, validate_params(h.info, params, "/forcing/params"));
}

}  // namespace geobarrier::test

#endif  // GEOBARRIER_TEST_SUPPORT_HPP
