// The Cauchy–Green tensor C = DF^T DF (paper eq. `cg`) and its eigen-decomposition, computed without cancellation
// or overflow (lambda1 = det(DF)^2 / lambda2, not the small root), pointwise and over a grid, also for DF beyond the
// double range (renormalised variational equations: DF = 2^e G) and with det DF from Liouville's formula.
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/errors.hpp>

// GCC 12 reports -Wmaybe-uninitialized inside its own AVX-512 intrinsics (the undefined pass-through operand of
// _mm512_extractf64x4_pd) wherever Eigen's packet code is inlined under -march=native: a false positive, silenced for
// the headers' own lines only.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <Eigen/Dense>
#pragma GCC diagnostic pop

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

} // namespace

CauchyGreenPoint cauchy_green_at(double f11, double f12, double f21, double f22, double abs_duration) {
    return cauchy_green_at(f11, f12, f21, f22, abs_duration, 0, std::numeric_limits<double>::quiet_NaN());
}

CauchyGreenPoint cauchy_green_at(double f11, double f12, double f21, double f22, double abs_duration, int exponent,
                                 double log_abs_det) {
    return cauchy_green_at(f11, f12, f21, f22, abs_duration, exponent, log_abs_det, CauchyGreenParts{});
}

CauchyGreenPoint cauchy_green_at(double f11, double f12, double f21, double f22, double abs_duration, int exponent,
                                 double log_abs_det, CauchyGreenParts parts) {
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    constexpr double ln2 = 0.69314718055994530942;
    CauchyGreenPoint p;
    const double big = std::max({std::abs(f11), std::abs(f12), std::abs(f21), std::abs(f22)});
    if (!std::isfinite(big) || !(big > 0.0)) {
        // Not a deformation gradient (NaN, Inf or zero): nothing trustworthy to report.
        p.lambda1 = p.lambda2 = p.ftle = nan;
        p.xi1_x = p.xi1_y = p.xi2_x = p.xi2_y = nan;
        p.degenerate = true;
        return p;
    }
    // Work with G = DF / 2^k, 2^k the power of 2 at or below the largest entry. The scaling is exact, so G holds DF's
    // entries unrounded (dividing by the largest entry itself would round them, and det G, a cancellation when
    // lambda1 << lambda2, would then lose every digit), and max |g| lies in [1, 2): squares neither overflow nor
    // underflow. With the caller's exponent, DF = 2^E G and C = 4^E G^T G.
    const int k = std::ilogb(big);
    const int e = exponent + k;
    const double g11 = std::ldexp(f11, -k), g12 = std::ldexp(f12, -k), g21 = std::ldexp(f21, -k),
                 g22 = std::ldexp(f22, -k);
    const double c11 = g11 * g11 + g21 * g21;
    const double c12 = g11 * g12 + g21 * g22;
    const double c22 = g12 * g12 + g22 * g22;
    const double half_diff = 0.5 * (c11 - c22);
    const double r = std::hypot(half_diff, c12);
    // Dominant root: a sum of non-negative terms, no cancellation. mu2 >= 1/2 because some |g| >= 1.
    const double mu2 = 0.5 * (c11 + c22) + r;
    const double det_g = det2(g11, g12, g21, g22);

    p.lambda2 = std::ldexp(mu2, 2 * e); // exact scaling; +Inf beyond the double range, where the FTLE stays finite
    const double log_lambda2 = 2.0 * e * ln2 + std::log(mu2);
    if (!parts.lambda1) {
        p.lambda1 = nan;
    } else if (std::isfinite(log_abs_det)) {
        // Liouville's det DF (variational equations): exact for area-preserving flows, and free of the cancellation
        // that loses det G once lambda2 exceeds ~1/eps.
        p.lambda1 = std::exp(2.0 * log_abs_det - log_lambda2);
    } else if (det_g == 0.0) {
        p.lambda1 = 0.0;
    } else {
        // Small root from det C = det(DF)^2 = lambda1 lambda2 instead of tr/2 - r, which would lose everything when
        // lambda1/lambda2 < 1e-16: lambda1 = 4^E det(G)^2 / mu2, with det G's own power of 2 taken out so that
        // squaring cannot underflow. Roundings: det2 (~1.5 ulp, doubled by the square), mu2 and two products.
        const int kd = std::ilogb(det_g);
        const double m = std::ldexp(std::abs(det_g), -kd);
        p.lambda1 = std::ldexp(m * m / mu2, 2 * (kd + e));
    }
    if (parts.lambda1) p.lambda1 = std::min(p.lambda1, p.lambda2); // rounding must not reorder a (near) double root
    p.ftle = abs_duration > 0.0 ? log_lambda2 / (2.0 * abs_duration) : 0.0;

    // lambda2 - lambda1 = 4^E (mu2 - mu1) = 4^E 2 r, without the subtraction.
    if (2.0 * r <= degenerate_gap * mu2) {
        p.degenerate = true;
        p.xi1_x = 1.0;
        p.xi1_y = 0.0;
        p.xi2_x = 0.0;
        p.xi2_y = 1.0;
        return p;
    }
    if (!parts.eigenvectors) return p;
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
    return cauchy_green_field(grid, dF, mask, abs_duration, {}, {});
}

