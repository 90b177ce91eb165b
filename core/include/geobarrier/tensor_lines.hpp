// Tensor lines: trajectories of r' = v(r) for an orientation-free LineField, parametrised by arc length (the
// paper's eqs. `strline` and `shrline`), many at once in lockstep lanes on the core's Runge-Kutta tableaux
// (rk_tableaux.hpp), each lane keeping its tangent consistent with its previous step. Stops are reported, never NaN.
#ifndef GEOBARRIER_TENSOR_LINES_HPP
#define GEOBARRIER_TENSOR_LINES_HPP

#include <geobarrier/line_field.hpp>

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace geobarrier {

// Why a tensor line ended.
enum class StopReason {
    domain_edge, // reached the edge of the grid's box
    masked,      // entered a cell touching a masked grid point
    singular,    // entered a cell touching a singular point (lambda2 - lambda1 small), or the field cancelled
    max_length,  // reached the requested maximum length
    closed,      // came back to its start point (the last point then equals the first)
    max_steps,   // safety net: the step budget ran out (step size collapsed)
    observer     // the caller's TensorLineObserver stopped it
};
const char *to_string(StopReason reason);

// How tensor lines are integrated. The line fields are bilinear in each grid cell and only continuous across cell
// edges, so a method's order shows only within a cell: fixed steps of half a cell with the midpoint rule put the
// lines within a small fraction of a grid spacing of the adaptive 5th-order ones at a third of the field
// evaluations (measured in docs/extractor-measurements.md, "Tensor-line integration"). The adaptive pairs remain for
// comparison and for fields where the steps must follow the tolerance.
enum class TensorLineMethod {
    midpoint, // fixed steps of max_step, explicit midpoint rule: 2 field evaluations per step
    rk4,      // fixed steps of max_step, classical Runge-Kutta: 4 per step
    bs32,     // adaptive Bogacki-Shampine 3(2) (rtol, atol): 3 per accepted step
    dopri5    // adaptive Dormand-Prince 5(4) (rtol, atol): 6 per accepted step
};
const char *to_string(TensorLineMethod method);
TensorLineMethod tensor_line_method(const std::string &name); // by to_string's name; std::invalid_argument if none

struct TensorLineSettings {
    TensorLineMethod method = TensorLineMethod::midpoint;
    double max_length = std::numeric_limits<double>::infinity(); // arc length per direction
    double rtol = 1e-6;                                          // relative tolerance of a step (adaptive methods)
    double atol = 1e-8;                                          // absolute tolerance of a step (state units)
    double max_step = 0.0;     // 0: half the smaller grid spacing, so no cell is skipped; the fixed methods' step
    double initial_step = 0.0; // adaptive methods: 0 = a tenth of the smaller grid spacing
    double min_step = 0.0;     // 0: 1e-4 of the smaller grid spacing; how close a stop is located
    std::size_t max_steps = 1000000;
    bool detect_closure = true;      // stop with `closed` when the line returns to its start point
    double closure_distance = 0.0;   // 0: half the smaller grid spacing
    double closure_min_length = 0.0; // 0: 10 grid spacings; shorter returns are not closures
};

// One direction of a tensor line: points (x, y interleaved; the first is the seed), their arc lengths from the
// seed (empty where the caller asked for ArcLengths::drop), and why it stopped. Every stored value is finite.
struct TensorLine {
    std::vector<double> xy;
    std::vector<double> s;
    StopReason stop = StopReason::max_length;
    std::size_t size() const { return xy.size() / 2; }
};

// Stops lines early: called after every accepted step of a line, from (ax, ay) to (bx, by) with arc length s at b
// (b is already the line's last point); true stops the line there with StopReason::observer. Called from several
// threads at once, never twice at once for the same line.
class TensorLineObserver {
  public:
    virtual ~TensorLineObserver() = default;
    virtual bool stop_after(std::size_t line, double ax, double ay, double bx, double by, double s) = 0;
};

// Integrates from (x0, y0) with the initial tangent aligned to (dir_x, dir_y). If the field is not usable at
// the seed the line holds only the seed and stops with that status (domain_edge / masked / singular).
TensorLine integrate_tensor_line(const LineField &field, double x0, double y0, double dir_x, double dir_y,
                                 const TensorLineSettings &settings = {});

// Many lines at once: starts holds x0, y0, dir_x, dir_y for each line; line k of the result is what
// integrate_tensor_line gives for start k (the same numbers: lanes do not interact). Lines run in lockstep lanes,
// so that a stage's field evaluations vectorise, and groups of lanes run on the OpenMP threads.
std::vector<TensorLine> integrate_tensor_lines(const LineField &field, const std::vector<double> &starts,
                                               const TensorLineSettings &settings = {},
                                               TensorLineObserver *observer = nullptr);

// Both ways from a seed, joined into one polyline: the backward branch reversed, then the forward branch.
// The forward branch starts along the field's stored vector at the seed (interpolated, aligned to +x when
// there is no better reference).
struct TwoWayLine {
    std::vector<double> xy;                            // x, y interleaved
    std::vector<double> s;                             // arc length from the first point (unless dropped)
    std::size_t seed_index = 0;                        // index of the seed point in the polyline
    StopReason stop_backward = StopReason::max_length; // at the first point
    StopReason stop_forward = StopReason::max_length;  // at the last point
    bool closed = false; // the forward branch closed on itself (then there is no backward branch)
    std::size_t size() const { return xy.size() / 2; }
};
TwoWayLine integrate_tensor_line_both_ways(const LineField &field, double x0, double y0,
                                           const TensorLineSettings &settings = {});
// The same from every seed (x, y interleaved), in lockstep lanes.
std::vector<TwoWayLine> integrate_tensor_lines_both_ways(const LineField &field, const std::vector<double> &seeds,
                                                         const TensorLineSettings &settings = {});
// Whether the lines keep each point's arc length (TwoWayLine::s). A caller that needs only the points drops them: on
// long lines (the hyperbolic extractor's, 18 million points at 1000 x 1000) they are a third of what is written.
// (An argument rather than a TensorLineSettings member, so that the settings' layout, which extractors linking the
// core library compile in, stays that of the 0.1 series.)
enum class ArcLengths { keep, drop };
std::vector<TwoWayLine> integrate_tensor_lines_both_ways(const LineField &field, const std::vector<double> &seeds,
                                                         const TensorLineSettings &settings, ArcLengths arc_lengths);

} // namespace geobarrier

#endif // GEOBARRIER_TENSOR_LINES_HPP
