// Tests of the shear vortex against its known answers: circles rotate rigidly by w(r) T, the FTLE is
// asinh(|shear| r^2 |T|) / |T| in both time directions, det DF = 1, and <e_theta, C e_theta> = 1 (every circle is a
// closed shearline). Plus the conformance checks.
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <geobarrier/flow_map.hpp>
#include <test_support.hpp>

#include <cmath>
#include <vector>

using namespace geobarrier;

namespace {
const PluginHandle &vortex() { return test::registry().find(PluginKind::system, "shear-vortex", "/system/plugin"); }
} // namespace

TEST_CASE("shear-vortex: flow map, FTLE, det DF and the closed shearlines, as derived") {
    const double omega = 0.7, shear = -0.4;
    const System s = test::make_system("shear-vortex", {{"omega", omega}, {"shear", shear}});
    const Forcing none = test::make_forcing("none");
    std::vector<double> x0, y0;
    for (int k = 0; k < 12; ++k) {
        const double r = 0.1 + 0.15 * k, angle = 0.9 * k;
        x0.push_back(r * std::cos(angle));
        y0.push_back(r * std::sin(angle));
    }
    IntegratorSettings tight;
    tight.rtol = 1e-12;
    tight.atol = 1e-14;
    for (double T : {5.0, -3.0}) {
        CAPTURE(T);
        const FlowMap res =
            flow_map_at_points({Dynamics{&s, &none}, 0.0, T, tight, GradientMethod::variational, true}, x0, y0);
        for (std::size_t k = 0; k < x0.size(); ++k) {
            CAPTURE(k);
            REQUIRE(res.mask[k] == 0);
            const double r2 = x0[k] * x0[k] + y0[k] * y0[k], r = std::sqrt(r2);
            // F rotates by theta = w(r) T; |theta| <= 4 rad here, integrated to ~1e-12 relative per step.
            const double theta = (omega + shear * r2) * T;
            CHECK(std::fabs(res.flow_x[k] - (x0[k] * std::cos(theta) - y0[k] * std::sin(theta))) <= 1e-9);
            CHECK(std::fabs(res.flow_y[k] - (x0[k] * std::sin(theta) + y0[k] * std::cos(theta))) <= 1e-9);
            // C = DF^T DF; in polar frames DF = [[1, 0], [gamma, 1]], gamma = 2 shear r^2 T: lambda2 =
            // (sqrt(1 + gamma^2/4) + |gamma|/2)^2, so log(lambda2) / (2|T|) = asinh(|shear| r^2 |T|) / |T|.
            const double *F = &res.dF[4 * k];
            const double c11 = F[0] * F[0] + F[2] * F[2], c12 = F[0] * F[1] + F[2] * F[3],
                         c22 = F[1] * F[1] + F[3] * F[3];
            const double half_trace = 0.5 * (c11 + c22), det = c11 * c22 - c12 * c12;
            const double lambda2 = half_trace + std::sqrt(half_trace * half_trace - det);
            const double ftle = std::log(lambda2) / (2 * std::fabs(T));
            const double expected = std::asinh(std::fabs(shear) * r2 * std::fabs(T)) / std::fabs(T);
            CHECK(std::fabs(ftle - expected) <= 1e-9);
            CHECK(std::fabs(F[0] * F[3] - F[1] * F[2] - 1.0) <= 1e-9);
            // e_theta = (-y, x) / r is stretched by exactly 1: the circle through x0 is a closed shearline.
            const double ex = -y0[k] / r, ey = x0[k] / r;
            CHECK(std::fabs(c11 * ex * ex + 2 * c12 * ex * ey + c22 * ey * ey - 1.0) <= 1e-9);
        }
    }
}

TEST_CASE("shear-vortex: shear = 0 is a rigid rotation, C = I") {
    const System s = test::make_system("shear-vortex", {{"omega", 2.0}, {"shear", 0.0}});
    const Forcing none = test::make_forcing("none");
    IntegratorSettings tight;
    tight.rtol = 1e-12;
    tight.atol = 1e-14;
    const FlowMap r = flow_map_at_points({Dynamics{&s, &none}, 0.0, 3.0, tight, GradientMethod::variational, true},
                                         {0.5, -1.0}, {0.25, 0.3});
    for (std::size_t k = 0; k < 2; ++k) {
        const double *F = &r.dF[4 * k];
        CHECK(std::fabs(F[0] - std::cos(6.0)) <= 1e-9);
        CHECK(std::fabs(F[1] + std::sin(6.0)) <= 1e-9);
        CHECK(std::fabs(F[2] - std::sin(6.0)) <= 1e-9);
        CHECK(std::fabs(F[3] - std::cos(6.0)) <= 1e-9);
    }
}

TEST_CASE("shear-vortex: passes the conformance checks") {
    for (const nlohmann::json &params : {nlohmann::json::object(), nlohmann::json{{"omega", -1.0}, {"shear", 3.0}}}) {
        ConformanceOptions options;
        options.params = params;
        const auto checks = check_plugin(vortex(), options);
        INFO(params.dump(), "\n", format_checks(checks));
        CHECK(all_passed(checks));
        for (const auto &c : checks) CHECK_FALSE(c.skipped); // forcing_ignored is verified, not skipped
    }
}
