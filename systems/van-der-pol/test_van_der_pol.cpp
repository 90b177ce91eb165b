// Tests of the Van der Pol oscillator: values, the attracting limit cycle of amplitude 2 + O(mu^2), and the
// shared conformance checks.
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <geobarrier/flow_map.hpp>
#include <test_support.hpp>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <vector>

using namespace geobarrier;

namespace {
const PluginHandle &van_der_pol() { return test::registry().find(PluginKind::system, "van-der-pol", "/system/plugin"); }
} // namespace

TEST_CASE("van-der-pol: x' = y, y' = mu (1 - x^2) y - x + f; Jacobian and divergence") {
    const double mu = 0.7;
    const System s = test::make_system("van-der-pol", {{"mu", mu}});
    const std::size_t ld = 3;
    const double t[ld] = {0.0, 5.0, -1.0};
    const double x[2 * ld] = {0.5, -2.0, 1.0, /* y */ 1.0, 0.25, -3.0};
    const double f[ld] = {0.2, 0.0, -0.5};
    double dxdt[2 * ld], jac[4 * ld], div[ld];
    std::int32_t status[ld];
    s.rhs(ld, ld, t, x, f, dxdt, status);
    s.jacobian(ld, ld, t, x, f, jac, status);
    s.divergence(ld, ld, t, x, f, div, status);
    for (std::size_t k = 0; k < ld; ++k) {
        CAPTURE(k);
        const double xk = x[k], yk = x[ld + k];
        CHECK(dxdt[k] == yk);
        CHECK(dxdt[ld + k] == doctest::Approx(mu * (1 - xk * xk) * yk - xk + f[k]).epsilon(4 * DBL_EPSILON));
        CHECK(jac[k] == 0.0);
        CHECK(jac[ld + k] == 1.0);
        CHECK(jac[2 * ld + k] == doctest::Approx(-2 * mu * xk * yk - 1).epsilon(4 * DBL_EPSILON));
        CHECK(jac[3 * ld + k] == doctest::Approx(mu * (1 - xk * xk)).epsilon(4 * DBL_EPSILON));
        CHECK(div[k] == jac[3 * ld + k]);
    }
}

TEST_CASE("van-der-pol: every start goes to the limit cycle of amplitude 2 + O(mu^2)") {
    // Poincare-Lindstedt: x = 2 cos tau + mu (3/4 sin tau - 1/4 sin 3 tau) + O(mu^2); the O(mu) term vanishes where
    // cos tau peaks, so max x = 2 + O(mu^2). Averaging gives the amplitude a(t) from a0:
    // a^2 = 4 / (1 + (4 / a0^2 - 1) e^{-mu t}); after t = 150 at mu = 0.1, starts at a0 = 1 and 3 are within
    // 2 * 3 e^{-15} / 4 = 5e-7 of the cycle.
    const double mu = 0.1;
    const System s = test::make_system("van-der-pol", {{"mu", mu}});
    const Forcing none = test::make_forcing("none");
    IntegratorSettings tight;
    tight.rtol = 1e-11;
    tight.atol = 1e-13;
    const Dynamics d{&s, &none};
    std::vector<double> x = {1.0, 3.0}, y = {0.0, 0.0};
    FlowMap r = flow_map_at_points({d, 0.0, 150.0, tight}, x, y);
    REQUIRE(r.mask[0] == 0);
    REQUIRE(r.mask[1] == 0);
    // Sample one period (2 pi (1 + mu^2/16) < 6.3) finely: the largest x on each trajectory.
    std::vector<double> peak(2, -1.0);
    const double dt = 0.005;
    for (double t = 150.0; t < 150.0 + 6.4; t += dt) {
        r = flow_map_at_points({d, t, t + dt, tight}, r.flow_x, r.flow_y);
        for (std::size_t k = 0; k < 2; ++k) peak[k] = std::max(peak[k], r.flow_x[k]);
    }
    // Sampling at dt falls short of the peak by at most |x''| dt^2 / 8 = 2 * 0.005^2 / 8 = 6e-6 (always from below).
    CHECK(std::fabs(peak[0] - 2.0) <= mu * mu);
    CHECK(std::fabs(peak[1] - 2.0) <= mu * mu);
    CHECK(std::fabs(peak[0] - peak[1]) <= 1e-5); // the same cycle from inside and outside: 6e-6 + 2 * 5e-7
}

TEST_CASE("van-der-pol: passes the conformance checks") {
    for (const nlohmann::json &params : {nlohmann::json::object(), nlohmann::json{{"mu", 3.0}}}) {
        ConformanceOptions options;
        options.params = params;
        const auto checks = check_plugin(van_der_pol(), options);
        INFO(params.dump(), "\n", format_checks(checks));
        CHECK(all_passed(checks));
    }
}
