// Tests of the zero forcing: no parameters, f = 0 at every time. Its conformance checks run in
// tests/sdk/test_check_plugin.cpp, with every built plugin's.
#include <doctest/doctest.h>

#include <geobarrier/errors.hpp>
#include <test_support.hpp>

#include <cmath>
#include <vector>

using namespace geobarrier;

TEST_CASE("none: a parameter it does not declare is refused") {
    CHECK_THROWS_AS(test::make_forcing("none", {{"amplitude", 1.0}}), ConfigError);
}

TEST_CASE("none: f(t) = 0 everywhere") {
    const Forcing f = test::make_forcing("none");
    const std::vector<double> t = {0.0, -1.0, 3.5, 1e300, -1e300, HUGE_VAL};
    std::vector<double> out(t.size(), 7.0);
    f.evaluate(t.size(), t.data(), out.data());
    for (double v : out) CHECK(v == 0.0);
}
