// Both directions in one run (tangle.hpp): the crossing finder on constructed curves, saddle orbits against an exact
// one, and the homoclinic tangles of the escape oscillator and damped Duffing appearing at Melnikov's threshold.
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/tangle.hpp>

#include <test_support.hpp>

#include <doctest/doctest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <utility>

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

namespace {

// A run of both directions into `out`, results from its tangle.json.
json run_tangle(const json &experiment, const fs::path &out) {
    RunOptions options;
    options.output_dir = out;
    options.quiet = true;
    run_experiment(resolve_experiment(parse_experiment(experiment)), options);
    return json::parse(test::read_text(out / "tangle.json"));
}

} // namespace

TEST_CASE("saddle orbits: the forced linear saddle's periodic orbit and multipliers, exactly") {
    // x' = x, y' = -y + a cos(w t): the one bounded solution is x = 0, y = a (cos w t + w sin w t) / (1 + w^2), a
    // saddle orbit with multipliers e^T and e^-T over the period T = 2 pi / w.
    const double a = 0.3, w = 2.0, pi = std::acos(-1.0), period = 2 * pi / w;
    json j = json::parse(R"({"system": {"plugin": "equations", "params": {"state": ["x", "y"], "rhs": ["x", "-y + f"]}},
                             "forcing": {"plugin": "cosine", "params": {"amplitude": 0.3, "omega": 2}},
                             "grid": {"x": [-1, 1], "y": [-1, 1], "n": [101, 101]},
                             "time": {"t0": 0, "t1": 3, "directions": "both"},
                             "integrator": {"rtol": 1e-10, "atol": 1e-12},
                             "products": ["ftle"], "extractors": [{"plugin": "hyperbolic"}]})");
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-saddle-" + std::to_string(::getpid()));
    ::setenv("GEOBARRIER_EQUATIONS_CACHE", (dir / "cache").c_str(), 1);
    const ResolvedExperiment r = resolve_experiment(parse_experiment(j));
    const double y0 = a / (1 + w * w);
    // Starts two and three grid spacings off, and one far off (beyond the reach given): one orbit, found once.
    const std::vector<SaddleOrbit> orbits = saddle_orbits_near(r, period, {0.04, y0 - 0.03, -0.05, y0, 0.6, 0.6}, 0.08);
    REQUIRE(orbits.size() == 1);
    CHECK(std::abs(orbits[0].x) < 1e-8);
    CHECK(orbits[0].y == doctest::Approx(y0).epsilon(1e-8));
    CHECK(orbits[0].multipliers[0] == doctest::Approx(std::exp(period)).epsilon(1e-6));
    CHECK(orbits[0].multipliers[1] == doctest::Approx(std::exp(-period)).epsilon(1e-6));
    ::unsetenv("GEOBARRIER_EQUATIONS_CACHE");
    fs::remove_all(dir);
}

