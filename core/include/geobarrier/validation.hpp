// Validation products: the instruments the paper uses to prove its barriers right (section 3) — iterates of the
// period map, tracer clouds, trajectories, the forcing itself and the stretching history of advected barriers
// (eq. `rel_def`) with their tube in extended phase space. Each is computed only when the experiment's
// "validation" object asks for it, with the project's own flow-map engine (flow_map_at_points, advect_curve).
#ifndef GEOBARRIER_VALIDATION_HPP
#define GEOBARRIER_VALIDATION_HPP

#include <geobarrier/flow_map.hpp>
#include <geobarrier/plugin.hpp>

#include <nlohmann/json.hpp>

#include <array>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace geobarrier {

// ------------------------------------------------------------------------------------------------ what to compute

// nx x ny points over a box, both ends included (a count of 1 takes the middle of that side).
struct SeedLattice {
    double x_min = 0.0, x_max = 1.0, y_min = 0.0, y_max = 1.0;
    std::size_t nx = 1, ny = 1;
};
// n points spread evenly over a disc (Vogel's sunflower spiral: point k at radius R sqrt((k + 1/2) / n), angle
// k times the golden angle).
struct SeedDisc {
    double center_x = 0.0, center_y = 0.0, radius = 1.0;
    std::size_t n = 1;
};

// Iterates of the period map P = F_{t_start}^{t_start + period} (for a periodic forcing, the Poincaré map).
struct PoincareSpec {
    double period = 0.0;
    std::size_t iterations = 100;
    std::optional<double> t_start; // default: the experiment's t0
    std::vector<std::array<double, 2>> seeds;
    std::optional<SeedLattice> lattice;
    std::size_t barrier_points = 0; // seeds spread evenly along each chosen barrier (0 = none)
    std::string which = "all";      // the barriers seeded from: "all", "outermost", or see `indices`
    std::vector<std::size_t> indices;
};

// A cloud released at `release` (default t0) whose positions are recorded at `times`.
struct TracerCloudSpec {
    std::optional<SeedLattice> box;
    std::optional<SeedDisc> disc;
    std::optional<double> release;
    std::vector<double> times; // default: {t1}
};

// Time series of chosen initial states over [t_start, t_end], sampled at `samples` evenly spaced times.
struct TrajectoriesSpec {
    std::vector<std::array<double, 2>> states;
    std::optional<double> t_start, t_end; // default: t0, t1
    std::size_t samples = 1000;
};

// The forcing f(t) at `samples` evenly spaced times of [t_start, t_end].
struct ForcingSpec {
    std::optional<double> t_start, t_end; // default: t0, t1
    std::size_t samples = 2000;
};

// Every found barrier advected from t0 to each of `times` (default: `samples` evenly spaced times of [t0, t1]).
struct AdvectBarriersSpec {
    std::vector<double> times;
    std::string which = "all";        // "all", "outermost" (the outermost elliptic ones), or see `indices`
    std::vector<std::size_t> indices; // given: these barriers (0-based, in barriers.json order)
    std::size_t samples = 9;
    double max_gap = 0.005;         // curve advection: image gaps at most this fraction of the image's size
    bool tube = true;               // tube.vtp and tube.png (the barriers swept through extended phase space)
    std::size_t tube_columns = 160; // material points around the tube
    std::size_t tube_rows = 97;     // tube slices, evenly spaced over the span of `times`
};

// An event section (systems of any dimension, autonomous ones above all): the crossings of the hyperplane
// normal . x = offset in `direction` by trajectories of whole states (section_crossings below).
struct SectionSpec {
    std::vector<double> normal; // one entry per state component
    double offset = 0.0;
    int direction = 1;                      // +1, -1, or 0 for both
    std::vector<std::vector<double>> seeds; // whole initial states
    std::optional<double> t_start, t_end;   // default: t0, t1
    std::size_t crossings = 10000;          // at most, over all seeds
    double sample = 0.1;                    // bracketing interval (time); crossings closer than it may be missed
};

struct ValidationSpec {
    std::optional<PoincareSpec> poincare;
    std::optional<SectionSpec> section;
    std::vector<TracerCloudSpec> tracers;
    std::optional<TrajectoriesSpec> trajectories;
    std::optional<ForcingSpec> forcing;
    std::optional<AdvectBarriersSpec> advect_barriers;
    bool empty() const {
        return !poincare && !section && tracers.empty() && !trajectories && !forcing && !advect_barriers;
    }
};

// Reads the experiment's "validation" object (docs/experiment-format.md). Every error is a ConfigError naming the
// JSON path below `path`, the value and the rule; unknown keys get a "did you mean" hint.
ValidationSpec parse_validation(const nlohmann::json &json, const std::string &path = "/validation");
// The spec with every default filled in (t0, t1 for the unset times), for the manifest.
nlohmann::json validation_to_json(const ValidationSpec &spec, double t0, double t1);

// ------------------------------------------------------------------------------------------------ building blocks

std::vector<double> lattice_points(const SeedLattice &lattice); // x, y interleaved, row by row (y outer)
std::vector<double> disc_points(const SeedDisc &disc);

// True when (x, y) lies inside the closed polygon xy (x, y interleaved, not repeating its first point), by the
// even-odd rule; points exactly on an edge may go either way.
bool point_in_polygon(double x, double y, const std::vector<double> &xy);

