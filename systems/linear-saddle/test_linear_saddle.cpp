// Tests of the linear-saddle test system: values, the constant Jacobian diag(a, -a), zero divergence,
// independence of the forcing, and the shared conformance checks.
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <test_support.hpp>

#include <cmath>
#include <vector>

using namespace geobarrier;

namespace {
const PluginHandle &saddle() { return test::registry().find(PluginKind::system, "linear-saddle", "/system/plugin"); }
} // namespace

TEST_CASE("linear-saddle: x' = a x, y' = -a y, whatever the forcing") {
    const System s = test::make_system("linear-saddle", {{"a", 0.75}});
    const std::size_t ld = 4;
    const double t[ld] = {0.0, 2.0, -1.0, 0.0};
    const double x[2 * ld] = {1.0, -2.0, 0.5, 0.0, /* y */ 4.0, 0.25, -8.0, 0.0};
    const double f[ld] = {10.0, -3.0, 0.5, 0.0};
    double dxdt[2 * ld], jac[4 * ld], div[ld];
    std::int32_t status[ld];
    s.rhs(3, ld, t, x, f, dxdt, status);
    const double expected_dx[3] = {0.75, -1.5, 0.375}, expected_dy[3] = {-3.0, -0.1875, 6.0}; // exact in binary
    for (int k = 0; k < 3; ++k) {
        CAPTURE(k);
        CHECK(dxdt[k] == expected_dx[k]);
        CHECK(dxdt[ld + k] == expected_dy[k]);
    }
    s.jacobian(3, ld, t, x, f, jac, status);
    s.divergence(3, ld, t, x, f, div, status);
    for (int k = 0; k < 3; ++k) {
        CHECK(jac[0 * ld + k] == 0.75);
        CHECK(jac[1 * ld + k] == 0.0);
        CHECK(jac[2 * ld + k] == 0.0);
        CHECK(jac[3 * ld + k] == -0.75);
        CHECK(div[k] == 0.0);
    }
}

TEST_CASE("linear-saddle: passes the conformance checks") {
    for (double a : {1.0, -0.5, 3.0}) {
        ConformanceOptions options;
        options.params = {{"a", a}};
        const auto checks = check_plugin(saddle(), options);
        INFO("a = ", a, "\n", format_checks(checks));
        CHECK(all_passed(checks));
        // It ignores the forcing, and the forcing_ignored check verifies that (not skipped).
        for (const auto &c : checks) CHECK_FALSE(c.skipped);
    }
}
