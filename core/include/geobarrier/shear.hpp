// Shear fields of a Cauchy–Green field: the shear vectors eta± (paper eq. `shrvec`), their geodesic shear
// deviation d_g^eta± (paper eq. `dg_shr`, in the general form that also holds for damped flows) and the
// singularities of the CG line field with their index, from which elliptic regions are found without looking.
#ifndef GEOBARRIER_SHEAR_HPP
#define GEOBARRIER_SHEAR_HPP

#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/line_field.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace geobarrier {

// The weights of eq. `shrvec`: eta± = alpha xi1 ± beta xi2 with alpha = sqrt(sqrt(l2) / (sqrt(l1) + sqrt(l2)))
// and beta = sqrt(sqrt(l1) / (sqrt(l1) + sqrt(l2))), so alpha^2 + beta^2 = 1. Computed from rho = sqrt(l1/l2), so a
// lambda2 that overflowed to +Inf still gives alpha = 1, beta = 0. NaN for non-finite or negative input.
struct ShearWeights {
    double alpha = 1.0, beta = 0.0;
};
ShearWeights shear_weights(double lambda1, double lambda2);

// Weights of the generalized lambda-lines eta_lambda± = alpha xi1 ± beta xi2 (Haller & Beron-Vera 2013, "Coherent
// Lagrangian vortices"): alpha^2 = (l2 - lambda^2) / (l2 - l1), beta^2 = (lambda^2 - l1) / (l2 - l1), the two
// directions e with <e, C e> = lambda^2 |e|^2, i.e. |DF e| = lambda |e|: material lines along which every element is
// stretched by exactly lambda. Defined where l1 <= lambda^2 <= l2, NaN elsewhere (and where l1 = l2). With
// lambda = 1 and l1 l2 = 1 (area-preserving) they equal shear_weights(): alpha^2 = l2 / (1 + l2) in both, so the
// closed lambda = 1 lines of a conservative system are its closed shearlines (eq. `shrvec`).
ShearWeights lambda_line_weights(double lambda, double lambda1, double lambda2);

// Geodesic shear deviation, general form (Haller & Beron-Vera 2012 eq. 33, as the authors' 2012 code had it;
// reducing to the paper's eq. `dg_shr` when l1 l2 = 1), sign = +1 for eta+ and -1 for eta-:
//   d_g^eta± = |1 - alpha| + | ∓<grad alpha, eta±>/beta + alpha kappa1 ∓ beta kappa2 + (l1/l2 - 1) kappa1
//                              - 1/2 <grad l1, xi2>/l2 |
// The absolute value covers the whole bracket: every term in it changes sign with the orientation of (xi1, xi2),
// so only its modulus is a property of the line field. Returns +Inf when beta = 0 (lambda2 overflowed).
double shear_deviation(int sign, double lambda1, double lambda2, double kappa1, double kappa2,
                       double grad_alpha_dot_eta, double grad_lambda1_dot_xi2);

// The paper's eq. `dg_shr` for area-preserving flow maps (lambda1 = 1/lambda2), written as the authors' 2012 code
// evaluated it (sqrt(lambda2) in the first term, the absolute value over the whole bracket; the typeset equation
// has sqrt(lambda1) there and leaves the curvature terms outside, which would make d_g depend on the arbitrary
// sign of xi1). It equals shear_deviation() with lambda1 = 1/lambda2 except in the <grad lambda2, xi1> term, whose
// coefficient is 1/(2 l2 sqrt(1 + l2)) here and 1/(2 (1 + l2)^(3/2)) in the general form: the two differ by at
// most |<grad l2, xi1>| / (2 l2 (1 + l2)^(3/2)), which vanishes as lambda2 grows.
double shear_deviation_area_preserving(int sign, double lambda2, double kappa1, double kappa2,
                                       double grad_lambda2_dot_xi1, double grad_lambda2_dot_xi2);

