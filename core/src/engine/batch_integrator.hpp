// The flow-map engine (private to the core): BatchIntegrator<N>, one thread's integrator of batches of trajectories
// of a system of dimension N, and run_batches_of<N>, which runs a request's batches over OpenMP threads. The parts:
//   batch_context.hpp   the lane layout and one batched right-hand-side call of the plugin (BatchContext)
//   batch_state.hpp     a batch's lanes and their bookkeeping: start, masking, screening, bounds, counts (BatchState)
//   df_rescaling.hpp    the renormalised variational equations on long horizons (DfRescaling)
//   error_control.hpp   the error norms and the checked steps' lane errors (ErrorControl)
//   rk_stages.hpp       the lockstep kernel's stages over a batch (LockstepStages)
// and one policy per way of stepping, chosen once per integrator from the parsed settings (StepPlan):
//   lockstep_steps.hpp  the lockstep kernel, adaptive or in fixed steps (the default engine)
//   checked_steps.hpp   checked fixed steps (step_tolerance), in the kernel or the plugin's fused step
//   fused_steps.hpp     the plugin's fused step (ABI 1.2 advance) in unchecked fixed steps
//   odeint_steps.hpp    Boost.Odeint's steppers ("engine": "odeint", and rosenbrock4), odeint_steppers.hpp
// flow_map_dim<N>.cpp instantiates this for one N each; everything here has internal linkage in each of those units,
// so each dimension's engine is inlined and optimised on its own, as one translation unit.
#pragma once

#include "batch_state.hpp"
#include "batches.hpp"
#include "checked_steps.hpp"
#include "error_control.hpp"
#include "fused_steps.hpp"
#include "lockstep_steps.hpp"
#include "odeint_steps.hpp"
#include "rk_stages.hpp"

#include <geobarrier/cancel.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/flow_map.hpp>
#include <geobarrier/rk_tableaux.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <optional>
#include <vector>

namespace geobarrier::flow_map_engine {

// Internal linkage in each flow_map_dim<N>.cpp (see above).
namespace {

// How an integrator steps, decided once from the settings and the system (StepPlan::of).
enum class Stepping {
    lockstep_adaptive, // run_lockstep, adaptive
    lockstep_fixed,    // run_lockstep in fixed steps, or the plugin's fused step (FusedSteps::run) when it takes them
    checked,           // run_checked: fixed steps with an error test, in the plugin's fused step or the kernel
    odeint_dopri5,     // Boost.Odeint's steppers, adaptive (run_odeint_adaptive) ...
    odeint_rkf78,
    odeint_rosenbrock4,
    odeint_rk4 // ... and classic RK4 in fixed steps (run_odeint_fixed)
};

struct StepPlan {
    Method method;
    Stepping stepping;
    bool try_fused; // offer the steps to the plugin's fused step first (it may decline on the first step)

