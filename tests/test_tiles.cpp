// Memory tiles (tiles.hpp): the flow map and Cauchy–Green fields computed block of rows by block of rows give the
// numbers of the untiled computation bit for bit, keep only the planned fields, count progress across tiles, and
// the tiled memory estimate is what the up-front refusal uses. Also the flow map at arbitrary points
// (flow_map_at_points), which the extractors' advection shares with the grid.
#include "engine/tiles.hpp"
#include "experiment/resources.hpp"

#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/flow_map.hpp>

#include <test_support.hpp>

#include <doctest/doctest.h>

#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <vector>

using namespace geobarrier;
using geobarrier::test::make_forcing;
using geobarrier::test::make_system;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

const double pi = std::acos(-1.0);

// Same bits, NaN included (== would call two NaNs different and +0 == -0 equal).
template <class T> bool same_bits(const std::vector<T> &a, const std::vector<T> &b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// The forced Duffing oscillator of the paper's first example on a grid whose rows are not whole batches (nx = 23
// with 8-lane batches), so tiles must be aligned to batches to reproduce the untiled numbers.
Grid odd_grid() {
    Grid g;
    g.x_min = -1.8;
    g.x_max = 1.8;
    g.y_min = -1.2;
    g.y_max = 1.2;
    g.nx = 23;
    g.ny = 17;
    return g;
}

IntegratorSettings adaptive(std::size_t batch) {
    IntegratorSettings s;
    s.method = "dopri5";
    s.rtol = 1e-6;
    s.atol = 1e-6;
    s.batch = batch;
    return s;
}

} // namespace

TEST_CASE("tiles: points_per_batch, the request's lanes per batch over its lanes per point, rounded up") {
    FlowMapRequest r; // no system is needed: points_per_batch reads the settings, gradient and want_positions
    r.settings.batch = 64;
    r.gradient = GradientMethod::none;
    CHECK(points_per_batch(r) == 64);
    r.gradient = GradientMethod::variational;
    CHECK(points_per_batch(r) == 64);
    r.gradient = GradientMethod::auxiliary_grid; // 4 neighbours per point
    CHECK(points_per_batch(r) == 16);
    r.want_positions = true; // and the centre: ceil(64 / 5)
    CHECK(points_per_batch(r) == 13);
    r.settings.method = "rosenbrock4"; // one trajectory at a time: the batch is one point whatever its lanes
    CHECK(points_per_batch(r) == 1);
    r.gradient = GradientMethod::none;
    CHECK(points_per_batch(r) == 1);
}

TEST_CASE("tiles: the flow map and Cauchy-Green fields tile by tile are the untiled numbers, bit for bit") {
    const System duffing = make_system("duffing");
    const Forcing cosine = make_forcing("cosine", {{"amplitude", 0.08}});
    const Dynamics dyn{&duffing, &cosine};
    const Grid grid = odd_grid();
    const double t1 = 4 * pi;
    for (const GradientMethod gradient : {GradientMethod::variational, GradientMethod::auxiliary_grid}) {
        for (const bool positions : {false, true}) {
            const std::string method = to_string(gradient);
            CAPTURE(method);
            CAPTURE(positions);
            const IntegratorSettings settings = adaptive(8);
            const FlowMap whole = compute_grid_flow_map(
                with_grid_offset({dyn, 0.0, t1, settings, gradient, positions}, grid, 1e-3), grid);
            const CauchyGreenField exact =
                cauchy_green_field(grid, whole.dF, whole.mask, t1, whole.dF_exponent, whole.log_det);

            FieldPlan plan;
            plan.cauchy_green = true;
            plan.gradient = gradient;
            plan.aux_offset = 1e-3;
            plan.positions = positions;
            plan.keep = cauchy_green_variables();
            for (const std::size_t tile_points : {std::size_t(1), std::size_t(50), std::size_t(1) << 20}) {
                CAPTURE(tile_points);
                plan.tile_points = tile_points;
                const std::size_t rows = tile_rows(grid, settings, plan);
                // Whole batches per tile: 8 points per batch (variational) or 2 (auxiliary grid, 4 or 5 lanes per
                // point, batches rounded up to whole points), and nx = 23 is prime to both.
                if (rows < grid.ny)
                    CHECK((rows * grid.nx) % points_per_batch({dyn, 0.0, t1, settings, gradient, positions}) == 0);
                const GridFields tiled = compute_grid_fields(dyn, grid, 0.0, t1, settings, std::nullopt, plan);
                CHECK(tiled.rows_per_tile == rows);
                CHECK(tiled.tiles == (grid.ny + rows - 1) / rows);
                if (tile_points == 1) CHECK(tiled.tiles > 1);
                CHECK(same_bits(tiled.cg.ftle, exact.ftle));
                CHECK(same_bits(tiled.cg.lambda1, exact.lambda1));
                CHECK(same_bits(tiled.cg.lambda2, exact.lambda2));
                CHECK(same_bits(tiled.cg.xi1_x, exact.xi1_x));
                CHECK(same_bits(tiled.cg.xi1_y, exact.xi1_y));
                CHECK(same_bits(tiled.cg.xi2_x, exact.xi2_x));
                CHECK(same_bits(tiled.cg.xi2_y, exact.xi2_y));
                CHECK(same_bits(tiled.cg.mask, exact.mask));
                CHECK(same_bits(tiled.flow.mask, whole.mask));
                CHECK(tiled.cg.degenerate_count == exact.degenerate_count);
                CHECK(same_bits(tiled.flow.flow_x, whole.flow_x));
                CHECK(same_bits(tiled.flow.flow_y, whole.flow_y));
                CHECK(tiled.flow.dF.empty()); // the gradient lives only while its tile is computed
                // The same batches, so the same work.
                CHECK(tiled.flow.stats.steps == whole.stats.steps);
                CHECK(tiled.flow.stats.rhs_evaluations == whole.stats.rhs_evaluations);
                CHECK(tiled.flow.stats.batches == whole.stats.batches);
            }
        }
    }
}

