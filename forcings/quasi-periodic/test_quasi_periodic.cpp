// Tests of the quasi-periodic forcing: values, no period, and the shared
// conformance checks.
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <test_support.hpp>

#include <cfloat>
#include <cmath>
#include <vector>

using namespace geobarrier;

namespace {
constexpr double pi = 3.141592653589793;
const PluginHandle &qp() { return test::registry().find(PluginKind::forcing, "quasi-periodic", "/forcing/plugin"); }
} // namespace

TEST_CASE("quasi-periodic: a1 cos(w1 t + p1) + a2 cos(w2 t + p2)") {
    const double a1 = 0.3, w1 = 1.1, p1 = 0.2, a2 = -0.15, w2 = 2.9, p2 = -1.0;
    const Forcing f = test::make_forcing(
        "quasi-periodic",
        {{"amplitude1", a1}, {"omega1", w1}, {"phase1", p1}, {"amplitude2", a2}, {"omega2", w2}, {"phase2", p2}});
    const std::vector<double> t = {-20.0, -0.5, 0.0, 1.0, 7.25, 100.0};
    std::vector<double> out(t.size());
    f.evaluate(t.size(), t.data(), out.data());
    for (std::size_t k = 0; k < t.size(); ++k) {
        CAPTURE(t[k]);
        // The same formula: only the two libm cosines may differ, by < 1 ulp each.
        CHECK(std::fabs(out[k] - (a1 * std::cos(w1 * t[k] + p1) + a2 * std::cos(w2 * t[k] + p2))) <=
              4 * DBL_EPSILON * (std::fabs(a1) + std::fabs(a2)));
    }
    const Forcing defaults = test::make_forcing("quasi-periodic");
    CHECK(defaults(0.0) == 0.08); // both cosines 1 at t = 0: 0.04 + 0.04
}

TEST_CASE("quasi-periodic: the default forcing has no period up to 100") {
    // With w2 / w1 irrational, f(t + P) = f(t) for all t would need both w1 P and w2 P in 2 pi Z. Check that no
    // candidate P = 2 pi m / w1 (m = 1..15, so P <= 100) comes within 1e-3 of a period: the second cosine is off
    // by 0.04 |1 - cos(w2 P)|-ish, bounded below by the distance of m sqrt 2 to the integers (>= 0.07 here).
    const Forcing f = test::make_forcing("quasi-periodic");
    for (int m = 1; m <= 15; ++m) {
        const double P = 2 * pi * m;
        double worst = 0.0;
        for (double t = 0.0; t < 10.0; t += 0.05) worst = std::max(worst, std::fabs(f(t + P) - f(t)));
        CAPTURE(m);
        CHECK(worst > 1e-3);
    }
}

TEST_CASE("quasi-periodic: passes the conformance checks") {
    for (const nlohmann::json &params : {nlohmann::json::object(), nlohmann::json{{"omega2", 3.0}, {"phase1", 2.0}}}) {
        ConformanceOptions options;
        options.params = params;
        const auto checks = check_plugin(qp(), options);
        INFO(params.dump(), "\n", format_checks(checks));
        CHECK(all_passed(checks));
    }
}
