// Polyline utilities and curve advection with adaptive point insertion, against analytic maps (a twist map
// whose image lengths and areas are known in closed form) and the project's own flow map (linear saddle).
#include <geobarrier/curves.hpp>

#include "test_support.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>

using namespace geobarrier;

namespace {

std::vector<double> circle(double r, std::size_t n) {
    std::vector<double> xy;
    for (std::size_t k = 0; k < n; ++k) {
        const double a = 2 * M_PI * static_cast<double>(k) / static_cast<double>(n);
        xy.push_back(r * std::cos(a));
        xy.push_back(r * std::sin(a));
    }
    return xy;
}

// Twist map: rotation by angle k r^2 about the origin (area-preserving, maps circles to themselves).
AdvectPointsFn twist(double k) {
    return [k](const std::vector<double> &in, std::vector<double> &out, std::vector<std::uint8_t> &mask) {
        out.resize(in.size());
        mask.assign(in.size() / 2, 0);
        for (std::size_t p = 0; p < in.size() / 2; ++p) {
            const double x = in[2 * p], y = in[2 * p + 1], a = k * (x * x + y * y);
            out[2 * p] = std::cos(a) * x - std::sin(a) * y;
            out[2 * p + 1] = std::sin(a) * x + std::cos(a) * y;
        }
    };
}

} // namespace

TEST_CASE("runs_below: the pieces of a line where a value stays below a threshold") {
    const double nan = std::nan("");
    // Below 1 at points 1-2, 4-6 and 8; point 8 alone has no length, NaN and the threshold itself are not below.
    const std::vector<double> d = {nan, 0.1, 0.2, 5.0, 0.1, 0.3, 0.2, 1.0, 0.1};
    const std::vector<PointRun> runs = runs_below(d, 1.0);
    REQUIRE(runs.size() == 2);
    CHECK((runs[0].first == 1 && runs[0].end == 3));
    CHECK((runs[1].first == 4 && runs[1].end == 7));
    CHECK(runs_below(d, 0.1).empty()); // nothing is below 0.1 at two neighbouring points
    const std::vector<PointRun> all = runs_below(std::vector<double>{0.0, 0.0, 0.0}, 1.0);
    REQUIRE(all.size() == 1);
    CHECK((all[0].first == 0 && all[0].end == 3)); // a run to the last point
    std::vector<PointRun> reused = runs;           // the buffer form clears what it is given
    runs_below(d.data(), 3, 1.0, reused);
    REQUIRE(reused.size() == 1);
    CHECK((reused[0].first == 1 && reused[0].end == 3));
}

