// The hyperbolic extractor's whole-curve stage (whole_curves.hpp) on polylines and fields whose answer is known by
// construction: pieces of one line or circle joined, also when traced a little off each other, neighbours that merely
// end near each other not joined, strands along better curves bundled, and a valley of stretching told from a slope.
#include "whole_curves.hpp"

#include <doctest/doctest.h>

#include <cmath>
#include <vector>

using geobarrier::Grid;
using geobarrier::hyperbolic::bundled_curves;
using geobarrier::hyperbolic::chain_points;
using geobarrier::hyperbolic::join_end_to_end;
using geobarrier::hyperbolic::JoinedPart;
using geobarrier::hyperbolic::JoinRules;
using geobarrier::hyperbolic::transverse_q_ratio;

namespace {

// Points from (x0, y0) to (x1, y1), `n` of them.
std::vector<double> segment(double x0, double y0, double x1, double y1, int n) {
    std::vector<double> xy;
    for (int k = 0; k < n; ++k) {
        const double s = static_cast<double>(k) / (n - 1);
        xy.push_back(x0 + s * (x1 - x0));
        xy.push_back(y0 + s * (y1 - y0));
    }
    return xy;
}

// An arc of the unit circle from angle a0 to a1.
std::vector<double> arc(double a0, double a1, int n) {
    std::vector<double> xy;
    for (int k = 0; k < n; ++k) {
        const double a = a0 + (a1 - a0) * k / (n - 1);
        xy.push_back(std::cos(a));
        xy.push_back(std::sin(a));
    }
    return xy;
}

} // namespace

TEST_CASE("pieces of one line laid end to end with a small gap are one curve, whichever way each runs") {
    const double join = 0.04, tangent = 0.04;
    // Three pieces of y = 0.5 x, the middle one reversed, gaps of 0.01 between them, given out of order.
    const std::vector<std::vector<double>> pieces = {
        segment(0.41, 0.205, 0.6, 0.3, 20), segment(0.4, 0.2, 0.21, 0.105, 20), segment(0.0, 0.0, 0.2, 0.1, 20)};
    const auto chains = join_end_to_end(pieces, join, tangent);
    REQUIRE(chains.size() == 1);
    REQUIRE(chains[0].size() == 3);
    const std::vector<double> xy = chain_points(pieces, chains[0]);
    // The points run monotonically along the line from one end to the other.
    const double sign = xy[2] > xy[0] ? 1.0 : -1.0;
    for (std::size_t k = 1; k < xy.size() / 2; ++k) CHECK(sign * (xy[2 * k] - xy[2 * k - 2]) > 0.0);
    CHECK(std::abs(std::abs(xy[0] - xy[xy.size() - 2]) - 0.6) < 1e-12);
}

TEST_CASE("curves that end near each other but do not run on into each other stay apart") {
    const double join = 0.05, tangent = 0.04;
    SUBCASE("side by side, ending at the same place (a hairpin would join them)") {
        const std::vector<std::vector<double>> pieces = {segment(0.0, 0.0, 0.5, 0.0, 30),
                                                         segment(0.5, 0.02, 0.0, 0.02, 30)};
        CHECK(join_end_to_end(pieces, join, tangent).size() == 2);
    }
    SUBCASE("at a right angle") {
        const std::vector<std::vector<double>> pieces = {segment(0.0, 0.0, 0.5, 0.0, 30),
                                                         segment(0.51, 0.01, 0.51, 0.5, 30)};
        CHECK(join_end_to_end(pieces, join, tangent).size() == 2);
    }
    SUBCASE("in line but farther apart than the join distance") {
        const std::vector<std::vector<double>> pieces = {segment(0.0, 0.0, 0.5, 0.0, 30),
                                                         segment(0.56, 0.0, 1.0, 0.0, 30)};
        CHECK(join_end_to_end(pieces, join, tangent).size() == 2);
    }
}

TEST_CASE("the arcs of a whole circle join into one open chain, not a loop") {
    const double pi = std::acos(-1.0);
    const std::vector<std::vector<double>> pieces = {arc(0.0, 2.0, 60), arc(2.01, 4.0, 60),
                                                     arc(4.01, 2 * pi - 0.01, 60)};
    const auto chains = join_end_to_end(pieces, 0.05, 0.05);
    REQUIRE(chains.size() == 1);
    CHECK(chains[0].size() == 3);
}

