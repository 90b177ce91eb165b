// The Cauchy–Green strain tensor C = DF^T DF (paper eq. `cg`), its eigenvalues
// lambda1 <= lambda2, eigenvectors xi1, xi2 with xi2 = Omega xi1, and the FTLE,
// computed stably: lambda2 from the dominant root (no cancellation),
// lambda1 = det(DF)^2 / lambda2, and xi1 as the rotation of xi2 (paper, section 2.2:
// xi2 is the more accurate of the two).
#ifndef GEOBARRIER_CAUCHY_GREEN_HPP
#define GEOBARRIER_CAUCHY_GREEN_HPP

#include <geobarrier/grid.hpp>

#include <cstdint>
#include <vector>

namespace geobarrier {

struct CauchyGreenPoint {
    double lambda1 = 1.0, lambda2 = 1.0;
    double xi1_x = 1.0, xi1_y = 0.0; // unit; xi2 = Omega xi1 = (-xi1_y, xi1_x)
    double xi2_x = 0.0, xi2_y = 1.0;
    double ftle = 0.0; // log(lambda2) / (2 |t1 - t0|)
    bool degenerate = false; // lambda2 - lambda1 <= tolerance * lambda2: eigenvectors undefined
};

// Relative eigenvalue gap below which a point is degenerate (C ~ multiple of I).
constexpr double degenerate_gap = 1e-12;

// From the deformation gradient DF = [[f11, f12], [f21, f22]] over |T| = |t1 - t0|.
CauchyGreenPoint cauchy_green_at(double f11, double f12, double f21, double f22, double abs_duration);

// The same for DF = 2^exponent [[f11, f12], [f21, f22]] (renormalised variational equations, flow_map.hpp), with
// log|det DF| from Liouville's formula when `log_abs_det` is finite (else det DF is taken from the entries).
// Where they leave the double range lambda2 is +Inf and lambda1 is 0 (or subnormal); ftle stays finite.
CauchyGreenPoint cauchy_green_at(double f11, double f12, double f21, double f22, double abs_duration, int exponent,
                                 double log_abs_det);

// What a Cauchy–Green computation must deliver: leaving out lambda1 saves an exp, the eigenvectors three hypot calls
// and two divisions per point (an FTLE-only run spends most of its Cauchy–Green time there). Left out values are
// unspecified; `degenerate` is always set.
struct CauchyGreenParts {
    bool lambda1 = true;
    bool eigenvectors = true;
};
CauchyGreenPoint cauchy_green_at(double f11, double f12, double f21, double f22, double abs_duration, int exponent,
                                 double log_abs_det, CauchyGreenParts parts);

struct CauchyGreenField {
    Grid grid;
    std::vector<double> lambda1, lambda2, ftle, xi1_x, xi1_y, xi2_x, xi2_y; // NaN where masked
    std::vector<std::uint8_t> mask; // input mask, plus mask_degenerate where eigenvectors are undefined
    std::uint64_t degenerate_count = 0;
};

// From a gradient field (4 per point, F11 F12 F21 F22) and its mask.
CauchyGreenField cauchy_green_field(const Grid &grid, const std::vector<double> &dF,
                                    const std::vector<std::uint8_t> &mask, double abs_duration);

// The same with the flow map's DF exponents and log|det DF| (GridFlowMap::dF_exponent, ::log_det); either may be
// empty (exponent 0, det from the entries).
CauchyGreenField cauchy_green_field(const Grid &grid, const std::vector<double> &dF,
                                    const std::vector<std::uint8_t> &mask, double abs_duration,
                                    const std::vector<std::int32_t> &dF_exponent, const std::vector<double> &log_det);

// The gradients of `count` consecutive points (dF 4 per point, their mask, exponents and log-determinants, either of
// the last two possibly empty), starting at point `first` of `out`'s grid, into those points of `out`: its mask (with
// mask_non_finite and mask_degenerate added) and each of its seven fields that already has the grid's size; fields
// left empty are neither computed nor touched. Returns the number of degenerate points. The memory tiles
// (tiles.hpp) fill the whole-grid result this way, computing only the fields an experiment keeps.
std::uint64_t cauchy_green_into(CauchyGreenField &out, std::size_t first, std::size_t count, const double *dF,
                                const std::uint8_t *mask, const std::int32_t *dF_exponent, const double *log_det,
                                double abs_duration);

}  // namespace geobarrier

#endif  // GEOBARRIER_CAUCHY_GREEN_HPP
