// The validation products' building blocks (validation.hpp): seed lattices and discs, points inside a polygon,
// snapshots of advected points, period-map iterates, the stretching history of an advected barrier (eq.
// `rel_def`) and its tube through extended phase space; and the small rules the products share (times, which
// barriers bound the regular regions).
#include <geobarrier/curves.hpp>
#include <geobarrier/validation.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "validation_internal.hpp"

namespace fs = std::filesystem;

namespace geobarrier {

namespace validation_detail {

// Times and coordinates in titles and legends: four significant digits read well (t = 3.142, not 3.14159).
std::string fmt_g(double v) { return fmt::format("{:.4g}", v); }

bool same_time(double a, double b) {
    return std::abs(a - b) <= 1e-9 * std::max(1.0, std::max(std::abs(a), std::abs(b)));
}

namespace {

std::string barrier_attribute(const Barrier &b, const std::string &name) {
    for (const auto &[key, value] : b.attributes)
        if (key == name) return value;
    return "";
}

}  // namespace

// The closed elliptic barriers that bound the regular regions: those marked outermost, or all closed elliptic
// ones when the extractor marked none.
std::vector<const Barrier *> outermost_elliptic(const std::vector<Barrier> &barriers) {
    std::vector<const Barrier *> closed, outermost;
    for (const Barrier &b : barriers) {
        if (b.kind != "elliptic" || !b.closed || b.xy.size() < 6) continue;
        closed.push_back(&b);
        if (barrier_attribute(b, "outermost") == "true") outermost.push_back(&b);
    }
    return outermost.empty() ? closed : outermost;
}

std::vector<double> default_times(const AdvectBarriersSpec &spec, double t0, double t1) {
    if (!spec.times.empty()) return spec.times;
    std::vector<double> times;
    for (std::size_t k = 0; k < spec.samples; ++k)
        times.push_back(t0 + (t1 - t0) * static_cast<double>(k) / static_cast<double>(spec.samples - 1));
    return times;
}

std::vector<double> even_times(double a, double b, std::size_t n) {
    std::vector<double> times(n);
    for (std::size_t k = 0; k < n; ++k) times[k] = a + (b - a) * static_cast<double>(k) / static_cast<double>(n - 1);
    return times;
}

}  // namespace validation_detail

using validation_detail::nan_value;

std::vector<double> lattice_points(const SeedLattice &l) {
    std::vector<double> xy;
    xy.reserve(2 * l.nx * l.ny);
    auto coord = [](double lo, double hi, std::size_t k, std::size_t n) {
        return n == 1 ? 0.5 * (lo + hi) : lo + (hi - lo) * static_cast<double>(k) / static_cast<double>(n - 1);
    };
    for (std::size_t i = 0; i < l.ny; ++i)
        for (std::size_t j = 0; j < l.nx; ++j) {
            xy.push_back(coord(l.x_min, l.x_max, j, l.nx));
            xy.push_back(coord(l.y_min, l.y_max, i, l.ny));
        }
    return xy;
}

std::vector<double> disc_points(const SeedDisc &d) {
    const double golden_angle = M_PI * (3.0 - std::sqrt(5.0));
    std::vector<double> xy;
    xy.reserve(2 * d.n);
    for (std::size_t k = 0; k < d.n; ++k) {
        const double r = d.radius * std::sqrt((static_cast<double>(k) + 0.5) / static_cast<double>(d.n));
        const double a = golden_angle * static_cast<double>(k);
        xy.push_back(d.center_x + r * std::cos(a));
        xy.push_back(d.center_y + r * std::sin(a));
    }
    return xy;
}

bool point_in_polygon(double x, double y, const std::vector<double> &xy) {
    const std::size_t n = xy.size() / 2;
    if (n < 3) return false;
    bool inside = false;
    for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
        const double xi = xy[2 * i], yi = xy[2 * i + 1], xj = xy[2 * j], yj = xy[2 * j + 1];
        // Edges that straddle the horizontal line through y (half-open, so a vertex is counted once) and cross
        // it to the right of x.
        if ((yi > y) != (yj > y) && x < xj + (y - yj) * (xi - xj) / (yi - yj)) inside = !inside;
    }
    return inside;
}

