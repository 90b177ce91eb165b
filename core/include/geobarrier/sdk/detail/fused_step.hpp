// Part of the plugin SDK's machinery, included by <geobarrier/sdk.hpp> only: not part of the public face (a plugin
// never names geobarrier::sdk::detail). The fused Runge-Kutta step of gb_system_vtable.advance: every stage of a lane,
// with the variational equations, in registers, the lanes vectorised.
#ifndef GEOBARRIER_SDK_DETAIL_FUSED_STEP_HPP
#define GEOBARRIER_SDK_DETAIL_FUSED_STEP_HPP

#ifndef GEOBARRIER_SDK_HPP
#error "include <geobarrier/sdk.hpp>, not its detail headers"
#endif

#include <geobarrier/sdk/detail/lanes.hpp>

namespace geobarrier::sdk::detail {

// One fused explicit Runge-Kutta step of tableau Tab for every lane of a request (gb_advance_request). Per lane the
// state (with the variational equations: x, DF row-major, log|det DF|) and the stage derivatives are small local
// arrays, so after inlining they live in registers, and the lane loop vectorises (GCC 12 -O3: 8 lanes with AVX-512,
// -fopt-info-vec; `omp simd` would not: its per-lane copies of the arrays defeat the vectoriser). The arithmetic is the
// core's stage-by-stage kernel's (flow_map.cpp: stage_state, new_state, the variational right-hand side), term for
// term, so both agree to rounding.
template <class T, class Tab, bool Variational> struct FusedStep {
    static constexpr unsigned D = T::dimension;
    static constexpr unsigned C = Variational ? D + D * D + 1 : D; // per-lane components
    static constexpr int S = Tab::stages;

    // True when the compiler knows v to be 0 after inlining (GCC and Clang; elsewhere never).
    GEOBARRIER_ALWAYS_INLINE static bool literal_zero(double v) {
#if defined(__GNUC__)
        return __builtin_constant_p(v) && v == 0.0;
#else
        (void)v;
        return false;
#endif
    }

    // d/dt of the lane's extended state: v, DF' = Dv DF, (log|det DF|)' = tr Dv (Liouville).
    GEOBARRIER_ALWAYS_INLINE static void derivative(const T &sys, double t, double f, const double *y, double *dy) {
        sys.field(t, y, f, dy);
        if constexpr (Variational) {
            double J[D * D];
            lane_jacobian(sys, t, y, f, J);
            const double *F = y + D;
#pragma GCC unroll 16
            for (unsigned i = 0; i < D; ++i)
#pragma GCC unroll 16
                for (unsigned j = 0; j < D; ++j) {
                    // Entries the plugin sets to a literal 0 (x' = y has two) drop out at compile time: 0 * F is
                    // not foldable in IEEE arithmetic, and those products were 8% of a Duffing dop853 step. Only
                    // the sign of an exact zero can differ from the core's stage-by-stage sum.
                    double s = 0.0;
                    bool started = false;
#pragma GCC unroll 16
                    for (unsigned l = 0; l < D; ++l) {
                        if (literal_zero(J[i * D + l])) continue;
                        s = started ? geobarrier::detail::mul_add(J[i * D + l], F[l * D + j], s)
                                    : J[i * D + l] * F[l * D + j];
                        started = true;
                    }
                    dy[D + i * D + j] = s;
                }
            double trace = J[0];
#pragma GCC unroll 16
            for (unsigned i = 1; i < D; ++i) trace += J[i * D + i];
            dy[D + D * D] = trace;
        }
    }

    // y = x + h sum_j row_j k_j, component by component (flow_map.cpp's stage_state and new_state).
    GEOBARRIER_ALWAYS_INLINE static void combine(const geobarrier::detail::RkRow &row, double h, const double *x,
                                                 const double (*k)[C], double *y) {
#pragma GCC unroll 16
        for (unsigned q = 0; q < C; ++q)
            y[q] = geobarrier::detail::row_step(row, h, x[q], [&](int j) { return k[j][q]; });
    }

    template <int I>
    GEOBARRIER_ALWAYS_INLINE static void stage(const T &sys, double t, double h, const double *forcing, const double *x,
                                               double (*k)[C]) {
        if constexpr (I == 0) {
            derivative(sys, t, forcing[0], x, k[0]);
        } else {
            double y[C];
            combine(Tab::a[I], h, x, k, y);
            derivative(sys, t + Tab::c[I] * h, forcing[I], y, k[I]);
        }
    }
    template <int... I>
    GEOBARRIER_ALWAYS_INLINE static void stages(std::integer_sequence<int, I...>, const T &sys, double t, double h,
                                                const double *forcing, const double *x, double (*k)[C]) {
        (stage<I>(sys, t, h, forcing, x, k), ...);
    }

    // Lanes are independent (x_out never aliases x): tell the vectoriser so. (Clang vectorises some of these loops on
    // its own; forcing it with `clang loop vectorize(assume_safety)` only brings warnings.) Every small loop above is
    // unrolled by pragma: with std::fma in the sums GCC's own unrolling heuristics leave some in place, and a lane
    // loop with inner loops does not vectorise.
    // Checked: also the lane's error estimate (gb_advance_request.lane_error, ABI 1.3) over the state components, by
    // the core's own function (rk_tableaux.hpp, lane_error_estimate), so that both paths take the same steps.
    template <bool Checked> static void run(const T &sys, const gb_advance_request &r) {
        const std::size_t n = r.n, ld = r.ld;
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC ivdep
#endif
        for (std::size_t lane = 0; lane < n; ++lane) {
            double x[C], k[S][C], out[C];
#pragma GCC unroll 16
            for (unsigned i = 0; i < D; ++i) x[i] = r.x[i * ld + lane];
            if constexpr (Variational) {
#pragma GCC unroll 16
                for (unsigned m = 0; m < D * D; ++m) x[D + m] = r.df[m * ld + lane];
                x[D + D * D] = r.log_det[lane];
            }
            stages(std::make_integer_sequence<int, S>{}, sys, r.t, r.h, r.forcing, x, k);
            combine(Tab::b, r.h, x, k, out);
#pragma GCC unroll 16
            for (unsigned i = 0; i < D; ++i) r.x_out[i * ld + lane] = out[i];
            if constexpr (Variational) {
#pragma GCC unroll 16
                for (unsigned m = 0; m < D * D; ++m) r.df_out[m * ld + lane] = out[D + m];
                r.log_det_out[lane] = out[D + D * D];
            }
            if constexpr (Checked)
                r.lane_error[lane] =
                    geobarrier::detail::lane_error_estimate<Tab, D>([&](int j, unsigned i) { return k[j][i]; });
        }
    }
};

template <class T, class Tab, bool Checked = false> void fused_step(const T &sys, const gb_advance_request &r) {
    if (r.variational) {
        if constexpr (has_lane_jacobian<T>) FusedStep<T, Tab, true>::template run<Checked>(sys, r);
    } else {
        FusedStep<T, Tab, false>::template run<Checked>(sys, r);
    }
}

} // namespace geobarrier::sdk::detail

#endif // GEOBARRIER_SDK_DETAIL_FUSED_STEP_HPP
