// The flow map's public functions: the settings checked, the plane of a system (a planar one, or an n-D one's slice)
// laid out as the engine's lanes, and the engine of the system's dimension run over them (batches.hpp; the engine
// itself: batch_integrator.hpp, compiled per dimension in flow_map_dim2.cpp .. flow_map_dim6.cpp).
#include "batches.hpp"

#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/flow_map.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace geobarrier {

namespace flow_map_engine {

Method parse_method(const std::string &name) {
    if (name == "dop853") return Method::dop853;
    if (name == "dopri5") return Method::dopri5;
    if (name == "rkf78") return Method::rkf78;
    if (name == "rk4") return Method::rk4;
    if (name == "rosenbrock4") return Method::rosenbrock4;
    throw EngineSettingError(EngineSetting::method,
                             "unknown method \"" + name + "\"; expected dop853, dopri5, rkf78, rk4 or rosenbrock4");
}

Engine parse_engine(const std::string &name) {
    if (name == "lockstep") return Engine::lockstep;
    if (name == "odeint") return Engine::odeint;
    throw EngineSettingError(EngineSetting::engine, "unknown engine \"" + name + "\"; expected lockstep or odeint");
}

} // namespace flow_map_engine

namespace {

using flow_map_engine::BatchRequest;
using flow_map_engine::DifferenceControl;
using flow_map_engine::Engine;
using flow_map_engine::FinishFn;
using flow_map_engine::InitFn;
using flow_map_engine::Method;
using flow_map_engine::parse_engine;
using flow_map_engine::parse_method;

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

} // namespace

void check_flow_map_settings(const FlowMapRequest &request) {
    const Dynamics &dynamics = request.dynamics;
    const IntegratorSettings &settings = request.settings;
    if (!dynamics.system) throw Error("flow map: no dynamical system given");
    parse_method(settings.method);
    const unsigned dimension = dynamics.system->dimension();
    if (dimension < 2 || dimension > max_dimension)
        throw EngineSettingError(EngineSetting::system, "system '" + dynamics.system->info().name + "' has dimension " +
                                                            std::to_string(dimension) +
                                                            "; the flow map engine "
                                                            "handles dimensions 2 to " +
                                                            std::to_string(max_dimension));
    if (request.gradient == GradientMethod::variational && !dynamics.system->has_jacobian())
        throw EngineSettingError(EngineSetting::gradient,
                                 "system '" + dynamics.system->info().name + "' has no Jacobian; use auxiliary-grid");
    if (parse_method(settings.method) == Method::rosenbrock4 && !dynamics.system->has_jacobian())
        throw EngineSettingError(EngineSetting::method, "rosenbrock4 needs the Jacobian of system '" +
                                                            dynamics.system->info().name +
                                                            "', which provides none; use dopri5 or rkf78");
    // rtol in (0, 1): 0 asks for exact arithmetic, 1 for no accuracy at all. Below min_rtol it is clamped.
    if (!(settings.rtol > 0.0 && settings.rtol < 1.0))
        throw EngineSettingError(EngineSetting::rtol,
                                 std::to_string(settings.rtol) + " must be between 0 and 1 (exclusive)");
    if (!(settings.atol >= 0.0) || !std::isfinite(settings.atol))
        throw EngineSettingError(EngineSetting::atol,
                                 std::to_string(settings.atol) + " must be finite and non-negative");
    if (!(settings.step > 0.0) || !std::isfinite(settings.step))
        throw EngineSettingError(EngineSetting::step, std::to_string(settings.step) + " is not a positive step");
    if (settings.batch == 0) throw EngineSettingError(EngineSetting::batch, "0 is below the minimum 1");
    if (parse_engine(settings.engine) == Engine::odeint && parse_method(settings.method) == Method::dop853)
        throw EngineSettingError(EngineSetting::method,
                                 "dop853 runs in the lockstep engine only; use \"engine\": \"lockstep\" "
                                 "or the odeint methods dopri5, rkf78, rk4, rosenbrock4");
    if (settings.max_steps == 0) throw EngineSettingError(EngineSetting::max_steps, "0 is below the minimum 1");
    if (!std::isfinite(request.t0) || !std::isfinite(request.t1))
        throw EngineSettingError(EngineSetting::time, "t0 and t1 must be finite");
}

