// Synthetic Cauchy–Green fields and grids for the line-field tests (test_line_field, test_lane_paths,
// test_tensor_lines): built from closed forms only, so that they also serve test_lane_paths' second build, which
// compiles the core's line field and curves itself.
#ifndef GEOBARRIER_TESTS_LINE_FIELDS_HPP
#define GEOBARRIER_TESTS_LINE_FIELDS_HPP

#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/grid.hpp>

#include <cmath>
#include <random>
#include <vector>

namespace geobarrier::test {

// Concentric circles around the origin: xi1 = (-y, x)/r is the counter-clockwise tangent, so kappa1 = 1/r; xi2 =
// Omega xi1 = -(x, y)/r is radial, so kappa2 = 0. lambda2 = exp(x + 2y), lambda1 = 1 / lambda2. The stored
// vectors get random signs: the derivatives must not see them, except that kappa1 and kappa2 change sign with the
// orientation at the point itself (xi2 = Omega xi1 flips with xi1), so their sign follows `orientation`.
inline CauchyGreenField circles(const Grid &g, unsigned seed, std::vector<double> *orientation = nullptr) {
    CauchyGreenField cg;
    cg.grid = g;
    const std::size_t n = g.size();
    for (auto *v : {&cg.lambda1, &cg.lambda2, &cg.ftle, &cg.xi1_x, &cg.xi1_y, &cg.xi2_x, &cg.xi2_y}) v->resize(n);
    cg.mask.assign(n, 0);
    if (orientation) orientation->resize(n);
    std::mt19937 rng(seed);
    std::bernoulli_distribution flip(0.5);
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const std::size_t p = i * g.nx + j;
            const double x = g.x(j), y = g.y(i), r = std::hypot(x, y);
            const double s = flip(rng) ? -1.0 : 1.0;
            if (orientation) (*orientation)[p] = s;
            cg.xi1_x[p] = -s * y / r;
            cg.xi1_y[p] = s * x / r;
            cg.xi2_x[p] = -cg.xi1_y[p];
            cg.xi2_y[p] = cg.xi1_x[p];
            cg.lambda2[p] = std::exp(x + 2 * y);
            cg.lambda1[p] = 1.0 / cg.lambda2[p];
            cg.ftle[p] = 0.5 * (x + 2 * y);
        }
    return cg;
}

inline Grid box(double x0, double x1, double y0, double y1, std::size_t nx, std::size_t ny) {
    Grid g;
    g.x_min = x0;
    g.x_max = x1;
    g.y_min = y0;
    g.y_max = y1;
    g.nx = nx;
    g.ny = ny;
    return g;
}

} // namespace geobarrier::test

#endif // GEOBARRIER_TESTS_LINE_FIELDS_HPP
