// The checked fixed steps (private; batch_integrator.hpp), IntegratorSettings::step_tolerance, the quality presets'
// default: fixed steps whose embedded error estimate is tested, sub-stepped where it fails; the stages run in the
// plugin's fused step (fused_steps.hpp) or in the lockstep kernel (rk_stages.hpp).
#pragma once

#include "batch_state.hpp"
#include "error_control.hpp"
#include "fused_steps.hpp"
#include "rk_stages.hpp"

#include <geobarrier/cancel.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/rk_tableaux.hpp>

#include <algorithm>
#include <cmath>

namespace geobarrier::flow_map_engine {

// Internal linkage in each flow_map_dim<N>.cpp (batch_integrator.hpp).
namespace {

// The kernel's lane error estimates of a trial step (stage derivatives in stages.k), exactly as the SDK's fused step
// computes them (rk_tableaux.hpp, lane_error_estimate).
template <class Tab, unsigned N>
void lane_errors(const BatchState<N> &batch, ErrorControl<N> &errors, const LockstepStages<N> &stages) {
    const std::size_t n = batch.ctx.n, stride = batch.x.size();
    const double *__restrict k = stages.k.data();
    double *__restrict out = errors.lane_error.data();
#pragma omp simd
    for (std::size_t lane = 0; lane < n; ++lane)
        out[lane] = detail::lane_error_estimate<Tab, LaneLayout<N>::position_components>(
            [&](int j, unsigned c) { return k[j * stride + c * n + lane]; });
}

// At the smallest sub-step: lanes whose error still exceeds 1 are frozen at their pre-step state, with the cause.
template <unsigned N>
void mask_failing_lanes(BatchState<N> &batch, const ErrorControl<N> &errors, LockstepStages<N> &stages,
                        bool in_plugin) {
    const std::size_t n = batch.ctx.n, comps = batch.ctx.components;
    for (std::size_t k = 0; k < n; ++k) {
        if (batch.ctx.mask[k] != 0 || !(errors.lane_error[k] > 1.0)) continue;
        bool finite = true;
        for (std::size_t c = 0; c < comps; ++c) finite = finite && std::isfinite(batch.x_new[c * n + k]);
        const double runaway_limit = batch.limit[k] * (runaway_factor / blow_up_factor);
        bool runaway = false;
        for (std::size_t i = 0; i < N; ++i) runaway = runaway || std::abs(batch.x[i * n + k]) > runaway_limit;
        batch.freeze(k, batch.ctx.invalid[k] ? mask_invalid_state
                        : finite && !runaway ? mask_unstable
                                             : mask_non_finite);
        batch.copy_lane(batch.x_new, batch.x, k);
        if (!in_plugin) batch.zero_lane(stages.k, k);
    }
}

// Fixed steps with an error test. The fixed grid t_i = t0 + i h (h = (t1 - t0) / ceil(|t1 - t0| / step)) is a
// sequence of checkpoints: each step goes from t to the next checkpoint in equal sub-steps of at most dt, dt = h
// until a step fails. Every trial step's embedded error estimate of the state (per lane: lane_error_estimate of
// rk_tableaux.hpp over x and y, scaled by scale_lane_errors) is tested by the batch's worst lane, so the batch
// stays in lockstep: a failure (or a NaN, Inf or plugin-refused state, the usual signature of an unstable
// explicit step) shrinks dt by the classic factor 0.9 err^(-1/(q+1)) and retries; accepted sub-steps grow it
// again, at most to h. On a smooth system every whole step passes, and the run takes exactly the unchecked fixed
// steps (same times, same forcing values, same numbers). At the floor h * min_step_fraction, lanes that still
// fail are masked with their cause (mask_unstable: the stepper, not the trajectory; mask_non_finite for a NaN or
// Inf there; mask_invalid_state for a refused state) and the others go on. DF is not in the test: it follows the
// state's time scales, and its error relative to DF tracks the state's (checked on the accuracy suite of the
// bench, docs/performance.md). Fused: the plugin's step writes the lane errors (ABI 1.3,
// GB_ADVANCE_DOP853_CHECKED); false when it declines on the first step (nothing has moved), and the kernel
// takes over. Otherwise the core's stage-by-stage kernel runs the stages (run_lockstep's passes).
template <class Tab, unsigned N>
bool run_checked(BatchState<N> &batch, ErrorControl<N> &errors, LockstepStages<N> &stages, FusedSteps<N> &fused,
                 bool in_plugin) {
    static_assert(Tab::error != detail::RkError::none, "the checked steps need an error estimate");
    const std::size_t n = batch.ctx.n, stride = batch.x.size();
    batch.x_new.assign(stride, 0.0);
    batch.dxdt.assign(stride, 0.0);
    errors.lane_error.assign(n, 0.0);
    const double span = batch.t1 - batch.t0;
    const double count = batch.fixed_step_count();
    const double h_fixed = span / count, h_full = std::abs(h_fixed);
    const double h_min = h_full * min_step_fraction;
    // The estimate's own order (lane_error_estimate): DOP853's 5th-order row alone is O(h^6).
    const double exponent = -1.0 / (Tab::error == detail::RkError::dop853 ? 6 : Tab::error_order + 1);
    gb_advance_request request = fused.fused_request(GB_ADVANCE_DOP853_CHECKED);
    if (in_plugin) {
        request.lane_error = errors.lane_error.data();
    } else {
        stages.size_for(Tab::stages, stride);
        batch.ctx.evaluate(batch.x.data(), stages.k.data(), batch.t0);
        batch.freeze_invalid(&stages.k);
    }
    double t = batch.t0, dt = h_full;
    std::size_t attempts = 0;
    for (double i = 0; batch.active > 0 && i < count;) {
        if (const int signal = cancel_requested()) throw Cancelled(signal, "while integrating trajectories");
        if (attempts >= batch.settings.max_steps) {
            batch.freeze_all_active(mask_step_limit);
            break;
        }
        const double t_next = i + 1 >= count ? batch.t1 : batch.t0 + (i + 1) * h_fixed; // not accumulated
        const double remaining = t_next - t;
        const double pieces = std::max(1.0, std::ceil(std::abs(remaining) / dt - 1e-9));
        const bool lands = pieces <= 1.0;
        const bool whole = lands && t == batch.t0 + i * h_fixed; // a step of the fixed grid: cached forcing
        const double h = lands ? remaining : remaining / pieces;
        batch.ctx.clear_invalid();
        if (in_plugin) {
            const double *forcing = whole ? fused.template stage_forcing<Tab>(static_cast<std::size_t>(i), count, t, h)
                                          : fused.template substep_forcing<Tab>(t, h);
            if (!fused.template fused_step<Tab>(request, forcing, t, h, attempts == 0)) return false;
            for (std::size_t k : batch.ctx.frozen) { // frozen lanes stay put, with no error
                batch.copy_lane(batch.x_new, batch.x, k);
                errors.lane_error[k] = 0.0;
            }
        } else {
            stages.template run<Tab>(batch.ctx, batch.x, t, h, stride);
            if constexpr (Tab::fsal)
                batch.x_new.swap(stages.y);
            else
                new_state<Tab>(batch.x_new.data(), batch.x.data(), stages.k.data(), stride, h);
            lane_errors<Tab>(batch, errors, stages); // frozen lanes: zero derivatives, so zero error
        }
        const bool any_over = errors.scale_lane_errors(batch, h);
        ++attempts;
        const double err = errors.batch_error(batch, any_over, !whole);
        const bool at_floor = std::abs(h) <= h_min * (1.0 + 1e-9);
        if (err > 1.0 && !at_floor) {
            ++batch.rejected;
            batch.ctx.clear_invalid();
            dt = std::max(h_min, std::abs(h) * step_factor(err, exponent)); // err > 1: a factor <= 0.9
            continue;
        }
        if (err > 1.0)
            mask_failing_lanes(batch, errors, stages, in_plugin); // at the floor: the rest of the batch goes on
        batch.ctx.clear_invalid();
        t = lands ? t_next : t + h;
        batch.x.swap(batch.x_new);
        if constexpr (Tab::fsal) {
            if (!in_plugin)
                std::copy(stages.k.begin() + (Tab::stages - 1) * stride, stages.k.begin() + Tab::stages * stride,
                          stages.k.begin());
        }
        ++batch.steps;
        if (lands) ++i;
        if (!in_plugin && !Tab::fsal && i < count) {
            batch.ctx.evaluate(batch.x.data(), stages.k.data(), t);
            batch.freeze_invalid(&stages.k);
        }
        if (!in_plugin && Tab::fsal)
            for (std::size_t k : batch.ctx.frozen) batch.zero_lane(stages.k, k);
        batch.after_step(in_plugin ? nullptr : &stages.k, t);
        dt = whole ? h_full : std::min(h_full, std::abs(h) * step_factor(err, exponent));
    }
    if (batch.ctx.variational)
        batch.rescaling.renormalise(batch, nullptr, true); // DF of the last steps: NaN or Inf is masked
    return true;
}

} // namespace

} // namespace geobarrier::flow_map_engine
