// Tensor-line integration: r' = v(r) on an orientation-free LineField by arc length, many lines at once in lockstep
// lanes on the core's Runge-Kutta tableaux (rk_tableaux.hpp, the flow map's): fixed steps of half a grid cell with the
// midpoint rule by default, or an embedded pair with Boost.Odeint's step control. Every stage of a step aligns the
// field with the lane's tangent at the step's start, so a line never turns back on itself at a sign flip of the
// stored vectors.
#include <geobarrier/rk_tableaux.hpp>
#include <geobarrier/tensor_lines.hpp>

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <stdexcept>

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
    case StopReason::observer:
        return "observer";
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

// The settings with their grid-relative defaults filled in.
struct Resolved {
    TensorLineSettings s;
    bool arc_lengths;
    double max_step, min_step, initial_step, closure_distance, closure_min_length;
    Resolved(const LineField &field, const TensorLineSettings &settings, bool keep_arc_lengths)
        : s(settings), arc_lengths(keep_arc_lengths) {
        const Grid &g = field.grid();
        const double h = std::min(g.dx(), g.dy());
        max_step = settings.max_step > 0.0 ? settings.max_step : 0.5 * h;
        min_step = settings.min_step > 0.0 ? settings.min_step : 1e-4 * h;
        initial_step = std::min(settings.initial_step > 0.0 ? settings.initial_step : 0.1 * h, max_step);
        closure_distance = settings.closure_distance > 0.0 ? settings.closure_distance : 0.5 * h;
        closure_min_length = settings.closure_min_length > 0.0 ? settings.closure_min_length : 10.0 * h;
    }
};

// Lanes per lockstep group: the widest vectors (8 doubles) four times over. A stage waits on its field evaluations,
// whose cell corners are loaded lane by lane from scattered cells, so more independent lanes per call hide more of
// that latency (on workload W the evaluation and lane bookkeeping took 0.39-0.56 of the flow map's profile samples
// with 32 lanes, 0.57-0.68 with 16); few enough that a group's arrays (about 6 KB) stay in the first-level cache.
constexpr std::size_t lane_count = 32;
constexpr std::size_t reserve_cap = 1 << 16; // points reserved per line at most

// How a line's backward branch ended, and where its seed lies in the joined line (join_backward).
struct BackwardBranch {
    StopReason stop = StopReason::closed; // closed: the forward branch closed, there is no backward branch
    std::size_t seed_index = 0;
};

// Joins a backward branch (from the seed on) to its forward branch: the backward branch reversed, without its seed,
// then the forward branch, in the forward branch's memory (reserved for both), its points moved up to make room.
void join_backward(TensorLine &fwd, const TensorLine &bwd, bool lengths, BackwardBranch &out) {
    const std::size_t nb = bwd.size(), nf = fwd.size();
    const std::size_t shift = nb ? nb - 1 : 0;
    const double total_back = lengths && nb ? bwd.s.back() : 0.0;
    fwd.xy.resize(2 * (shift + nf));
    std::memmove(fwd.xy.data() + 2 * shift, fwd.xy.data(), 2 * nf * sizeof(double));
    if (lengths) {
        fwd.s.resize(shift + nf);
        for (std::size_t k = nf; k-- > 0;) fwd.s[shift + k] = total_back + fwd.s[k];
    }
    for (std::size_t k = nb, i = 0; k-- > 1; ++i) {
        fwd.xy[2 * i] = bwd.xy[2 * k];
        fwd.xy[2 * i + 1] = bwd.xy[2 * k + 1];
        if (lengths) fwd.s[i] = total_back - bwd.s[k];
    }
    out.seed_index = shift;
    out.stop = bwd.stop;
}

