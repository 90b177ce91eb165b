// A batch's lanes (private; batch_integrator.hpp): BatchState<N> holds the state of one batch of trajectories in
// structure-of-arrays layout and does the lane bookkeeping every stepping policy shares: starting the lanes, freezing
// (masking) lanes with their cause, screening trial steps for NaN, Inf and plugin-refused states, blow-up and bounds
// after each accepted step, the DF rescaling, and the batch's counts.
#pragma once

#include "batch_context.hpp"
#include "df_rescaling.hpp"

#include <geobarrier/flow_map.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

namespace geobarrier::flow_map_engine {

// Internal linkage in each flow_map_dim<N>.cpp (batch_integrator.hpp).
namespace {

// One batch of lanes of a system of dimension N and its bookkeeping. The stepping policies (odeint_steps.hpp,
// lockstep_steps.hpp, checked_steps.hpp, fused_steps.hpp) advance x; what they share is here.
template <unsigned N> class BatchState {
    static constexpr std::size_t position_components = LaneLayout<N>::position_components,
                                 variational_components = LaneLayout<N>::variational_components;
    static constexpr std::size_t comp_f11 = LaneLayout<N>::comp_f11;

  public:
    BatchState(const Dynamics &dynamics, double t0_, double t1_, const IntegratorSettings &settings_, bool variational,
               const std::optional<Bounds> &bounds, const std::array<unsigned, 2> &bound_axes)
        : t0(t0_), t1(t1_), settings(settings_), m_bounds(bounds), m_bound_axes(bound_axes) {
        ctx.system = dynamics.system;
        ctx.forcing = dynamics.system->uses_forcing() ? dynamics.forcing : nullptr;
        ctx.variational = variational;
    }

    // Starts n lanes at start[i * n + k] (component i < N of lane k < n), DF = I with the variational equations.
    // Lanes that start non-finite or outside the bounds are frozen at once.
    void begin_batch(std::size_t n, const double *start) {
        const std::size_t comps = ctx.variational ? variational_components : position_components;
        ctx.reset(n, comps);
        active = n;
        x.assign(comps * n, 0.0);
        rescaling.reset(n);
        limit.resize(n);
        exit_time.assign(n, std::numeric_limits<double>::quiet_NaN());
        std::copy(start, start + N * n, x.begin());
        for (std::size_t k = 0; k < n; ++k) {
            double big = 1.0;
            bool finite = true;
            for (std::size_t i = 0; i < N; ++i) {
                big = std::max(big, std::abs(start[i * n + k]));
                finite = finite && std::isfinite(start[i * n + k]);
            }
            limit[k] = blow_up_factor * big;
            if (!finite) {
                freeze(k, mask_non_finite);
                for (std::size_t i = 0; i < N; ++i) x[i * n + k] = 0.0; // keep what the plugin sees finite
            }
        }
        if (ctx.variational) // DF = I (diagonal blocks comp_f11 + (N + 1) i); log|det DF| starts at 0
            for (std::size_t i = 0; i < N; ++i) std::fill_n(x.begin() + (comp_f11 + (N + 1) * i) * n, n, 1.0);
        check_bounds(nullptr, t0);
        steps = rejected = 0;
        planned = 0;
    }

    // At the end of the batch: exits released (ExitRule::stop), DF settled, and the batch's counts added to stats.
    void end_batch(IntegratorStats &stats) {
        const std::size_t n = ctx.n;
        stats.exited += release_exits();
        if (ctx.variational) rescaling.settle(*this);
        stats.trajectories += n;
        stats.batches += 1;
        stats.steps += steps;
        stats.rejected_steps += rejected;
        stats.planned_steps += planned;
        stats.rhs_evaluations += static_cast<std::uint64_t>(n) * ctx.rhs_calls;
        for (std::size_t k = 0; k < n; ++k) {
            const std::uint8_t m = ctx.mask[k];
            if (m == 0) continue;
            ++stats.masked;
            if (m & mask_left_bounds) ++stats.masked_left_bounds;
            if (m & mask_non_finite) ++stats.masked_non_finite;
            if (m & mask_step_limit) ++stats.masked_step_limit;
            if (m & mask_invalid_state) ++stats.masked_invalid_state;
            if (m & mask_unstable) ++stats.masked_unstable;
        }
        stats.renormalised += rescaling.renormalised();
    }

    // ExitRule::stop: lanes frozen for leaving the bounds (and for nothing else) are results, not masked: their
    // state and DF are the flow map stopped at the exit (Bounds, ExitRule). Returns how many.
    std::uint64_t release_exits() {
        if (!m_bounds || m_bounds->exits != ExitRule::stop) return 0;
        std::uint64_t released = 0;
        for (std::size_t k = 0; k < ctx.n; ++k)
            if (ctx.mask[k] == mask_left_bounds) {
                ctx.mask[k] = 0;
                ++released;
            }
        return released;
    }

    void freeze(std::size_t k, std::uint8_t reason) {
        if (ctx.mask[k] != 0) return;
        ctx.mask[k] = reason;
        ctx.frozen.push_back(k);
        --active;
    }
    void zero_lane(State &v, std::size_t k) const {
        for (std::size_t c = 0; c < ctx.components; ++c) v[c * ctx.n + k] = 0.0;
    }
    void copy_lane(State &dst, const State &src, std::size_t k) const {
        for (std::size_t c = 0; c < ctx.components; ++c) dst[c * ctx.n + k] = src[c * ctx.n + k];
    }
    void freeze_all_active(std::uint8_t reason) {
        for (std::size_t k = 0; k < ctx.n; ++k)
            if (ctx.mask[k] == 0) freeze(k, reason);
    }

    // Lanes the plugin flagged invalid during the last evaluations are frozen; their derivative is zeroed.
    void freeze_invalid(State *derivative) {
        if (!ctx.any_invalid) return;
        for (std::size_t k = 0; k < ctx.n; ++k) {
            if (!ctx.invalid[k]) continue;
            freeze(k, mask_invalid_state);
            if (derivative) zero_lane(*derivative, k);
        }
        ctx.clear_invalid();
    }

    // After a trial step from x to x_new: lanes the plugin rejected, or whose new state or error estimate is not
    // finite, are frozen at their pre-step state and dropped from the error norm. The other lanes are unaffected
    // (lanes are independent), so this equals restoring the batch and retrying the step without the bad lanes.
    // `suspect` says a cheap whole-batch probe found a NaN or Inf; only then are lanes scanned one by one.
    void screen_trial(bool suspect, State *derivative_new, State *error) {
        if (!suspect && !ctx.any_invalid) return;
        const std::size_t n = ctx.n, comps = ctx.components;
        m_bad.assign(n, 0);
        for (std::size_t c = 0; c < comps; ++c) {
            const double *xn = x_new.data() + c * n;
            const double *xe = error ? error->data() + c * n : nullptr;
            for (std::size_t k = 0; k < n; ++k)
                if (!std::isfinite(xn[k]) || (xe && !std::isfinite(xe[k]))) m_bad[k] = 1;
        }
        for (std::size_t k = 0; k < n; ++k) {
            if (ctx.mask[k] != 0) continue;
            if (ctx.invalid[k])
                freeze(k, mask_invalid_state);
            else if (m_bad[k])
                freeze(k, mask_non_finite);
            else
                continue;
            copy_lane(x_new, x, k);
            zero_lane(dxdt, k);
            if (derivative_new) zero_lane(*derivative_new, k);
            if (error) zero_lane(*error, k);
        }
        ctx.clear_invalid();
    }

    // After an accepted step to time t: blown-up lanes and lanes outside the bounds are frozen (check_after_step),
    // and with the variational equations DF is rescaled where it left its range. dxdt: the derivative at the new
    // state, whose frozen lanes are zeroed (null when the policy keeps none).
    void after_step(State *derivative, double t) {
        check_after_step(derivative, t);
        if (ctx.variational) rescaling.renormalise(*this, derivative);
    }

    // After an accepted step: blown-up lanes and lanes outside the bounds box are frozen.
    // One branch-free, vectorisable pass finds whether any lane needs it; lanes are visited only then (frozen lanes
    // keep a state from before they left, so they rarely send us down the slow path, which skips them).
    void check_after_step(State *derivative, double t) {
        const std::size_t n = ctx.n;
        const double *xs = x.data(), *limits = limit.data();
        const double *bx = xs + m_bound_axes[0] * n, *by = xs + m_bound_axes[1] * n;
        const auto blown_up = [&](std::size_t k) {
            int out = 0;
#pragma GCC unroll 8
            for (std::size_t i = 0; i < N; ++i) out |= std::abs(xs[i * n + k]) > limits[k];
            return out;
        };
        int any = 0;
        if (m_bounds) {
            const Bounds &b = *m_bounds;
            for (std::size_t k = 0; k < n; ++k)
                any |=
                    blown_up(k) | !((bx[k] >= b.x_min) & (bx[k] <= b.x_max) & (by[k] >= b.y_min) & (by[k] <= b.y_max));
        } else {
            for (std::size_t k = 0; k < n; ++k) any |= blown_up(k);
        }
        if (!any) return;
        for (std::size_t k = 0; k < n; ++k) {
            if (ctx.mask[k] != 0) continue;
            if (blown_up(k)) {
                freeze(k, mask_non_finite);
                if (derivative) zero_lane(*derivative, k);
            }
        }
        check_bounds(derivative, t);
    }
    // Lanes outside the bounds at time t are frozen there (mask_left_bounds), and t is their exit time.
    void check_bounds(State *derivative, double t) {
        if (!m_bounds) return;
        const std::size_t n = ctx.n;
        const double *bx = x.data() + m_bound_axes[0] * n, *by = x.data() + m_bound_axes[1] * n;
        const Bounds &b = *m_bounds;
        for (std::size_t k = 0; k < n; ++k) {
            if (ctx.mask[k] != 0) continue;
            if (!(bx[k] >= b.x_min && bx[k] <= b.x_max && by[k] >= b.y_min && by[k] <= b.y_max)) {
                freeze(k, mask_left_bounds);
                exit_time[k] = t;
                if (derivative) zero_lane(*derivative, k);
            }
        }
    }

    // Fixed steps: ceil(|t1 - t0| / step) equal steps that land on t1 (the 1e-9 keeps rounding from adding a step).
    double fixed_step_count() const {
        const double ratio = std::abs(t1 - t0) / settings.step;
        return std::max(1.0, std::ceil(ratio - 1e-9 * ratio));
    }

    // Variational: DF of lane k is 2^exponent()[k] times the state's DF block (0 wherever DF fits in a double).
    const std::vector<std::int32_t> &exponent() const { return rescaling.exponent(); }

    const double t0, t1;
    const IntegratorSettings &settings;
    BatchContext<N> ctx;
    DfRescaling<N> rescaling;
    std::size_t active = 0; // lanes not frozen
    std::uint64_t steps = 0, rejected = 0;
    std::uint64_t planned = 0;            // fixed steps: the fixed grid's step count (stats.planned_steps)
    State x, x_new, dxdt, dxdt_new, xerr; // the state, a trial step's state, derivatives and error estimate
    std::vector<double> limit;            // per lane: beyond this |component| it has blown up
    std::vector<double> exit_time;        // with bounds: when each lane left them (NaN: never)

  private:
    const std::optional<Bounds> &m_bounds;
    std::array<unsigned, 2> m_bound_axes; // the state components the bounds box limits (a slice's axes)
    std::vector<std::uint8_t> m_bad;
};

} // namespace

} // namespace geobarrier::flow_map_engine
