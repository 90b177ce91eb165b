// Continuation across a sweep's parameter: barriers of neighbouring members (same t0, the parameter one step apart)
// matched by distance with the frames' matcher (barrier_matching.hpp), tracks of their figures against the parameter,
// and events (a torus or an island breaking up, a tangle forming, a track splitting or ending). docs/sweeps.md,
// "Continuation across the parameter".
#ifndef GEOBARRIER_SWEEP_CONTINUATION_HPP
#define GEOBARRIER_SWEEP_CONTINUATION_HPP

#include "sweep/sweep.hpp"
#include <geobarrier/experiment.hpp>
#include <geobarrier/frames.hpp>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace geobarrier {

// One member of a series: its value of the continued parameter, and (when it finished) its barriers and grid.
struct ContinuationMember {
    std::string name;
    double value = 0.0;
    bool available = false;                            // finished, with its barriers read
    nlohmann::json barriers = nlohmann::json::array(); // barriers.json entries (both directions: forward then backward)
    std::vector<std::string> runs;    // per barrier: "" or, for both directions, "forward" / "backward"
    std::vector<std::size_t> indices; // per barrier: its index in its own barriers.json
    Grid grid;
    std::optional<long long> tangle_crossings; // both directions: the manifest's /crossings/tangle (a count)
};

// The tracks and events of one series of members in the parameter's order: members[k]'s barriers matched to those of
// the next available member (a member that failed is skipped) by the frames' rule (TrackSettings), without advection.
// Islands (the regions inside outermost tori) are continued by position. Returns {"members", "tracks", "islands",
// "events"} (docs/sweeps.md, "Continuation across the parameter").
nlohmann::json continue_series(const std::vector<ContinuationMember> &members, const TrackSettings &settings = {});

// After a sweep whose base has extractors: continuation.json (and, when the sweep draws a picture, continuation.png)
// in `out`, with the events appended to summary.md; the files written. The continued parameter is the plot's, else the
// last one; members with equal values of the other parameters, one after another, form a series.
std::vector<std::filesystem::path> write_continuation(const Sweep &sweep, const std::filesystem::path &out,
                                                      const std::vector<SweepMemberResult> &results);

} // namespace geobarrier

#endif // GEOBARRIER_SWEEP_CONTINUATION_HPP
