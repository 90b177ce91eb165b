// Tests of the coupled-duffing system plugin beside it: the right-hand side at a point where every operation is exact,
// the fixed points, the Jacobian at the origin and its normal modes (in phase: eigenvalues +-sqrt(alpha); in
// antiphase: +-sqrt(alpha - 2k), the spring stretched twice), the divergence -2 delta, the exchange symmetry of the two
// oscillators, and where the forcing enters. Energy conservation along the flow is in tests/test_ndim.cpp.
#include <doctest/doctest.h>

#include <geobarrier/plugin.hpp>
#include <system_tests.hpp>
#include <test_support.hpp>

#include <array>
#include <cstdint>

using namespace geobarrier;

namespace {

using State = std::array<double, 4>;

State rhs(const System &s, const State &x, double f) { return test::rhs_at(s, x, f); }

// The 4 x 4 Jacobian, row-major (one lane: entry (i, j) at i * 4 + j).
std::array<double, 16> jacobian(const System &s, const State &x, double f) {
    std::array<double, 16> jac{};
    const double t = 0.0;
    std::int32_t status = -1;
    s.jacobian(1, 1, &t, x.data(), &f, jac.data(), &status);
    CHECK(status == GB_OK);
    return jac;
}

State times(const std::array<double, 16> &m, const State &v) {
    State out{};
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) out[i] += m[4 * i + j] * v[j];
    return out;
}

} // namespace

TEST_CASE("coupled-duffing: right-hand side at a hand-computed point") {
    const System s = test::make_system("coupled-duffing",
                                       {{"alpha", 1.5}, {"beta", 2.0}, {"delta", 0.25}, {"k", 0.5}, {"drive2", 0.5}});
    // (x1, v1, x2, v2) = (0.5, -1, -1, 0.25), f = 0.125: dyadic values, so every product and sum is exact.
    const State d = rhs(s, {0.5, -1.0, -1.0, 0.25}, 0.125);
    CHECK(d[0] == -1.0);
    CHECK(d[2] == 0.25);
    // v1' = alpha x1 - beta x1^3 - delta v1 + k (x2 - x1) + f = 0.75 - 0.25 + 0.25 - 0.75 + 0.125
    CHECK(d[1] == 0.125);
    // v2' = alpha x2 - beta x2^3 - delta v2 + k (x1 - x2) + drive2 f = -1.5 + 2 - 0.0625 + 0.75 + 0.0625
    CHECK(d[3] == 1.25);
}

TEST_CASE("coupled-duffing: fixed points and the normal modes of the origin") {
    const double alpha = 1.0, k = 0.25;
    const System s = test::make_system("coupled-duffing", {{"alpha", alpha}, {"k", k}});
    // The origin and the two in-phase wells (x1 = x2 = +-1 with alpha = beta = 1: the spring is not stretched).
    for (const State &p : {State{0, 0, 0, 0}, State{1, 0, 1, 0}, State{-1, 0, -1, 0}}) {
        CAPTURE(p[0]);
        for (double v : rhs(s, p, 0.0)) CHECK(v == 0.0);
    }
    // J at the origin: [[0, 1, 0, 0], [alpha - k, 0, k, 0], [0, 0, 0, 1], [k, 0, alpha - k, 0]].
    const std::array<double, 16> J = jacobian(s, {0, 0, 0, 0}, 0.0);
    const std::array<double, 16> expected = {0, 1, 0, 0, alpha - k, 0, k, 0, 0, 0, 0, 1, k, 0, alpha - k, 0};
    for (int e = 0; e < 16; ++e) {
        CAPTURE(e);
        CHECK(J[e] == expected[e]);
    }
    // The modes: J^2 (1, 0, 1, 0) = alpha (1, 0, 1, 0) and J^2 (1, 0, -1, 0) = (alpha - 2k) (1, 0, -1, 0), so the
    // eigenvalues are +-1 (a saddle in phase) and +-sqrt(0.5) (a saddle in antiphase; alpha < 2k would make the
    // antiphase mode a centre).
    const State in_phase = times(J, times(J, {1, 0, 1, 0}));
    const State antiphase = times(J, times(J, {1, 0, -1, 0}));
    CHECK(in_phase == State{alpha, 0, alpha, 0});
    CHECK(antiphase == State{alpha - 2 * k, 0, -(alpha - 2 * k), 0});
}

TEST_CASE("coupled-duffing: divergence -2 delta, and the exchange symmetry of the oscillators") {
    const double delta = 0.375;
    const System s = test::make_system("coupled-duffing", {{"delta", delta}, {"k", 0.75}, {"drive2", 1.0}});
    const double t = 0.0, f = 0.5;
    const State x = {0.75, -0.5, -1.25, 2.0};
    double div = 0.0;
    std::int32_t status = -1;
    s.divergence(1, 1, &t, x.data(), &f, &div, &status);
    CHECK(status == GB_OK);
    CHECK(div == -2 * delta); // only v_i' contains v_i, each with -delta
    // With drive2 = 1 both oscillators feel the same forcing: exchanging them exchanges their velocities.
    const State d = rhs(s, x, f), swapped = rhs(s, {x[2], x[3], x[0], x[1]}, f);
    CHECK(swapped == State{d[2], d[3], d[0], d[1]});
}

TEST_CASE("coupled-duffing: the forcing drives the first oscillator, and the second with weight drive2") {
    const System s = test::make_system("coupled-duffing", {{"drive2", 0.25}});
    const State x = {0.5, 0.25, -0.75, 1.0};
    const State unforced = rhs(s, x, 0.0), forced = rhs(s, x, 2.0);
    CHECK(forced[0] == unforced[0]);
    CHECK(forced[1] == unforced[1] + 2.0);
    CHECK(forced[2] == unforced[2]);
    CHECK(forced[3] == unforced[3] + 0.5);
}