// Positions of points (x, y interleaved) at each of `times`, integrated from t_from in time order (forward and
// backward chains separately, each restarting the integrator at every recorded time). snapshots[k] holds the
// positions at times[k], NaN once a trajectory is masked; `masked` counts the masked trajectories.
struct Snapshots {
    std::vector<std::vector<double>> positions;
    std::size_t masked = 0;
    IntegratorStats stats;
};
Snapshots advect_snapshots(const Dynamics &dynamics, const IntegratorSettings &settings,
                           const std::optional<Bounds> &bounds, const std::vector<double> &xy, double t_from,
                           const std::vector<double> &times);

// Iterates P^k(seed), k = 0 .. iterations, of the period map from t_start: iterates[k] = positions after k
// periods (NaN once masked).
Snapshots poincare_iterates(const Dynamics &dynamics, const IntegratorSettings &settings,
                            const std::optional<Bounds> &bounds, const std::vector<double> &seeds, double t_start,
                            double period, std::size_t iterations);

// An event section of an autonomous (or any) system of any dimension: the states where trajectories cross the
// hyperplane normal . x = offset, in the chosen direction (+1: normal . x increasing, -1: decreasing, 0: both). The
// whole states (Dynamics::slice is ignored) advance together in chunks of `sample` time; a chunk whose ends lie on
// both sides brackets a crossing, which is then located by Newton's method on g(t) = normal . x(t) - offset with
// g'(t) = normal . v(x(t), t), each iterate integrated afresh from the bracket's start (bisection where Newton
// leaves the bracket), until the time changes by less than 1e-13 max(1, |t|): the crossing of the integrated
// trajectory, to the integrator's own accuracy. Integration stops at t_end or after max_crossings crossings.
struct SectionCrossings {
    unsigned dimension = 0;
    std::vector<double> states;     // dimension per crossing
    std::vector<double> times;      // per crossing
    std::vector<std::size_t> seeds; // per crossing: the seed it came from
    std::size_t masked = 0;         // seeds whose trajectory was masked before t_end
    IntegratorStats stats;
};
SectionCrossings section_crossings(const Dynamics &dynamics, const IntegratorSettings &settings,
                                   const std::optional<Bounds> &bounds, const std::vector<double> &seeds,
                                   double t_start, double t_end, const std::vector<double> &normal, double offset,
                                   int direction, std::size_t max_crossings, double sample);

// One barrier advected to several times: length, delta_l (eq. `rel_def`) and, for closed ones, enclosed area.
struct StretchingSample {
    double t = 0.0;
    double length = 0.0;    // l(gamma_t)
    double delta_l = 0.0;   // (l(gamma_t) - l(gamma_t0)) / l(gamma_t0)
    double area = 0.0;      // closed barriers: |shoelace area| of gamma_t (NaN for open ones)
    std::size_t points = 0; // points of the advected curve (after insertion)
    bool converged = false;
    std::vector<double> xy;  // the advected curve gamma_t
    std::vector<double> xy0; // the initial curve with the inserted points, point by point matching xy
};
struct StretchingHistory {
    double length0 = 0.0, area0 = 0.0;
    std::vector<StretchingSample> samples;
};
StretchingHistory stretching_history(const Dynamics &dynamics, const IntegratorSettings &settings,
                                     const std::optional<Bounds> &bounds, const std::vector<double> &xy, bool closed,
                                     double t0, const std::vector<double> &times, double max_gap);

// The tube of one barrier through extended phase space: `columns` material points, equally spaced in arc length
// along the barrier at t0, advected to each of `times`; point (r, c) = F_{t0}^{times[r]}(material point c) at
// xyz[3 * (r * columns + c)] with z = times[r] (NaN once masked), so the tube's long lines are trajectories and its
// rings are material curves. `slices` may hold curves advected with point insertion (their times in
// `slice_times`), written to the VTK file as polylines.
struct BarrierTube {
    std::vector<double> xyz;
    std::size_t rows = 0, columns = 0;
    bool closed = false;
    std::vector<double> times;
    std::vector<double> slice_times;
    std::vector<std::vector<double>> slices;
};
BarrierTube barrier_tube(const Dynamics &dynamics, const IntegratorSettings &settings,
                         const std::optional<Bounds> &bounds, const std::vector<double> &xy, bool closed, double t0,
                         const std::vector<double> &times, std::size_t columns);

// A VTK XML PolyData file (ParaView opens it) of tubes, points (x, y, t): every slice as a polyline and every tube
// as quads, with the point arrays "time" and "barrier" and the cell array "barrier". Written atomically.
void write_tubes_vtp(const std::filesystem::path &file, const std::vector<BarrierTube> &tubes);

// ------------------------------------------------------------------------------------------------ the stage

struct ValidationInput {
    Dynamics dynamics;
    IntegratorSettings integrator;
    std::optional<Bounds> bounds;
    double t0 = 0.0, t1 = 1.0;
    const std::vector<Barrier> *barriers = nullptr; // found by the extractors, at t0
    bool plots = true;
    std::string title; // e.g. "duffing + cosine", for picture titles
};

struct ValidationOutput {
    std::vector<std::filesystem::path> files;
    nlohmann::json summary = nlohmann::json::object(); // per product: files, counts, wall_seconds
    std::vector<std::string> warnings;
};

// Computes the requested products and writes their CSV files, pictures and the tube into `out_dir`.
ValidationOutput run_validation(const ValidationSpec &spec, const ValidationInput &input,
                                const std::filesystem::path &out_dir);

} // namespace geobarrier

#endif // GEOBARRIER_VALIDATION_HPP