namespace {

// The engine for the system's dimension (check_flow_map_settings has checked it is 2 .. max_dimension) over `lanes`
// lanes in batches of `batch`. The bounds box limits the slice's axes when there is a slice, else components 0 and 1.
IntegratorStats run_batches(const FlowMapRequest &r, bool variational, std::size_t lanes, std::size_t batch,
                            const InitFn &init, const FinishFn &finish, const DifferenceControl &differences = {}) {
    static_assert(max_dimension == 6, "specialise run_batches_for for every dimension up to max_dimension");
    const Dynamics &dynamics = r.dynamics;
    const std::array<unsigned, 2> axes = dynamics.slice ? dynamics.slice->axes : std::array<unsigned, 2>{0, 1};
    const BatchRequest request{dynamics, r.t0, r.t1,   r.settings, variational, r.bounds, lanes,
                               batch,    init, finish, r.progress, differences, axes};
    switch (dynamics.system->dimension()) {
    case 2:
        return flow_map_engine::run_batches_for<2>(request);
    case 3:
        return flow_map_engine::run_batches_for<3>(request);
    case 4:
        return flow_map_engine::run_batches_for<4>(request);
    case 5:
        return flow_map_engine::run_batches_for<5>(request);
    case 6:
        return flow_map_engine::run_batches_for<6>(request);
    default:
        throw Error("flow map: dimension " + std::to_string(dynamics.system->dimension()) + " not compiled in");
    }
}

// The planar view of a system: a planar system as it is, or an n-D one on its slice (Dynamics::slice). Lanes'
// (x, y) are the slice's axes; the other components start at the slice's values; DF is the slice's 2 x 2 gradient.
class PlaneView {
  public:
    // `what` names the caller for the error on an n-D system without a slice.
    PlaneView(const Dynamics &dynamics, GradientMethod gradient, const char *what)
        : m_dimension(dynamics.system ? dynamics.system->dimension() : 2), m_slice(dynamics.slice) {
        if (m_dimension != 2 && !m_slice)
            throw Error(std::string(what) + ": system '" + dynamics.system->info().name + "' has dimension " +
                        std::to_string(m_dimension) + "; give the slice of its phase space the grid spans");
        if (m_slice) {
            if (m_slice->state.size() != m_dimension || m_slice->axes[0] >= m_dimension ||
                m_slice->axes[1] >= m_dimension || m_slice->axes[0] == m_slice->axes[1])
                throw Error(std::string(what) + ": the slice does not fit a system of dimension " +
                            std::to_string(m_dimension));
            m_axes = m_slice->axes;
            if (m_dimension != 2 && gradient == GradientMethod::auxiliary_grid)
                throw EngineSettingError(EngineSetting::gradient,
                                         "auxiliary-grid handles planar systems; system '" +
                                             dynamics.system->info().name + "' has dimension " +
                                             std::to_string(m_dimension) +
                                             ": use \"variational\" (SDK plugins derive the Jacobian)");
        }
    }
    // The InitFn of a planar fill: the fixed components first, then the axes from `fill`.
    InitFn init(std::function<void(std::size_t first, std::size_t n, double *xs, double *ys)> fill) const {
        if (!m_slice) return [fill](std::size_t first, std::size_t n, double *s) { fill(first, n, s, s + n); };
        return [fill, this](std::size_t first, std::size_t n, double *s) {
            for (unsigned i = 0; i < m_dimension; ++i) std::fill_n(s + i * n, n, m_slice->state[i]);
            fill(first, n, s + m_axes[0] * n, s + m_axes[1] * n);
        };
    }
    unsigned axis(std::size_t i) const { return m_axes[i]; }
    double x(const double *s, std::size_t n, std::size_t k) const { return s[m_axes[0] * n + k]; }
    double y(const double *s, std::size_t n, std::size_t k) const { return s[m_axes[1] * n + k]; }
    // The 2 x 2 gradient of lane k (row-major into out) and the log|det| that goes with it (NaN: from the entries).
    void gradient(const double *s, std::size_t n, std::size_t k, int exponent, double *out, double &log_det) const {
        const std::size_t f11 = m_dimension, NN = std::size_t{m_dimension} * m_dimension;
        log_det = s[(f11 + NN) * n + k];
        if (!m_slice) { // a planar system: DF as it is
            for (std::size_t q = 0; q < 4; ++q) out[q] = s[(f11 + q) * n + k];
            return;
        }
        if (m_dimension == 2) { // the slice, if any, is the whole plane: DF itself, in the axes' order
            const std::size_t a = m_axes[0], b = m_axes[1];
            out[0] = s[(f11 + 2 * a + a) * n + k];
            out[1] = s[(f11 + 2 * a + b) * n + k];
            out[2] = s[(f11 + 2 * b + a) * n + k];
            out[3] = s[(f11 + 2 * b + b) * n + k];
            return;
        }
        double dF[max_dimension * max_dimension];
        for (std::size_t q = 0; q < NN; ++q) dF[q] = s[(f11 + q) * n + k];
        slice_gradient(dF, m_dimension, m_axes, m_slice->tensor, exponent, log_det, out, log_det);
    }

