// Seeds where the exit time jumps (exit_edges.hpp), on exit-time fields whose jump lines are known by construction:
// the edge of a captured disc and a line across which trajectories leave a fixed time apart.
#include "exit_edges.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

using geobarrier::Grid;
using geobarrier::hyperbolic::exit_jump_edges;
using geobarrier::hyperbolic::ExitJumps;

namespace {

// The seeds as the extractor finds them: the jump edges, then their midpoints thinned.
std::vector<double> exit_jump_seeds(const Grid &g, const double *exit_time, const std::uint8_t *mask,
                                    const ExitJumps &rule, double separation) {
    return geobarrier::hyperbolic::exit_jump_seeds(g, exit_jump_edges(g, exit_time, mask, rule), separation);
}

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();
constexpr double radius = 0.3, cx = 0.5, cy = 0.5, line_x = 0.8, step = 5.0, horizon = 10.0;

Grid unit_grid(std::size_t n) {
    Grid g;
    g.nx = g.ny = n;
    return g;
}

// Backward time from t0 = 2 over a horizon of 10: points within `radius` of the centre never leave (NaN); the others
// leave at t = 2 - (1 + r), the time to exit growing smoothly with the distance r from the centre (by 1 across the
// box, far below any threshold below; at the disc's edge 1.3, far below the horizon), and `step` later right of
// x = line_x.
std::vector<double> disc_and_line(const Grid &g) {
    std::vector<double> exit(g.size());
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const double r = std::hypot(g.x(j) - cx, g.y(i) - cy);
            exit[i * g.nx + j] = r < radius ? nan_value : 2.0 - (1.0 + r + (g.x(j) > line_x ? step : 0.0));
        }
    return exit;
}

double distance_to_circle(double x, double y) { return std::fabs(std::hypot(x - cx, y - cy) - radius); }

} // namespace

TEST_CASE("exit-time seeds lie on the captured disc's edge and the jump line, the given distance apart") {
    const Grid g = unit_grid(101);
    const std::vector<double> exit = disc_and_line(g);
    const double separation = 0.05;
    const std::vector<double> seeds = exit_jump_seeds(g, exit.data(), nullptr, {2.0, horizon, 2.0, 2.0}, separation);
    REQUIRE(seeds.size() % 2 == 0);
    std::size_t on_circle = 0, on_line = 0;
    for (std::size_t k = 0; k < seeds.size(); k += 2) {
        const double x = seeds[k], y = seeds[k + 1];
        // An edge's midpoint lies within half a cell of the curve it crosses.
        const bool circle = distance_to_circle(x, y) <= 0.5 * g.dx() + 1e-12;
        const bool line = std::fabs(x - line_x) <= 0.5 * g.dx() + 1e-12;
        CHECK((circle || line));
        on_circle += circle;
        on_line += line;
        for (std::size_t m = 0; m < k; m += 2) CHECK(std::hypot(seeds[m] - x, seeds[m + 1] - y) >= separation);
    }
    // Covered: every edge that jumps lies within the separation of a seed, so every point of the circle and of the
    // line within the separation and a cell.
    const auto covered = [&](double x, double y) {
        for (std::size_t k = 0; k < seeds.size(); k += 2)
            if (std::hypot(seeds[k] - x, seeds[k + 1] - y) <= separation + g.dx()) return true;
        return false;
    };
    for (int a = 0; a < 360; a += 5) {
        const double t = a * M_PI / 180.0;
        CHECK(covered(cx + radius * std::cos(t), cy + radius * std::sin(t)));
    }
    for (double y = 0.0; y <= 1.0; y += 0.02) CHECK(covered(line_x, y));
    // The circle (length 1.88) and the line (length 1) hold a seed about every separation at most.
    CHECK(on_circle >= 19);
    CHECK(on_circle <= 40);
    CHECK(on_line >= 10);
    CHECK(on_line <= 21);
}

TEST_CASE("exit-time seeds: a jump below the threshold, masked points and a run where nothing exits give none there") {
    const Grid g = unit_grid(101);
    std::vector<double> exit = disc_and_line(g);
    // A threshold above the line's step: only the disc's edge (captured against leaving) is left.
    std::vector<double> seeds = exit_jump_seeds(g, exit.data(), nullptr, {2.0, horizon, step + 0.5, step + 0.5}, 0.05);
    REQUIRE(!seeds.empty());
    for (std::size_t k = 0; k < seeds.size(); k += 2)
        CHECK(distance_to_circle(seeds[k], seeds[k + 1]) <= 0.5 * g.dx() + 1e-12);
    // Masked points take part in no edge: masking the right part of the box removes the line's seeds, and masking
    // the disc (masked points hold NaN, as captured ones do) removes its edge's.
    std::vector<std::uint8_t> mask(g.size(), 0);
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const std::size_t p = i * g.nx + j;
            if (g.x(j) > 0.7 || std::isnan(exit[p])) mask[p] = 1;
        }
    CHECK(exit_jump_seeds(g, exit.data(), mask.data(), {2.0, horizon, 2.0, 2.0}, 0.05).empty());
    // Nothing exits (a run without bounds): no seed.
    const std::vector<double> never(g.size(), nan_value);
    CHECK(exit_jump_seeds(g, never.data(), nullptr, {2.0, horizon, 2.0, 2.0}, 0.05).empty());
}

