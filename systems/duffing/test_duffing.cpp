// Tests of the duffing system plugin: values at hand-computed points (chosen so every operation is
// exact in binary floating point, hence exact equality), the analytic Jacobian and divergence, and the shared
// conformance checks.
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <geobarrier/errors.hpp>
#include <test_support.hpp>

#include <cmath>
#include <vector>

using namespace geobarrier;

namespace {

const PluginHandle &duffing() { return test::registry().find(PluginKind::system, "duffing", "/system/plugin"); }

struct Lanes {
    std::vector<double> t, x, f, out;
    std::vector<std::int32_t> status;
};

// Three lanes in rows of ld = 5: (x, y, f) = (2, -1, 0.375), (0.5, 0.25, 0), (-1.5, 2, -0.125).
Lanes three_lanes(std::size_t out_rows) {
    const std::size_t ld = 5;
    Lanes l;
    l.t = {0.0, 1.0, -3.5, 0.0, 0.0};
    l.x = {2.0, 0.5, -1.5, 0.0, 0.0, /* y */ -1.0, 0.25, 2.0, 0.0, 0.0};
    l.f = {0.375, 0.0, -0.125, 0.0, 0.0};
    l.out.assign(out_rows * ld, -99.0);
    l.status.assign(ld, -1);
    return l;
}

} // namespace

TEST_CASE("duffing: right-hand side at hand-computed points") {
    const System s = test::make_system("duffing", {{"alpha", 1.5}, {"beta", 0.5}, {"delta", 0.25}});
    Lanes l = three_lanes(2);
    s.rhs(3, 5, l.t.data(), l.x.data(), l.f.data(), l.out.data(), l.status.data());
    // x' = y
    CHECK(l.out[0] == -1.0);
    CHECK(l.out[1] == 0.25);
    CHECK(l.out[2] == 2.0);
    // y' = 1.5 x - 0.5 x^3 - 0.25 y + f
    CHECK(l.out[5] == 1.5 * 2 - 0.5 * 8 + 0.25 + 0.375);       // -0.375
    CHECK(l.out[6] == 1.5 * 0.5 - 0.5 * 0.125 - 0.0625 + 0.0); // 0.625
    CHECK(l.out[7] == 1.5 * -1.5 + 0.5 * 3.375 - 0.5 - 0.125); // -1.1875
    for (int k = 0; k < 3; ++k) CHECK(l.status[k] == GB_OK);
    // Lanes 3 and 4 are padding: untouched.
    CHECK(l.out[3] == -99.0);
    CHECK(l.out[9] == -99.0);
}

TEST_CASE("duffing: the defaults are the paper's undamped eq. duffing-ex3") {
    const System s = test::make_system("duffing");
    const double t = 0.0, x[2] = {0.5, 0.25}, f = 0.0;
    double dxdt[2];
    std::int32_t status;
    s.rhs(1, 1, &t, x, &f, dxdt, &status);
    CHECK(dxdt[0] == 0.25);
    CHECK(dxdt[1] == 0.5 - 0.125); // x - x^3
    // The fixed points of the unforced system: (0, 0) hyperbolic, (+-1, 0) elliptic.
    for (double x0 : {-1.0, 0.0, 1.0}) {
        const double xs[2] = {x0, 0.0};
        s.rhs(1, 1, &t, xs, &f, dxdt, &status);
        CHECK(dxdt[0] == 0.0);
        CHECK(dxdt[1] == 0.0);
    }
}

TEST_CASE("duffing: analytic Jacobian [[0, 1], [alpha - 3 beta x^2, -delta]] and divergence -delta") {
    const System s = test::make_system("duffing", {{"alpha", 1.5}, {"beta", 0.5}, {"delta", 0.25}});
    Lanes l = three_lanes(4);
    s.jacobian(3, 5, l.t.data(), l.x.data(), l.f.data(), l.out.data(), l.status.data());
    const double xs[3] = {2.0, 0.5, -1.5};
    for (int k = 0; k < 3; ++k) {
        CAPTURE(k);
        CHECK(l.out[0 * 5 + k] == 0.0);
        CHECK(l.out[1 * 5 + k] == 1.0);
        CHECK(l.out[2 * 5 + k] == 1.5 - 3 * 0.5 * xs[k] * xs[k]); // exact: -4.5, 1.125, -1.875
        CHECK(l.out[3 * 5 + k] == -0.25);
    }
    Lanes d = three_lanes(1);
    s.divergence(3, 5, d.t.data(), d.x.data(), d.f.data(), d.out.data(), d.status.data());
    for (int k = 0; k < 3; ++k) CHECK(d.out[k] == -0.25);
    CHECK(d.out[3] == -99.0);
}

TEST_CASE("duffing: passes the conformance checks") {
    // The paper's three parameter sets: undamped (eq. duffing-ex3) and damped (eqs. duffing_dissipative, -ex4),
    // and a stiffer one with a sign change, on the paper's plotting box and beyond.
    const nlohmann::json parameter_sets[] = {
        nlohmann::json::object(), {{"delta", 0.15}}, {{"alpha", -2.0}, {"beta", 3.0}, {"delta", -0.5}}};
    for (const auto &params : parameter_sets) {
        ConformanceOptions options;
        options.params = params;
        options.state_min = {-2.5, -2.0};
        options.state_max = {2.5, 2.0};
        const auto checks = check_plugin(duffing(), options);
        INFO(params.dump(), "\n", format_checks(checks));
        CHECK(all_passed(checks));
        CHECK(checks.size() == 12); // with code_generation (ABI 1.3) and advance_equals_stages (a fused step)
        for (const auto &c : checks) CHECK(c.skipped == (c.name == "forcing_ignored"));
    }
}

TEST_CASE("duffing: parameters are validated against the schema") {
    CHECK_THROWS_AS(test::make_system("duffing", {{"gamma", 1.0}}), ConfigError);
    CHECK_THROWS_AS(test::make_system("duffing", {{"alpha", "one"}}), ConfigError);
}
