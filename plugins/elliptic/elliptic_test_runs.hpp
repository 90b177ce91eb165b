// Helpers of the elliptic extractor's tests (test_elliptic.cpp, test_lambda_fallback.cpp): whole runs through the
// plugin and the geometry of the closed curves they report.
#ifndef GEOBARRIER_ELLIPTIC_TEST_RUNS_HPP
#define GEOBARRIER_ELLIPTIC_TEST_RUNS_HPP

#include <geobarrier/experiment.hpp>

#include <test_support.hpp>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace geobarrier::elliptic::test_runs {

struct RadiusStats {
    double mean = 0.0, spread = 0.0; // spread: max |r - mean|
};
inline RadiusStats radius_stats(const std::vector<double> &xy, double cx = 0.0, double cy = 0.0) {
    RadiusStats s;
    const std::size_t n = xy.size() / 2;
    for (std::size_t k = 0; k < n; ++k) s.mean += std::hypot(xy[2 * k] - cx, xy[2 * k + 1] - cy);
    s.mean /= static_cast<double>(n);
    for (std::size_t k = 0; k < n; ++k)
        s.spread = std::max(s.spread, std::abs(std::hypot(xy[2 * k] - cx, xy[2 * k + 1] - cy) - s.mean));
    return s;
}

inline std::filesystem::path fresh_dir(const std::string &name) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                      ("geobarrier-test-elliptic-" + name + "-" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    return dir;
}

// Runs an experiment with the built and test-only plugins; returns barriers.json, and elliptic-sections.json in
// `sections` when given.
inline nlohmann::json run(nlohmann::json experiment, const std::string &name, nlohmann::json *sections = nullptr) {
    experiment["plugin_paths"] = {test::plugin_dir().string(), test::test_plugin_dir().string()};
    const ResolvedExperiment r = resolve_experiment(parse_experiment(experiment));
    const std::filesystem::path dir = fresh_dir(name);
    RunOptions options;
    options.output_dir = dir;
    options.quiet = true;
    run_experiment(r, options);
    nlohmann::json b = nlohmann::json::parse(std::ifstream(dir / "barriers.json"));
    CHECK(std::filesystem::exists(dir / "elliptic-sections.json"));
    if (sections) *sections = nlohmann::json::parse(std::ifstream(dir / "elliptic-sections.json"));
    std::filesystem::remove_all(dir);
    return b;
}

inline std::vector<double> points_of(const nlohmann::json &barrier) {
    std::vector<double> xy;
    for (const auto &p : barrier["points"]) {
        xy.push_back(p[0].get<double>());
        xy.push_back(p[1].get<double>());
    }
    return xy;
}

} // namespace geobarrier::elliptic::test_runs

#endif // GEOBARRIER_ELLIPTIC_TEST_RUNS_HPP
