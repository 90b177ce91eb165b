// The flow map engine: lockstep batches of trajectories (one Boost.Odeint state in SoA layout per batch) with our
// own step-size control, masking of bad lanes, OpenMP over batches, and the grid flow map with its gradient.
#include <geobarrier/errors.hpp>
#include <geobarrier/flow_map.hpp>

#include <boost/numeric/odeint/stepper/runge_kutta4.hpp>
#include <boost/numeric/odeint/stepper/runge_kutta_dopri5.hpp>
#include <boost/numeric/odeint/stepper/runge_kutta_fehlberg78.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace geobarrier {

namespace {

namespace odeint = boost::numeric::odeint;
using State = std::vector<double>;

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

// A lane whose position grows beyond this factor times max(1, |initial position|) is treated as blown up.
constexpr double blow_up_factor = 1e8;
// A step below this fraction of max(1, |t|) makes no progress: the batch stops with mask_step_limit.
constexpr double min_relative_step = 1e-14;
// Floor of the error scale atol + rtol |x|.
constexpr double min_scale = std::numeric_limits<double>::min();

enum class Method { dopri5, rkf78, rk4 };

Method parse_method(const std::string &name) {
    if (name == "dopri5") return Method::dopri5;
    if (name == "rkf78") return Method::rkf78;
    if (name == "rk4") return Method::rk4;
    throw ConfigError("/integrator/method", "unknown method \"" + name + "\"; expected dopri5, rkf78 or rk4");
}

void validate(const Dynamics &dynamics, double t0, double t1, const IntegratorSettings &settings, bool variational) {
    if (!dynamics.system) throw Error("flow map: no dynamical system given");
    parse_method(settings.method);
    if (dynamics.system->dimension() != 2)
        throw ConfigError("/system/plugin", "system '" + dynamics.system->info().name + "' has dimension " +
                                                std::to_string(dynamics.system->dimension()) +
                                                "; the flow map engine handles planar systems (dimension 2)");
    if (variational && !dynamics.system->has_jacobian())
        throw ConfigError("/cauchy_green/method", "system '" + dynamics.system->info().name +
                                                      "' has no Jacobian; use auxiliary-grid");
    if (!(settings.rtol >= 0.0) || !(settings.atol >= 0.0) || !(settings.rtol + settings.atol > 0.0) ||
        !std::isfinite(settings.rtol + settings.atol))
        throw ConfigError("/integrator/rtol", "tolerances must be finite, non-negative and not both zero (rtol " +
                                                  std::to_string(settings.rtol) + ", atol " +
                                                  std::to_string(settings.atol) + ")");
    if (!(settings.step > 0.0) || !std::isfinite(settings.step))
        throw ConfigError("/integrator/step", std::to_string(settings.step) + " is not a positive step");
    if (settings.batch == 0) throw ConfigError("/integrator/batch", "0 is below the minimum 1");
    if (settings.max_steps == 0) throw ConfigError("/integrator/max_steps", "0 is below the minimum 1");
    if (!std::isfinite(t0) || !std::isfinite(t1)) throw ConfigError("/time", "t0 and t1 must be finite");
}

// Everything one batched right-hand-side call needs. The functor handed to Odeint holds only a pointer to it,
// because Odeint copies the system object into every do_step.
struct BatchContext {
    const System *system = nullptr;
    const Forcing *forcing = nullptr; // null when the system does not read the forcing
    bool variational = false;
    std::size_t n = 0;               // lanes (= ld)
    std::size_t components = 2;      // 2, or 6 with DF
    std::vector<double> times, forcing_values, jac;
    std::vector<std::int32_t> lane_status;
    std::vector<std::uint8_t> mask;  // per lane, 0 = active
    std::vector<std::size_t> frozen; // lanes with mask != 0: their derivatives are zeroed
    std::vector<std::uint8_t> invalid; // lanes the plugin declared invalid since the last clear_invalid()
    bool any_invalid = false;
    double filled_time = nan_value;
    std::uint64_t rhs_calls = 0;

