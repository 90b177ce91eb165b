// Grid derivatives of the Cauchy–Green field (orientation-consistent differences of the eigenvector fields), the
// geodesic strain deviation (paper eq. `gdev_str`, general form) and the orientation-free LineField.
#include <geobarrier/line_field.hpp>

#include "fields/cell_corners.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

namespace geobarrier {

namespace {

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

// Interpolated vectors shorter than this (the four aligned unit corner vectors nearly cancel) mean the cell holds
// an orientation singularity of the line field: no direction is reported there.
constexpr double min_interpolated_norm = 0.1;

// d/dx (axis 0) or d/dy (axis 1) of a scalar field at (i, j): centred where both neighbours are usable, one-sided
// where one is, NaN where none is.
template <class Usable, class Value>
double difference(const Grid &g, std::size_t i, std::size_t j, int axis, const Usable &usable, const Value &value) {
    const std::size_t n = axis == 0 ? g.nx : g.ny;
    const std::size_t k = axis == 0 ? j : i;
    const double h = axis == 0 ? g.dx() : g.dy();
    auto at = [&](std::size_t m) { return axis == 0 ? i * g.nx + m : m * g.nx + j; };
    const bool has_minus = k > 0 && usable(at(k - 1));
    const bool has_plus = k + 1 < n && usable(at(k + 1));
    const std::size_t c = at(k);
    if (has_minus && has_plus) return (value(at(k + 1), c) - value(at(k - 1), c)) / (2.0 * h);
    if (has_plus) return (value(at(k + 1), c) - value(c, c)) / h;
    if (has_minus) return (value(c, c) - value(at(k - 1), c)) / h;
    return nan_value;
}

} // namespace

StrainDerivatives strain_derivatives(const CauchyGreenField &cg) {
    const Grid &g = cg.grid;
    const std::size_t n = g.size();
    StrainDerivatives d;
    d.grid = g;
    for (auto *v : {&d.dlambda1_dx, &d.dlambda1_dy, &d.dlambda2_dx, &d.dlambda2_dy, &d.kappa1, &d.kappa2})
        v->assign(n, nan_value);
    d.valid.assign(n, 0);
    auto usable = [&](std::size_t p) {
        return cg.mask[p] == 0 && std::isfinite(cg.lambda1[p]) && std::isfinite(cg.lambda2[p]) &&
               std::isfinite(cg.xi1_x[p]) && std::isfinite(cg.xi1_y[p]);
    };
    // The neighbour's eigenvector, flipped to agree with the centre's, minus nothing: differences of aligned
    // vectors are the derivative of the locally oriented field (xi is defined only up to sign).
    auto aligned = [&](const std::vector<double> &ax, const std::vector<double> &ay, std::size_t p, std::size_t c,
                       int comp) {
        const double sign = ax[p] * ax[c] + ay[p] * ay[c] < 0.0 ? -1.0 : 1.0;
        return sign * (comp == 0 ? ax[p] : ay[p]);
    };
    // Rows are independent (each point reads its neighbours, writes only itself): in parallel, since the elliptic
    // extractor and the runner's shear-deviation stage take these derivatives of the whole grid.
#pragma omp parallel for schedule(static)
    for (long long row = 0; row < static_cast<long long>(g.ny); ++row)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const std::size_t i = static_cast<std::size_t>(row);
            const std::size_t c = i * g.nx + j;
            if (!usable(c)) continue;
            auto lam1 = [&](std::size_t p, std::size_t) { return cg.lambda1[p]; };
            auto lam2 = [&](std::size_t p, std::size_t) { return cg.lambda2[p]; };
            const double l1x = difference(g, i, j, 0, usable, lam1), l1y = difference(g, i, j, 1, usable, lam1);
            const double l2x = difference(g, i, j, 0, usable, lam2), l2y = difference(g, i, j, 1, usable, lam2);
            // grad xi1 columns: d xi1 / dx and d xi1 / dy (components 0 = x, 1 = y).
            double dxi1[2][2], dxi2[2][2];
            for (int axis = 0; axis < 2; ++axis)
                for (int comp = 0; comp < 2; ++comp) {
                    dxi1[axis][comp] = difference(g, i, j, axis, usable, [&](std::size_t p, std::size_t cc) {
                        return aligned(cg.xi1_x, cg.xi1_y, p, cc, comp);
                    });
                    dxi2[axis][comp] = difference(g, i, j, axis, usable, [&](std::size_t p, std::size_t cc) {
                        return aligned(cg.xi2_x, cg.xi2_y, p, cc, comp);
                    });
                }
            const double e1x = cg.xi1_x[c], e1y = cg.xi1_y[c], e2x = cg.xi2_x[c], e2y = cg.xi2_y[c];
            // (grad xi1) xi1 = d xi1/dx * xi1_x + d xi1/dy * xi1_y: the derivative of xi1 along itself.
            const double a1x = dxi1[0][0] * e1x + dxi1[1][0] * e1y, a1y = dxi1[0][1] * e1x + dxi1[1][1] * e1y;
            const double a2x = dxi2[0][0] * e2x + dxi2[1][0] * e2y, a2y = dxi2[0][1] * e2x + dxi2[1][1] * e2y;
            const double k1 = a1x * e2x + a1y * e2y; // kappa1 = <(grad xi1) xi1, xi2>
            const double k2 = a2x * e1x + a2y * e1y; // kappa2 = <(grad xi2) xi2, xi1>
            d.dlambda1_dx[c] = l1x;
            d.dlambda1_dy[c] = l1y;
            d.dlambda2_dx[c] = l2x;
            d.dlambda2_dy[c] = l2y;
            d.kappa1[c] = k1;
            d.kappa2[c] = k2;
            const bool ok = std::isfinite(l1x) && std::isfinite(l1y) && std::isfinite(l2x) && std::isfinite(l2y) &&
                            std::isfinite(k1) && std::isfinite(k2);
            d.valid[c] = ok ? 1 : 0;
            if (!ok)
                for (auto *v : {&d.dlambda1_dx, &d.dlambda1_dy, &d.dlambda2_dx, &d.dlambda2_dy, &d.kappa1, &d.kappa2})
                    (*v)[c] = nan_value;
        }
    return d;
}

