// The lockstep policy (private; batch_integrator.hpp), the default engine: the lockstep kernel's explicit
// Runge-Kutta steps (rk_stages.hpp) over the whole batch, adaptive with the engine's error norm or in fixed steps.
#pragma once

#include "batch_state.hpp"
#include "error_control.hpp"
#include "rk_stages.hpp"

#include <geobarrier/cancel.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/rk_tableaux.hpp>

#include <algorithm>
#include <cmath>

namespace geobarrier::flow_map_engine {

// Internal linkage in each flow_map_dim<N>.cpp (batch_integrator.hpp).
namespace {

// Explicit Runge-Kutta over the whole block in structure-of-arrays layout, lanes in lockstep: one batched
// right-hand-side call (and, with the variational equations, one Jacobian call) per stage, the forcing
// evaluated once per stage time (BatchContext::fill_time), every pass over the block one vectorisable loop.
// stages.k holds the stage derivatives; block 0 is the derivative at the current state (computed once per accepted
// step, reused by rejected retries). Adaptive: the step is controlled by the worst lane and component, the
// error norm and masking exactly as in run_adaptive. Fixed: ceil(|t1 - t0| / step) equal steps that land on t1.
template <class Tab, unsigned N>
void run_lockstep(BatchState<N> &batch, const ErrorControl<N> &errors, LockstepStages<N> &stages, bool adaptive) {
    static_assert(Tab::error != detail::RkError::none || !Tab::fsal, "FSAL needs an error-controlled tableau");
    const std::size_t stride = batch.x.size();
    stages.size_for(Tab::stages, stride);
    batch.x_new.assign(stride, 0.0);
    batch.dxdt.assign(stride,
                      0.0); // screen_trial zeroes frozen lanes here; the kernel's own derivative is stages.k block 0
    if (adaptive) batch.xerr.assign(stride, 0.0);
    const double span = batch.t1 - batch.t0;
    double t = batch.t0;
    batch.ctx.evaluate(batch.x.data(), stages.k.data(), t);
    batch.freeze_invalid(&stages.k);

    double count = 1.0, h_fixed = span;
    if (!adaptive) {
        count = batch.fixed_step_count();
        h_fixed = span / count;
    }
    double dt = std::copysign(std::min(batch.settings.step, std::abs(span)), span);
    const double exponent = -1.0 / (Tab::error_order + 1);
    std::size_t attempts = 0;
    for (double i = 0; batch.active > 0 && (adaptive ? t != batch.t1 : i < count);) {
        if (const int signal = cancel_requested()) throw Cancelled(signal, "while integrating trajectories");
        bool last;
        double h;
        if (adaptive) {
            last = std::abs(dt) >= std::abs(batch.t1 - t);
            if (attempts >= batch.settings.max_steps || (!last && ErrorControl<N>::no_progress(dt, t))) {
                batch.freeze_all_active(mask_step_limit);
                break;
            }
            h = last ? batch.t1 - t : dt;
        } else {
            if (batch.steps >= batch.settings.max_steps) {
                batch.freeze_all_active(mask_step_limit);
                break;
            }
            last = i + 1 >= count;
            t = batch.t0 + i * h_fixed; // step times t0 + i h, not accumulated
            h = (last ? batch.t1 : batch.t0 + (i + 1) * h_fixed) - t;
        }
        const std::size_t frozen_before = batch.ctx.frozen.size();
        batch.ctx.clear_invalid();
        stages.template run<Tab>(batch.ctx, batch.x, t, h, stride);
        if constexpr (Tab::fsal)
            batch.x_new.swap(stages.y); // the last stage is evaluated at the new state
        else
            new_state<Tab>(batch.x_new.data(), batch.x.data(), stages.k.data(), stride, h);
        ++attempts;
        double err = 0.0;
        if (adaptive) {
            if constexpr (Tab::error != detail::RkError::none) {
                error_estimate<Tab>(batch.xerr.data(), stages.k.data(), stride, h);
                bool suspect = false;
                err = errors.error_norm(batch, batch.xerr, suspect);
                if (suspect || batch.ctx.any_invalid) {
                    batch.screen_trial(true, &stages.k, &batch.xerr);
                    if (batch.active == 0) break;
                    err = errors.error_norm(batch, batch.xerr, suspect);
                }
            }
        } else {
            batch.screen_trial(any_non_finite_in(batch.x_new), &stages.k, nullptr);
        }
        if (err <= 1.0) {
            t = last ? batch.t1 : t + h; // land exactly on t1
            batch.x.swap(batch.x_new);
            if constexpr (Tab::fsal) {
                std::copy(stages.k.begin() + (Tab::stages - 1) * stride, stages.k.begin() + Tab::stages * stride,
                          stages.k.begin());
                // Lanes frozen while screening this trial still hold their last-stage derivative.
                for (std::size_t f = frozen_before; f < batch.ctx.frozen.size(); ++f)
                    batch.zero_lane(stages.k, batch.ctx.frozen[f]);
            } else if (adaptive || !last) {
                // (Fixed steps skip it after the last step: rk4 then costs exactly 4 evaluations per step.)
                batch.ctx.evaluate(batch.x.data(), stages.k.data(), t);
                batch.freeze_invalid(&stages.k);
            }
            ++batch.steps;
            ++i;
            batch.after_step(&stages.k, t);
            if (adaptive) dt = h * step_factor(err, exponent);
        } else {
            ++batch.rejected;
            // The newly frozen lanes' derivative at the step's start must not move them in the retry.
            for (std::size_t f = frozen_before; f < batch.ctx.frozen.size(); ++f)
                batch.zero_lane(stages.k, batch.ctx.frozen[f]);
            dt = h * step_factor(err, exponent);
        }
    }
}

} // namespace

} // namespace geobarrier::flow_map_engine
