// Polyline utilities shared by the barrier extractors and validation products (length, resampling, sampling grid
// fields along a curve, shoelace area) and curve advection with adaptive point insertion, which measures the true
// length of an advected barrier l(gamma_t1) (paper eqs. `rel_stretch`, `rel_def`) without trusting a shortcut.
#ifndef GEOBARRIER_CURVES_HPP
#define GEOBARRIER_CURVES_HPP

#include <geobarrier/flow_map.hpp>
#include <geobarrier/grid.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

namespace geobarrier {

// Polylines are x, y interleaved: x0, y0, x1, y1, ... A closed curve does not repeat its first point; `closed`
// adds the segment from the last point back to the first.

double polyline_length(const std::vector<double> &xy, bool closed = false);
// Arc length at each point from the first (size n; with `closed`, n + 1: the last entry is the full length).
std::vector<double> cumulative_length(const std::vector<double> &xy, bool closed = false);
// Points spaced evenly in arc length, at most `spacing` apart (to 1e-9 relative), keeping both ends of an open curve.
// A spacing of length / N gives N parts in every build: the count does not hinge on the last bit of the quotient.
std::vector<double> resample_polyline(const std::vector<double> &xy, double spacing, bool closed = false);
// Enclosed signed area (shoelace formula), positive for counter-clockwise curves; the curve is taken as closed.
double shoelace_area(const std::vector<double> &xy);

// Bilinear interpolation of a grid field at (x, y); NaN outside the box or when a corner is masked (any bit of
// mask & masked_by) or not finite. `mask` may be empty.
double sample_field(const Grid &grid, const std::vector<double> &field, const std::vector<std::uint8_t> &mask, double x,
                    double y, std::uint8_t masked_by = 0xff);
// sample_field at every point of a polyline.
std::vector<double> sample_along(const Grid &grid, const std::vector<double> &field,
                                 const std::vector<std::uint8_t> &mask, const std::vector<double> &xy,
                                 std::uint8_t masked_by = 0xff);
// One or two grid fields at every point of a polyline in one pass: `fields` holds `components` (1 or 2) values per
// grid point (point p's at components * p); outputs[f] is resized to the polyline's point count and filled with
// field f's values, each exactly sample_field's with an empty mask (a masked point is given as NaN in its field).
// One pass finds each point's cell once and reads both fields' corners from the same cache lines: the hyperbolic
// extractor samples d_g and log lambda1 at the ~18 million points of W's strainlines this way, where two
// sample_along calls missed the cache twice.
void sample_interleaved_along(const Grid &grid, const std::vector<double> &fields, std::size_t components,
                              const std::vector<double> &xy, std::vector<double> *outputs);

// Statistics of point values along a polyline (values.size() == number of points). NaN values are skipped:
// `integral` (trapezoidal, int f ds) and `mean` (integral / covered length) use only segments with two finite
// ends; `covered_length` is their total length.
struct CurveStats {
    double integral = 0.0, mean = 0.0, max = 0.0, min = 0.0;
    double covered_length = 0.0;
    std::size_t finite_points = 0;
};
CurveStats curve_statistics(const std::vector<double> &xy, const std::vector<double> &values, bool closed = false);
// The same from the lengths of the curve's segments (segment k joins point k to point (k + 1) mod n; `segments` is
// n - 1 for an open curve, n for a closed one), bit for bit: a caller that measures many pieces of one long polyline
// (the hyperbolic extractor's strainline segments) computes each length once instead of once per statistic.
CurveStats curve_statistics(const double *values, std::size_t n, const double *segment_lengths, std::size_t segments);
// The lengths of a polyline's segments, point k to point k + 1 (and the last back to the first when `closed`):
// their sum in order is polyline_length, their running sum cumulative_length.
std::vector<double> segment_lengths(const std::vector<double> &xy, bool closed = false);
// The same for points first..last of an interleaved polyline only, into out[first..last - 1]: a caller that needs
// the lengths of some stretches of a long line (the strainline pieces with d_g < epsilon) measures only those.
void segment_lengths(const double *xy, std::size_t first, std::size_t last, double *out);

// Points first..end - 1 of a polyline.
struct PointRun {
    std::size_t first = 0, end = 0;
};
// The compact pieces of a tensor line where a pointwise quantity stays below a threshold: the maximal runs of at least
// two consecutive points with value < threshold (NaN is not below), in order, into `out` (cleared first; a caller
// looping over many lines reuses it). The hyperbolic extractor truncates strainlines where d_g^xi1 >= epsilon (paper
// Alg. 1, step 2), the parabolic one shearlines where d_g^eta >= epsilon, both with this.
void runs_below(const double *values, std::size_t n, double threshold, std::vector<PointRun> &out);
std::vector<PointRun> runs_below(const std::vector<double> &values, double threshold);

// "Advect these points": xy_in (x, y interleaved, n points) to xy_out (2n values) with mask (n MaskBits, 0 =
// valid). The runner wraps flow_map_at_points in one; an extractor plugin wraps sdk::Host::advect.
using AdvectPointsFn =
    std::function<void(const std::vector<double> &xy_in, std::vector<double> &xy_out, std::vector<std::uint8_t> &mask)>;

// An AdvectPointsFn over flow_map_at_points (positions only) for code that holds the dynamics itself.
AdvectPointsFn make_advect_points_fn(const Dynamics &dynamics, double t_from, double t_to,
                                     const IntegratorSettings &settings, const std::optional<Bounds> &bounds = {});

struct CurveAdvectionSettings {
    // Insert points until no gap between consecutive image points exceeds this fraction of the image's size (the
    // diagonal of its bounding box).
    double max_gap_fraction = 0.005;
    // When > 0: the largest image gap as a length instead (a grown manifold's image can reach far beyond the region
    // looked at, and a fraction of its size would be coarse there).
    double max_gap = 0.0;
    // When set (x_min, x_max, y_min, y_max): gaps whose image lies wholly beyond one edge of this box are left as they
    // are (only what can show inside the box is refined; such gaps do not count against `converged`).
    std::optional<std::array<double, 4>> refine_box;
    std::size_t max_points = 200000; // stop inserting at this many points (converged = false)
    std::size_t max_rounds = 40;     // insertion rounds (each halves the offending gaps)
    // Gaps whose initial-curve parameter spacing falls below this fraction of the initial length are not split
    // further (a fold or a discontinuity of the flow map there); converged = false if such gaps stay too long.
    double min_parameter_fraction = 1e-12;
};

struct AdvectedCurve {
    std::vector<double> xy0; // the initial curve with the inserted points (valid points only)
    std::vector<double> xy1; // its image, point by point
    bool closed = false;
    double length0 = 0.0, length1 = 0.0; // l(gamma_t0) and l(gamma_t1) over the valid points
    double area0 = 0.0, area1 = 0.0;     // closed curves only: shoelace areas (signed)
    double max_gap = 0.0;                // largest image gap left, absolute
    double size1 = 0.0;                  // the image's size (bounding-box diagonal)
    std::size_t inserted = 0;            // points added by refinement
    std::size_t masked = 0;              // points dropped because their trajectory was masked
    bool converged = false;              // every gap within max_gap_fraction * size1 and nothing masked
};

// Advects a curve (at least 2 points) with `advect`, inserting midpoints of the initial curve (in its original
// polyline parametrisation) wherever the image gap is too large.
AdvectedCurve advect_curve(const std::vector<double> &xy, bool closed, const AdvectPointsFn &advect,
                           const CurveAdvectionSettings &settings = {});
// Many curves at once: each insertion round advects the new points of every curve in one call (so the integrator
// sees large batches); the result for each curve is what advect_curve would give.
std::vector<AdvectedCurve> advect_curves(const std::vector<std::vector<double>> &curves,
                                         const std::vector<bool> &closed, const AdvectPointsFn &advect,
                                         const CurveAdvectionSettings &settings = {});

} // namespace geobarrier

#endif // GEOBARRIER_CURVES_HPP
