// Tests of the ramp forcing: r(s) in closed form for the three shapes, 0 before the start, the base after the end,
// flat ends to the promised order, composition with other composites, and the shared conformance checks.
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <test_support.hpp>

#include <cfloat>
#include <cmath>
#include <string>
#include <vector>

using namespace geobarrier;

namespace {
const PluginHandle &ramp_handle() { return test::registry().find(PluginKind::forcing, "ramp", "/forcing/plugin"); }

Forcing make_ramp(const nlohmann::json &params, const Forcing &base) {
    return Forcing(ramp_handle(), validate_params(ramp_handle().info, params, "/forcing/params"), {base});
}
} // namespace

TEST_CASE("ramp: f = r((t - start) / duration) base(t)") {
    const Forcing base = test::make_forcing("cosine", {{"amplitude", 0.5}, {"omega", 1.3}});
    const double start = 2.0, duration = 4.0;
    // r(1/4) in closed form for each shape.
    const double quarter[] = {1.0 / (1.0 + std::exp(4.0 - 4.0 / 3.0)), 10.0 / 64 - 15.0 / 256 + 6.0 / 1024,
                              3.0 / 16 - 2.0 / 64};
    const char *shapes[] = {"smooth", "quintic", "cubic"};
    for (int i = 0; i < 3; ++i) {
        CAPTURE(shapes[i]);
        const Forcing f = make_ramp({{"start", start}, {"duration", duration}, {"shape", shapes[i]}}, base);
        for (double t : {-5.0, 0.0, start}) CHECK(f(t) == 0.0);
        for (double t : {start + duration, 7.0, 30.0}) CHECK(f(t) == base(t));
        CHECK(f(start + duration / 2) == 0.5 * base(start + duration / 2)); // r(1/2) = 1/2 by symmetry
        const double t = start + duration / 4;
        CHECK(std::fabs(f(t) - quarter[i] * base(t)) <= 4 * DBL_EPSILON);
        // r(1 - s) = 1 - r(s).
        const double t3 = start + 3 * duration / 4;
        CHECK(std::fabs(f(t3) - (1.0 - quarter[i]) * base(t3)) <= 4 * DBL_EPSILON);
    }
}

TEST_CASE("ramp: r rises monotonically and its ends are flat to the promised order") {
    const Forcing one = test::make_forcing("cosine", {{"amplitude", 1.0}, {"omega", 0.0}}); // f = 1
    const Forcing smooth = make_ramp({{"duration", 1.0}}, one);
    const Forcing quintic = make_ramp({{"duration", 1.0}, {"shape", "quintic"}}, one);
    const Forcing cubic = make_ramp({{"duration", 1.0}, {"shape", "cubic"}}, one);
    for (const Forcing *f : {&smooth, &quintic, &cubic}) {
        double previous = 0.0;
        for (double s = 0.0; s <= 1.0; s += 1.0 / 64) {
            CHECK((*f)(s) >= previous);
            previous = (*f)(s);
        }
    }
    // Near s = 0: cubic ~ 3 s^2 (C1), quintic ~ 10 s^3 (C2), and smooth = 1 / (1 + e^{1/s - 1/(1-s)}) below
    // e^{2 - 1/s} for s <= 1/2: flatter than any power of s (all derivatives 0).
    const double s = 1e-3;
    CHECK(cubic(s) / (s * s) == doctest::Approx(3.0).epsilon(1e-2));
    CHECK(quintic(s) / (s * s * s) == doctest::Approx(10.0).epsilon(1e-2));
    for (double small : {0.2, 0.05, 0.02}) CHECK(smooth(small) <= std::exp(2.0 - 1.0 / small));
    CHECK(smooth(0.02) / std::pow(0.02, 5) < 1e-12);
    // And symmetrically near s = 1.
    CHECK((1.0 - cubic(1.0 - s)) / (s * s) == doctest::Approx(3.0).epsilon(1e-2));
    CHECK((1.0 - quintic(1.0 - s)) / (s * s * s) == doctest::Approx(10.0).epsilon(1e-2));
}

TEST_CASE("ramp: composes with other composites (a ramp of a sum)") {
    const Forcing a = test::make_forcing("cosine", {{"amplitude", 0.2}});
    const Forcing b = test::make_forcing("cosine", {{"amplitude", 0.1}, {"omega", 3.0}});
    const PluginHandle &sum = test::registry().find(PluginKind::forcing, "sum", "/forcing/plugin");
    const Forcing total(sum, validate_params(sum.info, {}, "/forcing/params"), {a, b});
    const Forcing f = make_ramp({{"duration", 2.0}, {"shape", "cubic"}}, total);
    for (double t : {0.5, 1.0, 3.0}) {
        const double s = std::min(t / 2.0, 1.0), r = s * s * (3.0 - 2.0 * s);
        CHECK(std::fabs(f(t) - r * (a(t) + b(t))) <= 4 * DBL_EPSILON);
    }
}

TEST_CASE("ramp: passes the conformance checks") {
    for (const char *shape : {"smooth", "quintic", "cubic"}) {
        ConformanceOptions options;
        options.params = {{"start", -3.0}, {"duration", 5.0}, {"shape", shape}}; // the ramp inside [-10, 10]
        const auto checks = check_plugin(ramp_handle(), options);
        INFO(shape, "\n", format_checks(checks));
        CHECK(all_passed(checks));
    }
}