Snapshots advect_snapshots(const Dynamics &dynamics, const IntegratorSettings &settings,
                           const std::optional<Bounds> &bounds, const std::vector<double> &xy, double t_from,
                           const std::vector<double> &times) {
    const std::size_t n = xy.size() / 2;
    Snapshots out;
    out.positions.assign(times.size(), std::vector<double>());
    std::vector<bool> masked(n, false);
    // Forward chain (times >= t_from, ascending), then backward chain (times < t_from, descending).
    std::vector<std::size_t> forward, backward;
    for (std::size_t k = 0; k < times.size(); ++k) (times[k] >= t_from ? forward : backward).push_back(k);
    std::sort(forward.begin(), forward.end(), [&](std::size_t a, std::size_t b) { return times[a] < times[b]; });
    std::sort(backward.begin(), backward.end(), [&](std::size_t a, std::size_t b) { return times[a] > times[b]; });
    for (const auto *chain : {&forward, &backward}) {
        std::vector<double> current = xy;
        std::vector<bool> dead(n, false);
        double t_current = t_from;
        for (std::size_t idx : *chain) {
            const double t = times[idx];
            if (t != t_current) {
                std::vector<double> x0, y0;
                std::vector<std::size_t> alive;
                for (std::size_t p = 0; p < n; ++p)
                    if (!dead[p]) {
                        alive.push_back(p);
                        x0.push_back(current[2 * p]);
                        y0.push_back(current[2 * p + 1]);
                    }
                if (!alive.empty()) {
                    const AdvectResult a = advect_points(dynamics, x0, y0, t_current, t, settings, false, bounds);
                    out.stats.add(a.stats);
                    for (std::size_t q = 0; q < alive.size(); ++q) {
                        const std::size_t p = alive[q];
                        if (a.mask[q] != 0) {
                            dead[p] = true;
                            masked[p] = true;
                            current[2 * p] = current[2 * p + 1] = nan_value;
                        } else {
                            current[2 * p] = a.x[q];
                            current[2 * p + 1] = a.y[q];
                        }
                    }
                }
                t_current = t;
            }
            out.positions[idx] = current;
        }
    }
    out.masked = static_cast<std::size_t>(std::count(masked.begin(), masked.end(), true));
    return out;
}

Snapshots poincare_iterates(const Dynamics &dynamics, const IntegratorSettings &settings,
                            const std::optional<Bounds> &bounds, const std::vector<double> &seeds, double t_start,
                            double period, std::size_t iterations) {
    std::vector<double> times(iterations + 1);
    for (std::size_t k = 0; k <= iterations; ++k) times[k] = t_start + static_cast<double>(k) * period;
    return advect_snapshots(dynamics, settings, bounds, seeds, t_start, times);
}

StretchingHistory stretching_history(const Dynamics &dynamics, const IntegratorSettings &settings,
                                     const std::optional<Bounds> &bounds, const std::vector<double> &xy, bool closed,
                                     double t0, const std::vector<double> &times, double max_gap) {
    StretchingHistory h;
    h.length0 = polyline_length(xy, closed);
    h.area0 = closed ? std::abs(shoelace_area(xy)) : nan_value;
    CurveAdvectionSettings curve_settings;
    curve_settings.max_gap_fraction = max_gap;
    for (double t : times) {
        StretchingSample s;
        s.t = t;
        if (t == t0) {
            s.xy = s.xy0 = xy;
            s.length = h.length0;
            s.area = h.area0;
            s.points = xy.size() / 2;
            s.converged = true;
        } else {
            const AdvectedCurve c = advect_curve(xy, closed, make_advect_points_fn(dynamics, t0, t, settings, bounds),
                                                 curve_settings);
            s.xy = c.xy1;
            s.xy0 = c.xy0;
            s.length = c.length1;
            s.area = closed ? std::abs(c.area1) : nan_value;
            s.points = c.xy1.size() / 2;
            s.converged = c.converged;
        }
        s.delta_l = h.length0 > 0.0 ? (s.length - h.length0) / h.length0 : nan_value;
        h.samples.push_back(std::move(s));
    }
    return h;
}

BarrierTube barrier_tube(const Dynamics &dynamics, const IntegratorSettings &settings,
                         const std::optional<Bounds> &bounds, const std::vector<double> &xy, bool closed, double t0,
                         const std::vector<double> &times, std::size_t columns) {
    BarrierTube tube;
    tube.closed = closed;
    tube.times = times;
    const std::size_t n = xy.size() / 2;
    if (n < 2 || columns < 2) return tube;
    // Material points equally spaced in arc length along the barrier.
    const std::vector<double> s0 = cumulative_length(xy, closed);
    const double total = s0.back();
    if (!(total > 0.0)) return tube;
    std::vector<double> material;
    std::size_t k = 0;
    for (std::size_t c = 0; c < columns; ++c) {
        const double target = total * static_cast<double>(c) / static_cast<double>(closed ? columns : columns - 1);
        while (k + 2 < s0.size() && s0[k + 1] < target) ++k;
        const std::size_t a = k % n, b = (k + 1) % n;
        const double len = s0[k + 1] - s0[k];
        const double u = len > 0.0 ? std::clamp((target - s0[k]) / len, 0.0, 1.0) : 0.0;
        material.push_back(xy[2 * a] + u * (xy[2 * b] - xy[2 * a]));
        material.push_back(xy[2 * a + 1] + u * (xy[2 * b + 1] - xy[2 * a + 1]));
    }
    const Snapshots snaps = advect_snapshots(dynamics, settings, bounds, material, t0, times);
    tube.columns = columns;
    tube.rows = times.size();
    for (std::size_t r = 0; r < times.size(); ++r)
        for (std::size_t c = 0; c < columns; ++c)
            tube.xyz.insert(tube.xyz.end(), {snaps.positions[r][2 * c], snaps.positions[r][2 * c + 1], times[r]});
    return tube;
}

}  // namespace geobarrier
