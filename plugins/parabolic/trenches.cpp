// Trench tracing for the parabolic extractor's "shearless" method (see trenches.hpp).
#include "trenches.hpp"

#include <geobarrier/curves.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

namespace geobarrier::parabolic {

namespace {

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

struct Vec {
    double x = 0.0, y = 0.0;
};

class TrenchField {
  public:
    TrenchField(const Grid &grid, const std::vector<double> &field, const std::vector<std::uint8_t> &mask,
                std::uint8_t bits)
        : m_grid(grid), m_field(field), m_mask(mask), m_bits(bits), m_hxx(grid.size(), nan_value),
          m_hxy(grid.size(), nan_value), m_hyy(grid.size(), nan_value) {
        const std::size_t nx = grid.nx, ny = grid.ny;
        const double dx = grid.dx(), dy = grid.dy();
        auto at = [&](std::size_t i, std::size_t j) {
            const std::size_t k = i * nx + j;
            return (mask.empty() || !(mask[k] & bits)) ? field[k] : nan_value;
        };
        // Centred second differences; NaN (unusable) unless the whole 3 x 3 block is.
        for (std::size_t i = 1; i + 1 < ny; ++i)
            for (std::size_t j = 1; j + 1 < nx; ++j) {
                const double c = at(i, j);
                const double xx = (at(i, j + 1) - 2 * c + at(i, j - 1)) / (dx * dx);
                const double yy = (at(i + 1, j) - 2 * c + at(i - 1, j)) / (dy * dy);
                const double xy =
                    (at(i + 1, j + 1) - at(i + 1, j - 1) - at(i - 1, j + 1) + at(i - 1, j - 1)) / (4 * dx * dy);
                if (std::isfinite(xx) && std::isfinite(yy) && std::isfinite(xy)) {
                    m_hxx[i * nx + j] = xx;
                    m_hxy[i * nx + j] = xy;
                    m_hyy[i * nx + j] = yy;
                }
            }
    }

    double value(Vec p) const { return sample_field(m_grid, m_field, m_mask, p.x, p.y, m_bits); }

    // The direction across which the field curves up most (unit), from the Hessian at p (bilinear between grid
    // points), when that curvature is positive and exceeds the other eigenvalue's magnitude.
    std::optional<Vec> across(Vec p) const {
        const double a = sample_field(m_grid, m_hxx, {}, p.x, p.y), b = sample_field(m_grid, m_hxy, {}, p.x, p.y),
                     c = sample_field(m_grid, m_hyy, {}, p.x, p.y);
        return across(a, b, c);
    }
    std::optional<Vec> across_at(std::size_t k) const { return across(m_hxx[k], m_hxy[k], m_hyy[k]); }

  private:
    static std::optional<Vec> across(double a, double b, double c) {
        if (!std::isfinite(a) || !std::isfinite(b) || !std::isfinite(c)) return std::nullopt;
        const double mean = 0.5 * (a + c), r = std::hypot(0.5 * (a - c), b);
        const double k1 = mean + r, k2 = mean - r;
        if (!(k1 > 0.0) || !(k1 > std::abs(k2)) || r == 0.0) return std::nullopt;
        Vec u{b, k1 - a}, v{k1 - c, b};
        const double nu = std::hypot(u.x, u.y), nv = std::hypot(v.x, v.y);
        if (nu >= nv) return Vec{u.x / nu, u.y / nu};
        return Vec{v.x / nv, v.y / nv};
    }

