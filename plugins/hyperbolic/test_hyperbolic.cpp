// The hyperbolic extractor through the runner: on the linear saddle x' = a x, y' = -a y the strainlines are the
// lines parallel to the stable direction (forward time) or the unstable one (backward time) and q = exp(-a|T|)
// exactly, by both routes; the strain_deviation product; and the shortcut l(gamma_t1) = int sqrt(lambda1) ds
// against curve advection on a smooth nonlinear case.
#include <geobarrier/experiment.hpp>

#include <test_support.hpp>

#include <doctest/doctest.h>
#include <netcdf.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <unistd.h>

using namespace geobarrier;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

// Seeds every 8 grid cells (not the default lattice in state units, which on this coarse 41 x 41 grid puts a seed
// in every cell): the scenarios below count the columns of that lattice.
json saddle_experiment(double t1, json params = json::object()) {
    if (!params.contains("seed_spacing")) params["seed_spacing"] = 8;
    json j = json::parse(R"({
      "system":  {"plugin": "linear-saddle", "params": {"a": 0.5}},
      "grid":    {"x": [-1, 1], "y": [-1, 1], "n": [41, 41]},
      "time":    {"t0": 0, "t1": 2},
      "integrator": {"rtol": 1e-10, "atol": 1e-12},
      "products": ["ftle"],
      "output": {"dir": "unused", "plots": false}
    })");
    j["time"]["t1"] = t1;
    j["extractors"] = {{{"plugin", "hyperbolic"}, {"params", params}}};
    j["plugin_paths"] = {test::plugin_dir().string()};
    return j;
}

struct Run {
    json barriers;
    json manifest;
    fs::path dir;
};

Run run(const json &j, const std::string &name) {
    const ResolvedExperiment r = resolve_experiment(parse_experiment(j));
    Run out;
    out.dir = fs::temp_directory_path() / ("geobarrier-test-hyperbolic-" + name + "-" + std::to_string(::getpid()));
    fs::remove_all(out.dir);
    RunOptions options;
    options.output_dir = out.dir;
    options.quiet = true;
    out.manifest = run_experiment(r, options).manifest;
    if (fs::exists(out.dir / "barriers.json"))
        out.barriers = json::parse(std::ifstream(out.dir / "barriers.json"))["barriers"];
    return out;
}

// Largest spread of one coordinate (0 = x, 1 = y) over a barrier's points.
double spread(const json &barrier, int coordinate) {
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (const auto &p : barrier["points"]) {
        lo = std::min(lo, p[coordinate].get<double>());
        hi = std::max(hi, p[coordinate].get<double>());
    }
    return hi - lo;
}

} // namespace

TEST_CASE("linear saddle, forward time: repelling barriers along the stable direction, q = exp(-a T)") {
    const double a = 0.5, T = 2.0;
    const Run r = run(saddle_experiment(T), "saddle-forward");
    // Seeds every 8 cells: 5 columns of strainlines, each spanning the box; neighbours (within 1/50 of the
    // diagonal) are the seeds of the same column, which the thinning merges.
    REQUIRE(r.barriers.size() == 5);
    int global = 0;
    for (const auto &b : r.barriers) {
        CHECK(b["kind"] == "hyperbolic");
        CHECK(b["closed"] == false);
        CHECK(b["repelling"] == true);
        CHECK_FALSE(b.contains("attracting"));
        CHECK(spread(b, 0) < 1e-9);                                // parallel to the stable direction (0, 1)
        CHECK(spread(b, 1) == doctest::Approx(2.0).epsilon(1e-3)); // edge to edge, stopped within min_step
        CHECK(b["length"].get<double>() == doctest::Approx(2.0).epsilon(1e-3));
        CHECK(b["relative_stretching"].get<double>() == doctest::Approx(std::exp(-a * T)).epsilon(1e-9));
        CHECK(b["max_geodesic_deviation"].get<double>() < 1e-12); // straight lines, constant lambda
        // The shortcut against curve advection with the project's flow map: exact for a linear map.
        CHECK(b["advected_length"].get<double>() ==
              doctest::Approx(std::exp(-a * T) * b["length"].get<double>()).epsilon(1e-8));
        CHECK(b["advection_converged"] == true);
        global += b["global_minimum"] == true ? 1 : 0;
    }
    CHECK(global == 1);
    CHECK(r.barriers[0]["global_minimum"] == true);
    fs::remove_all(r.dir);
}

