// The bench's own arithmetic on known answers: the FTLE errors against an exact field (mean, 99th percentile, max,
// interior max, missing points), the median and spread of per-run ratios, the least of repeated runs, and the
// numbers as the report prints them. Timings are never tested; what the bench does with them is.
#include "fields.hpp"
#include "repeat.hpp"
#include "tables.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <vector>

using namespace geobarrier::bench;

TEST_CASE("ftle_errors: a 10 x 10 field whose error at point k is k / 100, one point missing") {
    // exact = 1 everywhere; ftle = exact + k/100 at row-major index k, so the errors are 0, 0.01, ..., 0.99.
    const std::size_t nx = 10, ny = 10;
    std::vector<double> exact(nx * ny, 1.0), ftle(nx * ny);
    for (std::size_t k = 0; k < ftle.size(); ++k) ftle[k] = 1.0 + 0.01 * static_cast<double>(k);
    // Point 5 masked by the run (NaN) where the exact field is finite: missing, and not among the errors.
    ftle[5] = nan_value;
    // Point 7 has no exact value: neither an error nor missing.
    exact[7] = nan_value;
    const ErrorStats s = ftle_errors(ftle, exact, nx, ny);
    CHECK(s.missing == 1);
    // 98 errors: the sum of k/100 over 0..99 (49.5) without points 5 and 7.
    CHECK(s.mean == doctest::Approx((49.5 - 0.05 - 0.07) / 98).epsilon(1e-12));
    CHECK(s.max == doctest::Approx(0.99).epsilon(1e-12));
    // The interior leaves out max(1, 10 / 50) = 1 point on each side: rows and columns 1..8, largest at (8, 8) = 88.
    CHECK(s.interior_max == doctest::Approx(0.88).epsilon(1e-12));
    // The 99th percentile is the sorted error at index floor(0.99 * 97) = 96: 0, 0.01, ..., 0.04, 0.06, 0.08, ...
    // skip two values below it, so index 96 holds 0.98.
    CHECK(s.p99 == doctest::Approx(0.98).epsilon(1e-12));
}

TEST_CASE("ftle_errors: no finite point gives NaN statistics, every masked point counted") {
    const std::vector<double> exact(4, 2.0), ftle(4, nan_value);
    const ErrorStats s = ftle_errors(ftle, exact, 2, 2);
    CHECK(s.missing == 4);
    CHECK(std::isnan(s.mean));
    CHECK(std::isnan(s.interior_max));
}

TEST_CASE("median and ratio_spread of per-run ratios") {
    CHECK(median({3.0, 1.0, 2.0}) == 2.0);
    CHECK(median({4.0, 1.0, 3.0, 2.0}) == 2.5);
    CHECK(std::isnan(median({})));
    CHECK(ratio_spread({4.0, 1.0, 3.0, 2.0}) == "2.50 (1.00–4.00) over 4 runs");
    // One run: the row's own ratio says it all.
    CHECK(ratio_spread({1.5}) == "–");
}

TEST_CASE("least of repeated runs: the first run is kept, then only faster ones") {
    CHECK(least(nan_value, 3.0) == 3.0);
    CHECK(least(3.0, 4.0) == 3.0);
    CHECK(least(3.0, 2.0) == 2.0);
    LeastTimes t;
    t.keep(5.0, 9.0);
    t.keep(6.0, 8.0); // slower wall, less user CPU: each is kept on its own
    CHECK(t.wall == 5.0);
    CHECK(t.user == 8.0);
}

TEST_CASE("numbers as the report prints them") {
    CHECK(fixed(1.005, 1) == "1.0");
    CHECK(fixed(12.3456, 2) == "12.35");
    CHECK(fixed(nan_value, 2) == "–");
    CHECK(sci(0.000123) == "1.2e-04");
    CHECK(sci(nan_value) == "–");
    CHECK(csv_number(0.1234567) == "0.123457");
    CHECK(csv_number(nan_value).empty());
}
