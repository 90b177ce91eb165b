// The flow-map engine's batch context (private; batch_integrator.hpp): the state layout of a lane, the engine's
// shared constants, and BatchContext<N>, everything one batched right-hand-side call of the plugin needs.
#pragma once

#include "batches.hpp"

#include <geobarrier/flow_map.hpp>
#include <geobarrier/rk_tableaux.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

namespace geobarrier::flow_map_engine {

// Internal linkage in each flow_map_dim<N>.cpp (batch_integrator.hpp).
namespace {

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

// True when some entry of v is NaN or Inf (any_non_finite over the whole vector).
inline bool any_non_finite_in(const State &v) { return any_non_finite(v.data(), v.size()); }

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

} // namespace

} // namespace geobarrier::flow_map_engine