TEST_CASE("linear saddle, backward time: attracting barriers along the unstable direction") {
    const double a = 0.5, T = 2.0;
    const Run r = run(saddle_experiment(-T), "saddle-backward");
    REQUIRE(r.barriers.size() == 5);
    for (const auto &b : r.barriers) {
        CHECK(b["attracting"] == true);
        CHECK(spread(b, 1) < 1e-9); // parallel to the unstable direction (1, 0)
        CHECK(b["relative_stretching"].get<double>() == doctest::Approx(std::exp(-a * T)).epsilon(1e-9));
    }
    fs::remove_all(r.dir);
}

TEST_CASE("linear saddle, opposite-time route: advected stretchlines give the same barriers and q") {
    const double a = 0.5, T = 2.0;
    const Run r = run(saddle_experiment(T, {{"route", "opposite-time"}}), "saddle-opposite");
    REQUIRE(!r.barriers.empty());
    for (const auto &b : r.barriers) {
        CHECK(spread(b, 0) < 1e-7); // images of vertical stretchlines at t1: vertical at t0
        // q = l(stretchline at t1) / l(its image at t0), both measured, no shortcut: exact up to the integrator.
        CHECK(b["relative_stretching"].get<double>() == doctest::Approx(std::exp(-a * T)).epsilon(1e-7));
        CHECK(b["advected_length"].get<double>() == doctest::Approx(b["stretched_length"].get<double>()).epsilon(1e-7));
    }
    fs::remove_all(r.dir);
}

TEST_CASE("the default seed lattice is fixed in state units: the same barriers on a grid twice as fine") {
    // seed_distance 0.25 on the box [-1, 1]^2: columns of strainlines at x = -0.875, -0.625, ..., 0.875 whatever
    // the grid, so the extraction's work does not grow with it (docs/extractors.md, the seeds).
    const double a = 0.5, T = 2.0;
    for (int n : {41, 81}) {
        json j = saddle_experiment(T, {{"seed_distance", 0.25}, {"seed_spacing", 0}});
        j["grid"]["n"] = {n, n};
        const Run r = run(j, "lattice-" + std::to_string(n));
        REQUIRE(r.barriers.size() == 8);
        std::vector<double> xs;
        for (const auto &b : r.barriers) {
            CHECK(spread(b, 0) < 1e-9);
            CHECK(b["relative_stretching"].get<double>() == doctest::Approx(std::exp(-a * T)).epsilon(1e-9));
            xs.push_back(b["points"][0][0].get<double>());
        }
        std::sort(xs.begin(), xs.end());
        for (std::size_t k = 0; k < xs.size(); ++k) CHECK(xs[k] == doctest::Approx(-0.875 + 0.25 * k).epsilon(1e-12));
        fs::remove_all(r.dir);
    }
}

TEST_CASE("strain_deviation is a field product, computed only when asked for") {
    json j = saddle_experiment(2.0);
    j.erase("extractors");
    j["products"] = {"ftle", "strain_deviation"};
    Run r = run(j, "product");
    bool timed = false;
    for (const auto &s : r.manifest["stages"]) timed = timed || s["stage"] == "strain deviation";
    CHECK(timed);
    int nc = 0, var = 0;
    REQUIRE(nc_open((r.dir / "fields.nc").c_str(), NC_NOWRITE, &nc) == NC_NOERR);
    REQUIRE(nc_inq_varid(nc, "strain_deviation", &var) == NC_NOERR);
    std::vector<double> values(41 * 41);
    REQUIRE(nc_get_var_double(nc, var, values.data()) == NC_NOERR);
    nc_close(nc);
    // Straight strainlines and constant eigenvalues: d_g = 0 up to rounding.
    for (double v : values) CHECK(std::abs(v) < 1e-12);
    fs::remove_all(r.dir);

    j["products"] = {"ftle"};
    r = run(j, "no-product");
    for (const auto &s : r.manifest["stages"]) CHECK(s["stage"] != "strain deviation");
    fs::remove_all(r.dir);
}

