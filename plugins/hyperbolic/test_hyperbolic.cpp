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
        CHECK(b["repelling"] == 1.0);
        CHECK_FALSE(b.contains("attracting"));
        CHECK(spread(b, 0) < 1e-9);                                // parallel to the stable direction (0, 1)
        CHECK(spread(b, 1) == doctest::Approx(2.0).epsilon(1e-3)); // edge to edge, stopped within min_step
        CHECK(b["length"].get<double>() == doctest::Approx(2.0).epsilon(1e-3));
        CHECK(b["relative_stretching"].get<double>() == doctest::Approx(std::exp(-a * T)).epsilon(1e-9));
        CHECK(b["max_geodesic_deviation"].get<double>() < 1e-12); // straight lines, constant lambda
        // The shortcut against curve advection with the project's flow map: exact for a linear map.
        CHECK(b["advected_length"].get<double>() ==
              doctest::Approx(std::exp(-a * T) * b["length"].get<double>()).epsilon(1e-8));
        CHECK(b["advection_converged"] == 1.0);
        global += b["global_minimum"] == 1.0 ? 1 : 0;
    }
    CHECK(global == 1);
    CHECK(r.barriers[0]["global_minimum"] == 1.0);
    fs::remove_all(r.dir);
}

TEST_CASE("linear saddle, backward time: attracting barriers along the unstable direction") {
    const double a = 0.5, T = 2.0;
    const Run r = run(saddle_experiment(-T), "saddle-backward");
    REQUIRE(r.barriers.size() == 5);
    for (const auto &b : r.barriers) {
        CHECK(b["attracting"] == 1.0);
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
        CHECK(b["advection_converged"] == 1.0);
        // Observed within 5e-4 (interpolation of log lambda1 over h = 0.02 cells and the strainlines' tangent
        // errors); 2e-3 leaves room for other compilers and thread counts.
        CHECK(advected == doctest::Approx(predicted).epsilon(2e-3));
    }
    fs::remove_all(r.dir);
}
