// Tests of the elliptic extractor's lambda-line fallback (docs/extractors.md, elliptic step 8): where no closed
// shearline passes the <d_g> test, the outermost closed generalized lambda-line is reported, with how it was
// selected; with the fallback off, nothing is. Small grids: a few seconds each.
#include "closed_shearlines.hpp"
#include "elliptic_test_runs.hpp"

#include <geobarrier/curves.hpp>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <string>

using namespace geobarrier;
using namespace geobarrier::elliptic;
using nlohmann::json;
using test_runs::points_of;
using test_runs::radius_stats;
using test_runs::RadiusStats;
using test_runs::run;

namespace {

// The contracting circular shear (test system `circular-shear`, c = 0.02, T = 8): every circle around the origin
// shrinks uniformly by e^(-cT) while turning, so the circles are the closed lambda-lines of lambda = e^(-cT) =
// 0.8521 and of no other lambda. max_mean_deviation 0 makes the eta-line search keep nothing, so that the fallback
// runs; 0.8521 lies between two lambdas of the scan (0.84, 0.86), where the bisection has to find it.
json contracting_circular_shear(bool fallback) {
    return {
        {"system", {{"plugin", "circular-shear"}, {"params", {{"omega", 1.0}, {"shear", 0.5}, {"contraction", 0.02}}}}},
        {"grid", {{"x", {-1.0, 1.0}}, {"y", {-1.0, 1.0}}, {"n", {121, 121}}}},
        {"time", {{"t0", 0.0}, {"t1", 8.0}}},
        {"integrator", {{"rtol", 1e-10}, {"atol", 1e-12}}},
        {"extractors",
         {{{"plugin", "elliptic"},
           {"params",
            {{"max_mean_deviation", 0.0},
             {"launch_points", 100},
             {"lambda_fallback", fallback},
             {"lambda_min", 0.8}}}}}},
        {"output", {{"plots", false}}}};
}

// The double gyre (Shadden, Lekien & Marsden 2005) over T = 15 on a coarse grid: one candidate region, whose closed
// eta- shearlines all have grid <d_g> above 1 (docs/extractors.md).
json double_gyre(const json &elliptic_params) {
    return {{"system", {{"plugin", "double-gyre"}}},
            {"grid", {{"x", {0.0, 2.0}}, {"y", {0.0, 1.0}}, {"n", {201, 101}}}},
            {"time", {{"t0", 0.0}, {"t1", 15.0}}},
            {"extractors", {{{"plugin", "elliptic"}, {"params", elliptic_params}}}},
            {"output", {{"plots", false}}}};
}

bool starts_with(const std::string &s, const std::string &prefix) { return s.rfind(prefix, 0) == 0; }

} // namespace

TEST_CASE("lambda-line fallback, contracting circular shear: the outermost closed lambda = e^(-cT) circle") {
    const double lambda_star = std::exp(-0.02 * 8.0), h = 2.0 / 120.0;
    json sections;
    const json b = run(contracting_circular_shear(true), "fallback-circles", &sections)["barriers"];
    REQUIRE(b.size() == 1);
    const json &barrier = b[0];
    CHECK(
        starts_with(barrier["selection"].get<std::string>(), "lambda-line fallback (no eta-line barrier in region 0)"));
    const double lambda = barrier["lambda"].get<double>();
    const RadiusStats r = radius_stats(points_of(barrier));
    // Advected length / length: e^(-cT) on a circle (to 1e-5: the curve is a circle to a few 1e-4, and its
    // stretching departs from e^(-cT) to second order in that), and within lambda_step / 2 (0.01) of its lambda.
    const double stretching = barrier["advected_stretching"].get<double>();
    MESSAGE("fallback: lambda " << lambda << " (e^(-cT) = " << lambda_star << "), radius " << r.mean << ", spread "
                                << r.spread << ", advected length / length " << stretching);
    // Bisection from the scan's interval [0.84, 0.86]: the lambda is found to a few halvings of 0.02.
    CHECK(std::abs(lambda - lambda_star) < 2.5e-3);
    CHECK(r.spread < 0.1 * h); // a circle, to a tenth of a grid spacing
    CHECK(std::abs(stretching - lambda_star) < 1e-5);
    CHECK(std::abs(barrier["relative_length_change"].get<double>() + 1.0 - stretching) < 1e-12);
    CHECK(std::abs(stretching - lambda) <= 0.01);
    // The outermost: no closed lambda-line kept at that lambda lies outside it. The explicit lambda run at the same
    // lambda reports every closed lambda-line (thinned): its largest circle is this one, within a grid spacing.
    json explicit_lambda = contracting_circular_shear(false);
    explicit_lambda["extractors"][0]["params"] = {{"lambda", lambda}, {"launch_points", 100}};
    const json all = run(explicit_lambda, "fallback-circles-explicit")["barriers"];
    double largest = 0.0;
    for (const json &other : all) largest = std::max(largest, radius_stats(points_of(other)).mean);
    MESSAGE("largest of " << all.size() << " closed lambda-lines at lambda " << lambda << " (lambda parameter): radius "
                          << largest);
    CHECK(std::abs(largest - r.mean) < h);
    // The log's figures are in elliptic-sections.json: every lambda tried, the scan's and the bisection's.
    std::size_t tried = 0;
    for (const json &t : sections["lambda_fallback"]) tried += t["region"] == 0 ? 1 : 0;
    CHECK(tried > 2 * 16); // 16 lambdas in [0.8, 1.1], two families, then the bisection
}