TEST_CASE("the shortcut int sqrt(lambda1) ds matches the advected length on a smooth nonlinear flow") {
    // Undamped Duffing over a short horizon (T = 2): lambda2 / lambda1 stays below e^4, so the small tangent errors
    // of grid strainlines (angle theta) add only lambda2 theta^2 to lambda1 in the stretching of the true image.
    json j = json::parse(R"({
      "system":  {"plugin": "duffing", "params": {"delta": 0}},
      "forcing": {"plugin": "cosine", "params": {"amplitude": 0.08}},
      "grid":    {"x": [-1.5, 1.5], "y": [-1, 1], "n": [151, 101]},
      "time":    {"t0": 0, "t1": 2},
      "integrator": {"rtol": 1e-10, "atol": 1e-12},
      "products": ["ftle"],
      "output": {"dir": "unused", "plots": false}
    })");
    // Seeds every 8 cells, the lattice the tolerance below was measured with.
    j["extractors"] = {
        {{"plugin", "hyperbolic"}, {"params", {{"max_deviation", 1.0}, {"max_barriers", 5}, {"seed_spacing", 8}}}}};
    j["plugin_paths"] = {test::plugin_dir().string()};
    const Run r = run(j, "shortcut");
    REQUIRE(!r.barriers.empty());
    for (const auto &b : r.barriers) {
        const double predicted = b["stretched_length"], advected = b["advected_length"];
        MESSAGE("length " << b["length"].get<double>() << ": int sqrt(lambda1) ds = " << predicted << ", advected "
                          << advected << ", ratio " << advected / predicted);
        CHECK(b["advection_converged"] == true);
        // Observed within 5e-4 (interpolation of log lambda1 over h = 0.02 cells and the strainlines' tangent
        // errors); 2e-3 leaves room for other compilers and thread counts.
        CHECK(advected == doctest::Approx(predicted).epsilon(2e-3));
    }
    fs::remove_all(r.dir);
}

