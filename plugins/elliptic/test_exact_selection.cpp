// The elliptic extractor's selection on exact <d_g> (selection_deviation "exact", docs/extractors.md, elliptic step
// 4): Alg. 2's test compares the mean of d_g from exact Cauchy-Green tensors with max_mean_deviation, for every closed
// shearline the rest of the test would keep, and barriers.json says so. The unforced Duffing's right well on a small
// grid: a few seconds.
#include "elliptic_test_runs.hpp"

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <string>
#include <vector>

using namespace geobarrier;
using elliptic::test_runs::run;
using nlohmann::json;

namespace {

// Right well of x'' = x - x^3 over T = 8 pi on a small grid: about 70 closed eta- shearlines, whose grid and exact
// <d_g> differ by up to a few hundredths.
json right_well(const std::string &selection, double max_mean_deviation) {
    return {{"system", {{"plugin", "duffing"}, {"params", {{"alpha", 1}, {"beta", 1}, {"delta", 0}}}}},
            {"grid", {{"x", {0.2, 1.8}}, {"y", {-0.75, 0.75}}, {"n", {121, 111}}}},
            {"time", {{"t0", 0.0}, {"t1", 8 * M_PI}}},
            {"integrator", {{"rtol", 1e-9}, {"atol", 1e-11}}},
            {"extractors",
             {{{"plugin", "elliptic"},
               {"params",
                {{"launch_points", 100},
                 {"max_mean_deviation", max_mean_deviation},
                 {"exact_deviation_points", 64},
                 {"selection_deviation", selection},
                 {"barrier_spacing", 0.0},
                 {"advect", "none"}}}}}},
            {"output", {{"plots", false}}}};
}

// The closed shearlines of elliptic-sections.json, region by region.
std::vector<json> closed_shearlines(const json &sections) {
    std::vector<json> all;
    for (const json &region : sections["regions"])
        for (const json &c : region["closed_shearlines"]) all.push_back(c);
    return all;
}

} // namespace

TEST_CASE("selection on exact <d_g>: kept exactly where the exact mean passes, and barriers.json says so") {
    // First every closed shearline on the regular side kept, to read both means; then a threshold halfway between
    // the grid's and the exact mean of the curve where they differ most, so that the two rules disagree on it.
    json sections;
    run(right_well("exact", 1e9), "exact-selection-all", &sections);
    const double ftle_threshold = sections["ftle_threshold"].get<double>();
    std::vector<json> closed = closed_shearlines(sections);
    REQUIRE(closed.size() >= 20);
    double threshold = 0.0, widest = 0.0;
    for (const json &c : closed) {
        const bool regular = c["mean_ftle"].is_number() && c["mean_ftle"].get<double>() < ftle_threshold;
        // Every closed shearline on the regular side has its exact <d_g>.
        if (!regular) continue;
        REQUIRE(c["mean_geodesic_deviation_exact"].is_number());
        const double grid = c["mean_geodesic_deviation"].get<double>();
        const double exact = c["mean_geodesic_deviation_exact"].get<double>();
        if (std::abs(grid - exact) > widest) {
            widest = std::abs(grid - exact);
            threshold = 0.5 * (grid + exact);
        }
    }
    MESSAGE(closed.size() << " closed shearlines; grid and exact <d_g> differ by up to " << widest);
    REQUIRE(widest > 1e-3);

    const json barriers = run(right_well("exact", threshold), "exact-selection", &sections)["barriers"];
    closed = closed_shearlines(sections);
    std::size_t kept = 0, kept_by_grid = 0;
    for (const json &c : closed) {
        const bool regular = c["mean_ftle"].is_number() && c["mean_ftle"].get<double>() < ftle_threshold;
        const bool passes = regular && c["mean_geodesic_deviation_exact"].get<double>() < threshold;
        CAPTURE(c["mean_geodesic_deviation_exact"]);
        CHECK(c["kept"].get<bool>() == passes);
        kept += passes ? 1 : 0;
        kept_by_grid += regular && c["mean_geodesic_deviation"].get<double>() < threshold ? 1 : 0;
    }
    MESSAGE(kept << " kept on exact <d_g> < " << threshold << " (the grid's <d_g> would keep " << kept_by_grid << ")");
    CHECK(kept >= 1);
    CHECK(kept < closed.size()); // the threshold separates them
    // The barriers are the kept closed shearlines, near-identical ones merged.
    REQUIRE(!barriers.empty());
    CHECK(barriers.size() <= kept);
    for (const json &b : barriers) {
        CHECK(b["selection"].get<std::string>().find("eta-line, exact <d_g> < ") == 0);
        CHECK(b["mean_geodesic_deviation_exact"].get<double>() < threshold);
    }
}

TEST_CASE("selection on the grid's <d_g> (the default) keeps by the grid's mean and computes no exact one") {
    json sections;
    const json barriers = run(right_well("grid", 0.3), "grid-selection", &sections)["barriers"];
    for (const json &c : closed_shearlines(sections)) CHECK(c["mean_geodesic_deviation_exact"].is_null());
    REQUIRE(!barriers.empty());
    for (const json &b : barriers) {
        CHECK(b["selection"].get<std::string>() == "eta-line, <d_g> < 0.3");
        CHECK(b["mean_geodesic_deviation"].get<double>() < 0.3);
        CHECK(!b.contains("mean_geodesic_deviation_exact"));
    }
}