TEST_CASE("lengths, resampling, shoelace area, bilinear sampling, statistics") {
    const std::vector<double> square = {0, 0, 1, 0, 1, 1, 0, 1};
    CHECK(polyline_length(square) == doctest::Approx(3.0));
    CHECK(polyline_length(square, true) == doctest::Approx(4.0));
    CHECK(shoelace_area(square) == doctest::Approx(1.0));
    const std::vector<double> cw = {0, 0, 0, 1, 1, 1, 1, 0};
    CHECK(shoelace_area(cw) == doctest::Approx(-1.0));
    const std::vector<double> c = cumulative_length(square, true);
    REQUIRE(c.size() == 5);
    CHECK(c.back() == doctest::Approx(4.0));

    const std::vector<double> r = resample_polyline(square, 0.3);
    // 3 / 0.3 = 10 segments, both ends kept; points evenly spaced in arc length along the square's sides (the
    // chords cut its corners, so only the points, not the length, are checked).
    REQUIRE(r.size() == 2 * 11);
    CHECK(r.front() == 0.0);
    CHECK(r[r.size() - 2] == doctest::Approx(0.0));
    CHECK(r.back() == doctest::Approx(1.0));
    CHECK(r[2 * 4] == doctest::Approx(1.0)); // arc length 1.2: on the right side, y = 0.2
    CHECK(r[2 * 4 + 1] == doctest::Approx(0.2));
    const std::vector<double> straight = resample_polyline({0, 0, 1, 1, 2, 2}, 0.1);
    CHECK(straight.size() == 2 * 30);
    CHECK(polyline_length(straight) == doctest::Approx(2 * std::sqrt(2.0)));
    const std::vector<double> rc = resample_polyline(square, 0.5, true);
    REQUIRE(rc.size() == 2 * 8);
    CHECK(polyline_length(rc, true) == doctest::Approx(4.0)); // the corners are among the points
    // A spacing of length / N gives N parts whichever way the quotient rounds: 3.469052 / (3.469052 / 500) is
    // 500.00000000000006 in double, and a count from ceil() alone gave 501 parts there (and 500 in a build whose
    // length came out one ulp different), moving every point. 6% of these lengths did so.
    for (int i = 1; i < 2000; ++i) {
        const double length = 1.0 + 0.001237 * i;
        for (const std::size_t parts : {10, 500}) {
            const std::vector<double> open = resample_polyline({0, 0, length, 0}, length / parts);
            REQUIRE(open.size() == 2 * (parts + 1));
            CHECK(open[2 * parts] == doctest::Approx(length));
            const std::vector<double> loop = resample_polyline({0, 0, length, 0}, 2 * length / parts, true);
            REQUIRE(loop.size() == 2 * parts);
        }
    }

    Grid g;
    g.x_min = -1;
    g.x_max = 2;
    g.y_min = 0;
    g.y_max = 1;
    g.nx = 7;
    g.ny = 5;
    std::vector<double> f(g.size());
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) f[i * g.nx + j] = 1 + 2 * g.x(j) + 3 * g.y(i) + 4 * g.x(j) * g.y(i);
    std::vector<std::uint8_t> mask(g.size(), 0);
    // Bilinear functions are reproduced exactly inside a cell.
    CHECK(sample_field(g, f, mask, 0.3, 0.6) == doctest::Approx(1 + 0.6 + 1.8 + 4 * 0.18));
    CHECK(sample_field(g, f, mask, 2.0, 1.0) == doctest::Approx(1 + 4 + 3 + 8));
    CHECK(std::isnan(sample_field(g, f, mask, 2.1, 0.5)));
    mask[1 * g.nx + 3] = mask_left_bounds; // the point (0.5, 0.25)
    CHECK(std::isnan(sample_field(g, f, mask, 0.6, 0.3)));
    CHECK(sample_field(g, f, mask, 0.6, 0.3, mask_degenerate) == doctest::Approx(1 + 1.2 + 0.9 + 4 * 0.18));

    // int x ds over the segment (0,0)-(1,0) = 1/2, exact for the trapezoid rule on a linear function.
    const std::vector<double> seg = resample_polyline({0, 0, 1, 0}, 0.1);
    std::vector<double> vals;
    for (std::size_t k = 0; k < seg.size() / 2; ++k) vals.push_back(seg[2 * k]);
    CurveStats st = curve_statistics(seg, vals);
    CHECK(st.integral == doctest::Approx(0.5));
    CHECK(st.mean == doctest::Approx(0.5));
    CHECK(st.max == doctest::Approx(1.0));
    CHECK(st.min == doctest::Approx(0.0));
    vals[3] = std::nan(""); // two segments drop out of the integral
    st = curve_statistics(seg, vals);
    CHECK(st.covered_length == doctest::Approx(0.8));
    CHECK(st.finite_points == 10);

    // A closed curve's last segment joins its last point to its first: the unit square with f = x + 2y (0, 1, 3, 2
    // at its corners) has int f ds = 0.5 + 2 + 2.5 + 1 = 6 by the trapezoid rule, exact since f is linear on each
    // side; open, the side back to the start (1) is left out.
    std::vector<double> corners = {0, 1, 3, 2};
    st = curve_statistics(square, corners, true);
    CHECK(st.integral == 6.0);
    CHECK(st.covered_length == 4.0);
    CHECK(st.mean == 1.5);
    st = curve_statistics(square, corners, false);
    CHECK(st.integral == 5.0);
    CHECK(st.covered_length == 3.0);
    corners[3] = std::nan(""); // both sides at the last corner drop out, the closing one included
    st = curve_statistics(square, corners, true);
    CHECK(st.integral == 2.5);
    CHECK(st.covered_length == 2.0);
}

