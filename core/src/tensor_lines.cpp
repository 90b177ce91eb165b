// Tensor-line integration: r' = v(r) on an orientation-free LineField by arc length with an adaptive Cash–Karp
// 5(4) pair (Boost.Odeint's controlled stepper, written out). Every stage of a step aligns the field with the tangent
// at the step's start, so the line never turns back on itself at a sign flip of the stored vectors.
#include <geobarrier/tensor_lines.hpp>

#include <algorithm>
#include <array>
#include <cmath>

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
    const double ex = px - (ax + t * ux), ey = py - (ay + t * uy);
    return std::sqrt(ex * ex + ey * ey); // not hypot: grid-sized numbers, and this runs at every step
}

double distance(double ax, double ay, double bx, double by) {
    return std::sqrt((bx - ax) * (bx - ax) + (by - ay) * (by - ay));
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

    // Cash–Karp 5(4), written out as Boost.Odeint's controlled stepper computes it (same coefficients, sums,
    // error norm and step-size rules, so the lines are those the extractors were validated with), but with k1
    // taken from the previous step: the tangent at the current point, aligned with the step before, is the field
    // there aligned with itself. That and no generic-algebra overhead make a step five field evaluations plus the
    // new point's tangent, where Odeint needed seven.
    using V = double;
    static const V a21 = V(1) / V(5);
    static const V a31 = V(3) / V(40), a32 = V(9) / V(40);
    static const V a41 = V(3) / V(10), a42 = V(-9) / V(10), a43 = V(6) / V(5);
    static const V a51 = V(-11) / V(54), a52 = V(5) / V(2), a53 = V(-70) / V(27), a54 = V(35) / V(27);
    static const V a61 = V(1631) / V(55296), a62 = V(175) / V(512), a63 = V(575) / V(13824), a64 = V(44275) / V(110592),
                   a65 = V(253) / V(4096);
    static const V c1 = V(37) / V(378), c2 = V(0), c3 = V(250) / V(621), c4 = V(125) / V(594), c5 = V(0),
                   c6 = V(512) / V(1771);
    static const V d1 = V(37) / V(378) - V(2825) / V(27648), d2 = V(0), d3 = V(250) / V(621) - V(18575) / V(48384),
                   d4 = V(125) / V(594) - V(13525) / V(55296), d5 = V(-277) / V(14336),
                   d6 = V(512) / V(1771) - V(1) / V(4);
    double rx = x0, ry = y0; // the current point
    double kx = tx, ky = ty; // the tangent there: stage k1 and the reference for aligning the field
    double s = 0.0;
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
        // One Cash–Karp step of length h from the current point; a stage outside the usable field records why.
        LineStatus failure = LineStatus::ok;
        const auto stage = [&](double x, double y, double &vx, double &vy) {
            vx = kx;
            vy = ky;
            if (failure != LineStatus::ok) return;
            const LineStatus st = field.evaluate(x, y, kx, ky, vx, vy);
            if (st != LineStatus::ok) {
                failure = st;
                vx = kx;
                vy = ky;
            }
        };
        double ox = 0, oy = 0, err = 0;
        const auto cash_karp = [&](double h) {
            double k2x, k2y, k3x, k3y, k4x, k4y, k5x, k5y, k6x, k6y;
            stage(1.0 * rx + a21 * h * kx, 1.0 * ry + a21 * h * ky, k2x, k2y);
            stage(1.0 * rx + a31 * h * kx + a32 * h * k2x, 1.0 * ry + a31 * h * ky + a32 * h * k2y, k3x, k3y);
            stage(1.0 * rx + a41 * h * kx + a42 * h * k2x + a43 * h * k3x,
                  1.0 * ry + a41 * h * ky + a42 * h * k2y + a43 * h * k3y, k4x, k4y);
            stage(1.0 * rx + a51 * h * kx + a52 * h * k2x + a53 * h * k3x + a54 * h * k4x,
                  1.0 * ry + a51 * h * ky + a52 * h * k2y + a53 * h * k3y + a54 * h * k4y, k5x, k5y);
            stage(1.0 * rx + a61 * h * kx + a62 * h * k2x + a63 * h * k3x + a64 * h * k4x + a65 * h * k5x,
                  1.0 * ry + a61 * h * ky + a62 * h * k2y + a63 * h * k3y + a64 * h * k4y + a65 * h * k5y, k6x, k6y);
            ox = 1.0 * rx + c1 * h * kx + c2 * h * k2x + c3 * h * k3x + c4 * h * k4x + c5 * h * k5x + c6 * h * k6x;
            oy = 1.0 * ry + c1 * h * ky + c2 * h * k2y + c3 * h * k3y + c4 * h * k4y + c5 * h * k5y + c6 * h * k6y;
            const double ex = d1 * h * kx + d2 * h * k2x + d3 * h * k3x + d4 * h * k4x + d5 * h * k5x + d6 * h * k6x;
            const double ey = d1 * h * ky + d2 * h * k2y + d3 * h * k3y + d4 * h * k4y + d5 * h * k5y + d6 * h * k6y;
            // Odeint's default error checker: |err| / (atol + rtol (|x| + h |dx/ds|)), the larger component.
            err = std::max(std::abs(ex) / (settings.atol + settings.rtol * (1.0 * std::abs(rx) + h * std::abs(kx))),
                           std::abs(ey) / (settings.atol + settings.rtol * (1.0 * std::abs(ry) + h * std::abs(ky))));
        };
        cash_karp(dt);
        if (failure != LineStatus::ok) {
            // A stage left the usable field: locate the stop to within min_step by halving.
            if (dt <= min_step) {
                line.stop = stop_for(failure);
                return line;
            }
            dt = std::max(0.5 * dt, min_step);
            continue;
        }
        double next_dt = dt; // Odeint's step adjuster: shrink on failure, grow when the error is below 1/2
        if (err > 1.0) {
            const double shorter = dt * std::max(0.9 * std::pow(err, -1.0 / 3.0), 0.2);
            if (!(shorter < min_step)) {
                dt = shorter;
                continue;
            }
            // The tolerance cannot be met with any useful step (a kink of the interpolated field at a
            // near-singular cell): take the step at min_step anyway, if the field allows it.
            cash_karp(min_step);
            if (failure != LineStatus::ok) {
                line.stop = stop_for(failure);
                return line;
            }
            next_dt = min_step;
        } else if (err < 0.5) {
            // Grown past max_step the value does not matter (the next step is capped): skip the pow then.
            const double e = std::max(1.0 / 3125.0, err), cap = 0.9 * dt / max_step;
            next_dt = e <= cap * cap * cap * cap * cap ? std::max(dt, max_step) : dt * (0.9 * std::pow(e, -0.2));
        }
        if (!std::isfinite(ox) || !std::isfinite(oy)) {
            line.stop = StopReason::singular;
            return line;
        }
        // Tangent at the new point, aligned with the old one; it is the next step's k1 and reference.
        double nx, ny;
        const LineStatus st = field.evaluate(ox, oy, kx, ky, nx, ny);
        if (st != LineStatus::ok) {
            if (dt <= min_step) {
                line.stop = stop_for(st);
                return line;
            }
            dt = std::max(0.5 * dt, min_step);
            continue;
        }
        const double px = rx, py = ry;
        const double seg = distance(px, py, ox, oy);
        rx = ox;
        ry = oy;
        s += seg;
        kx = nx;
        ky = ny;
        dt = next_dt;
        // Closing on itself: the last segment passes the seed, heading the way the line started.
        if (settings.detect_closure && s >= closure_min_length &&
            segment_distance(x0, y0, px, py, rx, ry) <= closure_distance && nx * start_tx + ny * start_ty > 0.0) {
            line.xy.push_back(x0);
            line.xy.push_back(y0);
            line.s.push_back(s - seg + distance(px, py, x0, y0));
            line.stop = StopReason::closed;
            return line;
        }
        line.xy.push_back(rx);
        line.xy.push_back(ry);
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