TEST_CASE("both directions of the escape oscillator: no tangle below Melnikov's threshold, a tangle above it") {
    // x'' = -x + x^2 - 0.1 x' + gamma cos(0.85 t); Melnikov: gamma_c = delta sinh(pi w) / (5 pi w^2) = 0.0634. Its
    // hilltop period-1 saddle orbit passes (0.97050, 0.00124) at t = 0 at gamma = 0.05 (Newton's method on the period
    // map with SciPy, independently of geobarrier).
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-tangle-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    ::setenv("GEOBARRIER_EQUATIONS_CACHE", (dir / "cache").c_str(), 1);
    json j = json::parse(test::read_text(test::source_dir() / "experiments" / "escape-oscillator.json"));
    const double pi = std::acos(-1.0), gamma_c = 0.0634;
    j["grid"]["n"] = {141, 121};
    j["time"]["directions"] = "both";
    j["time"]["period"] = 2 * pi / 0.85;
    j["output"]["plots"] = true;
    for (const double gamma : {0.05, 0.9 * gamma_c, 1.1 * gamma_c}) {
        CAPTURE(gamma);
        j["forcing"]["params"]["amplitude"] = gamma;
        const fs::path out = dir / ("gamma-" + std::to_string(gamma));
        const json tangle = run_tangle(j, out);
        CHECK(fs::exists(out / "tangle.png"));
        const json forward = json::parse(test::read_text(out / "forward" / "manifest.json"));
        const json backward = json::parse(test::read_text(out / "backward" / "manifest.json"));
        CHECK(forward["resolved"]["time"]["t1"].get<double>() > 0.0);
        CHECK(backward["resolved"]["time"]["t1"].get<double>() < 0.0);
        // The folder's own manifest: the experiment as given and the counts (what a sweep reads).
        const json manifest = json::parse(test::read_text(out / "manifest.json"));
        CHECK(manifest["experiment"] == j);
        CHECK(manifest["crossings"] == tangle["counts"]);
        const json &counts = tangle["counts"];
        MESSAGE("gamma " << gamma << ": " << counts.dump());
        // The saddle orbit, where its own manifolds cross, is no tangle: found by Newton's method from that crossing,
        // with multipliers whose product is det DP = exp(-delta T) (Liouville).
        REQUIRE(tangle["saddle_orbits"].size() >= 1);
        const json &orbit = tangle["saddle_orbits"][0];
        CHECK(orbit["multipliers"][0].get<double>() * orbit["multipliers"][1].get<double>() ==
              doctest::Approx(std::exp(-0.1 * 2 * pi / 0.85)).epsilon(1e-5));
        CHECK(counts["saddle_orbit"] == 1);
        if (gamma == 0.05) {
            // The safe basin's boundary is the hilltop's stable manifold: the top-ranked repelling barrier bounds it.
            const json barriers = json::parse(test::read_text(out / "forward" / "barriers.json"))["barriers"];
            std::size_t top = barriers.size();
            for (std::size_t b = 0; b < barriers.size(); ++b)
                if (barriers[b].value("global_minimum", false)) top = b;
            REQUIRE(top < barriers.size());
            CHECK(barriers[top]["basin_boundary_share"].get<double>() > 0.9);
            const json &bounding = forward["escape"]["bounding_barriers"];
            CHECK(std::find(bounding.begin(), bounding.end(), json(top)) != bounding.end());
            CHECK(orbit["point"][0].get<double>() == doctest::Approx(0.97050).epsilon(1e-5));
            CHECK(orbit["point"][1].get<double>() == doctest::Approx(0.00124).epsilon(1e-2));
        }
        if (gamma < gamma_c)
            CHECK(counts["tangle"] == 0);
        else
            CHECK(counts["homoclinic"].get<int>() >= 1);
    }
    ::unsetenv("GEOBARRIER_EQUATIONS_CACHE");
    fs::remove_all(dir);
}

namespace {

// x' = y, y' = -x + x^2 - delta y + gamma cos(omega t) from t_from to t_to by classical Runge-Kutta with `steps` steps:
// the test's own integrator, independent of the engine's.
std::pair<double, double> escape_rk4(double x, double y, double t_from, double t_to, double delta, double gamma,
                                     double omega, int steps) {
    const double h = (t_to - t_from) / steps;
    const auto f = [&](double t, double px, double py) {
        return std::pair<double, double>{py, -px + px * px - delta * py + gamma * std::cos(omega * t)};
    };
    double t = t_from;
    for (int k = 0; k < steps; ++k, t = t_from + k * h) {
        const auto [k1x, k1y] = f(t, x, y);
        const auto [k2x, k2y] = f(t + h / 2, x + h / 2 * k1x, y + h / 2 * k1y);
        const auto [k3x, k3y] = f(t + h / 2, x + h / 2 * k2x, y + h / 2 * k2y);
        const auto [k4x, k4y] = f(t + h, x + h * k3x, y + h * k3y);
        x += h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
        y += h / 6 * (k1y + 2 * k2y + 2 * k3y + k4y);
    }
    return {x, y};
}

// The distance from (x, y) to a barrier's polyline.
double distance_to(const json &barrier, double x, double y) {
    double best = std::numeric_limits<double>::infinity();
    const json &p = barrier["points"];
    for (std::size_t k = 0; k + 1 < p.size(); ++k) {
        const double ax = p[k][0], ay = p[k][1], bx = p[k + 1][0], by = p[k + 1][1];
        const double dx = bx - ax, dy = by - ay, l2 = dx * dx + dy * dy;
        const double s = l2 > 0 ? std::clamp(((x - ax) * dx + (y - ay) * dy) / l2, 0.0, 1.0) : 0.0;
        best = std::min(best, std::hypot(x - ax - s * dx, y - ay - s * dy));
    }
    return best;
}

} // namespace

