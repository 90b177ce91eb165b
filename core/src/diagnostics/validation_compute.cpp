// The validation products' building blocks (validation.hpp): seed lattices and discs, points inside a polygon,
// snapshots of advected points, period-map iterates, the stretching history of an advected barrier (eq.
// `rel_def`) and its tube through extended phase space; and the small rules the products share (times, which
// barriers bound the regular regions).
#include <geobarrier/curves.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/validation.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "diagnostics/validation_internal.hpp"

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

} // namespace

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

} // namespace validation_detail

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
    // On a slice of a system with more components every chain carries whole states (dim per point), so that a
    // segment starts where the last one ended, not back on the slice; positions are their slice components.
    const Slice *slice = dynamics.system && dynamics.system->dimension() > 2 ? dynamics.slice : nullptr;
    const std::size_t dim = slice ? dynamics.system->dimension() : 2;
    const std::size_t ax = slice ? slice->axes[0] : 0, ay = slice ? slice->axes[1] : 1;
    std::vector<double> start(dim * n);
    for (std::size_t p = 0; p < n; ++p) {
        if (slice) std::copy(slice->state.begin(), slice->state.end(), start.begin() + dim * p);
        start[dim * p + ax] = xy[2 * p];
        start[dim * p + ay] = xy[2 * p + 1];
    }
    Snapshots out;
    out.positions.assign(times.size(), std::vector<double>());
    std::vector<bool> masked(n, false);
    // Forward chain (times >= t_from, ascending), then backward chain (times < t_from, descending).
    std::vector<std::size_t> forward, backward;
    for (std::size_t k = 0; k < times.size(); ++k) (times[k] >= t_from ? forward : backward).push_back(k);
    std::sort(forward.begin(), forward.end(), [&](std::size_t a, std::size_t b) { return times[a] < times[b]; });
    std::sort(backward.begin(), backward.end(), [&](std::size_t a, std::size_t b) { return times[a] > times[b]; });
    for (const auto *chain : {&forward, &backward}) {
        std::vector<double> current = start;
        std::vector<bool> dead(n, false);
        double t_current = t_from;
        for (std::size_t idx : *chain) {
            const double t = times[idx];
            if (t != t_current) {
                std::vector<std::size_t> alive;
                for (std::size_t p = 0; p < n; ++p)
                    if (!dead[p]) alive.push_back(p);
                if (!alive.empty()) {
                    // The segment from t_current to t: new states of the alive points, and their masks.
                    std::vector<std::uint8_t> mask;
                    std::vector<double> moved;
                    FlowMapRequest request{dynamics, t_current, t, settings};
                    request.bounds = bounds;
                    if (slice) {
                        const FlowMap a = flow_map_of_states( // the slice only places the bounds box
                            request, alive.size(),
                            [&](std::size_t q, double *x) { std::copy_n(current.begin() + dim * alive[q], dim, x); });
                        out.stats.add(a.stats);
                        mask = a.mask;
                        moved = a.state;
                    } else {
                        std::vector<double> x0, y0;
                        for (std::size_t p : alive) {
                            x0.push_back(current[2 * p]);
                            y0.push_back(current[2 * p + 1]);
                        }
                        const FlowMap a = flow_map_at_points(request, x0, y0);
                        out.stats.add(a.stats);
                        mask = a.mask;
                        for (std::size_t q = 0; q < alive.size(); ++q) {
                            moved.push_back(a.flow_x[q]);
                            moved.push_back(a.flow_y[q]);
                        }
                    }
                    for (std::size_t q = 0; q < alive.size(); ++q) {
                        const std::size_t p = alive[q];
                        if (mask[q] != 0) {
                            dead[p] = true;
                            masked[p] = true;
                            std::fill_n(current.begin() + dim * p, dim, nan_value);
                        } else {
                            std::copy_n(moved.begin() + dim * q, dim, current.begin() + dim * p);
                        }
                    }
                }
                t_current = t;
            }
            std::vector<double> positions(2 * n);
            for (std::size_t p = 0; p < n; ++p) {
                positions[2 * p] = current[dim * p + ax];
                positions[2 * p + 1] = current[dim * p + ay];
            }
            out.positions[idx] = std::move(positions);
        }
    }
    out.masked = static_cast<std::size_t>(std::count(masked.begin(), masked.end(), true));
    return out;
}

