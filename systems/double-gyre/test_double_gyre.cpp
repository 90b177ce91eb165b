// Tests of the double gyre: the steady stream
// function at epsilon = 0, the invariant boundary, period 2 pi / omega, area preservation, and the conformance
// checks on the declared domain.
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <geobarrier/flow_map.hpp>
#include <test_support.hpp>

#include <cfloat>
#include <cmath>
#include <vector>

using namespace geobarrier;

namespace {
constexpr double pi = 3.141592653589793;
const PluginHandle &gyre() { return test::registry().find(PluginKind::system, "double-gyre", "/system/plugin"); }

// One velocity (u, v) at (x, y, t).
std::pair<double, double> velocity(const System &s, double x, double y, double t) {
    const double state[2] = {x, y}, f = 0.0;
    double out[2];
    std::int32_t status;
    s.rhs(1, 1, &t, state, &f, out, &status);
    return {out[0], out[1]};
}
} // namespace

TEST_CASE("double-gyre: at epsilon = 0 the stream function A sin(pi x) sin(pi y): u = -psi_y, v = psi_x") {
    const double A = 0.3;
    const System s = test::make_system("double-gyre", {{"amplitude", A}, {"epsilon", 0.0}});
    for (double x : {0.1, 0.5, 1.3, 1.9})
        for (double y : {0.05, 0.4, 0.8})
            for (double t : {0.0, 3.7}) {
                const auto [u, v] = velocity(s, x, y, t);
                // g = x exactly when a = 0 and b = 1, so only the libm sin/cos round (1 ulp each).
                CHECK(std::fabs(u + pi * A * std::sin(pi * x) * std::cos(pi * y)) <= 4 * DBL_EPSILON * pi * A);
                CHECK(std::fabs(v - pi * A * std::cos(pi * x) * std::sin(pi * y)) <= 4 * DBL_EPSILON * pi * A);
            }
}

TEST_CASE("double-gyre: the boundary of [0, 2] x [0, 1] is invariant (no normal velocity)") {
    const System s = test::make_system("double-gyre");
    const double A = 0.1;
    for (double t : {0.0, 1.3, 2.5, 7.9}) {
        for (double a : {0.0, 0.25, 0.5, 0.77, 1.0}) {
            CAPTURE(t);
            CAPTURE(a);
            CHECK(velocity(s, 0.0, a, t).first == 0.0);        // g(0) = 0 and sin 0 = 0 exactly
            CHECK(velocity(s, 2.0 * a, 0.0, t).second == 0.0); // sin(0) = 0 exactly
            // g(2) = 2 (2a + b) = 2 up to rounding of a few ulp, and sin(pi) = 1.2e-16 in doubles:
            // |u| and |v| stay below pi A times a few 1e-16 (g_x <= 1.5 on the domain).
            CHECK(std::fabs(velocity(s, 2.0, a, t).first) <= pi * A * 16 * DBL_EPSILON);
            CHECK(std::fabs(velocity(s, 2.0 * a, 1.0, t).second) <= pi * A * 1.5 * 2 * DBL_EPSILON);
        }
    }
    // So trajectories started inside stay inside, up to the integration tolerance.
    const Forcing none = test::make_forcing("none");
    std::vector<double> x0, y0;
    for (int i = 0; i < 9; ++i)
        for (int j = 0; j < 5; ++j) {
            x0.push_back(0.01 + 1.98 * i / 8.0);
            y0.push_back(0.01 + 0.98 * j / 4.0);
        }
    IntegratorSettings tight;
    tight.rtol = 1e-10;
    tight.atol = 1e-12;
    const FlowMap r = flow_map_at_points({Dynamics{&s, &none}, 0.0, 20.0, tight}, x0, y0);
    for (std::size_t k = 0; k < x0.size(); ++k) {
        REQUIRE(r.mask[k] == 0);
        CHECK(r.flow_x[k] >= -1e-9);
        CHECK(r.flow_x[k] <= 2.0 + 1e-9);
        CHECK(r.flow_y[k] >= -1e-9);
        CHECK(r.flow_y[k] <= 1.0 + 1e-9);
    }
}

TEST_CASE("double-gyre: period 2 pi / omega, and area preserving (det DF = 1)") {
    const System s = test::make_system("double-gyre");
    for (double t : {0.3, 4.1}) {
        const auto [u0, v0] = velocity(s, 0.7, 0.3, t);
        const auto [u1, v1] = velocity(s, 0.7, 0.3, t + 10.0);
        // omega (t + 10) and omega t + 2 pi differ by a few ulp of 2 pi + omega t; |d/dt| <= A pi^2 omega.
        CHECK(std::fabs(u1 - u0) <= 1e-14);
        CHECK(std::fabs(v1 - v0) <= 1e-14);
    }
    const Forcing none = test::make_forcing("none");
    IntegratorSettings tight;
    tight.rtol = 1e-12;
    tight.atol = 1e-14;
    const FlowMap r = flow_map_at_points({Dynamics{&s, &none}, 0.0, 15.0, tight, GradientMethod::variational, true},
                                         {0.2, 1.0, 1.5}, {0.5, 0.5, 0.2});
    for (std::size_t k = 0; k < 3; ++k) {
        REQUIRE(r.mask[k] == 0);
        const double *F = &r.dF[4 * k];
        // Each entry of DF is good to about 1e-11 relative (rtol 1e-12, accumulated over the steps), so the
        // determinant to 1e-11 times the size of its two products, which grow like e^{2 FTLE T}.
        CHECK(std::fabs(F[0] * F[3] - F[1] * F[2] - 1.0) <= 1e-11 * (std::fabs(F[0] * F[3]) + std::fabs(F[1] * F[2])));
    }
}

TEST_CASE("double-gyre: passes the conformance checks on its domain") {
    ConformanceOptions options;
    const auto checks = check_plugin(gyre(), options);
    INFO(format_checks(checks));
    CHECK(all_passed(checks));
    bool sampled_domain = false;
    for (const auto &c : checks)
        if (c.name == "finite_on_sample_box") sampled_domain = c.detail.find("[0, 2] x [0, 1]") != std::string::npos;
    CHECK(sampled_domain);
    options.params = {{"epsilon", 0.0}};
    CHECK(all_passed(check_plugin(gyre(), options)));
}
