// Stage 3, one extractor on fields over an experiment's grid: what the runner does for each of an experiment's
// extractors and what the Python module's barriers() does on fields computed before, so that both give the same
// barriers from the same fields.
#ifndef GEOBARRIER_EXTRACTION_HPP
#define GEOBARRIER_EXTRACTION_HPP

#include <geobarrier/experiment.hpp>
#include <geobarrier/plugin.hpp>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace geobarrier {

// The host's advection service for extractors: the experiment's system and integrator, and the grid's engine and
// gradient method (flow_map_at_points), so advected points get the same batching and, on the auxiliary grid, the
// same difference-aware error control; the offset is relative to the grid spacing. Holds a reference to `r`.
ExtractServices advection_services(const ResolvedExperiment &r);

// The barriers an extractor found: as barriers.json items, and as Barrier values for the validation products. An
// item an extractor marks "candidate": true is a curve it does not assert as a barrier (too weak by its criterion): it
// goes to "candidates", not to "items", and `barriers` does not hold it.
struct FoundBarriers {
    nlohmann::json items = nlohmann::json::array();
    nlohmann::json candidates = nlohmann::json::array();
    std::vector<Barrier> barriers;
};

// Runs extractor `x` of `r` on `inputs` (its required fields over r's grid, row-major ny x nx) and `mask` (MaskBits
// per grid point), writing its own files into `out_dir` (pictures when `plots`), and appends what it found to `found`.
// The axes of its pictures carry the system's state names and units (a slice's two axes).
void run_extractor(const ResolvedExperiment &r, const Extractor &x, const std::vector<gb_field> &inputs,
                   const std::uint8_t *mask, const std::string &out_dir, bool plots, const ExtractServices &services,
                   FoundBarriers &found);

} // namespace geobarrier

#endif // GEOBARRIER_EXTRACTION_HPP