// One thread's group of lanes: each lane takes the batch's next job (from a counter the threads share) when its line
// ends, so the lanes stay busy until the whole batch runs dry, once, rather than at the end of every share of it. A
// job is one line, or, for lines both ways, a seed's forward branch and then, in the same lane, its backward branch
// (so that a batch is one pass, not two that each drain). Every lane does exactly what a lone line would: the stage
// states go through the tableau's rows (row_step), the field is evaluated for all lanes of a stage at once
// (LineField::evaluate_lanes) aligned with each lane's tangent at its step's start, and the step control (fixed, or
// the embedded pair's with Boost.Odeint's rules) and the stops are decided lane by lane.
template <class Tab> class LaneGroup {
  public:
    // Jobs 0..count-1: line k starts at starts[4k..4k+3] (x, y, dir_x, dir_y) and is moved to out[k] when it ends;
    // with `backward`, a line that did not close is followed by its backward branch, from the same point along -dir,
    // integrated into the lane's own buffer (reused line after line: no fresh memory) and joined to out[k] as soon as
    // it ends (join_backward), backward[k] saying how. `next` is the batch's job counter, shared by all threads'
    // groups.
    LaneGroup(const LineField &field, const Resolved &r, const double *starts, std::size_t count,
              std::atomic<std::size_t> &next, TensorLineObserver *observer, TensorLine *out, BackwardBranch *backward,
              std::size_t room_factor)
        : m_field(field), m_r(r), m_starts(starts), m_count(count), m_next(next), m_observer(observer), m_out(out),
          m_backward(backward), m_room_factor(room_factor) {}

    void run() {
        for (std::size_t l = 0; l < lane_count; ++l) {
            m_line[l] = m_pending_backward[l] = none;
            load(l);
        }
        while (true) {
            bool any = false;
            for (std::size_t l = 0; l < lane_count; ++l) any = any || m_line[l] != none;
            if (!any) return;
            attempt();
            for (std::size_t l = 0; l < lane_count; ++l)
                if (m_line[l] != none && decide(l)) load(l);
        }
    }

  private:
    static constexpr int S = Tab::stages;
    static constexpr bool adaptive = Tab::error != detail::RkError::none;
    static constexpr std::size_t none = static_cast<std::size_t>(-1);

    // Lane l's line, forward or backward, in the lane's own buffers while it runs: out[k] of neighbouring k are
    // written by other threads' lanes at the same time, and a push to a vector whose header shares a cache line with
    // theirs would move that line between the cores at every step (W's strainlines, 1000 x 1000: 0.57 s with one
    // thread, 0.36 s with two while written in place, 0.30 s with two since).
    TensorLine &line_of(std::size_t l) { return m_on_backward[l] ? m_backward_line[l] : m_forward_line[l]; }

    // Ends lane l's line with `why`: a forward branch is moved to its place in out and, unless it closed, queues its
    // backward branch in the lane; a backward branch is joined to its forward one. Once per line: kept out of the
    // step's code (inlined, it pushed the limits check out of line, and a step took longer).
    [[gnu::noinline]] void finish(std::size_t l, StopReason why) {
        line_of(l).stop = why;
        if (m_on_backward[l]) {
            join_backward(m_out[m_line[l]], m_backward_line[l], m_r.arc_lengths, m_backward[m_line[l]]);
        } else {
            m_out[m_line[l]] = std::move(m_forward_line[l]);
            m_forward_line[l] = TensorLine{};
            if (m_backward && why != StopReason::closed) m_pending_backward[l] = m_line[l];
        }
        m_line[l] = none;
    }

    // Fills lane l with its pending backward branch, or else the batch's next job, whose seed is usable (lines
    // ending at their seed are finished on the way).
    void load(std::size_t l) {
        m_line[l] = none;
        while (true) {
            const bool backward = m_pending_backward[l] != none;
            const std::size_t k = backward ? m_pending_backward[l] : m_next.fetch_add(1, std::memory_order_relaxed);
            m_pending_backward[l] = none;
            if (k >= m_count) return;
            m_line[l] = k;
            m_on_backward[l] = backward;
            const double *st = m_starts + 4 * k;
            const double sign = backward ? -1.0 : 1.0;
            TensorLine &line = line_of(l);
            const double x0 = st[0], y0 = st[1];
            if (!std::isfinite(x0) || !std::isfinite(y0)) {
                finish(l, StopReason::domain_edge);
                continue;
            }
            // Fixed steps: room for a line that runs its whole length (times room_factor: a forward branch also
            // receives its backward one), so that the lane never copies its points to grow them (capped: only lines
            // stopped early leave reserved memory untouched).
            if (!adaptive) {
                const std::size_t whole = static_cast<std::size_t>(std::min(m_r.s.max_length / m_r.max_step, 1e9)) + 2;
                const std::size_t room =
                    (backward ? 1 : m_room_factor) * std::min<std::size_t>({m_r.s.max_steps, reserve_cap, whole});
                line.xy.reserve(2 * room);
                if (m_r.arc_lengths) line.s.reserve(room);
            }
            line.xy = {x0, y0};
            if (m_r.arc_lengths) line.s = {0.0};
            double tx, ty;
            const LineStatus s0 = m_field.evaluate(x0, y0, sign * st[2], sign * st[3], tx, ty);
            if (s0 != LineStatus::ok) {
                finish(l, stop_for(s0));
                continue;
            }
            m_x0[l] = x0;
            m_y0[l] = y0;
            m_rx[l] = x0;
            m_ry[l] = y0;
            m_kx[0][l] = m_start_tx[l] = tx;
            m_ky[0][l] = m_start_ty[l] = ty;
            m_h[l] = adaptive ? m_r.initial_step : m_r.max_step;
            m_s[l] = 0.0;
            m_steps[l] = 0;
            if (limits_reached(l)) continue;
            return;
        }
    }

    // The step budget and the length: checked before each attempt, as a lone line does. True (and the lane
    // emptied) when the line ends.
    bool limits_reached(std::size_t l) {
        if (m_steps[l] >= m_r.s.max_steps) {
            finish(l, StopReason::max_steps);
        } else if (m_s[l] >= m_r.s.max_length - 1e-9 * m_r.max_step) {
            // (a step's length, measured between its ends, may fall short of h by a rounding error: a remainder
            // that small would take steps that no longer move)
            finish(l, StopReason::max_length);
        } else {
            m_h[l] = std::min({m_h[l], m_r.max_step, m_r.s.max_length - m_s[l]});
            return false;
        }
        return true;
    }

    // One step attempt of every lane (idle lanes compute on harmless numbers): stages, the new point, its error and
    // the tangent there.
    void attempt() {
        std::uint8_t status[lane_count];
        for (std::size_t l = 0; l < lane_count; ++l) m_fail[l] = 0;
        {
            // About where each step will end (on the tangent at its start): the cells there start loading now, while
            // the stages are evaluated, instead of when the new point's tangent is. On W the lanes of a thread that
            // did this took ~7% more steps in the same time than the other thread's (median of 10 runs, each thread
            // in turn); with the hint on every other attempt, those attempts took 5-8% fewer cycles (4 runs). A
            // second hint, for the next step's midpoint, made it slower again.
            double px[lane_count], py[lane_count];
            for (std::size_t l = 0; l < lane_count; ++l) {
                px[l] = m_rx[l] + m_h[l] * m_kx[0][l];
                py[l] = m_ry[l] + m_h[l] * m_ky[0][l];
            }
            m_field.prefetch_lanes(lane_count, px, py);
        }
        for (int i = 1; i < S; ++i) {
            double px[lane_count], py[lane_count];
#pragma GCC ivdep
            for (std::size_t l = 0; l < lane_count; ++l) {
                px[l] = detail::row_step(Tab::a[i], m_h[l], m_rx[l], [&](int j) { return m_kx[j][l]; });
                py[l] = detail::row_step(Tab::a[i], m_h[l], m_ry[l], [&](int j) { return m_ky[j][l]; });
            }
            m_field.evaluate_lanes(lane_count, px, py, m_kx[0], m_ky[0], m_kx[i], m_ky[i], status);
            // With FSAL the last stage is the new point: its status is judged apart (below and in decide).
            if (!Tab::fsal || i < S - 1)
                for (std::size_t l = 0; l < lane_count; ++l) m_fail[l] = m_fail[l] ? m_fail[l] : status[l];
        }
#pragma GCC ivdep
        for (std::size_t l = 0; l < lane_count; ++l) {
            m_ox[l] = detail::row_step(Tab::b, m_h[l], m_rx[l], [&](int j) { return m_kx[j][l]; });
            m_oy[l] = detail::row_step(Tab::b, m_h[l], m_ry[l], [&](int j) { return m_ky[j][l]; });
        }
        if constexpr (adaptive) {
            // Odeint's default error checker: |err| / (atol + rtol (|x| + h |dx/ds|)), the larger component.
            for (std::size_t l = 0; l < lane_count; ++l) {
                const double h = m_h[l];
                const double ex = h * detail::row_sum(Tab::e, [&](int j) { return m_kx[j][l]; });
                const double ey = h * detail::row_sum(Tab::e, [&](int j) { return m_ky[j][l]; });
                m_err[l] =
                    std::max(std::abs(ex) / (m_r.s.atol + m_r.s.rtol * (std::abs(m_rx[l]) + h * std::abs(m_kx[0][l]))),
                             std::abs(ey) / (m_r.s.atol + m_r.s.rtol * (std::abs(m_ry[l]) + h * std::abs(m_ky[0][l]))));
            }
        }
        if constexpr (Tab::fsal) {
            // The last stage is the field at the new point, aligned with the step's start: the next step's k1.
            for (std::size_t l = 0; l < lane_count; ++l) {
                m_nx[l] = m_kx[S - 1][l];
                m_ny[l] = m_ky[S - 1][l];
                m_new_status[l] = status[l];
            }
        } else {
            m_field.evaluate_lanes(lane_count, m_ox, m_oy, m_kx[0], m_ky[0], m_nx, m_ny, m_new_status);
        }
    }

    // Lane l's decision on its attempt: retry shorter, accept, or end. True when the line ended.
    bool decide(std::size_t l) {
        TensorLine &line = line_of(l);
        const auto end = [&](StopReason why) {
            finish(l, why);
            return true;
        };
        ++m_steps[l];
        double &h = m_h[l];
        const std::uint8_t stage_failure = m_fail[l];
        if (stage_failure) {
            // A stage left the usable field: locate the stop to within min_step by halving.
            if (h <= m_r.min_step) return end(stop_for(static_cast<LineStatus>(stage_failure)));
            h = std::max(0.5 * h, m_r.min_step);
            return limits_reached(l);
        }
        double next_h = adaptive ? h : std::min(2.0 * h, m_r.max_step); // fixed: back to max_step after a stop
        if constexpr (adaptive) {
            // Boost.Odeint's step adjuster (controlled_runge_kutta), not the engine's step_factor (error_control.hpp):
            // a different rule, on purpose. It shrinks by err^(-1 / (q - 1)) (q: Tab::error_order), grows only below
            // half the tolerance, by err^(-1 / p) (p: Tab::order) at most 4.5-fold, and keeps the step for err in
            // [1/2, 1]; the engine's rule scales the step after every trial, by err^(-1 / (q + 1)) within [1/5, 5].
            // The lines follow Odeint's error checker above as well: together they are the controlled stepper the
            // tensor lines were written against, one line at a time, before they ran in lanes.
            const double err = m_err[l];
            if (err > 1.0) {
                const double shorter =
                    h * std::max(0.9 * std::pow(err, -1.0 / (Tab::error_order > 1 ? Tab::error_order - 1 : 1)), 0.2);
                if (!(shorter < m_r.min_step)) {
                    h = shorter;
                    return limits_reached(l);
                }
                // The tolerance cannot be met with any useful step (a kink of the interpolated field at a
                // near-singular cell): take the step at min_step anyway.
                if (h > m_r.min_step) {
                    h = m_r.min_step;
                    m_force[l] = 1;
                    return limits_reached(l);
                }
            } else if (err < 0.5 && !m_force[l]) {
                const double e = std::max(std::pow(5.0, -Tab::order), err);
                next_h = h * (0.9 * std::pow(e, -1.0 / Tab::order));
            }
            m_force[l] = 0;
        }
        const double ox = m_ox[l], oy = m_oy[l];
        if (!std::isfinite(ox) || !std::isfinite(oy)) return end(StopReason::singular);
        if (m_new_status[l] != 0) {
            if (h <= m_r.min_step) return end(stop_for(static_cast<LineStatus>(m_new_status[l])));
            h = std::max(0.5 * h, m_r.min_step);
            return limits_reached(l);
        }
        const double px = m_rx[l], py = m_ry[l];
        const double seg = distance(px, py, ox, oy);
        m_rx[l] = ox;
        m_ry[l] = oy;
        m_s[l] += seg;
        m_kx[0][l] = m_nx[l];
        m_ky[0][l] = m_ny[l];
        h = next_h;
        // Closing on itself: the last segment passes the seed, heading the way the line started.
        if (m_r.s.detect_closure && m_s[l] >= m_r.closure_min_length &&
            segment_distance(m_x0[l], m_y0[l], px, py, ox, oy) <= m_r.closure_distance &&
            m_nx[l] * m_start_tx[l] + m_ny[l] * m_start_ty[l] > 0.0) {
            line.xy.push_back(m_x0[l]);
            line.xy.push_back(m_y0[l]);
            if (m_r.arc_lengths) line.s.push_back(m_s[l] - seg + distance(px, py, m_x0[l], m_y0[l]));
            return end(StopReason::closed);
        }
        line.xy.push_back(ox);
        line.xy.push_back(oy);
        if (m_r.arc_lengths) line.s.push_back(m_s[l]);
        if (m_observer && m_observer->stop_after(m_line[l], px, py, ox, oy, m_s[l])) return end(StopReason::observer);
        return limits_reached(l);
    }

    const LineField &m_field;
    const Resolved &m_r;
    const double *m_starts;
    std::size_t m_count;
    std::atomic<std::size_t> &m_next;
    TensorLineObserver *m_observer;
    TensorLine *m_out;
    BackwardBranch *m_backward;
    std::size_t m_room_factor;
    TensorLine m_forward_line[lane_count], m_backward_line[lane_count]; // each lane's line, while it runs

    // Per lane (idle lanes keep harmless values: evaluate_lanes accepts any point).
    std::size_t m_line[lane_count] = {}, m_pending_backward[lane_count] = {};
    bool m_on_backward[lane_count] = {};
    std::size_t m_steps[lane_count] = {};
    alignas(64) double m_rx[lane_count] = {}, m_ry[lane_count] = {}, m_h[lane_count] = {}, m_s[lane_count] = {};
    alignas(64) double m_kx[S][lane_count] = {}, m_ky[S][lane_count] = {};
    alignas(64) double m_ox[lane_count] = {}, m_oy[lane_count] = {}, m_nx[lane_count] = {}, m_ny[lane_count] = {},
                       m_err[lane_count] = {};
    double m_x0[lane_count] = {}, m_y0[lane_count] = {}, m_start_tx[lane_count] = {}, m_start_ty[lane_count] = {};
    std::uint8_t m_fail[lane_count] = {}, m_new_status[lane_count] = {}, m_force[lane_count] = {};
};

