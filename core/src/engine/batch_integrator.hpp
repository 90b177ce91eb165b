// The flow-map engine's templates (private to the core): BatchIntegrator<N>, one thread's integrator of batches of
// trajectories in lockstep for systems of dimension N, and run_batches_of<N>, which runs the batches of a request over
// OpenMP threads. flow_map_dim<N>.cpp instantiates them for one N each; everything here has internal linkage in each
// of those units, so each dimension's engine is inlined and optimised on its own, as one translation unit.
// Long horizons: the variational equations are renormalised (DF rescaled by exact powers of 2) and carry log|det DF|
// by Liouville's formula. Stiff systems: Boost.Odeint's rosenbrock4 with the plugin's Jacobian.
#pragma once

#include "batches.hpp"

#include <geobarrier/cancel.hpp>
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/flow_map.hpp>
#include <geobarrier/rk_tableaux.hpp>

#include <boost/numeric/odeint/stepper/rosenbrock4.hpp>
#include <boost/numeric/odeint/stepper/runge_kutta4.hpp>
#include <boost/numeric/odeint/stepper/runge_kutta_dopri5.hpp>
#include <boost/numeric/odeint/stepper/runge_kutta_fehlberg78.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

namespace geobarrier::flow_map_engine {

namespace {

namespace odeint = boost::numeric::odeint;
using State = std::vector<double>;

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

// A lane whose position grows beyond this factor times max(1, |initial position|) is treated as blown up.
constexpr double blow_up_factor = 1e8;
// Checked fixed steps: a lane that fails the error test even at the smallest sub-step while its position is already
// beyond this factor times max(1, |initial position|) is running away (a finite-time blow-up defeats every stepper
// before the position reaches blow_up_factor), so it is masked as blown up, not as an unstable integrator. Stiff or
// too-coarse steps fail on bounded trajectories, far below this factor.
constexpr double runaway_factor = 1e4;
// A step below this fraction of max(1, |t|) makes no progress: the batch stops with mask_step_limit.
constexpr double min_relative_step = 1e-14;
// Floor of the error scale atol + rtol |x|.
constexpr double min_scale = std::numeric_limits<double>::min();

// Renormalised variational equations: a lane's DF is rescaled by an exact power of 2 (the equations are linear in
// DF, so the trajectory is not perturbed) when its largest entry leaves [1/2, 2^256], and the exponent is carried
// per lane. Above: DF never overflows on long horizons. Below: the error scale atol + rtol |DF| stays relative to
// DF's size, so a decaying DF (damped systems in forward time) keeps rtol relative accuracy instead of drowning in
// atol. The check runs every few accepted steps: to overflow in between, DF would have to grow by 2^768 in that many
// steps, which no step that passed the error control can do.
constexpr int renormalise_exponent = 256;
constexpr double renormalise_low = 0.5;
constexpr unsigned renormalise_every = 4;

// State layout of a lane of a system of dimension N: the N state components, then with the variational equations
// DF row-major (N^2 components from comp_f11; F11 F12 F21 F22 in the plane) and l = log|det DF|, whose derivative
// is tr Dv (Liouville). The engine is a template on N (compile-time loops, so the planar kernel is what it was),
// instantiated for 2 .. max_dimension.
template <unsigned N> struct LaneLayout {
    static constexpr std::size_t position_components = N, variational_components = N + N * N + 1;
    static constexpr std::size_t comp_f11 = N, comp_log_det = N + N * N;
};

// ---- reductions over a batch's lanes, once per step
// Written for GCC 12 at the vector width it prefers (256 bits even where AVX-512 exists): an OpenMP sum or an
// integer OR vectorises; `#pragma omp simd reduction(max : ...)` compiled to masked gathers from a stack copy of the
// accumulators (perf on W: 40% of the checked steps' bookkeeping), and Eigen's reductions use 512-bit vectors under
// -march=native, whose frequency licence slowed the plugin's fused step that runs beside them by 20-40% (perf,
// cpu-clock samples of W against a build without them).

// Whether any of v[0 .. size) is NaN or Inf, from the bits: the exponent field is all ones exactly then, and adding
// one unit of the exponent's lowest bit to it carries into the top bit exactly then. Integer and, add and or have a
// one-cycle latency, so the pass is throughput-bound (a floating-point probe sum, v * 0 summed, waited on its chain
// of 4-cycle additions: 8% of W's run).
bool any_non_finite(const double *v, std::size_t size) {
    constexpr std::uint64_t exponent_field = 0x7ff0000000000000u, exponent_unit = 0x0010000000000000u;
    std::uint64_t carries = 0;
#pragma omp simd reduction(| : carries)
    for (std::size_t i = 0; i < size; ++i) {
        std::uint64_t bits;
        std::memcpy(&bits, v + i, sizeof bits);
        carries |= (bits & exponent_field) + exponent_unit;
    }
    return (carries >> 63) != 0;
}

// Everything one batched right-hand-side call needs. The functor handed to Odeint holds only a pointer to it,
// because Odeint copies the system object into every do_step.
template <unsigned N> struct BatchContext {
    static constexpr std::size_t position_components = LaneLayout<N>::position_components;
    static constexpr std::size_t comp_f11 = LaneLayout<N>::comp_f11, comp_log_det = LaneLayout<N>::comp_log_det;
    const System *system = nullptr;
    const Forcing *forcing = nullptr; // null when the system does not read the forcing
    bool variational = false;
    std::size_t n = 0;          // lanes (= ld)
    std::size_t components = N; // position_components, or variational_components with DF and log|det DF|
    std::vector<double> times, forcing_values, jac;
    std::vector<std::int32_t> lane_status;
    std::vector<std::uint8_t> mask;    // per lane, 0 = active
    std::vector<std::size_t> frozen;   // lanes with mask != 0: their derivatives are zeroed
    std::vector<std::uint8_t> invalid; // lanes the plugin declared invalid since the last clear_invalid()
    bool any_invalid = false;
    double filled_time = nan_value;
    std::uint64_t rhs_calls = 0;

    void reset(std::size_t lanes, std::size_t comps) {
        n = lanes;
        components = comps;
        times.assign(n, 0.0);
        forcing_values.assign(n, 0.0);
        jac.assign(variational ? N * N * n : 0, 0.0);
        lane_status.assign(n, GB_OK);
        mask.assign(n, 0);
        frozen.clear();
        invalid.assign(n, 0);
        any_invalid = false;
        filled_time = nan_value;
        rhs_calls = 0;
    }

    void clear_invalid() {
        if (!any_invalid) return;
        std::fill(invalid.begin(), invalid.end(), std::uint8_t{0});
        any_invalid = false;
    }

    void note_lane_status() {
        // Fast path: one branch-free pass; invalid lanes are rare.
        std::int32_t any = 0;
        for (std::size_t k = 0; k < n; ++k) any |= lane_status[k] == GB_LANE_INVALID;
        if (!any) return;
        for (std::size_t k = 0; k < n; ++k) {
            if (lane_status[k] == GB_LANE_INVALID && mask[k] == 0) {
                invalid[k] = 1;
                any_invalid = true;
            }
        }
    }

    // Lockstep: every lane is at the same time, so the forcing is evaluated once per stage time.
    void fill_time(double t) {
        if (t == filled_time) return;
        std::fill(times.begin(), times.end(), t);
        double f = 0.0;
        if (forcing) forcing->evaluate(1, &t, &f);
        std::fill(forcing_values.begin(), forcing_values.end(), f);
        filled_time = t;
    }

    void evaluate(const double *xp, double *dp, double t) {
        fill_time(t);
        std::fill(lane_status.begin(), lane_status.end(), GB_OK);
        system->rhs(n, n, times.data(), xp, forcing_values.data(), dp, lane_status.data());
        note_lane_status();
        if (variational) {
            std::fill(lane_status.begin(), lane_status.end(), GB_OK);
            system->jacobian(n, n, times.data(), xp, forcing_values.data(), jac.data(), lane_status.data());
            note_lane_status();
            // DF' = J DF (variational equations), DF row-major in blocks comp_f11..; (log|det DF|)' = tr J
            // (Liouville). One base pointer per buffer (restrict): with a pointer per block the compiler must prove
            // the ranges disjoint at run time and fell back to scalar code. The loops over i, j, l have compile-time
            // bounds and unroll, so the lane loop vectorises.
            const double *__restrict J = jac.data();
            const double *__restrict F = xp + comp_f11 * n;
            double *__restrict D = dp + comp_f11 * n;
            if constexpr (N == 2) {
                // The plane written out: the generic loops below cost 2% more instructions here (callgrind, GCC 12).
#pragma omp simd
                for (std::size_t k = 0; k < n; ++k) {
                    const double j11 = J[k], j12 = J[n + k], j21 = J[2 * n + k], j22 = J[3 * n + k];
                    const double f11 = F[k], f12 = F[n + k], f21 = F[2 * n + k], f22 = F[3 * n + k];
                    // The SDK's fused step sums in this order too (sdk.hpp, FusedStep::derivative).
                    D[k] = detail::mul_add(j12, f21, j11 * f11);
                    D[n + k] = detail::mul_add(j12, f22, j11 * f12);
                    D[2 * n + k] = detail::mul_add(j22, f21, j21 * f11);
                    D[3 * n + k] = detail::mul_add(j22, f22, j21 * f12);
                    D[4 * n + k] = j11 + j22; // comp_log_det
                }
            } else {
#pragma omp simd
                for (std::size_t k = 0; k < n; ++k) {
#pragma GCC unroll 8
                    for (unsigned i = 0; i < N; ++i)
#pragma GCC unroll 8
                        for (unsigned j = 0; j < N; ++j) {
                            // The SDK's fused step sums in this order too (sdk.hpp, FusedStep::derivative).
                            double sum = J[(i * N) * n + k] * F[j * n + k];
#pragma GCC unroll 8
                            for (unsigned l = 1; l < N; ++l)
                                sum = detail::mul_add(J[(i * N + l) * n + k], F[(l * N + j) * n + k], sum);
                            D[(i * N + j) * n + k] = sum;
                        }
                    double trace = J[k];
#pragma GCC unroll 8
                    for (unsigned i = 1; i < N; ++i) trace += J[(i * N + i) * n + k];
                    D[N * N * n + k] = trace; // comp_log_det
                }
            }
        }
        // Masked lanes are frozen: with zero derivatives in every stage their state and error stay exactly put.
        for (std::size_t k : frozen)
            for (std::size_t c = 0; c < components; ++c) dp[c * n + k] = 0.0;
        ++rhs_calls;
    }

    // ---- stiff systems: what rosenbrock4 needs besides the right-hand side

    // The Jacobian d(rhs)/d(state) of the whole batch state (dense, N = components * n; lanes are independent, so it
    // is block diagonal) and the time derivative d(rhs)/dt. The plugin gives Dv; the variational rows d(Dv DF)/dx and
    // d(tr Dv)/dx need second derivatives, taken as forward differences of Dv, and d/dt is a forward difference in t
    // (the plugins give neither). Their O(sqrt(eps)) error only makes the Rosenbrock matrix slightly inexact; the
    // embedded error estimate still controls the step.
    template <class Matrix> void stiff_jacobian(const double *xp, double t, Matrix &J, double *dfdt) {
        const std::size_t size = components * n;
        J.clear(); // zero; odeint has sized it size x size
        std::fill(dfdt, dfdt + size, 0.0);
        constexpr double root_eps = 1.4901161193847656e-08; // sqrt(DBL_EPSILON)
        constexpr std::size_t NN = std::size_t{N} * N;
        // Dv at (x, t), at (x + e_m eps_m, t) for m < N, and at (x, t + tau); v at (x, t) and (x, t + tau).
        m_jacs.assign((N + 2) * NN * n, 0.0);
        m_v.assign(2 * N * n, 0.0);
        m_xp.assign(N * n, 0.0);
        m_eps.assign(N * n, 0.0);
        std::copy(xp, xp + N * n, m_xp.begin());
        for (std::size_t k = 0; k < N * n; ++k) m_eps[k] = root_eps * std::max(1.0, std::abs(xp[k]));
        const double tau = root_eps * std::max(1.0, std::abs(t));
        auto jacobian_at = [&](const double *x, double time, double *out) {
            fill_time(time);
            std::fill(lane_status.begin(), lane_status.end(), GB_OK);
            system->jacobian(n, n, times.data(), x, forcing_values.data(), out, lane_status.data());
            note_lane_status();
        };
        auto rhs_at = [&](const double *x, double time, double *out) {
            fill_time(time);
            std::fill(lane_status.begin(), lane_status.end(), GB_OK);
            system->rhs(n, n, times.data(), x, forcing_values.data(), out, lane_status.data());
            note_lane_status();
            ++rhs_calls;
        };
        // Blocks of m_jacs: 0 at (x, t), 1 at (x, t + tau), 2 + m at (x + e_m eps_m, t).
        double *jac0 = m_jacs.data(), *jac_t = jac0 + NN * n;
        const auto jac_m = [&](std::size_t m) { return m_jacs.data() + (2 + m) * NN * n; };
        jacobian_at(xp, t, jac0);
        jacobian_at(xp, t + tau, jac_t);
        rhs_at(xp, t, m_v.data());
        rhs_at(xp, t + tau, m_v.data() + N * n);
        if (variational) {
            for (std::size_t m = 0; m < N; ++m) {
                for (std::size_t k = 0; k < n; ++k) m_xp[m * n + k] = xp[m * n + k] + m_eps[m * n + k];
                jacobian_at(m_xp.data(), t, jac_m(m));
                for (std::size_t k = 0; k < n; ++k) m_xp[m * n + k] = xp[m * n + k];
            }
        }
        for (std::size_t k = 0; k < n; ++k) {
            if (mask[k] != 0) continue; // frozen: zero rows, so the lane stays put
            auto at = [&](const double *block, std::size_t i, std::size_t j) { return block[(N * i + j) * n + k]; };
            auto row = [&](std::size_t c) { return c * n + k; };
            for (std::size_t i = 0; i < N; ++i) {
                for (std::size_t j = 0; j < N; ++j) J(row(i), row(j)) = at(jac0, i, j);
                dfdt[row(i)] = (m_v[(N + i) * n + k] - m_v[i * n + k]) / tau;
            }
            if (!variational) continue;
            // DF' = Dv DF: row (i, j) is sum_l Dv_il F_lj. With F_lj at component comp_f11 + N l + j:
            const double *f = xp + comp_f11 * n;
            auto F = [&](std::size_t l, std::size_t j) { return f[(N * l + j) * n + k]; };
            for (std::size_t i = 0; i < N; ++i) {
                for (std::size_t j = 0; j < N; ++j) {
                    const std::size_t r = row(comp_f11 + N * i + j);
                    for (std::size_t l = 0; l < N; ++l) J(r, row(comp_f11 + N * l + j)) = at(jac0, i, l);
                    for (std::size_t m = 0; m < N; ++m) {
                        const double *jm = jac_m(m);
                        double sum = 0.0;
                        for (std::size_t l = 0; l < N; ++l) sum += (at(jm, i, l) - at(jac0, i, l)) * F(l, j);
                        J(r, row(m)) = sum / m_eps[m * n + k];
                    }
                    double dt_sum = 0.0;
                    for (std::size_t l = 0; l < N; ++l) dt_sum += (at(jac_t, i, l) - at(jac0, i, l)) * F(l, j);
                    dfdt[r] = dt_sum / tau;
                }
            }
            const auto trace_change = [&](const double *block) {
                double sum = 0.0;
                for (std::size_t i = 0; i < N; ++i) sum += at(block, i, i) - at(jac0, i, i);
                return sum;
            };
            const std::size_t r = row(comp_log_det);
            for (std::size_t m = 0; m < N; ++m) J(r, row(m)) = trace_change(jac_m(m)) / m_eps[m * n + k];
            dfdt[r] = trace_change(jac_t) / tau;
        }
    }

  private:
    std::vector<double> m_jacs, m_v, m_xp, m_eps; // stiff_jacobian's scratch
};

template <unsigned N> struct Rhs {
    BatchContext<N> *ctx;
    void operator()(const State &x, State &dxdt, double t) const { ctx->evaluate(x.data(), dxdt.data(), t); }
};

using Dopri5 = odeint::runge_kutta_dopri5<State>;
using Rkf78 = odeint::runge_kutta_fehlberg78<State>;
using Rk4 = odeint::runge_kutta4<State>;

// The coefficients of Boost.Odeint's rosenbrock4 (Hairer & Wanner's ROS4 set, as in Numerical Recipes' StepperRoss),
// except d4: Boost 1.74 ships d4 = +0.0362 where the published tableau has -0.0362. d4 weighs the time derivative
// df/dt in the last stage, so the wrong sign leaves every non-autonomous system (any forcing) first-order accurate:
// on x' = cos t - x/2 the error at t = 1 halves with h (1.2e-3, 6.4e-4, 3.3e-4 for h = 0.1, 0.05, 0.025) instead of
// falling 16-fold (9.1e-9, 5.6e-10, 3.5e-11 with the sign fixed). Autonomous systems never see d4.
struct RosenbrockCoefficients {
    using value_type = double;
    using order_type = unsigned short;
    const double gamma = 0.25;
    const double d1 = 0.25, d2 = -0.1043, d3 = 0.1035, d4 = -0.3620000000000023e-01; // d4: see above
    const double c2 = 0.386, c3 = 0.21, c4 = 0.63;
    const double c21 = -0.5668800000000000e+01;
    const double a21 = 0.1544000000000000e+01;
    const double c31 = -0.2430093356833875e+01, c32 = -0.2063599157091915e+00;
    const double a31 = 0.9466785280815826e+00, a32 = 0.2557011698983284e+00;
    const double c41 = -0.1073529058151375e+00, c42 = -0.9594562251023355e+01, c43 = -0.2047028614809616e+02;
    const double a41 = 0.3314825187068521e+01, a42 = 0.2896124015972201e+01, a43 = 0.9986419139977817e+00;
    const double c51 = 0.7496443313967647e+01, c52 = -0.1024680431464352e+02, c53 = -0.3399990352819905e+02,
                 c54 = 0.1170890893206160e+02;
    const double a51 = 0.1221224509226641e+01, a52 = 0.6019134481288629e+01, a53 = 0.1253708332932087e+02,
                 a54 = -0.6878860361058950e+00;
    const double c61 = 0.8083246795921522e+01, c62 = -0.7981132988064893e+01, c63 = -0.3152159432874371e+02,
                 c64 = 0.1631930543123136e+02, c65 = -0.6058818238834054e+01;
    const double d21 = 0.1012623508344586e+02, d22 = -0.7487995877610167e+01, d23 = -0.3480091861555747e+02,
                 d24 = -0.7992771707568823e+01, d25 = 0.1025137723295662e+01;
    const double d31 = -0.6762803392801253e+00, d32 = 0.6087714651680015e+01, d33 = 0.1643084320892478e+02,
                 d34 = 0.2476722511418386e+02, d35 = -0.6594389125716872e+01;
    static const order_type stepper_order = 4;
    static const order_type error_order = 3;
};

// rosenbrock4 (Kaps-Rentrop, order 4, embedded order-3 error estimate) behind the same do_step call as the explicit
// steppers, so run_adaptive drives it with the same error norm, masking and step control. Odeint's stepper works on
// ublas vectors with a (right-hand side, Jacobian) pair; the copies in and out are a few dozen doubles.
class RosenbrockStepper {
  public:
    template <unsigned N>
    void do_step(Rhs<N> sys, const State &x, const State & /*dxdt*/, double t, State &x_out, double dt, State &xerr) {
        const std::size_t size = x.size();
        if (m_x.size() != size) {
            m_x.resize(size, false);
            m_out.resize(size, false);
            m_err.resize(size, false);
        }
        std::copy(x.begin(), x.end(), m_x.begin());
        BatchContext<N> *ctx = sys.ctx;
        auto rhs = [ctx](const Vector &u, Vector &dudt, double time) { ctx->evaluate(&u[0], &dudt[0], time); };
        auto jacobian = [ctx](const Vector &u, Matrix &J, double time, Vector &dfdt) {
            ctx->stiff_jacobian(&u[0], time, J, &dfdt[0]);
        };
        m_stepper.do_step(std::make_pair(rhs, jacobian), m_x, t, m_out, dt, m_err);
        std::copy(m_out.begin(), m_out.end(), x_out.begin());
        std::copy(m_err.begin(), m_err.end(), xerr.begin());
    }

