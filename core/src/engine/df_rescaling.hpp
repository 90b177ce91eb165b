// Long horizons (private; batch_integrator.hpp): the renormalised variational equations. DF is rescaled by exact
// powers of 2 and the exponent carried per lane (DfRescaling<N>), so DF never overflows and a decaying DF keeps
// relative accuracy.
#pragma once

#include "batch_context.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace geobarrier::flow_map_engine {

// Internal linkage in each flow_map_dim<N>.cpp (batch_integrator.hpp).
namespace {

// Renormalised variational equations: a lane's DF is rescaled by an exact power of 2 (the equations are linear in
// DF, so the trajectory is not perturbed) when its largest entry leaves [1/2, 2^256], and the exponent is carried
// per lane. Above: DF never overflows on long horizons. Below: the error scale atol + rtol |DF| stays relative to
// DF's size, so a decaying DF (damped systems in forward time) keeps rtol relative accuracy instead of drowning in
// atol. The check runs every few accepted steps: to overflow in between, DF would have to grow by 2^768 in that many
// steps, which no step that passed the error control can do.
constexpr int renormalise_exponent = 256;
constexpr double renormalise_low = 0.5;
constexpr unsigned renormalise_every = 4;

// One integrator's DF scales: per lane the exponent e (DF = 2^e times the state's DF block) and whether the lane was
// ever rescaled. `Batch` is the BatchState<N> that holds the lanes (batch_state.hpp).
template <unsigned N> class DfRescaling {
    static constexpr std::size_t comp_f11 = LaneLayout<N>::comp_f11;

  public:
    void reset(std::size_t lanes) {
        m_exponent.assign(lanes, 0);
        m_renormalised.assign(lanes, 0);
        m_since_renormalise = 0;
    }
    // Variational: DF of lane k is 2^exponent()[k] times the state's DF block (0 wherever DF fits in a double).
    const std::vector<std::int32_t> &exponent() const { return m_exponent; }
    // Lanes rescaled at least once (stats.renormalised).
    std::uint64_t renormalised() const {
        std::uint64_t count = 0;
        for (std::size_t k = 0; k < m_renormalised.size(); ++k) count += m_renormalised[k];
        return count;
    }

    // After an accepted step: a lane whose largest |DF| entry left [1/2, 2^256] has its DF block (and, since
    // DF' = Dv DF is linear in DF, the DF block of its derivative) multiplied by an exact power of 2, and the
    // exponent is carried. Nothing is rounded, so the integration is exactly the unscaled one, minus the overflow.
    // One vectorisable pass finds whether any lane needs it; lanes are visited only then. The same pass freezes lanes
    // whose DF became NaN or Inf under a finite state (the checked steps screen only the state: such a DF is no
    // failure of the step); `now` runs it whatever the count, for the last step of a run.
    template <class Batch> void renormalise(Batch &batch, State *dxdt, bool now = false) {
        if (++m_since_renormalise < renormalise_every && !now) return;
        m_since_renormalise = 0;
        const std::size_t n = batch.ctx.n;
        const double *f = batch.x.data() + comp_f11 * n;
        const auto lane_max = [&](std::size_t k) { // NaN when an entry is NaN (a comparison with NaN is false)
            double big = std::abs(f[k]);
#pragma GCC unroll 8
            for (std::size_t c = 1; c < N * N; ++c) {
                const double a = std::abs(f[c * n + k]);
                big = (a > big || a != a) ? a : big;
            }
            return big;
        };
        const double high = std::ldexp(1.0, renormalise_exponent), low = renormalise_low;
        int any = 0;
        for (std::size_t k = 0; k < n; ++k) {
            const double big = lane_max(k);
            any |= static_cast<int>(!(big <= high)) | ((big < low) & (big > 0.0));
        }
        if (!any) return;
        for (std::size_t k = 0; k < n; ++k) {
            const double big = lane_max(k);
            if (batch.ctx.mask[k] != 0 || (big <= high && !(big < low && big > 0.0))) continue;
            if (!(big <= std::numeric_limits<double>::max())) {
                batch.freeze(k, mask_non_finite);
                if (dxdt) batch.zero_lane(*dxdt, k);
                continue;
            }
            const int e = std::ilogb(big);
            for (std::size_t c = comp_f11; c < comp_f11 + N * N; ++c) {
                batch.x[c * n + k] = std::ldexp(batch.x[c * n + k], -e);
                if (dxdt) (*dxdt)[c * n + k] = std::ldexp((*dxdt)[c * n + k], -e);
            }
            m_exponent[k] += e;
            m_renormalised[k] = 1;
        }
    }

    // At the end: DF is handed back unscaled wherever it fits in a double (exponent 0), so callers that never meet
    // long horizons see plain DF; elsewhere it stays scaled with its exponent.
    template <class Batch> void settle(Batch &batch) {
        const std::size_t n = batch.ctx.n;
        for (std::size_t k = 0; k < n; ++k) {
            const int e = m_exponent[k];
            if (e == 0 || batch.ctx.mask[k] != 0) continue;
            double big = 0.0;
            for (std::size_t c = comp_f11; c < comp_f11 + N * N; ++c) big = std::max(big, std::abs(batch.x[c * n + k]));
            if (!(big > 0.0)) continue;
            const int top = std::ilogb(big) + e;
            if (top >= std::numeric_limits<double>::max_exponent - 1 ||
                top <= std::numeric_limits<double>::min_exponent)
                continue; // does not fit: keep it scaled
            for (std::size_t c = comp_f11; c < comp_f11 + N * N; ++c)
                batch.x[c * n + k] = std::ldexp(batch.x[c * n + k], e);
            m_exponent[k] = 0;
        }
    }

  private:
    std::vector<std::int32_t> m_exponent;     // DF = 2^m_exponent[k] * (the state's DF block)
    std::vector<std::uint8_t> m_renormalised; // lanes rescaled at least once
    unsigned m_since_renormalise = 0;
};

} // namespace

} // namespace geobarrier::flow_map_engine
