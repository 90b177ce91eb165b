// The exact Cauchy–Green field of a steady circular shear flow, a known answer
// for shear-line tests: its closed shearlines are the circles around the centre.
#ifndef GEOBARRIER_TEST_CIRCULAR_SHEAR_HPP
#define GEOBARRIER_TEST_CIRCULAR_SHEAR_HPP

#include <geobarrier/cauchy_green.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

namespace geobarrier::test {

// Angular velocity w(r) = omega + shear r^2 after time T, from the exact flow map
// DF = R(w T) (I + g e_theta e_r^T) with g = r w'(r) T = 2 shear r^2 T. Area-preserving (det DF = 1).
inline CauchyGreenField circular_shear_cg(const Grid &grid, double omega, double shear, double T) {
    std::vector<double> dF(4 * grid.size());
    for (std::size_t i = 0; i < grid.ny; ++i)
        for (std::size_t j = 0; j < grid.nx; ++j) {
            const double x = grid.x(j), y = grid.y(i), r = std::hypot(x, y);
            const double c = r > 0 ? x / r : 1.0, s = r > 0 ? y / r : 0.0;
            const double g = 2.0 * shear * r * r * T, a = (omega + shear * r * r) * T;
            // S = I + g e_theta e_r^T, e_r = (c, s), e_theta = (-s, c).
            const double s11 = 1.0 - g * s * c, s12 = -g * s * s, s21 = g * c * c, s22 = 1.0 + g * c * s;
            const double ca = std::cos(a), sa = std::sin(a);
            double *f = &dF[4 * (i * grid.nx + j)];
            f[0] = ca * s11 - sa * s21;
            f[1] = ca * s12 - sa * s22;
            f[2] = sa * s11 + ca * s21;
            f[3] = sa * s12 + ca * s22;
        }
    return cauchy_green_field(grid, dF, std::vector<std::uint8_t>(grid.size(), 0), T);
}

} // namespace geobarrier::test

#endif // GEOBARRIER_TEST_CIRCULAR_SHEAR_HPP