  private:
    using Stepper = odeint::rosenbrock4<double, RosenbrockCoefficients>;
    using Vector = Stepper::state_type;
    using Matrix = Stepper::matrix_type;
    Stepper m_stepper;
    Vector m_x, m_out, m_err;
};

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

// One thread's integrator for systems of dimension N: integrates one batch at a time, reusing its buffers.
template <unsigned N> class BatchIntegrator {
    static constexpr std::size_t position_components = LaneLayout<N>::position_components,
                                 variational_components = LaneLayout<N>::variational_components;
    static constexpr std::size_t comp_f11 = LaneLayout<N>::comp_f11, comp_log_det = LaneLayout<N>::comp_log_det;

    // (0, 1, .., N - 1) as a tuple of std::size_t, for fold expressions over the state components.
    template <std::size_t... I> static constexpr auto component_indices(std::index_sequence<I...>) {
        return std::make_tuple(I...);
    }
    static constexpr auto component_indices() { return component_indices(std::make_index_sequence<N>{}); }

  public:
    BatchIntegrator(const Dynamics &dynamics, double t0, double t1, const IntegratorSettings &settings, Method method,
                    bool variational, const std::optional<Bounds> &bounds, const DifferenceControl &differences,
                    const std::array<unsigned, 2> &bound_axes)
        : m_t0(t0), m_t1(t1), m_settings(settings), m_rtol(std::max(settings.rtol, min_rtol)), m_method(method),
          m_lockstep(settings.engine != "odeint"), m_bounds(bounds), m_bound_axes(bound_axes),
          m_differences(differences) {
        m_ctx.system = dynamics.system;
        m_ctx.forcing = dynamics.system->uses_forcing() ? dynamics.forcing : nullptr;
        m_ctx.variational = variational;
    }

    // Integrates lanes starting at start[i * n + k] (component i < N of lane k < n). Afterwards state() holds the
    // final states (ld = n) and mask() the lanes' MaskBits; masked lanes' states are meaningless.
    void run(std::size_t n, const double *start, IntegratorStats &stats) {
        const std::size_t comps = m_ctx.variational ? variational_components : position_components;
        m_ctx.reset(n, comps);
        m_active = n;
        m_x.assign(comps * n, 0.0);
        m_exponent.assign(n, 0);
        m_renormalised.assign(n, 0);
        m_since_renormalise = 0;
        m_limit.resize(n);
        m_exit_time.assign(n, std::numeric_limits<double>::quiet_NaN());
        std::copy(start, start + N * n, m_x.begin());
        for (std::size_t k = 0; k < n; ++k) {
            double big = 1.0;
            bool finite = true;
            for (std::size_t i = 0; i < N; ++i) {
                big = std::max(big, std::abs(start[i * n + k]));
                finite = finite && std::isfinite(start[i * n + k]);
            }
            m_limit[k] = blow_up_factor * big;
            if (!finite) {
                freeze(k, mask_non_finite);
                for (std::size_t i = 0; i < N; ++i) m_x[i * n + k] = 0.0; // keep what the plugin sees finite
            }
        }
        if (m_ctx.variational) // DF = I (diagonal blocks comp_f11 + (N + 1) i); log|det DF| starts at 0
            for (std::size_t i = 0; i < N; ++i) std::fill_n(m_x.begin() + (comp_f11 + (N + 1) * i) * n, n, 1.0);
        check_bounds(nullptr, m_t0);
        m_steps = m_rejected = 0;
        m_planned = 0;
        if (m_t0 != m_t1 && m_active > 0 && m_lockstep && m_method != Method::rosenbrock4) {
            // rk4 has no error estimate: always fixed steps, never checked.
            const bool adaptive = m_settings.adaptive && m_method != Method::rk4;
            const bool checked = !adaptive && m_settings.step_tolerance > 0.0 && m_method != Method::rk4;
            if (!adaptive) m_planned = static_cast<std::uint64_t>(fixed_step_count());
            // The plugin's fused step took every step (checked: dop853 only, the method the SDK fuses).
            const bool fused = !adaptive && (checked ? try_fused_checked() : try_fused());
            stats.fused_batches += fused ? 1 : 0;
            if (!fused)
                with_explicit_tableau(m_method, [&](auto tableau) {
                    using Tab = decltype(tableau);
                    if constexpr (Tab::error != detail::RkError::none) {
                        if (checked) {
                            run_checked<Tab>(false);
                            return;
                        }
                    }
                    run_lockstep<Tab>(adaptive);
                });
        } else if (m_t0 != m_t1 && m_active > 0) {
            switch (m_method) {
            case Method::dop853:
                break; // refused by validate()
            case Method::dopri5:
                run_adaptive<Dopri5, true, true>(4);
                break;
            case Method::rkf78:
                run_adaptive<Rkf78, false, true>(7);
                break;
            case Method::rk4:
                run_fixed();
                break;
            case Method::rosenbrock4:
                run_adaptive<RosenbrockStepper, false, false>(3);
                break;
            }
        }
        stats.exited += release_exits();
        if (m_ctx.variational) settle_exponents();
        stats.trajectories += n;
        stats.batches += 1;
        stats.steps += m_steps;
        stats.rejected_steps += m_rejected;
        stats.planned_steps += m_planned;
        stats.rhs_evaluations += static_cast<std::uint64_t>(n) * m_ctx.rhs_calls;
        for (std::size_t k = 0; k < n; ++k) {
            const std::uint8_t m = m_ctx.mask[k];
            if (m == 0) continue;
            ++stats.masked;
            if (m & mask_left_bounds) ++stats.masked_left_bounds;
            if (m & mask_non_finite) ++stats.masked_non_finite;
            if (m & mask_step_limit) ++stats.masked_step_limit;
            if (m & mask_invalid_state) ++stats.masked_invalid_state;
            if (m & mask_unstable) ++stats.masked_unstable;
        }
        for (std::size_t k = 0; k < n; ++k) stats.renormalised += m_renormalised[k];
    }

    const State &state() const { return m_x; }
    const std::vector<std::uint8_t> &mask() const { return m_ctx.mask; }
    // Variational: DF of lane k is 2^exponent()[k] times the state's DF block (0 wherever DF fits in a double).
    const std::vector<std::int32_t> &exponent() const { return m_exponent; }
    // With bounds: when each lane left them (NaN: it never did).
    const std::vector<double> &exit_time() const { return m_exit_time; }

  private:
    // ExitRule::stop: lanes frozen for leaving the bounds (and for nothing else) are results, not masked: their
    // state and DF are the flow map stopped at the exit (Bounds, ExitRule). Returns how many.
    std::uint64_t release_exits() {
        if (!m_bounds || m_bounds->exits != ExitRule::stop) return 0;
        std::uint64_t released = 0;
        for (std::size_t k = 0; k < m_ctx.n; ++k)
            if (m_ctx.mask[k] == mask_left_bounds) {
                m_ctx.mask[k] = 0;
                ++released;
            }
        return released;
    }

    void freeze(std::size_t k, std::uint8_t reason) {
        if (m_ctx.mask[k] != 0) return;
        m_ctx.mask[k] = reason;
        m_ctx.frozen.push_back(k);
        --m_active;
    }
    void zero_lane(State &v, std::size_t k) const {
        for (std::size_t c = 0; c < m_ctx.components; ++c) v[c * m_ctx.n + k] = 0.0;
    }
    void copy_lane(State &dst, const State &src, std::size_t k) const {
        for (std::size_t c = 0; c < m_ctx.components; ++c) dst[c * m_ctx.n + k] = src[c * m_ctx.n + k];
    }
    void freeze_all_active(std::uint8_t reason) {
        for (std::size_t k = 0; k < m_ctx.n; ++k)
            if (m_ctx.mask[k] == 0) freeze(k, reason);
    }

    // ---- long horizons: renormalised variational equations

    // After an accepted step: a lane whose largest |DF| entry left [1/2, 2^256] has its DF block (and, since
    // DF' = Dv DF is linear in DF, the DF block of its derivative) multiplied by an exact power of 2, and the
    // exponent is carried. Nothing is rounded, so the integration is exactly the unscaled one, minus the overflow.
    // One vectorisable pass finds whether any lane needs it; lanes are visited only then. The same pass freezes lanes
    // whose DF became NaN or Inf under a finite state (the checked steps screen only the state: such a DF is no
    // failure of the step); `now` runs it whatever the count, for the last step of a run.
    void renormalise(State *dxdt, bool now = false) {
        if (++m_since_renormalise < renormalise_every && !now) return;
        m_since_renormalise = 0;
        const std::size_t n = m_ctx.n;
        const double *f = m_x.data() + comp_f11 * n;
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
            if (m_ctx.mask[k] != 0 || (big <= high && !(big < low && big > 0.0))) continue;
            if (!(big <= std::numeric_limits<double>::max())) {
                freeze(k, mask_non_finite);
                if (dxdt) zero_lane(*dxdt, k);
                continue;
            }
            const int e = std::ilogb(big);
            for (std::size_t c = comp_f11; c < comp_f11 + N * N; ++c) {
                m_x[c * n + k] = std::ldexp(m_x[c * n + k], -e);
                if (dxdt) (*dxdt)[c * n + k] = std::ldexp((*dxdt)[c * n + k], -e);
            }
            m_exponent[k] += e;
            m_renormalised[k] = 1;
        }
    }