TEST_CASE("exit-time seeds: the horizon's cut through a smooth exit time is no jump") {
    // A dissipative system run backward: every point leaves, the later the nearer the centre, and those that would
    // leave after the horizon (10) are captured, left of x = 5/9. The time to exit changes by 0.09 from one point to
    // the next; where the captured set begins it is 9.91 or more next to 10 (the horizon, the least a captured
    // point can take).
    const Grid g = unit_grid(101);
    std::vector<double> exit(g.size());
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const double time_to_exit = 15.0 - 9.0 * g.x(j); // from 15 at x = 0 to 6 at x = 1
            exit[i * g.nx + j] = time_to_exit >= horizon ? nan_value : -time_to_exit;
        }
    REQUIRE(std::isnan(exit[0]));
    REQUIRE(!std::isnan(exit[g.nx - 2]));
    CHECK(exit_jump_seeds(g, exit.data(), nullptr, {0.0, horizon, 1.0, 1.0}, 0.05).empty());
    // The same captured set with every other point leaving at once: its edge is a jump.
    for (double &e : exit)
        if (!std::isnan(e)) e = -0.5;
    const std::vector<double> seeds = exit_jump_seeds(g, exit.data(), nullptr, {0.0, horizon, 1.0, 1.0}, 0.05);
    REQUIRE(!seeds.empty());
    for (std::size_t k = 0; k < seeds.size(); k += 2) CHECK(std::fabs(seeds[k] - 5.0 / 9.0) <= 0.5 * g.dx());
}

TEST_CASE("exit-time seeds: next to a captured point, one leaving more than stay_jump before the horizon is a jump") {
    // A strand across which trajectories leave a loop apart, next to the captured set: the time to exit falls
    // smoothly with y, by 0.09 a point (the test above's ramp, now along y), and right of x = 0.5 the points below
    // y = 5/9, which would leave after the horizon (10), stay; left of x = 0.5 they leave 0.5 before the horizon,
    // a loop (here the rest of the ramp) before their neighbours. The jump is seen only as 0.5: less than `jump` (1),
    // more than `stay_jump` (0.2). Between the left points the time to exit never jumps, nor across x = 0.5 above
    // y = 5/9 (by 0.5 at most), nor across the horizon's cut right of x = 0.5 (by 0.09 at most).
    const Grid g = unit_grid(101);
    std::vector<double> exit(g.size());
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const double ramp = 15.0 - 9.0 * g.y(i);
            const double time_to_exit = g.x(j) < 0.5 ? std::min(ramp, horizon - 0.5) : ramp;
            exit[i * g.nx + j] = time_to_exit >= horizon ? nan_value : -time_to_exit;
        }
    const std::vector<double> seeds = exit_jump_seeds(g, exit.data(), nullptr, {0.0, horizon, 1.0, 0.2}, 0.05);
    REQUIRE(!seeds.empty());
    for (std::size_t k = 0; k < seeds.size(); k += 2) { // on the strand's edges, midway between x = 0.49 and 0.5
        CHECK(std::fabs(seeds[k] - 0.495) <= 1e-12);
        CHECK(seeds[k + 1] <= 5.0 / 9.0);
    }
    // Every point of the strand beside the captured set (y from 0 to 5/9) lies within a seed's separation.
    for (double y = 0.0; y <= 5.0 / 9.0; y += 0.02) {
        bool covered = false;
        for (std::size_t k = 0; k < seeds.size(); k += 2)
            covered = covered || std::hypot(seeds[k] - 0.495, seeds[k + 1] - y) <= 0.05 + g.dx();
        CHECK(covered);
    }
    // With stay_jump at the jump (1), as with a point that stays counted as leaving at the horizon: no seed.
    CHECK(exit_jump_seeds(g, exit.data(), nullptr, {0.0, horizon, 1.0, 1.0}, 0.05).empty());
}