    const Grid &m_grid;
    const std::vector<double> &m_field;
    const std::vector<std::uint8_t> &m_mask;
    std::uint8_t m_bits;
    std::vector<double> m_hxx, m_hxy, m_hyy;
};

// The trench's depth at p: how far the field at p lies below the lesser of its values at +-w along n.
double depth(const TrenchField &f, Vec p, Vec n, double w) {
    const double c = f.value(p), a = f.value({p.x + w * n.x, p.y + w * n.y}),
                 b = f.value({p.x - w * n.x, p.y - w * n.y});
    return std::min(a, b) - c; // NaN when any is masked
}

// The least value along n within +-h of q: the least of 9 samples, then the vertex of a parabola through it and
// the values one grid spacing h to either side. The wide stencil matters: between grid points the bilinear
// interpolant is piecewise linear across a trench, so its own least value sits on a grid line, and only values a
// cell apart carry where the trench lies between the lines. None when the least sample is an end one (no trench
// crossed) or a value is masked.
std::optional<Vec> settle(const TrenchField &f, Vec q, Vec n, double h) {
    constexpr int samples = 9;
    const double step = 2.0 * h / (samples - 1);
    std::array<double, samples> v{};
    for (int k = 0; k < samples; ++k) {
        const double s = -h + step * k;
        v[k] = f.value({q.x + s * n.x, q.y + s * n.y});
        if (!std::isfinite(v[k])) return std::nullopt;
    }
    const int k = static_cast<int>(std::min_element(v.begin(), v.end()) - v.begin());
    if (k == 0 || k == samples - 1) return std::nullopt;
    const double s0 = -h + step * k;
    const double below = f.value({q.x + (s0 - h) * n.x, q.y + (s0 - h) * n.y}),
                 above = f.value({q.x + (s0 + h) * n.x, q.y + (s0 + h) * n.y});
    if (!std::isfinite(below) || !std::isfinite(above)) return std::nullopt;
    const double curvature = below - 2 * v[k] + above;
    const double shift = curvature > 0.0 ? 0.5 * h * (below - above) / curvature : 0.0;
    const double s = s0 + std::clamp(shift, -step, step);
    return Vec{q.x + s * n.x, q.y + s * n.y};
}

} // namespace

std::vector<Trench> trace_trenches(const Grid &grid, const std::vector<double> &field,
                                   const std::vector<std::uint8_t> &mask, std::uint8_t mask_bits,
                                   const TrenchSettings &settings) {
    const TrenchField f(grid, field, mask, mask_bits);
    const double h = std::min(grid.dx(), grid.dy());
    const double w = settings.probe_cells * h;
    const double step = 0.5 * h;
    const std::size_t max_steps = static_cast<std::size_t>(std::ceil(settings.max_length / step)) + 1;

    // Seeds, deepest first.
    struct Seed {
        std::size_t k;
        Vec n;
        double depth;
    };
    std::vector<Seed> seeds;
    for (std::size_t i = 1; i + 1 < grid.ny; ++i)
        for (std::size_t j = 1; j + 1 < grid.nx; ++j) {
            const std::size_t k = i * grid.nx + j;
            const std::optional<Vec> n = f.across_at(k);
            if (!n) continue;
            const Vec p{grid.x(j), grid.y(i)};
            const double c = f.value(p);
            if (!(c <= f.value({p.x + h * n->x, p.y + h * n->y}) && c <= f.value({p.x - h * n->x, p.y - h * n->y})))
                continue;
            const double d = depth(f, p, *n, w);
            if (d >= settings.min_depth && d > 0.0) seeds.push_back({k, *n, d});
        }
    std::stable_sort(seeds.begin(), seeds.end(), [](const Seed &a, const Seed &b) { return a.depth > b.depth; });

    std::vector<long> owner(grid.size(), -1);          // nearest grid point of a traced trench's point
    std::vector<std::uint8_t> covered(grid.size(), 0); // those and their 8 neighbours: seeds there are skipped
    std::vector<Trench> trenches;
    for (const Seed &seed : seeds) {
        if (covered[seed.k]) continue;
        const long id = static_cast<long>(trenches.size());
        const Vec p0_grid{grid.x(seed.k % grid.nx), grid.y(seed.k / grid.nx)};
        const std::optional<Vec> start = settle(f, p0_grid, seed.n, h);
        if (!start) continue;
        bool closed = false;
        std::array<std::vector<Vec>, 2> halves;
        for (int side = 0; side < 2 && !closed; ++side) {
            Vec p = *start, n = seed.n;
            Vec t{-n.y, n.x};
            if (side == 1) t = {-t.x, -t.y};
            // A step that fails is halved until the stop is located within min_step: ends on the grid of full
            // steps from the seed would move by a step when rounding picks another seed along a flat trench (a jet
            // core's FTLE is rounding: its length came out 4 or 3.975 on a grid moved by two ulps).
            const double min_step = 1e-4 * step;
            double ds = step;
            for (std::size_t s = 0, tries = 0; s < max_steps && tries < 64 * max_steps; ++tries) {
                if (const std::optional<Vec> m = f.across(p)) n = *m;
                Vec tn{-n.y, n.x};
                if (tn.x * t.x + tn.y * t.y < 0.0) tn = {-tn.x, -tn.y};
                const Vec q{p.x + ds * tn.x, p.y + ds * tn.y};
                Vec nq = n;
                if (const std::optional<Vec> m = f.across(q)) nq = *m;
                const std::optional<Vec> next = settle(f, q, nq, h);
                bool ok = next.has_value();
                if (ok) {
                    const double jump = std::hypot(next->x - p.x, next->y - p.y);
                    ok = jump <= 2.0 * ds && jump >= 0.25 * ds; // else: jumped to another trench, or stalled
                }
                ok = ok && depth(f, *next, nq, w) >= 0.5 * settings.min_depth && depth(f, *next, nq, w) > 0.0;
                const long o = ok ? owner[grid.nearest_point(next->x, next->y)] : -1;
                ok = ok && !(o >= 0 && o != id); // else: met a trench traced before
                if (!ok) {
                    if (ds <= min_step) break;
                    ds *= 0.5;
                    continue;
                }
                t = tn;
                if (side == 0 && s > 8 && std::hypot(next->x - start->x, next->y - start->y) < step) {
                    closed = true;
                    break;
                }
                halves[side].push_back(*next);
                p = *next;
                ++s;
                ds = std::min(2.0 * ds, step);
            }
        }
        Trench trench;
        trench.closed = closed;
        for (auto it = halves[1].rbegin(); it != halves[1].rend(); ++it)
            trench.xy.insert(trench.xy.end(), {it->x, it->y});
        trench.xy.insert(trench.xy.end(), {start->x, start->y});
        for (const Vec &v : halves[0]) trench.xy.insert(trench.xy.end(), {v.x, v.y});
        trench.length = polyline_length(trench.xy, closed);
        double sum = 0.0;
        std::size_t counted = 0;
        for (std::size_t q = 0; q + 1 < trench.xy.size(); q += 2) {
            const Vec v{trench.xy[q], trench.xy[q + 1]};
            const std::size_t k = grid.nearest_point(v.x, v.y);
            owner[k] = id;
            const long ci = static_cast<long>(k / grid.nx), cj = static_cast<long>(k % grid.nx);
            for (long di = -1; di <= 1; ++di)
                for (long dj = -1; dj <= 1; ++dj) {
                    const long i = ci + di, j = cj + dj;
                    if (i >= 0 && j >= 0 && i < static_cast<long>(grid.ny) && j < static_cast<long>(grid.nx))
                        covered[static_cast<std::size_t>(i) * grid.nx + static_cast<std::size_t>(j)] = 1;
                }
            const std::optional<Vec> n = f.across(v);
            const double d = depth(f, v, n ? *n : seed.n, w);
            if (std::isfinite(d)) {
                sum += d;
                ++counted;
            }
        }
        trench.mean_depth = counted ? sum / static_cast<double>(counted) : nan_value;
        trenches.push_back(std::move(trench));
    }
    return trenches;
}

} // namespace geobarrier::parabolic
