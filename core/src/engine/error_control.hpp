// The engine's error control (private; batch_integrator.hpp): the norm of a trial step's error estimate that the
// adaptive steppers (Odeint's and the lockstep kernel's) hold to atol + rtol |x|, over the positions and, on auxiliary
// grids, their centred differences; and the lane error ratios of the checked fixed steps (step_tolerance).
#pragma once

#include "batch_state.hpp"

#include <geobarrier/flow_map.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <tuple>
#include <utility>
#include <vector>

namespace geobarrier::flow_map_engine {

// Internal linkage in each flow_map_dim<N>.cpp (batch_integrator.hpp).
namespace {

// The factor from one step h to the next, h * step_factor(err, exponent): the step-size rule of every adaptive stepper
// of the engine (the lockstep kernel's, Boost.Odeint's, the checked fixed steps' sub-steps), after an accepted step and
// after a rejected one. err: the trial step's error over its tolerance (accepted at err <= 1), never NaN (the norms
// skip or screen NaN: error_norm, batch_error); exponent: -1 / (q + 1) for an estimate of order q, since err grows as
// h^(q+1), so that h err^exponent is the step that would just have met the tolerance. The limits are the textbook ones
// (Hairer, Norsett & Wanner, Solving ODEs I, II.4, who advise a largest growth between 1.5 and 5; Boost.Odeint's step
// adjuster has the same 0.9 and 1/5, and grows at most 4.5-fold):
// - 0.9, a safety factor: aim a little under that step, so that the next trial is seldom rejected;
// - at least 0.2 (5 times shorter): far over the tolerance the estimate has left its asymptotic range and predicts
//   the passing step poorly, so a retry shrinks by at most 5 and the next estimate decides again;
// - at most 5 (5 times longer): one step's estimate says little about steps much longer than itself; an error of
//   exactly 0 (every lane of the batch frozen, or a step with no error) takes the largest growth.
// After a rejected step (err > 1) the factor is at most 0.9, so a retry is always shorter. Keep the operations in this
// order: the fields are bit-identical across releases only while every step rounds as it did.
inline double step_factor(double err, double exponent) {
    return std::clamp(err > 0.0 ? 0.9 * std::pow(err, exponent) : 5.0, 0.2, 5.0);
}

// The tolerances of one integrator's steps and the error measures built on them. N: the system's dimension.
template <unsigned N> class ErrorControl {
    static constexpr std::size_t position_components = LaneLayout<N>::position_components;

    // (0, 1, .., N - 1) as a tuple of std::size_t, for fold expressions over the state components.
    template <std::size_t... I> static constexpr auto component_indices(std::index_sequence<I...>) {
        return std::make_tuple(I...);
    }
    static constexpr auto component_indices() { return component_indices(std::make_index_sequence<N>{}); }

  public:
    ErrorControl(const IntegratorSettings &settings, const DifferenceControl &differences)
        : m_atol(settings.atol), m_rtol(std::max(settings.rtol, min_rtol)), m_step_tolerance(settings.step_tolerance),
          m_differences(differences) {}

    // err = max over lanes and components of |xerr| / (atol + rtol max(|x_old|, |x_new|)). Frozen lanes have an
    // error of exactly zero (all their stage derivatives are zero), so no lane test is needed. Sets `suspect` when
    // the new state or the error holds a NaN or Inf (then err is meaningless and the caller screens the lanes).
    double error_norm(const BatchState<N> &batch, const State &xerr, bool &suspect) const {
        const double atol = m_atol, rtol = m_rtol;
        const double *xo = batch.x.data(), *xn = batch.x_new.data(), *xe = xerr.data();
        const std::size_t size = xerr.size();
        double err = 0.0, probe = 0.0;
        // The reductions may be reordered (simd): max is exact in any order, and the probe is NaN in any order.
#pragma omp simd reduction(max : err) reduction(+ : probe)
        for (std::size_t i = 0; i < size; ++i) {
            // DBL_MIN floor: an exactly zero scale (atol = 0 at x = 0) must not give 0/0 = NaN.
            const double scale = std::max(atol + rtol * std::max(std::abs(xo[i]), std::abs(xn[i])), min_scale);
            err = std::max(err, std::abs(xe[i]) / scale);
            probe += (xn[i] + xe[i]) * 0.0;
        }
        suspect = probe != probe;
        if (m_differences.per_point > 0) err = std::max(err, difference_error_norm(batch, xerr));
        return err;
    }

    // The same norm over the auxiliary groups' centred differences D = (F(+) - F(-)) / 2d (see DifferenceControl).
    // Frozen lanes have zero error; their group is masked at the end anyway.
    double difference_error_norm(const BatchState<N> &batch, const State &xerr) const {
        const double atol = m_atol, rtol = m_rtol;
        const std::size_t n = batch.ctx.n, per_point = m_differences.per_point;
        const double inv[2] = {m_differences.inv_2dx, m_differences.inv_2dy};
        double err = 0.0;
        for (std::size_t c = 0; c < 2; ++c) {
            const double *xo = batch.x.data() + c * n, *xn = batch.x_new.data() + c * n, *xe = xerr.data() + c * n;
            for (std::size_t b = 0; b + 3 < n; b += per_point) {
                for (std::size_t axis = 0; axis < 2; ++axis) {
                    const std::size_t plus = b + 2 * axis, minus = plus + 1;
                    const double d_old = (xo[plus] - xo[minus]) * inv[axis];
                    const double d_new = (xn[plus] - xn[minus]) * inv[axis];
                    const double e = (xe[plus] - xe[minus]) * inv[axis];
                    const double scale = std::max(atol + rtol * std::max(std::abs(d_old), std::abs(d_new)), min_scale);
                    err = std::max(err, std::abs(e) / scale);
                }
            }
        }
        return err;
    }

    static bool no_progress(double dt, double t) {
        return !(std::abs(dt) >= min_relative_step * std::max(1.0, std::abs(t)));
    }

    // ---- checked fixed steps (IntegratorSettings::step_tolerance)

    // Lane error estimates to ratios: times |h|, over the lane's scale step_tolerance (1 + max(|x|, |x_new|)) over
    // its state components (a norm-wise error of the state, relative where it is large). A lane whose new state is
    // NaN or Inf gets a NaN ratio (x - x is 0 for a finite x, NaN otherwise), so that this one vectorisable pass also
    // does the non-finite screening of the trial step; a non-finite DF under a finite state is no failure of the
    // step (check_after_step freezes such lanes). Returns whether any ratio exceeds 1 or is NaN.
    bool scale_lane_errors(const BatchState<N> &batch, double h) {
        const std::size_t n = batch.ctx.n;
        const double factor = std::abs(h) / m_step_tolerance;
        const double *__restrict x = batch.x.data(), *__restrict xn = batch.x_new.data();
        double *__restrict e = lane_error.data();
        // By value (std::max returns a reference, which keeps GCC 12 from vectorising this loop).
        const auto larger = [](double a, double b) { return a < b ? b : a; };
        int over = 0;
#pragma omp simd reduction(| : over)
        for (std::size_t k = 0; k < n; ++k) {
            // One expression per lane (a loop over the components here kept GCC 12 from vectorising the lane loop).
            const auto largest = [&](auto... i) {
                double big = 0.0;
                ((big = larger(big, larger(std::abs(x[i * n + k]), std::abs(xn[i * n + k])))), ...);
                return big;
            };
            const auto non_finite_probe = [&](auto... i) { return ((xn[i * n + k] - xn[i * n + k]) + ...); };
            double big, probe;
            if constexpr (N == 2) {
                big = larger(larger(std::abs(x[k]), std::abs(x[n + k])), larger(std::abs(xn[k]), std::abs(xn[n + k])));
                probe = (xn[k] - xn[k]) + (xn[n + k] - xn[n + k]);
            } else {
                big = std::apply(largest, component_indices());
                probe = std::apply(non_finite_probe, component_indices());
            }
            e[k] = factor * e[k] / (1.0 + big) + probe;
            over |= !(e[k] <= 1.0);
        }
        return over != 0;
    }

    // The batch's error of a trial step: the largest lane error of the active lanes; +Inf when a lane's new state or
    // error is NaN or Inf or the plugin refused one of its stage states. Such lanes get an infinite lane error, for
    // mask_failing_lanes. A whole step of the fixed grid that every lane passes (`any_over` false: scale_lane_errors
    // found no ratio above 1 and no NaN) needs no more (the next step is whole again), so without `exact` such a step
    // gets 0 and the largest lane error is left unsearched.
    double batch_error(const BatchState<N> &batch, bool any_over, bool exact) {
        const std::size_t n = batch.ctx.n;
        const double *e = lane_error.data();
        double err = 0.0;
        if (!batch.ctx.any_invalid) {
            if (!exact && !any_over) return 0.0; // the common case
            if (!any_non_finite(e, n)) {
                for (std::size_t k = 0; k < n; ++k) err = e[k] > err ? e[k] : err;
                return err;
            }
        }
        const std::size_t comps = batch.ctx.components;
        for (std::size_t k = 0; k < n; ++k) {
            if (batch.ctx.mask[k] != 0) continue;
            bool lane_bad = batch.ctx.invalid[k] || !(lane_error[k] <= std::numeric_limits<double>::max());
            for (std::size_t c = 0; c < comps && !lane_bad; ++c) lane_bad = !std::isfinite(batch.x_new[c * n + k]);
            if (lane_bad) lane_error[k] = std::numeric_limits<double>::infinity();
        }
        err = 0.0;
        for (std::size_t k = 0; k < n; ++k)
            if (batch.ctx.mask[k] == 0) err = std::max(err, lane_error[k]);
        return err;
    }

    std::vector<double> lane_error; // checked fixed steps: each lane's error of the trial step

  private:
    double m_atol;
    double m_rtol; // settings.rtol clamped to min_rtol
    double m_step_tolerance;
    DifferenceControl m_differences;
};

} // namespace

} // namespace geobarrier::flow_map_engine
