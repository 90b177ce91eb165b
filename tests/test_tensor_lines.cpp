// Tensor-line integration on analytic line fields: accuracy along circles, every stop rule, orientation
// consistency with randomly flipped stored vectors, and no NaN ever returned.
#include <geobarrier/curves.hpp>
#include <geobarrier/tensor_lines.hpp>

#include "line_fields.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

using namespace geobarrier;
using geobarrier::test::box;

namespace {

// Tangents of circles around (cx, cy) with random signs; undefined within `hole` of the centre.
LineField circle_field(const Grid &g, double cx, double cy, double hole, unsigned seed) {
    std::vector<double> vx(g.size()), vy(g.size());
    std::vector<std::uint8_t> undefined(g.size(), 0);
    std::mt19937 rng(seed);
    std::bernoulli_distribution flip(0.5);
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const std::size_t p = i * g.nx + j;
            const double x = g.x(j) - cx, y = g.y(i) - cy, s = flip(rng) ? -1.0 : 1.0;
            vx[p] = -s * y;
            vy[p] = s * x;
            undefined[p] = std::hypot(x, y) < hole ? 1 : 0;
        }
    return LineField(g, vx, vy, {}, undefined);
}

bool all_finite(const std::vector<double> &v) {
    for (double x : v)
        if (!std::isfinite(x)) return false;
    return true;
}

} // namespace

TEST_CASE("a tensor line of a circle field closes on itself, on the circle") {
    const Grid g = box(-1, 1, -1, 1, 101, 101); // h = 0.02
    const LineField f = circle_field(g, 0, 0, 0.05, 5);
    const double r = 0.6;
    const TensorLine line = integrate_tensor_line(f, r, 0.0, 0.0, 1.0);
    REQUIRE(line.stop == StopReason::closed);
    CHECK(all_finite(line.xy));
    double worst = 0;
    for (std::size_t k = 0; k < line.size(); ++k)
        worst = std::max(worst, std::abs(std::hypot(line.xy[2 * k], line.xy[2 * k + 1]) - r));
    // Bilinear interpolation of the unit tangent: O(h^2 / r) error in direction per unit length, integrated
    // over one turn the radius drifts by about 2 pi r * h^2 / (8 r^2) = 5e-4.
    MESSAGE("largest radius error over one turn " << worst << ", length " << line.s.back());
    CHECK(worst < 1e-3);
    CHECK(line.s.back() == doctest::Approx(2 * M_PI * r).epsilon(2e-3));
    // Counter-clockwise as started (0, 1) at (r, 0): the second point has y > 0.
    CHECK(line.xy[3] > 0.0);
}

TEST_CASE("stop rules: domain edge, masked cell, singular point, maximum length") {
    const Grid g = box(0, 1, 0, 1, 51, 51);
    // A uniform field along x with random signs; masked column x in [0.7, 0.72].
    std::vector<double> vx(g.size()), vy(g.size(), 0.0);
    std::vector<std::uint8_t> masked(g.size(), 0), undefined(g.size(), 0);
    std::mt19937 rng(1);
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const std::size_t p = i * g.nx + j;
            vx[p] = (rng() & 1) ? 1.0 : -1.0;
            if (j == 35 && i < 25) masked[p] = 1;
            if (j == 10 && i >= 25) undefined[p] = 1;
        }
    const LineField f(g, vx, vy, masked, undefined);
    const TensorLine to_edge = integrate_tensor_line(f, 0.5, 0.8, 1.0, 0.0);
    CHECK(to_edge.stop == StopReason::domain_edge);
    CHECK(to_edge.xy[to_edge.xy.size() - 2] == doctest::Approx(1.0).epsilon(1e-3));
    CHECK(to_edge.xy.back() == doctest::Approx(0.8)); // straight along x
    const TensorLine to_mask = integrate_tensor_line(f, 0.5, 0.2, 1.0, 0.0);
    CHECK(to_mask.stop == StopReason::masked);
    // Stops before the cell [0.68, 0.7] whose corner at x = 0.7 is masked, within min_step (2e-6).
    CHECK(to_mask.xy[to_mask.xy.size() - 2] == doctest::Approx(0.68).epsilon(1e-4));
    const TensorLine to_singular = integrate_tensor_line(f, 0.5, 0.8, -1.0, 0.0);
    CHECK(to_singular.stop == StopReason::singular);
    CHECK(to_singular.xy[to_singular.xy.size() - 2] == doctest::Approx(0.22).epsilon(1e-4));
    TensorLineSettings s;
    s.max_length = 0.1;
    const TensorLine short_line = integrate_tensor_line(f, 0.5, 0.8, -1.0, 0.0, s);
    CHECK(short_line.stop == StopReason::max_length);
    CHECK(short_line.s.back() == doctest::Approx(0.1).epsilon(1e-9));
    CHECK(short_line.xy[short_line.xy.size() - 2] == doctest::Approx(0.4).epsilon(1e-9));
    // A seed in an unusable cell gives the seed alone, with the reason.
    const TensorLine seed_masked = integrate_tensor_line(f, 0.7, 0.2, 1.0, 0.0);
    CHECK(seed_masked.stop == StopReason::masked);
    CHECK(seed_masked.size() == 1);
    for (const auto *l : {&to_edge, &to_mask, &to_singular, &short_line}) CHECK(all_finite(l->xy));
}

