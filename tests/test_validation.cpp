// Validation products against known answers: period-map iterates of the unforced Duffing oscillator keep H, tracers
// and advected curves of the linear saddle follow its exact flow map, an invariant closed orbit keeps its length
// and area (the elliptic check of eq. `rel_def`), forcing.csv holds the plugin's values, point-in-polygon on known
// shapes, the VTK tube is consistent, and a smoke experiment writes every product.
#include <geobarrier/curves.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/validation.hpp>

#include <doctest/doctest.h>
#include <test_support.hpp>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include <unistd.h>

using namespace geobarrier;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

// Tight tolerances: the checks below are about the products, not the integrator.
IntegratorSettings tight() {
    IntegratorSettings s;
    s.rtol = 1e-11;
    s.atol = 1e-13;
    return s;
}

double duffing_h(double x, double y) { return 0.5 * y * y - 0.5 * x * x + 0.25 * x * x * x * x; }

fs::path fresh_dir(const std::string &name) {
    const fs::path dir =
        fs::temp_directory_path() / ("geobarrier-test-validation-" + name + "-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

std::vector<std::vector<std::string>> read_csv(const fs::path &file) {
    std::ifstream in(file);
    std::vector<std::vector<std::string>> rows;
    std::string line;
    while (std::getline(in, line)) {
        std::vector<std::string> cells;
        std::stringstream ss(line);
        std::string cell;
        while (std::getline(ss, cell, ',')) cells.push_back(cell);
        if (!line.empty() && line.back() == ',') cells.push_back("");
        rows.push_back(cells);
    }
    return rows;
}

bool is_png(const fs::path &file) {
    std::ifstream in(file, std::ios::binary);
    char head[8] = {};
    in.read(head, 8);
    return in && std::string(head, 8) == std::string("\x89PNG\r\n\x1a\n", 8);
}

// The level set H = h of the unforced Duffing oscillator around the centre (1, 0), as a polygon of n points: for
// each angle about the centre, the radius solving H = h by bisection (H increases along every ray from (1, 0) up
// to the homoclinic level 0 for h in (-1/4, 0)).
std::vector<double> duffing_level_curve(double h, std::size_t n) {
    std::vector<double> xy;
    for (std::size_t k = 0; k < n; ++k) {
        const double a = 2.0 * M_PI * static_cast<double>(k) / static_cast<double>(n);
        double lo = 0.0, hi = 0.9;
        for (int it = 0; it < 200; ++it) {
            const double mid = 0.5 * (lo + hi);
            (duffing_h(1.0 + mid * std::cos(a), mid * std::sin(a)) < h ? lo : hi) = mid;
        }
        xy.push_back(1.0 + lo * std::cos(a));
        xy.push_back(lo * std::sin(a));
    }
    return xy;
}

} // namespace

TEST_CASE("point_in_polygon on known shapes") {
    const std::vector<double> square = {0, 0, 1, 0, 1, 1, 0, 1};
    CHECK(point_in_polygon(0.5, 0.5, square));
    CHECK(point_in_polygon(0.01, 0.99, square));
    CHECK_FALSE(point_in_polygon(1.5, 0.5, square));
    CHECK_FALSE(point_in_polygon(0.5, -0.01, square));
    CHECK_FALSE(point_in_polygon(-3.0, 0.5, square));
    // A concave L: the notch (upper right) is outside.
    const std::vector<double> ell = {0, 0, 2, 0, 2, 1, 1, 1, 1, 2, 0, 2};
    CHECK(point_in_polygon(0.5, 1.5, ell));
    CHECK(point_in_polygon(1.5, 0.5, ell));
    CHECK_FALSE(point_in_polygon(1.5, 1.5, ell));
    // A ray through a vertex (y = 1 passes the L's corners) still counts once.
    CHECK(point_in_polygon(0.5, 1.0, ell));
    CHECK_FALSE(point_in_polygon(2.5, 1.0, ell));
    // A clockwise circle of 200 points: radius 1 about (3, -2).
    std::vector<double> circle;
    for (int k = 199; k >= 0; --k)
        circle.insert(circle.end(), {3 + std::cos(2 * M_PI * k / 200), -2 + std::sin(2 * M_PI * k / 200)});
    CHECK(point_in_polygon(3.0, -2.0, circle));
    CHECK(point_in_polygon(3.99, -2.0, circle));
    CHECK_FALSE(point_in_polygon(3.0, -0.99, circle));
    CHECK_FALSE(point_in_polygon(4.01, -2.0, circle));
    // Degenerate polygons contain nothing.
    CHECK_FALSE(point_in_polygon(0.0, 0.0, {0, 0, 1, 1}));
}

TEST_CASE("seed lattices and discs") {
    const std::vector<double> l = lattice_points({-1, 1, 0, 2, 3, 2});
    REQUIRE(l.size() == 12);
    CHECK(l[0] == -1.0);
    CHECK(l[1] == 0.0);
    CHECK(l[2] == 0.0);
    CHECK(l[10] == 1.0);
    CHECK(l[11] == 2.0);
    const std::vector<double> one = lattice_points({0, 2, 4, 4, 1, 1});
    REQUIRE(one.size() == 2);
    CHECK(one[0] == 1.0);
    CHECK(one[1] == 4.0);
    // Vogel's spiral: n points strictly inside the disc, centred on it (the mean lies within a few point spacings
    // of the centre: spacing ~ R sqrt(pi / n)).
    const SeedDisc disc{0.5, -0.25, 0.2, 1000};
    const std::vector<double> d = disc_points(disc);
    REQUIRE(d.size() == 2000);
    double mx = 0, my = 0, r_max = 0;
    for (std::size_t k = 0; k < 1000; ++k) {
        mx += d[2 * k] / 1000;
        my += d[2 * k + 1] / 1000;
        r_max = std::max(r_max, std::hypot(d[2 * k] - 0.5, d[2 * k + 1] + 0.25));
    }
    CHECK(r_max < 0.2);
    CHECK(std::hypot(mx - 0.5, my + 0.25) < 0.2 * std::sqrt(M_PI / 1000));
}

TEST_CASE("the period map of the unforced Duffing oscillator keeps H along its iterates") {
    const System duffing = test::make_system("duffing");
    const Forcing none = test::make_forcing("none");
    // Seeds on closed orbits in both wells and outside the homoclinic loops (H from -0.22 to 0.3).
    const std::vector<double> seeds = {1.2, 0.0, 0.6, 0.1, -1.3, 0.2, -0.5, -0.3, 0.0, 0.9, 1.5, 0.4};
    const std::size_t iterations = 40;
    const Snapshots it = poincare_iterates({&duffing, &none}, tight(), std::nullopt, seeds, 0.0, 2 * M_PI, iterations);
    REQUIRE(it.positions.size() == iterations + 1);
    CHECK(it.masked == 0);
    double worst = 0.0;
    for (std::size_t s = 0; s < seeds.size() / 2; ++s) {
        const double h0 = duffing_h(seeds[2 * s], seeds[2 * s + 1]);
        CHECK(it.positions[0][2 * s] == seeds[2 * s]);
        for (std::size_t k = 1; k <= iterations; ++k)
            worst = std::max(worst, std::abs(duffing_h(it.positions[k][2 * s], it.positions[k][2 * s + 1]) - h0));
    }
    // 40 periods (t = 251) at rtol 1e-11: the energy error grows about linearly with the number of steps, each
    // contributing ~1e-11 relative; 1e-8 leaves a factor ~10 of room over what the integrator achieves.
    MESSAGE("max |H(P^k x) - H(x)| over 40 iterates: " << worst);
    CHECK(worst < 1e-8);
    // The iterates move: P is not the identity (the check above is not vacuous).
    CHECK(std::hypot(it.positions[1][0] - seeds[0], it.positions[1][1] - seeds[1]) > 0.01);
}

TEST_CASE("tracers of the linear saddle follow its exact flow map, forward and backward") {
    const System saddle = test::make_system("linear-saddle", {{"a", 0.7}});
    const Forcing none = test::make_forcing("none");
    const std::vector<double> cloud = disc_points({0.3, -0.2, 0.25, 50});
    const double release = 2.0;
    const std::vector<double> times = {5.0, 0.5, 3.0, 2.0, -1.0};
    const Snapshots snaps = advect_snapshots({&saddle, &none}, tight(), std::nullopt, cloud, release, times);
    REQUIRE(snaps.positions.size() == times.size());
    double worst = 0.0;
    for (std::size_t k = 0; k < times.size(); ++k)
        for (std::size_t p = 0; p < 50; ++p) {
            const double ex = cloud[2 * p] * std::exp(0.7 * (times[k] - release));
            const double ey = cloud[2 * p + 1] * std::exp(-0.7 * (times[k] - release));
            worst = std::max(worst, std::hypot(snaps.positions[k][2 * p] - ex, snaps.positions[k][2 * p + 1] - ey) /
                                        std::hypot(ex, ey));
        }
    MESSAGE("largest relative tracer error: " << worst);
    // rtol 1e-11 over |T| <= 3 (a few hundred steps at most): 1e-9 relative.
    CHECK(worst < 1e-9);
    // At the release time itself the positions are the cloud, untouched.
    CHECK(snaps.positions[3] == cloud);
}

TEST_CASE("advected length of straight segments and areas under the linear saddle are exact") {
    const double a = 0.8, T = 1.5;
    const System saddle = test::make_system("linear-saddle", {{"a", a}});
    const Forcing none = test::make_forcing("none");
    const Dynamics dynamics{&saddle, &none};
    // A diagonal segment of length L maps to a segment of length L sqrt(e^{2aT} + e^{-2aT}) / sqrt(2).
    const std::vector<double> diagonal = {-0.5, -0.5, -0.3, -0.3, 0.5, 0.5};
    const StretchingHistory h =
        stretching_history(dynamics, tight(), std::nullopt, diagonal, false, 0.0, {0.0, T / 2, T}, 0.005);
    REQUIRE(h.samples.size() == 3);
    const double L = std::sqrt(2.0);
    CHECK(h.length0 == doctest::Approx(L).epsilon(1e-14));
    CHECK(h.samples[0].delta_l == 0.0);
    for (const StretchingSample &s : h.samples) {
        const double exact = L * std::sqrt(std::exp(2 * a * s.t) + std::exp(-2 * a * s.t)) / std::sqrt(2.0);
        CHECK(s.length == doctest::Approx(exact).epsilon(1e-9));
        CHECK(s.delta_l == doctest::Approx(exact / L - 1.0).epsilon(1e-9));
        CHECK(s.converged);
    }
    // A strainline of the forward saddle runs along xi1 = y (the compressed direction): its advected length is
    // int sqrt(lambda1) ds = e^{-aT} L (paper, section 2.2), with no shortcut taken here.
    const std::vector<double> strainline = {0.2, -0.4, 0.2, 0.6};
    const StretchingHistory hs =
        stretching_history(dynamics, tight(), std::nullopt, strainline, false, 0.0, {T}, 0.005);
    CHECK(hs.samples[0].length == doctest::Approx(std::exp(-a * T) * 1.0).epsilon(1e-9));
    // A closed square keeps its area (det DF = 1); its image is a parallelogram... here a rectangle.
    const std::vector<double> square = {-0.1, -0.1, 0.1, -0.1, 0.1, 0.1, -0.1, 0.1};
    const StretchingHistory hq = stretching_history(dynamics, tight(), std::nullopt, square, true, 0.0, {T}, 0.005);
    CHECK(hq.area0 == doctest::Approx(0.04).epsilon(1e-14));
    CHECK(hq.samples[0].area == doctest::Approx(0.04).epsilon(1e-9));
    CHECK(hq.samples[0].length == doctest::Approx(2 * 0.2 * (std::exp(a * T) + std::exp(-a * T))).epsilon(1e-9));
}

TEST_CASE("an invariant closed orbit keeps its length and area when advected (elliptic check of eq. rel_def)") {
    const System duffing = test::make_system("duffing");
    const Forcing none = test::make_forcing("none");
    // H = -0.15 around (1, 0): a closed orbit of the unforced flow, mapped onto itself at every time.
    const std::vector<double> orbit = duffing_level_curve(-0.15, 2000);
    const std::vector<double> times = {0.0, M_PI, 2 * M_PI, 4 * M_PI};
    const StretchingHistory h =
        stretching_history({&duffing, &none}, tight(), std::nullopt, orbit, true, 0.0, times, 0.002);
    double worst_l = 0.0, worst_a = 0.0;
    for (const StretchingSample &s : h.samples) {
        worst_l = std::max(worst_l, std::abs(s.delta_l));
        worst_a = std::max(worst_a, std::abs(s.area - h.area0) / h.area0);
        CHECK(s.converged);
        // Each image point keeps the energy of its initial point (inserted points lie on the polygon's chords,
        // off the level set by the sagitta, so they are compared with themselves, not with -0.15).
        REQUIRE(s.xy0.size() == s.xy.size());
        double drift = 0.0;
        for (std::size_t p = 0; p < s.xy.size(); p += 2)
            drift = std::max(drift, std::abs(duffing_h(s.xy[p], s.xy[p + 1]) - duffing_h(s.xy0[p], s.xy0[p + 1])));
        CHECK(drift < 1e-9);
    }
    // The initial polygon and its image are two different polygons through points of the same convex curve
    // (perimeter ~2.3, curvature <= 3.5); each misses the curve's length by at most (spacing x curvature)^2 / 24
    // ~ (0.0014 x 3.5)^2 / 24 = 1e-6 relative, and its area by about twice that: 2e-6 and 4e-6 bound the
    // differences.
    MESSAGE("max |delta_l| = " << worst_l << ", max relative area change = " << worst_a);
    CHECK(worst_l < 2e-6);
    CHECK(worst_a < 4e-6);
}

TEST_CASE("trajectories: inside or outside the outermost elliptic barrier, by point in polygon") {
    const System duffing = test::make_system("duffing");
    const Forcing none = test::make_forcing("none");
    // Two nested closed elliptic barriers around (1, 0); only the outer one is marked outermost.
    auto ring = [](double r) {
        Barrier b;
        b.kind = "elliptic";
        b.closed = true;
        for (int k = 0; k < 100; ++k)
            b.xy.insert(b.xy.end(), {1 + r * std::cos(M_PI * k / 50), r * std::sin(M_PI * k / 50)});
        return b;
    };
    std::vector<Barrier> barriers = {ring(0.1), ring(0.3)};
    barriers[0].attributes = {{"outermost", "false"}};
    barriers[1].attributes = {{"outermost", "true"}};
    ValidationSpec spec;
    spec.trajectories = TrajectoriesSpec{{{1.0, 0.2}, {0.5, 0.0}, {1.0, 0.05}}, std::nullopt, 1.0, 5};
    ValidationInput input;
    input.dynamics = {&duffing, &none};
    input.integrator = tight();
    input.t0 = 0.0;
    input.t1 = 2.0;
    input.barriers = &barriers;
    input.plots = false;
    const fs::path dir = fresh_dir("inside");
    const ValidationOutput out = run_validation(spec, input, dir);
    const json &list = out.summary["trajectories"]["trajectories"];
    CHECK(list[0]["inside"] == true); // between the rings: inside the outermost
    CHECK(list[1]["inside"] == false);
    CHECK(list[2]["inside"] == true);
    CHECK(out.summary["trajectories"]["elliptic_barriers_used"] == 1);
    const auto rows = read_csv(dir / "trajectories.csv");
    REQUIRE(rows.size() == 1 + 3 * 5);
    CHECK(rows[1][5] == "1");
    CHECK(rows[6][5] == "0");
    CHECK(std::stod(rows[5][2]) == 1.0); // t_end
    // The states are sampled on the trajectory: H is conserved along each (unforced Duffing).
    for (std::size_t r = 1; r < rows.size(); ++r) {
        const std::size_t s = std::stoul(rows[r][0]);
        const double h0 = duffing_h(spec.trajectories->states[s][0], spec.trajectories->states[s][1]);
        CHECK(duffing_h(std::stod(rows[r][3]), std::stod(rows[r][4])) == doctest::Approx(h0).epsilon(1e-9));
    }
    fs::remove_all(dir);
}

TEST_CASE("barrier tubes and their VTK file") {
    const System saddle = test::make_system("linear-saddle", {{"a", 0.5}});
    const Forcing none = test::make_forcing("none");
    std::vector<double> circle;
    for (int k = 0; k < 40; ++k)
        circle.insert(circle.end(), {0.3 * std::cos(M_PI * k / 20), 0.3 * std::sin(M_PI * k / 20)});
    BarrierTube tube = barrier_tube({&saddle, &none}, tight(), std::nullopt, circle, true, 0.0, {0.0, 0.5, 1.0}, 32);
    REQUIRE(tube.rows == 3);
    REQUIRE(tube.columns == 32);
    REQUIRE(tube.xyz.size() == 3 * 3 * 32);
    // Column c is one material point: at time t it sits at (x0 e^{at}, y0 e^{-at}), x0, y0 its place at t = 0, and
    // the t = 0 ring lies on the barrier (the polygon's vertices are 0.3 from the centre, its edges a little less).
    for (std::size_t c = 0; c < 32; ++c) {
        const double x0 = tube.xyz[3 * c], y0 = tube.xyz[3 * c + 1];
        CHECK(std::hypot(x0, y0) <= 0.3 + 1e-15);
        CHECK(std::hypot(x0, y0) >= 0.3 * std::cos(M_PI / 40) - 1e-15);
        for (std::size_t r = 1; r < 3; ++r) {
            const double t = tube.xyz[3 * (r * 32 + c) + 2];
            CHECK(tube.xyz[3 * (r * 32 + c)] == doctest::Approx(x0 * std::exp(0.5 * t)).epsilon(1e-9));
            CHECK(tube.xyz[3 * (r * 32 + c) + 1] == doctest::Approx(y0 * std::exp(-0.5 * t)).epsilon(1e-9));
        }
    }
    const StretchingHistory h =
        stretching_history({&saddle, &none}, tight(), std::nullopt, circle, true, 0.0, {0.0, 1.0}, 0.01);
    for (const StretchingSample &s : h.samples) {
        tube.slice_times.push_back(s.t);
        tube.slices.push_back(s.xy);
    }
    const fs::path dir = fresh_dir("vtp");
    write_tubes_vtp(dir / "tube.vtp", {tube});
    std::ifstream in(dir / "tube.vtp");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    CHECK(text.find("<VTKFile type=\"PolyData\"") != std::string::npos);
    std::size_t slice_points = 0;
    for (const auto &s : tube.slices) slice_points += s.size() / 2;
    CHECK(text.find("NumberOfPoints=\"" + std::to_string(slice_points + 3 * 32) + "\"") != std::string::npos);
    CHECK(text.find("NumberOfLines=\"2\"") != std::string::npos);
    CHECK(text.find("NumberOfPolys=\"" + std::to_string(2 * 32) + "\"") != std::string::npos);
    fs::remove_all(dir);
}

TEST_CASE("the validation object: parsing, defaults and errors") {
    auto error_of = [](const std::string &text) {
        try {
            parse_validation(json::parse(text));
        } catch (const ConfigError &e) {
            return std::string(e.what());
        }
        return std::string();
    };
    CHECK(error_of(R"({"poincare": {"period": 6.28, "seed": [[1, 0]]}})").find("did you mean \"seeds\"") !=
          std::string::npos);
    CHECK(error_of(R"({"poincare": {"period": 6.28}})").find("/validation/poincare: no seeds") == 0);
    CHECK(error_of(R"({"poincare": {"period": -1, "seeds": [[1, 0]]}})").find("/validation/poincare/period") == 0);
    CHECK(error_of(R"({"tracers": {"times": [1]}})").find("exactly one of") != std::string::npos);
    CHECK(error_of(R"({"tracers": [{"disc": {"center": [0, 0], "radius": 0, "n": 5}}]})")
              .find("/validation/tracers/0/disc/radius") == 0);
    CHECK(error_of(R"({"trajectories": {"states": [[0, "a"]]}})").find("/validation/trajectories/states/0") == 0);
    CHECK(error_of(R"({"advect_barriers": {"max_gap": 2}})").find("/validation/advect_barriers/max_gap") == 0);
    CHECK(error_of(R"({"forcing": false})").find("/validation/forcing") == 0);
    CHECK(error_of(R"({})").find("asks for nothing") != std::string::npos);

    const ValidationSpec spec = parse_validation(json::parse(
        R"({"forcing": true, "advect_barriers": {"samples": 5, "barriers": "outermost"},
            "tracers": {"box": {"x": [0, 1], "y": [2, 2], "n": [3, 1]}}})"));
    const json resolved = validation_to_json(spec, 1.0, 3.0);
    CHECK(resolved["forcing"]["t_start"] == 1.0);
    CHECK(resolved["forcing"]["t_end"] == 3.0);
    CHECK(resolved["advect_barriers"]["times"] == json({1.0, 1.5, 2.0, 2.5, 3.0}));
    CHECK(resolved["advect_barriers"]["barriers"] == "outermost");
    CHECK(resolved["tracers"][0]["times"] == json({3.0}));

    // In an experiment: barrier-based products need an extractor.
    json e = json::parse(R"({
      "system": {"plugin": "duffing"}, "grid": {"x": [-1, 1], "y": [-1, 1], "n": [5, 5]},
      "time": {"t0": 0, "t1": 1}, "validation": {"advect_barriers": true}})");
    try {
        parse_experiment(e);
        FAIL("no error");
    } catch (const ConfigError &err) {
        CHECK(std::string(err.what()).find("/validation/advect_barriers: works on the barriers") == 0);
    }
    // Validation products alone are something to compute.
    e["validation"] = {{"forcing", true}};
    CHECK_NOTHROW(parse_experiment(e));
}

