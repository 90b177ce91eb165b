// The fused policy (private; batch_integrator.hpp): the plugin runs whole steps (ABI 1.2, gb_system_vtable.advance),
// every stage of a lane in registers inside the plugin. FusedSteps<N> builds the requests, supplies the forcing at
// the stage times (cached per thread for the fixed grid) and runs the unchecked fixed steps; the checked fixed steps
// (checked_steps.hpp) use its step too.
#pragma once

#include "batch_state.hpp"

#include <geobarrier/cancel.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/rk_tableaux.hpp>

#include <algorithm>
#include <cstdint>
#include <vector>

namespace geobarrier::flow_map_engine {

// Internal linkage in each flow_map_dim<N>.cpp (batch_integrator.hpp).
namespace {

// Fixed steps of rk4 or dop853 when the system's plugin offers a fused step: every stage of a lane (state, DF,
// log|det DF|) stays in registers inside the plugin instead of passing through the k blocks in memory, which cost
// most of run_lockstep's time (the blocks of 64 lanes x 7 components x 12 stages do not fit in L1). The plugin
// gets the forcing at the stage times (evaluated here, once per stage time as in fill_time); the core keeps the
// rest exactly as run_lockstep: the same step times, frozen lanes restored to their pre-step state (the kernel's
// zero derivatives), the same screening, bounds, renormalisation and counts. Same tableaux, same arithmetic
// order, so the results agree with run_lockstep to rounding. False when the plugin has no fused step or
// declines the method on the first step (nothing has moved then); run_lockstep takes over.
template <unsigned N> class FusedSteps {
    static constexpr std::size_t comp_f11 = LaneLayout<N>::comp_f11, comp_log_det = LaneLayout<N>::comp_log_det;

  public:
    explicit FusedSteps(BatchState<N> &batch) : m_batch(batch) {}

    // The parts of a fused-step request (ABI 1.2 advance) that stay the same for every step of a batch.
    gb_advance_request fused_request(std::int32_t method) {
        gb_advance_request request{};
        request.method = method;
        request.variational = m_batch.ctx.variational ? 1 : 0;
        request.n = request.ld = m_batch.ctx.n;
        request.lane_status = m_batch.ctx.lane_status.data();
        return request;
    }

    // One step of the plugin's fused kernel from (t, m_batch.x) into m_batch.x_new, with the forcing at the step's
    // stage times. False when the plugin declines the method on the batch's first step (nothing has moved: the core's
    // own kernel takes over); declining later, after it took earlier steps, is the plugin's error.
    template <class Tab>
    bool fused_step(gb_advance_request &request, const double *forcing, double t, double h, bool first) {
        const std::size_t n = m_batch.ctx.n;
        request.forcing = forcing;
        request.t = t;
        request.h = h;
        request.x = m_batch.x.data();
        request.x_out = m_batch.x_new.data();
        if (m_batch.ctx.variational) {
            request.df = m_batch.x.data() + comp_f11 * n;
            request.log_det = m_batch.x.data() + comp_log_det * n;
            request.df_out = m_batch.x_new.data() + comp_f11 * n;
            request.log_det_out = m_batch.x_new.data() + comp_log_det * n;
        }
        std::fill(m_batch.ctx.lane_status.begin(), m_batch.ctx.lane_status.end(), GB_OK);
        if (!m_batch.ctx.system->advance(request)) {
            if (first) return false;
            throw PluginError("system '" + m_batch.ctx.system->info().name +
                              "': advance() declined a method it had accepted on earlier steps");
        }
        m_batch.ctx.note_lane_status();
        m_batch.ctx.rhs_calls += Tab::stages;
        return true;
    }

    // The unchecked fixed steps of `method` (dop853 or rk4) in the plugin; false when the plugin declines it on the
    // first step (nothing has moved: run_lockstep takes over).
    bool run(Method method) {
        switch (method) {
        case Method::dop853:
            return run_fused<detail::Dop853Tableau>(GB_ADVANCE_DOP853);
        case Method::rk4:
            return run_fused<detail::Rk4Tableau>(GB_ADVANCE_RK4);
        default:
            return false;
        }
    }

    // The forcing at the stage times of fixed step i (t, h). Every batch of this integrator takes the same steps, so
    // the values are computed once per thread and reused by its later batches (one cos per stage time and step would
    // otherwise cost ~10% of the fused run on workload W); beyond max_cached_forcing values they are computed per step.
    template <class Tab> const double *stage_forcing(std::size_t i, double count, double t, double h) {
        constexpr std::size_t max_cached_forcing = 1u << 16;
        const std::size_t S = Tab::stages;
        const bool cached = count * S <= max_cached_forcing;
        const std::size_t size = cached ? static_cast<std::size_t>(count) * S : S;
        if (m_forcing_stages != S || m_forcing.size() != size) {
            m_forcing.assign(size, 0.0);
            m_forcing_known.assign(cached ? static_cast<std::size_t>(count) : 1, 0);
            m_forcing_stages = S;
        }
        const std::size_t slot = cached ? i : 0;
        double *f = m_forcing.data() + slot * S;
        if (!cached || !m_forcing_known[slot]) {
            for (std::size_t s = 0; s < S; ++s) {
                const double ts = t + Tab::c[s] * h;
                f[s] = 0.0;
                if (m_batch.ctx.forcing) m_batch.ctx.forcing->evaluate(1, &ts, &f[s]);
            }
            m_forcing_known[slot] = cached ? 1 : 0;
        }
        return f;
    }

    // The forcing at the stage times of a sub-step (not on the fixed grid, so not cached).
    template <class Tab> const double *substep_forcing(double t, double h) {
        m_substep_forcing.assign(Tab::stages, 0.0);
        for (int s = 0; s < Tab::stages; ++s) {
            const double ts = t + Tab::c[s] * h;
            if (m_batch.ctx.forcing)
                m_batch.ctx.forcing->evaluate(1, &ts, &m_substep_forcing[static_cast<std::size_t>(s)]);
        }
        return m_substep_forcing.data();
    }

  private:
    template <class Tab> bool run_fused(std::int32_t method) {
        const std::size_t stride = m_batch.x.size();
        m_batch.x_new.assign(stride, 0.0);
        m_batch.dxdt.assign(stride, 0.0); // screen_trial zeroes frozen lanes here
        const double span = m_batch.t1 - m_batch.t0;
        const double count = m_batch.fixed_step_count();
        const double h_fixed = span / count;
        gb_advance_request request = fused_request(method);
        for (double i = 0; m_batch.active > 0 && i < count;) {
            if (const int signal = cancel_requested()) throw Cancelled(signal, "while integrating trajectories");
            if (m_batch.steps >= m_batch.settings.max_steps) {
                m_batch.freeze_all_active(mask_step_limit);
                break;
            }
            const bool last = i + 1 >= count;
            const double t = m_batch.t0 + i * h_fixed; // step times t0 + i h, not accumulated
            const double h = (last ? m_batch.t1 : m_batch.t0 + (i + 1) * h_fixed) - t;
            m_batch.ctx.clear_invalid();
            if (!fused_step<Tab>(request, stage_forcing<Tab>(static_cast<std::size_t>(i), count, t, h), t, h,
                                 m_batch.steps == 0))
                return false;
            for (std::size_t k : m_batch.ctx.frozen) m_batch.copy_lane(m_batch.x_new, m_batch.x, k);
            m_batch.screen_trial(any_non_finite_in(m_batch.x_new), nullptr, nullptr);
            m_batch.x.swap(m_batch.x_new);
            ++m_batch.steps;
            ++i;
            m_batch.after_step(nullptr, t + h);
        }
        return true;
    }

    BatchState<N> &m_batch;
    std::vector<double> m_forcing;             // forcing at each fixed step's stage times (stage_forcing)
    std::vector<std::uint8_t> m_forcing_known; // per step: m_forcing holds its values
    std::size_t m_forcing_stages = 0;
    std::vector<double> m_substep_forcing; // checked fixed steps: forcing at a sub-step's stage times
};

} // namespace

} // namespace geobarrier::flow_map_engine
