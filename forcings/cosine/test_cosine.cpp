// Tests of the cosine forcing: values against
// amplitude cos(omega t + phase), periodicity, and the shared conformance checks.
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <test_support.hpp>

#include <cfloat>
#include <cmath>
#include <vector>

using namespace geobarrier;

namespace {
constexpr double pi = 3.141592653589793;
const PluginHandle &cosine() { return test::registry().find(PluginKind::forcing, "cosine", "/forcing/plugin"); }
} // namespace

TEST_CASE("cosine: values") {
    SUBCASE("defaults: 0.08 cos t") {
        const Forcing f = test::make_forcing("cosine");
        CHECK(f(0.0) == 0.08); // cos 0 = 1 exactly
        CHECK(f(pi) == -0.08); // cos(pi rounded) = -1 + 1e-33: rounds to -1
        // cos(pi/2 rounded) = 6.1e-17: f is 0.08 times that.
        CHECK(std::fabs(f(pi / 2)) < 1e-17);
    }
    SUBCASE("amplitude cos(omega t + phase) at a batch of times") {
        const double amplitude = 0.3, omega = 2.5, phase = -0.7;
        const Forcing f = test::make_forcing("cosine", {{"amplitude", amplitude}, {"omega", omega}, {"phase", phase}});
        const std::vector<double> t = {-12.0, -1.25, 0.0, 0.4, 3.0, 25.132741228718345};
        std::vector<double> out(t.size());
        f.evaluate(t.size(), t.data(), out.data());
        for (std::size_t k = 0; k < t.size(); ++k) {
            CAPTURE(t[k]);
            // Same formula in the same order: only the libm cos can differ (faithfully rounded, < 1 ulp).
            CHECK(std::fabs(out[k] - amplitude * std::cos(omega * t[k] + phase)) <= 2 * DBL_EPSILON * amplitude);
        }
    }
    SUBCASE("period 2 pi / omega") {
        const double omega = 1.7;
        const Forcing f = test::make_forcing("cosine", {{"omega", omega}});
        const double period = 2 * pi / omega;
        for (double t : {0.1, 1.0, 7.3}) {
            // The argument omega (t + T) differs from omega t + 2 pi by rounding of about 4 ulp of |omega t| + 2 pi;
            // |f'| <= amplitude, so f changes by at most that much times 0.08.
            const double tol = 0.08 * 8 * DBL_EPSILON * (omega * t + 2 * pi);
            CHECK(std::fabs(f(t + period) - f(t)) <= tol);
        }
    }
}

TEST_CASE("cosine: passes the conformance checks") {
    for (const nlohmann::json &params :
         {nlohmann::json::object(), nlohmann::json{{"amplitude", 0.3}, {"omega", 3.0}, {"phase", 1.0}}}) {
        ConformanceOptions options;
        options.params = params;
        const auto checks = check_plugin(cosine(), options);
        INFO(params.dump(), "\n", format_checks(checks));
        CHECK(all_passed(checks));
    }
}
