// Tensor-line integration: r' = v(r) on an orientation-free LineField by arc length with Boost.Odeint's
// Cash–Karp 5(4) controlled stepper. Every stage of a step aligns the field with the tangent at the step's start,
// so the line never turns back on itself at a sign flip of the stored vectors.
#include <geobarrier/tensor_lines.hpp>

// GCC 12 reports a false -Wmaybe-uninitialized inside Boost.Odeint's steppers on std::array states.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <boost/numeric/odeint.hpp>

#include <algorithm>
#include <array>
#include <cmath>

namespace odeint = boost::numeric::odeint;

namespace geobarrier {

const char *to_string(StopReason reason) {
    switch (reason) {
    case StopReason::domain_edge:
        return "domain_edge";
    case StopReason::masked:
        return "masked";
    case StopReason::singular:
        return "singular";
    case StopReason::max_length:
        return "max_length";
    case StopReason::closed:
        return "closed";
    case StopReason::max_steps:
        return "max_steps";
    }
    return "?";
}

namespace {

using State = std::array<double, 2>;

StopReason stop_for(LineStatus s) {
    switch (s) {
    case LineStatus::outside:
        return StopReason::domain_edge;
    case LineStatus::masked:
        return StopReason::masked;
    default:
        return StopReason::singular;
    }
}

// Distance from p to the segment [a, b].
double segment_distance(double px, double py, double ax, double ay, double bx, double by) {
    const double ux = bx - ax, uy = by - ay;
    const double uu = ux * ux + uy * uy;
    double t = uu > 0.0 ? ((px - ax) * ux + (py - ay) * uy) / uu : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    return std::hypot(px - (ax + t * ux), py - (ay + t * uy));
}

} // namespace

TensorLine integrate_tensor_line(const LineField &field, double x0, double y0, double dir_x, double dir_y,
                                 const TensorLineSettings &settings) {
    const Grid &g = field.grid();
    const double h = std::min(g.dx(), g.dy());
    const double max_step = settings.max_step > 0.0 ? settings.max_step : 0.5 * h;
    const double min_step = settings.min_step > 0.0 ? settings.min_step : 1e-4 * h;
    const double closure_distance = settings.closure_distance > 0.0 ? settings.closure_distance : 0.5 * h;
    const double closure_min_length = settings.closure_min_length > 0.0 ? settings.closure_min_length : 10.0 * h;
    double dt = std::min(settings.initial_step > 0.0 ? settings.initial_step : 0.1 * h, max_step);

    TensorLine line;
    line.xy = {x0, y0};
    line.s = {0.0};
    if (!std::isfinite(x0) || !std::isfinite(y0)) {
        line.xy.clear();
        line.s.clear();
        line.stop = StopReason::domain_edge;
        return line;
    }
    double tx, ty;
    const LineStatus s0 = field.evaluate(x0, y0, dir_x, dir_y, tx, ty);
    if (s0 != LineStatus::ok) {
        line.stop = stop_for(s0);
        return line;
    }
    const double start_tx = tx, start_ty = ty;

    auto stepper = odeint::make_controlled(settings.atol, settings.rtol, odeint::runge_kutta_cash_karp54<State>());
    State r{x0, y0};
    double s = 0.0;
    LineStatus failure = LineStatus::ok;
    double ref_x = tx, ref_y = ty;
    // The right-hand side: the field aligned with the step's starting tangent. A stage outside the usable field
    // records why and returns the reference direction (finite), and the step is then discarded.
    auto rhs = [&](const State &p, State &dpds, double) {
        double vx, vy;
        const LineStatus st = field.evaluate(p[0], p[1], ref_x, ref_y, vx, vy);
        if (st != LineStatus::ok) {
            if (failure == LineStatus::ok) failure = st;
            vx = ref_x;
            vy = ref_y;
        }
        dpds[0] = vx;
        dpds[1] = vy;
    };

    for (std::size_t step = 0;; ++step) {
        if (step >= settings.max_steps) {
            line.stop = StopReason::max_steps;
            return line;
        }
        if (s >= settings.max_length) {
            line.stop = StopReason::max_length;
            return line;
        }
        dt = std::min({dt, max_step, settings.max_length - s});
        State trial = r;
        double t = s;
        double dt_try = dt;
        failure = LineStatus::ok;
        const odeint::controlled_step_result result = stepper.try_step(rhs, trial, t, dt_try);
        if (failure != LineStatus::ok) {
            // A stage left the usable field: locate the stop to within min_step by halving.
            if (dt <= min_step) {
                line.stop = stop_for(failure);
                return line;
            }
            dt = std::max(0.5 * dt, min_step);
            continue;
        }
        if (result == odeint::fail) {
            if (dt_try < min_step) {
                // The tolerance cannot be met with any useful step (a kink of the interpolated field at a
                // near-singular cell): take the step at min_step anyway, if the field allows it.
                dt_try = min_step;
                State forced = r;
                double tf = s;
                failure = LineStatus::ok;
                odeint::runge_kutta_cash_karp54<State>().do_step(rhs, forced, tf, dt_try);
                if (failure != LineStatus::ok) {
                    line.stop = stop_for(failure);
                    return line;
                }
                trial = forced;
                t = s + dt_try;
                dt_try = min_step;
            } else {
                dt = dt_try;
                continue;
            }
        }
        if (!std::isfinite(trial[0]) || !std::isfinite(trial[1])) {
            line.stop = StopReason::singular;
            return line;
        }
        // Tangent at the new point, aligned with the old one; it is the next step's reference.
        double nx, ny;
        const LineStatus st = field.evaluate(trial[0], trial[1], ref_x, ref_y, nx, ny);
        if (st != LineStatus::ok) {
            if (dt <= min_step) {
                line.stop = stop_for(st);
                return line;
            }
            dt = std::max(0.5 * dt, min_step);
            continue;
        }
        const double px = r[0], py = r[1];
        const double seg = std::hypot(trial[0] - px, trial[1] - py);
        r = trial;
        s += seg;
        ref_x = nx;
        ref_y = ny;
        dt = dt_try;
        // Closing on itself: the last segment passes the seed, heading the way the line started.
        if (settings.detect_closure && s >= closure_min_length &&
            segment_distance(x0, y0, px, py, r[0], r[1]) <= closure_distance && nx * start_tx + ny * start_ty > 0.0) {
            line.xy.push_back(x0);
            line.xy.push_back(y0);
            line.s.push_back(s - seg + std::hypot(x0 - px, y0 - py));
            line.stop = StopReason::closed;
            return line;
        }
        line.xy.push_back(r[0]);
        line.xy.push_back(r[1]);
        line.s.push_back(s);
    }
}

TwoWayLine integrate_tensor_line_both_ways(const LineField &field, double x0, double y0,
                                           const TensorLineSettings &settings) {
    TwoWayLine out;
    double vx = 0.0, vy = 0.0;
    const LineStatus st = field.evaluate(x0, y0, 1.0, 0.0, vx, vy);
    if (st != LineStatus::ok || !std::isfinite(x0) || !std::isfinite(y0)) {
        if (std::isfinite(x0) && std::isfinite(y0)) {
            out.xy = {x0, y0};
            out.s = {0.0};
        }
        out.stop_backward = out.stop_forward = st == LineStatus::ok ? StopReason::domain_edge : stop_for(st);
        return out;
    }
    const TensorLine fwd = integrate_tensor_line(field, x0, y0, vx, vy, settings);
    if (fwd.stop == StopReason::closed) {
        out.xy = fwd.xy;
        out.s = fwd.s;
        out.stop_forward = out.stop_backward = StopReason::closed;
        out.closed = true;
        return out;
    }
    const TensorLine bwd = integrate_tensor_line(field, x0, y0, -vx, -vy, settings);
    const std::size_t nb = bwd.size();
    const double total_back = nb ? bwd.s.back() : 0.0;
    for (std::size_t k = nb; k-- > 1;) { // the backward branch reversed, without its seed
        out.xy.push_back(bwd.xy[2 * k]);
        out.xy.push_back(bwd.xy[2 * k + 1]);
        out.s.push_back(total_back - bwd.s[k]);
    }
    out.seed_index = out.s.size();
    for (std::size_t k = 0; k < fwd.size(); ++k) {
        out.xy.push_back(fwd.xy[2 * k]);
        out.xy.push_back(fwd.xy[2 * k + 1]);
        out.s.push_back(total_back + fwd.s[k]);
    }
    out.stop_backward = bwd.stop;
    out.stop_forward = fwd.stop;
    return out;
}

} // namespace geobarrier
