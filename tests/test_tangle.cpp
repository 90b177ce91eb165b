// Both directions in one run (tangle.hpp): the crossing finder on constructed curves, and the escape oscillator's
// homoclinic tangle appearing across Melnikov's threshold.
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/tangle.hpp>

#include <test_support.hpp>

#include <doctest/doctest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;
using nlohmann::json;
using namespace geobarrier;

namespace {

json curve(std::initializer_list<std::pair<double, double>> points, bool closed = false) {
    json p = json::array();
    for (const auto &[x, y] : points) p.push_back({x, y});
    return {{"points", p}, {"closed", closed}};
}

// The curve y = a sin(k x) + b over [x0, x1] in n points.
json wave(double a, double k, double b, double x0, double x1, int n) {
    json p = json::array();
    for (int i = 0; i < n; ++i) {
        const double x = x0 + (x1 - x0) * i / (n - 1);
        p.push_back({x, a * std::sin(k * x) + b});
    }
    return {{"points", p}, {"closed", false}};
}

} // namespace

TEST_CASE("transverse crossings of constructed curves: where, how many, at what angle") {
    // A horizontal and a vertical segment cross once at (0.3, 0.2), at 90 degrees.
    auto c =
        transverse_crossings(json::array({curve({{-1, 0.2}, {1, 0.2}})}), json::array({curve({{0.3, -1}, {0.3, 1}})}));
    REQUIRE(c.size() == 1);
    CHECK(c[0].x == doctest::Approx(0.3));
    CHECK(c[0].y == doctest::Approx(0.2));
    CHECK(c[0].angle_degrees == doctest::Approx(90.0));
    // Through a shared vertex: counted once.
    c = transverse_crossings(json::array({curve({{-1, 0}, {0, 0}, {1, 0}})}),
                             json::array({curve({{0, -1}, {0, 0}, {0, 1}})}));
    CHECK(c.size() == 1);
    // A closed square and a line through it: 2 crossings, the closing side included; indices name the barriers.
    c = transverse_crossings(json::array({curve({{5, 5}, {6, 5}}), curve({{0, -2}, {0, 2}})}),
                             json::array({curve({{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}, true)}));
    REQUIRE(c.size() == 2);
    CHECK(c[0].forward == 1);
    CHECK(c[0].backward == 0);
    CHECK(c[0].y == doctest::Approx(-1.0));
    CHECK(c[1].y == doctest::Approx(1.0));
    // sin x and sin 2x on [0.5, 6]: they cross where sin x = sin 2x, i.e. cos x = 1/2 (x = pi/3, 5 pi/3) and
    // sin x = 0 (x = pi), at angles atan|2 cos 2x| - atan|cos x| > 10 degrees; sampled finely enough, exactly those.
    c = transverse_crossings(json::array({wave(1, 1, 0, 0.5, 6, 4001)}), json::array({wave(1, 2, 0, 0.5, 6, 4001)}));
    REQUIRE(c.size() == 3);
    const double pi = std::acos(-1.0);
    CHECK(c[0].x == doctest::Approx(pi / 3).epsilon(1e-5));
    CHECK(c[1].x == doctest::Approx(pi).epsilon(1e-5));
    CHECK(c[2].x == doctest::Approx(5 * pi / 3).epsilon(1e-5));
    // The same curve sampled twice with different points (a separatrix that is both a stable and an unstable
    // manifold): its polylines cross at tiny angles only, which is no tangle.
    c = transverse_crossings(json::array({wave(1, 1, 0, 0.0, 6, 300)}), json::array({wave(1, 1, 0, 0.01, 6.01, 457)}));
    CHECK(c.empty());
    // Crossings within the merge distance are one.
    const json zigzag = json::array({curve({{0, -1}, {0.01, 1}, {0.02, -1}, {0.03, 1}})});
    CHECK(transverse_crossings(zigzag, json::array({curve({{-2, 0.0}, {2, 0.0}})})).size() == 3);
    CHECK(transverse_crossings(zigzag, json::array({curve({{-2, 0.0}, {2, 0.0}})}), 10.0, 0.05).size() == 1);
}

TEST_CASE("both directions of the escape oscillator: one crossing (the saddle orbit) below Melnikov's threshold, "
          "a tangle above it") {
    // x'' = -x + x^2 - 0.1 x' + gamma cos(0.85 t); Melnikov: gamma_c = delta sinh(pi w) / (5 pi w^2) = 0.0634. Its
    // hilltop period-1 saddle orbit passes (0.97050, 0.00124) at t = 0 at gamma = 0.05 (Newton's method on the period
    // map with SciPy, independently of geobarrier).
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-tangle-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    ::setenv("GEOBARRIER_EQUATIONS_CACHE", (dir / "cache").c_str(), 1);
    json j = json::parse(test::read_text(test::source_dir() / "experiments" / "escape-oscillator.json"));
    j["grid"]["n"] = {141, 121};
    j["time"]["directions"] = "both";
    j["output"]["plots"] = true;
    for (const double gamma : {0.05, 0.08}) {
        CAPTURE(gamma);
        j["forcing"]["params"]["amplitude"] = gamma;
        const fs::path out = dir / ("gamma-" + std::to_string(gamma));
        RunOptions options;
        options.output_dir = out;
        options.quiet = true;
        const RunSummary s = run_experiment(resolve_experiment(parse_experiment(j)), options);
        CHECK(fs::exists(out / "forward" / "manifest.json"));
        CHECK(fs::exists(out / "backward" / "manifest.json"));
        CHECK(fs::exists(out / "tangle.png"));
        const json forward = json::parse(test::read_text(out / "forward" / "manifest.json"));
        const json backward = json::parse(test::read_text(out / "backward" / "manifest.json"));
        CHECK(forward["resolved"]["time"]["t1"].get<double>() > 0.0);
        CHECK(backward["resolved"]["time"]["t1"].get<double>() < 0.0);
        const json tangle = json::parse(test::read_text(out / "tangle.json"));
        const json &crossings = tangle["crossings"];
        MESSAGE("gamma " << gamma << ": " << crossings.size() << " crossings");
        if (gamma < 0.0634) {
            REQUIRE(crossings.size() == 1);
            CHECK(std::hypot(crossings[0]["point"][0].get<double>() - 0.97050,
                             crossings[0]["point"][1].get<double>() - 0.00124) < 0.01);
        } else {
            CHECK(crossings.size() >= 3); // the saddle orbit and at least one lobe's pair of homoclinic points
        }
    }
    ::unsetenv("GEOBARRIER_EQUATIONS_CACHE");
    fs::remove_all(dir);
}

TEST_CASE("both directions: bad input names /time/directions") {
    json j = json::parse(test::read_text(test::source_dir() / "experiments" / "escape-oscillator.json"));
    j["time"]["directions"] = "sideways";
    CHECK_THROWS_WITH_AS(parse_experiment(j), doctest::Contains("/time/directions"), ConfigError);
    j["time"]["directions"] = "both";
    j["time"]["t1"] = 0;
    CHECK_THROWS_WITH_AS(parse_experiment(j), doctest::Contains("/time/t1"), ConfigError);
    // Both directions look for crossings of barriers, and write two runs: no extractor, or results kept in memory
    // only (the Python module's way), is refused before anything runs.
    json d = json::parse(R"({"system": {"plugin": "duffing"}, "grid": {"x": [-1, 1], "y": [-1, 1], "n": [11, 11]},
                             "time": {"t0": 0, "t1": 1, "directions": "both"}, "products": ["ftle"]})");
    d["plugin_paths"] = {test::plugin_dir().string()};
    const fs::path out = fs::temp_directory_path() / ("geobarrier-test-tangle-bad-" + std::to_string(::getpid()));
    RunOptions options;
    options.output_dir = out;
    options.quiet = true;
    CHECK_THROWS_WITH_AS(run_experiment(resolve_experiment(parse_experiment(d)), options),
                         doctest::Contains("/time/directions"), ConfigError);
    d["extractors"] = {{{"plugin", "hyperbolic"}}};
    options.keep_results = true;
    CHECK_THROWS_WITH_AS(run_experiment(resolve_experiment(parse_experiment(d)), options),
                         doctest::Contains("/time/directions"), ConfigError);
    CHECK_FALSE(fs::exists(out));
}