double strain_deviation(double lambda1, double lambda2, double kappa1, double grad_lambda1_dot_xi2) {
    return std::abs(lambda1 * kappa1 - 0.5 * grad_lambda1_dot_xi2) / lambda2;
}

double strain_deviation_area_preserving(double lambda2, double kappa1, double grad_lambda2_dot_xi2) {
    return std::abs(grad_lambda2_dot_xi2 + 2.0 * lambda2 * kappa1) / (2.0 * lambda2 * lambda2 * lambda2);
}

std::vector<double> strain_deviation_field(const CauchyGreenField &cg, const StrainDerivatives &d) {
    std::vector<double> out(cg.grid.size(), nan_value);
    for (std::size_t p = 0; p < out.size(); ++p) {
        if (!d.valid[p]) continue;
        const double g1 = d.dlambda1_dx[p] * cg.xi2_x[p] + d.dlambda1_dy[p] * cg.xi2_y[p];
        out[p] = strain_deviation(cg.lambda1[p], cg.lambda2[p], d.kappa1[p], g1);
    }
    return out;
}

std::vector<std::uint8_t> singular_mask(const CauchyGreenField &cg, double gap) {
    std::vector<std::uint8_t> out(cg.grid.size(), 0);
#pragma omp parallel for schedule(static)
    for (std::size_t p = 0; p < out.size(); ++p) {
        const double l1 = cg.lambda1[p], l2 = cg.lambda2[p];
        // As a ratio, so that a lambda2 that overflowed to +Inf (long horizons) counts as strongly anisotropic.
        out[p] = (cg.mask[p] != 0 || std::isnan(l1) || std::isnan(l2) || l1 >= (1.0 - gap) * l2) ? 1 : 0;
    }
    return out;
}