TEST_CASE("pieces traced a little off each other join when each end lies on the other's tangent line") {
    const double join = 0.04, tangent = 0.04;
    JoinRules off_each_other;
    off_each_other.join_distance = join;
    off_each_other.tangent_length = tangent;
    off_each_other.beside = 0.02;
    off_each_other.reach = 0.08;
    SUBCASE("side by side where they overlap: one curve that does not run back") {
        // y = 0 up to x = 0.5, then y = 0.012 from x = 0.4825 on: they overlap by 0.0175, 0.012 apart.
        const std::vector<std::vector<double>> pieces = {segment(0.0, 0.0, 0.5, 0.0, 51),
                                                         segment(1.0, 0.012, 0.4825, 0.012, 116)};
        CHECK(join_end_to_end(pieces, join, tangent).size() == 2); // neither end lies ahead of the other
        const auto chains = join_end_to_end(pieces, off_each_other);
        REQUIRE(chains.size() == 1);
        const std::vector<double> xy = chain_points(pieces, chains[0]);
        const double sign = xy[2] > xy[0] ? 1.0 : -1.0;
        for (std::size_t k = 1; k < xy.size() / 2; ++k) CHECK(sign * (xy[2 * k] - xy[2 * k - 2]) > 0.0);
        CHECK(std::abs(xy[0] - xy[xy.size() - 2]) == doctest::Approx(1.0));
    }
    SUBCASE("in line across a gap wider than the join distance, up to the reach") {
        const std::vector<std::vector<double>> gap = {segment(0.0, 0.0, 0.5, 0.0, 30),
                                                      segment(0.56, 0.0, 1.0, 0.0, 30)};
        CHECK(join_end_to_end(gap, off_each_other).size() == 1);
        const std::vector<std::vector<double>> far = {segment(0.0, 0.0, 0.5, 0.0, 30), segment(0.6, 0.0, 1.0, 0.0, 30)};
        CHECK(join_end_to_end(far, off_each_other).size() == 2);
        // Across the gap, but 0.03 off the first one's line: farther than `beside`.
        const std::vector<std::vector<double>> off = {segment(0.0, 0.0, 0.5, 0.0, 30),
                                                      segment(0.56, 0.03, 1.0, 0.03, 30)};
        CHECK(join_end_to_end(off, off_each_other).size() == 2);
    }
    SUBCASE("only between the curves flagged loose, when flags are given") {
        const std::vector<std::vector<double>> gap = {segment(0.0, 0.0, 0.5, 0.0, 30),
                                                      segment(0.56, 0.0, 1.0, 0.0, 30)};
        JoinRules flagged = off_each_other;
        flagged.loose = {1, 1};
        CHECK(join_end_to_end(gap, flagged).size() == 1);
        flagged.loose = {1, 0};
        CHECK(join_end_to_end(gap, flagged).size() == 2);
    }
    SUBCASE("side by side, ending at the same place: running the same way, so still apart") {
        const std::vector<std::vector<double>> pieces = {segment(0.0, 0.0, 0.5, 0.0, 30),
                                                         segment(0.5, 0.012, 0.0, 0.012, 30)};
        CHECK(join_end_to_end(pieces, off_each_other).size() == 2);
    }
}

TEST_CASE("ends known to be one curve join at a corner too, where no measured join took them") {
    const double join = 0.05, tangent = 0.04;
    // A separatrix's corner at a saddle: y = 0 up to x = 0.5, then from (0.51, 0.01) straight up. At a right angle the
    // ends do not meet (above), but given as one curve (end 1: the first polyline's last point, end 2: the second's
    // first) they join there.
    const std::vector<std::vector<double>> corner = {segment(0.0, 0.0, 0.5, 0.0, 30),
                                                     segment(0.51, 0.01, 0.51, 0.5, 30)};
    CHECK(join_end_to_end(corner, join, tangent).size() == 2);
    JoinRules known;
    known.join_distance = join;
    known.tangent_length = tangent;
    known.joined = {{1, 2}};
    const auto chains = join_end_to_end(corner, known);
    REQUIRE(chains.size() == 1);
    CHECK(chain_points(corner, chains[0]).size() == 2 * 60);
    // A third polyline in line with the first: the measured join comes first, and the known one finds end 1 taken.
    std::vector<std::vector<double>> pieces = corner;
    pieces.push_back(segment(0.52, 0.0, 1.0, 0.0, 30));
    const auto measured_first = join_end_to_end(pieces, known);
    REQUIRE(measured_first.size() == 2);
    REQUIRE(measured_first[0].size() == 2);
    CHECK(measured_first[0][0].index + measured_first[0][1].index == 2); // the first and third
    REQUIRE(measured_first[1].size() == 1);
    CHECK(measured_first[1][0].index == 1);
}