  private:
    unsigned m_dimension;
    const Slice *m_slice;
    std::array<unsigned, 2> m_axes{0, 1};
};

// The earliest exit time of `count` lanes integrated from t0, forward or backward (NaN when none left).
double earliest_exit(const double *exit_time, std::size_t count, double t0) {
    double earliest = nan_value;
    for (std::size_t q = 0; q < count; ++q)
        if (std::isfinite(exit_time[q]) &&
            !(std::abs(exit_time[q] - t0) >= std::abs(earliest - t0))) // true while earliest is NaN
            earliest = exit_time[q];
    return earliest;
}

// Every grid point masked is an error, not an empty result: say why, with what to try.
void require_unmasked_points(const FlowMap &out, const IntegratorSettings &settings, const Dynamics &dynamics) {
    if (out.mask.empty() || std::any_of(out.mask.begin(), out.mask.end(), [](std::uint8_t m) { return m == 0; }))
        return;
    throw NumericalError("every one of the " + std::to_string(out.mask.size()) + " grid points was masked: " +
                         describe_masking(out.stats, settings, dynamics.system->has_jacobian()) +
                         "; check the grid, the time interval, the bounds and the system");
}

} // namespace

const char *to_string(ExitRule rule) { return rule == ExitRule::stop ? "stop" : "mask"; }

std::optional<Bounds> masking(const std::optional<Bounds> &bounds) {
    if (!bounds) return bounds;
    Bounds box = *bounds;
    box.exits = ExitRule::mask;
    return box;
}

std::size_t lanes_per_batch(const IntegratorSettings &settings) {
    return settings.method == "rosenbrock4" ? 1 : settings.batch;
}