TEST_CASE("advecting a radial segment under a twist map: length of the spiral image") {
    // The segment r in [0.2, 1] at angle 0 maps to the spiral angle = k r^2, of length
    // int sqrt(1 + (2 k r^2)^2) dr. With 3 starting points the image is far too coarse; insertion must fix it.
    const double k = 6.0;
    const std::vector<double> seg = {0.2, 0.0, 0.6, 0.0, 1.0, 0.0};
    CurveAdvectionSettings s;
    s.max_gap_fraction = 1e-3;
    const AdvectedCurve a = advect_curve(seg, false, twist(k), s);
    double exact = 0;
    const int m = 200000;
    for (int q = 0; q < m; ++q) {
        const double r = 0.2 + 0.8 * (q + 0.5) / m;
        exact += std::sqrt(1 + std::pow(2 * k * r * r, 2)) * 0.8 / m;
    }
    MESSAGE("spiral: " << a.xy1.size() / 2 << " points, " << a.inserted << " inserted, length " << a.length1
                       << " (exact " << exact << ")");
    CHECK(a.converged);
    CHECK(a.masked == 0);
    CHECK(a.length0 == doctest::Approx(0.8));
    // Chords of a curve with curvature <= kappa and length <= g*size fall short of the arc by (kappa g size)^2/24
    // relatively; kappa <= 2k/sqrt(1+...) < 12, g size < 2.4e-3: under 2e-5.
    CHECK(a.length1 == doctest::Approx(exact).epsilon(2e-5));
    CHECK(a.max_gap <= s.max_gap_fraction * a.size1 * (1 + 1e-12));
}

TEST_CASE("a closed curve under an area-preserving twist map keeps its enclosed area") {
    // A 16-gon: inserted points lie on its sides, so area0 stays the polygon's area exactly, and the twist map
    // preserves area, so the refined image must enclose the same area up to the chord error of the image.
    const double r = 0.7;
    const std::vector<double> c = circle(r, 16);
    CurveAdvectionSettings s;
    s.max_gap_fraction = 2e-3;
    const AdvectedCurve a = advect_curve(c, true, twist(3.0), s);
    const double polygon = 8 * r * r * std::sin(2 * M_PI / 16);
    MESSAGE("twisted 16-gon: " << a.xy1.size() / 2 << " points, area " << a.area1 << " vs " << polygon);
    CHECK(a.converged);
    CHECK(a.closed);
    CHECK(a.area0 == doctest::Approx(polygon).epsilon(1e-12));
    CHECK(a.length0 == doctest::Approx(32 * r * std::sin(M_PI / 16)).epsilon(1e-12));
    CHECK(a.area1 == doctest::Approx(polygon).epsilon(1e-4));
}

TEST_CASE("advecting a segment with the project's own flow map (linear saddle): l(gamma_t1) = e^{aT} l0") {
    const System saddle = test::make_system("linear-saddle", {{"a", 0.5}});
    const Forcing none = test::make_forcing("none");
    IntegratorSettings s;
    s.rtol = 1e-10;
    s.atol = 1e-12;
    const double T = 4.0;
    const AdvectPointsFn advect = make_advect_points_fn(Dynamics{&saddle, &none}, 0.0, T, s);
    // A segment along the unstable direction (x): stretched by e^{aT}; along y: shrunk by e^{-aT}.
    const AdvectedCurve ax = advect_curve({-0.1, 0.3, 0.1, 0.3}, false, advect);
    CHECK(ax.length1 == doctest::Approx(0.2 * std::exp(0.5 * T)).epsilon(1e-8));
    const AdvectedCurve ay = advect_curve({0.2, -0.1, 0.2, 0.1}, false, advect);
    CHECK(ay.length1 == doctest::Approx(0.2 * std::exp(-0.5 * T)).epsilon(1e-8));
    CHECK(ax.converged);
    CHECK(ay.converged);
}