enum class ShearDeviationForm {
    general,        // shear_deviation(): any flow
    area_preserving // shear_deviation_area_preserving(): lambda1 = 1/lambda2 assumed
};

// eta± and d_g^eta± on the grid. eta± are unit vectors built from each point's own xi1 (and xi2 = Omega xi1), so
// they are defined up to sign like xi1; NaN where the point is masked (any bit). The deviations are NaN where the
// grid derivatives are not valid (see StrainDerivatives) and +Inf where lambda2 overflowed.
struct ShearFields {
    Grid grid;
    std::vector<double> alpha, beta;
    std::vector<double> eta_plus_x, eta_plus_y, eta_minus_x, eta_minus_y;
    std::vector<double> deviation_plus, deviation_minus;
};

ShearFields shear_fields(const CauchyGreenField &cg, const StrainDerivatives &derivatives,
                         ShearDeviationForm form = ShearDeviationForm::general);
ShearFields shear_fields(const CauchyGreenField &cg, ShearDeviationForm form = ShearDeviationForm::general);

// The lambda-line fields eta_lambda± in the places of eta± (alpha, beta and the vectors; NaN where lambda^2 is
// outside [lambda1, lambda2] or the point is masked). The deviations are NaN: d_g (eq. `dg_shr`) measures how far a
// shearline is from a geodesic and has no counterpart here (lambda-lines are exact stationary curves of the
// averaged strain, Haller & Beron-Vera 2013).
ShearFields lambda_line_fields(const CauchyGreenField &cg, double lambda);

// The eta+ (sign = +1) or eta- (sign = -1) line field, for shearlines r' = eta±(r) (paper eq. `shrline`); masked
// where a trajectory was, undefined where lambda2 - lambda1 <= gap * lambda2 (as LineField::from_cauchy_green).
LineField shear_line_field(const CauchyGreenField &cg, const ShearFields &shear, int sign,
                           double gap = default_singular_gap);

// How far the flow map F_t0^t1 is from area-preserving, from |ln det DF| = |ln(lambda1 lambda2)| / 2 at the grid
// points with finite eigenvalues (Liouville: ln det DF is the integral of div v along the trajectory, so this
// samples the system's divergence over the domain and [t0, t1]). The paper (section 2.1) calls a system
// conservative when div v = 0; then F_t0^t1 preserves area and shearlines keep their length, so elliptic barriers
// keep arclength and enclosed area.
struct AreaPreservation {
    double median = 0.0, q99 = 0.0, max = 0.0; // of |ln det DF|; NaN when no point has finite eigenvalues
    std::size_t points = 0;
};
AreaPreservation area_preservation(const CauchyGreenField &cg);

// (lambda2 - lambda1) / (lambda2 + lambda1) in [0, 1]: 0 at a tensor singularity (C a multiple of I), near 1 where
// the flow map stretches strongly. Computed from the ratio, so an infinite lambda2 gives 1.
double anisotropy(double lambda1, double lambda2);

// A singularity of the CG line field (xi1, equivalently xi2 or eta±, which wind alike): a point where
// lambda1 = lambda2. `twice_index` is twice its index: +1 for a wedge (index +1/2), -1 for a trisector (-1/2);
// +2 and beyond for a point whose surroundings turn the field by a full turn or more (e.g. the centre of a circular
// shear flow, index +1). Found per grid cell from the winding of the doubled angle of xi1 around its four corners
// (the orientation-free index); a grid point that is itself degenerate (mask_degenerate) gets the winding around
// its eight neighbours instead, and its four cells are skipped.
struct TensorSingularity {
    double x = 0.0, y = 0.0; // cell centre, or the degenerate grid point
    int twice_index = 0;
    double anisotropy = 0.0; // smallest anisotropy() among the points the winding was taken around
};
std::vector<TensorSingularity> tensor_singularities(const CauchyGreenField &cg);

} // namespace geobarrier

#endif // GEOBARRIER_SHEAR_HPP
