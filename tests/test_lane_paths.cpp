// The vectorised paths of the line field and of sampling give the scalar paths' values bit for bit:
// LineField::evaluate_lanes against LineField::evaluate, sample_interleaved_along against sample_along. Built twice:
// as test_lane_paths, against the core as built, and as test_lane_paths_avx2, which compiles the core's line field
// and curves itself for AVX2 without AVX-512 (-march=x86-64-v3), the code path of CPUs without AVX-512, which the
// core as built on an AVX-512 machine never runs (tests/CMakeLists.txt).
#include <geobarrier/curves.hpp>
#include <geobarrier/line_field.hpp>

#include "line_fields.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <vector>

using namespace geobarrier;
using geobarrier::test::box;
using geobarrier::test::circles;

TEST_CASE("LineField::evaluate_lanes gives evaluate's status and vector bit for bit") {
    // The lane evaluation finds a cell's status from NaNs stored for unusable points and runs vectorised; the
    // scalar one reads the cell codes. Random points inside, on the edges, outside and NaN, around masked and
    // singular points, with random nonzero references, in a count that is no multiple of the lane chunk.
    const Grid g = box(0.5, 1.5, 0.2, 1.2, 41, 31);
    CauchyGreenField cg = circles(g, 5);
    std::mt19937 rng(17);
    std::uniform_int_distribution<std::size_t> point(0, g.size() - 1);
    for (int k = 0; k < 40; ++k) cg.mask[point(rng)] = mask_left_bounds;
    for (int k = 0; k < 40; ++k) {
        const std::size_t p = point(rng);
        cg.lambda1[p] = cg.lambda2[p] * (1 - 1e-5);
    }
    const LineField f = LineField::from_cauchy_green(cg, 1, 1e-3);
    const std::size_t n = 1000;
    std::uniform_real_distribution<double> xs(0.4, 1.6), ys(0.1, 1.3), ref(-1.0, 1.0);
    std::vector<double> x(n), y(n), rx(n), ry(n), vx(n), vy(n);
    for (std::size_t k = 0; k < n; ++k) {
        x[k] = xs(rng);
        y[k] = ys(rng);
        rx[k] = ref(rng);
        ry[k] = ref(rng);
    }
    x[0] = g.x_max; // the far corner belongs to the box
    y[0] = g.y_max;
    x[1] = g.x_min;
    x[2] = std::nan("");
    y[3] = HUGE_VAL;
    std::vector<std::uint8_t> status(n);
    f.evaluate_lanes(n, x.data(), y.data(), rx.data(), ry.data(), vx.data(), vy.data(), status.data());
    std::size_t counts[4] = {0, 0, 0, 0};
    for (std::size_t k = 0; k < n; ++k) {
        double sx = rx[k], sy = ry[k];
        const LineStatus s = f.evaluate(x[k], y[k], rx[k], ry[k], sx, sy);
        REQUIRE(static_cast<int>(status[k]) == static_cast<int>(s));
        ++counts[status[k]];
        if (s == LineStatus::ok) {
            CHECK(vx[k] == sx); // bit for bit
            CHECK(vy[k] == sy);
        } else {
            CHECK(vx[k] == rx[k]); // the reference, so that no NaN reaches a lane's next stage
            CHECK(vy[k] == ry[k]);
        }
    }
    // Every status occurs, so each branch of the lane code was compared.
    for (std::size_t c = 0; c < 4; ++c) CHECK(counts[c] > 0);
}

TEST_CASE("several fields sampled in one pass give sample_along's values bit for bit; partial segment lengths") {
    const Grid g = box(-1.3, 2.1, -0.7, 0.9, 37, 23);
    // Two non-bilinear fields, one with a NaN and an infinite point and one with a masked point given as NaN.
    std::vector<double> a(g.size()), b(g.size());
    for (std::size_t p = 0; p < g.size(); ++p) {
        a[p] = std::sin(0.37 * static_cast<double>(p)) * 1e-3;
        b[p] = std::log(1.5 + std::cos(0.11 * static_cast<double>(p)));
    }
    a[5 * g.nx + 7] = std::nan("");
    a[3 * g.nx + 30] = HUGE_VAL; // an overflowed value: as unusable as a NaN
    std::vector<std::uint8_t> mask(g.size(), 0);
    mask[11 * g.nx + 20] = mask_left_bounds;
    std::vector<double> both(2 * g.size());
    for (std::size_t p = 0; p < g.size(); ++p) {
        both[2 * p] = a[p];
        both[2 * p + 1] = mask[p] ? std::nan("") : b[p];
    }
    // A wandering polyline that leaves the box, crosses the bad points and ends on the box's far corner.
    std::vector<double> xy;
    for (int k = 0; k < 2000; ++k) {
        const double t = 0.01 * k;
        xy.push_back(0.4 + 1.9 * std::sin(1.3 * t) * std::cos(0.21 * t));
        xy.push_back(0.1 + 0.95 * std::cos(0.7 * t + 0.3));
    }
    xy.insert(xy.end(), {g.x(7), g.y(5), g.x(30), g.y(3), g.x(20) + 1e-3, g.y(11) - 1e-3, g.x_max, g.y_max});
    std::vector<double> sampled[2];
    sample_interleaved_along(g, both, 2, xy, sampled);
    const std::vector<double> sa = sample_along(g, a, {}, xy), sb = sample_along(g, b, mask, xy);
    REQUIRE(sampled[0].size() == sa.size());
    REQUIRE(sampled[1].size() == sa.size());
    // How many values differ, NaN counting as equal to NaN only.
    const auto differing = [](const std::vector<double> &u, const std::vector<double> &v) {
        std::size_t count = 0;
        for (std::size_t k = 0; k < u.size(); ++k) count += !((std::isnan(u[k]) && std::isnan(v[k])) || u[k] == v[k]);
        return count;
    };
    CHECK(differing(sampled[0], sa) == 0);
    CHECK(differing(sampled[1], sb) == 0);
    const auto nan_a =
        static_cast<std::size_t>(std::count_if(sa.begin(), sa.end(), [](double v) { return std::isnan(v); }));
    const auto nan_b =
        static_cast<std::size_t>(std::count_if(sb.begin(), sb.end(), [](double v) { return std::isnan(v); }));
    CHECK(nan_a > 0); // the polyline met the unknown and infinite points, the box's edge ...
    CHECK(nan_b > 0); // ... and the masked one
    CHECK(nan_b < sa.size() / 2);
    CHECK(std::isnan(sampled[0][2001])); // the infinite point's own value
    CHECK_THROWS_AS(sample_interleaved_along(g, a, 2, xy, sampled), std::invalid_argument);
    // One field alone: sample_along's values too.
    sample_interleaved_along(g, a, 1, xy, sampled);
    CHECK(differing(sampled[0], sa) == 0);

    // Partial segment lengths are the whole polyline's, bit for bit, on the stretch asked for and nowhere else.
    const std::vector<double> whole = segment_lengths(xy);
    std::vector<double> part(whole.size(), -1.0);
    segment_lengths(xy.data(), 100, 700, part.data());
    for (std::size_t k = 0; k < part.size(); ++k) {
        if (k >= 100 && k < 700)
            CHECK(part[k] == whole[k]);
        else
            CHECK(part[k] == -1.0);
    }
}