    // At the end: DF is handed back unscaled wherever it fits in a double (exponent 0), so callers that never meet
    // long horizons see plain DF; elsewhere it stays scaled with its exponent.
    void settle_exponents() {
        const std::size_t n = m_ctx.n;
        for (std::size_t k = 0; k < n; ++k) {
            const int e = m_exponent[k];
            if (e == 0 || m_ctx.mask[k] != 0) continue;
            double big = 0.0;
            for (std::size_t c = comp_f11; c < comp_f11 + N * N; ++c) big = std::max(big, std::abs(m_x[c * n + k]));
            if (!(big > 0.0)) continue;
            const int top = std::ilogb(big) + e;
            if (top >= std::numeric_limits<double>::max_exponent - 1 ||
                top <= std::numeric_limits<double>::min_exponent)
                continue; // does not fit: keep it scaled
            for (std::size_t c = comp_f11; c < comp_f11 + N * N; ++c) m_x[c * n + k] = std::ldexp(m_x[c * n + k], e);
            m_exponent[k] = 0;
        }
    }

    // Lanes the plugin flagged invalid during the last evaluations are frozen; their derivative is zeroed.
    void freeze_invalid(State *dxdt) {
        if (!m_ctx.any_invalid) return;
        for (std::size_t k = 0; k < m_ctx.n; ++k) {
            if (!m_ctx.invalid[k]) continue;
            freeze(k, mask_invalid_state);
            if (dxdt) zero_lane(*dxdt, k);
        }
        m_ctx.clear_invalid();
    }