Grid grid_of(const gb_extract_input &input) {
    Grid g;
    g.x_min = input.x_min;
    g.x_max = input.x_max;
    g.y_min = input.y_min;
    g.y_max = input.y_max;
    g.nx = static_cast<std::size_t>(input.nx);
    g.ny = static_cast<std::size_t>(input.ny);
    return g;
}

const double *find_field(const gb_extract_input &input, const char *name) {
    for (std::uint32_t k = 0; k < input.field_count; ++k)
        if (input.fields[k].name && std::strcmp(input.fields[k].name, name) == 0) return input.fields[k].data;
    return nullptr;
}

CauchyGreenField cauchy_green_from_input(const gb_extract_input &input) {
    CauchyGreenField cg;
    cg.grid = grid_of(input);
    const std::size_t n = cg.grid.size();
    auto need = [&](const char *name) {
        const double *p = find_field(input, name);
        if (!p) throw std::invalid_argument(std::string("the core did not hand over the field \"") + name + "\"");
        return std::vector<double>(p, p + n);
    };
    cg.lambda1 = need("lambda1");
    cg.lambda2 = need("lambda2");
    cg.xi1_x = need("xi1_x");
    cg.xi1_y = need("xi1_y");
    cg.xi2_x.resize(n);
    cg.xi2_y.resize(n);
#pragma omp parallel for schedule(static)
    for (std::size_t p = 0; p < n; ++p) { // xi2 = Omega xi1 (paper, section 2.2)
        cg.xi2_x[p] = -cg.xi1_y[p];
        cg.xi2_y[p] = cg.xi1_x[p];
    }
    cg.mask.assign(input.mask, input.mask + n);
    for (std::uint8_t m : cg.mask)
        if (m & mask_degenerate) ++cg.degenerate_count;
    if (const double *f = find_field(input, "ftle")) {
        cg.ftle.assign(f, f + n);
    } else {
        const double abs_t = std::abs(input.t1 - input.t0);
        cg.ftle.resize(n);
        for (std::size_t p = 0; p < n; ++p) cg.ftle[p] = std::log(cg.lambda2[p]) / (2.0 * abs_t);
    }
    return cg;
}

const char *to_string(LineStatus status) {
    switch (status) {
    case LineStatus::ok:
        return "ok";
    case LineStatus::outside:
        return "outside";
    case LineStatus::masked:
        return "masked";
    case LineStatus::singular:
        return "singular";
    }
    return "?";
}

LineField::LineField(const Grid &grid, std::vector<double> vx, std::vector<double> vy, std::vector<std::uint8_t> masked,
                     std::vector<std::uint8_t> undefined)
    : m_grid(grid), m_vx(std::move(vx)), m_vy(std::move(vy)), m_state(grid.size(), 0) {
    const std::size_t n = grid.size();
    if (m_vx.size() != n || m_vy.size() != n || (!masked.empty() && masked.size() != n) ||
        (!undefined.empty() && undefined.size() != n))
        throw std::invalid_argument("LineField: every array must have nx * ny entries");
        // Each loop below runs point by point in parallel: a 1000 x 1000 grid is a million points, on the extractors'
        // serial path before their tensor lines.
#pragma omp parallel for schedule(static)
    for (std::size_t p = 0; p < n; ++p) {
        const double norm = std::hypot(m_vx[p], m_vy[p]);
        if (!masked.empty() && masked[p]) {
            m_state[p] = 1;
        } else if ((!undefined.empty() && undefined[p]) || !std::isfinite(norm) || norm == 0.0) {
            m_state[p] = 2;
        } else {
            m_vx[p] /= norm;
            m_vy[p] /= norm;
        }
    }
    m_inv_dx = 1.0 / grid.dx();
    m_inv_dy = 1.0 / grid.dy();
    m_v.resize(2 * n);
#pragma omp parallel for schedule(static)
    for (std::size_t p = 0; p < n; ++p) {
        // An unusable point holds (NaN, NaN) when masked and (NaN, 0) when undefined instead of its vector, so that
        // the lane evaluation learns a cell's status from the sums of its corners: the x sum is NaN when any corner
        // is unusable, the y sum when any is masked.
        m_v[2 * p] = m_state[p] == 0 ? m_vx[p] : nan_value;
        m_v[2 * p + 1] = m_state[p] == 0 ? m_vy[p] : m_state[p] == 1 ? nan_value : 0.0;
    }
    if (grid.nx < 2 || grid.ny < 2) return;
    const std::size_t cx = grid.nx - 1, cy = grid.ny - 1;
    m_cell.assign(cx * cy, 0);
#pragma omp parallel for schedule(static)
    for (std::size_t i = 0; i < cy; ++i)
        for (std::size_t j = 0; j < cx; ++j) {
            const std::size_t p = i * grid.nx + j;
            std::uint8_t c = 0;
            for (std::size_t q : {p, p + 1, p + grid.nx, p + grid.nx + 1}) {
                if (m_state[q] == 1) {
                    c = 1;
                    break;
                }
                if (m_state[q] == 2) c = 2;
            }
            m_cell[i * cx + j] = c;
        }
}

