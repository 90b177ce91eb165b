// An experiment: the validated contents of an experiment JSON file (the format
// is documented in docs/experiment-format.md), and the runner that computes
// exactly the stages its products and extractors need.
#ifndef GEOBARRIER_EXPERIMENT_HPP
#define GEOBARRIER_EXPERIMENT_HPP

#include <geobarrier/errors.hpp>
#include <geobarrier/flow_map.hpp>
#include <geobarrier/grid.hpp>
#include <geobarrier/plugin.hpp>
#include <geobarrier/validation.hpp>

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace geobarrier {

// A plugin named in the experiment, with its parameters as written.
struct PluginUse {
    std::string plugin;
    nlohmann::json params = nlohmann::json::object();
    std::string json_path; // e.g. "/extractors/0"
    // Forcings only: the terms of a composite forcing (e.g. "sum", "ramp"), written as "terms": [...] or, for one
    // term, "base": {...} (terms_key says which, for messages and the manifest). The core evaluates them.
    std::vector<PluginUse> terms;
    std::string terms_key;
};

// Field products a user may request, and the fields.nc variables each writes.
struct ProductInfo {
    const char *name;
    std::vector<const char *> variables;
    const char *doc;
};
const std::vector<ProductInfo> &known_products();

// A grid over two state components of an n-dimensional system, the others fixed ("grid": {"axes": [...],
// "fixed": {...}}), by the state names the system declares; checked against them when the experiment is resolved.
struct GridSliceSpec {
    std::array<std::string, 2> axes;
    std::vector<std::pair<std::string, double>> fixed; // as written, in order
    SliceTensor tensor = SliceTensor::full;            // "cauchy_green": {"slice_tensor": ...}
};

// "convergence" (docs/experiment-format.md): the run repeated with changed settings, and each barrier's share of
// length that the changed runs reproduce within `spacings` grid spacings (run/convergence.hpp). Empty lists: that
// change is not made.
struct ConvergenceSpec {
    std::vector<double> grid;                   // factors of the grid's intervals: n - 1 -> round((n - 1) f)
    std::vector<double> horizon;                // factors of the horizon t1 - t0
    std::vector<nlohmann::json> extractor_keys; // each an object of keys set in every extractor that declares them
    double threshold = 0.9;                     // a barrier converged: share >= threshold under every change
    double spacings = 2.0;                      // "near": within this many of the run's grid spacings
};

struct Experiment {
    std::filesystem::path file; // where it was read from ("" for in-memory)
    nlohmann::json source;      // the JSON as written
    std::string description;

    PluginUse system;
    PluginUse forcing; // {"plugin": "none"} when absent
    std::vector<PluginUse> extractors;
    std::vector<std::filesystem::path> plugin_paths; // resolved against the file's folder

    Grid grid;
    std::optional<GridSliceSpec> slice; // the grid's "axes" and "fixed" when given
    double t0 = 0.0, t1 = 1.0;
    // "time": {"t0": [...] or {"from", "to", "count"}, "T": ...}: the initial times of the frames (frames.hpp), t0 the
    // first of them and t1 = t0 + T; empty for a run of one initial time.
    std::vector<double> frames;
    bool both_directions = false; // "time": {"directions": "both"}: forward and backward from t0 (run_both_directions)
    // "time": {"period": P}: the forcing's period, with which run_both_directions tells the crossings at a saddle
    // orbit from those of a tangle (tangle.hpp); unset: crossings unclassified.
    std::optional<double> forcing_period;
    // "time": {"grow_periods": k}: the barriers of both directions grown over k forcing periods (tangle.hpp).
    std::size_t grow_periods = 0;
    std::optional<Bounds> bounds;
    std::string quality = "standard";     // the preset: draft | standard | publication (quality_preset)
    IntegratorSettings integrator;        // the preset's, with the experiment's own keys applied
    std::string gradient_method = "auto"; // auto | auxiliary-grid | variational
    double aux_offset = 1e-3;             // relative to the grid spacing; default: default_aux_offset(integrator, grid)
    std::vector<std::string> products;
    std::filesystem::path output_dir;
    bool plots = true;
    std::vector<std::string> warnings; // what parsing adjusted (e.g. a clamped rtol); copied into the manifest
    ValidationSpec validation;         // the "validation" object: products computed only when asked
    // The "convergence" object: changed runs, only when asked.
    std::optional<ConvergenceSpec> convergence;

    bool wants(const std::string &product) const;
};

// The integrator of a quality preset ("draft", "standard", "publication"; docs/experiment-format.md gives the
// measured time and FTLE error of each on the paper's first example). Throws ConfigError at /quality otherwise.
IntegratorSettings quality_preset(const std::string &quality);

// The auxiliary-grid offset (a fraction of the grid spacing) that goes with an integrator's tolerances when the
// experiment gives none: 1e-3, raised so that the offset in state units is at least 1e-14 / tau (tau = max(rtol,
// atol)) and the rounding noise of the centred differences stays below the tolerance; at most 0.5
// (docs/experiment-format.md, cauchy_green).
double default_aux_offset(const IntegratorSettings &integrator, const Grid &grid);

// The JSON path in an experiment file of a setting of the flow-map engine (flow_map.hpp, EngineSetting), e.g.
// "/integrator/rtol".
std::string json_path_of(EngineSetting setting);

// Runs `step`; a setting the engine refuses (EngineSettingError) comes out as the ConfigError at that setting's JSON
// path, with the engine's message. resolve_experiment and run_experiment report the engine's refusals this way.
template <class Step> auto with_json_paths(Step &&step) -> decltype(step()) {
    try {
        return step();
    } catch (const EngineSettingError &e) {
        throw ConfigError(json_path_of(e.setting()), e.message());
    }
}

// Parses and checks the structure and values of an experiment (not yet the
// plugins' parameters: see ResolvedExperiment). Every error is a ConfigError
// naming the JSON path, the value and the rule; unknown keys get a
// "did you mean" hint.
Experiment parse_experiment(const nlohmann::json &json, const std::filesystem::path &file = {});
Experiment load_experiment(const std::filesystem::path &file);
// The same from the text of an experiment file (`file` names it in messages and resolves relative paths). Malformed
// JSON is a ConfigError at "file:line:col"; so are numbers beyond the double range and nesting deeper than 64.
Experiment parse_experiment_text(const std::string &text, const std::filesystem::path &file = {});
// The JSON of an experiment (or sweep) file's text with those rules; `where` names the file in messages.
nlohmann::json parse_json_text(const std::string &text, const std::string &where);

// The experiment with its plugins found, parameters validated and objects created.
struct ResolvedExperiment {
    Experiment experiment;
    PluginRegistry registry;
    System system;
    Forcing forcing;
    std::optional<Slice> slice; // the grid's slice, component indices resolved against the system's state names
    std::vector<Extractor> extractors;
    GradientMethod gradient = GradientMethod::none;
    bool need_positions = false;
    bool need_cauchy_green = false;
    nlohmann::json resolved; // the experiment with every default filled in, for the manifest

    // What the flow map integrates: the system, its forcing and the grid's slice (if any).
    Dynamics dynamics() const { return Dynamics{&system, &forcing, slice ? &*slice : nullptr}; }
    // The state component along the grid's x (i = 0) or y (i = 1): the slice's axes, else 0 and 1.
    std::size_t plane_component(std::size_t i) const { return slice ? slice->axes[i] : i; }
};

ResolvedExperiment resolve_experiment(const Experiment &experiment);

// The most worker threads a run (or a sweep member) may ask for, in every interface: the command line's --threads, a
// sweep's "threads", Python's threads=. More would exhaust the machine's threads or OpenMP's own limits (libgomp aborts
// the process) before any work is done; run_experiment refuses more with a ConfigError at "threads".
constexpr int max_threads = 1024;

struct RunOptions {
    std::optional<std::filesystem::path> output_dir; // overrides output.dir
    int threads = 0;    // 0 = OpenMP's default (for this run only: restored afterwards); at most max_threads
    bool quiet = false; // no progress bar, warnings only
    // For programs that embed the library (the Python module). write_files = false: nothing is written and no
    // picture is drawn (the output folder is not touched; extractors and validation products write into a private
    // temporary folder that is removed). keep_results: RunSummary also holds the fields, the mask and the barriers.
    bool write_files = true;
    bool keep_results = false;
    // Called as a stage advances ("flow map": done/total grid rows; other stages: 0/1 when they start); possibly from
    // worker threads, one call at a time. Cancellation stays cancel.hpp's request_cancel.
    std::function<void(const std::string &stage, std::size_t done, std::size_t total)> progress;
};

// One variable of fields.nc, kept in memory (RunOptions::keep_results): shape (ny, nx), row index = y.
struct FieldResult {
    std::string name, long_name, units;
    std::uint8_t masked_by = 0; // fields.nc holds _FillValue where (mask & masked_by) != 0 or the value is not finite
    std::vector<double> values;
};

struct RunSummary {
    std::filesystem::path output_dir;         // empty when nothing was written
    std::vector<std::filesystem::path> files; // everything written
    nlohmann::json manifest;
    // keep_results only: what fields.nc and barriers.json hold.
    Grid grid;
    std::vector<FieldResult> fields;
    std::vector<FieldResult> coordinates; // x (nx values) and y (ny values)
    std::vector<std::uint8_t> mask;
    nlohmann::json field_attributes; // fields.nc's global attributes
    nlohmann::json barriers = nlohmann::json::array();
    nlohmann::json candidates = nlohmann::json::array(); // curves an extractor reported but does not assert
    // keep_results of a "directions": "both" run (tangle.hpp): the forward run's results, then the backward one's,
    // each as a run of one direction keeps them, and what tangle.json holds; grid, fields, mask and barriers above
    // stay empty.
    std::vector<RunSummary> directions;
    nlohmann::json tangle;
};

RunSummary run_experiment(const ResolvedExperiment &experiment, const RunOptions &options);

} // namespace geobarrier

#endif // GEOBARRIER_EXPERIMENT_HPP