TEST_CASE("both ways from a seed: one polyline, seed inside, stops at both ends") {
    const Grid g = box(-1, 1, -1, 1, 81, 81);
    const LineField f = circle_field(g, 0, -2.0, 0.0, 9); // arcs of radius ~2 crossing the box
    const TwoWayLine line = integrate_tensor_line_both_ways(f, 0.1, 0.0);
    CHECK(line.stop_backward == StopReason::domain_edge);
    CHECK(line.stop_forward == StopReason::domain_edge);
    CHECK_FALSE(line.closed);
    REQUIRE(line.seed_index > 0);
    REQUIRE(line.seed_index + 1 < line.size());
    CHECK(line.xy[2 * line.seed_index] == doctest::Approx(0.1));
    CHECK(line.xy[2 * line.seed_index + 1] == doctest::Approx(0.0));
    CHECK(line.s.front() == 0.0);
    CHECK(line.s.back() == doctest::Approx(polyline_length(line.xy)).epsilon(1e-12));
    // The arc of the circle of radius |(0.1, 2)| through the seed, from the box's left edge to its right edge.
    const double rad = std::hypot(0.1, 2.0);
    double worst = 0;
    for (std::size_t k = 0; k < line.size(); ++k)
        worst = std::max(worst, std::abs(std::hypot(line.xy[2 * k], line.xy[2 * k + 1] + 2.0) - rad));
    CHECK(worst < 1e-4);
    CHECK(std::abs(line.xy.front()) == doctest::Approx(1.0).epsilon(1e-3));
    CHECK(std::abs(line.xy[line.xy.size() - 2]) == doctest::Approx(1.0).epsilon(1e-3));
    CHECK(line.xy.front() * line.xy[line.xy.size() - 2] < 0); // the two ends on opposite edges
    CHECK(all_finite(line.xy));
}

TEST_CASE("every line_method closes circles within the interpolation error; a batch equals lines one by one") {
    const Grid g = box(-1, 1, -1, 1, 101, 101); // h = 0.02
    const LineField f = circle_field(g, 0, 0, 0.05, 7);
    // Seeds on radii 0.2 .. 0.9 (more than one lane group), started counter-clockwise.
    std::vector<double> starts;
    for (int k = 0; k < 40; ++k) {
        const double r = 0.2 + 0.7 * k / 39.0;
        starts.insert(starts.end(), {r, 0.0, 0.0, 1.0});
    }
    for (const TensorLineMethod method :
         {TensorLineMethod::midpoint, TensorLineMethod::rk4, TensorLineMethod::bs32, TensorLineMethod::dopri5}) {
        const std::string name = to_string(method);
        CAPTURE(name);
        CHECK(tensor_line_method(to_string(method)) == method);
        TensorLineSettings s;
        s.method = method;
        const std::vector<TensorLine> batch = integrate_tensor_lines(f, starts, s);
        REQUIRE(batch.size() == starts.size() / 4);
        double worst = 0.0;
        for (std::size_t k = 0; k < batch.size(); ++k) {
            const double r = starts[4 * k];
            REQUIRE(batch[k].stop == StopReason::closed);
            for (std::size_t p = 0; p < batch[k].size(); ++p)
                worst = std::max(worst, std::abs(std::hypot(batch[k].xy[2 * p], batch[k].xy[2 * p + 1]) - r));
            // Lanes do not interact: the same line alone, bit for bit.
            const TensorLine alone = integrate_tensor_line(f, starts[4 * k], starts[4 * k + 1], 0.0, 1.0, s);
            CHECK(alone.xy == batch[k].xy);
            CHECK(alone.s == batch[k].s);
        }
        // The bilinear field's own error (about 5e-4 over a turn, test above) dominates every method's.
        MESSAGE(std::string(to_string(method)) << ": largest radius error " << worst);
        CHECK(worst < 1e-3);
    }
    CHECK_THROWS_AS(tensor_line_method("euler"), std::invalid_argument);
}

