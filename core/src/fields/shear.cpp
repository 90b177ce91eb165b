// Shear vectors eta± (paper eq. `shrvec`), the geodesic shear deviation (paper eq. `dg_shr`, general and
// area-preserving forms) on the grid, and the index of the CG line field's singularities.
#include <geobarrier/shear.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace geobarrier {

namespace {

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();
constexpr double pi = 3.14159265358979323846;

// Centred difference of a scalar grid field where both neighbours are usable, one-sided where one is, NaN where
// none is (the rule strain_derivatives() uses, so all derivatives of d_g are taken alike).
double scalar_difference(const Grid &g, const std::vector<double> &f, const std::vector<std::uint8_t> &usable,
                         std::size_t i, std::size_t j, int axis) {
    const std::size_t n = axis == 0 ? g.nx : g.ny;
    const std::size_t k = axis == 0 ? j : i;
    const double h = axis == 0 ? g.dx() : g.dy();
    auto at = [&](std::size_t m) { return axis == 0 ? i * g.nx + m : m * g.nx + j; };
    const bool has_minus = k > 0 && usable[at(k - 1)];
    const bool has_plus = k + 1 < n && usable[at(k + 1)];
    if (has_minus && has_plus) return (f[at(k + 1)] - f[at(k - 1)]) / (2.0 * h);
    if (has_plus) return (f[at(k + 1)] - f[at(k)]) / h;
    if (has_minus) return (f[at(k)] - f[at(k - 1)]) / h;
    return nan_value;
}

// The doubled angle of an orientation-free direction: the same for v and -v.
double doubled_angle(double vx, double vy) { return 2.0 * std::atan2(vy, vx); }

// Twice the index of the line field around a closed loop of directions (counter-clockwise): the winding of the
// doubled angle, with every step taken as the shorter turn.
int twice_winding(const double *angles, std::size_t n) {
    double total = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
        double d = angles[(k + 1) % n] - angles[k];
        d = std::remainder(d, 2.0 * pi); // into [-pi, pi]
        total += d;
    }
    return static_cast<int>(std::lround(total / (2.0 * pi)));
}

} // namespace

ShearWeights shear_weights(double lambda1, double lambda2) {
    ShearWeights w;
    if (!(lambda1 >= 0.0) || !(lambda2 > 0.0) || std::isnan(lambda1) || std::isnan(lambda2)) {
        w.alpha = w.beta = nan_value;
        return w;
    }
    // rho = sqrt(l1 / l2) in [0, 1]: alpha^2 = 1 / (1 + rho), beta^2 = rho / (1 + rho).
    const double rho = std::isinf(lambda2) ? 0.0 : std::sqrt(std::min(lambda1 / lambda2, 1.0));
    w.alpha = 1.0 / std::sqrt(1.0 + rho);
    w.beta = std::sqrt(rho / (1.0 + rho));
    return w;
}

ShearWeights lambda_line_weights(double lambda, double lambda1, double lambda2) {
    ShearWeights w;
    const double l2 = lambda * lambda;
    if (!(lambda1 >= 0.0) || !(lambda2 > lambda1) || !(l2 >= lambda1) || !(l2 <= lambda2) || std::isnan(l2)) {
        w.alpha = w.beta = nan_value;
        return w;
    }
    if (std::isinf(lambda2)) { // beta^2 = (lambda^2 - l1) / l2 -> 0
        w.alpha = 1.0;
        w.beta = 0.0;
        return w;
    }
    const double d = lambda2 - lambda1;
    w.alpha = std::sqrt((lambda2 - l2) / d);
    w.beta = std::sqrt((l2 - lambda1) / d);
    return w;
}