    // After a trial step from m_x to m_x_new: lanes the plugin rejected, or whose new state or error estimate is not
    // finite, are frozen at their pre-step state and dropped from the error norm. The other lanes are unaffected
    // (lanes are independent), so this equals restoring the batch and retrying the step without the bad lanes.
    // `suspect` says a cheap whole-batch probe found a NaN or Inf; only then are lanes scanned one by one.
    void screen_trial(bool suspect, State *dxdt_new, State *xerr) {
        if (!suspect && !m_ctx.any_invalid) return;
        const std::size_t n = m_ctx.n, comps = m_ctx.components;
        m_bad.assign(n, 0);
        for (std::size_t c = 0; c < comps; ++c) {
            const double *xn = m_x_new.data() + c * n;
            const double *xe = xerr ? xerr->data() + c * n : nullptr;
            for (std::size_t k = 0; k < n; ++k)
                if (!std::isfinite(xn[k]) || (xe && !std::isfinite(xe[k]))) m_bad[k] = 1;
        }
        for (std::size_t k = 0; k < n; ++k) {
            if (m_ctx.mask[k] != 0) continue;
            if (m_ctx.invalid[k])
                freeze(k, mask_invalid_state);
            else if (m_bad[k])
                freeze(k, mask_non_finite);
            else
                continue;
            copy_lane(m_x_new, m_x, k);
            zero_lane(m_dxdt, k);
            if (dxdt_new) zero_lane(*dxdt_new, k);
            if (xerr) zero_lane(*xerr, k);
        }
        m_ctx.clear_invalid();
    }

