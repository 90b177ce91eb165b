// Tensor lines: trajectories of r' = v(r) for an orientation-free LineField, parametrised by arc length (the
// paper's eqs. `strline` and `shrline`), integrated with an adaptive Cash–Karp 5(4) pair while keeping the
// tangent consistent with the previous step. Stops are reported, never NaN.
#ifndef GEOBARRIER_TENSOR_LINES_HPP
#define GEOBARRIER_TENSOR_LINES_HPP

#include <geobarrier/line_field.hpp>

#include <cstddef>
#include <limits>
#include <vector>

namespace geobarrier {

// Why a tensor line ended.
enum class StopReason {
    domain_edge, // reached the edge of the grid's box
    masked,      // entered a cell touching a masked grid point
    singular,    // entered a cell touching a singular point (lambda2 - lambda1 small), or the field cancelled
    max_length,  // reached the requested maximum length
    closed,      // came back to its start point (the last point then equals the first)
    max_steps    // safety net: the step budget ran out (step size collapsed)
};
const char *to_string(StopReason reason);

struct TensorLineSettings {
    double max_length = std::numeric_limits<double>::infinity(); // arc length per direction
    double rtol = 1e-6;                                          // relative tolerance of a step
    double atol = 1e-8;                                          // absolute tolerance of a step (state units)
    double max_step = 0.0;     // 0: half the smaller grid spacing, so no cell is skipped
    double initial_step = 0.0; // 0: a tenth of the smaller grid spacing
    double min_step = 0.0;     // 0: 1e-4 of the smaller grid spacing; how close a stop is located
    std::size_t max_steps = 1000000;
    bool detect_closure = true;      // stop with `closed` when the line returns to its start point
    double closure_distance = 0.0;   // 0: half the smaller grid spacing
    double closure_min_length = 0.0; // 0: 10 grid spacings; shorter returns are not closures
};

// One direction of a tensor line: points (x, y interleaved; the first is the seed), their arc lengths from the
// seed, and why it stopped. Every stored value is finite.
struct TensorLine {
    std::vector<double> xy;
    std::vector<double> s;
    StopReason stop = StopReason::max_length;
    std::size_t size() const { return s.size(); }
};

// Integrates from (x0, y0) with the initial tangent aligned to (dir_x, dir_y). If the field is not usable at
// the seed the line holds only the seed and stops with that status (domain_edge / masked / singular).
TensorLine integrate_tensor_line(const LineField &field, double x0, double y0, double dir_x, double dir_y,
                                 const TensorLineSettings &settings = {});

// Both ways from a seed, joined into one polyline: the backward branch reversed, then the forward branch.
// The forward branch starts along the field's stored vector at the seed (interpolated, aligned to +x when
// there is no better reference).
struct TwoWayLine {
    std::vector<double> xy;                            // x, y interleaved
    std::vector<double> s;                             // arc length from the first point
    std::size_t seed_index = 0;                        // index of the seed point in the polyline
    StopReason stop_backward = StopReason::max_length; // at the first point
    StopReason stop_forward = StopReason::max_length;  // at the last point
    bool closed = false; // the forward branch closed on itself (then there is no backward branch)
    std::size_t size() const { return s.size(); }
};
TwoWayLine integrate_tensor_line_both_ways(const LineField &field, double x0, double y0,
                                           const TensorLineSettings &settings = {});

} // namespace geobarrier

#endif // GEOBARRIER_TENSOR_LINES_HPP
