// Frames (one run per initial time) and the tracks of their barriers (frames.hpp).
#include <geobarrier/curves.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/flow_map.hpp>
#include <geobarrier/frames.hpp>
#include <geobarrier/output.hpp>
#include <geobarrier/segment_index.hpp>

#include "engine/tiles.hpp"
#include "experiment/resources.hpp"
#include "run/barrier_matching.hpp"
#include "run/convergence.hpp"
#include "run/mpi.hpp"

#include <fmt/format.h>
#include <omp.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <deque>
#include <filesystem>
#include <future>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <unordered_map>

namespace geobarrier {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string short_value(const json &v) {
    std::string s = v.dump();
    return s.size() > 60 ? s.substr(0, 57) + "..." : s;
}

double finite_number(const json &v, const std::string &path) {
    if (!v.is_number()) throw ConfigError(path, short_value(v) + " is not a number; expected an initial time");
    const double d = v.get<double>();
    if (!std::isfinite(d)) throw ConfigError(path, short_value(v) + " is not finite");
    return d;
}

std::string too_many(std::size_t n) {
    return std::to_string(n) + " initial times; at most " + std::to_string(max_frames) +
           " frames per run (each is a whole run, and every frame's barriers are held for the tracks): split the "
           "times over several runs";
}

// {"from": a, "to": b, "count": n}: n evenly spaced times, both ends included.
std::vector<double> evenly_spaced_times(const json &t0, const std::string &path) {
    for (const auto &item : t0.items())
        if (item.key() != "from" && item.key() != "to" && item.key() != "count")
            throw ConfigError(path + "/" + item.key(), "unknown key (allowed here: from to count)");
    for (const char *key : {"from", "to", "count"})
        if (!t0.contains(key)) throw ConfigError(path, std::string("missing required key \"") + key + "\"");
    const double from = finite_number(t0.at("from"), path + "/from"), to = finite_number(t0.at("to"), path + "/to");
    const json &count = t0.at("count");
    if (!count.is_number_integer() || count.get<long long>() < 2)
        throw ConfigError(path + "/count",
                          short_value(count) + " must be an integer >= 2 (frames, both ends included)");
    if (count.get<unsigned long long>() > max_frames)
        throw ConfigError(path + "/count", too_many(count.get<std::size_t>()));
    if (!(to > from)) throw ConfigError(path + "/to", short_value(t0.at("to")) + " must be greater than \"from\"");
    const std::size_t n = count.get<std::size_t>();
    std::vector<double> times(n);
    // Each time from the ends (not by repeated addition), so the last one is `to` exactly.
    for (std::size_t k = 0; k < n; ++k)
        times[k] = k + 1 == n ? to : from + (to - from) * static_cast<double>(k) / static_cast<double>(n - 1);
    return times;
}

} // namespace

std::vector<double> frame_initial_times(const json &t0, const std::string &path) {
    if (t0.is_object()) return evenly_spaced_times(t0, path);
    if (!t0.is_array())
        throw ConfigError(path, short_value(t0) + " is neither a number, a list of initial times nor {\"from\", "
                                                  "\"to\", \"count\"}");
    if (t0.empty()) throw ConfigError(path, "[] is empty; expected at least one initial time");
    if (t0.size() > max_frames) throw ConfigError(path, too_many(t0.size()));
    std::vector<double> times;
    for (std::size_t k = 0; k < t0.size(); ++k) {
        const std::string at = path + "/" + std::to_string(k);
        times.push_back(finite_number(t0[k], at));
        // Increasing: the tracks follow the flow from each frame to the next.
        if (k > 0 && !(times[k] > times[k - 1]))
            throw ConfigError(at, short_value(t0[k]) + " is not greater than the time before it (" +
                                      short_value(t0[k - 1]) +
                                      "); list the initial times in increasing order, each once");
    }
    return times;
}

double mean_distance_to_polyline(const std::vector<double> &from, const std::vector<double> &to, bool to_closed,
                                 double cutoff) {
    if (from.size() < 2 || to.size() < 4 || !(cutoff > 0)) return std::numeric_limits<double>::quiet_NaN();
    // Cells of side `cutoff`: a distance capped at the cutoff looks at the 3 x 3 cells around the point at most.
    std::vector<Segment> segments;
    append_polyline_segments(to.data(), to.size() / 2, to_closed, 0, segments);
    const SegmentIndex index(std::move(segments), cutoff);
    double sum = 0.0;
    for (std::size_t k = 0; k + 1 < from.size(); k += 2) sum += index.distance(from[k], from[k + 1], cutoff);
    return sum / static_cast<double>(from.size() / 2);
}