TEST_CASE("smoke experiment: every validation product, written by the runner") {
    const fs::path dir = fresh_dir("smoke");
    json j = json::parse(R"({
      "system":  {"plugin": "duffing"},
      "forcing": {"plugin": "cosine", "params": {"amplitude": 0.08}},
      "grid":    {"x": [-1.5, 1.5], "y": [-1, 1], "n": [13, 9]},
      "time":    {"t0": 0, "t1": 3.141592653589793},
      "extractors": [{"plugin": "probe"}],
      "validation": {
        "poincare": {"period": 6.283185307179586, "iterations": 5, "seeds": [[1.2, 0]],
                     "lattice": {"x": [0.8, 1.2], "y": [0, 0], "n": [3, 1]}, "barrier_points": 2},
        "tracers": [{"disc": {"center": [1, 0], "radius": 0.1, "n": 30}, "times": [1, 2]},
                    {"box": {"x": [-1, 1], "y": [-0.5, 0.5], "n": [4, 3]}, "release": -1, "times": [0]}],
        "trajectories": {"states": [[1, 0.2], [0, 0.5]], "samples": 20},
        "forcing": {"samples": 11},
        "advect_barriers": {"samples": 3}
      }
    })");
    j["plugin_paths"] = {test::plugin_dir().string(), test::test_plugin_dir().string()};
    j["output"] = {{"dir", dir.string()}, {"plots", true}};
    const ResolvedExperiment r = resolve_experiment(parse_experiment(j));
    RunOptions options;
    options.quiet = true;
    const RunSummary s = run_experiment(r, options);
    for (const char *f : {"poincare.csv", "poincare.png", "tracers.csv", "tracers_0_0.png", "tracers_0_1.png",
                          "tracers_1_0.png", "trajectories.csv", "trajectories_phase.png", "trajectories_x.png",
                          "trajectories_y.png", "trajectories_3d.png", "forcing.csv", "forcing.png", "stretching.csv",
                          "stretching.png", "barriers_advected.png", "tube.vtp", "tube.png", "manifest.json"})
        CHECK_MESSAGE(fs::exists(dir / f), f);
    for (const char *f : {"poincare.png", "tracers_1_0.png", "trajectories_3d.png", "forcing.png", "tube.png"})
        CHECK_MESSAGE(is_png(dir / f), f);

    const auto poincare = read_csv(dir / "poincare.csv");
    CHECK(poincare[0] == std::vector<std::string>{"seed", "origin", "iteration", "t", "x", "y"});
    // 1 seed + 3 lattice points + 2 points of the probe's barrier, 6 rows each (iterations 0..5).
    CHECK(poincare.size() == 1 + 6 * 6);
    CHECK(poincare[1][1] == "seed");
    CHECK(poincare[7][1] == "lattice");
    CHECK(poincare.back()[1] == "barrier0");
    const auto tracers = read_csv(dir / "tracers.csv");
    CHECK(tracers[0] == std::vector<std::string>{"cloud", "tracer", "t", "x", "y"});
    CHECK(tracers.size() == 1 + 30 * 3 + 12 * 2); // cloud 0 at release, 1 and 2; cloud 1 at release -1 and 0
    const auto traj = read_csv(dir / "trajectories.csv");
    CHECK(traj[0] == std::vector<std::string>{"trajectory", "sample", "t", "x", "y", "inside"});
    CHECK(traj.size() == 1 + 2 * 20);
    CHECK(traj[1][5] == ""); // no elliptic barrier: unknown
    CHECK(std::stod(traj.back()[2]) == doctest::Approx(M_PI).epsilon(1e-15));
    const auto stretching = read_csv(dir / "stretching.csv");
    CHECK(stretching[0] == std::vector<std::string>{"barrier", "kind", "closed", "t", "length", "delta_l", "area",
                                                    "area_change", "points", "converged"});
    CHECK(stretching.size() == 1 + 3);
    CHECK(std::stod(stretching[1][5]) == 0.0);

    // forcing.csv holds the plugin's own values at the stated times, to the last bit.
    const auto forcing = read_csv(dir / "forcing.csv");
    REQUIRE(forcing.size() == 12);
    CHECK(forcing[0] == std::vector<std::string>{"t", "f"});
    const Forcing cosine = test::make_forcing("cosine", {{"amplitude", 0.08}});
    for (std::size_t k = 1; k < forcing.size(); ++k) {
        const double t = std::stod(forcing[k][0]);
        CHECK(t == doctest::Approx(M_PI * static_cast<double>(k - 1) / 10).epsilon(1e-15));
        CHECK(std::stod(forcing[k][1]) == cosine(t));
    }

    const json m = json::parse(std::ifstream(dir / "manifest.json"));
    for (const char *p : {"poincare", "tracers", "trajectories", "forcing", "advect_barriers"})
        CHECK_MESSAGE(m["validation"].contains(p), p);
    CHECK(m["validation"]["poincare"]["seeds"] == 6);
    CHECK(m["validation"]["poincare"]["seeds_from_barriers"] == 2);
    CHECK(m["resolved"]["validation"]["trajectories"]["t_end"] == M_PI);
    bool staged = false;
    for (const auto &stage : m["stages"]) staged = staged || stage["stage"] == "validation";
    CHECK(staged);
    fs::remove_all(dir);
}

TEST_CASE("validation products alone integrate no grid") {
    const fs::path dir = fresh_dir("alone");
    json j = json::parse(R"({
      "system":  {"plugin": "duffing"},
      "forcing": {"plugin": "cosine"},
      "grid":    {"x": [-1.5, 1.5], "y": [-1, 1], "n": [400, 400]},
      "time":    {"t0": 0, "t1": 10},
      "validation": {"forcing": {"samples": 5}}
    })");
    j["plugin_paths"] = {test::plugin_dir().string()};
    j["output"] = {{"dir", dir.string()}, {"plots", false}};
    RunOptions options;
    options.quiet = true;
    const RunSummary s = run_experiment(resolve_experiment(parse_experiment(j)), options);
    CHECK(fs::exists(dir / "forcing.csv"));
    CHECK_FALSE(fs::exists(dir / "forcing.png"));
    CHECK_FALSE(fs::exists(dir / "fields.nc"));
    for (const auto &stage : s.manifest["stages"]) CHECK(stage["stage"] != "flow map");
    fs::remove_all(dir);
}