ShearFields lambda_line_fields(const CauchyGreenField &cg, double lambda) {
    const std::size_t n = cg.grid.size();
    ShearFields f;
    f.grid = cg.grid;
    for (auto *v : {&f.alpha, &f.beta, &f.eta_plus_x, &f.eta_plus_y, &f.eta_minus_x, &f.eta_minus_y, &f.deviation_plus,
                    &f.deviation_minus})
        v->assign(n, nan_value);
    for (std::size_t p = 0; p < n; ++p) {
        if (cg.mask[p] & mask_trajectory_bits) continue;
        const ShearWeights w = lambda_line_weights(lambda, cg.lambda1[p], cg.lambda2[p]);
        if (std::isnan(w.alpha) || !std::isfinite(cg.xi1_x[p]) || !std::isfinite(cg.xi1_y[p])) continue;
        f.alpha[p] = w.alpha;
        f.beta[p] = w.beta;
        f.eta_plus_x[p] = w.alpha * cg.xi1_x[p] + w.beta * cg.xi2_x[p];
        f.eta_plus_y[p] = w.alpha * cg.xi1_y[p] + w.beta * cg.xi2_y[p];
        f.eta_minus_x[p] = w.alpha * cg.xi1_x[p] - w.beta * cg.xi2_x[p];
        f.eta_minus_y[p] = w.alpha * cg.xi1_y[p] - w.beta * cg.xi2_y[p];
    }
    return f;
}

AreaPreservation area_preservation(const CauchyGreenField &cg) {
    std::vector<double> v;
    v.reserve(cg.grid.size());
    for (std::size_t p = 0; p < cg.grid.size(); ++p) {
        if (cg.mask[p] & mask_trajectory_bits) continue;
        const double l1 = cg.lambda1[p], l2 = cg.lambda2[p];
        if (std::isfinite(l1) && std::isfinite(l2) && l1 > 0.0 && l2 > 0.0)
            v.push_back(0.5 * std::abs(std::log(l1) + std::log(l2)));
    }
    AreaPreservation a;
    a.points = v.size();
    if (v.empty()) {
        a.median = a.q99 = a.max = nan_value;
        return a;
    }
    auto quantile = [&](double q) {
        const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())));
        std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
        return v[k];
    };
    a.median = quantile(0.5);
    a.q99 = quantile(0.99);
    a.max = *std::max_element(v.begin(), v.end());
    return a;
}

double anisotropy(double lambda1, double lambda2) {
    if (std::isinf(lambda2)) return 1.0;
    const double r = std::min(lambda1 / lambda2, 1.0);
    return (1.0 - r) / (1.0 + r);
}

double shear_deviation(int sign, double lambda1, double lambda2, double kappa1, double kappa2,
                       double grad_alpha_dot_eta, double grad_lambda1_dot_xi2) {
    const ShearWeights w = shear_weights(lambda1, lambda2);
    if (!(w.beta > 0.0)) return std::isnan(w.beta) ? nan_value : std::numeric_limits<double>::infinity();
    const double s = sign >= 0 ? 1.0 : -1.0;
    const double bracket = -s * grad_alpha_dot_eta / w.beta + w.alpha * kappa1 - s * w.beta * kappa2 +
                           (lambda1 / lambda2 - 1.0) * kappa1 - 0.5 * grad_lambda1_dot_xi2 / lambda2;
    return std::abs(1.0 - w.alpha) + std::abs(bracket);
}

double shear_deviation_area_preserving(int sign, double lambda2, double kappa1, double kappa2,
                                       double grad_lambda2_dot_xi1, double grad_lambda2_dot_xi2) {
    const double s = sign >= 0 ? 1.0 : -1.0;
    const double l2 = lambda2;
    const double r = std::sqrt(1.0 + l2); // sqrt(1 + lambda2)
    const double sl2 = std::sqrt(l2);
    const double first = (r - sl2) / r;
    const double bracket =
        grad_lambda2_dot_xi1 / (2.0 * l2 * r) -
        s * grad_lambda2_dot_xi2 * (r * r * r - sl2 * sl2 * sl2 * sl2 * sl2) / (2.0 * l2 * l2 * l2 * r * r * r) -
        s * kappa1 * (sl2 * sl2 * sl2 * sl2 * sl2 + (1.0 - l2 * l2) * r) / (l2 * l2 * r) + kappa2 / r;
    return first + std::abs(bracket);
}