std::string describe_masking(const IntegratorStats &stats, const IntegratorSettings &settings, bool has_jacobian) {
    if (stats.masked == 0) return std::string();
    std::string text =
        std::to_string(stats.masked) + " of " + std::to_string(stats.trajectories) + " trajectories masked (";
    const std::pair<const char *, std::uint64_t> reasons[] = {{"left the bounds", stats.masked_left_bounds},
                                                              {"blew up or became non-finite", stats.masked_non_finite},
                                                              {"hit the step limit", stats.masked_step_limit},
                                                              {"refused by the plugin", stats.masked_invalid_state},
                                                              {"failed the step's error test at the smallest sub-step "
                                                               "(integrator unstable / step too large)",
                                                               stats.masked_unstable}};
    bool first = true;
    for (const auto &[what, count] : reasons) {
        if (count == 0) continue;
        text += (first ? "" : ", ") + std::to_string(count) + " " + what;
        first = false;
    }
    text += ")";
    if (stats.masked_unstable > 0) {
        char step[32];
        std::snprintf(step, sizeof step, "%g", settings.step);
        text += "; " + settings.method + " in checked fixed steps (step = " + step +
                ") could not meet its step_tolerance on these trajectories even at 1/" +
                std::to_string(static_cast<long>(1.0 / min_step_fraction)) +
                " of the step: the explicit stepper is unstable or far too coarse there (stiff or very fast dynamics), "
                "not the trajectory; try \"adaptive\": true" +
                (has_jacobian ? std::string(", \"method\": \"rosenbrock4\" (stiff systems)") : std::string()) +
                " or a smaller \"step\"";
    }
    if (stats.masked_step_limit > 0) {
        text += "; " + settings.method + " reached its step limit (max_steps = " + std::to_string(settings.max_steps) +
                " attempted steps per batch, or a step below 1e-14 max(1, |t|))";
        if (settings.method != "rosenbrock4")
            text += has_jacobian ? ": the system may be stiff; try \"method\": \"rosenbrock4\" (implicit, uses the "
                                   "system's Jacobian) or a larger \"max_steps\""
                                 : ": the system may be stiff (rosenbrock4 would need its Jacobian); try a larger "
                                   "\"max_steps\" or looser tolerances";
        else
            text += ": try a larger \"max_steps\" or looser tolerances";
    }
    // Escape to infinity looks like blow-up, instability or stiffness to the stepper. Without a box nothing stops it.
    if ((stats.masked_non_finite | stats.masked_unstable | stats.masked_step_limit) > 0 &&
        stats.masked_left_bounds == 0 && stats.exited == 0)
        text += "; if trajectories escape (an open system: escape from a well, a dissipative system in backward "
                "time), set \"bounds\" around the region of interest: trajectories then stop where they leave it and "
                "are data (exit_time in fields.nc), at a fraction of the cost";
    if (stats.masked_left_bounds > 0)
        text += "; \"exits\": \"stop\" in \"bounds\" keeps trajectories that leave as data (stopped where they "
                "leave)";
    return text;
}

std::string describe_step_refinement(const IntegratorStats &stats, const IntegratorSettings &settings,
                                     bool has_jacobian) {
    if (stats.planned_steps == 0 || stats.steps <= 2 * stats.planned_steps) return std::string();
    char text[512];
    std::snprintf(text, sizeof text,
                  "%s in checked fixed steps (step = %g) took %llu steps and %llu rejected trials where the fixed "
                  "grid has %llu (%.1fx): the system has faster or stiffer dynamics than the step resolves; the "
                  "error test kept step_tolerance, but ",
                  settings.method.c_str(), settings.step, static_cast<unsigned long long>(stats.steps),
                  static_cast<unsigned long long>(stats.rejected_steps),
                  static_cast<unsigned long long>(stats.planned_steps),
                  static_cast<double>(stats.steps) / static_cast<double>(stats.planned_steps));
    return std::string(text) + "\"adaptive\": true" +
           (has_jacobian ? ", \"method\": \"rosenbrock4\" (stiff systems)" : "") +
           " or a smaller \"step\" may be faster";
}

nlohmann::json long_horizon_method(GradientMethod method) {
    switch (method) {
    case GradientMethod::variational:
        return {{"method", "renormalised variational equations"},
                {"detail", "DF is rescaled by exact powers of 2 whenever its largest entry leaves [1/2, 2^256] and "
                           "the exponent is carried, so DF never overflows; FTLE = (log mu2 + 2 e log 2) / (2|T|) "
                           "from the scaled DF; lambda2 and lambda1 are +Inf / 0 where they leave the double range"},
                {"det_dF", "Liouville: log|det DF| = integral of tr Dv along the trajectory"}};
    case GradientMethod::auxiliary_grid:
        return {{"method", "centred differences of positions"},
                {"detail", "DF = (F(+) - F(-)) / 2d cannot overflow: trajectories growing beyond 1e8 times their "
                           "initial scale are masked as blown up first"},
                {"det_dF", "from the entries of DF (compensated fma determinant)"}};
    case GradientMethod::none:
        break;
    }
    return {{"method", "none"}};
}

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
    masked_unstable += other.masked_unstable;
    exited += other.exited;
    planned_steps += other.planned_steps;
    renormalised += other.renormalised;
    fused_batches += other.fused_batches;
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
                          {"exited", exited},
                          {"masked_non_finite", masked_non_finite},
                          {"masked_step_limit", masked_step_limit},
                          {"masked_invalid_state", masked_invalid_state},
                          {"masked_unstable", masked_unstable},
                          {"planned_steps", planned_steps},
                          {"renormalised", renormalised},
                          {"fused_batches", fused_batches},
                          {"wall_seconds", wall_seconds}};
}