    void reset(std::size_t lanes, std::size_t comps) {
        n = lanes;
        components = comps;
        times.assign(n, 0.0);
        forcing_values.assign(n, 0.0);
        jac.assign(variational ? 4 * n : 0, 0.0);
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

    void evaluate(const State &x, State &dxdt, double t) {
        // Lockstep: every lane is at the same time, so the forcing is evaluated once per stage time.
        if (!(t == filled_time)) {
            std::fill(times.begin(), times.end(), t);
            double f = 0.0;
            if (forcing) forcing->evaluate(1, &t, &f);
            std::fill(forcing_values.begin(), forcing_values.end(), f);
            filled_time = t;
        }
        const double *xp = x.data();
        double *dp = dxdt.data();
        std::fill(lane_status.begin(), lane_status.end(), GB_OK);
        system->rhs(n, n, times.data(), xp, forcing_values.data(), dp, lane_status.data());
        note_lane_status();
        if (variational) {
            std::fill(lane_status.begin(), lane_status.end(), GB_OK);
            system->jacobian(n, n, times.data(), xp, forcing_values.data(), jac.data(), lane_status.data());
            note_lane_status();
            // DF' = J DF (variational equations), DF row-major in blocks 2..5.
            const double *j11 = jac.data(), *j12 = j11 + n, *j21 = j12 + n, *j22 = j21 + n;
            const double *f11 = xp + 2 * n, *f12 = f11 + n, *f21 = f12 + n, *f22 = f21 + n;
            double *d11 = dp + 2 * n, *d12 = d11 + n, *d21 = d12 + n, *d22 = d21 + n;
            for (std::size_t k = 0; k < n; ++k) {
                d11[k] = j11[k] * f11[k] + j12[k] * f21[k];
                d12[k] = j11[k] * f12[k] + j12[k] * f22[k];
                d21[k] = j21[k] * f11[k] + j22[k] * f21[k];
                d22[k] = j21[k] * f12[k] + j22[k] * f22[k];
            }
        }
        // Masked lanes are frozen: with zero derivatives in every stage their state and error stay exactly put.
        for (std::size_t k : frozen)
            for (std::size_t c = 0; c < components; ++c) dp[c * n + k] = 0.0;
        ++rhs_calls;
    }
};

struct Rhs {
    BatchContext *ctx;
    void operator()(const State &x, State &dxdt, double t) const { ctx->evaluate(x, dxdt, t); }
};

using Dopri5 = odeint::runge_kutta_dopri5<State>;
using Rkf78 = odeint::runge_kutta_fehlberg78<State>;
using Rk4 = odeint::runge_kutta4<State>;

// Auxiliary-grid batches: every `per_point` consecutive lanes are the neighbours (+dx, -dx, +dy, -dy[, centre]) of
// one grid point. The error norm then also covers the centred differences (F(+) - F(-)) / 2d, so the tolerances
// bound the error of the gradient the user asked for, as they do for DF in the variational equations, and not
// only the error of the positions (with atol 1e-4 and d ~ 1e-6 a position-only norm leaves the difference
// quotient's error unbounded). per_point = 0: plain trajectories.
struct DifferenceControl {
    std::size_t per_point = 0;
    double inv_2dx = 0.0, inv_2dy = 0.0;
};

// One thread's integrator: integrates one batch at a time, reusing its buffers.
class BatchIntegrator {
  public:
    BatchIntegrator(const Dynamics &dynamics, double t0, double t1, const IntegratorSettings &settings, Method method,
                    bool variational, const std::optional<Bounds> &bounds, const DifferenceControl &differences)
        : m_t0(t0), m_t1(t1), m_settings(settings), m_method(method), m_bounds(bounds), m_differences(differences) {
        m_ctx.system = dynamics.system;
        m_ctx.forcing = dynamics.system->uses_forcing() ? dynamics.forcing : nullptr;
        m_ctx.variational = variational;
    }