TEST_CASE("grown manifolds: one period back (stable) or on (unstable), they map onto their barriers, without gaps") {
    // The escape oscillator below Melnikov's threshold. A repelling barrier grown backward over one period is
    // P^-1(barrier): its points, integrated one period forward by the test's own Runge-Kutta, land on the barrier
    // (curve advection inserts midpoints of the barrier's own polyline); attracting ones alike, backward.
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-grown-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    ::setenv("GEOBARRIER_EQUATIONS_CACHE", (dir / "cache").c_str(), 1);
    json j = json::parse(test::read_text(test::source_dir() / "experiments" / "escape-oscillator.json"));
    const double pi = std::acos(-1.0), omega = 0.85, period = 2 * pi / omega, gamma = 0.05;
    j["grid"]["n"] = {141, 121};
    j["forcing"]["params"]["amplitude"] = gamma;
    j["time"]["directions"] = "both";
    j["time"]["period"] = period;
    j["time"]["grow_periods"] = 1;
    j["output"]["plots"] = true;
    const json tangle = run_tangle(j, dir / "out");
    CHECK(fs::exists(dir / "out" / "grown.png"));
    const json &grown = tangle["grown"];
    const double spacing = 2.8 / 140;
    for (const bool repelling : {true, false}) {
        CAPTURE(repelling);
        const json barriers =
            json::parse(test::read_text(dir / "out" / (repelling ? "forward" : "backward") / "barriers.json"))
                .at("barriers");
        const json &report = grown[repelling ? "repelling" : "attracting"];
        REQUIRE(report.size() == barriers.size());
        double longest_growth = 0.0;
        for (const json &r : report) {
            CHECK(r["refined"] == true);
            CHECK(r["max_gap_in_box"].get<double>() <= grown["max_gap"].get<double>() * (1 + 1e-9));
            longest_growth = std::max(longest_growth, r["grown_length"].get<double>() / r["length"].get<double>());
        }
        // The stable manifold grows backward along itself (1.8x here); the unstable one, forward, leaves the bounds
        // over the hilltop on one side and winds into the well on the other, so its length need not grow.
        if (repelling) CHECK(longest_growth > 1.5);
        double worst = 0.0;
        std::size_t checked = 0;
        for (const json &piece : grown[repelling ? "repelling_pieces" : "attracting_pieces"]) {
            const json &points = piece["points"];
            for (std::size_t k = 0; k < points.size(); k += 7) {
                // P^-j(barrier) lives at t0 - j period, P^j(barrier) at t0 + j period (t0 = 0; j = 0: the barrier).
                const double span = piece["periods"].get<double>() * period;
                const auto [x, y] =
                    escape_rk4(points[k][0], points[k][1], repelling ? -span : span, 0.0, 0.1, gamma, omega, 4000);
                worst = std::max(worst, distance_to(barriers[piece["barrier"].get<std::size_t>()], x, y));
                ++checked;
            }
        }
        MESSAGE(std::string(repelling ? "repelling" : "attracting")
                << ": " << checked << " points, farthest from the barrier " << worst);
        CHECK(checked > 50);
        CHECK(worst < 0.05 * spacing);
    }
    ::unsetenv("GEOBARRIER_EQUATIONS_CACHE");
    fs::remove_all(dir);
}

TEST_CASE("damped Duffing: the tangle begins within 10% of Melnikov's threshold, at two dampings") {
    // x'' = x - x^3 - delta x' + gamma cos t; Melnikov: gamma_c = 4 delta cosh(pi / 2) / (3 sqrt(2) pi).
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-melnikov-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    json j = json::parse(test::read_text(test::source_dir() / "experiments" / "duffing-tangle.json"));
    j["output"]["plots"] = false;
    j["time"].erase("grow_periods"); // the counts are the barriers' own
    const double pi = std::acos(-1.0);
    for (const double delta : {0.1, 0.2}) {
        const double gamma_c = 4 * delta * std::cosh(pi / 2) / (3 * std::sqrt(2.0) * pi);
        for (const double factor : {0.9, 1.1}) {
            CAPTURE(delta);
            CAPTURE(factor);
            j["system"]["params"]["delta"] = delta;
            j["forcing"]["params"]["amplitude"] = factor * gamma_c;
            const json counts = run_tangle(j, dir / (std::to_string(delta) + "-" + std::to_string(factor)))["counts"];
            MESSAGE("delta " << delta << ", gamma " << factor << " gamma_c: " << counts.dump());
            if (factor < 1)
                CHECK(counts["tangle"] == 0);
            else
                CHECK(counts["tangle"].get<int>() >= 1);
        }
    }
    fs::remove_all(dir);
}

