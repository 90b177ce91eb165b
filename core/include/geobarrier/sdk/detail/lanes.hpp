// Part of the plugin SDK's machinery, included by <geobarrier/sdk.hpp> only: not part of the public face (a plugin
// never names geobarrier::sdk::detail). The batched members derived from a system's per-lane `field`: the lane Jacobian
// (given or by dual numbers), the gather-call-scatter loops, and what a system class declares, checked once with
// messages that say what to write.
#ifndef GEOBARRIER_SDK_DETAIL_LANES_HPP
#define GEOBARRIER_SDK_DETAIL_LANES_HPP

#ifndef GEOBARRIER_SDK_HPP
#error "include <geobarrier/sdk.hpp>, not its detail headers"
#endif

#include <geobarrier/sdk/detail/traits.hpp>

namespace geobarrier::sdk::detail {

// The Jacobian of one lane, jac[i * D + j] = dv_i/dx_j: the plugin's field_jacobian, or the field on dual numbers
// seeded with the identity (forward-mode automatic differentiation; exact up to rounding).
template <class T>
GEOBARRIER_ALWAYS_INLINE void lane_jacobian(const T &sys, double t, const double *x, double f, double *jac) {
    if constexpr (has_field_jacobian<T>::value) {
        sys.field_jacobian(t, x, f, jac);
    } else {
        constexpr unsigned D = T::dimension;
        Dual<D> s[D], v[D];
#pragma GCC unroll 16
        for (unsigned i = 0; i < D; ++i) {
            s[i] = Dual<D>(x[i]);
            s[i].d[i] = 1.0;
        }
        sys.field(t, static_cast<const Dual<D> *>(s), f, v);
#pragma GCC unroll 16
        for (unsigned i = 0; i < D; ++i)
#pragma GCC unroll 16
            for (unsigned j = 0; j < D; ++j) jac[i * D + j] = v[i].d[j];
    }
}

// The batched members derived from the per-lane ones: gather a lane, call, scatter. Lanes are independent, so the
// loops vectorise like the fused step's (ivdep: the outputs never alias the inputs).
template <class T> struct LaneLoops {
    static constexpr unsigned D = T::dimension;
    template <class PerLane> static void run(const Batch &b, double *out, unsigned rows, PerLane per_lane) {
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC ivdep
#endif
        for (std::size_t k = 0; k < b.n; ++k) {
            double s[D], r[D * D];
#pragma GCC unroll 16
            for (unsigned i = 0; i < D; ++i) s[i] = b.x[i * b.ld + k];
            per_lane(b.t[k], s, b.f ? b.f[k] : 0.0, r);
#pragma GCC unroll 16
            for (unsigned i = 0; i < rows; ++i) out[i * b.ld + k] = r[i];
        }
    }
    static void rhs(const T &sys, const Batch &b, double *dxdt) {
        run(b, dxdt, D, [&](double t, const double *s, double f, double *r) { sys.field(t, s, f, r); });
    }
    static void jacobian(const T &sys, const Batch &b, double *jac) {
        run(b, jac, D * D, [&](double t, const double *s, double f, double *r) { lane_jacobian(sys, t, s, f, r); });
    }
    // The trace, summed as the fused step sums it.
    static void divergence(const T &sys, const Batch &b, double *div) {
        run(b, div, 1, [&](double t, const double *s, double f, double *r) {
            double J[D * D];
            lane_jacobian(sys, t, s, f, J);
            double trace = J[0];
#pragma GCC unroll 16
            for (unsigned i = 1; i < D; ++i) trace += J[i * D + i];
            r[0] = trace;
        });
    }
};

// What a system class declares, checked once with messages that say what to write.
template <class T> struct SystemShape {
    static constexpr bool field = has_field<T>::value;
    static constexpr bool batch_rhs = has_rhs<T>::value || has_lane_status_rhs<T>::value;
    static_assert(!declares_field<T>::value || field,
                  "geobarrier::sdk: this system's `field` has the wrong signature or is not const. Write "
                  "`template <class Real> void field(double t, const Real *x, double f, Real *dxdt) const` (the SDK "
                  "then derives the Jacobian) or `void field(double t, const double *x, double f, double *dxdt) "
                  "const`");
    static_assert(!declares_field_jacobian<T>::value || has_field_jacobian<T>::value,
                  "geobarrier::sdk: this system's `field_jacobian` has the wrong signature or is not const. Write "
                  "`void field_jacobian(double t, const double *x, double f, double *jac) const` (jac[i * dimension "
                  "+ j] = dv_i/dx_j), or leave it out and make `field` a template so that the SDK derives it");
    static_assert(!declares_rhs<T>::value || batch_rhs,
                  "geobarrier::sdk: this system's `rhs` has the wrong signature or is not const. Write `void "
                  "rhs(const geobarrier::sdk::Batch &b, double *dxdt) const` (optionally with a third parameter "
                  "std::int32_t *lane_status), or leave it out: the SDK derives it from `field`");
    static_assert(!declares_jacobian<T>::value || has_jacobian<T>::value,
                  "geobarrier::sdk: this system's `jacobian` has the wrong signature or is not const. Write `void "
                  "jacobian(const geobarrier::sdk::Batch &b, double *jac) const`, or leave it out: the SDK derives "
                  "it from `field`");
    static_assert(!declares_divergence<T>::value || has_divergence<T>::value,
                  "geobarrier::sdk: this system's `divergence` has the wrong signature or is not const. Write `void "
                  "divergence(const geobarrier::sdk::Batch &b, double *div) const`, or leave it out: the SDK "
                  "derives it from the Jacobian");
    static_assert(field || batch_rhs,
                  "geobarrier::sdk: a system needs its vector field: `template <class Real> void field(double t, "
                  "const Real *x, double f, Real *dxdt) const` (or a batched rhs)");
    static_assert(!has_field_jacobian<T>::value || field,
                  "geobarrier::sdk: `field_jacobian` is given without `field`: give the per-lane field too");
    static constexpr bool jacobian = has_jacobian<T>::value || (field && has_lane_jacobian<T>);
    static constexpr bool divergence = has_divergence<T>::value || (field && has_lane_jacobian<T>);
    static constexpr bool derived_jacobian =
        !has_jacobian<T>::value && !has_field_jacobian<T>::value && field && has_dual_field<T>::value;
};

} // namespace geobarrier::sdk::detail

#endif // GEOBARRIER_SDK_DETAIL_LANES_HPP