    // True when some entry of v is NaN or Inf (|v| <= DBL_MAX fails for both). One vectorisable pass, no branches;
    // an OR of comparisons, not a floating-point sum, so that the reduction is no chain of dependent additions.
    static bool has_non_finite(const State &v) { return any_non_finite(v.data(), v.size()); }

    // After an accepted step: blown-up lanes and lanes outside the bounds box are frozen.
    // One branch-free, vectorisable pass finds whether any lane needs it; lanes are visited only then (frozen lanes
    // keep a state from before they left, so they rarely send us down the slow path, which skips them).
    void check_after_step(State *dxdt, double t) {
        const std::size_t n = m_ctx.n;
        const double *x = m_x.data(), *limit = m_limit.data();
        const double *bx = x + m_bound_axes[0] * n, *by = x + m_bound_axes[1] * n;
        const auto blown_up = [&](std::size_t k) {
            int out = 0;
#pragma GCC unroll 8
            for (std::size_t i = 0; i < N; ++i) out |= std::abs(x[i * n + k]) > limit[k];
            return out;
        };
        int any = 0;
        if (m_bounds) {
            const Bounds &b = *m_bounds;
            for (std::size_t k = 0; k < n; ++k)
                any |=
                    blown_up(k) | !((bx[k] >= b.x_min) & (bx[k] <= b.x_max) & (by[k] >= b.y_min) & (by[k] <= b.y_max));
        } else {
            for (std::size_t k = 0; k < n; ++k) any |= blown_up(k);
        }
        if (!any) return;
        for (std::size_t k = 0; k < n; ++k) {
            if (m_ctx.mask[k] != 0) continue;
            if (blown_up(k)) {
                freeze(k, mask_non_finite);
                if (dxdt) zero_lane(*dxdt, k);
            }
        }
        check_bounds(dxdt, t);
    }
    // Lanes outside the bounds at time t are frozen there (mask_left_bounds), and t is their exit time.
    void check_bounds(State *dxdt, double t) {
        if (!m_bounds) return;
        const std::size_t n = m_ctx.n;
        const double *x = m_x.data() + m_bound_axes[0] * n, *y = m_x.data() + m_bound_axes[1] * n;
        const Bounds &b = *m_bounds;
        for (std::size_t k = 0; k < n; ++k) {
            if (m_ctx.mask[k] != 0) continue;
            if (!(x[k] >= b.x_min && x[k] <= b.x_max && y[k] >= b.y_min && y[k] <= b.y_max)) {
                freeze(k, mask_left_bounds);
                m_exit_time[k] = t;
                if (dxdt) zero_lane(*dxdt, k);
            }
        }
    }

    // err = max over lanes and components of |xerr| / (atol + rtol max(|x_old|, |x_new|)). Frozen lanes have an
    // error of exactly zero (all their stage derivatives are zero), so no lane test is needed. Sets `suspect` when
    // the new state or the error holds a NaN or Inf (then err is meaningless and the caller screens the lanes).
    double error_norm(const State &xerr, bool &suspect) const {
        const double atol = m_settings.atol, rtol = m_rtol;
        const double *xo = m_x.data(), *xn = m_x_new.data(), *xe = xerr.data();
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
        if (m_differences.per_point > 0) err = std::max(err, difference_error_norm(xerr));
        return err;
    }

