// "convergence" (docs/experiment-format.md, "Convergence"): the run repeated with a finer or coarser grid, a shorter
// or longer horizon, or other extractor keys, and each of its barriers marked with the share of its length that each
// changed run's barriers reproduce within a few grid spacings (issue 33: the reported barriers stay within a grid
// spacing or two under refinement, and where one cannot, the run says so). The share is barrier_share_near
// (barrier_matching.hpp), the measure of scripts/barrier_suite.py's agreement().
#ifndef GEOBARRIER_RUN_CONVERGENCE_HPP
#define GEOBARRIER_RUN_CONVERGENCE_HPP

#include <geobarrier/experiment.hpp>

#include <nlohmann/json.hpp>

#include <string>
#include <utility>
#include <vector>

namespace geobarrier::detail {

// One changed run.
struct ConvergenceChange {
    std::string label;        // "grid x1.5 (451 x 301)", "horizon x1.1 (t1 = 27.6)", "extractor_keys {...}"
    std::string json_path;    // where it is asked for: "/convergence/grid", "/convergence/horizon/1", ...
    nlohmann::json source;    // the experiment as written, changed, without "convergence" and "validation"
    bool same_fields = false; // only extractor keys change: the run's own fields serve (no new flow map)
};

// The changed runs of r's "convergence" (none without it), each checked: its experiment parses, and each extractor key
// is declared by at least one of r's extractors and takes the value given (set in every extractor that declares it).
// A ConfigError at the change's JSON path otherwise. resolve_experiment calls it so that validate refuses them.
std::vector<ConvergenceChange> convergence_changes(const ResolvedExperiment &r);

// Marks each barrier of `items` (barriers.json's "barriers") with "persistence" (per change, the share of its length
// within spec.spacings grid spacings of changed_barriers[c] of its own family) and "converged" (every share at least
// spec.threshold); `runs` describes each changed run (label, JSON path, ...) and goes into the result. Returns
// barriers.json's and the manifest's "convergence" object; appends a warning per barrier that does not persist.
nlohmann::json mark_convergence(nlohmann::json &items, const std::vector<ConvergenceChange> &changes,
                                const std::vector<nlohmann::json> &changed_barriers, nlohmann::json runs,
                                const Grid &grid, const ConvergenceSpec &spec, std::vector<std::string> &warnings);

// The "convergence" object of the manifest of a run made of several runs ("directions": "both", frames) from each
// one's (its folder, its manifest's "convergence"; null when it has none), null when none has one: their `barriers` and
// `converged` summed, so that `geobarrier run` ends with the count as after a single run, and per run its own counts
// and `not_converged`.
nlohmann::json total_convergence(const std::vector<std::pair<std::string, nlohmann::json>> &runs);

} // namespace geobarrier::detail

#endif // GEOBARRIER_RUN_CONVERGENCE_HPP