bool detail::same_family(const json &a, const json &b) {
    return a.value("extractor", "") == b.value("extractor", "") && a.value("kind", "") == b.value("kind", "") &&
           a.value("repelling", false) == b.value("repelling", false) &&
           a.value("attracting", false) == b.value("attracting", false);
}

namespace {

std::vector<double> points_of(const json &barrier) {
    std::vector<double> xy;
    for (const json &p : barrier.at("points")) xy.insert(xy.end(), {p[0].get<double>(), p[1].get<double>()});
    return xy;
}

// The barrier's own stretching figure, by the first of these keys it has: the hyperbolic extractor's relative
// stretching q, the elliptic one's lambda of a lambda-line, its advected stretching.
constexpr const char *stretching_keys[] = {"relative_stretching", "lambda", "advected_stretching"};

// A curve's points inside the box [x_min, x_max] x [y_min, y_max], resampled to `spacing` (pieces outside dropped).
std::vector<double> resampled_inside(const std::vector<double> &xy, bool closed, const Grid &g, double spacing) {
    const std::vector<double> fine = resample_polyline(xy, spacing, closed);
    std::vector<double> inside;
    for (std::size_t k = 0; k + 1 < fine.size(); k += 2)
        if (fine[k] >= g.x_min && fine[k] <= g.x_max && fine[k + 1] >= g.y_min && fine[k + 1] <= g.y_max)
            inside.insert(inside.end(), {fine[k], fine[k + 1]});
    return inside;
}

// Every pair of one of frame k's advected barriers (`images`; image_of[c]: the barrier of image c) and one of frame
// k + 1's barriers (`next`) within the tolerance. Two closed barriers (whole tori) are as far apart as the larger of
// the directed distances, so that nested tori a grid spacing apart stay apart; an open barrier may be extracted as a
// longer or shorter piece of the curve, so the smaller counts.
std::vector<detail::BarrierMatch> candidate_matches(const std::vector<std::vector<double>> &curves,
                                                    const std::vector<bool> &curve_closed,
                                                    const std::vector<std::size_t> &image_of, const json &previous,
                                                    const json &next, const Grid &g, double tolerance) {
    const double h = std::max(g.dx(), g.dy()), spacing = 0.5 * h, cutoff = 2.0 * tolerance * h;
    std::vector<std::vector<double>> next_xy;
    for (const json &b : next) next_xy.push_back(resampled_inside(points_of(b), b.value("closed", false), g, spacing));
    std::vector<detail::BarrierMatch> matches;
    for (std::size_t c = 0; c < curves.size(); ++c) {
        const std::vector<double> image = resampled_inside(curves[c], curve_closed[c], g, spacing);
        if (image.size() < 4) continue; // nothing of it is left in the box
        for (std::size_t b = 0; b < next.size(); ++b) {
            if (!detail::same_family(previous[image_of[c]], next[b]) || next_xy[b].size() < 4) continue;
            const bool closed = next[b].value("closed", false);
            const double to = mean_distance_to_polyline(image, next_xy[b], closed, cutoff),
                         from = mean_distance_to_polyline(next_xy[b], image, curve_closed[c], cutoff);
            const double d = closed && curve_closed[c] ? std::max(to, from) : std::min(to, from);
            if (d <= tolerance * h) matches.push_back({image_of[c], b, d / h});
        }
    }
    return matches;
}

} // namespace