TEST_CASE("tiles: only the planned fields are kept, and progress counts grid points across tiles") {
    const System duffing = make_system("duffing");
    const Forcing cosine = make_forcing("cosine", {{"amplitude", 0.08}});
    const Dynamics dyn{&duffing, &cosine};
    const Grid grid = odd_grid();
    FieldPlan plan;
    plan.cauchy_green = true;
    plan.gradient = GradientMethod::variational;
    plan.keep = {"ftle"};
    plan.tile_points = 40;
    std::mutex m;
    std::size_t calls = 0, largest = 0;
    bool total_is_grid = true;
    const GridFields f = compute_grid_fields(dyn, grid, 0.0, 2 * pi, adaptive(8), std::nullopt, plan,
                                             [&](std::size_t done, std::size_t total) {
                                                 std::lock_guard<std::mutex> lock(m);
                                                 ++calls;
                                                 largest = std::max(largest, done);
                                                 total_is_grid = total_is_grid && total == grid.size();
                                             });
    CHECK(f.tiles > 2);
    CHECK(calls > f.tiles);
    CHECK(total_is_grid);
    CHECK(largest == grid.size());
    CHECK(f.cg.ftle.size() == grid.size());
    CHECK(f.cg.mask.size() == grid.size());
    for (const auto *v : {&f.cg.lambda1, &f.cg.lambda2, &f.cg.xi1_x, &f.cg.xi1_y, &f.cg.xi2_x, &f.cg.xi2_y})
        CHECK(v->empty());
    CHECK(f.flow.flow_x.empty());
    // Whole grid masked (x'' = x + x^3 + 1e6 cos t blows up everywhere): an error naming the reason, as untiled.
    const System blowing_up = make_system("duffing", {{"alpha", 1.0}, {"beta", -1.0}, {"delta", 0.0}});
    const Forcing huge = make_forcing("cosine", {{"amplitude", 1e6}});
    CHECK_THROWS_WITH_AS(
        compute_grid_fields(Dynamics{&blowing_up, &huge}, grid, 0.0, 20.0, adaptive(8), std::nullopt, plan),
        doctest::Contains("every one of the 391 grid points was masked"), NumericalError);
}

