// The flow map engine: integrates sets of initial conditions from t0 to t1
// (t1 < t0 is backward time), optionally with the variational equations
// DF' = Dv(x, t) DF, DF(t0) = I.
//
// Points are integrated in lockstep batches of `batch` lanes in structure-of-arrays
// layout: one batched right-hand-side call (and Jacobian call) per stage, one
// forcing evaluation per stage time, with the step size (when adaptive)
// controlled by the worst lane of the batch, so every lane meets the tolerances.
// OpenMP runs batches in parallel. Two engines: "lockstep" (the default), our
// explicit Runge-Kutta kernel whose passes over a batch are vectorised loops, and
// "odeint", Boost.Odeint's steppers on the same batches (batch = 1 is classic
// one-trajectory-at-a-time stepping); rosenbrock4 always runs in Boost.Odeint.
#ifndef GEOBARRIER_FLOW_MAP_HPP
#define GEOBARRIER_FLOW_MAP_HPP

#include <geobarrier/grid.hpp>
#include <geobarrier/plugin.hpp>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace geobarrier {

// These defaults are the library's; an experiment's defaults are its quality preset (experiment.hpp).
struct IntegratorSettings {
    // dop853 | dopri5 | rkf78 | rk4 | rosenbrock4 (stiff; needs the system's Jacobian; always Boost.Odeint)
    std::string method = "dopri5";
    std::string engine = "lockstep"; // lockstep (our kernel) | odeint (Boost.Odeint's steppers; no dop853)
    bool adaptive = true;            // false: fixed steps (rk4 always); rosenbrock4 is always adaptive
    double rtol = 1e-8;
    double atol = 1e-10;
    // Fixed steps: the largest step; the run takes ceil(|t1 - t0| / step) equal steps landing on t1. Adaptive: the
    // first trial step.
    double step = 0.01;
    std::size_t batch = 64;          // lanes in lockstep; 64 was fastest of 1..64 on a 400x400 Duffing grid
    std::size_t max_steps = 1000000; // per batch; lanes still running after it are masked
    // Lockstep, fixed steps of rk4 or dop853: take each step with the system plugin's fused step (ABI 1.2
    // gb_system_vtable.advance, all stages in registers) when it has one; the same numbers to rounding, several
    // times faster. false: always the stage-by-stage kernel (tests compare the two).
    bool fused = true;
    // Fixed steps of a tableau with an error estimate (dop853, dopri5, rkf78; not rk4), when > 0: every step's
    // embedded error estimate of the state must stay below step_tolerance (1 + |state|) (norm-wise, the largest
    // component); a step that fails is split into equal sub-steps, down to step * min_step_fraction, that land back
    // on the fixed steps' grid t0 + i step (flow_map.cpp, run_checked). On a smooth system every step passes and the
    // run is exactly the unchecked one; where the step is too large (fast or stiff dynamics, an unstable explicit
    // step) it is refined instead of blowing up, and a lane that fails even the smallest sub-step is masked
    // mask_unstable. Separate from rtol/atol, which keep their meaning for adaptive steps. The quality presets set
    // it; 0 (off) here so that code asking for plain fixed steps gets them.
    double step_tolerance = 0.0;
};

// The largest state dimension the engine integrates (its kernels are compiled for each dimension 2 .. max_dimension;
// the variational equations of dimension N carry N + N^2 + 1 components per lane). Systems of higher dimension are
// refused with an error naming /system/plugin.
constexpr unsigned max_dimension = 6;

// Checked fixed steps never go below step * min_step_fraction: a lane whose error still exceeds the tolerance there
// is masked mask_unstable (the explicit stepper is unstable at any step the run can afford; try rosenbrock4).
constexpr double min_step_fraction = 1.0 / 1024;

// rtol below this cannot be honoured in double precision (each stage's rounding error is ~1e-16 |x|, and a step
// sums several): the engine uses max(rtol, min_rtol), and the experiment parser warns when it clamps.
constexpr double min_rtol = 1e-14;