// One lane group per thread (no more threads than lane groups' worth of lines), all drawing jobs from one counter.
template <class Tab>
void run_batch(const LineField &field, const Resolved &r, const std::vector<double> &starts,
               TensorLineObserver *observer, std::size_t room_factor, std::vector<TensorLine> &out,
               std::vector<BackwardBranch> *backward) {
    const std::size_t n = out.size();
    const int threads = static_cast<int>(
        std::clamp<std::size_t>((n + lane_count - 1) / lane_count, 1, std::max(omp_get_max_threads(), 1)));
    std::atomic<std::size_t> next{0};
#pragma omp parallel num_threads(threads)
    LaneGroup<Tab>(field, r, starts.data(), n, next, observer, out.data(), backward ? backward->data() : nullptr,
                   room_factor)
        .run();
}

} // namespace

const char *to_string(TensorLineMethod method) {
    switch (method) {
    case TensorLineMethod::midpoint:
        return "midpoint";
    case TensorLineMethod::rk4:
        return "rk4";
    case TensorLineMethod::bs32:
        return "bs32";
    case TensorLineMethod::dopri5:
        return "dopri5";
    }
    return "?";
}

TensorLineMethod tensor_line_method(const std::string &name) {
    for (const TensorLineMethod m :
         {TensorLineMethod::midpoint, TensorLineMethod::rk4, TensorLineMethod::bs32, TensorLineMethod::dopri5})
        if (name == to_string(m)) return m;
    throw std::invalid_argument("tensor-line method \"" + name + "\" is not one of midpoint, rk4, bs32, dopri5");
}