CauchyGreenField cauchy_green_field(const Grid &grid, const std::vector<double> &dF,
                                    const std::vector<std::uint8_t> &mask, double abs_duration,
                                    const std::vector<std::int32_t> &dF_exponent, const std::vector<double> &log_det) {
    const std::size_t count = grid.size();
    if (dF.size() != 4 * count || mask.size() != count)
        throw Error("cauchy_green_field: grid of " + std::to_string(count) + " points but " +
                    std::to_string(dF.size()) + " gradient values and " + std::to_string(mask.size()) + " mask values");
    if ((!dF_exponent.empty() && dF_exponent.size() != count) || (!log_det.empty() && log_det.size() != count))
        throw Error("cauchy_green_field: grid of " + std::to_string(count) + " points but " +
                    std::to_string(dF_exponent.size()) + " DF exponents and " + std::to_string(log_det.size()) +
                    " log-determinants");
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    CauchyGreenField field;
    field.grid = grid;
    field.mask = mask;
    for (auto *v :
         {&field.lambda1, &field.lambda2, &field.ftle, &field.xi1_x, &field.xi1_y, &field.xi2_x, &field.xi2_y})
        v->assign(count, nan);
    field.degenerate_count =
        cauchy_green_into(field, 0, count, dF.data(), mask.data(), dF_exponent.empty() ? nullptr : dF_exponent.data(),
                          log_det.empty() ? nullptr : log_det.data(), abs_duration);
    return field;
}

std::uint64_t cauchy_green_into(CauchyGreenField &out, std::size_t first, std::size_t count, const double *dF,
                                const std::uint8_t *mask, const std::int32_t *dF_exponent, const double *log_det,
                                double abs_duration) {
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    const std::size_t size = out.mask.size();
    if (first + count > size)
        throw Error("cauchy_green_into: points " + std::to_string(first) + " .. " + std::to_string(first + count) +
                    " beyond the field's " + std::to_string(size));
    // A field is wanted when it has the grid's size; anything else must be empty.
    const auto wanted = [&](std::vector<double> &v, const char *name) -> double * {
        if (!v.empty() && v.size() != size)
            throw Error(std::string("cauchy_green_into: ") + name + " has " + std::to_string(v.size()) +
                        " values for " + std::to_string(size) + " points");
        return v.empty() ? nullptr : v.data() + first;
    };
    double *lambda1 = wanted(out.lambda1, "lambda1"), *lambda2 = wanted(out.lambda2, "lambda2"),
           *ftle = wanted(out.ftle, "ftle"), *xi1_x = wanted(out.xi1_x, "xi1_x"), *xi1_y = wanted(out.xi1_y, "xi1_y"),
           *xi2_x = wanted(out.xi2_x, "xi2_x"), *xi2_y = wanted(out.xi2_y, "xi2_y");
    std::uint8_t *out_mask = out.mask.data() + first;
    const CauchyGreenParts parts{lambda1 != nullptr, xi1_x || xi1_y || xi2_x || xi2_y};
    std::uint64_t degenerate = 0;

#pragma omp parallel for schedule(static) reduction(+ : degenerate)
    for (long long i = 0; i < static_cast<long long>(count); ++i) {
        const std::size_t p = static_cast<std::size_t>(i);
        out_mask[p] = mask[p];
        CauchyGreenPoint c;
        if (!(mask[p] & mask_trajectory_bits)) {
            const double *f = dF + 4 * p;
            c = cauchy_green_at(f[0], f[1], f[2], f[3], abs_duration, dF_exponent ? dF_exponent[p] : 0,
                                log_det ? log_det[p] : nan, parts);
            // An unmasked but unusable gradient (NaN/Inf from upstream): flag it rather than pass NaN on.
            if (!std::isfinite(c.ftle))
                out_mask[p] |= mask_non_finite;
            else if (c.degenerate) {
                out_mask[p] |= mask_degenerate;
                ++degenerate;
            }
        }
        if (mask[p] & mask_trajectory_bits || !std::isfinite(c.ftle)) {
            c.lambda1 = c.lambda2 = c.ftle = c.xi1_x = c.xi1_y = c.xi2_x = c.xi2_y = nan;
        }
        if (lambda1) lambda1[p] = c.lambda1;
        if (lambda2) lambda2[p] = c.lambda2;
        if (ftle) ftle[p] = c.ftle;
        if (xi1_x) xi1_x[p] = c.xi1_x;
        if (xi1_y) xi1_y[p] = c.xi1_y;
        if (xi2_x) xi2_x[p] = c.xi2_x;
        if (xi2_y) xi2_y[p] = c.xi2_y;
    }
    return degenerate;
}