TEST_CASE("tiles: the plan keeps what products, extractors and pictures read; the estimate is the tiled one") {
    json j = json::parse(R"({"system": {"plugin": "duffing"}, "forcing": {"plugin": "cosine"},
                             "grid": {"x": [-1.8, 1.8], "y": [-1.2, 1.2], "n": [4000, 4000]},
                             "time": {"t0": 0, "t1": 25.132741228718345}, "products": ["ftle"],
                             "output": {"plots": false}})");
    FieldPlan plan = plan_fields(resolve_experiment(parse_experiment(j)));
    CHECK(plan.cauchy_green);
    CHECK(plan.keep == std::vector<std::string>{"ftle"});
    CHECK_FALSE(plan.positions);
    CHECK_FALSE(plan.plot);
    CHECK_FALSE(plan.derived);
    // The issue's memory bound: a 4000 x 4000 grid of FTLE in under 2 GiB, by the estimate (high side) too.
    const std::uint64_t need = estimate_run_memory(parse_experiment(j).grid, IntegratorSettings{}, plan);
    MESSAGE("4000 x 4000 FTLE estimate: " << format_bytes(need));
    CHECK(need < (2ull << 30));

    j["products"] = {"eigenvectors", "flow_map"};
    plan = plan_fields(resolve_experiment(parse_experiment(j)));
    CHECK(plan.keep == std::vector<std::string>{"xi1_x", "xi1_y", "xi2_x", "xi2_y"});
    CHECK(plan.positions);
    j["products"] = {"eigenvalues"};
    j["output"]["plots"] = true;
    plan = plan_fields(resolve_experiment(parse_experiment(j)));
    CHECK(plan.keep == std::vector<std::string>{"ftle", "lambda1", "lambda2"});
    CHECK(plan.plot);
    j["products"] = {"strain_deviation"};
    plan = plan_fields(resolve_experiment(parse_experiment(j)));
    CHECK(plan.keep == cauchy_green_variables()); // a derived field differentiates the whole eigen-fields
    CHECK(plan.derived);
    j["products"] = {"flow_map"};
    j["output"]["plots"] = false;
    plan = plan_fields(resolve_experiment(parse_experiment(j)));
    CHECK_FALSE(plan.cauchy_green);
    CHECK(plan.keep.empty());
}

TEST_CASE("flow_map_at_points: arbitrary points, both gradient methods, against the linear saddle's exact DF") {
    // x' = a x, y' = -a y: F(x0) = (x0 e^{aT}, y0 e^{-aT}), DF = diag(e^{aT}, e^{-aT}) everywhere.
    const double a = 0.8, t1 = 3.0;
    const System saddle = make_system("linear-saddle", {{"a", a}});
    const Dynamics dyn{&saddle, nullptr};
    const std::vector<double> xy = {0.3, -0.2, -0.7, 0.05, 0.01, 0.9, 0.5, 0.5, -0.4, -0.6};
    const std::size_t n = xy.size() / 2;
    const auto start = [&](std::size_t k, double &x, double &y) { x = xy[2 * k], y = xy[2 * k + 1]; };
    IntegratorSettings s = adaptive(4);
    s.rtol = s.atol = 1e-10;
    for (const GradientMethod g : {GradientMethod::variational, GradientMethod::auxiliary_grid}) {
        const std::string method = to_string(g);
        CAPTURE(method);
        FlowMapRequest request{dyn, 0.0, t1, s, g, true};
        request.offset_x = 1e-4;
        request.offset_y = 2e-4;
        const FlowMap f = flow_map_at_points(request, n, start);
        REQUIRE(f.flow_x.size() == n);
        REQUIRE(f.dF.size() == 4 * n);
        for (std::size_t k = 0; k < n; ++k) {
            CHECK(f.mask[k] == 0);
            CHECK(f.flow_x[k] == doctest::Approx(xy[2 * k] * std::exp(a * t1)).epsilon(1e-8));
            CHECK(f.flow_y[k] == doctest::Approx(xy[2 * k + 1] * std::exp(-a * t1)).epsilon(1e-8));
            const double scale = f.dF_exponent.empty() ? 1.0 : std::ldexp(1.0, f.dF_exponent[k]);
            CHECK(f.dF[4 * k] * scale == doctest::Approx(std::exp(a * t1)).epsilon(1e-6));
            CHECK(std::abs(f.dF[4 * k + 1] * scale) < 1e-6);
            CHECK(std::abs(f.dF[4 * k + 2] * scale) < 1e-6);
            CHECK(f.dF[4 * k + 3] * scale == doctest::Approx(std::exp(-a * t1)).epsilon(1e-6));
        }
    }
    // Every point leaving the bounds is a result (the extractors' advection asks for such points), not an error.
    const FlowMap out =
        flow_map_at_points({dyn, 0.0, t1, s, GradientMethod::none, true, Bounds{-1e-3, 1e-3, -1e-3, 1e-3}}, n, start);
    for (std::size_t k = 0; k < n; ++k) CHECK((out.mask[k] & mask_left_bounds) != 0);
}