namespace {

// integrate_tensor_lines, with room for room_factor times a whole line reserved per line (fixed steps), with or
// without arc lengths; with `backward`, each line that did not close also backward, joined to it (backward[k] says
// how).
std::vector<TensorLine> integrate_lines(const LineField &field, const std::vector<double> &starts,
                                        const TensorLineSettings &settings, TensorLineObserver *observer,
                                        std::size_t room_factor, bool arc_lengths,
                                        std::vector<BackwardBranch> *backward = nullptr) {
    if (starts.size() % 4 != 0)
        throw std::invalid_argument("integrate_tensor_lines: starts must hold x, y, dir_x, dir_y for each line");
    std::vector<TensorLine> out(starts.size() / 4);
    if (backward) backward->assign(out.size(), BackwardBranch{});
    const Resolved r(field, settings, arc_lengths);
    switch (settings.method) {
    case TensorLineMethod::midpoint:
        run_batch<detail::MidpointTableau>(field, r, starts, observer, room_factor, out, backward);
        break;
    case TensorLineMethod::rk4:
        run_batch<detail::Rk4Tableau>(field, r, starts, observer, room_factor, out, backward);
        break;
    case TensorLineMethod::bs32:
        run_batch<detail::Bs32Tableau>(field, r, starts, observer, room_factor, out, backward);
        break;
    case TensorLineMethod::dopri5:
        run_batch<detail::Dopri5Tableau>(field, r, starts, observer, room_factor, out, backward);
        break;
    }
    return out;
}

} // namespace

