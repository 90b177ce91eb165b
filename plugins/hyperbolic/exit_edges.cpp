#include "exit_edges.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <unordered_map>

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

constexpr double masked = -1.0, stays = std::numeric_limits<double>::infinity();

// The time to exit of grid point p: +inf for a point that stays, -1 for a masked point, which takes part in no jump.
double time_to_exit(const double *exit_time, const std::uint8_t *mask, const ExitJumps &rule, std::size_t p) {
    if (mask && mask[p]) return masked;
    return std::isnan(exit_time[p]) ? stays : std::fabs(exit_time[p] - rule.t0);
}

// Whether the time to exit jumps between two points whose times are a and b (ExitJumps says when).
bool jumps(const ExitJumps &rule, double a, double b) {
    if (a == masked || b == masked || (a == stays && b == stays)) return false;
    if (a == stays || b == stays) return rule.horizon - std::min(a, b) > rule.stay_jump;
    return std::fabs(a - b) > rule.jump;
}

// Calls visit(p, horizontal, captured) for every grid edge across which the exit time jumps (ExitJumps says when): the
// edge from point p to p + 1 (horizontal) or to p + nx, in grid order; `captured` when one of its points stays.
template <class Visit>
void for_each_jump_edge(const Grid &g, const double *exit_time, const std::uint8_t *mask, const ExitJumps &rule,
                        Visit &&visit) {
    const auto time_to_exit = [&](std::size_t p) { return hyperbolic::time_to_exit(exit_time, mask, rule, p); };
    // Between two points that leave, the time to leave must grow towards the edge on the side that leaves first:
    // `before` is that side's neighbour away from the edge. Where that cannot be told (no such neighbour at the
    // grid's edge, or one masked or captured, a jump of its own) the jump counts.
    const auto rises = [&](double first, std::size_t before, bool exists) {
        if (!exists) return true;
        const double t = time_to_exit(before);
        return t == masked || t == stays || t < first;
    };
    // The edge from p to p + step, the point `back` (p - step) and `on` (p + 2 step) beyond its ends when they exist.
    const auto jumps = [&](std::size_t p, std::size_t step, bool back, bool on) {
        const double a = time_to_exit(p), b = time_to_exit(p + step);
        if (!hyperbolic::jumps(rule, a, b)) return false;
        if (a == stays || b == stays) return true;
        return a < b ? rises(a, p - (back ? step : 0), back) : rises(b, p + (on ? 2 * step : step), on);
    };
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const std::size_t p = i * g.nx + j;
            const double here = time_to_exit(p);
            if (j + 1 < g.nx && jumps(p, 1, j > 0, j + 2 < g.nx))
                visit(p, true, here == stays || time_to_exit(p + 1) == stays);
            if (i + 1 < g.ny && jumps(p, g.nx, i > 0, i + 2 < g.ny))
                visit(p, false, here == stays || time_to_exit(p + g.nx) == stays);
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

std::vector<std::uint8_t> across_exit_jumps(const Grid &g, const double *exit_time, const std::uint8_t *mask,
                                            const ExitJumps &rule, const double *xy, std::size_t n, double offset) {
    std::vector<std::uint8_t> kind(n, 0), across(n, 0);
    if (n < 2) return across;
    for (std::size_t k = 0; k < n; ++k) {
        const std::size_t a = k > 0 ? k - 1 : 0, b = k + 1 < n ? k + 1 : n - 1;
        const double tx = xy[2 * b] - xy[2 * a], ty = xy[2 * b + 1] - xy[2 * a + 1], t = std::hypot(tx, ty);
        if (!(t > 0.0)) continue;
        const double ox = -ty / t * offset, oy = tx / t * offset, x = xy[2 * k], y = xy[2 * k + 1];
        const double left = time_to_exit(exit_time, mask, rule, g.nearest_point(x + ox, y + oy)),
                     right = time_to_exit(exit_time, mask, rule, g.nearest_point(x - ox, y - oy));
        if (jumps(rule, left, right))
            kind[k] = left == stays || right == stays ? near_captured_jump : near_leaving_jump;
    }
    // Each point's kind spread over `offset` of arc length either way.
    for (std::size_t k = 0; k < n; ++k) {
        if (!kind[k]) continue;
        across[k] |= kind[k];
        for (std::size_t m = k + 1; m < n && std::hypot(xy[2 * m] - xy[2 * k], xy[2 * m + 1] - xy[2 * k + 1]) <= offset;
             ++m)
            across[m] |= kind[k];
        for (std::size_t m = k; m-- > 0 && std::hypot(xy[2 * m] - xy[2 * k], xy[2 * m + 1] - xy[2 * k + 1]) <= offset;)
            across[m] |= kind[k];
    }
    return across;
}

std::vector<EdgeCurve> captured_set_edges(const Grid &g, const double *exit_time, const std::uint8_t *mask,
                                          const ExitJumps &rule) {
    // A node per grid edge between a point that stays and one that does not: 2p for the edge from p to p + 1, 2p + 1
    // for the edge from p to p + nx; up to two links, one through each cell the edge bounds.
    constexpr std::size_t none = std::numeric_limits<std::size_t>::max();
    struct Node {
        std::size_t link[2] = {none, none};
        bool jump = false, done = false;
    };
    const auto stays_at = [&](std::size_t p) { return time_to_exit(exit_time, mask, rule, p) == stays; };
    std::unordered_map<std::size_t, Node> nodes;
    std::vector<std::size_t> cells; // the lower-left points of the cells next to such an edge
    const auto add = [&](std::size_t p, std::size_t q, bool along_x) {
        if (stays_at(p) == stays_at(q)) return;
        nodes[2 * p + (along_x ? 0 : 1)].jump =
            jumps(rule, time_to_exit(exit_time, mask, rule, p), time_to_exit(exit_time, mask, rule, q));
        const std::size_t i = p / g.nx, j = p % g.nx;
        if (along_x ? i > 0 : j > 0) cells.push_back(along_x ? p - g.nx : p - 1);
        if (along_x ? i + 1 < g.ny : j + 1 < g.nx) cells.push_back(p);
    };
    for (std::size_t p = 0; p < g.size(); ++p) {
        if (p % g.nx + 1 < g.nx) add(p, p + 1, true);
        if (p / g.nx + 1 < g.ny) add(p, p + g.nx, false);
    }
    std::sort(cells.begin(), cells.end());
    cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
    const auto link = [&](std::size_t a, std::size_t b) {
        Node &na = nodes[a], &nb = nodes[b];
        (na.link[0] == none ? na.link[0] : na.link[1]) = b;
        (nb.link[0] == none ? nb.link[0] : nb.link[1]) = a;
    };
    for (const std::size_t p : cells) {
        if (p % g.nx + 1 >= g.nx || p / g.nx + 1 >= g.ny) continue;
        // Sides in order round the cell; a binary field crosses an even number of them.
        const std::size_t side[4] = {2 * p, 2 * (p + 1) + 1, 2 * (p + g.nx), 2 * p + 1}; // bottom, right, top, left
        std::size_t crossed[4], count = 0;
        for (const std::size_t s : side)
            if (nodes.count(s)) crossed[count++] = s;
        if (count == 2) {
            link(crossed[0], crossed[1]);
        } else if (count == 4) { // corners alternate: cut off the two that stay
            if (stays_at(p)) {
                link(side[0], side[3]); // the lower-left point: bottom and left
                link(side[1], side[2]); // the upper-right point
            } else {
                link(side[0], side[1]); // the lower-right point
                link(side[2], side[3]); // the upper-left point
            }
        }
    }
    const auto midpoint = [&](std::size_t node, std::vector<double> &xy) {
        const std::size_t p = node / 2;
        const double x = g.x(p % g.nx), y = g.y(p / g.nx);
        xy.push_back(node % 2 == 0 ? x + 0.5 * g.dx() : x);
        xy.push_back(node % 2 == 0 ? y : y + 0.5 * g.dy());
    };
    // Walks from `start` along its links until an end or back at the start.
    const auto walk = [&](std::size_t start) {
        EdgeCurve curve;
        std::size_t previous = none, at = start, edges = 0, jumped = 0;
        while (at != none && !nodes[at].done) {
            Node &n = nodes[at];
            n.done = true;
            midpoint(at, curve.xy);
            ++edges;
            jumped += n.jump ? 1 : 0;
            const std::size_t next = n.link[0] != previous ? n.link[0] : n.link[1];
            previous = at;
            at = next;
        }
        curve.closed = at == start;
        if (curve.closed) midpoint(start, curve.xy);
        curve.jumps = static_cast<double>(jumped) / static_cast<double>(edges);
        return curve;
    };
    // In grid order of their nodes: ends first (curves that meet the grid's edge), then the closed curves.
    std::vector<std::size_t> order;
    for (const auto &kv : nodes) order.push_back(kv.first);
    std::sort(order.begin(), order.end());
    std::vector<EdgeCurve> curves;
    for (int pass = 0; pass < 2; ++pass)
        for (const std::size_t node : order) {
            const Node &n = nodes[node];
            if (n.done || (pass == 0 && n.link[1] != none)) continue;
            EdgeCurve curve = walk(node);
            if (curve.xy.size() >= 4) curves.push_back(std::move(curve));
        }
    return curves;
}

} // namespace geobarrier::hyperbolic