    // Integrates lanes starting at (x0[k], y0[k]), k < n. Afterwards state() holds the final states (ld = n) and
    // mask() the lanes' MaskBits; masked lanes' states are meaningless.
    void run(std::size_t n, const double *x0, const double *y0, IntegratorStats &stats) {
        const std::size_t comps = m_ctx.variational ? 6 : 2;
        m_ctx.reset(n, comps);
        m_active = n;
        m_x.assign(comps * n, 0.0);
        m_limit.resize(n);
        for (std::size_t k = 0; k < n; ++k) {
            m_x[k] = x0[k];
            m_x[n + k] = y0[k];
            m_limit[k] = blow_up_factor * std::max({1.0, std::abs(x0[k]), std::abs(y0[k])});
        }
        if (m_ctx.variational) {
            std::fill(m_x.begin() + 2 * n, m_x.begin() + 3 * n, 1.0); // F11
            std::fill(m_x.begin() + 5 * n, m_x.begin() + 6 * n, 1.0); // F22
        }
        for (std::size_t k = 0; k < n; ++k) {
            if (!std::isfinite(x0[k]) || !std::isfinite(y0[k])) {
                freeze(k, mask_non_finite);
                m_x[k] = 0.0; // keep what the plugin sees finite
                m_x[n + k] = 0.0;
            }
        }
        check_bounds(nullptr);
        m_steps = m_rejected = 0;
        if (m_t0 != m_t1 && m_active > 0) {
            switch (m_method) {
            case Method::dopri5: run_adaptive<Dopri5, true>(4); break;
            case Method::rkf78: run_adaptive<Rkf78, false>(7); break;
            case Method::rk4: run_fixed(); break;
            }
        }
        stats.trajectories += n;
        stats.batches += 1;
        stats.steps += m_steps;
        stats.rejected_steps += m_rejected;
        stats.rhs_evaluations += static_cast<std::uint64_t>(n) * m_ctx.rhs_calls;
        for (std::size_t k = 0; k < n; ++k) {
            const std::uint8_t m = m_ctx.mask[k];
            if (m == 0) continue;
            ++stats.masked;
            if (m & mask_left_bounds) ++stats.masked_left_bounds;
            if (m & mask_non_finite) ++stats.masked_non_finite;
            if (m & mask_step_limit) ++stats.masked_step_limit;
            if (m & mask_invalid_state) ++stats.masked_invalid_state;
        }
    }

    const State &state() const { return m_x; }
    const std::vector<std::uint8_t> &mask() const { return m_ctx.mask; }

  private:
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
            if (m_ctx.invalid[k]) freeze(k, mask_invalid_state);
            else if (m_bad[k]) freeze(k, mask_non_finite);
            else continue;
            copy_lane(m_x_new, m_x, k);
            zero_lane(m_dxdt, k);
            if (dxdt_new) zero_lane(*dxdt_new, k);
            if (xerr) zero_lane(*xerr, k);
        }
        m_ctx.clear_invalid();
    }

    // True when some entry of v is NaN or Inf: v * 0 is 0 for finite entries and NaN otherwise, and a NaN survives
    // the sum. One vectorisable pass, no branches.
    static bool has_non_finite(const State &v) {
        double probe = 0.0;
        const double *p = v.data();
        const std::size_t size = v.size();
#pragma omp simd reduction(+ : probe)
        for (std::size_t i = 0; i < size; ++i) probe += p[i] * 0.0;
        return probe != probe;
    }

    // After an accepted step: blown-up lanes and lanes outside the bounds box are frozen.
    void check_after_step(State *dxdt) {
        const std::size_t n = m_ctx.n;
        const double *x = m_x.data(), *y = x + n;
        for (std::size_t k = 0; k < n; ++k) {
            if (m_ctx.mask[k] != 0) continue;
            if (std::abs(x[k]) > m_limit[k] || std::abs(y[k]) > m_limit[k]) {
                freeze(k, mask_non_finite);
                if (dxdt) zero_lane(*dxdt, k);
            }
        }
        check_bounds(dxdt);
    }
    void check_bounds(State *dxdt) {
        if (!m_bounds) return;
        const std::size_t n = m_ctx.n;
        const double *x = m_x.data(), *y = x + n;
        const Bounds &b = *m_bounds;
        for (std::size_t k = 0; k < n; ++k) {
            if (m_ctx.mask[k] != 0) continue;
            if (!(x[k] >= b.x_min && x[k] <= b.x_max && y[k] >= b.y_min && y[k] <= b.y_max)) {
                freeze(k, mask_left_bounds);
                if (dxdt) zero_lane(*dxdt, k);
            }
        }
    }

