// The Cauchy–Green strain tensor C = DF^T DF (paper eq. `cg`), its eigenvalues
// lambda1 <= lambda2, eigenvectors xi1, xi2 with xi2 = Omega xi1, and the FTLE,
// computed stably: lambda2 from the dominant root (no cancellation),
// lambda1 = det(DF)^2 / lambda2, and xi1 as the rotation of xi2 (paper, section 2.2:
// xi2 is the more accurate of the two).
#ifndef GEOBARRIER_CAUCHY_GREEN_HPP
#define GEOBARRIER_CAUCHY_GREEN_HPP

#include <geobarrier/grid.hpp>

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

namespace geobarrier {

struct CauchyGreenPoint {
    double lambda1 = 1.0, lambda2 = 1.0;
    double xi1_x = 1.0, xi1_y = 0.0; // unit; xi2 = Omega xi1 = (-xi1_y, xi1_x)
    double xi2_x = 0.0, xi2_y = 1.0;
    double ftle = 0.0;       // log(lambda2) / (2 |t1 - t0|)
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

// The same with the flow map's DF exponents and log|det DF| (FlowMap::dF_exponent, ::log_det); either may be
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

// --- n-dimensional systems (dimension 2 .. max_dimension of flow_map.hpp) ---

// The Cauchy–Green tensor C = DF^T DF of an n x n gradient DF = 2^exponent G (G row-major, n^2 values), from the
// singular value decomposition of G (Eigen's JacobiSVD: C = V S^2 V^T, so C is never formed and its eigenvalues
// keep their relative accuracy where forming C would square G's condition number). lambda holds C's eigenvalues in
// ascending order (+Inf / 0 where they leave the double range), eigenvectors the matching unit eigenvectors
// (n per eigenvalue: eigenvectors[i * n + j] is component j of the i-th), ftle = log(lambda_max) / (2 |T|) computed
// in logarithms (finite however large DF is). When log_abs_det (Liouville's log|det DF|) is finite, the smallest
// eigenvalue is det(DF)^2 over the product of the others, free of the cancellation that loses it in the SVD once
// lambda_max / lambda_min exceeds ~1/eps^2.
struct CauchyGreenND {
    unsigned dimension = 0;
    std::vector<double> lambda;       // ascending
    std::vector<double> eigenvectors; // dimension x dimension; row i = eigenvector of lambda[i]
    double ftle = 0.0;
    double log_lambda_max = 0.0, log_lambda_min = 0.0;
};
CauchyGreenND cauchy_green_nd(const double *dF, unsigned dimension, double abs_duration, int exponent = 0,
                              double log_abs_det = std::numeric_limits<double>::quiet_NaN());

// A slice of an n-dimensional system (grid.hpp, Slice): the 2 x 2 gradient `out` (row-major) whose Cauchy–Green
// tensor out^T out is the slice's view of DF = 2^exponent dF (n x n, row-major) on the components axes[0], axes[1],
// and the log|det| that goes with it (NaN: take it from out's entries), so that the planar pipeline (cauchy_green_at
// with the same exponent) computes the slice's fields:
//   full:       out = diag(s_max, s_min), the extreme singular values of dF: eigenvalues s_max^2, s_min^2 of the
//               whole C (s_min from Liouville's log_abs_det when finite); its eigenvectors mean nothing on the slice
//   restricted: out = R of the QR factorisation of the n x 2 columns DF P (Householder), R^T R = P^T C P exactly
//   projected:  out = the 2 x 2 block of dF on the axes
void slice_gradient(const double *dF, unsigned dimension, const std::array<unsigned, 2> &axes, SliceTensor tensor,
                    int exponent, double log_abs_det, double *out, double &out_log_abs_det);

} // namespace geobarrier

#endif // GEOBARRIER_CAUCHY_GREEN_HPP
