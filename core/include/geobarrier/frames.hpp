// Barriers through time: one run of several frames (initial times t0_k, one horizon T) and the tracks that say which
// barrier of one frame is the same material curve as which barrier of the next. Barriers are material curves, so the
// theory's own identity is the flow: frame k's barrier advected from t0_k to t0_{k+1} is matched to an extracted
// barrier of frame k + 1 by distance.
#ifndef GEOBARRIER_FRAMES_HPP
#define GEOBARRIER_FRAMES_HPP

#include <geobarrier/experiment.hpp>

#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>
#include <vector>

namespace geobarrier {

// The most frames one run takes: each frame is a whole run, and the barriers of every frame are held in memory until
// the tracks are made (a frame of W's barriers is a few MB of JSON).
constexpr std::size_t max_frames = 1000;

// The initial times of "time": {"t0": [t_0, t_1, ...]} (strictly increasing) or {"t0": {"from": a, "to": b, "count":
// n}} (n evenly spaced times from a to b, both included, n >= 2), at most max_frames. `path` names "t0" in messages
// ("/time/t0"); an empty, unsorted or too long list is a ConfigError there.
std::vector<double> frame_initial_times(const nlohmann::json &t0, const std::string &path);

// The mean distance from the points of `from` (x, y interleaved) to the polyline `to`, each point's distance capped at
// `cutoff` (a point farther away counts as `cutoff`). NaN when `from` has no points or `to` fewer than 2.
double mean_distance_to_polyline(const std::vector<double> &from, const std::vector<double> &to, bool to_closed,
                                 double cutoff);

// How barriers are matched between frames: the distance of two curves is the smaller of the two directed mean
// distances (mean_distance_to_polyline, both curves resampled to half a grid spacing; the advected curve only where it
// lies inside the grid's box), so that a barrier extracted as a longer or shorter piece of the same material curve
// still matches; two curves match when it is at most `tolerance` grid spacings (the larger of dx, dy), one to one,
// closest pairs first, and only between barriers of the same extractor, kind and direction (repelling, attracting).
struct TrackSettings {
    double tolerance = 2.0; // grid spacings
};

// The tracks of the barriers of several frames (`barriers[k]`: frame k's barriers as in its barriers.json, at the
// initial time t0s[k]): each barrier of frame k is advected to t0s[k + 1] with the experiment's dynamics and
// integrator (advect_curves, image gaps refined to a grid spacing inside the box) and matched (TrackSettings). A
// barrier no earlier barrier matched starts a track. Returns tracks.json's contents (docs/experiment-format.md,
// "Frames"): per track its barriers per frame, birth and death, and per-frame figures (length, the barrier's own
// stretching figure, enclosed area of a closed barrier, the match distance).
nlohmann::json track_barriers(const ResolvedExperiment &experiment, const std::vector<double> &t0s,
                              const std::vector<nlohmann::json> &barriers, const TrackSettings &settings = {});

// "time": {"t0": [...] or {"from", "to", "count"}, "T": ...}: one complete run per initial time into
// <out>/frames/000, <out>/frames/001, ... (each with its own manifest), then <out>/tracks.json (track_barriers, when
// the experiment has extractors) and <out>/manifest.json, written last, listing the frames. Writes files only
// (RunOptions::write_files; keep_results is refused, as Python's run does not write folders).
RunSummary run_frames(const ResolvedExperiment &experiment, const RunOptions &options);

} // namespace geobarrier

#endif // GEOBARRIER_FRAMES_HPP
