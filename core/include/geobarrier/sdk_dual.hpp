// Forward-mode automatic differentiation for the plugin SDK (<geobarrier/sdk.hpp> includes it): a dual number
// carries a value and its partial derivatives with respect to the N state components of one lane. A system whose
// per-lane `field` is a template over its number type,
//
//   template <class Real> void field(double t, const Real *x, double f, Real *dxdt) const;
//
// is evaluated by the SDK once with Real = double (the vector field) and once with Real = Dual<dimension> seeded
// with the identity (the vector field and its exact Jacobian dv_i/dx_j, no finite differences). The value part of
// every operation below is the double operation itself (mul_add included), so the value of a Dual evaluation is the
// double evaluation bit for bit. Call math functions unqualified (`using std::sin; sin(x)`) or as
// geobarrier::sdk::sin(x): argument-dependent lookup then finds the Dual overloads, which std::sin(x) would not.
#ifndef GEOBARRIER_SDK_DUAL_HPP
#define GEOBARRIER_SDK_DUAL_HPP

#include <geobarrier/rk_tableaux.hpp>

#include <cmath>
#include <type_traits>

namespace geobarrier::sdk {

template <unsigned N> struct Dual {
    double v;    // the value
    double d[N]; // d[j] = d value / d x_j
    constexpr Dual() : v(0.0), d{} {}
    // A constant: its derivatives are 0. Implicit, so that a template field may write Real(1) or assign a double.
    constexpr Dual(double value) : v(value), d{} {}

    Dual &operator+=(const Dual &o) { return *this = *this + o; }
    Dual &operator-=(const Dual &o) { return *this = *this - o; }
    Dual &operator*=(const Dual &o) { return *this = *this * o; }
    Dual &operator/=(const Dual &o) { return *this = *this / o; }
};

namespace detail {
template <class T> struct dual_size : std::integral_constant<unsigned, 0> {};
template <unsigned N> struct dual_size<Dual<N>> : std::integral_constant<unsigned, N> {};
template <class T> constexpr bool is_dual = dual_size<T>::value > 0;
// An operation with at least one Dual operand, the others arithmetic (doubles, integers) or Duals of the same size.
template <class A, class B>
constexpr bool dual_pair = (is_dual<A> || is_dual<B>)&&(is_dual<A> || std::is_arithmetic_v<A>)&&(
    is_dual<B> || std::is_arithmetic_v<B>)&&(!is_dual<A> || !is_dual<B> || dual_size<A>::value == dual_size<B>::value);
template <class A, class B>
constexpr unsigned pair_size = dual_size<A>::value ? dual_size<A>::value : dual_size<B>::value;

template <class T> GEOBARRIER_ALWAYS_INLINE double value_of(const T &x) {
    if constexpr (is_dual<T>)
        return x.v;
    else
        return static_cast<double>(x);
}

// r.d = sa * a.d + sb * b.d, with the terms of a non-Dual operand left out (its derivatives are 0, and 0 * x is not
// foldable in IEEE arithmetic).
template <unsigned N, class A, class B>
GEOBARRIER_ALWAYS_INLINE void combine_derivatives(Dual<N> &r, double sa, const A &a, double sb, const B &b) {
#pragma GCC unroll 16
    for (unsigned j = 0; j < N; ++j) {
        if constexpr (is_dual<A> && is_dual<B>)
            r.d[j] = sa * a.d[j] + sb * b.d[j];
        else if constexpr (is_dual<A>)
            r.d[j] = sa * a.d[j];
        else
            r.d[j] = sb * b.d[j];
    }
}
// The chain rule for a function of one variable: r = g(x), r.d = g'(x) x.d.
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> chain(double value, double slope, const Dual<N> &x) {
    Dual<N> r(value);
#pragma GCC unroll 16
    for (unsigned j = 0; j < N; ++j) r.d[j] = slope * x.d[j];
    return r;
}
} // namespace detail

template <class A, class B, std::enable_if_t<detail::dual_pair<A, B>, int> = 0>
GEOBARRIER_ALWAYS_INLINE Dual<detail::pair_size<A, B>> operator+(const A &a, const B &b) {
    Dual<detail::pair_size<A, B>> r(detail::value_of(a) + detail::value_of(b));
    detail::combine_derivatives(r, 1.0, a, 1.0, b);
    return r;
}
template <class A, class B, std::enable_if_t<detail::dual_pair<A, B>, int> = 0>
GEOBARRIER_ALWAYS_INLINE Dual<detail::pair_size<A, B>> operator-(const A &a, const B &b) {
    Dual<detail::pair_size<A, B>> r(detail::value_of(a) - detail::value_of(b));
    detail::combine_derivatives(r, 1.0, a, -1.0, b);
    return r;
}
template <class A, class B, std::enable_if_t<detail::dual_pair<A, B>, int> = 0>
GEOBARRIER_ALWAYS_INLINE Dual<detail::pair_size<A, B>> operator*(const A &a, const B &b) {
    const double av = detail::value_of(a), bv = detail::value_of(b);
    Dual<detail::pair_size<A, B>> r(av * bv);
    detail::combine_derivatives(r, bv, a, av, b); // (a b)' = b a' + a b'
    return r;
}
template <class A, class B, std::enable_if_t<detail::dual_pair<A, B>, int> = 0>
GEOBARRIER_ALWAYS_INLINE Dual<detail::pair_size<A, B>> operator/(const A &a, const B &b) {
    const double av = detail::value_of(a), bv = detail::value_of(b), q = av / bv;
    Dual<detail::pair_size<A, B>> r(q);
    detail::combine_derivatives(r, 1.0 / bv, a, -q / bv, b); // (a / b)' = a' / b - (a / b) b' / b
    return r;
}
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> operator-(const Dual<N> &x) {
    return detail::chain(-x.v, -1.0, x);
}
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> operator+(const Dual<N> &x) { return x; }

// Comparisons look at values only: a branch of a piecewise field picks the piece, whose derivative is the result's.
#define GEOBARRIER_DUAL_COMPARISON(op)                                                                                 \
    template <class A, class B, std::enable_if_t<detail::dual_pair<A, B>, int> = 0>                                    \
    GEOBARRIER_ALWAYS_INLINE bool operator op(const A &a, const B &b) {                                                \
        return detail::value_of(a) op detail::value_of(b);                                                             \
    }
GEOBARRIER_DUAL_COMPARISON(<)
GEOBARRIER_DUAL_COMPARISON(<=)
GEOBARRIER_DUAL_COMPARISON(>)
GEOBARRIER_DUAL_COMPARISON(>=)
GEOBARRIER_DUAL_COMPARISON(==)
GEOBARRIER_DUAL_COMPARISON(!=)
#undef GEOBARRIER_DUAL_COMPARISON

// a * b + c: the value with the double mul_add's one rounding (one FMA where the CPU has it), so a templated field
// that writes mul_add gives the same values as its double instantiation.
using geobarrier::detail::mul_add;
template <class A, class B, class C,
          std::enable_if_t<(detail::is_dual<A> || detail::is_dual<B> || detail::is_dual<C>), int> = 0>
GEOBARRIER_ALWAYS_INLINE auto mul_add(const A &a, const B &b, const C &c) {
    constexpr unsigned N = detail::dual_size<A>::value   ? detail::dual_size<A>::value
                           : detail::dual_size<B>::value ? detail::dual_size<B>::value
                                                         : detail::dual_size<C>::value;
    const double av = detail::value_of(a), bv = detail::value_of(b);
    Dual<N> r(geobarrier::detail::mul_add(av, bv, detail::value_of(c)));
#pragma GCC unroll 16
    for (unsigned j = 0; j < N; ++j) {
        double s = 0.0;
        bool started = false;
        if constexpr (detail::is_dual<A>) s = bv * a.d[j], started = true;
        if constexpr (detail::is_dual<B>) s = started ? s + av * b.d[j] : av * b.d[j], started = true;
        if constexpr (detail::is_dual<C>) s = started ? s + c.d[j] : c.d[j];
        r.d[j] = s;
    }
    return r;
}

// The elementary functions, for doubles (std::) and for Duals (chain rule).
using std::atan;
using std::cos;
using std::cosh;
using std::exp;
using std::fabs;
using std::log;
using std::pow;
using std::sin;
using std::sinh;
using std::sqrt;
using std::tan;
using std::tanh;
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> sin(const Dual<N> &x) {
    return detail::chain(std::sin(x.v), std::cos(x.v), x);
}
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> cos(const Dual<N> &x) {
    return detail::chain(std::cos(x.v), -std::sin(x.v), x);
}
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> tan(const Dual<N> &x) {
    const double t = std::tan(x.v);
    return detail::chain(t, 1.0 + t * t, x);
}
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> exp(const Dual<N> &x) {
    const double e = std::exp(x.v);
    return detail::chain(e, e, x);
}
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> log(const Dual<N> &x) {
    return detail::chain(std::log(x.v), 1.0 / x.v, x);
}
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> sqrt(const Dual<N> &x) {
    const double s = std::sqrt(x.v);
    return detail::chain(s, 0.5 / s, x);
}
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> sinh(const Dual<N> &x) {
    return detail::chain(std::sinh(x.v), std::cosh(x.v), x);
}
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> cosh(const Dual<N> &x) {
    return detail::chain(std::cosh(x.v), std::sinh(x.v), x);
}
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> tanh(const Dual<N> &x) {
    const double t = std::tanh(x.v);
    return detail::chain(t, 1.0 - t * t, x);
}
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> atan(const Dual<N> &x) {
    return detail::chain(std::atan(x.v), 1.0 / (1.0 + x.v * x.v), x);
}
// |x|: the derivative of the branch taken (sign(x) x'; at x = 0 the right-hand one).
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> fabs(const Dual<N> &x) {
    return detail::chain(std::fabs(x.v), x.v < 0.0 ? -1.0 : 1.0, x);
}
// x^p for a constant exponent p.
template <unsigned N> GEOBARRIER_ALWAYS_INLINE Dual<N> pow(const Dual<N> &x, double p) {
    return detail::chain(std::pow(x.v, p), p * std::pow(x.v, p - 1.0), x);
}

} // namespace geobarrier::sdk

#endif // GEOBARRIER_SDK_DUAL_HPP
