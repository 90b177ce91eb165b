// Experiment files: validation errors name the JSON path and the rule; the
// runner computes only what is asked, writes complete outputs, and its FTLE
// agrees with an independent high-accuracy computation.
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>

#include <doctest/doctest.h>
#include <netcdf.h>
#include <reference_ftle.hpp>
#include <test_support.hpp>

#include <array>
#include <cmath>
#include <fstream>

using namespace geobarrier;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

json minimal_experiment() {
    return json::parse(R"({
      "system":  {"plugin": "duffing", "params": {"alpha": 1, "beta": 1, "delta": 0}},
      "forcing": {"plugin": "cosine",  "params": {"amplitude": 0.08, "omega": 1, "phase": 0}},
      "grid":    {"x": [-1.9, 1.9], "y": [-1.1, 1.1], "n": [21, 13]},
      "time":    {"t0": 0, "t1": 6.283185307179586},
      "products": ["ftle"],
      "output": {"dir": "unused", "plots": false}
    })");
}

std::string config_error(const json &j) {
    try {
        parse_experiment(j);
    } catch (const ConfigError &e) {
        return e.what();
    }
    return "";
}

bool contains(const std::string &text, const std::string &part) { return text.find(part) != std::string::npos; }

// A 39 x 23 block of the issue's example grid (571 x 331 over [-1.9, 1.9] x
// [-1.1, 1.1]) with the same spacing, so the auxiliary offset (relative to the
// spacing) is the example's; it straddles the hyperbolic region around the
// origin, where the FTLE is largest and roughest.
json example_block() {
    json j = minimal_experiment();
    const double dx = 3.8 / 570, dy = 2.2 / 330;
    j["grid"] = {{"x", {-1.9 + 280 * dx, -1.9 + 318 * dx}}, {"y", {-1.1 + 150 * dy, -1.1 + 172 * dy}}, {"n", {39, 23}}};
    j["time"]["t1"] = 8 * M_PI;
    return j;
}

fs::path fresh_dir(const std::string &name) {
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-" + name + "-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    return dir;
}

std::vector<std::string> netcdf_variables(const fs::path &file) {
    int nc = -1, nvars = 0;
    REQUIRE(nc_open(file.c_str(), NC_NOWRITE, &nc) == NC_NOERR);
    REQUIRE(nc_inq_nvars(nc, &nvars) == NC_NOERR);
    std::vector<std::string> names;
    for (int v = 0; v < nvars; ++v) {
        char name[NC_MAX_NAME + 1];
        nc_inq_varname(nc, v, name);
        names.emplace_back(name);
    }
    nc_close(nc);
    return names;
}

std::vector<double> netcdf_read(const fs::path &file, const char *variable, std::size_t count) {
    int nc = -1, var = -1;
    REQUIRE(nc_open(file.c_str(), NC_NOWRITE, &nc) == NC_NOERR);
    REQUIRE(nc_inq_varid(nc, variable, &var) == NC_NOERR);
    std::vector<double> values(count);
    REQUIRE(nc_get_var_double(nc, var, values.data()) == NC_NOERR);
    nc_close(nc);
    return values;
}

ResolvedExperiment resolved_with_test_plugins(const json &j) {
    json with_paths = j;
    with_paths["plugin_paths"] = {test::plugin_dir().string()};
    return resolve_experiment(parse_experiment(with_paths));
}

} // namespace

TEST_CASE("a minimal experiment parses with documented defaults") {
    const Experiment e = parse_experiment(minimal_experiment());
    CHECK(e.grid.nx == 21);
    CHECK(e.grid.ny == 13);
    CHECK(e.t1 == doctest::Approx(2 * M_PI));
    // The standard quality preset: dop853 in fixed steps of at most 0.33 (docs/experiment-format.md).
    CHECK(e.quality == "standard");
    CHECK(e.integrator.method == "dop853");
    CHECK_FALSE(e.integrator.adaptive);
    CHECK(e.integrator.step == 0.33);
    CHECK(e.gradient_method == "auto");
    CHECK(e.wants("ftle"));
    CHECK_FALSE(e.wants("flow_map"));
    CHECK_FALSE(e.plots);
    json no_forcing = minimal_experiment();
    no_forcing.erase("forcing");
    CHECK(parse_experiment(no_forcing).forcing.plugin == "none");
}

