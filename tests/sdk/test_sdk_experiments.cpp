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
        {"pendulum", "pendulum/cosine"},
        {"van-der-pol", "van-der-pol/cosine"},
        {"double-gyre", "double-gyre/none"},
        {"shear-vortex", "shear-vortex/none"},
        {"quasi-periodic-duffing", "duffing/quasi-periodic"},
        {"data-duffing", "duffing/data"},
        {"ramp-duffing", "duffing/ramp"},
        {"sum-duffing", "duffing/sum"}};
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
    const FlowMap flow = compute_grid_flow_map(
        with_grid_offset({Dynamics{&r.system, &r.forcing}, e.t0, e.t1, e.integrator, r.gradient}, e.grid, e.aux_offset),
        e.grid);
    const CauchyGreenField cg = cauchy_green_field(e.grid, flow.dF, flow.mask, std::fabs(T));
    const double shear = e.system.params["shear"];
    for (std::size_t i = 0; i < e.grid.ny; ++i)
        for (std::size_t j = 0; j < e.grid.nx; ++j) {
            const double x = e.grid.x_min + j * (e.grid.x_max - e.grid.x_min) / (e.grid.nx - 1);
            const double y = e.grid.y_min + i * (e.grid.y_max - e.grid.y_min) / (e.grid.ny - 1);
            const std::size_t k = i * e.grid.nx + j;
            REQUIRE(flow.mask[k] == 0);
            // The default (standard preset: dop853, 18 fixed steps h = 0.35 over 2 pi): the angular velocity
            // 1 + r^2 reaches 3 at the corners, |w h| = 1.05, where each step's relative error is about
            // |w h|^9 / 9! = 4e-6; measured max 6.9e-6 in FTLE there (1e-8 at the centre). The degenerate centre
            // (lambda1 = lambda2 = 1) has FTLE 0.
            const double expected = std::asinh(std::fabs(shear) * (x * x + y * y) * std::fabs(T)) / std::fabs(T);
            CHECK(std::fabs(cg.ftle[k] - expected) <= 3e-5);
        }
}
