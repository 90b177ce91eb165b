// Tests of the spring-pendulum system plugin beside it: the hanging equilibrium r* = L0 + g/k, its Jacobian with the
// textbook frequencies (the spring's sqrt(k), the pendulum's sqrt(g / r*)), the mirror symmetry theta -> -theta, the
// divergence -2 damping - 2 vr / r, and where the forcing enters. Energy conservation along the flow is in
// tests/test_ndim.cpp.
#include <doctest/doctest.h>

#include <geobarrier/plugin.hpp>
#include <system_tests.hpp>
#include <test_support.hpp>

#include <array>
#include <cmath>
#include <cstdint>

using namespace geobarrier;

namespace {

using State = std::array<double, 4>; // r, vr, theta, omega

State rhs(const System &s, const State &x, double f) { return test::rhs_at(s, x, f); }

} // namespace

TEST_CASE("spring-pendulum: the hanging equilibrium and its frequencies sqrt(k) and sqrt(g / (L0 + g/k))") {
    const double g = 1.0, k = 4.0, L0 = 1.0, c = 0.25;
    const System s = test::make_system("spring-pendulum", {{"g", g}, {"k", k}, {"rest_length", L0}, {"damping", c}});
    // At rest straight down, the spring is stretched until it carries the weight: k (r* - L0) = g.
    const State rest = {L0 + g / k, 0.0, 0.0, 0.0};
    for (double v : rhs(s, rest, 0.0)) CHECK(v == 0.0);
    // Linearised there the radial and angular motions decouple: vr' = -k (r - r*) - c vr, omega' = -(g / r*) theta -
    // c omega, i.e. a spring of frequency sqrt(k) = 2 and a pendulum of length r* = 1.25, frequency sqrt(0.8).
    std::array<double, 16> J{};
    const double t = 0.0, f = 0.0;
    std::int32_t status = -1;
    s.jacobian(1, 1, &t, rest.data(), &f, J.data(), &status);
    REQUIRE(status == GB_OK);
    const std::array<double, 16> expected = {0, 1, 0, 0, -k, -c, 0, 0, 0, 0, 0, 1, 0, 0, -g / (L0 + g / k), -c};
    for (int e = 0; e < 16; ++e) {
        CAPTURE(e);
        // g / r* = 0.8 is not a binary fraction: one rounding of the division, in whatever order the plugin divides.
        CHECK(std::fabs(J[e] - expected[e]) <= 2e-16);
    }
}

TEST_CASE("spring-pendulum: mirror symmetry theta -> -theta, omega -> -omega") {
    const System s = test::make_system("spring-pendulum", {{"damping", 0.125}});
    const State x = {1.5, -0.25, 0.7, 1.1};
    const State d = rhs(s, x, 0.3), mirrored = rhs(s, {x[0], x[1], -x[2], -x[3]}, 0.3);
    CHECK(mirrored == State{d[0], d[1], -d[2], -d[3]});
}

TEST_CASE("spring-pendulum: divergence -2 damping - 2 vr / r, and the forcing drives the spring") {
    const double c = 0.125;
    const System s = test::make_system("spring-pendulum", {{"damping", c}});
    // d(vr')/d(vr) = -c, d(omega')/d(omega) = -2 vr / r - c (the Coriolis term): at vr = 0.5, r = 2 the trace is -0.75.
    const State x = {2.0, 0.5, 0.3, -0.4};
    const double t = 0.0, f = 0.0;
    double div = 0.0;
    std::int32_t status = -1;
    s.divergence(1, 1, &t, x.data(), &f, &div, &status);
    CHECK(status == GB_OK);
    CHECK(div == -2 * c - 2 * 0.5 / 2.0);
    // f(t) is a force on the spring: only vr' changes, by f.
    const State unforced = rhs(s, x, 0.0), forced = rhs(s, x, 0.75);
    CHECK(forced[0] == unforced[0]);
    CHECK(forced[1] == unforced[1] + 0.75);
    CHECK(forced[2] == unforced[2]);
    CHECK(forced[3] == unforced[3]);
}
