// Tests of the parallel-shear system plugin beside it, against its closed-form flow map: every line y = const slides
// rigidly, F(x0, y0) = (x0 + U p(y0/L) T, y0) and DF = [[1, (U/L) p'(y0/L) T], [0, 1]], with p' worked out by hand
// (jet: p = sech^2, p' = -2 sech^2 tanh; layer: p = tanh, p' = sech^2); area is preserved (divergence 0); the jet is
// even in y and the layer odd.
#include <doctest/doctest.h>

#include <geobarrier/flow_map.hpp>
#include <system_tests.hpp>
#include <test_support.hpp>

#include <cmath>
#include <string>
#include <vector>

using namespace geobarrier;

namespace {

double sech2(double z) { return 1.0 / (std::cosh(z) * std::cosh(z)); }
double profile(const std::string &name, double z) { return name == "jet" ? sech2(z) : std::tanh(z); }
double profile_slope(const std::string &name, double z) {
    return name == "jet" ? -2.0 * sech2(z) * std::tanh(z) : sech2(z);
}

} // namespace

TEST_CASE("parallel-shear: the flow map and its gradient are the closed forms, for the jet and the layer") {
    const double U = 1.5, L = 0.75, T = 4.0;
    const Forcing none = test::make_forcing("none");
    for (const std::string name : {"jet", "layer"}) {
        CAPTURE(name);
        const System s = test::make_system("parallel-shear", {{"profile", name}, {"velocity", U}, {"width", L}});
        const std::vector<double> x0 = {0.0, -1.0, 2.5, 0.3}, y0 = {0.0, 0.4, -1.1, 2.0};
        const FlowMap r = flow_map_at_points(
            {Dynamics{&s, &none}, 0.0, T, test::tight_integrator(), GradientMethod::variational, true}, x0, y0);
        for (std::size_t k = 0; k < x0.size(); ++k) {
            CAPTURE(y0[k]);
            REQUIRE(r.mask[k] == 0);
            // The velocity is constant along each trajectory, so the integrator only rounds: |x| <= 9, rtol 1e-12.
            CHECK(std::fabs(r.flow_x[k] - (x0[k] + U * profile(name, y0[k] / L) * T)) <= 1e-11);
            CHECK(r.flow_y[k] == y0[k]);
            const double *F = &r.dF[4 * k];
            CHECK(std::fabs(F[0] - 1.0) <= 1e-12);
            CHECK(std::fabs(F[1] - U / L * profile_slope(name, y0[k] / L) * T) <= 1e-11);
            CHECK(F[2] == 0.0);
            CHECK(std::fabs(F[3] - 1.0) <= 1e-12);
        }
    }
}

TEST_CASE("parallel-shear: divergence 0, the jet even in y and the layer odd") {
    const double t = 0.0, f = 0.0;
    for (const std::string name : {"jet", "layer"}) {
        CAPTURE(name);
        const System s = test::make_system("parallel-shear", {{"profile", name}, {"velocity", -2.0}});
        const double x[2] = {0.5, 0.8}, mirrored[2] = {0.5, -0.8};
        double v[2], w[2], div = 1.0;
        std::int32_t status = -1;
        s.rhs(1, 1, &t, x, &f, v, &status);
        s.rhs(1, 1, &t, mirrored, &f, w, &status);
        CHECK(w[0] == (name == "jet" ? v[0] : -v[0]));
        CHECK(v[1] == 0.0);
        s.divergence(1, 1, &t, x, &f, &div, &status);
        CHECK(status == GB_OK);
        CHECK(div == 0.0);
    }
}
