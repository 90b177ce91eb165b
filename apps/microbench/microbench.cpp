// Microbenchmarks of the pipeline's inner stages on Google Benchmark: the engine (flow map with its gradient), the
// fields (Cauchy–Green eigen-decomposition, strain derivatives) and the tensor lines (strainlines in lockstep lanes).
// The whole-run bench (apps/bench, scripts/bench) says how a run compares with the baselines a user would write;
// these say where a stage's time goes when one of them changes, one stage at a time, with Google Benchmark's
// repetitions and statistics (--benchmark_repetitions=N --benchmark_report_aggregates_only).
//
// Every case works on workload W of docs/performance.md (forced Duffing x'' = x - x^3 + 0.08 cos t, the paper's
// Example 1 box [-1.8, 1.8] x [-1.2, 1.2]); the fields and lines start from one flow map over 8 pi computed once.
// Items per second are grid points (engine, fields) or strainline points (tensor lines).
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/flow_map.hpp>
#include <geobarrier/line_field.hpp>
#include <geobarrier/plugin.hpp>
#include <geobarrier/tensor_lines.hpp>

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

namespace {

using namespace geobarrier;

constexpr double eight_pi = 8.0 * M_PI;

const PluginRegistry &registry() {
    static const PluginRegistry r({GEOBARRIER_PLUGIN_DIR});
    return r;
}

template <class Plugin>
Plugin make_plugin(PluginKind kind, const char *name, const nlohmann::json &params, const std::string &json_path) {
    const PluginHandle &h = registry().find(kind, name, json_path + "/plugin");
    return Plugin(h, validate_params(h.info, params, json_path + "/params"));
}

// Workload W's system and forcing, loaded once from the built plugins.
struct Workload {
    System duffing =
        make_plugin<System>(PluginKind::system, "duffing", {{"alpha", 1.0}, {"beta", 1.0}, {"delta", 0.0}}, "/system");
    Forcing cosine = make_plugin<Forcing>(PluginKind::forcing, "cosine",
                                          {{"amplitude", 0.08}, {"omega", 1.0}, {"phase", 0.0}}, "/forcing");
    Dynamics dynamics() const { return Dynamics{&duffing, &cosine}; }
};

const Workload &workload() {
    static const Workload w;
    return w;
}

Grid w_grid(std::size_t n) {
    Grid g;
    g.x_min = -1.8;
    g.x_max = 1.8;
    g.y_min = -1.2;
    g.y_max = 1.2;
    g.nx = n;
    g.ny = n;
    return g;
}

// W's flow map over 8 pi on a 301 x 301 grid (variational gradient, the engine's defaults), computed once.
const FlowMap &w_flow_map() {
    static const FlowMap fm = compute_grid_flow_map(
        {workload().dynamics(), 0.0, eight_pi, IntegratorSettings{}, GradientMethod::variational}, w_grid(301));
    return fm;
}

const CauchyGreenField &w_cauchy_green() {
    static const CauchyGreenField cg = cauchy_green_field(w_grid(301), w_flow_map().dF, w_flow_map().mask, eight_pi,
                                                          w_flow_map().dF_exponent, w_flow_map().log_det);
    return cg;
}

// The engine: flow map and gradient of an n x n grid over one forcing period (the argument is n).
void flow_map_one_period(benchmark::State &state) {
    const auto n = static_cast<std::size_t>(state.range(0));
    const Grid grid = w_grid(n);
    for (auto _ : state) {
        FlowMap fm = compute_grid_flow_map(
            {workload().dynamics(), 0.0, 2.0 * M_PI, IntegratorSettings{}, GradientMethod::variational}, grid);
        benchmark::DoNotOptimize(fm.dF.data());
    }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * grid.size()));
}
BENCHMARK(flow_map_one_period)->Arg(64)->Arg(128)->UseRealTime()->Unit(benchmark::kMillisecond);

// The fields: eigenvalues and eigenvectors of C = DF^T DF at every point of the 301 x 301 grid.
void cauchy_green_eigen(benchmark::State &state) {
    const FlowMap &fm = w_flow_map();
    for (auto _ : state) {
        CauchyGreenField cg = cauchy_green_field(fm.grid, fm.dF, fm.mask, eight_pi, fm.dF_exponent, fm.log_det);
        benchmark::DoNotOptimize(cg.lambda2.data());
    }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * fm.grid.size()));
}
BENCHMARK(cauchy_green_eigen)->UseRealTime()->Unit(benchmark::kMillisecond);

// The fields: derivatives of lambda_2 and of the eigenvectors on the grid (what the strain deviation needs).
void strain_derivatives_of_w(benchmark::State &state) {
    const CauchyGreenField &cg = w_cauchy_green();
    for (auto _ : state) {
        StrainDerivatives d = strain_derivatives(cg);
        benchmark::DoNotOptimize(&d);
    }
    state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * cg.grid.size()));
}
BENCHMARK(strain_derivatives_of_w)->UseRealTime()->Unit(benchmark::kMillisecond);

// The tensor lines: strainlines (xi1 lines) both ways from a lattice of seeds, each at most 2 units each way, with
// the default midpoint method and step; the argument is the number of seeds per axis.
void strainlines_both_ways(benchmark::State &state) {
    const CauchyGreenField &cg = w_cauchy_green();
    const LineField xi1 = LineField::from_cauchy_green(cg, 1);
    const auto per_axis = static_cast<std::size_t>(state.range(0));
    std::vector<double> seeds;
    for (std::size_t i = 0; i < per_axis; ++i)
        for (std::size_t j = 0; j < per_axis; ++j) {
            seeds.push_back(-1.7 + 3.4 * (static_cast<double>(j) + 0.5) / static_cast<double>(per_axis));
            seeds.push_back(-1.1 + 2.2 * (static_cast<double>(i) + 0.5) / static_cast<double>(per_axis));
        }
    TensorLineSettings settings;
    settings.max_length = 2.0;
    std::size_t points = 0;
    for (auto _ : state) {
        const std::vector<TwoWayLine> lines = integrate_tensor_lines_both_ways(xi1, seeds, settings, ArcLengths::drop);
        for (const TwoWayLine &l : lines) points += l.size();
        benchmark::DoNotOptimize(lines.data());
    }
    state.SetItemsProcessed(static_cast<std::int64_t>(points));
}
BENCHMARK(strainlines_both_ways)->Arg(16)->Arg(32)->UseRealTime()->Unit(benchmark::kMillisecond);

} // namespace

BENCHMARK_MAIN();