TEST_CASE("near_exit_jumps: the captured set's edge and a jump between leaving points are told apart") {
    // disc_and_line: the disc's edge separates points that stay from points that leave (captured), the line x = 0.8
    // points that leave `step` apart (leaving). Reach 1: the points within a grid point of an edge's end.
    using geobarrier::hyperbolic::near_captured_jump;
    using geobarrier::hyperbolic::near_exit_jumps;
    using geobarrier::hyperbolic::near_leaving_jump;
    const Grid g = unit_grid(101);
    const std::vector<double> exit = disc_and_line(g);
    const std::vector<std::uint8_t> near =
        near_exit_jumps(g, exit_jump_edges(g, exit.data(), nullptr, {2.0, horizon, 2.0, 2.0}), 1);
    std::size_t captured = 0, leaving = 0;
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const std::uint8_t kind = near[i * g.nx + j];
            const double x = g.x(j), y = g.y(i);
            // Within a grid point (along x and along y) of an edge's end, which lies within a cell of the curve along
            // the edge: within sqrt(1 + 2^2) = sqrt(5) cells of the curve.
            const double bound = std::sqrt(5.0) * g.dx() + 1e-12;
            if (kind & near_captured_jump) {
                ++captured;
                CHECK(distance_to_circle(x, y) <= bound);
            }
            if (kind & near_leaving_jump) {
                ++leaving;
                CHECK(std::fabs(x - line_x) <= 2.0 * g.dx() + 1e-12); // along x only
            }
            // And every point on either curve is marked with its kind.
            if (distance_to_circle(x, y) <= 0.5 * g.dx()) CHECK((kind & near_captured_jump) != 0);
            if (std::fabs(x - line_x) <= 0.5 * g.dx()) CHECK((kind & near_leaving_jump) != 0);
            if (kind == 0) CHECK((distance_to_circle(x, y) > 0.5 * g.dx() && std::fabs(x - line_x) > 0.5 * g.dx()));
        }
    CHECK(captured > 0);
    CHECK(leaving > 0);
}

TEST_CASE("a jump between leaving points counts where the time to leave rises towards it, not where it falls") {
    // Backward from t0 = 0 over 10. Left of x = 0.5 points leave at a time that changes by 0.02 a point, right of it
    // 4 later (a loop, above `jump` 1). A strand of a saddle's manifold: the time rises towards x = 0.5 on the early
    // side (from 2 at x = 0 to 3 at x = 0.5): every jump is on the line. A trajectory grazing the bounds: the time
    // falls towards it (3 to 2): no jump, and no seed.
    const Grid g = unit_grid(51);
    for (const double slope : {2.0, -2.0}) {
        std::vector<double> exit(g.size());
        for (std::size_t i = 0; i < g.ny; ++i)
            for (std::size_t j = 0; j < g.nx; ++j) {
                const double early = (slope > 0 ? 2.0 : 3.0) + slope * g.x(j);
                exit[i * g.nx + j] = -(g.x(j) < 0.5 ? early : early + 4.0);
            }
        const auto edges = exit_jump_edges(g, exit.data(), nullptr, {0.0, horizon, 1.0, 0.2});
        if (slope < 0) {
            CHECK(edges.empty());
            continue;
        }
        CHECK(edges.size() == g.ny); // one edge across the line on every row
        for (const auto &e : edges) {
            CHECK(e.along_x);
            CHECK(!e.captured);
            CHECK(std::fabs(g.x(e.p % g.nx) + 0.5 * g.dx() - 0.5) <= 0.5 * g.dx() + 1e-12);
        }
    }
}

TEST_CASE("across_exit_jumps: a curve on the captured disc's edge lies on its jump, one two cells inside does not") {
    using geobarrier::hyperbolic::across_exit_jumps;
    using geobarrier::hyperbolic::near_captured_jump;
    using geobarrier::hyperbolic::near_leaving_jump;
    const Grid g = unit_grid(101);
    const std::vector<double> exit = disc_and_line(g);
    const ExitJumps rule{2.0, horizon, 2.0, 2.0};
    const auto circle = [&](double r) {
        std::vector<double> xy;
        for (int k = 0; k <= 400; ++k) {
            const double t = 2.0 * M_PI * k / 400.0;
            xy.push_back(cx + r * std::cos(t));
            xy.push_back(cy + r * std::sin(t));
        }
        return xy;
    };
    const double cell = g.dx();
    const std::vector<double> on = circle(radius), inside = circle(radius - 2.0 * cell);
    const auto kind_on = across_exit_jumps(g, exit.data(), nullptr, rule, on.data(), on.size() / 2, cell);
    for (const std::uint8_t k : kind_on) CHECK(k == near_captured_jump); // the disc's edge, left of the line
    // Two cells inside every point stays on both sides: nothing, though the band near_exit_jumps marks reaches it.
    const auto kind_in = across_exit_jumps(g, exit.data(), nullptr, rule, inside.data(), inside.size() / 2, cell);
    for (const std::uint8_t k : kind_in) CHECK(k == 0);
    // The line x = 0.8, between points that leave `step` apart: a jump between leaving points.
    std::vector<double> line;
    for (int k = 0; k <= 50; ++k) {
        line.push_back(line_x);
        line.push_back(0.9 + 0.002 * k);
    }
    for (const std::uint8_t k : across_exit_jumps(g, exit.data(), nullptr, rule, line.data(), line.size() / 2, cell))
        CHECK(k == near_leaving_jump);
}