// Lanes per lockstep batch for these settings: `batch`, except for rosenbrock4, whose Boost.Odeint stepper solves a
// dense linear system over the whole batch state (cost cubic in the lanes), so it integrates one lane (or one
// auxiliary-grid group) at a time.
std::size_t lanes_per_batch(const IntegratorSettings &settings);

// What becomes of a trajectory that leaves the bounds box.
enum class ExitRule {
    mask, // masked (mask_left_bounds): its final state and DF are unusable
    // Stopped where it left: the flow map is that of the system stopped on leaving the domain, F(x0) = x(t_exit)
    // and DF = DF(t_exit, t0), and the point is data, not masked; the results carry t_exit (exit_time). Open systems
    // (escape from a well, every dissipative system in backward time) keep the whole grid this way, and the boundary
    // between escaping and captured points, along which DF stretches most, is a barrier like any other.
    stop
};

// An optional box. It limits state components 0 and 1, or a slice's two axes (Dynamics::slice). What happens to
// trajectories that leave it is `exits` (the engine's default masks them; experiments default to stop).
struct Bounds {
    double x_min, x_max, y_min, y_max;
    ExitRule exits = ExitRule::mask;
};
const char *to_string(ExitRule rule);
// The same box with trajectories that leave it masked: for callers that must know a point left (advection of
// curves and tracers), whatever the experiment's rule for its grid.
std::optional<Bounds> masking(const std::optional<Bounds> &bounds);

// The system and its forcing (may be null when unused). Systems of dimension above 2 are seen by the planar functions
// below (compute_grid_flow_map, flow_map_at_points) on a slice: their (x, y) are the slice's axes, the other
// components start at the slice's fixed values, and their DF is the slice's 2 x 2 gradient (Slice::tensor).
// flow_map_of_states integrates whole states.
struct Dynamics {
    const System *system = nullptr;
    const Forcing *forcing = nullptr;
    const Slice *slice = nullptr; // required for systems of dimension > 2 in the planar functions; else ignored
};

// The engine's settings, by the engine's own names: a bad one is reported as an EngineSettingError naming it. The
// engine does not know where its settings came from; the experiment layer maps each to its JSON path
// (experiment.hpp, json_path_of).
enum class EngineSetting {
    system,    // the dynamical system (missing, or of a dimension the engine does not handle)
    method,    // IntegratorSettings::method
    engine,    // IntegratorSettings::engine
    rtol,      // IntegratorSettings::rtol
    atol,      // IntegratorSettings::atol
    step,      // IntegratorSettings::step
    batch,     // IntegratorSettings::batch
    max_steps, // IntegratorSettings::max_steps
    time,      // t0, t1
    gradient,  // the gradient method
    offset,    // the auxiliary-grid offset
    grid       // the grid's points
};
const char *to_string(EngineSetting setting);

// A setting the engine cannot work with. what() reads "<setting>: <message>" (e.g. "rtol: 1.000000 must be between
// 0 and 1 (exclusive)"); message() is the part after the setting's name.
class EngineSettingError : public std::invalid_argument {
  public:
    EngineSettingError(EngineSetting setting, const std::string &message)
        : std::invalid_argument(std::string(to_string(setting)) + ": " + message), m_setting(setting),
          m_message(message) {}
    EngineSetting setting() const { return m_setting; }
    const std::string &message() const { return m_message; }

  private:
    EngineSetting m_setting;
    std::string m_message;
};

// Totals over all trajectories of a stage, for the manifest.
struct IntegratorStats {
    std::uint64_t trajectories = 0;
    std::uint64_t batches = 0;
    std::uint64_t steps = 0;           // accepted steps, summed over batches
    std::uint64_t rejected_steps = 0;  // summed over batches
    std::uint64_t rhs_evaluations = 0; // lane right-hand-side evaluations (batch calls x lanes)
    std::uint64_t masked = 0;          // trajectories masked for any reason
    std::uint64_t masked_left_bounds = 0, masked_non_finite = 0, masked_step_limit = 0, masked_invalid_state = 0;
    std::uint64_t masked_unstable = 0; // checked fixed steps: failed the error test at the smallest sub-step
    std::uint64_t exited = 0;          // ExitRule::stop: trajectories stopped on leaving the bounds (not masked)
    std::uint64_t planned_steps = 0;   // fixed steps: the steps of the fixed grid, summed over batches (0: adaptive)
    std::uint64_t renormalised = 0;    // variational: trajectories whose DF left [1/2, 2^256] and was rescaled
    std::uint64_t fused_batches = 0;   // batches the system plugin's fused step integrated (ABI 1.2 advance)
    double wall_seconds = 0.0;