ShearFields shear_fields(const CauchyGreenField &cg, const StrainDerivatives &d, ShearDeviationForm form) {
    const Grid &g = cg.grid;
    const std::size_t n = g.size();
    if (d.kappa1.size() != n) throw std::invalid_argument("shear_fields: derivatives of another grid");
    ShearFields f;
    f.grid = g;
    for (auto *v : {&f.alpha, &f.beta, &f.eta_plus_x, &f.eta_plus_y, &f.eta_minus_x, &f.eta_minus_y, &f.deviation_plus,
                    &f.deviation_minus})
        v->assign(n, nan_value);
    std::vector<std::uint8_t> usable(n, 0);
    for (std::size_t p = 0; p < n; ++p) {
        if (cg.mask[p] & mask_trajectory_bits) continue;
        const ShearWeights w = shear_weights(cg.lambda1[p], cg.lambda2[p]);
        if (std::isnan(w.alpha) || !std::isfinite(cg.xi1_x[p]) || !std::isfinite(cg.xi1_y[p])) continue;
        f.alpha[p] = w.alpha;
        f.beta[p] = w.beta;
        f.eta_plus_x[p] = w.alpha * cg.xi1_x[p] + w.beta * cg.xi2_x[p];
        f.eta_plus_y[p] = w.alpha * cg.xi1_y[p] + w.beta * cg.xi2_y[p];
        f.eta_minus_x[p] = w.alpha * cg.xi1_x[p] - w.beta * cg.xi2_x[p];
        f.eta_minus_y[p] = w.alpha * cg.xi1_y[p] - w.beta * cg.xi2_y[p];
        usable[p] = cg.mask[p] == 0 ? 1 : 0; // degenerate points: alpha is fine, their eigenvectors are not
    }
#pragma omp parallel for schedule(static)
    for (long long row = 0; row < static_cast<long long>(g.ny); ++row) {
        const std::size_t i = static_cast<std::size_t>(row);
        for (std::size_t j = 0; j < g.nx; ++j) {
            const std::size_t p = i * g.nx + j;
            if (!d.valid[p] || !usable[p]) continue;
            const double ax = scalar_difference(g, f.alpha, usable, i, j, 0);
            const double ay = scalar_difference(g, f.alpha, usable, i, j, 1);
            if (!std::isfinite(ax) || !std::isfinite(ay)) continue;
            const double l1 = cg.lambda1[p], l2 = cg.lambda2[p];
            if (form == ShearDeviationForm::general) {
                const double g1x2 = d.dlambda1_dx[p] * cg.xi2_x[p] + d.dlambda1_dy[p] * cg.xi2_y[p];
                const double ap = ax * f.eta_plus_x[p] + ay * f.eta_plus_y[p];
                const double am = ax * f.eta_minus_x[p] + ay * f.eta_minus_y[p];
                f.deviation_plus[p] = shear_deviation(+1, l1, l2, d.kappa1[p], d.kappa2[p], ap, g1x2);
                f.deviation_minus[p] = shear_deviation(-1, l1, l2, d.kappa1[p], d.kappa2[p], am, g1x2);
            } else {
                const double g2x1 = d.dlambda2_dx[p] * cg.xi1_x[p] + d.dlambda2_dy[p] * cg.xi1_y[p];
                const double g2x2 = d.dlambda2_dx[p] * cg.xi2_x[p] + d.dlambda2_dy[p] * cg.xi2_y[p];
                f.deviation_plus[p] = shear_deviation_area_preserving(+1, l2, d.kappa1[p], d.kappa2[p], g2x1, g2x2);
                f.deviation_minus[p] = shear_deviation_area_preserving(-1, l2, d.kappa1[p], d.kappa2[p], g2x1, g2x2);
            }
        }
    }
    return f;
}

