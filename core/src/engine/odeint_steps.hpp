// The Boost.Odeint policy (private; batch_integrator.hpp), "engine": "odeint" and rosenbrock4: Odeint's steppers on
// the whole batch state with the engine's error norm, masking and step control (adaptive), or classic RK4 in fixed
// steps.
#pragma once

#include "batch_state.hpp"
#include "error_control.hpp"
#include "odeint_steppers.hpp"

#include <geobarrier/cancel.hpp>
#include <geobarrier/errors.hpp>

#include <algorithm>
#include <cmath>

namespace geobarrier::flow_map_engine {

// Internal linkage in each flow_map_dim<N>.cpp (batch_integrator.hpp).
namespace {

// Adaptive stepping with an embedded error pair of error order `order`. Fsal: dopri5's first-same-as-last
// derivative is reused; otherwise, when the stepper uses it (UsesDerivative: not rosenbrock4, which evaluates
// its own), the derivative at the new state is computed once per accepted step and reused by rejected retries.
template <class Stepper, bool Fsal, bool UsesDerivative, unsigned N>
void run_odeint_adaptive(BatchState<N> &batch, const ErrorControl<N> &errors, int order) {
    const std::size_t size = batch.x.size();
    batch.x_new.assign(size, 0.0);
    batch.dxdt.assign(size, 0.0);
    batch.dxdt_new.assign(size, 0.0);
    batch.xerr.assign(size, 0.0);
    Stepper stepper; // fresh per batch: Odeint sizes its temporaries once, on first use
    Rhs<N> sys{&batch.ctx};
    const double span = batch.t1 - batch.t0;
    double t = batch.t0;
    double dt = std::copysign(std::min(batch.settings.step, std::abs(span)), span);
    const double exponent = -1.0 / (order + 1);
    std::size_t attempts = 0;

    if constexpr (UsesDerivative) {
        sys(batch.x, batch.dxdt, t);
        batch.freeze_invalid(&batch.dxdt);
    }
    while (batch.active > 0 && t != batch.t1) {
        if (const int signal = cancel_requested()) throw Cancelled(signal, "while integrating trajectories");
        const bool last = std::abs(dt) >= std::abs(batch.t1 - t);
        // A final step shorter than the progress floor is taken as it is: tiny horizons (|T| ~ 1e-300) must
        // give DF = I, not a step-limit mask.
        if (attempts >= batch.settings.max_steps || (!last && ErrorControl<N>::no_progress(dt, t))) {
            batch.freeze_all_active(mask_step_limit);
            break;
        }
        const double h = last ? batch.t1 - t : dt;
        batch.ctx.clear_invalid();
        if constexpr (Fsal)
            stepper.do_step(sys, batch.x, batch.dxdt, t, batch.x_new, batch.dxdt_new, h, batch.xerr);
        else
            stepper.do_step(sys, batch.x, batch.dxdt, t, batch.x_new, h, batch.xerr);
        ++attempts;
        bool suspect = false;
        double err = errors.error_norm(batch, batch.xerr, suspect);
        if (suspect || batch.ctx.any_invalid) {
            batch.screen_trial(true, Fsal ? &batch.dxdt_new : nullptr, &batch.xerr);
            if (batch.active == 0) break;
            err = errors.error_norm(batch, batch.xerr, suspect);
        }
        if (err <= 1.0) {
            t = last ? batch.t1 : t + h; // land exactly on t1
            batch.x.swap(batch.x_new);
            if constexpr (Fsal) {
                batch.dxdt.swap(batch.dxdt_new);
            } else if constexpr (UsesDerivative) {
                sys(batch.x, batch.dxdt, t);
                batch.freeze_invalid(&batch.dxdt);
            }
            ++batch.steps;
            batch.after_step(&batch.dxdt, t);
            dt = h * step_factor(err, exponent);
        } else {
            ++batch.rejected;
            dt = h * step_factor(err, exponent);
        }
    }
}

// Classic RK4 with fixed step settings.step; the last step is shortened to land exactly on t1. Step times are
// computed as t0 + i h, not accumulated, so rounding does not add a sliver step at the end.
template <unsigned N> void run_odeint_fixed(BatchState<N> &batch) {
    const std::size_t size = batch.x.size();
    batch.x_new.assign(size, 0.0);
    batch.dxdt.assign(size, 0.0);
    Rk4 stepper;
    Rhs<N> sys{&batch.ctx};
    const double span = batch.t1 - batch.t0;
    const double h = std::copysign(batch.settings.step, span);
    const double count = batch.fixed_step_count();
    for (double i = 0; i < count && batch.active > 0; ++i) {
        if (const int signal = cancel_requested()) throw Cancelled(signal, "while integrating trajectories");
        if (batch.steps >= batch.settings.max_steps) {
            batch.freeze_all_active(mask_step_limit);
            break;
        }
        const double t = batch.t0 + i * h;
        const double t_next = i + 1 >= count ? batch.t1 : batch.t0 + (i + 1) * h;
        batch.ctx.clear_invalid();
        sys(batch.x, batch.dxdt, t);
        stepper.do_step(sys, batch.x, batch.dxdt, t, batch.x_new, t_next - t);
        batch.screen_trial(any_non_finite_in(batch.x_new), nullptr, nullptr);
        batch.x.swap(batch.x_new);
        ++batch.steps;
        batch.after_step(nullptr, t_next);
    }
}

} // namespace

} // namespace geobarrier::flow_map_engine