GradientMethod parse_gradient_method(const std::string &name) {
    if (name == "auxiliary-grid") return GradientMethod::auxiliary_grid;
    if (name == "variational") return GradientMethod::variational;
    if (name == "none") return GradientMethod::none;
    throw EngineSettingError(EngineSetting::gradient,
                             "unknown method \"" + name + "\"; expected auxiliary-grid, variational or none");
}

const char *to_string(EngineSetting setting) {
    static const char *const names[] = {"system", "method",    "engine", "rtol",     "atol",   "step",
                                        "batch",  "max_steps", "time",   "gradient", "offset", "grid"}; // enum order
    return names[static_cast<int>(setting)];
}

const char *to_string(GradientMethod method) {
    switch (method) {
    case GradientMethod::none:
        return "none";
    case GradientMethod::auxiliary_grid:
        return "auxiliary-grid";
    case GradientMethod::variational:
        return "variational";
    }
    return "?";
}

FlowMapRequest with_grid_offset(FlowMapRequest request, const Grid &grid, double fraction) {
    request.offset_x = fraction * grid.dx();
    request.offset_y = fraction * grid.dy();
    return request;
}

FlowMap compute_grid_flow_map(const FlowMapRequest &request, const Grid &grid) {
    if (grid.nx < 2 || grid.ny < 2)
        throw EngineSettingError(EngineSetting::grid, "the grid needs at least 2 points per direction (got " +
                                                          std::to_string(grid.nx) + " x " + std::to_string(grid.ny) +
                                                          ")");
    // The grid's points row-major (row = y), so neighbours in x share a batch.
    const std::size_t nx = grid.nx;
    const StartFn start = [&](std::size_t p, double &x, double &y) {
        x = grid.x(p % nx);
        y = grid.y(p / nx);
    };
    FlowMap out = flow_map_at_points(request, grid.size(), start);
    out.grid = grid;
    require_unmasked_points(out, request.settings, request.dynamics);
    return out;
}

// --- The flow map at arbitrary points (memory tiles, extractors' advection) ---

std::size_t points_per_batch(const FlowMapRequest &request) {
    if (request.gradient != GradientMethod::auxiliary_grid) return lanes_per_batch(request.settings);
    const std::size_t per_point = request.want_positions ? 5 : 4;
    return (lanes_per_batch(request.settings) + per_point - 1) / per_point;
}