// The matches kept from the candidates: one to one, closest pairs first; then each open barrier left without a match
// (on either side) takes its closest candidate, so that a curve the extractor reports as one piece in one frame and
// as two in the next keeps one track with both pieces. A closed barrier is a whole curve and never splits.
std::vector<detail::BarrierMatch> detail::match_barriers(const std::vector<std::vector<double>> &curves,
                                                         const std::vector<bool> &closed,
                                                         const std::vector<std::size_t> &curve_of, const json &previous,
                                                         const json &next, const Grid &g, double tolerance) {
    std::vector<BarrierMatch> candidates = candidate_matches(curves, closed, curve_of, previous, next, g, tolerance);
    std::sort(candidates.begin(), candidates.end(), [](const BarrierMatch &a, const BarrierMatch &b) {
        return a.distance != b.distance ? a.distance < b.distance : a.from != b.from ? a.from < b.from : a.to < b.to;
    });
    std::vector<BarrierMatch> matches;
    std::vector<bool> from_used(previous.size(), false), to_used(next.size(), false), taken(candidates.size(), false);
    for (std::size_t m = 0; m < candidates.size(); ++m) {
        const BarrierMatch &c = candidates[m];
        if (from_used[c.from] || to_used[c.to]) continue;
        from_used[c.from] = to_used[c.to] = taken[m] = true;
        matches.push_back(c);
    }
    for (std::size_t m = 0; m < candidates.size(); ++m) {
        const BarrierMatch &c = candidates[m];
        if (taken[m] || previous[c.from].value("closed", false) || next[c.to].value("closed", false)) continue;
        if (from_used[c.from] && to_used[c.to]) continue;
        from_used[c.from] = to_used[c.to] = true;
        matches.push_back(c);
    }
    return matches;
}

namespace {

// Frame k's barriers advected from t_from to t_to (image gaps refined to a grid spacing inside the box).
std::vector<AdvectedCurve> advect_frame(const ResolvedExperiment &r, const json &barriers, double t_from, double t_to,
                                        std::vector<std::size_t> &image_of) {
    const Experiment &e = r.experiment;
    std::vector<std::vector<double>> curves;
    std::vector<bool> closed;
    for (std::size_t b = 0; b < barriers.size(); ++b) {
        if (barriers[b].at("points").size() < 2) continue;
        curves.push_back(points_of(barriers[b]));
        closed.push_back(barriers[b].value("closed", false));
        image_of.push_back(b);
    }
    if (curves.empty()) return {};
    CurveAdvectionSettings settings;
    settings.max_gap = std::min(e.grid.dx(), e.grid.dy());
    settings.refine_box = std::array<double, 4>{e.grid.x_min, e.grid.x_max, e.grid.y_min, e.grid.y_max};
    return advect_curves(curves, closed,
                         make_advect_points_fn(r.dynamics(), t_from, t_to, e.integrator, masking(e.bounds)), settings);
}

} // namespace

// (barrier_matching.hpp)
std::vector<double> detail::barrier_points(const json &barrier) { return points_of(barrier); }

json detail::barrier_track_entry(const json &barrier, std::size_t index, double match_distance) {
    const bool closed = barrier.value("closed", false);
    const std::vector<double> xy = points_of(barrier);
    json entry = {{"barrier", index}, {"length", barrier.value("length", polyline_length(xy, closed))}};
    for (const char *key : stretching_keys)
        if (barrier.contains(key) && barrier[key].is_number()) {
            entry["stretching"] = barrier[key];
            entry["stretching_figure"] = key;
            break;
        }
    if (closed) entry["area"] = barrier.value("enclosed_area", std::abs(shoelace_area(xy)));
    entry["match_distance"] = std::isfinite(match_distance) ? json(match_distance) : json(nullptr);
    return entry;
}

namespace {

// Tracks from the components: each track's barriers per frame with their figures, birth and death, in the order of
// their first barrier.
json assemble_tracks(detail::TrackComponents &components, const std::vector<std::size_t> &offset,
                     const std::vector<double> &t0s, const std::vector<json> &barriers,
                     const std::vector<double> &match_distance) {
    std::map<std::size_t, std::size_t> track_of_root;
    json tracks = json::array();
    for (std::size_t k = 0; k < t0s.size(); ++k)
        for (std::size_t b = 0; b < barriers[k].size(); ++b) {
            const std::size_t root = components.root(offset[k] + b);
            auto [it, fresh] = track_of_root.emplace(root, tracks.size());
            const json &item = barriers[k][b];
            if (fresh)
                tracks.push_back({{"id", tracks.size()},
                                  {"extractor", item.value("extractor", "")},
                                  {"kind", item.value("kind", "")},
                                  {"birth", k},
                                  {"death", nullptr},
                                  {"frames", json::array()}});
            json &frames = tracks[it->second]["frames"];
            if (frames.empty() || frames.back()["frame"] != k)
                frames.push_back({{"frame", k}, {"t0", t0s[k]}, {"barriers", json::array()}, {"length", 0.0}});
            frames.back()["barriers"].push_back(detail::barrier_track_entry(item, b, match_distance[offset[k] + b]));
            frames.back()["length"] =
                frames.back()["length"].get<double>() + frames.back()["barriers"].back()["length"].get<double>();
        }
    for (json &t : tracks) {
        const std::size_t last = t["frames"].back()["frame"];
        if (last + 1 < t0s.size()) t["death"] = last + 1;
        // The frames a track crossed without a barrier there (TrackSettings::max_gap).
        json skipped = json::array();
        for (std::size_t f = 1; f < t["frames"].size(); ++f)
            for (std::size_t k = t["frames"][f - 1]["frame"].get<std::size_t>() + 1; k < t["frames"][f]["frame"]; ++k)
                skipped.push_back(k);
        t["skipped"] = skipped;
    }
    return tracks;
}

} // namespace