TEST_CASE("captured_set_edges: the captured disc's edge is one closed curve on the circle, all jumps") {
    using geobarrier::hyperbolic::captured_set_edges;
    const Grid g = unit_grid(101);
    const std::vector<double> exit = disc_and_line(g);
    const ExitJumps rule{2.0, horizon, 2.0, 2.0};
    const auto curves = captured_set_edges(g, exit.data(), nullptr, rule);
    REQUIRE(curves.size() == 1); // the line x = 0.8 (leaving on both sides) bounds no captured set
    const std::vector<double> &xy = curves[0].xy;
    const std::size_t n = xy.size() / 2;
    CHECK(curves[0].closed);
    CHECK(curves[0].jumps == 1.0); // every point beside the disc leaves at 1.3, far before the horizon
    CHECK(xy[0] == xy[2 * n - 2]); // closed: it ends on its first point
    CHECK(xy[1] == xy[2 * n - 1]);
    double length = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
        // Every point, an edge's midpoint, within half a cell of the circle; consecutive points a cell apart at most.
        CHECK(distance_to_circle(xy[2 * k], xy[2 * k + 1]) <= 0.5 * g.dx() + 1e-12);
        if (k > 0) {
            const double d = std::hypot(xy[2 * k] - xy[2 * k - 2], xy[2 * k + 1] - xy[2 * k - 1]);
            CHECK(d <= g.dx() + 1e-12);
            length += d;
        }
    }
    // Around the whole circle (2 pi 0.3 = 1.885), the corners cut at most by a factor 4 / pi (a staircase).
    CHECK(length >= 2.0 * M_PI * radius);
    CHECK(length <= 8.0 * radius + 4.0 * g.dx());
    // Masked points are no part of the captured set: masking the disc leaves no edge.
    std::vector<std::uint8_t> mask(g.size(), 0);
    for (std::size_t p = 0; p < g.size(); ++p) mask[p] = std::isnan(exit[p]) ? 1 : 0;
    CHECK(captured_set_edges(g, exit.data(), mask.data(), rule).empty());
}

TEST_CASE("captured_set_edges: where the horizon cuts the captured set, its edge's share of jumps falls") {
    using geobarrier::hyperbolic::captured_set_edges;
    const Grid g = unit_grid(101);
    const ExitJumps rule{2.0, horizon, 2.0, 2.0};
    // The points within three cells outside the disc's right half leave 0.1 before the horizon, within stay_jump:
    // the horizon's cut. The edge is still one closed curve, about half of it jumps.
    std::vector<double> cut = disc_and_line(g);
    const auto ring = [&](std::size_t i, std::size_t j) {
        const double r = std::hypot(g.x(j) - cx, g.y(i) - cy);
        return r >= radius && r < radius + 3.0 * g.dx();
    };
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j)
            if (g.x(j) > cx && ring(i, j)) cut[i * g.nx + j] = 2.0 - (horizon - 0.1);
    auto curves = captured_set_edges(g, cut.data(), nullptr, rule);
    REQUIRE(curves.size() == 1);
    CHECK(curves[0].closed);
    CHECK(curves[0].jumps > 0.4);
    CHECK(curves[0].jumps < 0.6);
    // Four such points only (a cycle's neighbours whose time to leave diverges): still nearly all jumps.
    std::vector<double> few = disc_and_line(g);
    std::size_t changed = 0;
    for (std::size_t i = 0; i < g.ny && changed < 4; ++i)
        for (std::size_t j = 0; j < g.nx && changed < 4; ++j)
            if (ring(i, j) && std::hypot(g.x(j) - cx, g.y(i) - cy) < radius + g.dx()) {
                few[i * g.nx + j] = 2.0 - (horizon - 0.1);
                ++changed;
            }
    curves = captured_set_edges(g, few.data(), nullptr, rule);
    REQUIRE(curves.size() == 1);
    CHECK(curves[0].closed);
    CHECK(curves[0].jumps < 1.0);
    CHECK(curves[0].jumps > 0.95);
    // A captured set that meets the grid's edge (the disc moved onto the left edge): an open curve.
    std::vector<double> edge(g.size());
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j)
            edge[i * g.nx + j] = std::hypot(g.x(j), g.y(i) - cy) < radius ? nan_value : -1.0;
    curves = captured_set_edges(g, edge.data(), nullptr, rule);
    REQUIRE(curves.size() == 1);
    CHECK(!curves[0].closed);
    CHECK(curves[0].jumps == 1.0);
}