SectionCrossings section_crossings(const Dynamics &dynamics, const IntegratorSettings &settings,
                                   const std::optional<Bounds> &bounds, const std::vector<double> &seeds,
                                   double t_start, double t_end, const std::vector<double> &normal, double offset,
                                   int direction, std::size_t max_crossings, double sample) {
    const Dynamics &whole = dynamics; // whole states; a slice only places the bounds box
    const std::size_t dim = dynamics.system->dimension();
    if (normal.size() != dim)
        throw Error("section_crossings: a normal of " + std::to_string(normal.size()) +
                    " components for a system of "
                    "dimension " +
                    std::to_string(dim));
    if (!(sample > 0.0) || !(t_end > t_start)) throw Error("section_crossings: needs sample > 0 and t_end > t_start");
    const std::size_t n = seeds.size() / dim;
    SectionCrossings out;
    out.dimension = static_cast<unsigned>(dim);
    const auto g = [&](const double *x) {
        double s = -offset;
        for (std::size_t i = 0; i < dim; ++i) s += normal[i] * x[i];
        return s;
    };
    // normal . v(x, t): the rate of g along the trajectory.
    const auto rate = [&](const double *x, double t) {
        double f = 0.0;
        if (dynamics.forcing && dynamics.system->uses_forcing()) dynamics.forcing->evaluate(1, &t, &f);
        std::vector<double> v(dim);
        std::int32_t status = GB_OK;
        dynamics.system->rhs(1, 1, &t, x, &f, v.data(), &status);
        double s = 0.0;
        for (std::size_t i = 0; i < dim; ++i) s += normal[i] * v[i];
        return s;
    };
    const auto request = [&](double from, double to) {
        FlowMapRequest r{whole, from, to, settings};
        r.bounds = bounds;
        return r;
    };
    // x(t) from the state a at time ta (one trajectory); false when masked.
    const auto advance = [&](const double *a, double ta, double t, double *x) {
        if (t == ta) {
            std::copy_n(a, dim, x);
            return true;
        }
        const FlowMap r =
            flow_map_of_states(request(ta, t), 1, [&](std::size_t, double *s) { std::copy_n(a, dim, s); });
        out.stats.add(r.stats);
        if (r.mask[0] != 0) return false;
        std::copy_n(r.state.begin(), dim, x);
        return true;
    };
    const auto wanted = [&](double g0, double g1) {
        const bool up = g0 < 0.0 && g1 >= 0.0, down = g0 > 0.0 && g1 <= 0.0;
        return direction > 0 ? up : direction < 0 ? down : up || down;
    };
    std::vector<double> current = seeds, next;
    std::vector<std::size_t> alive(n);
    for (std::size_t p = 0; p < n; ++p) alive[p] = p;
    std::vector<double> x(dim), a(dim);
    for (double t = t_start; t < t_end && !alive.empty() && out.times.size() < max_crossings;) {
        const double t_next = std::min(t_end, t + sample);
        const FlowMap r = flow_map_of_states(request(t, t_next), alive.size(), [&](std::size_t q, double *s) {
            std::copy_n(current.begin() + dim * alive[q], dim, s);
        });
        out.stats.add(r.stats);
        std::vector<std::size_t> still;
        for (std::size_t q = 0; q < alive.size(); ++q) {
            const std::size_t p = alive[q];
            if (r.mask[q] != 0) {
                ++out.masked;
                continue;
            }
            const double *before = &current[dim * p], *after = &r.state[dim * q];
            const double g0 = g(before), g1 = g(after);
            if (wanted(g0, g1) && out.times.size() < max_crossings) {
                // Newton from the end of the bracket nearer the root's linear estimate, safeguarded by bisection.
                double lo = t, hi = t_next, glo = g0;
                double tc = t + (t_next - t) * g0 / (g0 - g1);
                std::copy_n(before, dim, a.begin());
                bool ok = true;
                for (int iteration = 0; iteration < 100; ++iteration) {
                    if (!(ok = advance(a.data(), t, tc, x.data()))) break;
                    const double gc = g(x.data());
                    if (gc == 0.0) break;
                    if ((gc < 0.0) == (glo < 0.0))
                        lo = tc, glo = gc;
                    else
                        hi = tc;
                    const double slope = rate(x.data(), tc);
                    double t_new = slope != 0.0 ? tc - gc / slope : 0.5 * (lo + hi);
                    if (!(t_new > lo && t_new < hi)) t_new = 0.5 * (lo + hi);
                    const bool done = std::abs(t_new - tc) <= 1e-13 * std::max(1.0, std::abs(tc));
                    tc = t_new;
                    if (done) {
                        ok = advance(a.data(), t, tc, x.data());
                        break;
                    }
                }
                if (ok) {
                    out.states.insert(out.states.end(), x.begin(), x.end());
                    out.times.push_back(tc);
                    out.seeds.push_back(p);
                }
            }
            std::copy_n(after, dim, current.begin() + dim * p);
            still.push_back(p);
        }
        alive.swap(still);
        t = t_next;
    }
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
            const AdvectedCurve c =
                advect_curve(xy, closed, make_advect_points_fn(dynamics, t0, t, settings, bounds), curve_settings);
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

} // namespace geobarrier