    // err = max over lanes and components of |xerr| / (atol + rtol max(|x_old|, |x_new|)). Frozen lanes have an
    // error of exactly zero (all their stage derivatives are zero), so no lane test is needed. Sets `suspect` when
    // the new state or the error holds a NaN or Inf (then err is meaningless and the caller screens the lanes).
    double error_norm(const State &xerr, bool &suspect) const {
        const double atol = m_settings.atol, rtol = m_settings.rtol;
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
        const double atol = m_settings.atol, rtol = m_settings.rtol;
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
    // derivative is reused; otherwise the derivative at the new state is computed once per accepted step and
    // reused by rejected retries.
    template <class Stepper, bool Fsal> void run_adaptive(int order) {
        const std::size_t size = m_x.size();
        m_x_new.assign(size, 0.0);
        m_dxdt.assign(size, 0.0);
        m_dxdt_new.assign(size, 0.0);
        m_xerr.assign(size, 0.0);
        Stepper stepper; // fresh per batch: Odeint sizes its temporaries once, on first use
        Rhs sys{&m_ctx};
        const double span = m_t1 - m_t0;
        double t = m_t0;
        double dt = std::copysign(std::min(m_settings.step, std::abs(span)), span);
        const double exponent = -1.0 / (order + 1);
        std::size_t attempts = 0;

        sys(m_x, m_dxdt, t);
        freeze_invalid(&m_dxdt);
        while (m_active > 0 && t != m_t1) {
            if (attempts >= m_settings.max_steps || no_progress(dt, t)) {
                freeze_all_active(mask_step_limit);
                break;
            }
            const bool last = std::abs(dt) >= std::abs(m_t1 - t);
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
                } else {
                    sys(m_x, m_dxdt, t);
                    freeze_invalid(&m_dxdt);
                }
                ++m_steps;
                check_after_step(&m_dxdt);
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
        Rhs sys{&m_ctx};
        const double span = m_t1 - m_t0;
        const double h = std::copysign(m_settings.step, span);
        const double ratio = std::abs(span) / m_settings.step;
        const double count = std::max(1.0, std::ceil(ratio - 1e-9 * ratio));
        for (double i = 0; i < count && m_active > 0; ++i) {
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
            check_after_step(nullptr);
        }
    }

    double m_t0, m_t1;
    const IntegratorSettings &m_settings;
    Method m_method;
    const std::optional<Bounds> &m_bounds;
    DifferenceControl m_differences;
    BatchContext m_ctx;
    std::size_t m_active = 0;
    std::uint64_t m_steps = 0, m_rejected = 0;
    State m_x, m_x_new, m_dxdt, m_dxdt_new, m_xerr;
    std::vector<double> m_limit;
    std::vector<std::uint8_t> m_bad;
};

// Fills the initial positions of lanes [first, first + n).
using InitFn = std::function<void(std::size_t first, std::size_t n, double *x0, double *y0)>;
// Receives the final states (SoA, ld = n) and masks of lanes [first, first + n).
using FinishFn = std::function<void(std::size_t first, std::size_t n, const double *state, const std::uint8_t *mask)>;

// Integrates `lanes` trajectories in batches of `batch` consecutive lanes, batches in parallel (OpenMP). The first
// exception thrown in any batch (a failing plugin call, say) stops the remaining batches and is rethrown here.
IntegratorStats run_batches(const Dynamics &dynamics, double t0, double t1, const IntegratorSettings &settings,
                            bool variational, const std::optional<Bounds> &bounds, std::size_t lanes,
                            std::size_t batch, const InitFn &init, const FinishFn &finish,
                            const ProgressFn &progress, const DifferenceControl &differences = {}) {
    const auto start = std::chrono::steady_clock::now();
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
            BatchIntegrator integrator(dynamics, t0, t1, settings, method, variational, bounds, differences);
            std::vector<double> x0(batch), y0(batch);
#pragma omp for schedule(dynamic, 1)
            for (long long b = 0; b < static_cast<long long>(batches); ++b) {
                if (failed.load(std::memory_order_relaxed)) continue;
                try {
                    const std::size_t first = static_cast<std::size_t>(b) * batch;
                    const std::size_t n = std::min(batch, lanes - first);
                    init(first, n, x0.data(), y0.data());
                    integrator.run(n, x0.data(), y0.data(), local);
                    finish(first, n, integrator.state().data(), integrator.mask().data());
                    const std::size_t d = done.fetch_add(1) + 1;
                    if (progress) progress(d, batches);
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

}  // namespace

void IntegratorStats::add(const IntegratorStats &other) {
    trajectories += other.trajectories;
    batches += other.batches;
    steps += other.steps;
    rejected_steps += other.rejected_steps;
    rhs_evaluations += other.rhs_evaluations;
    masked += other.masked;
    masked_left_bounds += other.masked_left_bounds;
    masked_non_finite += other.masked_non_finite;
    masked_step_limit += other.masked_step_limit;
    masked_invalid_state += other.masked_invalid_state;
    wall_seconds += other.wall_seconds;
}

nlohmann::json IntegratorStats::to_json() const {
    return nlohmann::json{{"trajectories", trajectories},
                          {"batches", batches},
                          {"steps", steps},
                          {"rejected_steps", rejected_steps},
                          {"rhs_evaluations", rhs_evaluations},
                          {"masked", masked},
                          {"masked_left_bounds", masked_left_bounds},
                          {"masked_non_finite", masked_non_finite},
                          {"masked_step_limit", masked_step_limit},
                          {"masked_invalid_state", masked_invalid_state},
                          {"wall_seconds", wall_seconds}};
}

AdvectResult advect_points(const Dynamics &dynamics, const std::vector<double> &x0, const std::vector<double> &y0,
                           double t0, double t1, const IntegratorSettings &settings, bool variational,
                           const std::optional<Bounds> &bounds, const ProgressFn &progress) {
    validate(dynamics, t0, t1, settings, variational);
    if (x0.size() != y0.size())
        throw Error("advect_points: " + std::to_string(x0.size()) + " x coordinates but " +
                    std::to_string(y0.size()) + " y coordinates");
    const std::size_t count = x0.size();
    AdvectResult result;
    result.x.assign(count, nan_value);
    result.y.assign(count, nan_value);
    if (variational) result.dF.assign(4 * count, nan_value);
    result.mask.assign(count, 0);
    if (count == 0) return result;

    const InitFn init = [&](std::size_t first, std::size_t n, double *xs, double *ys) {
        std::copy(x0.begin() + first, x0.begin() + first + n, xs);
        std::copy(y0.begin() + first, y0.begin() + first + n, ys);
    };
    const FinishFn finish = [&](std::size_t first, std::size_t n, const double *s, const std::uint8_t *mask) {
        for (std::size_t k = 0; k < n; ++k) {
            const std::size_t p = first + k;
            result.mask[p] = mask[k];
            if (mask[k] != 0) continue;
            result.x[p] = s[k];
            result.y[p] = s[n + k];
            if (variational)
                for (std::size_t q = 0; q < 4; ++q) result.dF[4 * p + q] = s[(2 + q) * n + k];
        }
    };
    result.stats = run_batches(dynamics, t0, t1, settings, variational, bounds, count, settings.batch, init, finish,
                               progress);
    return result;
}

GradientMethod parse_gradient_method(const std::string &name) {
    if (name == "auxiliary-grid") return GradientMethod::auxiliary_grid;
    if (name == "variational") return GradientMethod::variational;
    if (name == "none") return GradientMethod::none;
    throw ConfigError("/cauchy_green/method",
                      "unknown method \"" + name + "\"; expected auxiliary-grid, variational or none");
}

const char *to_string(GradientMethod method) {
    switch (method) {
    case GradientMethod::none: return "none";
    case GradientMethod::auxiliary_grid: return "auxiliary-grid";
    case GradientMethod::variational: return "variational";
    }
    return "?";
}

GridFlowMap compute_grid_flow_map(const Dynamics &dynamics, const Grid &grid, double t0, double t1,
                                  const IntegratorSettings &settings, GradientMethod gradient, double aux_offset,
                                  bool want_positions, const std::optional<Bounds> &bounds,
                                  const ProgressFn &progress) {
    const bool variational = gradient == GradientMethod::variational;
    validate(dynamics, t0, t1, settings, variational);
    if (grid.nx < 2 || grid.ny < 2)
        throw ConfigError("/grid/n", "the grid needs at least 2 points per direction (got " + std::to_string(grid.nx) +
                                         " x " + std::to_string(grid.ny) + ")");
    if (gradient == GradientMethod::auxiliary_grid && !(aux_offset > 0.0 && std::isfinite(aux_offset)))
        throw ConfigError("/cauchy_green/offset", std::to_string(aux_offset) + " is not a positive offset");

    const std::size_t count = grid.size(), nx = grid.nx;
    const bool positions = want_positions || gradient == GradientMethod::none;
    GridFlowMap out;
    out.grid = grid;
    out.mask.assign(count, 0);
    if (positions) {
        out.flow_x.assign(count, nan_value);
        out.flow_y.assign(count, nan_value);
    }
    if (gradient != GradientMethod::none) out.dF.assign(4 * count, nan_value);

    if (gradient != GradientMethod::auxiliary_grid) {
        // One lane per grid point, row-major (row = y), so neighbours in x share a batch.
        const InitFn init = [&](std::size_t first, std::size_t n, double *xs, double *ys) {
            for (std::size_t k = 0; k < n; ++k) {
                const std::size_t p = first + k;
                xs[k] = grid.x(p % nx);
                ys[k] = grid.y(p / nx);
            }
        };
        const FinishFn finish = [&](std::size_t first, std::size_t n, const double *s, const std::uint8_t *mask) {
            for (std::size_t k = 0; k < n; ++k) {
                const std::size_t p = first + k;
                out.mask[p] = mask[k];
                if (mask[k] != 0) continue;
                if (positions) {
                    out.flow_x[p] = s[k];
                    out.flow_y[p] = s[n + k];
                }
                if (variational)
                    for (std::size_t q = 0; q < 4; ++q) out.dF[4 * p + q] = s[(2 + q) * n + k];
            }
        };
        out.stats = run_batches(dynamics, t0, t1, settings, variational, bounds, count, settings.batch, init, finish,
                                progress);
        return out;
    }

    // Auxiliary grid (Farazmand & Haller 2012): a grid point's 4 neighbours (and its centre when positions are
    // wanted) are consecutive lanes of one batch. Integrated in lockstep, they take identical steps, so their
    // integration errors are strongly correlated and largely cancel in the centred differences. The batch is rounded
    // up to a whole number of points, and DF is written per batch: no aux final states are kept for the whole grid.
    const std::size_t per_point = positions ? 5 : 4;
    const std::size_t batch = (settings.batch + per_point - 1) / per_point * per_point;
    const double dxo = aux_offset * grid.dx(), dyo = aux_offset * grid.dy();
    const double offset_x[5] = {dxo, -dxo, 0.0, 0.0, 0.0};
    const double offset_y[5] = {0.0, 0.0, dyo, -dyo, 0.0};
    const InitFn init = [&](std::size_t first, std::size_t n, double *xs, double *ys) {
        for (std::size_t k = 0; k < n; ++k) {
            const std::size_t lane = first + k, p = lane / per_point, q = lane % per_point;
            xs[k] = grid.x(p % nx) + offset_x[q];
            ys[k] = grid.y(p / nx) + offset_y[q];
        }
    };
    const FinishFn finish = [&](std::size_t first, std::size_t n, const double *s, const std::uint8_t *mask) {
        const double *xs = s, *ys = s + n;
        for (std::size_t k = 0; k < n; k += per_point) {
            const std::size_t p = (first + k) / per_point;
            std::uint8_t m = 0;
            for (std::size_t q = 0; q < per_point; ++q) m |= mask[k + q];
            out.mask[p] = m;
            if (m != 0) continue;
            // Centred differences: columns of DF are d F / d x0 and d F / d y0.
            out.dF[4 * p + 0] = (xs[k] - xs[k + 1]) / (2.0 * dxo);
            out.dF[4 * p + 1] = (xs[k + 2] - xs[k + 3]) / (2.0 * dyo);
            out.dF[4 * p + 2] = (ys[k] - ys[k + 1]) / (2.0 * dxo);
            out.dF[4 * p + 3] = (ys[k + 2] - ys[k + 3]) / (2.0 * dyo);
            if (positions) {
                out.flow_x[p] = xs[k + 4];
                out.flow_y[p] = ys[k + 4];
            }
        }
    };
    const DifferenceControl differences{per_point, 1.0 / (2.0 * dxo), 1.0 / (2.0 * dyo)};
    out.stats = run_batches(dynamics, t0, t1, settings, false, bounds, per_point * count, batch, init, finish, progress,
                            differences);
    return out;
}

}  // namespace geobarrier