CauchyGreenND cauchy_green_nd(const double *dF, unsigned dimension, double abs_duration, int exponent,
                              double log_abs_det) {
    constexpr double ln2 = 0.69314718055994530942;
    const unsigned n = dimension;
    CauchyGreenND r;
    r.dimension = n;
    r.lambda.assign(n, std::numeric_limits<double>::quiet_NaN());
    r.eigenvectors.assign(std::size_t{n} * n, std::numeric_limits<double>::quiet_NaN());
    r.ftle = r.log_lambda_max = r.log_lambda_min = std::numeric_limits<double>::quiet_NaN();
    Eigen::MatrixXd G(n, n);
    double big = 0.0;
    for (unsigned i = 0; i < n; ++i)
        for (unsigned j = 0; j < n; ++j) {
            G(i, j) = dF[i * n + j];
            big = std::max(big, std::abs(G(i, j)));
        }
    if (!std::isfinite(big) || !(big > 0.0)) return r;
    // G / 2^k exactly (as in the planar path): singular values near 1, no overflow in the SVD's rotations.
    const int k = std::ilogb(big);
    G *= std::ldexp(1.0, -k);
    const int e = exponent + k;
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(G, Eigen::ComputeFullV);
    const Eigen::VectorXd s = svd.singularValues(); // descending
    std::vector<double> log_sigma(n);
    for (unsigned i = 0; i < n; ++i) log_sigma[i] = std::log(s(i)) + e * ln2;
    if (std::isfinite(log_abs_det)) {
        double others = 0.0;
        for (unsigned i = 0; i + 1 < n; ++i) others += log_sigma[i];
        log_sigma[n - 1] = std::min(log_abs_det - others, log_sigma[n - 2]);
    }
    for (unsigned i = 0; i < n; ++i) {
        const unsigned from = n - 1 - i; // ascending
        r.lambda[i] = std::exp(2.0 * log_sigma[from]);
        for (unsigned j = 0; j < n; ++j) r.eigenvectors[std::size_t{i} * n + j] = svd.matrixV()(j, from);
    }
    r.log_lambda_max = 2.0 * log_sigma[0];
    r.log_lambda_min = 2.0 * log_sigma[n - 1];
    r.ftle = abs_duration > 0.0 ? r.log_lambda_max / (2.0 * abs_duration) : 0.0;
    return r;
}

void slice_gradient(const double *dF, unsigned dimension, const std::array<unsigned, 2> &axes, SliceTensor tensor,
                    int exponent, double log_abs_det, double *out, double &out_log_abs_det) {
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    const unsigned n = dimension, a = axes[0], b = axes[1];
    out_log_abs_det = nan;
    switch (tensor) {
    case SliceTensor::projected:
        out[0] = dF[a * n + a];
        out[1] = dF[a * n + b];
        out[2] = dF[b * n + a];
        out[3] = dF[b * n + b];
        return;
    case SliceTensor::restricted: {
        Eigen::MatrixXd M(n, 2);
        for (unsigned i = 0; i < n; ++i) {
            M(i, 0) = dF[i * n + a];
            M(i, 1) = dF[i * n + b];
        }
        const Eigen::HouseholderQR<Eigen::MatrixXd> qr(M);
        const Eigen::MatrixXd R = qr.matrixQR().topRows(2).triangularView<Eigen::Upper>();
        out[0] = R(0, 0);
        out[1] = R(0, 1);
        out[2] = 0.0;
        out[3] = R(1, 1);
        return;
    }
    case SliceTensor::full: {
        // diag(s_max, s_min) in DF's own scale 2^exponent: cauchy_green_at then applies the same exponent.
        const CauchyGreenND cg = cauchy_green_nd(dF, n, 1.0, 0, nan);
        constexpr double ln2 = 0.69314718055994530942;
        const double log_max = 0.5 * cg.log_lambda_max;
        double log_min = 0.5 * cg.log_lambda_min;
        if (std::isfinite(log_abs_det) && std::isfinite(log_max)) {
            // Liouville in DF's scale: log|det dF| = log|det DF| - n exponent log 2; s_min = |det| / (others).
            double others = 0.0;
            for (unsigned i = 1; i + 1 < n; ++i) others += 0.5 * std::log(cg.lambda[i]);
            log_min = std::min(log_abs_det - n * exponent * ln2 - log_max - others, log_max);
            // Both entries in DF's true scale: cauchy_green_at adds log_abs_det only through det = product.
            out_log_abs_det = log_max + log_min + 2 * exponent * ln2;
        }
        out[0] = std::exp(log_max);
        out[1] = out[2] = 0.0;
        out[3] = std::exp(log_min);
        return;
    }
    }
}

} // namespace geobarrier