TEST_CASE("both directions: bad input names /time/directions") {
    json j = json::parse(test::read_text(test::source_dir() / "experiments" / "escape-oscillator.json"));
    j["time"]["directions"] = "sideways";
    CHECK_THROWS_WITH_AS(parse_experiment(j), doctest::Contains("/time/directions"), ConfigError);
    j["time"]["directions"] = "both";
    j["time"]["t1"] = 0;
    CHECK_THROWS_WITH_AS(parse_experiment(j), doctest::Contains("/time/t1"), ConfigError);
    // The forcing period classifies crossings: it must be positive, and only both directions have crossings.
    j["time"]["t1"] = 10;
    j["time"]["period"] = 0;
    CHECK_THROWS_WITH_AS(parse_experiment(j), doctest::Contains("/time/period"), ConfigError);
    j["time"]["period"] = 7.4;
    j["time"]["directions"] = "one";
    CHECK_THROWS_WITH_AS(parse_experiment(j), doctest::Contains("/time/period"), ConfigError);
    // Both directions look for crossings of barriers: no extractor is refused as the experiment is read (so validate
    // and a sweep's checks say so).
    json d = json::parse(R"({"system": {"plugin": "duffing"}, "grid": {"x": [-1, 1], "y": [-1, 1], "n": [11, 11]},
                             "time": {"t0": 0, "t1": 1, "directions": "both"}, "products": ["ftle"]})");
    d["plugin_paths"] = {test::plugin_dir().string()};
    CHECK_THROWS_WITH_AS(parse_experiment(d), doctest::Contains("/time/directions"), ConfigError);
}

TEST_CASE("both directions in memory (the Python module's way): the results the files hold, nothing written") {
    // Unforced Duffing x'' = x - x^3: the origin is a saddle whose stable (forward, repelling) and unstable (backward,
    // attracting) manifolds are the homoclinic loops, crossing there at the angle between the eigenvectors (1, +-1):
    // 90 degrees.
    json d = json::parse(R"({"system": {"plugin": "duffing"}, "grid": {"x": [-1.5, 1.5], "y": [-1, 1], "n": [151, 101]},
                             "time": {"t0": 0, "t1": 8, "directions": "both"}, "products": ["ftle"],
                             "extractors": [{"plugin": "hyperbolic"}], "output": {"plots": true}})");
    d["plugin_paths"] = {test::plugin_dir().string()};
    const ResolvedExperiment r = resolve_experiment(parse_experiment(d));
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-tangle-memory-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    RunOptions written;
    written.output_dir = dir / "written";
    written.quiet = true;
    run_experiment(r, written);
    RunOptions in_memory = written;
    in_memory.output_dir = dir / "in-memory";
    in_memory.write_files = false;
    in_memory.keep_results = true;
    const RunSummary kept = run_experiment(r, in_memory);
    CHECK_FALSE(fs::exists(dir / "in-memory"));
    CHECK(kept.files.empty());
    REQUIRE(kept.directions.size() == 2);
    const char *names[] = {"forward", "backward"};
    for (std::size_t k = 0; k < 2; ++k) {
        CAPTURE(names[k]);
        const RunSummary &one = kept.directions[k];
        const json file = json::parse(test::read_text(dir / "written" / names[k] / "barriers.json"));
        CHECK(one.barriers == file["barriers"]);
        CHECK(one.manifest["resolved"]["time"]["t1"].get<double>() == (k == 0 ? 8.0 : -8.0));
        REQUIRE(one.grid.nx == 151);
        CHECK(one.fields.size() >= 1);
    }
    const json tangle = json::parse(test::read_text(dir / "written" / "tangle.json"));
    CHECK(kept.tangle["crossings"] == tangle["crossings"]);
    CHECK(kept.manifest["crossings"] == tangle["counts"]);
    // The repelling and attracting barriers cross at the saddle, at right angles.
    const json &crossings = kept.tangle["crossings"];
    const auto at_saddle = std::find_if(crossings.begin(), crossings.end(), [](const json &c) {
        return std::hypot(c["point"][0].get<double>(), c["point"][1].get<double>()) < 0.04;
    });
    REQUIRE(at_saddle != crossings.end());
    CHECK((*at_saddle)["angle_degrees"].get<double>() == doctest::Approx(90.0).epsilon(0.05));
    fs::remove_all(dir);
}
