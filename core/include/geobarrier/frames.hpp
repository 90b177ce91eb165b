// Barriers through time: one run of several frames (initial times t0_k, one horizon T) and the tracks that say which
// barrier of one frame is the same material curve as which barrier of the next. Barriers are material curves, so the
// theory's own identity is the flow: frame k's barrier advected from t0_k to t0_{k+1} is matched to an extracted
// barrier of frame k + 1 by distance.
#ifndef GEOBARRIER_FRAMES_HPP
#define GEOBARRIER_FRAMES_HPP

#include <geobarrier/experiment.hpp>

#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
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

// How barriers are matched between frames: the distance of two curves is a directed mean distance
// (mean_distance_to_polyline, both curves resampled to half a grid spacing; the advected curve only where it lies
// inside the grid's box), of two open curves the smaller of the two directions (a barrier extracted as a longer or
// shorter piece of the same material curve still matches), of two closed ones the larger (nested tori stay apart).
// Two curves match when it is at most `tolerance` grid spacings (the larger of dx, dy), one to one, closest pairs
// first, then each open barrier left without a match takes its closest (a curve extracted in two pieces keeps one
// track); only barriers of the same extractor, kind and direction (repelling, attracting) match. A barrier of frame k
// that no barrier of frame k + 1 matched is advected straight to frame k + 2, ..., k + 1 + max_gap (nearest first) and
// matched there with the barriers no earlier frame matched: an extractor that misses a barrier in one frame (a KAM
// torus whose figure is a little above the threshold there) does not break its track.
struct TrackSettings {
    double tolerance = 2.0;  // grid spacings
    std::size_t max_gap = 1; // frames a track may skip (0: every frame)
};

// The tracks of the barriers of several frames (`barriers[k]`: frame k's barriers as in its barriers.json, at the
// initial time t0s[k]): each barrier of frame k is advected to t0s[k + 1] with the experiment's dynamics and
// integrator (advect_curves, image gaps refined to a grid spacing inside the box) and matched (TrackSettings). A
// barrier no earlier barrier matched starts a track; across a missed frame see TrackSettings::max_gap. Returns
// tracks.json's contents (docs/experiment-format.md, "Frames"): per track its barriers per frame, birth and death, the
// frames it skipped, and per-frame figures (length, the barrier's own stretching figure, enclosed area of a closed
// barrier, the match distance).
nlohmann::json track_barriers(const ResolvedExperiment &experiment, const std::vector<double> &t0s,
                              const std::vector<nlohmann::json> &barriers, const TrackSettings &settings = {});

// A frame's FTLE field for the animation (row-major ny x nx, with the run's mask).
struct FrameField {
    double t0 = 0.0;
    std::vector<double> ftle;
    std::vector<std::uint8_t> mask;
};

// An animated PNG (APNG: the PNG format with acTL, fcTL and fdAT chunks, which browsers, ffmpeg and image viewers
// play; a reader without APNG shows the first frame) from PNG pictures of one size and kind, each shown for
// `delay_ms`, played over and over.
void write_animated_png(const std::filesystem::path &file, const std::vector<std::filesystem::path> &frames,
                        unsigned delay_ms);
// The frames' FTLE fields with their barriers, each coloured by its track (`tracks`: track_barriers' result), as an
// animated PNG; the frame pictures are drawn into `scratch` and removed.
void plot_frames_animation(const std::filesystem::path &file, const std::filesystem::path &scratch, const Grid &grid,
                           const std::vector<FrameField> &fields, const std::vector<nlohmann::json> &barriers,
                           const nlohmann::json &tracks, const std::string &title);
// Each track's length against its frames' initial times, coloured as in the animation.
void plot_track_figures(const std::filesystem::path &file, const nlohmann::json &tracks);

// "time": {"t0": [...] or {"from", "to", "count"}, "T": ...}: one complete run per initial time into
// <out>/frames/000, <out>/frames/001, ... (each with its own manifest), then <out>/tracks.json (track_barriers, when
// the experiment has extractors), with plots <out>/animation.png (plot_frames_animation, when the frames' FTLE fields
// fit in 1 GiB) and <out>/tracks.png (plot_track_figures), and <out>/manifest.json, written last, listing the frames.
// Writes files only
// (RunOptions::write_files; keep_results is refused, as Python's run does not write folders).
RunSummary run_frames(const ResolvedExperiment &experiment, const RunOptions &options);

} // namespace geobarrier

#endif // GEOBARRIER_FRAMES_HPP