    // The same norm over the auxiliary groups' centred differences D = (F(+) - F(-)) / 2d (see DifferenceControl).
    // Frozen lanes have zero error; their group is masked at the end anyway.
    double difference_error_norm(const State &xerr) const {
        const double atol = m_settings.atol, rtol = m_rtol;
        const std::size_t n = m_ctx.n, per_point = m_differences.per_point;
        const double inv[2] = {m_differences.inv_2dx, m_differences.inv_2dy};
        double err = 0.0;
        for (std::size_t c = 0; c < 2; ++c) {
            const double *xo = m_x.data() + c * n, *xn = m_x_new.data() + c * n, *xe = xerr.data() + c * n;
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

    bool no_progress(double dt, double t) const {
        return !(std::abs(dt) >= min_relative_step * std::max(1.0, std::abs(t)));
    }

    // Adaptive stepping with an embedded error pair of error order `order`. Fsal: dopri5's first-same-as-last
    // derivative is reused; otherwise, when the stepper uses it (UsesDerivative: not rosenbrock4, which evaluates
    // its own), the derivative at the new state is computed once per accepted step and reused by rejected retries.
    template <class Stepper, bool Fsal, bool UsesDerivative> void run_adaptive(int order) {
        const std::size_t size = m_x.size();
        m_x_new.assign(size, 0.0);
        m_dxdt.assign(size, 0.0);
        m_dxdt_new.assign(size, 0.0);
        m_xerr.assign(size, 0.0);
        Stepper stepper; // fresh per batch: Odeint sizes its temporaries once, on first use
        Rhs<N> sys{&m_ctx};
        const double span = m_t1 - m_t0;
        double t = m_t0;
        double dt = std::copysign(std::min(m_settings.step, std::abs(span)), span);
        const double exponent = -1.0 / (order + 1);
        std::size_t attempts = 0;

        if constexpr (UsesDerivative) {
            sys(m_x, m_dxdt, t);
            freeze_invalid(&m_dxdt);
        }
        while (m_active > 0 && t != m_t1) {
            if (const int signal = cancel_requested()) throw Cancelled(signal, "while integrating trajectories");
            const bool last = std::abs(dt) >= std::abs(m_t1 - t);
            // A final step shorter than the progress floor is taken as it is: tiny horizons (|T| ~ 1e-300) must
            // give DF = I, not a step-limit mask.
            if (attempts >= m_settings.max_steps || (!last && no_progress(dt, t))) {
                freeze_all_active(mask_step_limit);
                break;
            }
            const double h = last ? m_t1 - t : dt;
            m_ctx.clear_invalid();
            if constexpr (Fsal)
                stepper.do_step(sys, m_x, m_dxdt, t, m_x_new, m_dxdt_new, h, m_xerr);
            else
                stepper.do_step(sys, m_x, m_dxdt, t, m_x_new, h, m_xerr);
            ++attempts;
            bool suspect = false;
            double err = error_norm(m_xerr, suspect);
            if (suspect || m_ctx.any_invalid) {
                screen_trial(true, Fsal ? &m_dxdt_new : nullptr, &m_xerr);
                if (m_active == 0) break;
                err = error_norm(m_xerr, suspect);
            }
            if (err <= 1.0) {
                t = last ? m_t1 : t + h; // land exactly on t1
                m_x.swap(m_x_new);
                if constexpr (Fsal) {
                    m_dxdt.swap(m_dxdt_new);
                } else if constexpr (UsesDerivative) {
                    sys(m_x, m_dxdt, t);
                    freeze_invalid(&m_dxdt);
                }
                ++m_steps;
                check_after_step(&m_dxdt, t);
                if (m_ctx.variational) renormalise(&m_dxdt);
                const double factor = err > 0.0 ? 0.9 * std::pow(err, exponent) : 5.0;
                dt = h * std::clamp(factor, 0.2, 5.0);
            } else {
                ++m_rejected;
                dt = h * std::clamp(0.9 * std::pow(err, exponent), 0.2, 5.0);
            }
        }
    }

    // Classic RK4 with fixed step settings.step; the last step is shortened to land exactly on t1. Step times are
    // computed as t0 + i h, not accumulated, so rounding does not add a sliver step at the end.
    void run_fixed() {
        const std::size_t size = m_x.size();
        m_x_new.assign(size, 0.0);
        m_dxdt.assign(size, 0.0);
        Rk4 stepper;
        Rhs<N> sys{&m_ctx};
        const double span = m_t1 - m_t0;
        const double h = std::copysign(m_settings.step, span);
        const double count = fixed_step_count();
        for (double i = 0; i < count && m_active > 0; ++i) {
            if (const int signal = cancel_requested()) throw Cancelled(signal, "while integrating trajectories");
            if (m_steps >= m_settings.max_steps) {
                freeze_all_active(mask_step_limit);
                break;
            }
            const double t = m_t0 + i * h;
            const double t_next = i + 1 >= count ? m_t1 : m_t0 + (i + 1) * h;
            m_ctx.clear_invalid();
            sys(m_x, m_dxdt, t);
            stepper.do_step(sys, m_x, m_dxdt, t, m_x_new, t_next - t);
            screen_trial(has_non_finite(m_x_new), nullptr, nullptr);
            m_x.swap(m_x_new);
            ++m_steps;
            check_after_step(nullptr, t_next);
            if (m_ctx.variational) renormalise(nullptr);
        }
    }

    // ---- the lockstep kernel (the default engine)

    // Explicit Runge-Kutta over the whole block in structure-of-arrays layout, lanes in lockstep: one batched
    // right-hand-side call (and, with the variational equations, one Jacobian call) per stage, the forcing
    // evaluated once per stage time (BatchContext::fill_time), every pass over the block one vectorisable loop.
    // m_k holds the stage derivatives; block 0 is the derivative at the current state (computed once per accepted
    // step, reused by rejected retries). Adaptive: the step is controlled by the worst lane and component, the
    // error norm and masking exactly as in run_adaptive. Fixed: ceil(|t1 - t0| / step) equal steps that land on t1.
    template <class Tab> void run_lockstep(bool adaptive) {
        static_assert(Tab::error != detail::RkError::none || !Tab::fsal, "FSAL needs an error-controlled tableau");
        const std::size_t stride = m_x.size();
        m_k.assign(static_cast<std::size_t>(Tab::stages) * stride, 0.0);
        m_y.assign(stride, 0.0);
        m_x_new.assign(stride, 0.0);
        m_dxdt.assign(stride, 0.0); // screen_trial zeroes frozen lanes here; the kernel's own derivative is m_k block 0
        if (adaptive) m_xerr.assign(stride, 0.0);
        const double span = m_t1 - m_t0;
        double t = m_t0;
        m_ctx.evaluate(m_x.data(), m_k.data(), t);
        freeze_invalid(&m_k);

        double count = 1.0, h_fixed = span;
        if (!adaptive) {
            count = fixed_step_count();
            h_fixed = span / count;
        }
        double dt = std::copysign(std::min(m_settings.step, std::abs(span)), span);
        const double exponent = -1.0 / (Tab::error_order + 1);
        std::size_t attempts = 0;
        for (double i = 0; m_active > 0 && (adaptive ? t != m_t1 : i < count);) {
            if (const int signal = cancel_requested()) throw Cancelled(signal, "while integrating trajectories");
            bool last;
            double h;
            if (adaptive) {
                last = std::abs(dt) >= std::abs(m_t1 - t);
                if (attempts >= m_settings.max_steps || (!last && no_progress(dt, t))) {
                    freeze_all_active(mask_step_limit);
                    break;
                }
                h = last ? m_t1 - t : dt;
            } else {
                if (m_steps >= m_settings.max_steps) {
                    freeze_all_active(mask_step_limit);
                    break;
                }
                last = i + 1 >= count;
                t = m_t0 + i * h_fixed; // step times t0 + i h, not accumulated
                h = (last ? m_t1 : m_t0 + (i + 1) * h_fixed) - t;
            }
            const std::size_t frozen_before = m_ctx.frozen.size();
            m_ctx.clear_invalid();
            run_stages<Tab>(std::make_index_sequence<Tab::stages - 1>{}, t, h, stride);
            if constexpr (Tab::fsal)
                m_x_new.swap(m_y); // the last stage is evaluated at the new state
            else
                new_state<Tab>(m_x_new.data(), m_x.data(), m_k.data(), stride, h);
            ++attempts;
            double err = 0.0;
            if (adaptive) {
                if constexpr (Tab::error != detail::RkError::none) {
                    error_estimate<Tab>(m_xerr.data(), m_k.data(), stride, h);
                    bool suspect = false;
                    err = error_norm(m_xerr, suspect);
                    if (suspect || m_ctx.any_invalid) {
                        screen_trial(true, &m_k, &m_xerr);
                        if (m_active == 0) break;
                        err = error_norm(m_xerr, suspect);
                    }
                }
            } else {
                screen_trial(has_non_finite(m_x_new), &m_k, nullptr);
            }
            if (err <= 1.0) {
                t = last ? m_t1 : t + h; // land exactly on t1
                m_x.swap(m_x_new);
                if constexpr (Tab::fsal) {
                    std::copy(m_k.begin() + (Tab::stages - 1) * stride, m_k.begin() + Tab::stages * stride,
                              m_k.begin());
                    // Lanes frozen while screening this trial still hold their last-stage derivative.
                    for (std::size_t f = frozen_before; f < m_ctx.frozen.size(); ++f) zero_lane(m_k, m_ctx.frozen[f]);
                } else if (adaptive || !last) {
                    // (Fixed steps skip it after the last step: rk4 then costs exactly 4 evaluations per step.)
                    m_ctx.evaluate(m_x.data(), m_k.data(), t);
                    freeze_invalid(&m_k);
                }
                ++m_steps;
                ++i;
                check_after_step(&m_k, t);
                if (m_ctx.variational) renormalise(&m_k);
                if (adaptive) dt = h * std::clamp(err > 0.0 ? 0.9 * std::pow(err, exponent) : 5.0, 0.2, 5.0);
            } else {
                ++m_rejected;
                // The newly frozen lanes' derivative at the step's start must not move them in the retry.
                for (std::size_t f = frozen_before; f < m_ctx.frozen.size(); ++f) zero_lane(m_k, m_ctx.frozen[f]);
                dt = h * std::clamp(0.9 * std::pow(err, exponent), 0.2, 5.0);
            }
        }
    }

    // ---- the fused step: the plugin runs whole steps (ABI 1.2, gb_system_vtable.advance)

    // Fixed steps of rk4 or dop853 when the system's plugin offers a fused step: every stage of a lane (state, DF,
    // log|det DF|) stays in registers inside the plugin instead of passing through the k blocks in memory, which cost
    // most of run_lockstep's time (the blocks of 64 lanes x 7 components x 12 stages do not fit in L1). The plugin
    // gets the forcing at the stage times (evaluated here, once per stage time as in fill_time); the core keeps the
    // rest exactly as run_lockstep: the same step times, frozen lanes restored to their pre-step state (the kernel's
    // zero derivatives), the same screening, bounds, renormalisation and counts. Same tableaux, same arithmetic
    // order, so the results agree with run_lockstep to rounding. False when the plugin has no fused step or
    // declines the method on the first step (nothing has moved then); run_lockstep takes over.
    // Fixed steps: ceil(|t1 - t0| / step) equal steps that land on t1 (the 1e-9 keeps rounding from adding a step).
    double fixed_step_count() const {
        const double ratio = std::abs(m_t1 - m_t0) / m_settings.step;
        return std::max(1.0, std::ceil(ratio - 1e-9 * ratio));
    }

    // ---- checked fixed steps (IntegratorSettings::step_tolerance, the quality presets' default)

    bool try_fused_checked() {
        if (!m_settings.fused || !m_ctx.system->has_advance() || m_method != Method::dop853) return false;
        return run_checked<detail::Dop853Tableau>(true);
    }

    // Fixed steps with an error test. The fixed grid t_i = t0 + i h (h = (t1 - t0) / ceil(|t1 - t0| / step)) is a
    // sequence of checkpoints: each step goes from t to the next checkpoint in equal sub-steps of at most dt, dt = h
    // until a step fails. Every trial step's embedded error estimate of the state (per lane: lane_error_estimate of
    // rk_tableaux.hpp over x and y, scaled by scale_lane_errors) is tested by the batch's worst lane, so the batch
    // stays in lockstep: a failure (or a NaN, Inf or plugin-refused state, the usual signature of an unstable
    // explicit step) shrinks dt by the classic factor 0.9 err^(-1/(q+1)) and retries; accepted sub-steps grow it
    // again, at most to h. On a smooth system every whole step passes, and the run takes exactly the unchecked fixed
    // steps (same times, same forcing values, same numbers). At the floor h * min_step_fraction, lanes that still
    // fail are masked with their cause (mask_unstable: the stepper, not the trajectory; mask_non_finite for a NaN or
    // Inf there; mask_invalid_state for a refused state) and the others go on. DF is not in the test: it follows the
    // state's time scales, and its error relative to DF tracks the state's (checked on the accuracy suite of the
    // bench, docs/performance.md). Fused: the plugin's step writes the lane errors (ABI 1.3,
    // GB_ADVANCE_DOP853_CHECKED); false when it declines on the first step (nothing has moved), and the kernel
    // takes over. Otherwise the core's stage-by-stage kernel runs the stages (run_lockstep's passes).
    template <class Tab> bool run_checked(bool fused) {
        static_assert(Tab::error != detail::RkError::none, "the checked steps need an error estimate");
        const std::size_t n = m_ctx.n, stride = m_x.size();
        m_x_new.assign(stride, 0.0);
        m_dxdt.assign(stride, 0.0);
        m_lane_error.assign(n, 0.0);
        const double span = m_t1 - m_t0;
        const double count = fixed_step_count();
        const double h_fixed = span / count, h_full = std::abs(h_fixed);
        const double h_min = h_full * min_step_fraction;
        // The estimate's own order (lane_error_estimate): DOP853's 5th-order row alone is O(h^6).
        const double exponent = -1.0 / (Tab::error == detail::RkError::dop853 ? 6 : Tab::error_order + 1);
        gb_advance_request request = fused_request(GB_ADVANCE_DOP853_CHECKED);
        if (fused) {
            request.lane_error = m_lane_error.data();
        } else {
            m_k.assign(static_cast<std::size_t>(Tab::stages) * stride, 0.0);
            m_y.assign(stride, 0.0);
            m_ctx.evaluate(m_x.data(), m_k.data(), m_t0);
            freeze_invalid(&m_k);
        }
        double t = m_t0, dt = h_full;
        std::size_t attempts = 0;
        for (double i = 0; m_active > 0 && i < count;) {
            if (const int signal = cancel_requested()) throw Cancelled(signal, "while integrating trajectories");
            if (attempts >= m_settings.max_steps) {
                freeze_all_active(mask_step_limit);
                break;
            }
            const double t_next = i + 1 >= count ? m_t1 : m_t0 + (i + 1) * h_fixed; // not accumulated
            const double remaining = t_next - t;
            const double pieces = std::max(1.0, std::ceil(std::abs(remaining) / dt - 1e-9));
            const bool lands = pieces <= 1.0;
            const bool whole = lands && t == m_t0 + i * h_fixed; // a step of the fixed grid: cached forcing
            const double h = lands ? remaining : remaining / pieces;
            m_ctx.clear_invalid();
            if (fused) {
                const double *forcing =
                    whole ? stage_forcing<Tab>(static_cast<std::size_t>(i), count, t, h) : substep_forcing<Tab>(t, h);
                if (!fused_step<Tab>(request, forcing, t, h, attempts == 0)) return false;
                for (std::size_t k : m_ctx.frozen) { // frozen lanes stay put, with no error
                    copy_lane(m_x_new, m_x, k);
                    m_lane_error[k] = 0.0;
                }
            } else {
                run_stages<Tab>(std::make_index_sequence<Tab::stages - 1>{}, t, h, stride);
                if constexpr (Tab::fsal)
                    m_x_new.swap(m_y);
                else
                    new_state<Tab>(m_x_new.data(), m_x.data(), m_k.data(), stride, h);
                lane_errors<Tab>(); // frozen lanes: zero derivatives, so zero error
            }
            const bool any_over = scale_lane_errors(h);
            ++attempts;
            const double err = batch_error(any_over, !whole);
            const bool at_floor = std::abs(h) <= h_min * (1.0 + 1e-9);
            if (err > 1.0 && !at_floor) {
                ++m_rejected;
                m_ctx.clear_invalid();
                dt = std::max(h_min, std::abs(h) * std::clamp(0.9 * std::pow(err, exponent), 0.2, 0.9));
                continue;
            }
            if (err > 1.0) mask_failing_lanes(fused); // at the floor: the rest of the batch goes on
            m_ctx.clear_invalid();
            t = lands ? t_next : t + h;
            m_x.swap(m_x_new);
            if constexpr (Tab::fsal) {
                if (!fused)
                    std::copy(m_k.begin() + (Tab::stages - 1) * stride, m_k.begin() + Tab::stages * stride,
                              m_k.begin());
            }
            ++m_steps;
            if (lands) ++i;
            if (!fused && !Tab::fsal && i < count) {
                m_ctx.evaluate(m_x.data(), m_k.data(), t);
                freeze_invalid(&m_k);
            }
            if (!fused && Tab::fsal)
                for (std::size_t k : m_ctx.frozen) zero_lane(m_k, k);
            check_after_step(fused ? nullptr : &m_k, t);
            if (m_ctx.variational) renormalise(fused ? nullptr : &m_k);
            dt = whole ? h_full
                       : std::min(h_full,
                                  std::abs(h) * std::clamp(err > 0.0 ? 0.9 * std::pow(err, exponent) : 5.0, 0.2, 5.0));
        }
        if (m_ctx.variational) renormalise(nullptr, true); // DF of the last steps: NaN or Inf is masked
        return true;
    }

    // The kernel's lane error estimates of a trial step (stage derivatives in m_k), exactly as the SDK's fused step
    // computes them (rk_tableaux.hpp, lane_error_estimate).
    template <class Tab> void lane_errors() {
        const std::size_t n = m_ctx.n, stride = m_x.size();
        const double *__restrict k = m_k.data();
        double *__restrict out = m_lane_error.data();
#pragma omp simd
        for (std::size_t lane = 0; lane < n; ++lane)
            out[lane] = detail::lane_error_estimate<Tab, position_components>(
                [&](int j, unsigned c) { return k[j * stride + c * n + lane]; });
    }

    // Lane error estimates to ratios: times |h|, over the lane's scale step_tolerance (1 + max(|x|, |x_new|)) over
    // its state components (a norm-wise error of the state, relative where it is large). A lane whose new state is
    // NaN or Inf gets a NaN ratio (x - x is 0 for a finite x, NaN otherwise), so that this one vectorisable pass also
    // does the non-finite screening of the trial step; a non-finite DF under a finite state is no failure of the
    // step (check_after_step freezes such lanes). Returns whether any ratio exceeds 1 or is NaN.
    bool scale_lane_errors(double h) {
        const std::size_t n = m_ctx.n;
        const double factor = std::abs(h) / m_settings.step_tolerance;
        const double *__restrict x = m_x.data(), *__restrict xn = m_x_new.data();
        double *__restrict e = m_lane_error.data();
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
    double batch_error(bool any_over, bool exact) {
        const std::size_t n = m_ctx.n;
        const double *e = m_lane_error.data();
        double err = 0.0;
        if (!m_ctx.any_invalid) {
            if (!exact && !any_over) return 0.0; // the common case
            if (!any_non_finite(e, n)) {
                for (std::size_t k = 0; k < n; ++k) err = e[k] > err ? e[k] : err;
                return err;
            }
        }
        const std::size_t comps = m_ctx.components;
        for (std::size_t k = 0; k < n; ++k) {
            if (m_ctx.mask[k] != 0) continue;
            bool lane_bad = m_ctx.invalid[k] || !(m_lane_error[k] <= std::numeric_limits<double>::max());
            for (std::size_t c = 0; c < comps && !lane_bad; ++c) lane_bad = !std::isfinite(m_x_new[c * n + k]);
            if (lane_bad) m_lane_error[k] = std::numeric_limits<double>::infinity();
        }
        err = 0.0;
        for (std::size_t k = 0; k < n; ++k)
            if (m_ctx.mask[k] == 0) err = std::max(err, m_lane_error[k]);
        return err;
    }

    // At the smallest sub-step: lanes whose error still exceeds 1 are frozen at their pre-step state, with the cause.
    void mask_failing_lanes(bool fused) {
        const std::size_t n = m_ctx.n, comps = m_ctx.components;
        for (std::size_t k = 0; k < n; ++k) {
            if (m_ctx.mask[k] != 0 || !(m_lane_error[k] > 1.0)) continue;
            bool finite = true;
            for (std::size_t c = 0; c < comps; ++c) finite = finite && std::isfinite(m_x_new[c * n + k]);
            const double runaway_limit = m_limit[k] * (runaway_factor / blow_up_factor);
            bool runaway = false;
            for (std::size_t i = 0; i < N; ++i) runaway = runaway || std::abs(m_x[i * n + k]) > runaway_limit;
            freeze(k, m_ctx.invalid[k] ? mask_invalid_state : finite && !runaway ? mask_unstable : mask_non_finite);
            copy_lane(m_x_new, m_x, k);
            if (!fused) zero_lane(m_k, k);
        }
    }

    // The forcing at the stage times of a sub-step (not on the fixed grid, so not cached).
    template <class Tab> const double *substep_forcing(double t, double h) {
        m_substep_forcing.assign(Tab::stages, 0.0);
        for (int s = 0; s < Tab::stages; ++s) {
            const double ts = t + Tab::c[s] * h;
            if (m_ctx.forcing) m_ctx.forcing->evaluate(1, &ts, &m_substep_forcing[static_cast<std::size_t>(s)]);
        }
        return m_substep_forcing.data();
    }

    // The parts of a fused-step request (ABI 1.2 advance) that stay the same for every step of a batch.
    gb_advance_request fused_request(std::int32_t method) {
        gb_advance_request request{};
        request.method = method;
        request.variational = m_ctx.variational ? 1 : 0;
        request.n = request.ld = m_ctx.n;
        request.lane_status = m_ctx.lane_status.data();
        return request;
    }

    // One step of the plugin's fused kernel from (t, m_x) into m_x_new, with the forcing at the step's stage times.
    // False when the plugin declines the method on the batch's first step (nothing has moved: the core's own kernel
    // takes over); declining later, after it took earlier steps, is the plugin's error.
    template <class Tab>
    bool fused_step(gb_advance_request &request, const double *forcing, double t, double h, bool first) {
        const std::size_t n = m_ctx.n;
        request.forcing = forcing;
        request.t = t;
        request.h = h;
        request.x = m_x.data();
        request.x_out = m_x_new.data();
        if (m_ctx.variational) {
            request.df = m_x.data() + comp_f11 * n;
            request.log_det = m_x.data() + comp_log_det * n;
            request.df_out = m_x_new.data() + comp_f11 * n;
            request.log_det_out = m_x_new.data() + comp_log_det * n;
        }
        std::fill(m_ctx.lane_status.begin(), m_ctx.lane_status.end(), GB_OK);
        if (!m_ctx.system->advance(request)) {
            if (first) return false;
            throw PluginError("system '" + m_ctx.system->info().name +
                              "': advance() declined a method it had accepted on earlier steps");
        }
        m_ctx.note_lane_status();
        m_ctx.rhs_calls += Tab::stages;
        return true;
    }

    // Calls f with a value of the Butcher tableau of an explicit method (the lockstep kernels' template argument);
    // nothing for rosenbrock4, which has none.
    template <class F> static void with_explicit_tableau(Method method, F &&f) {
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

    bool try_fused() {
        if (!m_settings.fused || !m_ctx.system->has_advance()) return false;
        switch (m_method) {
        case Method::dop853:
            return run_fused<detail::Dop853Tableau>(GB_ADVANCE_DOP853);
        case Method::rk4:
            return run_fused<detail::Rk4Tableau>(GB_ADVANCE_RK4);
        default:
            return false;
        }
    }
    template <class Tab> bool run_fused(std::int32_t method) {
        const std::size_t stride = m_x.size();
        m_x_new.assign(stride, 0.0);
        m_dxdt.assign(stride, 0.0); // screen_trial zeroes frozen lanes here
        const double span = m_t1 - m_t0;
        const double count = fixed_step_count();
        const double h_fixed = span / count;
        gb_advance_request request = fused_request(method);
        for (double i = 0; m_active > 0 && i < count;) {
            if (const int signal = cancel_requested()) throw Cancelled(signal, "while integrating trajectories");
            if (m_steps >= m_settings.max_steps) {
                freeze_all_active(mask_step_limit);
                break;
            }
            const bool last = i + 1 >= count;
            const double t = m_t0 + i * h_fixed; // step times t0 + i h, not accumulated
            const double h = (last ? m_t1 : m_t0 + (i + 1) * h_fixed) - t;
            m_ctx.clear_invalid();
            if (!fused_step<Tab>(request, stage_forcing<Tab>(static_cast<std::size_t>(i), count, t, h), t, h,
                                 m_steps == 0))
                return false;
            for (std::size_t k : m_ctx.frozen) copy_lane(m_x_new, m_x, k);
            screen_trial(has_non_finite(m_x_new), nullptr, nullptr);
            m_x.swap(m_x_new);
            ++m_steps;
            ++i;
            check_after_step(nullptr, t + h);
            if (m_ctx.variational) renormalise(nullptr);
        }
        return true;
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
                if (m_ctx.forcing) m_ctx.forcing->evaluate(1, &ts, &f[s]);
            }
            m_forcing_known[slot] = cached ? 1 : 0;
        }
        return f;
    }

    // Stages 1 .. stages-1 of one trial step from (t, m_x) with step h; stage 0 (m_k block 0) is already there.
    template <class Tab, std::size_t... I>
    void run_stages(std::index_sequence<I...>, double t, double h, std::size_t stride) {
        (stage<Tab, static_cast<int>(I) + 1>(t, h, stride), ...);
    }
    template <class Tab, int I> void stage(double t, double h, std::size_t stride) {
        stage_state<Tab, I>(m_y.data(), m_x.data(), m_k.data(), stride, h);
        m_ctx.evaluate(m_y.data(), m_k.data() + static_cast<std::size_t>(I) * stride, t + Tab::c[I] * h);
    }

    double m_t0, m_t1;
    const IntegratorSettings &m_settings;
    double m_rtol; // settings.rtol clamped to min_rtol
    Method m_method;
    bool m_lockstep; // the lockstep kernel (run_lockstep) rather than Boost.Odeint's steppers
    const std::optional<Bounds> &m_bounds;
    std::array<unsigned, 2> m_bound_axes; // the state components the bounds box limits (a slice's axes)
    DifferenceControl m_differences;
    BatchContext<N> m_ctx;
    std::size_t m_active = 0;
    std::uint64_t m_steps = 0, m_rejected = 0;
    State m_x, m_x_new, m_dxdt, m_dxdt_new, m_xerr;
    State m_k, m_y; // lockstep kernel: stage derivatives (stages x components x lanes) and the stage state
    std::vector<double> m_limit;
    std::vector<std::uint8_t> m_bad;
    std::vector<std::int32_t> m_exponent;     // variational: DF = 2^m_exponent[k] * (the state's DF block)
    std::vector<std::uint8_t> m_renormalised; // lanes rescaled at least once
    std::vector<double> m_exit_time;          // with bounds: when each lane left them (NaN: never)
    unsigned m_since_renormalise = 0;
    std::vector<double> m_lane_error;          // checked fixed steps: each lane's error of the trial step
    std::vector<double> m_substep_forcing;     // checked fixed steps: forcing at a sub-step's stage times
    std::uint64_t m_planned = 0;               // fixed steps: the fixed grid's step count (stats.planned_steps)
    std::vector<double> m_forcing;             // fused steps: forcing at each step's stage times (stage_forcing)
    std::vector<std::uint8_t> m_forcing_known; // per step: m_forcing holds its values
    std::size_t m_forcing_stages = 0;
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