    void add(const IntegratorStats &other);
    nlohmann::json to_json() const;
};

// Called with (done, total) work units from the thread that finished them;
// must be cheap and thread-safe.
using ProgressFn = std::function<void(std::size_t done, std::size_t total)>;

// How the gradient of the flow map is computed.
enum class GradientMethod {
    none,           // positions only
    auxiliary_grid, // centred differences of 4 neighbours at +-offset_x, +-offset_y (planar only)
    variational     // DF from the variational equations (needs the system's Jacobian)
};
GradientMethod parse_gradient_method(const std::string &name); // throws EngineSettingError (gradient)
const char *to_string(GradientMethod method);

// What every entry point of the engine integrates, and how: one aggregate with the engine's defaults, so that a
// caller names only what it sets, in the order of need (FlowMapRequest r{dynamics, t0, t1, settings, gradient}; the
// auxiliary grid's offsets, which no other method uses, last; in C++20, designated initialisers). What differs between
// the entry points is only where the points start (a grid, a callback, two coordinate vectors, whole states), which is
// why they stay separate functions below.
struct FlowMapRequest {
    // Every member has a default initialiser, so that brace-initialising the first few warns of none missing.
    Dynamics dynamics = {};
    double t0 = 0.0, t1 = 0.0; // t1 < t0 is backward time
    IntegratorSettings settings = {};
    GradientMethod gradient = GradientMethod::none;
    // Integrate the positions F(x0) even where the gradient method does not produce them (the auxiliary grid, at the
    // cost of a fifth lane per point). Gradient none always has them; the variational equations carry them anyway
    // but keep them only when asked.
    bool want_positions = false;
    std::optional<Bounds> bounds = std::nullopt; // none: no box
    ProgressFn progress = {};                    // none: no progress reports
    // The auxiliary grid's neighbours at +-offset_x, +-offset_y, in the plane's own units (a grid's caller passes a
    // fraction of its spacing: offset dx, offset dy). Unused by the other gradient methods.
    double offset_x = 0.0, offset_y = 0.0;
};

// The request with the auxiliary grid's offsets a fraction of the grid's spacing (fraction dx, fraction dy): the
// experiment's "offset" (Experiment::aux_offset) for a grid's points.
FlowMapRequest with_grid_offset(FlowMapRequest request, const Grid &grid, double fraction);

// What every entry point returns; which members are filled depends on the entry point and the request, the others are
// empty. Points keep the order in which they were given.
struct FlowMap {
    Grid grid;              // compute_grid_flow_map: the grid; else default
    unsigned dimension = 2; // the side of DF: 2 for the planar entry points, the system's for flow_map_of_states
    // The planar entry points: final positions in the plane (the slice's axes), when asked for (or gradient none).
    std::vector<double> flow_x, flow_y;
    std::vector<double> state; // flow_map_of_states: final states, dimension per point (NaN where masked)
    // With a gradient: dimension^2 per point, row-major (planar: F11 F12 F21 F22), NaN where masked; see dF_exponent.
    std::vector<double> dF;
    // Variational only. On long horizons DF leaves the double range (|DF| ~ e^{FTLE |T|}); the engine then carries
    // it renormalised, and DF = 2^dF_exponent[k] * dF. dF_exponent is 0 wherever DF itself fits in a double.
    std::vector<std::int32_t> dF_exponent;
    // Variational only: log|det DF| by Liouville's formula, the integral of tr Dv along the trajectory. Exact for
    // area-preserving systems, and accurate where det DF computed from the entries is lost to cancellation.
    std::vector<double> log_det;
    std::vector<std::uint8_t> mask; // MaskBits per point
    // The planar entry points with bounds whose rule is ExitRule::stop: when each point's trajectory left the box
    // (NaN: it never did, the point is captured); empty otherwise. Auxiliary grid without positions: the earliest of
    // its 4 neighbours.
    std::vector<double> exit_time;
    IntegratorStats stats;
};