TEST_CASE("both ways in a batch: arc lengths optional, the same points either way, joins in place") {
    // Circles around (0.3, 0), seeded above the centre: those of radius < 0.7 close inside the box, larger ones leave
    // it at both ends. More seeds than two threads' lanes, so that lanes take a seed's backward branch after its
    // forward one and then further seeds.
    const Grid g = box(-1, 1, -1, 1, 101, 101);
    const LineField f = circle_field(g, 0.3, 0.0, 0.05, 11);
    std::vector<double> seeds;
    for (int k = 0; k < 150; ++k) seeds.insert(seeds.end(), {0.31, 0.2 + 0.78 * k / 149.0});
    TensorLineSettings with_lengths;
    with_lengths.max_length = 3.0;
    const std::vector<TwoWayLine> a = integrate_tensor_lines_both_ways(f, seeds, with_lengths);
    const std::vector<TwoWayLine> b = integrate_tensor_lines_both_ways(f, seeds, with_lengths, ArcLengths::drop);
    REQUIRE(a.size() == b.size());
    int closed = 0, open = 0;
    for (std::size_t k = 0; k < a.size(); ++k) {
        CAPTURE(k);
        CHECK(a[k].xy == b[k].xy);
        CHECK(a[k].size() == b[k].size());
        CHECK(a[k].seed_index == b[k].seed_index);
        CHECK(a[k].closed == b[k].closed);
        CHECK(a[k].stop_backward == b[k].stop_backward);
        CHECK(a[k].stop_forward == b[k].stop_forward);
        CHECK(b[k].s.empty());
        (a[k].closed ? closed : open) += 1;
        // The seed where seed_index says, and each arc length the length of the polyline up to its point.
        REQUIRE(a[k].s.size() == a[k].size());
        CHECK(a[k].xy[2 * a[k].seed_index] == seeds[2 * k]);
        CHECK(a[k].xy[2 * a[k].seed_index + 1] == seeds[2 * k + 1]);
        const std::vector<double> length = cumulative_length(a[k].xy);
        for (std::size_t p = 0; p < a[k].size(); ++p)
            CHECK(a[k].s[p] - a[k].s[0] == doctest::Approx(length[p]).epsilon(1e-12));
        if (a[k].closed) continue;
        // Each branch, integrated alone one way, lies bit for bit in its place: the forward one from the seed on,
        // the backward one reversed before it.
        double vx = 0.0, vy = 0.0;
        REQUIRE(f.evaluate(seeds[2 * k], seeds[2 * k + 1], 1.0, 0.0, vx, vy) == LineStatus::ok);
        const TensorLine fwd = integrate_tensor_line(f, seeds[2 * k], seeds[2 * k + 1], vx, vy, with_lengths);
        const TensorLine bwd = integrate_tensor_line(f, seeds[2 * k], seeds[2 * k + 1], -vx, -vy, with_lengths);
        const std::size_t seed = a[k].seed_index;
        REQUIRE(seed + 1 == bwd.size());
        REQUIRE(seed + fwd.size() == a[k].size());
        CHECK(a[k].stop_forward == fwd.stop);
        CHECK(a[k].stop_backward == bwd.stop);
        for (std::size_t p = 0; p < fwd.size(); ++p) {
            CHECK(a[k].xy[2 * (seed + p)] == fwd.xy[2 * p]);
            CHECK(a[k].xy[2 * (seed + p) + 1] == fwd.xy[2 * p + 1]);
        }
        for (std::size_t p = 0; p < bwd.size(); ++p) {
            CHECK(a[k].xy[2 * (seed - p)] == bwd.xy[2 * p]);
            CHECK(a[k].xy[2 * (seed - p) + 1] == bwd.xy[2 * p + 1]);
        }
    }
    CHECK(closed > 0);
    CHECK(open > 0);
}
