// Derivatives of the Cauchy–Green field on the grid (gradients of lambda1, lambda2; curvatures kappa1, kappa2 of
// the xi1 and xi2 line fields; the geodesic strain deviation, paper eq. `gdev_str` in its general form) and the
// orientation-free LineField that tensor lines (strainlines, stretchlines, shearlines) are integrated on.
#ifndef GEOBARRIER_LINE_FIELD_HPP
#define GEOBARRIER_LINE_FIELD_HPP

#include <geobarrier/abi.h>
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/grid.hpp>

#include <cstdint>
#include <vector>

namespace geobarrier {

// Grid derivatives of a Cauchy–Green field. Differences are centred where both neighbours are usable, one-sided
// where only one is, and NaN (valid = 0) where neither is; a point is usable when its mask is 0 (no trajectory
// bit, not degenerate). Eigenvector differences flip each neighbour's vector to agree with the centre's first,
// since xi1 and xi2 are defined only up to sign. All vectors are (ny * nx) row-major like the field.
struct StrainDerivatives {
    Grid grid;
    std::vector<double> dlambda1_dx, dlambda1_dy; // grad lambda1
    std::vector<double> dlambda2_dx, dlambda2_dy; // grad lambda2
    std::vector<double> kappa1;                   // <(grad xi1) xi1, xi2>: curvature of the xi1 lines
    std::vector<double> kappa2;                   // <(grad xi2) xi2, xi1>: curvature of the xi2 lines
    std::vector<std::uint8_t> valid;              // 1 where every value above is finite and usable
};

StrainDerivatives strain_derivatives(const CauchyGreenField &cg);

// Geodesic strain deviation of strainlines, general (compressible) form, Haller & Beron-Vera 2012 eq. 31:
//   d_g^xi1 = |lambda1 kappa1 - 1/2 <grad lambda1, xi2>| / lambda2.
// With lambda1 lambda2 = 1 it equals the paper's eq. `gdev_str` (strain_deviation_area_preserving).
double strain_deviation(double lambda1, double lambda2, double kappa1, double grad_lambda1_dot_xi2);
// The paper's eq. `gdev_str`: |<grad lambda2, xi2> + 2 lambda2 kappa1| / (2 lambda2^3); valid only when
// lambda1 lambda2 = 1 (area-preserving flow maps).
double strain_deviation_area_preserving(double lambda2, double kappa1, double grad_lambda2_dot_xi2);

// d_g^xi1 (general form) at every grid point; NaN where the derivatives are not valid.
std::vector<double> strain_deviation_field(const CauchyGreenField &cg, const StrainDerivatives &derivatives);
inline std::vector<double> strain_deviation_field(const CauchyGreenField &cg) {
    return strain_deviation_field(cg, strain_derivatives(cg));
}

// Default relative eigenvalue gap below which a point counts as singular for line fields (lambda2 - lambda1 <=
// gap * lambda2): eigenvectors there are too poorly determined to follow.
constexpr double default_singular_gap = 1e-3;

// 1 where a point must not be used by a line field: masked (any bit) or lambda2 - lambda1 <= gap * lambda2.
std::vector<std::uint8_t> singular_mask(const CauchyGreenField &cg, double gap = default_singular_gap);

// The Cauchy–Green field an extractor was handed: grid, mask and the fields lambda1, lambda2, xi1_x, xi1_y
// (required; xi2 = Omega xi1 is rebuilt, and ftle from lambda2 when not handed over). Throws std::invalid_argument
// naming a missing field.
Grid grid_of(const gb_extract_input &input);
const double *find_field(const gb_extract_input &input, const char *name); // nullptr when absent
CauchyGreenField cauchy_green_from_input(const gb_extract_input &input);

// Why a line field has no direction at a point.
enum class LineStatus {
    ok,
    outside, // outside the grid's box
    masked,  // the cell touches a masked point (trajectory bits)
    singular // the cell touches a singular/undefined point, or the aligned corners cancel
};
const char *to_string(LineStatus status);

// An orientation-free unit-vector field on the grid (xi1, xi2, eta+-, ...). Values at a point are defined only
// up to sign; evaluation aligns the four corner vectors of the cell with a reference direction (normally the
// current tangent of a tensor line), interpolates bilinearly (the paper's Alg. 1, step 2) and normalises.
class LineField {
  public:
    LineField() = default;
    // vx, vy: the vectors (need not be unit; they are normalised). masked: 1 where the point's trajectory data is
    // unusable; undefined: 1 where the direction is undefined (singular). Either may be empty (= none).
    LineField(const Grid &grid, std::vector<double> vx, std::vector<double> vy, std::vector<std::uint8_t> masked,
              std::vector<std::uint8_t> undefined);

    // xi1 (which = 1) or xi2 (which = 2) of a Cauchy–Green field, singular where the relative gap is below `gap`.
    static LineField from_cauchy_green(const CauchyGreenField &cg, int which, double gap = default_singular_gap);

    // The field at (x, y), aligned so that <v, (ref_x, ref_y)> >= 0; a unit vector in (vx, vy) when ok.
    LineStatus evaluate(double x, double y, double ref_x, double ref_y, double &vx, double &vy) const;
    // The same for n points at once (the lockstep tensor-line integrator, tensor_lines.cpp): the field at (x[k], y[k])
    // aligned with the nonzero reference (ref_x[k], ref_y[k]), status[k] a LineStatus; where it is not ok, (vx[k],
    // vy[k]) is the reference, so no NaN reaches a lane's next stage. Any input (outside, NaN) is safe. Written
    // without branches so that the arithmetic vectorises over the points (the cell corners are loaded point by point);
    // a value equals evaluate's bit for bit wherever evaluate is given a nonzero finite reference.
    void evaluate_lanes(std::size_t n, const double *x, const double *y, const double *ref_x, const double *ref_y,
                        double *vx, double *vy, std::uint8_t *status) const;
    // A hint, no result: starts loading the cells of points (x[k], y[k]) (any values, NaN included) into the cache,
    // for evaluate_lanes there soon after. The tensor-line lanes give it where their steps will about end.
    void prefetch_lanes(std::size_t n, const double *x, const double *y) const;
    // Status only (is there a usable cell around (x, y)?).
    LineStatus status_at(double x, double y) const;
    // The stored (unaligned) unit vector at grid point (i, j) and whether it may be used.
    bool point_vector(std::size_t i, std::size_t j, double &vx, double &vy) const;

    const Grid &grid() const { return m_grid; }

  private:
    Grid m_grid;
    // The grid's inverse spacing, computed once: evaluate runs millions of times, each tensor-line stage waits on
    // the one before, and a multiplication has a quarter of a division's latency.
    double m_inv_dx = 1.0, m_inv_dy = 1.0;
    std::vector<double> m_vx, m_vy;
    // The same vectors interleaved (x, y), so that a cell's corners share cache lines; an unusable point holds
    // (NaN, NaN) when masked and (NaN, 0) when undefined instead (evaluate_lanes reads its cell's status from them).
    std::vector<double> m_v;
    std::vector<std::uint8_t> m_state; // 0 ok, 1 masked, 2 undefined
    // Per cell ((ny - 1) * (nx - 1), row-major): the status of its four corners together (0 ok, 1 masked,
    // 2 singular), so that a tensor-line step reads one byte instead of four.
    std::vector<std::uint8_t> m_cell;
    // The cell holding (x, y) and the local coordinates in it; false outside the box.
    bool locate(double x, double y, std::size_t &i, std::size_t &j, double &u, double &v) const;
};

} // namespace geobarrier

#endif // GEOBARRIER_LINE_FIELD_HPP