TEST_CASE("lambda-line fallback off: where no shearline passes <d_g>, nothing is reported (the behaviour before)") {
    CHECK(run(contracting_circular_shear(false), "fallback-off")["barriers"].empty());
    CHECK(run(double_gyre({{"lambda_fallback", false}}), "fallback-off-gyre")["barriers"].empty());
}

TEST_CASE("selection: barriers whose eta-lines pass say so, and the fallback does not run in their region") {
    json e = contracting_circular_shear(true);
    e["extractors"][0]["params"]["max_mean_deviation"] = 0.5; // its closed shearlines: <d_g> from 0.071 up
    const json b = run(e, "selection-eta")["barriers"];
    REQUIRE(!b.empty());
    for (const json &barrier : b) {
        CHECK(barrier["selection"] == "eta-line, <d_g> < 0.5");
        CHECK(barrier.contains("mean_geodesic_deviation"));
        CHECK(!barrier.contains("lambda"));
    }
}

TEST_CASE("lambda-line fallback, double gyre: a closed lambda-line around the gyre's region, stretched by lambda") {
    json sections;
    const json b = run(double_gyre(json::object()), "fallback-gyre", &sections)["barriers"];
    REQUIRE(b.size() == 1);
    const json &barrier = b[0];
    const std::vector<double> xy = points_of(barrier);
    const json &region = sections["regions"][0];
    // The eta-line search found closed shearlines there and kept none: why the fallback ran.
    std::size_t closed = 0, kept = 0;
    for (const json &r : sections["regions"]) {
        closed += r["closed"].get<std::size_t>();
        kept += r["kept"].get<std::size_t>();
    }
    CHECK(closed > 0);
    CHECK(kept == 0);
    CHECK(
        starts_with(barrier["selection"].get<std::string>(), "lambda-line fallback (no eta-line barrier in region 0)"));
    CHECK(encloses(xy, region["centre"][0].get<double>(), region["centre"][1].get<double>()));
    const double lambda = barrier["lambda"].get<double>(), stretching = barrier["advected_stretching"].get<double>();
    MESSAGE("double gyre 201 x 101: lambda " << lambda << ", advected length / length " << stretching
                                             << ", enclosed area " << barrier["enclosed_area"].get<double>());
    CHECK(lambda >= 0.9);
    CHECK(lambda <= 1.1);
    // The extractor keeps only curves its own advection finds stretched by lambda; advected here independently, with
    // the library's flow map at a tight tolerance, the curve must be a lambda-line too (|DF e| = lambda |e|).
    const System gyre = test::make_system("double-gyre");
    const Forcing none = test::make_forcing("none");
    IntegratorSettings tight;
    tight.rtol = 1e-10;
    tight.atol = 1e-12;
    const AdvectedCurve image = advect_curve(xy, true, make_advect_points_fn(Dynamics{&gyre, &none}, 0.0, 15.0, tight));
    REQUIRE(image.converged);
    const double independent = image.length1 / image.length0;
    MESSAGE("independent advection: length ratio " << independent);
    CHECK(std::abs(independent - lambda) <= 0.01); // lambda_step / 2
    CHECK(std::abs(independent - stretching) < 1e-3);
    CHECK(barrier["outermost"] == true);
}