TEST_CASE("structural errors name the JSON path, the value and the rule") {
    json j = minimal_experiment();
    j["grdi"] = 1;
    std::string msg = config_error(j);
    CHECK(contains(msg, "/grdi"));
    CHECK(contains(msg, "did you mean \"grid\""));

    j = minimal_experiment();
    j["grid"]["n"] = {1, 13};
    CHECK(contains(config_error(j), "/grid/n/0"));

    j = minimal_experiment();
    j["grid"]["x"] = {1.9, -1.9};
    CHECK(contains(config_error(j), "/grid/x"));
    CHECK(contains(config_error(j), "min < max"));

    j = minimal_experiment();
    j["time"]["t1"] = 0;
    CHECK(contains(config_error(j), "/time/t1"));

    j = minimal_experiment();
    j["integrator"] = {{"method", "dopri"}};
    msg = config_error(j);
    CHECK(contains(msg, "/integrator/method"));
    CHECK(contains(msg, "did you mean \"dopri5\""));

    j = minimal_experiment();
    j["integrator"] = {{"method", "rk4"}};
    CHECK(contains(config_error(j), "\"step\""));

    j = minimal_experiment();
    j["integrator"] = {{"rtol", -1}};
    CHECK(contains(config_error(j), "/integrator/rtol"));

    j = minimal_experiment();
    j["products"] = {"ftl"};
    msg = config_error(j);
    CHECK(contains(msg, "/products/0"));
    CHECK(contains(msg, "did you mean \"ftle\""));

    j = minimal_experiment();
    j["cauchy_green"] = {{"method", "auxiliary-grid"}, {"ofset", 1e-3}};
    CHECK(contains(config_error(j), "/cauchy_green/ofset"));

    j = minimal_experiment();
    j["system"] = {{"params", json::object()}};
    CHECK(contains(config_error(j), "missing required key \"plugin\""));

    j = minimal_experiment();
    j["products"] = json::array();
    CHECK(contains(config_error(j), "nothing to compute"));
}

TEST_CASE("plugin errors name the JSON path") {
    json j = minimal_experiment();
    j["forcing"]["params"]["amplitud"] = 0.1;
    try {
        resolved_with_test_plugins(j);
        FAIL("expected a ConfigError");
    } catch (const ConfigError &e) {
        CHECK(e.json_path() == "/forcing/params/amplitud");
        CHECK(contains(e.what(), "did you mean \"amplitude\""));
    }
    j = minimal_experiment();
    j["extractors"] = {{{"plugin", "no-such-extractor"}}};
    try {
        resolved_with_test_plugins(j);
        FAIL("expected a ConfigError");
    } catch (const ConfigError &e) {
        CHECK(e.json_path() == "/extractors/0/plugin");
    }
}

TEST_CASE("malformed JSON is reported with line and column") {
    const fs::path dir = fresh_dir("badjson");
    fs::create_directories(dir);
    const fs::path file = dir / "bad.json";
    std::ofstream(file) << "{\n  \"system\": {\"plugin\": \"duffing\"},\n  \"grid\": [1, 2,,]\n}\n";
    try {
        load_experiment(file);
        FAIL("expected a ConfigError");
    } catch (const ConfigError &e) {
        CHECK(contains(e.what(), file.string() + ":3:"));
    }
    fs::remove_all(dir);
}

