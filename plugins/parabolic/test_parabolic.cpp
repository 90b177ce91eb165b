// The parabolic extractor on steady parallel shear flows x' = p(y), y' = 0, whose horizontal lines are exact
// shearlines (DF = [[1, s], [0, 1]] maps e_x to itself): the barriers must be the horizontal lines where the
// geodesic shear deviation is least, i.e. where the shear |p'| peaks (d_g ~ |1 - alpha| ~ 1 / (2 s^2) there).
// Shear layer p = tanh: the layer's centre y = 0. Bickley jet p = sech^2: the lines of strongest shear
// y = ±atanh(1/sqrt 3) = ±0.6585 — not the jet core y = 0, which is shearless (C = I, eta± undefined there).
#include <geobarrier/experiment.hpp>

#include <doctest/doctest.h>
#include <test_support.hpp>

#include <cmath>
#include <fstream>

#include <unistd.h>

using namespace geobarrier;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

struct Line {
    double mean_y = 0.0, spread_y = 0.0, x_min = 0.0, x_max = 0.0, mean_deviation = 0.0;
    std::string family;
};

// Runs the extractor on a 81 x 81 grid over [0, 4] x [-2, 2] (dy = 0.05), T = 10, and summarises its barriers.
std::vector<Line> parabolic_barriers(const std::string &profile, const fs::path &dir) {
    json j = {{"system", {{"plugin", "parallel-shear"}, {"params", {{"profile", profile}}}}},
              {"grid", {{"x", {0.0, 4.0}}, {"y", {-2.0, 2.0}}, {"n", {81, 81}}}},
              {"time", {{"t0", 0.0}, {"t1", 10.0}}},
              {"integrator", {{"rtol", 1e-10}, {"atol", 1e-12}}},
              {"extractors", {{{"plugin", "parabolic"}}}},
              {"plugin_paths", {test::plugin_dir().string()}},
              {"output", {{"dir", dir.string()}, {"plots", true}}}};
    RunOptions options;
    options.quiet = true;
    run_experiment(resolve_experiment(parse_experiment(j)), options);
    const json b = json::parse(std::ifstream(dir / "barriers.json"));
    std::vector<Line> lines;
    for (const json &barrier : b["barriers"]) {
        CHECK(barrier["kind"] == "parabolic");
        CHECK(barrier["closed"] == false);
        Line l;
        double lo = HUGE_VAL, hi = -HUGE_VAL;
        l.x_min = HUGE_VAL;
        l.x_max = -HUGE_VAL;
        for (const json &p : barrier["points"]) {
            const double x = p[0], y = p[1];
            l.mean_y += y / static_cast<double>(barrier["points"].size());
            lo = std::min(lo, y);
            hi = std::max(hi, y);
            l.x_min = std::min(l.x_min, x);
            l.x_max = std::max(l.x_max, x);
        }
        l.spread_y = hi - lo;
        l.mean_deviation = barrier["mean_geodesic_deviation"];
        l.family = barrier["family"];
        lines.push_back(l);
    }
    return lines;
}

fs::path fresh_dir(const std::string &name) {
    const fs::path dir =
        fs::temp_directory_path() / ("geobarrier-test-parabolic-" + name + "-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    return dir;
}

}  // namespace

TEST_CASE("shear layer: the parabolic barrier is the layer's centre y = 0") {
    const fs::path dir = fresh_dir("layer");
    const std::vector<Line> lines = parabolic_barriers("layer", dir);
    REQUIRE(!lines.empty());
    const Line &best = lines[0];
    MESSAGE("barriers: " << lines.size() << "; the least deviating at mean y = " << best.mean_y << " (spread "
                         << best.spread_y << "), x from " << best.x_min << " to " << best.x_max
                         << ", mean d_g = " << best.mean_deviation);
    const double dy = 0.05;
    CHECK(std::abs(best.mean_y) < dy);  // at y = 0 within a grid spacing
    CHECK(best.spread_y < 0.1 * dy);    // and horizontal
    CHECK(best.x_max - best.x_min > 4.0 - 2 * dy); // across the whole box
    // Its deviation is the analytic |1 - alpha| at s = T p'(0) = 10: alpha = mu / sqrt(1 + mu^2) with the singular
    // value mu = s/2 + sqrt(1 + s^2/4), so 1 - alpha = 0.00485; every curvature term vanishes there by symmetry.
    CHECK(best.mean_deviation == doctest::Approx(0.00485).epsilon(0.02));
    CHECK(fs::exists(dir / "parabolic.png"));
    fs::remove_all(dir);
}

TEST_CASE("Bickley jet: the parabolic barriers are the lines of strongest shear, not the shearless core") {
    const fs::path dir = fresh_dir("jet");
    const std::vector<Line> lines = parabolic_barriers("jet", dir);
    const double y_star = std::atanh(1.0 / std::sqrt(3.0)), dy = 0.05;
    bool above = false, below = false;
    for (const Line &l : lines) {
        MESSAGE("barrier at mean y = " << l.mean_y << " (spread " << l.spread_y << ", family " << l.family
                                       << ", mean d_g " << l.mean_deviation << ")");
        // Nothing near the core: there the shear vanishes, C = I and the shear directions are undefined.
        CHECK(std::abs(l.mean_y) > 0.3);
    }
    REQUIRE(lines.size() >= 2);
    for (std::size_t k = 0; k < 2; ++k) {
        const Line &l = lines[k];
        CHECK(l.spread_y < 0.1 * dy);
        CHECK(std::abs(std::abs(l.mean_y) - y_star) < dy);
        (l.mean_y > 0 ? above : below) = true;
    }
    CHECK(above);
    CHECK(below);
    fs::remove_all(dir);
}