LineField LineField::from_cauchy_green(const CauchyGreenField &cg, int which, double gap) {
    if (which != 1 && which != 2) throw std::invalid_argument("LineField::from_cauchy_green: which must be 1 or 2");
    std::vector<std::uint8_t> masked(cg.grid.size(), 0);
#pragma omp parallel for schedule(static)
    for (std::size_t p = 0; p < masked.size(); ++p) masked[p] = (cg.mask[p] & mask_trajectory_bits) ? 1 : 0;
    return LineField(cg.grid, which == 1 ? cg.xi1_x : cg.xi2_x, which == 1 ? cg.xi1_y : cg.xi2_y, std::move(masked),
                     singular_mask(cg, gap));
}

inline bool LineField::locate(double x, double y, std::size_t &i, std::size_t &j, double &u, double &v) const {
    const Grid &g = m_grid;
    if (m_cell.empty() || !(x >= g.x_min && x <= g.x_max && y >= g.y_min && y <= g.y_max)) return false;
    const double fx = (x - g.x_min) * m_inv_dx, fy = (y - g.y_min) * m_inv_dy;
    j = std::min(static_cast<std::size_t>(fx), g.nx - 2);
    i = std::min(static_cast<std::size_t>(fy), g.ny - 2);
    u = fx - static_cast<double>(j);
    v = fy - static_cast<double>(i);
    return true;
}

namespace {
constexpr LineStatus cell_status[3] = {LineStatus::ok, LineStatus::masked, LineStatus::singular};
}

LineStatus LineField::status_at(double x, double y) const {
    std::size_t i, j;
    double u, v;
    if (!locate(x, y, i, j, u, v)) return LineStatus::outside;
    return cell_status[m_cell[i * (m_grid.nx - 1) + j]];
}