TEST_CASE("bundled_curves: a curve along better ones adds nothing a candidate's length long") {
    const double distance = 0.02, min_length = 0.1;
    const std::vector<double> best = segment(0.0, 0.0, 1.0, 0.0, 101);
    SUBCASE("a strand 0.01 off the best one, within its length or running on past it by less than min_length") {
        const std::vector<char> b = bundled_curves(
            {best, segment(0.1, 0.01, 0.9, 0.01, 81), segment(0.5, 0.01, 1.08, 0.01, 59)}, distance, min_length);
        CHECK(b == std::vector<char>{0, 1, 1});
    }
    SUBCASE("a strand farther off than the distance, or running on past it by more, is kept") {
        const std::vector<char> b = bundled_curves(
            {best, segment(0.1, 0.05, 0.9, 0.05, 81), segment(0.5, 0.01, 1.3, 0.01, 81)}, distance, min_length);
        CHECK(b == std::vector<char>{0, 0, 0});
    }
    SUBCASE("only curves kept bundle others: along a bundled curve alone is not along a barrier") {
        // The second lies along the first; the third lies along the second only, beyond the first's reach.
        const std::vector<char> b = bundled_curves(
            {best, segment(0.0, 0.015, 1.0, 0.015, 101), segment(0.0, 0.03, 1.0, 0.03, 101)}, distance, min_length);
        CHECK(b == std::vector<char>{0, 1, 0});
    }
    SUBCASE("the first curve is never bundled, the order decides") {
        // The longer one runs on 0.18 past either end of the shorter: kept too, though the shorter came first.
        CHECK(bundled_curves({segment(0.2, 0.01, 0.8, 0.01, 61), best}, distance, min_length) ==
              std::vector<char>{0, 0});
        // Past it by 0.08 only: bundled.
        CHECK(bundled_curves({segment(0.1, 0.01, 0.9, 0.01, 81), best}, distance, min_length) ==
              std::vector<char>{0, 1});
    }
}

TEST_CASE("transverse_q_ratio: above 1 in a valley of sqrt(lambda1), below 1 on its flank, NaN along the edge") {
    Grid g;
    g.nx = g.ny = 101;
    const double h = g.dx();
    std::vector<double> root(g.size());
    // A valley along y = 0.3 + 0.1 x, three cells wide, on a background that rises with y.
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const double d = g.y(i) - 0.3 - 0.1 * g.x(j);
            root[i * g.nx + j] = 1.0 - 0.5 * std::exp(-d * d / (9 * h * h)) + 0.2 * g.y(i);
        }
    const std::vector<std::uint8_t> no_mask;
    const double near = 2 * h, far = 10 * h;
    CHECK(transverse_q_ratio(g, root, no_mask, segment(0.1, 0.31, 0.9, 0.39, 50), h, near, far) > 1.1);
    // Off the valley floor by one cell: still within `near` of the least stretched parallel.
    CHECK(transverse_q_ratio(g, root, no_mask, segment(0.1, 0.32, 0.9, 0.40, 50), h, near, far) > 1.1);
    // Parallel to the valley, 0.1 above it: the copies towards the valley are less stretched.
    CHECK(transverse_q_ratio(g, root, no_mask, segment(0.1, 0.41, 0.9, 0.49, 50), h, near, far) < 0.9);
    // 0.3 above it, out of the valley's reach: the background's slope alone, the copy below less stretched.
    CHECK(transverse_q_ratio(g, root, no_mask, segment(0.1, 0.61, 0.9, 0.69, 50), h, near, far) < 1.0);
    // Along the bottom edge: the copies below leave the box.
    CHECK(std::isnan(transverse_q_ratio(g, root, no_mask, segment(0.1, 0.0, 0.9, 0.0, 50), h, near, far)));
    // A masked band across the valley leaves those points out of every copy.
    std::vector<std::uint8_t> mask(g.size(), 0);
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < 30; ++j) mask[i * g.nx + j] = 1;
    CHECK(transverse_q_ratio(g, root, mask, segment(0.1, 0.31, 0.9, 0.39, 50), h, near, far) > 1.1);
}

TEST_CASE("transverse_q_ratio: in a uniform field every parallel is as stretched (ratio 1)") {
    Grid g;
    g.nx = g.ny = 51;
    const std::vector<double> root(g.size(), 0.4);
    const double ratio = transverse_q_ratio(g, root, {}, segment(0.3, 0.3, 0.7, 0.6, 40), g.dx(), 2 * g.dx(), 0.1);
    CHECK(ratio == doctest::Approx(1.0).epsilon(1e-12));
}

TEST_CASE("pieces of one line in different groups stay apart; in the same group they join") {
    // Two pieces of y = 0.5 x with a gap of 0.01, which join when nothing keeps them apart (the first test case).
    const std::vector<std::vector<double>> pieces = {segment(0.0, 0.0, 0.2, 0.1, 20),
                                                     segment(0.21, 0.105, 0.4, 0.2, 20)};
    JoinRules grouped;
    grouped.join_distance = grouped.tangent_length = 0.04;
    grouped.group = {0, 0};
    CHECK(join_end_to_end(pieces, grouped).size() == 1);
    // A piece that is no barrier on its own joins no piece that is (the extractor's groups): two chains of one.
    grouped.group = {0, 1};
    const auto apart = join_end_to_end(pieces, grouped);
    REQUIRE(apart.size() == 2);
    CHECK(apart[0].size() == 1);
    CHECK(apart[1].size() == 1);
    // Also where the looser rule for pieces traced off each other would join them (both flagged loose).
    grouped.beside = 0.02;
    grouped.reach = 0.08;
    grouped.loose = {1, 1};
    grouped.group = {1, 0};
    CHECK(join_end_to_end(pieces, grouped).size() == 2);
}