TEST_CASE("the runner computes only what is asked") {
    json j = minimal_experiment();
    j["products"] = {"flow_map"};
    const ResolvedExperiment r = resolved_with_test_plugins(j);
    CHECK_FALSE(r.need_cauchy_green);
    CHECK(r.need_positions);
    const fs::path dir = fresh_dir("flowmap-only");
    RunOptions options;
    options.output_dir = dir;
    options.quiet = true;
    const RunSummary s = run_experiment(r, options);
    CHECK(s.manifest["gradient_method"] == "none");
    // Positions only: one trajectory per grid point, two state components.
    CHECK(s.manifest["integrator_stats"]["trajectories"] == 21 * 13);
    const auto vars = netcdf_variables(dir / "fields.nc");
    CHECK(std::find(vars.begin(), vars.end(), "flow_x") != vars.end());
    CHECK(std::find(vars.begin(), vars.end(), "ftle") == vars.end());
    CHECK_FALSE(fs::exists(dir / "ftle.png"));
    CHECK(fs::exists(dir / "manifest.json"));
    fs::remove_all(dir);
}

TEST_CASE("a full run writes fields.nc, ftle.png and a manifest with statistics") {
    json j = minimal_experiment();
    j["products"] = {"ftle", "eigenvalues", "eigenvectors"};
    j["output"]["plots"] = true;
    const ResolvedExperiment r = resolved_with_test_plugins(j);
    CHECK(r.gradient == GradientMethod::variational); // duffing has a Jacobian: the default is exact DF
    const fs::path dir = fresh_dir("full");
    RunOptions options;
    options.output_dir = dir;
    options.quiet = true;
    const RunSummary s = run_experiment(r, options);
    for (const char *f : {"fields.nc", "ftle.png", "manifest.json"}) CHECK_MESSAGE(fs::exists(dir / f), f);
    const auto vars = netcdf_variables(dir / "fields.nc");
    for (const char *v : {"x", "y", "ftle", "lambda1", "lambda2", "xi1_x", "xi1_y", "xi2_x", "xi2_y", "mask"})
        CHECK_MESSAGE(std::find(vars.begin(), vars.end(), v) != vars.end(), v);
    CHECK(std::find(vars.begin(), vars.end(), "flow_x") == vars.end());
    const json m = json::parse(std::ifstream(dir / "manifest.json"));
    CHECK(m["integrator_stats"]["steps"].get<long long>() > 0);
    CHECK(m["integrator_stats"]["rhs_evaluations"].get<long long>() > 0);
    CHECK(m["integrator_stats"]["masked"] == 0);
    CHECK(m["resolved"]["cauchy_green"]["method"] == "variational");
    CHECK(m["resolved"]["forcing"]["params"]["amplitude"] == 0.08);
    CHECK(m["stages"].size() >= 2); // the flow map (with the Cauchy-Green fields, tile by tile) and the output
    CHECK(m["stages"][0]["stage"] == "flow map");
    CHECK(m["tiles"]["count"] == 1);       // 21 x 13 points: one tile
    CHECK(m["tiles"]["kept"].size() == 7); // ftle, eigenvalues, eigenvectors
    CHECK(m["plugins"][0]["name"] == "duffing");
    // Conservative system: det DF = 1, so lambda1 * lambda2 = 1 (DESIGN §4: lambda1 = det^2 / lambda2).
    const auto l1 = netcdf_read(dir / "fields.nc", "lambda1", 21 * 13);
    const auto l2 = netcdf_read(dir / "fields.nc", "lambda2", 21 * 13);
    double worst = 0;
    for (std::size_t k = 0; k < l1.size(); ++k) worst = std::max(worst, std::abs(l1[k] * l2[k] - 1.0));
    CHECK(worst < 1e-6);
    fs::remove_all(dir);
}