namespace {

// What track_barriers has joined so far, barrier by barrier (numbered frame by frame from offset[k]).
struct TrackState {
    std::vector<std::size_t> offset;
    detail::TrackComponents components;
    std::vector<double> match_distance;               // of each barrier to its closest match in the frame before it
    std::vector<bool> has_successor, has_predecessor; // matched to a later frame, from an earlier one
    explicit TrackState(const std::vector<json> &barriers) : offset{0}, components(0) {
        for (const json &frame : barriers) offset.push_back(offset.back() + frame.size());
        components = detail::TrackComponents(offset.back());
        match_distance.assign(offset.back(), NAN);
        has_successor.assign(offset.back(), false);
        has_predecessor.assign(offset.back(), false);
    }
};

// Frame `from`'s barriers `previous` advected to frame `to`'s t0 and matched with `next` (subsets of the two frames'
// barriers: `previous_index[b]` and `next_index[b]` are their indices in the frames); the matches joined in `state`.
// Returns {matches, barriers advected, advections converged}.
std::array<std::size_t, 3> match_frames(const ResolvedExperiment &r, const std::vector<double> &t0s, std::size_t from,
                                        std::size_t to, const json &previous, const json &next,
                                        const std::vector<std::size_t> &previous_index,
                                        const std::vector<std::size_t> &next_index, double tolerance,
                                        TrackState &state) {
    std::vector<std::size_t> image_of;
    const std::vector<AdvectedCurve> images = advect_frame(r, previous, t0s[from], t0s[to], image_of);
    std::vector<std::vector<double>> curves;
    std::vector<bool> closed;
    std::size_t converged = 0;
    for (const AdvectedCurve &a : images) {
        curves.push_back(a.xy1);
        closed.push_back(a.closed);
        converged += a.converged ? 1 : 0;
    }
    const std::vector<detail::BarrierMatch> matches =
        detail::match_barriers(curves, closed, image_of, previous, next, r.experiment.grid, tolerance);
    for (const detail::BarrierMatch &m : matches) {
        const std::size_t a = state.offset[from] + previous_index[m.from], b = state.offset[to] + next_index[m.to];
        state.components.join(a, b);
        state.has_successor[a] = state.has_predecessor[b] = true;
        double &d = state.match_distance[b];
        d = std::isnan(d) ? m.distance : std::min(d, m.distance);
    }
    return {matches.size(), images.size(), converged};
}

// The barriers of `frame` (global numbers from `first`) with `flag` equal to `wanted`: their items and indices.
json barriers_where(const json &frame, const std::vector<bool> &flag, std::size_t first, bool wanted,
                    std::vector<std::size_t> &index) {
    json out = json::array();
    for (std::size_t b = 0; b < frame.size(); ++b)
        if (flag[first + b] == wanted) {
            out.push_back(frame[b]);
            index.push_back(b);
        }
    return out;
}

// Tracks across a missed frame: a barrier of frame k that no barrier of frame k + 1 matched is advected straight to
// frame k + g (g = 2 ... max_gap + 1, the nearest first) and matched with the barriers there that no earlier frame
// matched (the extractor may miss a barrier in one frame, e.g. a KAM torus whose stretching figure is a little above
// the threshold there). One advection over the whole gap, not frame by frame, so the missing frame is not needed.
json bridge_gaps(const ResolvedExperiment &r, const std::vector<double> &t0s, const std::vector<json> &barriers,
                 std::size_t max_gap, double tolerance, TrackState &state) {
    json gaps = json::array();
    for (std::size_t k = 0; k < t0s.size(); ++k)
        for (std::size_t g = 2; g <= max_gap + 1 && k + g < t0s.size(); ++g) {
            std::vector<std::size_t> ended_index, unmatched_index;
            const json ended = barriers_where(barriers[k], state.has_successor, state.offset[k], false, ended_index);
            if (ended.empty()) break;
            const json unmatched =
                barriers_where(barriers[k + g], state.has_predecessor, state.offset[k + g], false, unmatched_index);
            if (unmatched.empty()) continue;
            const auto counts =
                match_frames(r, t0s, k, k + g, ended, unmatched, ended_index, unmatched_index, tolerance, state);
            if (counts[0] > 0) gaps.push_back({{"from", k}, {"to", k + g}, {"matched_pairs", counts[0]}});
        }
    return gaps;
}

} // namespace

