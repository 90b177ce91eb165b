// What the flow-map engine's translation units share (private to the core): one run of batches described by a
// BatchRequest, the integrator method parsed once, and the engine of each dimension, compiled in its own unit
// (flow_map_dim2.cpp .. flow_map_dim6.cpp, from the templates of batch_integrator.hpp).
#pragma once

#include <geobarrier/flow_map.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

namespace geobarrier::flow_map_engine {

// Auxiliary-grid batches: every `per_point` consecutive lanes are the neighbours (+dx, -dx, +dy, -dy[, centre]) of
// one grid point. The error norm then also covers the centred differences (F(+) - F(-)) / 2d, so the tolerances
// bound the error of the gradient the user asked for, as they do for DF in the variational equations, and not
// only the error of the positions (with atol 1e-4 and d ~ 1e-6 a position-only norm leaves the difference
// quotient's error unbounded). per_point = 0: plain trajectories.
struct DifferenceControl {
    std::size_t per_point = 0;
    double inv_2dx = 0.0, inv_2dy = 0.0;
};

// Fills the initial states of lanes [first, first + n): component i of lane k at start[i * n + k].
using InitFn = std::function<void(std::size_t first, std::size_t n, double *start)>;
// Receives the final states (SoA, ld = n) and masks of lanes [first, first + n).
// With the variational equations, `exponent` gives each lane's DF scale (see BatchIntegrator::exponent);
// `exit_time` says when each lane left the bounds (NaN: never, or no bounds).
using FinishFn = std::function<void(std::size_t first, std::size_t n, const double *state, const std::uint8_t *mask,
                                    const std::int32_t *exponent, const double *exit_time)>;

// One run of the engine: `lanes` trajectories from t0 to t1, integrated in batches of `batch` consecutive lanes.
// bound_axes: the state components the bounds box limits (the slice's axes, else 0 and 1).
struct BatchRequest {
    const Dynamics &dynamics;
    double t0, t1;
    const IntegratorSettings &settings;
    bool variational;
    const std::optional<Bounds> &bounds;
    std::size_t lanes, batch;
    const InitFn &init;
    const FinishFn &finish;
    const ProgressFn &progress;
    DifferenceControl differences;
    std::array<unsigned, 2> bound_axes;
};

enum class Method { dopri5, rkf78, rk4, rosenbrock4, dop853 };

enum class Engine { lockstep, odeint };

// IntegratorSettings::method and ::engine parsed; EngineSettingError for an unknown name.
Method parse_method(const std::string &name);
Engine parse_engine(const std::string &name);

// Integrates the request's lanes with the engine for systems of dimension N, batches in parallel (OpenMP). The first
// exception thrown in any batch stops the remaining batches and is rethrown here. Specialised for N = 2 ..
// max_dimension, each in flow_map_dim<N>.cpp.
template <unsigned N> IntegratorStats run_batches_for(const BatchRequest &request);

} // namespace geobarrier::flow_map_engine
