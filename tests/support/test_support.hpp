// Helpers shared by the test programs: where the built plugins are, and
// one-line creation of plugin objects from JSON parameters.
#ifndef GEOBARRIER_TEST_SUPPORT_HPP
#define GEOBARRIER_TEST_SUPPORT_HPP

#include <geobarrier/plugin.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace geobarrier::test {

// Built-in plugins (build/lib/geobarrier/plugins), test-only plugins, the
// source tree and the program, as the build placed them (see CMakeLists.txt).
inline std::filesystem::path plugin_dir() { return GEOBARRIER_PLUGIN_DIR; }
inline std::filesystem::path test_plugin_dir() { return GEOBARRIER_TEST_PLUGIN_DIR; }
inline std::filesystem::path source_dir() { return GEOBARRIER_SOURCE_DIR; }
inline std::filesystem::path geobarrier_program() { return GEOBARRIER_BIN; }

// The whole text of a file ("" when it cannot be read): program output, logs, summaries.
inline std::string read_text(const std::filesystem::path &file) {
    std::ifstream in(file);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

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

// n points spread over [-1, 1]^2 on a skewed lattice (no symmetric pairs hide sign errors).
inline void sample_points(std::size_t n, std::vector<double> &x, std::vector<double> &y) {
    x.resize(n);
    y.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
        x[k] = -1.0 + 2.0 * std::fmod(0.618033988749895 * static_cast<double>(k) + 0.1, 1.0);
        y[k] = -1.0 + 2.0 * static_cast<double>(k) / static_cast<double>(n - 1);
    }
}

// The unforced, undamped Duffing oscillator's energy H = y^2/2 - x^2/2 + x^4/4: conserved along its trajectories.
inline double duffing_energy(double x, double y) { return 0.5 * y * y - 0.5 * x * x + 0.25 * x * x * x * x; }

} // namespace geobarrier::test

#endif // GEOBARRIER_TEST_SUPPORT_HPP