json track_barriers(const ResolvedExperiment &r, const std::vector<double> &t0s, const std::vector<json> &barriers,
                    const TrackSettings &settings) {
    const Grid &g = r.experiment.grid;
    TrackState state(barriers);
    json transitions = json::array();
    for (std::size_t k = 0; k + 1 < t0s.size(); ++k) {
        std::vector<std::size_t> all_k(barriers[k].size()), all_next(barriers[k + 1].size());
        for (std::size_t b = 0; b < all_k.size(); ++b) all_k[b] = b;
        for (std::size_t b = 0; b < all_next.size(); ++b) all_next[b] = b;
        const auto counts =
            match_frames(r, t0s, k, k + 1, barriers[k], barriers[k + 1], all_k, all_next, settings.tolerance, state);
        const auto first_k = state.has_successor.begin() + static_cast<std::ptrdiff_t>(state.offset[k]);
        const auto first_next = state.has_predecessor.begin() + static_cast<std::ptrdiff_t>(state.offset[k + 1]);
        transitions.push_back(
            {{"from", k},
             {"to", k + 1},
             {"matched_pairs", counts[0]},
             {"ended", std::count(first_k, first_k + static_cast<std::ptrdiff_t>(barriers[k].size()), false)},
             {"new", std::count(first_next, first_next + static_cast<std::ptrdiff_t>(barriers[k + 1].size()), false)},
             {"advected", counts[1]},
             {"advection_converged", counts[2]}});
    }
    const json gaps = bridge_gaps(r, t0s, barriers, settings.max_gap, settings.tolerance, state);
    const json tracks = assemble_tracks(state.components, state.offset, t0s, barriers, state.match_distance);
    std::size_t whole = 0;
    for (const json &t : tracks) whole += t["frames"].size() == t0s.size() ? 1 : 0;
    return {{"tolerance_grid_spacings", settings.tolerance},
            {"grid_spacing", std::max(g.dx(), g.dy())},
            {"max_gap_frames", settings.max_gap},
            {"distance",
             "the smaller directed mean distance between frame k's barrier advected to frame k + 1's t0 (k + g's "
             "across a gap) and that frame's barrier, in grid spacings"},
            {"frame_count", t0s.size()},
            {"track_count", tracks.size()},
            {"tracks_through_all_frames", whole},
            {"transitions", transitions},
            {"gaps", gaps},
            {"tracks", tracks}};
}

