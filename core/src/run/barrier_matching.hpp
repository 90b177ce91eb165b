// The barrier matcher shared by frames (barriers through time, frames.cpp) and continuation (barriers across a
// sweep's parameter, continuation.cpp): which barrier of one frame or member is the same curve as which of the next.
#ifndef GEOBARRIER_RUN_BARRIER_MATCHING_HPP
#define GEOBARRIER_RUN_BARRIER_MATCHING_HPP

#include <geobarrier/experiment.hpp>
#include <geobarrier/segment_index.hpp>

#include <nlohmann/json.hpp>

#include <cstddef>
#include <vector>

namespace geobarrier::detail {

struct BarrierMatch {
    std::size_t from = 0, to = 0; // indices into `previous` and `next`
    double distance = 0.0;        // grid spacings
};

// The matches between the barriers `previous` and `next` (barriers.json entries) by the rule of TrackSettings
// (frames.hpp): curves[c] (x, y interleaved; closed[c]) stands for previous[curve_of[c]] (the barrier advected to
// next's t0 for frames, the barrier itself for continuation), compared only where it lies inside the grid's box.
std::vector<BarrierMatch> match_barriers(const std::vector<std::vector<double>> &curves,
                                         const std::vector<bool> &closed, const std::vector<std::size_t> &curve_of,
                                         const nlohmann::json &previous, const nlohmann::json &next, const Grid &grid,
                                         double tolerance);

// Whether two barriers (barriers.json entries) can be one material curve: the same extractor, kind and direction (a
// repelling and an attracting barrier never are).
bool same_family(const nlohmann::json &a, const nlohmann::json &b);

// The share of a polyline's length (x, y interleaved; `closed` joins the last point to the first) within `distance`
// of the curves of `others` (0 when there are none, or the polyline has no length): its segments are cut into pieces
// of at most distance / 4, each near when its midpoint is. The convergence of a run's barriers under changed
// settings (convergence.hpp) and scripts/barrier_suite.py's agreement() measure the same.
double barrier_share_near(const std::vector<double> &xy, bool closed, const SegmentIndex &others, double distance);

// A barrier's points (x, y interleaved), from its "points".
std::vector<double> barrier_points(const nlohmann::json &barrier);

// A barrier's entry in a track: its index, length, its own stretching figure (with the key it came from), the enclosed
// area of a closed barrier and the distance of its match (null when none).
nlohmann::json barrier_track_entry(const nlohmann::json &barrier, std::size_t index, double match_distance);

// Union-find over barriers numbered frame by frame (or member by member): a track is a set of matched barriers.
struct TrackComponents {
    std::vector<std::size_t> parent;
    explicit TrackComponents(std::size_t n) : parent(n) {
        for (std::size_t k = 0; k < n; ++k) parent[k] = k;
    }
    std::size_t root(std::size_t k) {
        while (parent[k] != k) k = parent[k] = parent[parent[k]];
        return k;
    }
    void join(std::size_t a, std::size_t b) {
        a = root(a), b = root(b);
        if (a != b) parent[std::max(a, b)] = std::min(a, b); // the root is the earliest barrier
    }
};

} // namespace geobarrier::detail

#endif // GEOBARRIER_RUN_BARRIER_MATCHING_HPP
