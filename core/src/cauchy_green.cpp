// The Cauchy–Green tensor C = DF^T DF (paper eq. `cg`) and its eigen-decomposition, computed without cancellation
// or overflow (DESIGN.md §4), pointwise and over a grid.
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/errors.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace geobarrier {

namespace {

// a*d - b*c to about one rounding error, even when the two products nearly cancel (Kahan's algorithm with fma).
double det2(double a, double b, double c, double d) {
    const double w = b * c;
    const double e = std::fma(-b, c, w); // the rounding error of w, exactly
    const double f = std::fma(a, d, -w);
    return f + e;
}

}  // namespace

CauchyGreenPoint cauchy_green_at(double f11, double f12, double f21, double f22, double abs_duration) {
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    CauchyGreenPoint p;
    const double s = std::max({std::abs(f11), std::abs(f12), std::abs(f21), std::abs(f22)});
    if (!std::isfinite(s) || !(s > 0.0)) {
        // Not a deformation gradient (NaN, Inf or zero): nothing trustworthy to report.
        p.lambda1 = p.lambda2 = p.ftle = nan;
        p.xi1_x = p.xi1_y = p.xi2_x = p.xi2_y = nan;
        p.degenerate = true;
        return p;
    }
    // Work with G = DF / s (entries in [-1, 1]) so that squaring cannot overflow or underflow; C = s^2 G^T G.
    const double g11 = f11 / s, g12 = f12 / s, g21 = f21 / s, g22 = f22 / s;
    const double c11 = g11 * g11 + g21 * g21;
    const double c12 = g11 * g12 + g21 * g22;
    const double c22 = g12 * g12 + g22 * g22;
    const double half_diff = 0.5 * (c11 - c22);
    const double r = std::hypot(half_diff, c12);
    // Dominant root: a sum of non-negative terms, no cancellation. mu2 >= 1/2 because some |g| = 1.
    const double mu2 = 0.5 * (c11 + c22) + r;
    const double det_g = det2(g11, g12, g21, g22);

    // Small root from det C = det(DF)^2 = lambda1 lambda2 instead of tr/2 - r, which would lose everything when
    // lambda1/lambda2 < 1e-16: lambda1 = (det(DF)/s)^2 / mu2.
    const double sd = s * det_g;
    p.lambda2 = (s * s) * mu2; // may overflow to +Inf for |DF| > ~1e154; the FTLE below stays finite
    p.lambda1 = std::min(sd * sd / mu2, p.lambda2); // rounding must not reorder a (near) double root
    const double log_lambda2 = 2.0 * std::log(s) + std::log(mu2);
    p.ftle = abs_duration > 0.0 ? log_lambda2 / (2.0 * abs_duration) : 0.0;

    // lambda2 - lambda1 = s^2 (mu2 - mu1) = 2 s^2 r, without the subtraction.
    if (2.0 * r <= degenerate_gap * mu2) {
        p.degenerate = true;
        p.xi1_x = 1.0;
        p.xi1_y = 0.0;
        p.xi2_x = 0.0;
        p.xi2_y = 1.0;
        return p;
    }
    // Two (parallel) eigenvectors of mu2: (c12, mu2 - c11) and (mu2 - c22, c12). mu2 - c11 = r - half_diff and
    // mu2 - c22 = r + half_diff; whichever would cancel is computed as c12^2 / (the other), since
    // (r - half_diff)(r + half_diff) = c12^2. Take the longer vector: it is the better conditioned.
    const double a = half_diff <= 0.0 ? r - half_diff : c12 * c12 / (r + half_diff);
    const double b = half_diff >= 0.0 ? r + half_diff : c12 * c12 / (r - half_diff);
    double vx, vy;
    if (std::hypot(c12, a) >= std::hypot(b, c12)) {
        vx = c12;
        vy = a;
    } else {
        vx = b;
        vy = c12;
    }
    const double norm = std::hypot(vx, vy);
    vx /= norm;
    vy /= norm;
    // A fixed sign makes the result reproducible; line fields are orientation-free anyway.
    if (vx < 0.0 || (vx == 0.0 && vy < 0.0)) {
        vx = -vx;
        vy = -vy;
    }
    p.xi2_x = vx;
    p.xi2_y = vy;
    // xi1 = Omega^T xi2, so that xi2 = Omega xi1 with Omega = [[0, -1], [1, 0]] (paper, section 2).
    p.xi1_x = vy;
    p.xi1_y = -vx;
    return p;
}

CauchyGreenField cauchy_green_field(const Grid &grid, const std::vector<double> &dF,
                                    const std::vector<std::uint8_t> &mask, double abs_duration) {
    const std::size_t count = grid.size();
    if (dF.size() != 4 * count || mask.size() != count)
        throw Error("cauchy_green_field: grid of " + std::to_string(count) + " points but " +
                    std::to_string(dF.size()) + " gradient values and " + std::to_string(mask.size()) +
                    " mask values");
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    CauchyGreenField field;
    field.grid = grid;
    field.mask = mask;
    for (auto *v : {&field.lambda1, &field.lambda2, &field.ftle, &field.xi1_x, &field.xi1_y, &field.xi2_x,
                    &field.xi2_y})
        v->assign(count, nan);
    std::uint64_t degenerate = 0;

#pragma omp parallel for schedule(static) reduction(+ : degenerate)
    for (long long i = 0; i < static_cast<long long>(count); ++i) {
        const std::size_t p = static_cast<std::size_t>(i);
        if (mask[p] & mask_trajectory_bits) continue;
        const double *f = dF.data() + 4 * p;
        const CauchyGreenPoint c = cauchy_green_at(f[0], f[1], f[2], f[3], abs_duration);
        if (!std::isfinite(c.ftle)) {
            // An unmasked but unusable gradient (NaN/Inf from upstream): flag it rather than pass NaN on.
            field.mask[p] |= mask_non_finite;
            continue;
        }
        field.lambda1[p] = c.lambda1;
        field.lambda2[p] = c.lambda2;
        field.ftle[p] = c.ftle;
        field.xi1_x[p] = c.xi1_x;
        field.xi1_y[p] = c.xi1_y;
        field.xi2_x[p] = c.xi2_x;
        field.xi2_y[p] = c.xi2_y;
        if (c.degenerate) {
            field.mask[p] |= mask_degenerate;
            ++degenerate;
        }
    }
    field.degenerate_count = degenerate;
    return field;
}

}  // namespace geobarrier
