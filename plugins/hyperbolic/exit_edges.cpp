#include "exit_edges.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

namespace geobarrier::hyperbolic {

namespace {

// Seeds kept so far, in square buckets of side `separation`: a new seed is compared with those of its bucket and the
// eight around it only.
class Thinning {
  public:
    Thinning(const Grid &g, double separation)
        : m_r(separation), m_x0(g.x_min), m_y0(g.y_min),
          m_nx(static_cast<std::size_t>(std::floor((g.x_max - g.x_min) / separation)) + 1),
          m_ny(static_cast<std::size_t>(std::floor((g.y_max - g.y_min) / separation)) + 1), m_buckets(m_nx * m_ny) {}

    // Keeps (x, y) unless a kept seed lies closer than the separation.
    void offer(double x, double y, std::vector<double> &kept) {
        const auto bx = static_cast<long>(std::floor((x - m_x0) / m_r)),
                   by = static_cast<long>(std::floor((y - m_y0) / m_r));
        for (long j = by - 1; j <= by + 1; ++j)
            for (long i = bx - 1; i <= bx + 1; ++i) {
                if (i < 0 || j < 0 || i >= static_cast<long>(m_nx) || j >= static_cast<long>(m_ny)) continue;
                for (std::size_t k : m_buckets[static_cast<std::size_t>(j) * m_nx + static_cast<std::size_t>(i)])
                    if (std::hypot(kept[2 * k] - x, kept[2 * k + 1] - y) < m_r) return;
            }
        const std::size_t b = static_cast<std::size_t>(std::clamp(by, 0L, static_cast<long>(m_ny) - 1)) * m_nx +
                              static_cast<std::size_t>(std::clamp(bx, 0L, static_cast<long>(m_nx) - 1));
        m_buckets[b].push_back(kept.size() / 2);
        kept.push_back(x);
        kept.push_back(y);
    }

  private:
    double m_r, m_x0, m_y0;
    std::size_t m_nx, m_ny;
    std::vector<std::vector<std::size_t>> m_buckets;
};

// Calls visit(p, horizontal) for every grid edge across which the exit time jumps (exit_jump_seeds says when): the
// edge from point p to p + 1 (horizontal) or to p + nx, in grid order.
template <class Visit>
void for_each_jump_edge(const Grid &g, const double *exit_time, const std::uint8_t *mask, double t0, double horizon,
                        double jump, Visit &&visit) {
    // The time to exit, the horizon for a point that stays; NaN for a masked point, which takes part in no edge.
    const auto time_to_exit = [&](std::size_t p) {
        if (mask && mask[p]) return std::numeric_limits<double>::quiet_NaN();
        return std::isnan(exit_time[p]) ? horizon : std::fabs(exit_time[p] - t0);
    };
    const auto jumps = [&](double a, double b) { return std::fabs(a - b) > jump; }; // false with a NaN
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const std::size_t p = i * g.nx + j;
            const double here = time_to_exit(p);
            if (j + 1 < g.nx && jumps(here, time_to_exit(p + 1))) visit(p, true);
            if (i + 1 < g.ny && jumps(here, time_to_exit(p + g.nx))) visit(p, false);
        }
}

} // namespace

std::vector<double> exit_jump_seeds(const Grid &g, const double *exit_time, const std::uint8_t *mask, double t0,
                                    double horizon, double jump, double separation) {
    std::vector<double> seeds;
    Thinning thinning(g, separation > 0 ? separation : std::min(g.dx(), g.dy()));
    for_each_jump_edge(g, exit_time, mask, t0, horizon, jump, [&](std::size_t p, bool horizontal) {
        const double x = g.x(p % g.nx), y = g.y(p / g.nx);
        if (horizontal)
            thinning.offer(x + 0.5 * g.dx(), y, seeds);
        else
            thinning.offer(x, y + 0.5 * g.dy(), seeds);
    });
    return seeds;
}

std::vector<std::uint8_t> near_exit_jumps(const Grid &g, const double *exit_time, const std::uint8_t *mask, double t0,
                                          double horizon, double jump, std::size_t reach) {
    std::vector<std::uint8_t> near(g.size(), 0);
    const auto mark = [&](std::size_t p) {
        const std::size_t i = p / g.nx, j = p % g.nx;
        for (std::size_t a = i > reach ? i - reach : 0; a <= std::min(g.ny - 1, i + reach); ++a)
            for (std::size_t b = j > reach ? j - reach : 0; b <= std::min(g.nx - 1, j + reach); ++b)
                near[a * g.nx + b] = 1;
    };
    for_each_jump_edge(g, exit_time, mask, t0, horizon, jump, [&](std::size_t p, bool horizontal) {
        mark(p);
        mark(horizontal ? p + 1 : p + g.nx);
    });
    return near;
}

} // namespace geobarrier::hyperbolic