// The flow map (and its gradient) over the grid's points in row order (row = y). Throws NumericalError, naming the
// reasons (and, for a step limit, the stepper and what to try), when every grid point is masked.
FlowMap compute_grid_flow_map(const FlowMapRequest &request, const Grid &grid);

// Where point k of a set starts: fills (x, y).
using StartFn = std::function<void(std::size_t k, double &x, double &y)>;

// The flow map and its gradient at `count` arbitrary points (memory tiles, extractors' advection): point k starts
// where `start` says, lanes of neighbouring k share a batch, and the auxiliary-grid gradient uses the neighbours at
// +-offset_x, +-offset_y with the difference-aware error control. compute_grid_flow_map is this function over a grid's
// points in row order; over the points [first, first + count) of that order, with `first` a multiple of
// points_per_batch, it gives the same numbers for those points bit for bit (the memory tiles of the runner rest on
// this). Unlike compute_grid_flow_map, every point masked is a result here, not an error. `reuse` lends its buffers to
// the result (a previous result, say): repeated calls then allocate, and fault in, no new memory.
FlowMap flow_map_at_points(const FlowMapRequest &request, std::size_t count, const StartFn &start, FlowMap reuse = {});

// The same at the points (x0[k], y0[k]), the two vectors of equal length (advection of given points). Points next to
// each other share a batch, so pass neighbours together.
FlowMap flow_map_at_points(const FlowMapRequest &request, const std::vector<double> &x0, const std::vector<double> &y0);

// The flow map of whole states of a system of any dimension 2 .. max_dimension: point k starts at the state `start`
// writes (dimension values), and the result holds every component of the final state (FlowMap::state) and, with the
// variational gradient, the whole n x n DF. Dynamics::slice, if any, only says which two components the bounds box
// limits (else 0 and 1). The auxiliary grid is planar only (refused: use the variational equations); want_positions
// and the offsets are unused. Points next to each other share a batch. Every point masked is a result, not an error.
using StateStartFn = std::function<void(std::size_t k, double *state)>;
FlowMap flow_map_of_states(const FlowMapRequest &request, std::size_t count, const StateStartFn &start);

// The checks every entry point of the engine makes before it integrates anything, for a caller that wants its
// settings refused before it starts (the experiment layer, at resolve time): the request's dynamics, times, settings
// and gradient (each entry point adds its own: the auxiliary grid's offsets, the grid's size, planar-only gradients).
// Throws EngineSettingError (Error when there is no system).
void check_flow_map_settings(const FlowMapRequest &request);

// One line on why trajectories were masked, with the counts per reason; when the step limit is among them, it names
// the stepper and suggests rosenbrock4 (stiff systems) or a larger max_steps. Empty when nothing was masked.
std::string describe_masking(const IntegratorStats &stats, const IntegratorSettings &settings, bool has_jacobian);

// Checked fixed steps that needed many more steps than the fixed grid (more than twice): one line naming the stepper,
// the step and what to try instead (a smaller step, adaptive, rosenbrock4 for stiff systems); else empty.
std::string describe_step_refinement(const IntegratorStats &stats, const IntegratorSettings &settings,
                                     bool has_jacobian);

// How the gradient of the flow map survives long horizons, for the manifest: the method and its details.
nlohmann::json long_horizon_method(GradientMethod method);

// Points per lockstep batch of flow_map_at_points for this request (see there): the alignment of bit-identical tiles.
// Reads the request's settings (batch), gradient and want_positions (the auxiliary grid's lanes per point).
std::size_t points_per_batch(const FlowMapRequest &request);

} // namespace geobarrier

#endif // GEOBARRIER_FLOW_MAP_HPP