namespace {

// The points' own lanes, one per point (gradient none or variational), into `out` (sized by flow_map_at_points).
IntegratorStats integrate_points(const FlowMapRequest &r, const PlaneView &plane, std::size_t count,
                                 const StartFn &start, bool positions, bool exits, FlowMap &out) {
    const bool variational = r.gradient == GradientMethod::variational;
    const InitFn init = plane.init([&](std::size_t first, std::size_t n, double *xs, double *ys) {
        for (std::size_t k = 0; k < n; ++k) start(first + k, xs[k], ys[k]);
    });
    const FinishFn finish = [&](std::size_t first, std::size_t n, const double *s, const std::uint8_t *mask,
                                const std::int32_t *exponent, const double *exit_time) {
        for (std::size_t k = 0; k < n; ++k) {
            const std::size_t p = first + k;
            out.mask[p] = mask[k];
            if (exits) out.exit_time[p] = exit_time[k];
            if (mask[k] != 0) continue;
            if (positions) {
                out.flow_x[p] = plane.x(s, n, k);
                out.flow_y[p] = plane.y(s, n, k);
            }
            if (variational) {
                plane.gradient(s, n, k, exponent[k], &out.dF[4 * p], out.log_det[p]);
                out.dF_exponent[p] = exponent[k];
            }
        }
    };
    return run_batches(r, variational, count, lanes_per_batch(r.settings), init, finish);
}

// Auxiliary grid (Farazmand & Haller 2012): a point's 4 neighbours (and its centre when positions are wanted) are
// consecutive lanes of one batch. Integrated in lockstep, they take identical steps, so their integration errors
// are strongly correlated and largely cancel in the centred differences; the difference control bounds what is
// left. The batch is rounded up to a whole number of points, and DF is written per batch: no auxiliary final
// states are kept.
IntegratorStats integrate_auxiliary_grid(const FlowMapRequest &r, const PlaneView &plane, std::size_t count,
                                         const StartFn &start, bool positions, bool exits, FlowMap &out) {
    const double offset_x = r.offset_x, offset_y = r.offset_y;
    const std::size_t per_point = positions ? 5 : 4;
    const std::size_t batch = points_per_batch(r) * per_point;
    const double offsets_x[5] = {offset_x, -offset_x, 0.0, 0.0, 0.0};
    const double offsets_y[5] = {0.0, 0.0, offset_y, -offset_y, 0.0};
    const InitFn init = plane.init([&](std::size_t first, std::size_t n, double *xs, double *ys) {
        double x = 0.0, y = 0.0;
        std::size_t started = std::numeric_limits<std::size_t>::max();
        for (std::size_t k = 0; k < n; ++k) {
            const std::size_t lane = first + k, p = lane / per_point, q = lane % per_point;
            if (p != started) start(started = p, x, y);
            xs[k] = x + offsets_x[q];
            ys[k] = y + offsets_y[q];
        }
    });
    const FinishFn finish = [&](std::size_t first, std::size_t n, const double *s, const std::uint8_t *mask,
                                const std::int32_t *, const double *exit_time) {
        const double *xs = s + plane.axis(0) * n, *ys = s + plane.axis(1) * n;
        for (std::size_t k = 0; k < n; k += per_point) {
            const std::size_t p = (first + k) / per_point;
            std::uint8_t m = 0;
            for (std::size_t q = 0; q < per_point; ++q) m |= mask[k + q];
            out.mask[p] = m;
            if (exits) // the point's own trajectory (the centre lane), else the earliest of its neighbours
                out.exit_time[p] = positions ? exit_time[k + 4] : earliest_exit(exit_time + k, per_point, r.t0);
            if (m != 0) continue;
            out.dF[4 * p + 0] = (xs[k] - xs[k + 1]) / (2.0 * offset_x);
            out.dF[4 * p + 1] = (xs[k + 2] - xs[k + 3]) / (2.0 * offset_y);
            out.dF[4 * p + 2] = (ys[k] - ys[k + 1]) / (2.0 * offset_x);
            out.dF[4 * p + 3] = (ys[k + 2] - ys[k + 3]) / (2.0 * offset_y);
            if (positions) {
                out.flow_x[p] = xs[k + 4];
                out.flow_y[p] = ys[k + 4];
            }
        }
    };
    const DifferenceControl differences{per_point, 1.0 / (2.0 * offset_x), 1.0 / (2.0 * offset_y)};
    return run_batches(r, false, per_point * count, batch, init, finish, differences);
}

} // namespace

