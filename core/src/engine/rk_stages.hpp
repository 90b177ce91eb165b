// The lockstep kernel's stages (private; batch_integrator.hpp): explicit Runge-Kutta over a whole batch in
// structure-of-arrays layout, one batched right-hand-side call per stage, every pass over the block one vectorisable
// loop. Used by the lockstep steps (lockstep_steps.hpp) and the checked fixed steps (checked_steps.hpp).
#pragma once

#include "batch_context.hpp"

#include <geobarrier/rk_tableaux.hpp>

#include <cmath>
#include <cstddef>
#include <utility>

namespace geobarrier::flow_map_engine {

// Internal linkage in each flow_map_dim<N>.cpp (batch_integrator.hpp).
namespace {

// ---- the lockstep kernel's passes over a block: `stride` = components x lanes contiguous doubles, the stage
// derivatives k_j at k + j * stride. Each is one vectorisable loop; the tableau's rows are compile-time constants, so
// the inner sums unroll with their zero coefficients already left out.

// y = x + h sum_j a_Ij k_j (stage I's state).
template <class Tab, int I>
void stage_state(double *__restrict y, const double *__restrict x, const double *__restrict k, std::size_t stride,
                 double h) {
    static_assert(Tab::a[I].count > 0, "stage 0 is the derivative at the step's start");
#pragma omp simd
    for (std::size_t q = 0; q < stride; ++q)
        y[q] = detail::row_step(Tab::a[I], h, x[q], [&](int j) { return k[j * stride + q]; });
}

// x_new = x + h sum_j b_j k_j.
template <class Tab>
void new_state(double *__restrict x_new, const double *__restrict x, const double *__restrict k, std::size_t stride,
               double h) {
#pragma omp simd
    for (std::size_t q = 0; q < stride; ++q)
        x_new[q] = detail::row_step(Tab::b, h, x[q], [&](int j) { return k[j * stride + q]; });
}

// The local error estimate per component: h sum_j e_j k_j, or for DOP853 Hairer's combination of its 5th- and
// 3rd-order estimates e5 |e5| / sqrt(e5^2 + 0.01 e3^2), an O(h^8) estimate. The combination is homogeneous of
// degree 1, so scaling it afterwards by atol + rtol |x| (error_norm) equals dop853.f's scaled form.
template <class Tab>
void error_estimate(double *__restrict err, const double *__restrict k, std::size_t stride, double h) {
#pragma omp simd
    for (std::size_t q = 0; q < stride; ++q) {
        const auto stage_value = [&](int j) { return k[j * stride + q]; };
        const double s = detail::row_sum(Tab::e, stage_value);
        if constexpr (Tab::error == detail::RkError::dop853) {
            const double s3 = detail::row_sum(Tab::e3, stage_value);
            const double e5 = h * s, e3 = h * s3;
            // DBL_MIN keeps 0 / 0 out (an exactly zero estimate, e.g. a frozen lane, stays 0).
            err[q] = e5 * std::abs(e5) / std::sqrt(e5 * e5 + 0.01 * e3 * e3 + min_scale);
        } else {
            err[q] = h * s;
        }
    }
}

// The stage derivatives of a trial step and the stage state: k holds `stages` blocks of stride = components x lanes
// doubles (block 0 is the derivative at the step's start, computed by the caller), y the state of the current stage.
template <unsigned N> struct LockstepStages {
    State k, y;

    void size_for(int stages, std::size_t stride) {
        k.assign(static_cast<std::size_t>(stages) * stride, 0.0);
        y.assign(stride, 0.0);
    }

    // Stages 1 .. stages-1 of one trial step from (t, x) with step h; stage 0 (k block 0) is already there.
    template <class Tab> void run(BatchContext<N> &ctx, const State &x, double t, double h, std::size_t stride) {
        run_stages<Tab>(ctx, x, std::make_index_sequence<Tab::stages - 1>{}, t, h, stride);
    }

  private:
    template <class Tab, std::size_t... I>
    void run_stages(BatchContext<N> &ctx, const State &x, std::index_sequence<I...>, double t, double h,
                    std::size_t stride) {
        (stage<Tab, static_cast<int>(I) + 1>(ctx, x, t, h, stride), ...);
    }
    template <class Tab, int I>
    void stage(BatchContext<N> &ctx, const State &x, double t, double h, std::size_t stride) {
        stage_state<Tab, I>(y.data(), x.data(), k.data(), stride, h);
        ctx.evaluate(y.data(), k.data() + static_cast<std::size_t>(I) * stride, t + Tab::c[I] * h);
    }
};

} // namespace

} // namespace geobarrier::flow_map_engine