std::vector<TensorLine> integrate_tensor_lines(const LineField &field, const std::vector<double> &starts,
                                               const TensorLineSettings &settings, TensorLineObserver *observer) {
    return integrate_lines(field, starts, settings, observer, 1, true);
}

TensorLine integrate_tensor_line(const LineField &field, double x0, double y0, double dir_x, double dir_y,
                                 const TensorLineSettings &settings) {
    return std::move(integrate_tensor_lines(field, {x0, y0, dir_x, dir_y}, settings).front());
}

std::vector<TwoWayLine> integrate_tensor_lines_both_ways(const LineField &field, const std::vector<double> &seeds,
                                                         const TensorLineSettings &settings) {
    return integrate_tensor_lines_both_ways(field, seeds, settings, ArcLengths::keep);
}

std::vector<TwoWayLine> integrate_tensor_lines_both_ways(const LineField &field, const std::vector<double> &seeds,
                                                         const TensorLineSettings &settings, ArcLengths arc_lengths) {
    const bool lengths = arc_lengths == ArcLengths::keep;
    const std::size_t n = seeds.size() / 2;
    std::vector<TwoWayLine> out(n);
    // The forward branch starts along the field's vector at the seed (aligned to +x); seeds where the field is not
    // usable end there.
    std::vector<double> forward_starts;
    std::vector<std::size_t> started;
    for (std::size_t k = 0; k < n; ++k) {
        const double x0 = seeds[2 * k], y0 = seeds[2 * k + 1];
        double vx = 0.0, vy = 0.0;
        const LineStatus st = field.evaluate(x0, y0, 1.0, 0.0, vx, vy);
        if (st != LineStatus::ok || !std::isfinite(x0) || !std::isfinite(y0)) {
            TwoWayLine &o = out[k];
            if (std::isfinite(x0) && std::isfinite(y0)) {
                o.xy = {x0, y0};
                if (lengths) o.s = {0.0};
            }
            o.stop_backward = o.stop_forward = st == LineStatus::ok ? StopReason::domain_edge : stop_for(st);
            continue;
        }
        forward_starts.insert(forward_starts.end(), {x0, y0, vx, vy});
        started.push_back(k);
    }
    // Each line forward and then, in the same lane, backward unless it closed, joined (room for the backward branch
    // in the forward branch's memory: the join moves it there).
    std::vector<BackwardBranch> backward;
    std::vector<TensorLine> joined = integrate_lines(field, forward_starts, settings, nullptr, 2, lengths, &backward);
    for (std::size_t m = 0; m < started.size(); ++m) {
        TwoWayLine &o = out[started[m]];
        o.xy = std::move(joined[m].xy);
        o.s = std::move(joined[m].s);
        o.closed = joined[m].stop == StopReason::closed;
        o.seed_index = backward[m].seed_index;
        o.stop_backward = backward[m].stop;
        o.stop_forward = joined[m].stop;
    }
    return out;
}

TwoWayLine integrate_tensor_line_both_ways(const LineField &field, double x0, double y0,
                                           const TensorLineSettings &settings) {
    return std::move(integrate_tensor_lines_both_ways(field, {x0, y0}, settings).front());
}

} // namespace geobarrier
