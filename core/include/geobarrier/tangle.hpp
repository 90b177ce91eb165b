// Both directions in one run: the repelling barriers of the forward run and the attracting barriers of the backward
// run from the same initial time, and their transverse crossings. Stable and unstable manifolds of one hyperbolic
// trajectory cross at that trajectory; every further crossing is a point of a homoclinic (or, between manifolds of
// different trajectories, heteroclinic) tangle.
#ifndef GEOBARRIER_TANGLE_HPP
#define GEOBARRIER_TANGLE_HPP

#include <geobarrier/experiment.hpp>

#include <nlohmann/json.hpp>

#include <cstddef>
#include <vector>

namespace geobarrier {

// What a crossing is, once the saddle orbits near the crossings are known (classify_crossings).
enum class CrossingKind {
    unclassified, // no forcing period given
    saddle_orbit, // at a saddle orbit, where its own stable and unstable manifolds meet: no tangle
    homoclinic,   // between a stable and an unstable barrier that both pass through one saddle orbit
    other,        // anything else: heteroclinic, or pieces not traced to a saddle orbit found in this run
};
const char *crossing_kind_name(CrossingKind kind);

// A point where a forward-time and a backward-time barrier cross.
struct BarrierCrossing {
    double x = 0.0, y = 0.0;
    std::size_t forward = 0, backward = 0; // indices into the two barrier lists
    double angle_degrees = 0.0;            // between the two curves at the crossing, in (0, 90]
    CrossingKind kind = CrossingKind::unclassified;
    std::size_t orbit = 0; // saddle_orbit, homoclinic: the index of the saddle orbit
};

// A saddle orbit of period T: a fixed point of the period map P = F_{t0}^{t0 + T} whose multipliers (the eigenvalues
// of DP) are real, one larger than 1 in magnitude and one smaller. For a T-periodic forcing it is a hyperbolic
// trajectory of period T, and its stable and unstable manifolds at t0 are what forward and backward barriers approach.
struct SaddleOrbit {
    double x = 0.0, y = 0.0;
    double multipliers[2] = {0.0, 0.0}; // |multipliers[0]| > 1 > |multipliers[1]|
};

// Newton's method on P(z) = z from each start point (x, y pairs): the saddle orbits it converges to within `within`
// of their start, each once (two within `within` of each other are one). The Jacobian DP is the flow map's gradient
// (the experiment's gradient method); a start whose iterates leave the bounds, move more than `within` away, or do
// not settle in 30 steps gives nothing.
std::vector<SaddleOrbit> saddle_orbits_near(const ResolvedExperiment &experiment, double period,
                                            const std::vector<double> &starts, double within);

// Sets each crossing's kind: saddle_orbit within `within` of a saddle orbit, homoclinic where both barriers pass within
// `within` of one saddle orbit, else other.
void classify_crossings(std::vector<BarrierCrossing> &crossings, const nlohmann::json &forward,
                        const nlohmann::json &backward, const std::vector<SaddleOrbit> &orbits, double within);

// The crossings of two lists of barriers (as in barriers.json: "points" [[x, y], ...] and "closed") at which the
// curves meet at more than min_angle_degrees: where two barriers run along each other (an unforced separatrix is
// both a stable and an unstable manifold) their polylines cross back and forth at tiny angles, which is no tangle.
// Each crossing is counted once, also at a vertex, and crossings within merge_distance of an earlier one are the same
// (a barrier folded back on itself, or two pieces ending at one point); ordered by forward barrier, then along it.
// The stable and unstable manifolds of one hyperbolic trajectory cross at it: one crossing there is no tangle.
std::vector<BarrierCrossing> transverse_crossings(const nlohmann::json &forward, const nlohmann::json &backward,
                                                  double min_angle_degrees = 10.0, double merge_distance = 0.0);

// Barriers grown along their manifolds: each advected from t0 to t_to with point insertion (curves.hpp), refined to
// a grid spacing wherever its image can show inside the grid's box. Run backward from a repelling barrier (a stable
// manifold) or forward from an attracting one (an unstable manifold), the flow stretches the curve along its manifold
// (by up to a saddle orbit's larger multiplier per period) and contracts it across, the direction of its error; over
// whole periods of a periodic forcing the image is a longer piece of the same manifold at t0.
struct GrownBarriers {
    nlohmann::json pieces =
        nlohmann::json::array(); // {"points", "closed": false, "barrier"}: the images inside the box
    nlohmann::json report = nlohmann::json::array(); // per barrier: lengths, points, gaps (tangle.json's "grown")
};
GrownBarriers grow_barriers(const ResolvedExperiment &experiment, const nlohmann::json &barriers, double t_to);
// The manifolds grown from barriers over 0, 1, ..., `periods` whole periods (direction -1: backward, for repelling
// barriers; +1: forward, for attracting ones): the union of the barriers (0 periods) and their images, which is the
// manifold as far as it reaches, where the image over `periods` alone loses the parts near the saddle orbit that the
// stretching has carried away. Each piece and report entry says its "periods".
GrownBarriers grow_barriers_over_periods(const ResolvedExperiment &experiment, const nlohmann::json &barriers,
                                         int direction, std::size_t periods, double period);

// "time": {"directions": "both"}: the experiment run forward (t0 to t0 + |t1 - t0|) into <out>/forward and backward
// (t0 to t0 - |t1 - t0|) into <out>/backward, each a complete run with its own manifest, then <out>/tangle.json (the
// barriers' transverse crossings) and, with plots, <out>/tangle.png (both barrier sets and the crossings over the
// larger of the two FTLE fields). With "time": {"period": T}, the crossings are classified (classify_crossings) and
// tangle.json lists the saddle orbits found at them. <out>/manifest.json, written last, names the two runs and counts
// the crossings by kind (a sweep's figures can point into it, e.g. "/crossings/tangle"). With "grow_periods": k, the
// barriers are grown over k periods (grow_barriers), their crossings classified alike, and <out>/grown.png drawn. Each
// folder is published when its run finishes: a failed backward run leaves a finished forward run and no tangle. With
// RunOptions::keep_results the summary's `directions` hold the two runs' results and `tangle` what tangle.json holds;
// with write_files false nothing is written (no folder, no picture), as for a run of one direction.
RunSummary run_both_directions(const ResolvedExperiment &experiment, const RunOptions &options);

} // namespace geobarrier

#endif // GEOBARRIER_TANGLE_HPP