    static StepPlan of(const IntegratorSettings &settings, Method method, const System &system) {
        if (parse_engine(settings.engine) == Engine::odeint || method == Method::rosenbrock4) {
            switch (method) {
            case Method::dopri5:
                return {method, Stepping::odeint_dopri5, false};
            case Method::rkf78:
                return {method, Stepping::odeint_rkf78, false};
            case Method::rk4:
                return {method, Stepping::odeint_rk4, false};
            case Method::rosenbrock4:
                return {method, Stepping::odeint_rosenbrock4, false};
            case Method::dop853:
                break; // refused by validate()
            }
            throw Error("flow map: dop853 runs in the lockstep engine only");
        }
        // rk4 has no error estimate: always fixed steps, never checked.
        const bool adaptive = settings.adaptive && method != Method::rk4;
        if (adaptive) return {method, Stepping::lockstep_adaptive, false};
        const bool fused = settings.fused && system.has_advance();
        // The plugin fuses dop853 (checked or not) and rk4.
        if (settings.step_tolerance > 0.0 && method != Method::rk4)
            return {method, Stepping::checked, fused && method == Method::dop853};
        return {method, Stepping::lockstep_fixed, fused && (method == Method::dop853 || method == Method::rk4)};
    }
};

// Calls f with a value of the Butcher tableau of an explicit method (the lockstep kernels' template argument);
// nothing for rosenbrock4, which has none.
template <class F> void with_explicit_tableau(Method method, F &&f) {
    switch (method) {
    case Method::dop853:
        return f(detail::Dop853Tableau{});
    case Method::dopri5:
        return f(detail::Dopri5Tableau{});
    case Method::rkf78:
        return f(detail::Rkf78Tableau{});
    case Method::rk4:
        return f(detail::Rk4Tableau{});
    case Method::rosenbrock4:
        return;
    }
}

// One thread's integrator for systems of dimension N: integrates one batch at a time, reusing its buffers.
template <unsigned N> class BatchIntegrator {
  public:
    BatchIntegrator(const Dynamics &dynamics, double t0, double t1, const IntegratorSettings &settings, Method method,
                    bool variational, const std::optional<Bounds> &bounds, const DifferenceControl &differences,
                    const std::array<unsigned, 2> &bound_axes)
        : m_plan(StepPlan::of(settings, method, *dynamics.system)),
          m_batch(dynamics, t0, t1, settings, variational, bounds, bound_axes), m_errors(settings, differences),
          m_fused(m_batch) {}

    // Integrates lanes starting at start[i * n + k] (component i < N of lane k < n). Afterwards state() holds the
    // final states (ld = n) and mask() the lanes' MaskBits; masked lanes' states are meaningless.
    void run(std::size_t n, const double *start, IntegratorStats &stats) {
        m_batch.begin_batch(n, start);
        if (m_batch.t0 != m_batch.t1 && m_batch.active > 0) stats.fused_batches += step() ? 1 : 0;
        m_batch.end_batch(stats);
    }

    const State &state() const { return m_batch.x; }
    const std::vector<std::uint8_t> &mask() const { return m_batch.ctx.mask; }
    // Variational: DF of lane k is 2^exponent()[k] times the state's DF block (0 wherever DF fits in a double).
    const std::vector<std::int32_t> &exponent() const { return m_batch.exponent(); }
    // With bounds: when each lane left them (NaN: it never did).
    const std::vector<double> &exit_time() const { return m_batch.exit_time; }

  private:
    // Steps the batch from t0 to t1 by the plan. True when the plugin's fused step took every step.
    bool step() {
        switch (m_plan.stepping) {
        case Stepping::odeint_dopri5:
            run_odeint_adaptive<Dopri5, true, true>(m_batch, m_errors, 4);
            return false;
        case Stepping::odeint_rkf78:
            run_odeint_adaptive<Rkf78, false, true>(m_batch, m_errors, 7);
            return false;
        case Stepping::odeint_rosenbrock4:
            run_odeint_adaptive<RosenbrockStepper, false, false>(m_batch, m_errors, 3);
            return false;
        case Stepping::odeint_rk4:
            run_odeint_fixed(m_batch);
            return false;
        case Stepping::lockstep_adaptive:
            run_kernel(true);
            return false;
        case Stepping::lockstep_fixed:
        case Stepping::checked:
            break;
        }
        m_batch.planned = static_cast<std::uint64_t>(m_batch.fixed_step_count());
        const bool checked = m_plan.stepping == Stepping::checked;
        // The plugin's fused step took every step (checked: dop853 only, the method the SDK fuses).
        if (m_plan.try_fused &&
            (checked ? run_checked<detail::Dop853Tableau>(m_batch, m_errors, m_stages, m_fused, true)
                     : m_fused.run(m_plan.method)))
            return true;
        run_kernel(false);
        return false;
    }

    // The core's lockstep kernel: checked fixed steps, or run_lockstep adaptive or in fixed steps.
    void run_kernel(bool adaptive) {
        const bool checked = m_plan.stepping == Stepping::checked;
        with_explicit_tableau(m_plan.method, [&](auto tableau) {
            using Tab = decltype(tableau);
            if constexpr (Tab::error != detail::RkError::none) {
                if (checked) {
                    run_checked<Tab>(m_batch, m_errors, m_stages, m_fused, false);
                    return;
                }
            }
            run_lockstep<Tab>(m_batch, m_errors, m_stages, adaptive);
        });
    }

    StepPlan m_plan;
    BatchState<N> m_batch;
    ErrorControl<N> m_errors;
    LockstepStages<N> m_stages;
    FusedSteps<N> m_fused;
};

// Integrates the request's lanes in batches, batches in parallel (OpenMP). The first exception thrown in any batch (a
// failing plugin call, say) stops the remaining batches and is rethrown here. N: the system's dimension.
template <unsigned N> IntegratorStats run_batches_of(const BatchRequest &request) {
    const auto start = std::chrono::steady_clock::now();
    const Dynamics &dynamics = request.dynamics;
    const IntegratorSettings &settings = request.settings;
    const std::size_t lanes = request.lanes, batch = request.batch;
    const Method method = parse_method(settings.method);
    const std::size_t batches = (lanes + batch - 1) / batch;
    // A plugin that only promises one instance per thread must not be called from several threads at once.
    const bool concurrent = dynamics.system->info().thread_safety == GB_THREAD_SAFE_CONCURRENT &&
                            (!dynamics.forcing || dynamics.forcing->info().thread_safety == GB_THREAD_SAFE_CONCURRENT);
    IntegratorStats total;
    std::atomic<std::size_t> done{0};
    std::atomic<bool> failed{false};
    std::exception_ptr error;

#pragma omp parallel if (concurrent && batches > 1)
    {
        IntegratorStats local;
        try {
            BatchIntegrator<N> integrator(dynamics, request.t0, request.t1, settings, method, request.variational,
                                          request.bounds, request.differences, request.bound_axes);
            std::vector<double> start(N * batch);
#pragma omp for schedule(dynamic, 1)
            for (long long b = 0; b < static_cast<long long>(batches); ++b) {
                if (failed.load(std::memory_order_relaxed)) continue;
                if (const int signal = cancel_requested()) {
#pragma omp critical(geobarrier_flow_map_error)
                    if (!error) error = std::make_exception_ptr(Cancelled(signal, "while integrating trajectories"));
                    failed.store(true);
                    continue;
                }
                try {
                    const std::size_t first = static_cast<std::size_t>(b) * batch;
                    const std::size_t n = std::min(batch, lanes - first);
                    request.init(first, n, start.data());
                    integrator.run(n, start.data(), local);
                    request.finish(first, n, integrator.state().data(), integrator.mask().data(),
                                   integrator.exponent().data(), integrator.exit_time().data());
                    const std::size_t d = done.fetch_add(1) + 1;
                    if (request.progress) request.progress(d, batches);
                } catch (...) {
#pragma omp critical(geobarrier_flow_map_error)
                    if (!error) error = std::current_exception();
                    failed.store(true);
                }
            }
        } catch (...) {
#pragma omp critical(geobarrier_flow_map_error)
            if (!error) error = std::current_exception();
            failed.store(true);
        }
#pragma omp critical(geobarrier_flow_map_stats)
        total.add(local);
    }
    if (error) std::rethrow_exception(error);
    total.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return total;
}

} // namespace

} // namespace geobarrier::flow_map_engine