TEST_CASE("an extractor plugin gets its fields, advects with the host and reports barriers") {
    json j = minimal_experiment();
    j["extractors"] = {{{"plugin", "probe"}, {"params", {{"closed", true}}}}};
    j["plugin_paths"] = {test::plugin_dir().string(), test::test_plugin_dir().string()};
    const ResolvedExperiment r = resolve_experiment(parse_experiment(j));
    CHECK(r.need_cauchy_green); // the extractor needs ftle
    const fs::path dir = fresh_dir("extractor");
    RunOptions options;
    options.output_dir = dir;
    options.quiet = true;
    run_experiment(r, options);
    const json b = json::parse(std::ifstream(dir / "barriers.json"));
    REQUIRE(b["barriers"].size() == 1);
    const json &barrier = b["barriers"][0];
    CHECK(barrier["kind"] == "hyperbolic");
    CHECK(barrier["closed"] == true);
    CHECK(barrier["extractor"] == "probe");
    REQUIRE(barrier["points"].size() == 2);
    // The host advected with the experiment's (variational) gradient: conservative, so det DF = 1.
    CHECK(barrier["det_gradient"].get<double>() == doctest::Approx(1.0).epsilon(1e-6));
    CHECK(barrier["plots"] == 0.0);
    // The image is the flow map of the reported point.
    const double x0 = barrier["points"][0][0], y0 = barrier["points"][0][1];
    const System duffing = test::make_system("duffing");
    const Forcing cosine = test::make_forcing("cosine", {{"amplitude", 0.08}});
    const FlowMap a = flow_map_at_points({{&duffing, &cosine}, 0.0, 2 * M_PI, r.experiment.integrator}, {x0}, {y0});
    CHECK(barrier["points"][1][0].get<double>() == doctest::Approx(a.flow_x[0]).epsilon(1e-7));
    CHECK(barrier["points"][1][1].get<double>() == doctest::Approx(a.flow_y[0]).epsilon(1e-7));
    fs::remove_all(dir);
}

TEST_CASE("FTLE of the paper's first example agrees with an independent rkf78 1e-12 computation") {
    using geobarrier::test::ftle_error_against_reference;
    // The defaults (variational equations, the standard preset: dop853 in fixed steps of at most 0.33). Measured
    // here: max 4.1e-5, mean 4.6e-7 (against the exact field, interior max 0.0059 / 0.0085 / 0.022 and mean 8.4e-7
    // at N = 700 / 1000 / 1400; the issue's bar is interior max 0.05, mean 1e-4).
    const auto defaults = ftle_error_against_reference(example_block(), json::object());
    CHECK(defaults.max < 2e-4);
    CHECK(defaults.mean < 2.5e-6);
    // The auxiliary grid at offset 1e-4 of the spacing with (nearly) exact
    // integration isolates the finite-difference error floor: at the most
    // stretched points a centred difference over d = 6.7e-7 is no longer
    // linear (|DF| d ~ 1): an error of a few hundredths at a few points.
    const auto floor = ftle_error_against_reference(
        example_block(), {{"integrator", {{"method", "rkf78"}, {"rtol", 1e-12}, {"atol", 1e-12}}},
                          {"cauchy_green", {{"method", "auxiliary-grid"}, {"offset", 1e-4}}}});
    CHECK(floor.mean < 1e-3);
    CHECK(floor.max < 0.1);
}

// The experiment layer maps what the flow-map engine refuses to the setting's JSON path when it resolves an
// experiment, before anything runs: an Experiment built in code, past the parser's own checks.
TEST_CASE("resolving refuses the engine's bad settings at their JSON paths") {
    Experiment e = parse_experiment(minimal_experiment());
    e.integrator.rtol = 1.0;
    try {
        resolve_experiment(e);
        FAIL("rtol = 1 resolved");
    } catch (const ConfigError &c) {
        CHECK(c.json_path() == "/integrator/rtol");
        CHECK(std::string(c.what()) == "/integrator/rtol: 1.000000 must be between 0 and 1 (exclusive)");
    }
    e = parse_experiment(minimal_experiment());
    e.integrator.engine = "warp";
    CHECK_THROWS_WITH_AS(resolve_experiment(e),
                         "/integrator/engine: unknown engine \"warp\"; expected lockstep or odeint", ConfigError);
}
