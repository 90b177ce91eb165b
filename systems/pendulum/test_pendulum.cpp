// Tests of the pendulum: values, the small-amplitude damped solution, energy conservation without damping,
// Liouville's det DF = exp(-damping T), and the shared conformance checks.
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <geobarrier/flow_map.hpp>
#include <system_tests.hpp>
#include <test_support.hpp>

#include <cfloat>
#include <cmath>
#include <vector>

using namespace geobarrier;

namespace {
const PluginHandle &pendulum() { return test::registry().find(PluginKind::system, "pendulum", "/system/plugin"); }
} // namespace

TEST_CASE("pendulum: x' = y, y' = -omega0^2 sin x - damping y + f; Jacobian and divergence") {
    const double w0 = 1.5, c = 0.2;
    const System s = test::make_system("pendulum", {{"omega0", w0}, {"damping", c}});
    const std::size_t ld = 4;
    const double t[ld] = {0.0, 1.0, -2.0, 0.0};
    const double x[2 * ld] = {0.3, -2.0, 3.0, 0.0, /* y */ 1.0, 0.5, -0.25, 0.0};
    const double f[ld] = {0.1, -0.3, 0.0, 0.0};
    double dxdt[2 * ld], jac[4 * ld], div[ld];
    std::int32_t status[ld];
    s.rhs(3, ld, t, x, f, dxdt, status);
    s.jacobian(3, ld, t, x, f, jac, status);
    s.divergence(3, ld, t, x, f, div, status);
    for (std::size_t k = 0; k < 3; ++k) {
        CAPTURE(k);
        const double xk = x[k], yk = x[ld + k];
        CHECK(dxdt[k] == yk);
        // The same operations in the same order: equal up to the libm sin (< 1 ulp of its result).
        CHECK(std::fabs(dxdt[ld + k] - (-w0 * w0 * std::sin(xk) - c * yk + f[k])) <= 4 * DBL_EPSILON);
        CHECK(jac[k] == 0.0);
        CHECK(jac[ld + k] == 1.0);
        CHECK(std::fabs(jac[2 * ld + k] + w0 * w0 * std::cos(xk)) <= 4 * DBL_EPSILON);
        CHECK(jac[3 * ld + k] == -c);
        CHECK(div[k] == -c);
    }
}

TEST_CASE("pendulum: small swings follow the damped linear oscillator") {
    // x'' + c x' + w0^2 x = 0 with x(0) = a, x'(0) = 0: x = e^{-ct/2} (a cos wd t + (c a / (2 wd)) sin wd t),
    // wd = sqrt(w0^2 - c^2/4). The pendulum's sin x = x - x^3/6 + ... shifts the frequency by about w0 a^2 / 16,
    // so after time T the phase is off by w0 a^2 T / 16 and x by at most a times that.
    const double w0 = 2.0, c = 0.3, a = 1e-3, T = 10.0;
    const System s = test::make_system("pendulum", {{"omega0", w0}, {"damping", c}});
    const Forcing none = test::make_forcing("none");
    const FlowMap r = flow_map_at_points({Dynamics{&s, &none}, 0.0, T, test::tight_integrator()}, {a}, {0.0});
    REQUIRE(r.mask[0] == 0);
    const double wd = std::sqrt(w0 * w0 - c * c / 4);
    const double decay = std::exp(-c * T / 2);
    const double x = decay * (a * std::cos(wd * T) + c * a / (2 * wd) * std::sin(wd * T));
    const double y = decay * (-(c / 2) * (a * std::cos(wd * T) + c * a / (2 * wd) * std::sin(wd * T)) +
                              (-a * wd * std::sin(wd * T) + c * a / 2 * std::cos(wd * T)));
    const double tol = a * w0 * a * a * T / 16; // 1.25e-9
    CHECK(std::fabs(r.flow_x[0] - x) <= tol);
    CHECK(std::fabs(r.flow_y[0] - y) <= w0 * tol);
}

TEST_CASE("pendulum: without damping or forcing, energy y^2/2 + w0^2 (1 - cos x) is conserved") {
    const double w0 = 1.3;
    const System s = test::make_system("pendulum", {{"omega0", w0}});
    const Forcing none = test::make_forcing("none");
    // Librations, and a rotation above the separatrix (energy 2 w0^2 = 3.38).
    const std::vector<double> x0 = {0.5, 2.5, 3.1, 0.0}, y0 = {0.0, 0.0, 0.2, 3.0};
    const FlowMap r = flow_map_at_points({Dynamics{&s, &none}, 0.0, 30.0, test::tight_integrator()}, x0, y0);
    auto energy = [w0](double x, double y) { return 0.5 * y * y + w0 * w0 * (1 - std::cos(x)); };
    for (std::size_t k = 0; k < x0.size(); ++k) {
        CAPTURE(k);
        REQUIRE(r.mask[k] == 0);
        // dopri5 at rtol 1e-12: a few thousand steps, each off by <= 1e-12 relative: the drift stays below 1e-8.
        CHECK(std::fabs(energy(r.flow_x[k], r.flow_y[k]) - energy(x0[k], y0[k])) <= 1e-8 * energy(x0[k], y0[k]));
    }
}

TEST_CASE("pendulum: det DF = exp(-damping T) (Liouville), forced or not") {
    const double c = 0.25, T = 8.0;
    const System s = test::make_system("pendulum", {{"damping", c}});
    const Forcing cosine = test::make_forcing("cosine", {{"amplitude", 0.4}});
    const FlowMap r =
        flow_map_at_points({Dynamics{&s, &cosine}, 0.0, T, test::tight_integrator(), GradientMethod::variational, true},
                           {0.3, -1.0}, {0.0, 0.7});
    for (std::size_t k = 0; k < 2; ++k) {
        REQUIRE(r.mask[k] == 0);
        const double *F = &r.dF[4 * k];
        // DF is integrated to rtol 1e-12 per entry; the determinant of entries of size |DF| <= 10 keeps 1e-9.
        CHECK(std::fabs(F[0] * F[3] - F[1] * F[2] - std::exp(-c * T)) <= 1e-9);
    }
}

TEST_CASE("pendulum: passes the conformance checks") {
    for (const nlohmann::json &params : {nlohmann::json::object(), nlohmann::json{{"omega0", 2.0}, {"damping", 0.3}}}) {
        ConformanceOptions options;
        options.params = params;
        const auto checks = check_plugin(pendulum(), options);
        INFO(params.dump(), "\n", format_checks(checks));
        CHECK(all_passed(checks));
    }
}
