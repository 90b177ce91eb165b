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

// Calls visit(p, horizontal, captured) for every grid edge across which the exit time jumps (ExitJumps says when): the
// edge from point p to p + 1 (horizontal) or to p + nx, in grid order; `captured` when one of its points stays.
template <class Visit>
void for_each_jump_edge(const Grid &g, const double *exit_time, const std::uint8_t *mask, const ExitJumps &rule,
                        Visit &&visit) {
    constexpr double masked = -1.0, stays = std::numeric_limits<double>::infinity();
    // The time to exit; +inf for a point that stays, -1 for a masked point, which takes part in no edge.
    const auto time_to_exit = [&](std::size_t p) {
        if (mask && mask[p]) return masked;
        return std::isnan(exit_time[p]) ? stays : std::fabs(exit_time[p] - rule.t0);
    };
    const auto jumps = [&](double a, double b) {
        if (a == masked || b == masked || (a == stays && b == stays)) return false;
        if (a == stays || b == stays) return rule.horizon - std::min(a, b) > rule.stay_jump;
        return std::fabs(a - b) > rule.jump;
    };
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const std::size_t p = i * g.nx + j;
            const double here = time_to_exit(p);
            if (j + 1 < g.nx) {
                const double right = time_to_exit(p + 1);
                if (jumps(here, right)) visit(p, true, here == stays || right == stays);
            }
            if (i + 1 < g.ny) {
                const double above = time_to_exit(p + g.nx);
                if (jumps(here, above)) visit(p, false, here == stays || above == stays);
            }
        }
}

} // namespace

std::vector<JumpEdge> exit_jump_edges(const Grid &g, const double *exit_time, const std::uint8_t *mask,
                                      const ExitJumps &rule) {
    std::vector<JumpEdge> edges;
    for_each_jump_edge(g, exit_time, mask, rule, [&](std::size_t p, bool along_x, bool captured) {
        edges.push_back({p, along_x, captured});
    });
    return edges;
}

std::vector<double> exit_jump_seeds(const Grid &g, const std::vector<JumpEdge> &edges, double separation) {
    std::vector<double> seeds;
    Thinning thinning(g, separation > 0 ? separation : std::min(g.dx(), g.dy()));
    for (const JumpEdge &e : edges) {
        const double x = g.x(e.p % g.nx), y = g.y(e.p / g.nx);
        if (e.along_x)
            thinning.offer(x + 0.5 * g.dx(), y, seeds);
        else
            thinning.offer(x, y + 0.5 * g.dy(), seeds);
    }
    return seeds;
}

std::vector<std::uint8_t> near_exit_jumps(const Grid &g, const std::vector<JumpEdge> &edges, std::size_t reach) {
    std::vector<std::uint8_t> near(g.size(), 0);
    const auto mark = [&](std::size_t p, std::uint8_t kind) {
        const std::size_t i = p / g.nx, j = p % g.nx;
        for (std::size_t a = i > reach ? i - reach : 0; a <= std::min(g.ny - 1, i + reach); ++a)
            for (std::size_t b = j > reach ? j - reach : 0; b <= std::min(g.nx - 1, j + reach); ++b)
                near[a * g.nx + b] |= kind;
    };
    for (const JumpEdge &e : edges) {
        const std::uint8_t kind = e.captured ? near_captured_jump : near_leaving_jump;
        mark(e.p, kind);
        mark(e.along_x ? e.p + 1 : e.p + g.nx, kind);
    }
    return near;
}

} // namespace geobarrier::hyperbolic