namespace {

// Frame k's experiment: the experiment as written with one initial time and t1 = t0 + T. Resolved (its plugins'
// instances created) on the thread that runs run_frames, as the plugin ABI asks of create and destroy.
std::unique_ptr<ResolvedExperiment> resolve_frame(const Experiment &e, double t0) {
    json source = e.source;
    json &time = source["time"];
    time["t0"] = t0;
    time["t1"] = t0 + (e.t1 - e.t0);
    time.erase("T");
    return std::make_unique<ResolvedExperiment>(resolve_experiment(parse_experiment(source, e.file)));
}

// How the frames are run: `in_flight` at a time, each on `threads` threads (0: OpenMP's default).
struct FrameSchedule {
    std::size_t in_flight = 1;
    int threads = 0;
};

// Two frames at a time, each on half the threads, when there are two frames, two threads and memory for two runs.
// A frame's own run leaves cores idle in its serial parts: the pictures (drawn one at a time, PLplot has one global
// state), fields.nc (NetCDF is not thread-safe either), the extractors' serial steps; the other frame computes
// meanwhile. The frames' results do not depend on it: a run's results do not depend on its thread count. Under
// mpirun the ranks share each frame's tiles, one frame at a time.
FrameSchedule frame_schedule(const ResolvedExperiment &r, const RunOptions &options) {
    const Experiment &e = r.experiment;
    const int threads = options.threads > 0 ? options.threads : omp_get_max_threads();
    if (e.frames.size() < 2 || threads < 2 || mpi::sharing_tiles()) return {1, options.threads};
    const AvailableMemory memory = available_memory();
    if (memory.known && 2 * estimate_run_memory(e.grid, e.integrator, plan_fields(r)) > memory.bytes)
        return {1, options.threads};
    return {2, threads / 2};
}

// A frame being run: its experiment (destroyed on this thread, after the run) and the run on a thread of its own.
struct RunningFrame {
    std::size_t index = 0;
    std::unique_ptr<ResolvedExperiment> experiment;
    std::future<RunSummary> run; // declared after `experiment`: destroyed first, waiting for the run to end
};

std::string frame_folder(std::size_t k) { return fmt::format("frames/{:03d}", k); }

// Frame folders an earlier run of more frames left under <out>/frames (the folder is claimed by this run).
void remove_stale_frames(const fs::path &frames, std::size_t count) {
    std::error_code ec;
    if (!fs::is_directory(frames, ec)) return;
    for (const auto &entry : fs::directory_iterator(frames, ec)) {
        const std::string name = entry.path().filename().string();
        if (name.size() == 3 && std::all_of(name.begin(), name.end(), [](char c) { return c >= '0' && c <= '9'; }) &&
            std::stoul(name) >= count)
            fs::remove_all(entry.path(), ec);
    }
}

} // namespace

namespace {

// The frame's FTLE field, kept for the animation while the fields of all frames fit in `budget` bytes.
void keep_ftle(const RunSummary &frame, double t0, std::size_t frames, std::vector<FrameField> &fields) {
    constexpr double budget = 1024.0 * 1024 * 1024;
    for (const FieldResult &f : frame.fields)
        if (f.name == "ftle" && static_cast<double>(f.values.size()) * 9.0 * static_cast<double>(frames) <= budget) {
            fields.push_back({t0, f.values, frame.mask});
            return;
        }
}

// tracks.json and, with plots, the animation and the tracks' picture; the names written, for the manifest.
// Seconds since `since`.
double seconds_since(std::chrono::steady_clock::time_point since) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

json write_tracks(const ResolvedExperiment &r, const fs::path &out, const std::vector<json> &barriers,
                  const std::vector<FrameField> &fields, RunSummary &summary, json &files, json &stages) {
    const Experiment &e = r.experiment;
    auto start = std::chrono::steady_clock::now();
    const json tracks = track_barriers(r, e.frames, barriers);
    write_text_file(out / "tracks.json", tracks.dump(1) + "\n");
    summary.files.push_back(out / "tracks.json");
    files.push_back("tracks.json");
    spdlog::info("tracks: {} over {} frames, {} through all of them", tracks["track_count"].get<std::size_t>(),
                 e.frames.size(), tracks["tracks_through_all_frames"].get<std::size_t>());
    stages.push_back({{"stage", "tracks"}, {"wall_seconds", seconds_since(start)}});
    start = std::chrono::steady_clock::now();
    if (e.plots) {
        plot_track_figures(out / "tracks.png", tracks);
        summary.files.push_back(out / "tracks.png");
        files.push_back("tracks.png");
        if (fields.size() == e.frames.size()) {
            const fs::path scratch = out / ".frames-animation";
            fs::create_directories(scratch);
            plot_frames_animation(out / "animation.png", scratch, e.grid, fields, barriers, tracks,
                                  "barriers by track");
            std::error_code ec;
            fs::remove_all(scratch, ec);
            summary.files.push_back(out / "animation.png");
            files.push_back("animation.png");
        } else {
            spdlog::warn("frames: no animation.png (it needs the \"ftle\" product, and every frame's FTLE field "
                         "within 1 GiB)");
        }
        stages.push_back({{"stage", "track pictures"}, {"wall_seconds", seconds_since(start)}});
    }
    return {{"count", tracks["track_count"]},
            {"through_all_frames", tracks["tracks_through_all_frames"]},
            {"tolerance_grid_spacings", tracks["tolerance_grid_spacings"]}};
}

} // namespace

