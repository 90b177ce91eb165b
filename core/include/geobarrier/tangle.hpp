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

// A point where a forward-time and a backward-time barrier cross.
struct BarrierCrossing {
    double x = 0.0, y = 0.0;
    std::size_t forward = 0, backward = 0; // indices into the two barrier lists
    double angle_degrees = 0.0;            // between the two curves at the crossing, in (0, 90]
};

// The crossings of two lists of barriers (as in barriers.json: "points" [[x, y], ...] and "closed") at which the
// curves meet at more than min_angle_degrees: where two barriers run along each other (an unforced separatrix is
// both a stable and an unstable manifold) their polylines cross back and forth at tiny angles, which is no tangle.
// Each crossing is counted once, also at a vertex, and crossings within merge_distance of an earlier one are the same
// (a barrier folded back on itself, or two pieces ending at one point); ordered by forward barrier, then along it.
// The stable and unstable manifolds of one hyperbolic trajectory cross at it: one crossing there is no tangle.
std::vector<BarrierCrossing> transverse_crossings(const nlohmann::json &forward, const nlohmann::json &backward,
                                                  double min_angle_degrees = 10.0, double merge_distance = 0.0);

// "time": {"directions": "both"}: the experiment run forward (t0 to t0 + |t1 - t0|) into <out>/forward and backward
// (t0 to t0 - |t1 - t0|) into <out>/backward, each a complete run with its own manifest, then <out>/tangle.json (the
// barriers' transverse crossings) and, with plots, <out>/tangle.png (both barrier sets and the crossings over the
// larger of the two FTLE fields). Each folder is published when its run finishes: a failed backward run leaves a
// finished forward run and no tangle. Writes files only (RunOptions::write_files; keep_results is refused).
RunSummary run_both_directions(const ResolvedExperiment &experiment, const RunOptions &options);

} // namespace geobarrier

#endif // GEOBARRIER_TANGLE_HPP