TEST_CASE("the extractors' advection shares the grid's auxiliary-grid path (flow_map_at_points)") {
    // The probe extractor advects a grid point with its gradient; the linear saddle x' = a x, y' = -a y is
    // area-preserving and linear, so det DF = 1 and centred differences are exact up to the integration error.
    const json j = json::parse(R"({
      "system":  {"plugin": "linear-saddle", "params": {"a": 0.8}},
      "grid":    {"x": [-1, 1], "y": [-1, 1], "n": [21, 13]}, "time": {"t0": 0, "t1": 2},
      "integrator": {"method": "dopri5", "rtol": 1e-9, "atol": 1e-9},
      "cauchy_green": {"method": "auxiliary-grid", "offset": 1e-3},
      "products": ["ftle"], "extractors": [{"plugin": "probe"}], "output": {"plots": false}})");
    json with_paths = j;
    with_paths["plugin_paths"] = {test::plugin_dir().string(), test::test_plugin_dir().string()};
    const ResolvedExperiment r = resolve_experiment(parse_experiment(with_paths));
    REQUIRE(r.gradient == GradientMethod::auxiliary_grid);
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-tiles-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    RunOptions options;
    options.output_dir = dir;
    options.quiet = true;
    run_experiment(r, options);
    const json b = json::parse(std::ifstream(dir / "barriers.json"));
    REQUIRE(b["barriers"].size() == 1);
    const json &barrier = b["barriers"][0];
    const double det = barrier["det_gradient"].get<double>();
    MESSAGE("det DF by the host's auxiliary grid: " << det);
    CHECK(det == doctest::Approx(1.0).epsilon(1e-6));
    // The image is F(x0) = (x0 e^{aT}, y0 e^{-aT}).
    const double x0 = barrier["points"][0][0], y0 = barrier["points"][0][1];
    CHECK(barrier["points"][1][0].get<double>() == doctest::Approx(x0 * std::exp(1.6)).epsilon(1e-8));
    CHECK(barrier["points"][1][1].get<double>() == doctest::Approx(y0 * std::exp(-1.6)).epsilon(1e-8));
    fs::remove_all(dir);
}

TEST_CASE("bounds that stop exits: the flow map stopped where the trajectory leaves, and its exit time") {
    // x' = a x, y' = -a y leaves |x| <= X at t_exit = log(X / |x0|) / a; stopped there, F = (x0 e^{a t}, y0 e^{-a t})
    // and DF = diag(e^{a t}, e^{-a t}) at the recorded exit time t, which is the end of the step that crossed:
    // t_exit <= t <= t_exit + one step. Points with |x0| e^{aT} <= X never leave (exit time NaN).
    const double a = 0.8, t1 = 3.0, X = 1.0;
    const System saddle = make_system("linear-saddle", {{"a", a}});
    const Dynamics dyn{&saddle, nullptr};
    const std::vector<double> xy = {0.3, -0.2, -0.7, 0.05, 0.01, 0.9, 0.5, 0.5, -0.4, -0.6, 0.0, 0.3};
    const std::size_t n = xy.size() / 2;
    const auto start = [&](std::size_t k, double &x, double &y) { x = xy[2 * k], y = xy[2 * k + 1]; };
    IntegratorSettings fixed; // the default: checked fixed steps
    fixed.step = 0.01;
    const Bounds stop{-X, X, -2.0, 2.0, ExitRule::stop};
    for (const IntegratorSettings &s : {fixed, adaptive(4)}) {
        for (const GradientMethod g : {GradientMethod::variational, GradientMethod::auxiliary_grid}) {
            CAPTURE(to_string(g));
            CAPTURE(s.adaptive);
            FlowMapRequest request{dyn, 0.0, t1, s, g, true, stop};
            request.offset_x = request.offset_y = 1e-6;
            const FlowMap f = flow_map_at_points(request, n, start);
            REQUIRE(f.exit_time.size() == n);
            CHECK(f.stats.masked == 0);
            std::uint64_t exited = 0;
            for (std::size_t k = 0; k < n; ++k) {
                CAPTURE(k);
                const double x0 = xy[2 * k], y0 = xy[2 * k + 1];
                CHECK(f.mask[k] == 0);
                const double t = f.exit_time[k];
                const bool leaves = std::abs(x0) * std::exp(a * t1) > X;
                CHECK(std::isnan(t) == !leaves);
                if (!leaves) continue;
                ++exited;
                const double t_exit = std::log(X / std::abs(x0)) / a;
                CHECK(t >= t_exit - 1e-9);
                CHECK(t <= t_exit + (s.adaptive ? 0.5 : fixed.step) + 1e-9); // within the crossing step
                CHECK(f.flow_x[k] == doctest::Approx(x0 * std::exp(a * t)).epsilon(1e-5));
                CHECK(f.flow_y[k] == doctest::Approx(y0 * std::exp(-a * t)).epsilon(1e-5));
                const double scale = f.dF_exponent.empty() ? 1.0 : std::ldexp(1.0, f.dF_exponent[k]);
                CHECK(f.dF[4 * k] * scale == doctest::Approx(std::exp(a * t)).epsilon(1e-4));
                CHECK(f.dF[4 * k + 3] * scale == doctest::Approx(std::exp(-a * t)).epsilon(1e-4));
            }
            CHECK(f.stats.exited >= exited); // the auxiliary grid's neighbours count as trajectories too
            CHECK(exited == 4);              // x0 = 0.3, -0.7, 0.5, -0.4 leave; 0.01 and 0 stay
        }
    }
    // The engine's default masks exits, as the extractors' advection needs.
    const FlowMap masked =
        flow_map_at_points({dyn, 0.0, t1, fixed, GradientMethod::variational, true, masking(stop)}, n, start);
    CHECK(masked.exit_time.empty());
    CHECK(masked.stats.masked_left_bounds == 4);
    CHECK(masked.stats.exited == 0);
}

