// Grid (grid.hpp): the nearest grid point of a point, with known answers on a grid whose spacings are exact in binary
// (dx = 1/4, dy = 1), so that half-way points are exactly half-way.
#include <geobarrier/grid.hpp>

#include <doctest/doctest.h>

#include <cstddef>
#include <limits>

using geobarrier::Grid;

TEST_CASE("grid: the nearest column, row and point, at the edges, half-way and outside") {
    Grid g;
    g.x_min = 0.0, g.x_max = 1.0, g.nx = 5;  // x(j) = 0, 0.25, 0.5, 0.75, 1
    g.y_min = -1.0, g.y_max = 1.0, g.ny = 3; // y(i) = -1, 0, 1
    REQUIRE(g.dx() == 0.25);
    REQUIRE(g.dy() == 1.0);

    // On the grid's points and its edges.
    CHECK(g.nearest_column(0.0) == 0);
    CHECK(g.nearest_column(0.5) == 2);
    CHECK(g.nearest_column(1.0) == 4);
    CHECK(g.nearest_row(-1.0) == 0);
    CHECK(g.nearest_row(1.0) == 2);
    // Between points: the nearer one.
    CHECK(g.nearest_column(0.3) == 1); // 1.2 spacings
    CHECK(g.nearest_column(0.4) == 2); // 1.6 spacings
    CHECK(g.nearest_row(0.49) == 1);
    // Half-way: away from the grid's first point (std::lround rounds half away from zero).
    CHECK(g.nearest_column(0.125) == 1); // 0.5 spacings
    CHECK(g.nearest_column(0.375) == 2); // 1.5
    CHECK(g.nearest_column(0.875) == 4); // 3.5
    CHECK(g.nearest_row(-0.5) == 1);
    CHECK(g.nearest_row(0.5) == 2);
    // Outside: the nearer edge.
    CHECK(g.nearest_column(-0.125) == 0); // -0.5 spacings: rounds to -1, clamped
    CHECK(g.nearest_column(-3.0) == 0);
    CHECK(g.nearest_column(1.2) == 4);
    CHECK(g.nearest_column(1e300) == 4);
    CHECK(g.nearest_column(-1e300) == 0);
    CHECK(g.nearest_column(std::numeric_limits<double>::quiet_NaN()) == 0);
    CHECK(g.nearest_row(-7.0) == 0);
    CHECK(g.nearest_row(2.6) == 2);

    // The point's index in row-major order, i nx + j.
    CHECK(g.nearest_point(0.4, 0.5) == 2 * 5 + 2);
    CHECK(g.nearest_point(0.3, -0.2) == 1 * 5 + 1);
    CHECK(g.nearest_point(-9.0, -9.0) == 0);
    CHECK(g.nearest_point(9.0, 9.0) == g.size() - 1);
    CHECK(g.nearest_point(9.0, -9.0) == 4);
    CHECK(g.nearest_point(-9.0, 9.0) == 2 * 5);
}

TEST_CASE("grid: every grid point is its own nearest point, on spacings not exact in binary") {
    Grid g;
    g.x_min = -1.8, g.x_max = 1.8, g.nx = 201; // dx = 0.018
    g.y_min = -1.2, g.y_max = 1.2, g.ny = 7;   // dy = 0.4
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            CAPTURE(i);
            CAPTURE(j);
            CHECK(g.nearest_point(g.x(j), g.y(i)) == i * g.nx + j);
        }
}