LineStatus LineField::evaluate(double x, double y, double ref_x, double ref_y, double &vx, double &vy) const {
    std::size_t i, j;
    double u, v;
    if (!locate(x, y, i, j, u, v)) return LineStatus::outside;
    const std::uint8_t cell = m_cell[i * (m_grid.nx - 1) + j];
    if (cell != 0) return cell_status[cell];
    const std::size_t corners[4] = {i * m_grid.nx + j, i * m_grid.nx + j + 1, (i + 1) * m_grid.nx + j,
                                    (i + 1) * m_grid.nx + j + 1};
    const double weights[4] = {(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v};
    // Without a reference, align to the corner with the largest weight.
    if (!(ref_x * ref_x + ref_y * ref_y > 0.0) || !std::isfinite(ref_x) || !std::isfinite(ref_y)) {
        std::size_t best = 0;
        for (std::size_t k = 1; k < 4; ++k)
            if (weights[k] > weights[best]) best = k;
        ref_x = m_v[2 * corners[best]];
        ref_y = m_v[2 * corners[best] + 1];
    }
    double sx = 0.0, sy = 0.0;
    for (std::size_t k = 0; k < 4; ++k) {
        const std::size_t c = corners[k];
        const double cx = m_v[2 * c], cy = m_v[2 * c + 1];
        const double sign = cx * ref_x + cy * ref_y < 0.0 ? -1.0 : 1.0;
        sx += weights[k] * sign * cx;
        sy += weights[k] * sign * cy;
    }
    // sqrt, not hypot: sx, sy are O(1) (no overflow to guard against) and hypot costs several times more.
    const double norm = std::sqrt(sx * sx + sy * sy);
    if (!(norm >= min_interpolated_norm)) return LineStatus::singular;
    const double inverse = 1.0 / norm; // one division: a tensor-line step waits on every evaluation in turn
    vx = sx * inverse;
    vy = sy * inverse;
    return LineStatus::ok;
}

namespace {

// One lane of LineField::evaluate_lanes: the field at local coordinates (u, w) of a cell whose corner vectors are
// `corners` (x, y of corners p, p + 1, p + nx, p + nx + 1), aligned with the reference (rx, ry).
inline void interpolate_lane(double u, double w, bool inside, const double *corners, double rx, double ry, double &vx,
                             double &vy, std::uint8_t &status) {
    const double weights[4] = {(1 - u) * (1 - w), u * (1 - w), (1 - u) * w, u * w};
    double sx = 0.0, sy = 0.0;
    for (int q = 0; q < 4; ++q) {
        const double cx = corners[2 * q], cy = corners[2 * q + 1];
        const double sign = cx * rx + cy * ry < 0.0 ? -1.0 : 1.0;
        sx += weights[q] * sign * cx;
        sy += weights[q] * sign * cy;
    }
    const double norm = std::sqrt(sx * sx + sy * sy);
    // Status codes as LineStatus: 0 ok, 1 outside, 2 masked, 3 singular, as m_cell would give them (masked before
    // singular) from the NaNs the constructor stored: the y sum is NaN when a corner is masked, the x sum, and
    // with it the norm, when a corner is masked or undefined (x != x: NaN, without a call, which would not
    // vectorise).
    const std::uint8_t st = !inside ? 1 : sy != sy ? 2 : !(norm >= min_interpolated_norm) ? 3 : 0;
    const bool ok = st == 0;
    const double inverse = 1.0 / (ok ? norm : 1.0);
    vx = ok ? sx * inverse : rx;
    vy = ok ? sy * inverse : ry;
    status = st;
}

// The cell of a lane's point for evaluate_lanes and prefetch_lanes: the index p of its first corner (the others are
// p + 1, p + nx, p + nx + 1) and the local coordinates (u, w), from the field's inverse spacings as locate() finds
// them (the floor, the last cell also holding the box's far edge). Outside (or NaN) the point is taken at the box's
// corner and reported outside: no branch, no bad index.
struct LaneCells {
    double x0, y0, x1, y1, inv_dx, inv_dy, last_j, last_i;
    std::ptrdiff_t nx;
    LaneCells(const Grid &g, double inverse_dx, double inverse_dy)
        : x0(g.x_min), y0(g.y_min), x1(g.x_max), y1(g.y_max), inv_dx(inverse_dx), inv_dy(inverse_dy),
          last_j(static_cast<double>(g.nx - 2)), last_i(static_cast<double>(g.ny - 2)),
          nx(static_cast<std::ptrdiff_t>(g.nx)) {}
    void locate(double px, double py, std::ptrdiff_t &p, double &u, double &w, bool &inside) const {
        inside = px >= x0 && px <= x1 && py >= y0 && py <= y1;
        const double fx = ((inside ? px : x0) - x0) * inv_dx, fy = ((inside ? py : y0) - y0) * inv_dy;
        const double cj = std::min(static_cast<double>(static_cast<std::ptrdiff_t>(fx)), last_j);
        const double ci = std::min(static_cast<double>(static_cast<std::ptrdiff_t>(fy)), last_i);
        u = fx - cj;
        w = fy - ci;
        p = static_cast<std::ptrdiff_t>(ci) * nx + static_cast<std::ptrdiff_t>(cj);
    }
};

} // namespace

void LineField::evaluate_lanes(std::size_t n, const double *x, const double *y, const double *ref_x,
                               const double *ref_y, double *vx, double *vy, std::uint8_t *status) const {
    const Grid &g = m_grid;
    if (m_cell.empty()) {
        for (std::size_t k = 0; k < n; ++k) {
            vx[k] = ref_x[k];
            vy[k] = ref_y[k];
            status[k] = static_cast<std::uint8_t>(LineStatus::outside);
        }
        return;
    }
    const LaneCells cells(g, m_inv_dx, m_inv_dy);
    const std::ptrdiff_t nx = cells.nx;
    const double *v = m_v.data();
#if defined(__AVX512F__)
    // With AVX-512 one loop: the compiler's code for it was as fast on W as copying the corners first (below).
#pragma GCC ivdep
    for (std::size_t k = 0; k < n; ++k) {
        std::ptrdiff_t p;
        double u, w;
        bool inside;
        cells.locate(x[k], y[k], p, u, w, inside);
        const double corners[8] = {v[2 * p],        v[2 * p + 1],        v[2 * p + 2],        v[2 * p + 3],
                                   v[2 * (p + nx)], v[2 * (p + nx) + 1], v[2 * (p + nx) + 2], v[2 * (p + nx) + 3]};
        interpolate_lane(u, w, inside, corners, ref_x[k], ref_y[k], vx[k], vy[k], status[k]);
    }
#else
    // With narrower vectors the compiler would assemble every corner value of every lane element by element. So the
    // corners are copied first (CornerBlock), and the arithmetic then runs vectorised over lanes on the copies (W on an
    // AVX2 build: the evaluation took ~15% less time, and less again with AVX's transposed loads). The same operations
    // in the same order: the same values bit for bit.
    detail::CornerBlock lanes;
    for (std::size_t b0 = 0; b0 < n; b0 += lanes.size) {
        const std::size_t m = std::min(lanes.size, n - b0);
        for (std::size_t k = 0; k < m; ++k) {
            std::ptrdiff_t p;
            cells.locate(x[b0 + k], y[b0 + k], p, lanes.u[k], lanes.w[k], lanes.inside[k]);
            lanes.first[k] = 2 * p;
        }
        lanes.load(v, 2 * nx, m);
#pragma GCC ivdep
        for (std::size_t k = 0; k < m; ++k) {
            const double corners[8] = {lanes.corner[0][k], lanes.corner[1][k], lanes.corner[2][k], lanes.corner[3][k],
                                       lanes.corner[4][k], lanes.corner[5][k], lanes.corner[6][k], lanes.corner[7][k]};
            interpolate_lane(lanes.u[k], lanes.w[k], lanes.inside[k], corners, ref_x[b0 + k], ref_y[b0 + k], vx[b0 + k],
                             vy[b0 + k], status[b0 + k]);
        }
    }
#endif
}

// The cells evaluate_lanes will read for these points (the same LaneCells), their two rows of corners (p, p + 1 and
// p + nx, p + nx + 1) a grid row apart.
void LineField::prefetch_lanes(std::size_t n, const double *x, const double *y) const {
    if (m_cell.empty()) return;
    const LaneCells cells(m_grid, m_inv_dx, m_inv_dy);
    const std::ptrdiff_t nx = cells.nx;
    std::ptrdiff_t first[64];
    for (std::size_t b0 = 0; b0 < n; b0 += 64) {
        const std::size_t m = std::min<std::size_t>(64, n - b0);
#pragma GCC ivdep
        for (std::size_t k = 0; k < m; ++k) {
            double u, w;
            bool inside;
            cells.locate(x[b0 + k], y[b0 + k], first[k], u, w, inside);
        }
        for (std::size_t k = 0; k < m; ++k) {
            __builtin_prefetch(m_v.data() + 2 * first[k]);
            __builtin_prefetch(m_v.data() + 2 * (first[k] + nx));
        }
    }
}

bool LineField::point_vector(std::size_t i, std::size_t j, double &vx, double &vy) const {
    const std::size_t p = i * m_grid.nx + j;
    vx = m_vx[p];
    vy = m_vy[p];
    return m_state[p] == 0;
}

} // namespace geobarrier