TEST_CASE("a run whose bounds stop exits: exit_time in fields.nc and the safe basin in the manifest") {
    // Linear saddle, grid [-1, 1]^2, bounds |x| <= 1, T = 2: a grid point stays in exactly when |x0| e^{2a} <= 1.
    const double a = 0.8, T = 2.0;
    const json j = json::parse(R"({
      "system":  {"plugin": "linear-saddle", "params": {"a": 0.8}},
      "grid":    {"x": [-1, 1], "y": [-1, 1], "n": [41, 21]}, "time": {"t0": 0, "t1": 2},
      "bounds":  {"x": [-1, 1], "y": [-5, 5]},
      "products": ["ftle"], "output": {"plots": false}})");
    json with_paths = j;
    with_paths["plugin_paths"] = {test::plugin_dir().string()};
    const ResolvedExperiment r = resolve_experiment(parse_experiment(with_paths));
    REQUIRE(r.experiment.bounds);
    CHECK(r.experiment.bounds->exits == ExitRule::stop); // the experiments' default
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-exits-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    RunOptions options;
    options.output_dir = dir;
    options.quiet = true;
    options.keep_results = true;
    const RunSummary summary = run_experiment(r, options);
    std::size_t stay = 0;
    for (std::size_t i = 0; i < 41; ++i)
        if (std::abs(-1.0 + 0.05 * static_cast<double>(i)) * std::exp(a * T) <= 1.0) stay += 21;
    const json manifest = json::parse(std::ifstream(dir / "manifest.json"));
    REQUIRE(manifest.contains("escape"));
    CHECK(manifest["escape"]["captured"].get<std::size_t>() == stay);
    CHECK(manifest["escape"]["captured_fraction"].get<double>() == doctest::Approx(stay / 861.0));
    CHECK(manifest["escape"]["captured_area"].get<double>() == doctest::Approx(4.0 * stay / 861.0));
    CHECK(manifest["integrator_stats"]["masked"] == 0);
    const auto exit =
        std::find_if(summary.fields.begin(), summary.fields.end(), [](const auto &v) { return v.name == "exit_time"; });
    REQUIRE(exit != summary.fields.end());
    CHECK(exit->long_name.find("left the bounds") != std::string::npos); // model time: units "1", named in it
    for (std::size_t p = 0; p < 861; ++p) {
        const double x0 = -1.0 + 0.05 * static_cast<double>(p % 41), t = exit->values[p];
        if (std::abs(x0) * std::exp(a * T) <= 1.0) {
            CHECK(std::isnan(t));
        } else {
            CHECK(t >= std::log(1.0 / std::abs(x0)) / a - 1e-9);
            CHECK(t <= T);
        }
    }
    fs::remove_all(dir);
}
