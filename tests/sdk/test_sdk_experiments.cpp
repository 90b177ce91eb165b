// The experiments of the new plugins (experiments/*.json) validate, resolve their plugins and parameters, and the
// shear-vortex experiment reproduces its known FTLE field, asinh(|shear| r^2 |T|) / |T|.
#include <doctest/doctest.h>

#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/flow_map.hpp>
#include <test_support.hpp>

#include <cmath>
#include <string>
#include <vector>

using namespace geobarrier;

TEST_CASE("the plugin SDK's experiments validate and resolve") {
    const std::vector<std::pair<std::string, std::string>> experiments = {
        {"pendulum", "pendulum/cosine"},           {"van-der-pol", "van-der-pol/cosine"},
        {"double-gyre", "double-gyre/none"},       {"shear-vortex", "shear-vortex/none"},
        {"quasi-periodic-duffing", "duffing/quasi-periodic"}, {"data-duffing", "duffing/data"},
        {"ramp-duffing", "duffing/ramp"},          {"sum-duffing", "duffing/sum"}};
    for (const auto &[file, plugins] : experiments) {
        CAPTURE(file);
        const ResolvedExperiment r =
            resolve_experiment(load_experiment(test::source_dir() / "experiments" / (file + ".json")));
        CHECK(r.system.info().name + "/" + r.forcing.info().name == plugins);
    }
}

TEST_CASE("experiments/shear-vortex.json: FTLE = asinh(|shear| r^2 |T|) / |T| on a coarse copy of its grid") {
    Experiment e = load_experiment(test::source_dir() / "experiments" / "shear-vortex.json");
    e.grid.nx = e.grid.ny = 21;
    const ResolvedExperiment r = resolve_experiment(e);
    REQUIRE(r.gradient == GradientMethod::variational);
    const double T = e.t1 - e.t0;
    const GridFlowMap flow = compute_grid_flow_map(Dynamics{&r.system, &r.forcing}, e.grid, e.t0, e.t1,
                                                   e.integrator, r.gradient, e.aux_offset, false);
    const CauchyGreenField cg = cauchy_green_field(e.grid, flow.dF, flow.mask, std::fabs(T));
    const double shear = e.system.params["shear"];
    for (std::size_t i = 0; i < e.grid.ny; ++i)
        for (std::size_t j = 0; j < e.grid.nx; ++j) {
            const double x = e.grid.x_min + j * (e.grid.x_max - e.grid.x_min) / (e.grid.nx - 1);
            const double y = e.grid.y_min + i * (e.grid.y_max - e.grid.y_min) / (e.grid.ny - 1);
            const std::size_t k = i * e.grid.nx + j;
            REQUIRE(flow.mask[k] == 0);
            // The default tolerances (rtol 1e-8) bound DF's relative error near 1e-7, so log(lambda2) / (2T) to
            // about 1e-7 / T; the degenerate centre (lambda1 = lambda2 = 1) has FTLE 0.
            const double expected = std::asinh(std::fabs(shear) * (x * x + y * y) * std::fabs(T)) / std::fabs(T);
            CHECK(std::fabs(cg.ftle[k] - expected) <= 1e-7);
        }
}