namespace {

// 600 points evenly spaced in arc length along the homoclinic loop of H = y^2/2 - x^2/2 - a x^3/3 + x^4/4 = 0 that
// reaches x = x_end (the saddle at the origin is its other end): y = +-sqrt(x^2 + 2a x^3/3 - x^4/2).
std::vector<std::pair<double, double>> homoclinic_loop(double a, double x_end) {
    std::vector<std::pair<double, double>> upper;
    for (int k = 0; k <= 4000; ++k) {
        const double x = x_end * (1.0 - std::cos(M_PI * k / 4000.0)) / 2.0;
        upper.emplace_back(x, std::sqrt(std::max(x * x + 2.0 * a * x * x * x / 3.0 - x * x * x * x / 2.0, 0.0)));
    }
    std::vector<std::pair<double, double>> loop = upper;
    for (auto it = upper.rbegin(); it != upper.rend(); ++it) loop.emplace_back(it->first, -it->second);
    std::vector<double> s(1, 0.0);
    for (std::size_t k = 1; k < loop.size(); ++k)
        s.push_back(s.back() + std::hypot(loop[k].first - loop[k - 1].first, loop[k].second - loop[k - 1].second));
    std::vector<std::pair<double, double>> out;
    std::size_t j = 0;
    for (int k = 0; k < 600; ++k) {
        const double u = s.back() * k / 599.0;
        while (j + 2 < s.size() && s[j + 1] < u) ++j;
        const double w = s[j + 1] > s[j] ? (u - s[j]) / (s[j + 1] - s[j]) : 0.0;
        out.emplace_back(loop[j].first + w * (loop[j + 1].first - loop[j].first),
                         loop[j].second + w * (loop[j + 1].second - loop[j].second));
    }
    return out;
}

// The fraction of the loop's samples within `distance` of some barrier (point-to-segment distances).
double loop_coverage(const json &barriers, const std::vector<std::pair<double, double>> &loop, double distance) {
    std::size_t near = 0;
    for (const auto &[px, py] : loop) {
        bool hit = false;
        for (const auto &b : barriers) {
            const auto &pts = b["points"];
            for (std::size_t k = 0; k + 1 < pts.size() && !hit; ++k) {
                const double ax = pts[k][0], ay = pts[k][1], bx = pts[k + 1][0], by = pts[k + 1][1];
                const double ux = bx - ax, uy = by - ay, uu = ux * ux + uy * uy;
                const double t = uu > 0 ? std::clamp(((px - ax) * ux + (py - ay) * uy) / uu, 0.0, 1.0) : 0.0;
                hit = std::hypot(px - ax - t * ux, py - ay - t * uy) <= distance;
            }
            if (hit) break;
        }
        near += hit ? 1 : 0;
    }
    return static_cast<double>(near) / static_cast<double>(loop.size());
}

} // namespace

TEST_CASE("unforced double wells, forward 8 pi: repelling barriers cover both homoclinic loops") {
    // x'' = x + a x^2 - x^3: a = 0 is the unforced Duffing oscillator (equal loops), a = 0.5 makes the loops unequal
    // (x from -1.120 to 0 and from 0 to 1.786). Both loops are the saddle's stable manifold: repelling barriers. The
    // selection must report both, each branch included (the branch leaving the saddle stretches more than the one
    // entering it, so a rule comparing pieces of one curve by q keeps only the entering branch: 59% of each loop).
    for (const double a : {0.0, 0.5}) {
        const double x_lo = a == 0.0 ? -1.8 : -1.5, x_hi = a == 0.0 ? 1.8 : 2.1;
        json j = {{"system", {{"plugin", "double-well"}, {"params", {{"a", a}}}}},
                  {"grid", {{"x", {x_lo, x_hi}}, {"y", {-1.2, 1.2}}, {"n", {361, 241}}}},
                  {"time", {{"t0", 0.0}, {"t1", 8 * M_PI}}},
                  {"products", {"ftle"}},
                  {"extractors", {{{"plugin", "hyperbolic"}}}},
                  {"plugin_paths", {test::plugin_dir().string(), test::test_plugin_dir().string()}},
                  {"output", {{"plots", false}}}};
        const Run r = run(j, "double-well");
        REQUIRE(!r.barriers.empty());
        const double root = std::sqrt(4.0 * a * a / 9.0 + 2.0);
        json loops = json::array();
        for (const double x_end : {2.0 * a / 3.0 - root, 2.0 * a / 3.0 + root}) {
            const std::vector<std::pair<double, double>> loop = homoclinic_loop(a, x_end);
            const double covered = loop_coverage(r.barriers, loop, 0.02);
            MESSAGE("a = " << a << ", loop to x = " << x_end << ": " << 100 * covered << "% within 0.02 of "
                           << r.barriers.size() << " barriers");
            CHECK(covered >= 0.9);
            json points = json::array();
            for (const auto &[x, y] : loop) points.push_back({x, y});
            loops.push_back({{"points", points}});
        }
        // Precision and wholeness: every barrier lies on H = 0 (the level sets of H around it, shaped by shear, are
        // candidates at most), and each loop is at most two barriers (pieces joined end to end).
        std::vector<int> pieces_on(2, 0);
        for (const json &b : r.barriers) {
            std::vector<std::pair<double, double>> points;
            for (const auto &p : b["points"]) points.emplace_back(p[0].get<double>(), p[1].get<double>());
            const double on = loop_coverage(loops, points, 0.02);
            INFO("barrier of rank " << b["rank"] << ", q " << b["relative_stretching"]);
            CHECK(on >= 0.95);
            for (int l = 0; l < 2; ++l)
                pieces_on[l] += loop_coverage(json::array({loops[l]}), points, 0.02) >= 0.5 ? 1 : 0;
        }
        CHECK(pieces_on[0] <= 2);
        CHECK(pieces_on[1] <= 2);
        // Ranked by q, the global minimum first and flagged, every flag a JSON boolean, and how each was selected.
        int global = 0;
        double previous = 0.0;
        for (std::size_t k = 0; k < r.barriers.size(); ++k) {
            const json &b = r.barriers[k];
            CHECK(b["repelling"] == true);
            CHECK(b["global_minimum"].is_boolean());
            global += b["global_minimum"] == true ? 1 : 0;
            CHECK(b["rank"] == static_cast<double>(k + 1));
            CHECK(b["relative_stretching"].get<double>() >= previous);
            previous = b["relative_stretching"];
            CHECK((b["selection"] == "local-minimum" || b["selection"] == "remainder" || b["selection"] == "joined"));
            CHECK((b["selection"] == "joined") == (b["pieces"].get<double>() > 1));
            CHECK(2 * b["probes_with_smaller_q"].get<double>() <= b["neighbour_probes"].get<double>());
            CHECK_FALSE(b.contains("extraction_seconds"));
            // sqrt(lambda2 / lambda1) ~ 1/q^2 here (> 1e5 on the loops, with q ~ 3e-3): an advected length would
            // measure the polyline's tangent error amplified that much, so none is given, and the condition says why.
            REQUIRE(b.contains("stretching_condition"));
            CHECK(b["stretching_condition"].get<double>() > 1e5);
            CHECK_FALSE(b.contains("advected_length"));
        }
        CHECK(global == 1);
        CHECK(r.barriers[0]["global_minimum"] == true);
        fs::remove_all(r.dir);
    }
}