ShearFields shear_fields(const CauchyGreenField &cg, ShearDeviationForm form) {
    return shear_fields(cg, strain_derivatives(cg), form);
}

LineField shear_line_field(const CauchyGreenField &cg, const ShearFields &shear, int sign, double gap) {
    std::vector<std::uint8_t> masked(cg.grid.size(), 0);
    for (std::size_t p = 0; p < masked.size(); ++p) masked[p] = (cg.mask[p] & mask_trajectory_bits) ? 1 : 0;
    return LineField(cg.grid, sign >= 0 ? shear.eta_plus_x : shear.eta_minus_x,
                     sign >= 0 ? shear.eta_plus_y : shear.eta_minus_y, std::move(masked), singular_mask(cg, gap));
}

std::vector<TensorSingularity> tensor_singularities(const CauchyGreenField &cg) {
    const Grid &g = cg.grid;
    std::vector<TensorSingularity> out;
    if (g.nx < 2 || g.ny < 2) return out;
    auto usable = [&](std::size_t p) {
        return cg.mask[p] == 0 && std::isfinite(cg.xi1_x[p]) && std::isfinite(cg.xi1_y[p]) &&
               std::isfinite(cg.lambda1[p]) && !std::isnan(cg.lambda2[p]);
    };
    auto degenerate = [&](std::size_t p) {
        return (cg.mask[p] & mask_trajectory_bits) == 0 && (cg.mask[p] & mask_degenerate) != 0;
    };
    // Cells: corners counter-clockwise (row index = y).
    for (std::size_t i = 0; i + 1 < g.ny; ++i)
        for (std::size_t j = 0; j + 1 < g.nx; ++j) {
            const std::size_t c[4] = {i * g.nx + j, i * g.nx + j + 1, (i + 1) * g.nx + j + 1, (i + 1) * g.nx + j};
            bool ok = true;
            double angles[4];
            double aniso = 1.0;
            for (int k = 0; k < 4 && ok; ++k) {
                ok = usable(c[k]);
                if (!ok) break;
                angles[k] = doubled_angle(cg.xi1_x[c[k]], cg.xi1_y[c[k]]);
                aniso = std::min(aniso, anisotropy(cg.lambda1[c[k]], cg.lambda2[c[k]]));
            }
            if (!ok) continue;
            const int w = twice_winding(angles, 4);
            if (w != 0)
                out.push_back({g.x_min + (static_cast<double>(j) + 0.5) * g.dx(),
                               g.y_min + (static_cast<double>(i) + 0.5) * g.dy(), w, aniso});
        }
    // Degenerate grid points: the winding around their eight neighbours.
    for (std::size_t i = 1; i + 1 < g.ny; ++i)
        for (std::size_t j = 1; j + 1 < g.nx; ++j) {
            if (!degenerate(i * g.nx + j)) continue;
            const long di[8] = {-1, -1, -1, 0, 1, 1, 1, 0}, dj[8] = {-1, 0, 1, 1, 1, 0, -1, -1};
            double angles[8];
            double aniso = 1.0;
            bool ok = true;
            for (int k = 0; k < 8 && ok; ++k) {
                const std::size_t q = (i + di[k]) * g.nx + (j + dj[k]);
                ok = usable(q);
                if (!ok) break;
                angles[k] = doubled_angle(cg.xi1_x[q], cg.xi1_y[q]);
                aniso = std::min(aniso, anisotropy(cg.lambda1[q], cg.lambda2[q]));
            }
            if (!ok) continue;
            const int w = twice_winding(angles, 8);
            if (w != 0) out.push_back({g.x(j), g.y(i), w, aniso});
        }
    return out;
}

} // namespace geobarrier