FlowMap flow_map_at_points(const FlowMapRequest &request, std::size_t count, const StartFn &start, FlowMap reuse) {
    const GradientMethod gradient = request.gradient;
    const bool variational = gradient == GradientMethod::variational;
    check_flow_map_settings(request);
    const PlaneView plane(request.dynamics, gradient, "flow_map_at_points");
    const double offset_x = request.offset_x, offset_y = request.offset_y;
    if (gradient == GradientMethod::auxiliary_grid &&
        !(offset_x > 0.0 && std::isfinite(offset_x) && offset_y > 0.0 && std::isfinite(offset_y)))
        throw EngineSettingError(EngineSetting::offset, std::to_string(offset_x) + ", " + std::to_string(offset_y) +
                                                            " are not positive offsets");
    const bool positions = request.want_positions || gradient == GradientMethod::none;
    FlowMap out = std::move(reuse);
    out.grid = Grid{};
    out.dimension = 2;
    out.stats = IntegratorStats{};
    // assign() and clear() keep the buffers' capacity.
    out.mask.assign(count, 0);
    out.flow_x.clear();
    out.flow_y.clear();
    out.state.clear();
    out.dF.clear();
    out.dF_exponent.clear();
    out.log_det.clear();
    out.exit_time.clear();
    const bool exits = request.bounds && request.bounds->exits == ExitRule::stop;
    if (exits) out.exit_time.assign(count, nan_value);
    if (positions) {
        out.flow_x.assign(count, nan_value);
        out.flow_y.assign(count, nan_value);
    }
    if (gradient != GradientMethod::none) out.dF.assign(4 * count, nan_value);
    if (variational) {
        out.dF_exponent.assign(count, 0);
        out.log_det.assign(count, nan_value);
    }
    if (count == 0) return out;
    out.stats = gradient == GradientMethod::auxiliary_grid
                    ? integrate_auxiliary_grid(request, plane, count, start, positions, exits, out)
                    : integrate_points(request, plane, count, start, positions, exits, out);
    return out;
}

FlowMap flow_map_at_points(const FlowMapRequest &request, const std::vector<double> &x0,
                           const std::vector<double> &y0) {
    if (x0.size() != y0.size())
        throw Error("flow_map_at_points: " + std::to_string(x0.size()) + " x coordinates but " +
                    std::to_string(y0.size()) + " y coordinates");
    return flow_map_at_points(request, x0.size(), [&](std::size_t k, double &x, double &y) {
        x = x0[k];
        y = y0[k];
    });
}

FlowMap flow_map_of_states(const FlowMapRequest &request, std::size_t count, const StateStartFn &start) {
    if (request.gradient == GradientMethod::auxiliary_grid)
        throw EngineSettingError(EngineSetting::gradient, "the auxiliary grid is planar only; the flow map of whole "
                                                          "states takes \"variational\" or \"none\"");
    const bool variational = request.gradient == GradientMethod::variational;
    const Dynamics &dynamics = request.dynamics;
    check_flow_map_settings(request);
    const std::size_t N = dynamics.system->dimension(), NN = N * N;
    FlowMap out;
    out.dimension = static_cast<unsigned>(N);
    out.state.assign(N * count, nan_value);
    out.mask.assign(count, 0);
    if (variational) {
        out.dF.assign(NN * count, nan_value);
        out.dF_exponent.assign(count, 0);
        out.log_det.assign(count, nan_value);
    }
    if (count == 0) return out;
    const InitFn init = [&](std::size_t first, std::size_t n, double *s) {
        std::vector<double> state(N);
        for (std::size_t k = 0; k < n; ++k) {
            start(first + k, state.data());
            for (std::size_t i = 0; i < N; ++i) s[i * n + k] = state[i];
        }
    };
    const FinishFn finish = [&](std::size_t first, std::size_t n, const double *s, const std::uint8_t *mask,
                                const std::int32_t *exponent, const double *) {
        for (std::size_t k = 0; k < n; ++k) {
            const std::size_t p = first + k;
            out.mask[p] = mask[k];
            if (mask[k] != 0) continue;
            for (std::size_t i = 0; i < N; ++i) out.state[N * p + i] = s[i * n + k];
            if (variational) {
                for (std::size_t q = 0; q < NN; ++q) out.dF[NN * p + q] = s[(N + q) * n + k];
                out.dF_exponent[p] = exponent[k];
                out.log_det[p] = s[(N + NN) * n + k];
            }
        }
    };
    out.stats = run_batches(request, variational, count, lanes_per_batch(request.settings), init, finish);
    return out;
}

} // namespace geobarrier