TEST_CASE("linear saddle, backward time with bounds: exit-time barriers on the unstable manifold; none without") {
    // Backward in time y grows as e^{a|t|}: a point leaves |y| <= 1.2 after |t| = 2 ln(1.2 / |y0|), and the x axis
    // (the unstable manifold) never. Over |T| = 8 the grid's row y = 0 stays and the rows next to it leave at 6.4:
    // a jump of 1.6, above exit_jump 0.1 of |T|, so the exit time's jumps lie on the manifold (the exit time
    // diverges logarithmically there: the jumps 2 ln 2 between rows y and 2y run on to a few cells from it).
    json j = saddle_experiment(-8.0);
    j["bounds"] = {{"x", {-3.0, 3.0}}, {"y", {-1.2, 1.2}}};
    const Run r = run(j, "saddle-exit");
    int exit_time = 0;
    for (const auto &b : r.barriers) {
        if (b["selection"] != "exit-time") continue;
        ++exit_time;
        CHECK(spread(b, 1) < 1e-9); // along the unstable direction (1, 0)
        CHECK(std::fabs(b["points"][0][1].get<double>()) < 0.2);
    }
    CHECK(exit_time >= 1);
    fs::remove_all(r.dir);
    // The same run without bounds: no exit time, no exit-time barrier, the barriers of exit_jump 0.
    json closed = saddle_experiment(-8.0), off = saddle_experiment(-8.0, {{"exit_jump", 0.0}});
    const Run a = run(closed, "saddle-no-bounds"), b = run(off, "saddle-exit-off");
    CHECK(a.barriers == b.barriers);
    for (const auto &barrier : a.barriers) CHECK(barrier["selection"] != "exit-time");
    fs::remove_all(a.dir);
    fs::remove_all(b.dir);
}