RunSummary run_frames(const ResolvedExperiment &r, const RunOptions &options) {
    const Experiment &e = r.experiment;
    if (!options.write_files || options.keep_results)
        throw ConfigError("/time/t0", "several initial times write a run per frame and their tracks into the output "
                                      "folder; to keep results in memory (Python), run one initial time at a time");
    const auto start = std::chrono::steady_clock::now();
    const fs::path out = options.output_dir ? *options.output_dir : e.output_dir;
    const FrameSchedule schedule = frame_schedule(r, options);
    if (schedule.in_flight > 1)
        spdlog::info("frames: {} at a time, {} threads each", schedule.in_flight, schedule.threads);
    RunOptions o = options;
    o.keep_results = true; // the barriers for the tracks
    o.threads = schedule.threads;
    std::mutex progress_mutex; // RunOptions::progress is called one call at a time
    if (schedule.in_flight > 1) {
        o.quiet = true; // two frames' progress bars would overwrite each other
        if (options.progress)
            o.progress = [&](const std::string &stage, std::size_t done, std::size_t total) {
                const std::lock_guard<std::mutex> lock(progress_mutex);
                options.progress(stage, done, total);
            };
    }
    std::vector<json> barriers;
    std::vector<FrameField> fields;
    json frames = json::array();
    std::vector<std::pair<std::string, json>> convergence; // each frame's manifest's, for the manifest's total
    RunSummary summary;
    // The frames' results in frame order, each as its run ends (the oldest first).
    const auto finish = [&](RunningFrame &running) {
        RunSummary frame = running.run.get();
        running.experiment.reset();
        const std::size_t k = running.index;
        summary.files.insert(summary.files.end(), frame.files.begin(), frame.files.end());
        frames.push_back({{"index", k},
                          {"t0", e.frames[k]},
                          {"t1", e.frames[k] + (e.t1 - e.t0)},
                          {"folder", frame_folder(k)},
                          {"manifest", frame_folder(k) + "/manifest.json"},
                          {"barriers", frame.barriers.size()}});
        convergence.emplace_back(frame_folder(k),
                                 frame.manifest.is_object() ? frame.manifest.value("convergence", json()) : json());
        if (e.plots && !e.extractors.empty()) keep_ftle(frame, e.frames[k], e.frames.size(), fields);
        barriers.push_back(std::move(frame.barriers));
    };
    std::deque<RunningFrame> running;
    for (std::size_t k = 0; k < e.frames.size(); ++k) {
        while (running.size() >= schedule.in_flight) {
            finish(running.front());
            running.pop_front();
        }
        spdlog::info("frame {} of {}: t0 = {}, t1 = {}", k + 1, e.frames.size(), e.frames[k],
                     e.frames[k] + e.t1 - e.t0);
        RunningFrame next;
        next.index = k;
        next.experiment = resolve_frame(e, e.frames[k]);
        RunOptions frame_options = o;
        frame_options.output_dir = out / frame_folder(k);
        // One at a time: on this thread, when finished (under mpirun the ranks call MPI from their main thread).
        const auto policy = schedule.in_flight > 1 ? std::launch::async : std::launch::deferred;
        next.run = std::async(policy, [experiment = next.experiment.get(), frame_options] {
            return run_experiment(*experiment, frame_options);
        });
        running.push_back(std::move(next));
    }
    for (; !running.empty(); running.pop_front()) finish(running.front());
    if (mpi::rank() != 0) return summary; // the other ranks only shared the flow maps' tiles
    remove_stale_frames(out / "frames", e.frames.size());
    summary.output_dir = out;
    json files = json::array({"frames"}), manifest_tracks = nullptr;
    json stages = json::array({{{"stage", "frames"}, {"wall_seconds", seconds_since(start)}}});
    if (!e.extractors.empty()) manifest_tracks = write_tracks(r, out, barriers, fields, summary, files, stages);
    files.push_back("manifest.json");
    json manifest = {{"experiment", e.source},
                     {"frames", frames},
                     {"horizon", e.t1 - e.t0},
                     {"frames_in_flight", schedule.in_flight},
                     {"threads_per_frame", schedule.threads},
                     {"tracks", manifest_tracks},
                     {"stages", stages},
                     {"wall_seconds", seconds_since(start)},
                     {"files", files}};
    // "convergence": each frame checked its own barriers; the counts of all, for `geobarrier run`'s last line.
    if (json total = detail::total_convergence(convergence); !total.is_null()) manifest["convergence"] = total;
    write_text_file(out / "manifest.json", manifest.dump(2) + "\n");
    summary.files.push_back(out / "manifest.json");
    summary.manifest = manifest;
    return summary;
}

} // namespace geobarrier
