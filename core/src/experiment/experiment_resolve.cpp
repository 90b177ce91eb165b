// Resolving a read experiment (experiment.hpp): its plugins created from the registry with their parameters checked
// against their schemas (an `equations` system compiled first), the slice of a higher-dimensional state, the stages
// the requested products need, the memory they take, and the settings as resolved, echoed into the manifest.
#include "equations/equations.hpp"
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/frames.hpp>

#include "engine/tiles.hpp"
#include "experiment/resources.hpp"
#include "run/convergence.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using nlohmann::json;

namespace geobarrier {

namespace {

// String parameters with the unit "path" name files relative to the experiment's folder: make them absolute
// before the plugin sees them, so an experiment runs the same from any working directory.
json resolve_path_params(const PluginInfo &info, const json &params, const fs::path &base) {
    json out = params;
    if (!out.is_object()) return out;
    for (const ParamSpec &p : info.params) {
        if (p.type != ParamType::string || p.unit != "path" || !out.contains(p.name) || !out[p.name].is_string())
            continue;
        const fs::path value = out[p.name].get<std::string>();
        if (!value.empty() && value.is_relative()) out[p.name] = (base / value).lexically_normal().string();
    }
    return out;
}

// Field names extractors may ask for, and what produces them: the products' grid fields, and exit_time (every run
// supplies it, all NaN when nothing can exit: abi.h).
bool is_cauchy_green_field(const std::string &name) {
    if (name == "exit_time") return true;
    for (const auto &p : known_products())
        if (std::string(p.name) != "flow_map")
            for (const char *v : p.variables)
                if (name == v) return true;
    return false;
}

} // namespace

namespace {

// Creates the plugins an experiment names, each from the registry with its parameters checked against its schema
// (string parameters with the unit "path" made absolute against the experiment's folder).
class PluginMaker {
  public:
    explicit PluginMaker(ResolvedExperiment &r)
        : m_r(r),
          m_base(r.experiment.file.empty() ? fs::current_path() : fs::absolute(r.experiment.file).parent_path()) {}

    std::pair<const PluginHandle *, ParamValues> create(PluginKind kind, const PluginUse &use) const {
        const PluginHandle &h = m_r.registry.find(kind, use.plugin, use.json_path + "/plugin");
        return {&h,
                validate_params(h.info, resolve_path_params(h.info, use.params, m_base), use.json_path + "/params")};
    }

    // The system; `echo` receives its resolved form for the manifest.
    System system(const PluginUse &use, json &echo) const {
        if (use.plugin == equations::plugin_name) {
            // Written in the experiment: compiled (or found in the cache) and loaded like any plugin (equations.hpp).
            const equations::Compiled compiled = equations::compile(use.params, use.json_path + "/params");
            json params = use.params;
            params["constants"] = params_to_json(compiled.handle.info, compiled.values);
            echo = {{"plugin", equations::plugin_name}, {"params", params}, {"compiled", compiled.record}};
            return System(compiled.handle, compiled.values);
        }
        auto [h, values] = create(PluginKind::system, use);
        echo = {{"plugin", h->info.name}, {"params", params_to_json(h->info, values)}};
        return System(*h, values);
    }

    // A forcing. A composite forcing's terms are created first and handed to it (plugin.hpp, Forcing): the core
    // evaluates them, plugins never call each other. `echo` receives the resolved tree for the manifest.
    Forcing forcing(const PluginUse &use, json &echo) const {
        auto [h, values] = create(PluginKind::forcing, use);
        const PluginInfo &info = h->info;
        echo = {{"plugin", info.name}, {"params", params_to_json(info, values)}};
        if (!info.composite()) {
            if (use.terms.empty()) return Forcing(*h, values);
            throw ConfigError(use.json_path + "/" + use.terms_key,
                              "forcing '" + info.name + "' is not a composite forcing and takes no \"" + use.terms_key +
                                  "\" (composite forcings here: " + composite_forcings() + ")");
        }
        check_term_count(info, use);
        std::vector<Forcing> terms;
        json echo_terms = json::array();
        for (const PluginUse &term : use.terms) {
            json term_echo;
            terms.push_back(forcing(term, term_echo));
            echo_terms.push_back(term_echo);
        }
        if (use.terms_key == "base")
            echo["base"] = echo_terms[0];
        else
            echo["terms"] = echo_terms;
        return Forcing(*h, values, std::move(terms));
    }

    // The extractors; `echo` receives their resolved forms.
    std::vector<Extractor> extractors(const std::vector<PluginUse> &uses, json &echo) const {
        std::vector<Extractor> out;
        echo = json::array();
        for (const PluginUse &use : uses) {
            auto [h, values] = create(PluginKind::extractor, use);
            for (const auto &field : h->info.required_fields)
                if (!is_cauchy_green_field(field))
                    throw ConfigError(use.json_path + "/plugin",
                                      "extractor '" + h->info.name + "' needs field \"" + field +
                                          "\", which this version of the core cannot compute");
            out.emplace_back(*h, values);
            echo.push_back({{"plugin", h->info.name}, {"params", params_to_json(h->info, values)}});
        }
        return out;
    }

  private:
    std::string composite_forcings() const {
        std::string composites;
        for (const PluginHandle &other : m_r.registry.plugins())
            if (other.info.kind == PluginKind::forcing && other.info.composite())
                composites += (composites.empty() ? "" : ", ") + other.info.name;
        // The registry maps only the libraries the experiment names: the others' plugins are not known here.
        return composites.empty() ? "see geobarrier plugins" : composites;
    }

    static void check_term_count(const PluginInfo &info, const PluginUse &use) {
        const std::string range = info.min_terms == info.max_terms
                                      ? std::to_string(info.min_terms)
                                      : std::to_string(info.min_terms) + " to " + std::to_string(info.max_terms);
        if (use.terms.size() < info.min_terms)
            throw ConfigError(use.json_path, "forcing '" + info.name + "' combines " + range + " other forcing(s), " +
                                                 "found " + std::to_string(use.terms.size()) + ": give " +
                                                 (info.max_terms == 1 ? "\"base\": {\"plugin\": ...}"
                                                                      : "\"terms\": [{\"plugin\": ...}, ...]"));
        if (use.terms.size() > info.max_terms)
            throw ConfigError(use.terms[info.max_terms].json_path, "forcing '" + info.name + "' combines " + range +
                                                                       " other forcing(s), found " +
                                                                       std::to_string(use.terms.size()));
    }

    ResolvedExperiment &m_r;
    fs::path m_base;
};

// The names an experiment gives a system's state components: the declared ones, else x, y (planar) or x1 .. xn.
std::vector<std::string> state_component_names(const PluginInfo &system) {
    std::vector<std::string> names;
    for (std::uint32_t i = 0; i < system.dimension; ++i) {
        if (i < system.state_names.size() && !system.state_names[i].empty())
            names.push_back(system.state_names[i]);
        else if (system.dimension == 2)
            names.push_back(i == 0 ? "x" : "y");
        else
            names.push_back("x" + std::to_string(i + 1));
    }
    return names;
}

// The grid's slice against the system's components: each axis names one, every other component is fixed, and a
// system of more than two components needs a slice. Errors name the JSON path.
std::optional<Slice> resolve_slice(const Experiment &e, const PluginInfo &system) {
    // The engine's limit first, before anything is sized from the dimension (the loader bounds it too: plugin.hpp).
    if (system.dimension > max_dimension)
        throw ConfigError("/system/plugin", "system '" + system.name + "' has dimension " +
                                                std::to_string(system.dimension) +
                                                "; the flow map engine handles "
                                                "dimensions 2 to " +
                                                std::to_string(max_dimension));
    const std::vector<std::string> names = state_component_names(system);
    std::string listed;
    for (const auto &n : names) listed += (listed.empty() ? "" : " ") + n;
    if (!e.slice) {
        if (system.dimension != 2)
            throw ConfigError("/grid", "system '" + system.name + "' has " + std::to_string(system.dimension) +
                                           " state components (" + listed +
                                           "): name the two the grid spans with "
                                           "\"axes\" and fix the others with \"fixed\"");
        return std::nullopt;
    }
    const auto index_of = [&](const std::string &name, const std::string &path) {
        const auto it = std::find(names.begin(), names.end(), name);
        if (it == names.end()) {
            std::string msg =
                "\"" + name + "\" is not a state component of system '" + system.name + "' (" + listed + ")";
            const std::string hint = did_you_mean(name, names);
            if (!hint.empty()) msg += "; did you mean \"" + hint + "\"?";
            throw ConfigError(path, msg);
        }
        return static_cast<unsigned>(it - names.begin());
    };
    Slice slice;
    slice.tensor = e.slice->tensor;
    slice.state.assign(system.dimension, std::numeric_limits<double>::quiet_NaN());
    for (std::size_t k = 0; k < 2; ++k) slice.axes[k] = index_of(e.slice->axes[k], "/grid/axes/" + std::to_string(k));
    std::vector<bool> given(system.dimension, false);
    given[slice.axes[0]] = given[slice.axes[1]] = true;
    for (const auto &[name, value] : e.slice->fixed) {
        const unsigned i = index_of(name, "/grid/fixed/" + name);
        slice.state[i] = value;
        given[i] = true;
    }
    for (std::uint32_t i = 0; i < system.dimension; ++i)
        if (!given[i])
            throw ConfigError("/grid/fixed", "gives no value for \"" + names[i] +
                                                 "\", which is not on an axis "
                                                 "either; every component of system '" +
                                                 system.name + "' (" + listed + ") is on an axis or fixed");
    return slice;
}

// What to compute: the gradient only for Cauchy–Green products or extractors, the positions only for the flow_map
// product; the gradient's method, checked against the system.
void plan_stages(ResolvedExperiment &r) {
    const Experiment &e = r.experiment;
    r.need_cauchy_green = e.wants("ftle") || e.wants("eigenvalues") || e.wants("eigenvectors") ||
                          e.wants("strain_deviation") || e.wants("shear_deviation_plus") ||
                          e.wants("shear_deviation_minus") || !e.extractors.empty();
    r.need_positions = e.wants("flow_map");
    const std::string &system_name = r.system.info().name;
    if (r.need_cauchy_green) {
        if (e.gradient_method == "auto")
            r.gradient = r.system.has_jacobian() ? GradientMethod::variational : GradientMethod::auxiliary_grid;
        else
            r.gradient = with_json_paths([&] { return parse_gradient_method(e.gradient_method); });
        if (r.gradient == GradientMethod::variational && !r.system.has_jacobian())
            throw ConfigError("/cauchy_green/method", "\"variational\" needs the system's Jacobian, and system '" +
                                                          system_name + "' provides none; use \"auxiliary-grid\"");
        if (r.slice && r.system.dimension() > 2 && r.gradient == GradientMethod::auxiliary_grid)
            throw ConfigError("/cauchy_green/method", "auxiliary-grid handles planar systems; system '" + system_name +
                                                          "' has dimension " + std::to_string(r.system.dimension()) +
                                                          ": give it a Jacobian (SDK plugins derive "
                                                          "one from a templated field) and use \"variational\"");
    }
    // The whole n x n tensor's eigenvectors do not lie in the slice: what is built on them needs a 2 x 2 tensor.
    if (r.slice && r.system.dimension() > 2 && r.slice->tensor == SliceTensor::full) {
        std::string needs;
        for (const char *product :
             {"eigenvectors", "strain_deviation", "shear_deviation_plus", "shear_deviation_minus"})
            if (e.wants(product)) needs += std::string(needs.empty() ? "" : ", ") + "product \"" + product + "\"";
        if (!e.extractors.empty()) needs += std::string(needs.empty() ? "" : ", ") + "extractors";
        if (!needs.empty())
            throw ConfigError("/cauchy_green/slice_tensor",
                              "\"full\" (the default over a slice): the eigenvectors of the whole " +
                                  std::to_string(r.system.dimension()) + " x " + std::to_string(r.system.dimension()) +
                                  " tensor do not lie in the slice, and " + needs +
                                  " need them; use \"restricted\" "
                                  "or \"projected\" (docs/experiment-format.md, grids as slices)");
    }
    // The extractors implement the geodesic theory of two-dimensional flow maps (docs/extractors.md, "Systems of
    // more than two components"). On a slice of a higher-dimensional system that theory holds for the projected
    // tensor of an invariant slice (the slice's own planar flow map, e.g. uncoupled components), and for nothing
    // else: the restricted tensor measures stretching that leaves the slice, whose curves are no material barriers.
    if (r.slice && r.system.dimension() > 2 && !e.extractors.empty()) {
        if (r.slice->tensor != SliceTensor::projected)
            throw ConfigError(
                e.extractors.front().json_path,
                "extractor '" + e.extractors.front().plugin +
                    "' finds barriers of a two-dimensional "
                    "flow map, and system '" +
                    system_name + "' has " + std::to_string(r.system.dimension()) +
                    " components: on a slice it needs \"cauchy_green\": {\"slice_tensor\": \"projected\"} "
                    "(exact when the slice is invariant, e.g. uncoupled components)");
        r.experiment.warnings.push_back(
            "/extractors: the barriers are those of the slice's projected flow map, material barriers of system '" +
            system_name + "' only where the slice is invariant (e.g. uncoupled components)");
    }
    if (e.integrator.method == "rosenbrock4" && !r.system.has_jacobian())
        throw ConfigError("/integrator/method", "\"rosenbrock4\" needs the system's Jacobian, and system '" +
                                                    system_name + "' provides none; use \"dopri5\"");
    // What the flow-map engine would refuse, refused now (geobarrier validate computes nothing).
    with_json_paths([&] {
        check_flow_map_settings(
            {r.dynamics(), e.t0, e.t1, e.integrator, r.need_cauchy_green ? r.gradient : GradientMethod::none});
    });
}

// The experiment's settings with every default filled in, into `resolved` (the manifest's "resolved").
void echo_settings(const ResolvedExperiment &r, json &resolved) {
    const Experiment &e = r.experiment;
    if (e.slice) {
        json fixed = json::object();
        for (const auto &[name, value] : e.slice->fixed) fixed[name] = value;
        resolved["grid"] = {{"axes", e.slice->axes},
                            {e.slice->axes[0], {e.grid.x_min, e.grid.x_max}},
                            {e.slice->axes[1], {e.grid.y_min, e.grid.y_max}},
                            {"n", {e.grid.nx, e.grid.ny}},
                            {"fixed", fixed}};
    } else {
        resolved["grid"] = {
            {"x", {e.grid.x_min, e.grid.x_max}}, {"y", {e.grid.y_min, e.grid.y_max}}, {"n", {e.grid.nx, e.grid.ny}}};
    }
    resolved["time"] = {{"t0", e.t0}, {"t1", e.t1}};
    if (!e.frames.empty()) resolved["time"] = {{"t0", e.frames}, {"T", e.t1 - e.t0}}; // frames.hpp
    if (e.both_directions) resolved["time"]["directions"] = "both";
    if (e.forcing_period) resolved["time"]["period"] = *e.forcing_period;
    if (e.grow_periods > 0) resolved["time"]["grow_periods"] = e.grow_periods;
    resolved["quality"] = e.quality;
    resolved["integrator"] = {{"method", e.integrator.method},
                              {"engine", e.integrator.engine},
                              {"adaptive", e.integrator.adaptive},
                              {"rtol", e.integrator.rtol},
                              {"atol", e.integrator.atol},
                              {"step", e.integrator.step},
                              {"batch", e.integrator.batch},
                              {"max_steps", e.integrator.max_steps},
                              {"step_tolerance", e.integrator.step_tolerance}};
    if (!e.integrator.adaptive) {
        const double span = std::abs(e.t1 - e.t0), ratio = span / e.integrator.step;
        resolved["integrator"]["fixed_steps"] =
            static_cast<std::uint64_t>(std::max(1.0, std::ceil(ratio - 1e-9 * ratio))); // as flow_map.cpp steps
    }
    resolved["cauchy_green"] = {{"method", r.need_cauchy_green ? to_string(r.gradient) : "none"},
                                {"offset", e.aux_offset}};
    if (r.slice)
        resolved["cauchy_green"]["slice_tensor"] = r.slice->tensor == SliceTensor::restricted  ? "restricted"
                                                   : r.slice->tensor == SliceTensor::projected ? "projected"
                                                                                               : "full";
    resolved["products"] = e.products;
    resolved["output"] = {{"dir", e.output_dir.string()}, {"plots", e.plots}};
    if (e.bounds)
        resolved["bounds"] = {{e.slice ? e.slice->axes[0] : "x", {e.bounds->x_min, e.bounds->x_max}},
                              {e.slice ? e.slice->axes[1] : "y", {e.bounds->y_min, e.bounds->y_max}},
                              {"exits", to_string(e.bounds->exits)}};
    if (!e.validation.empty()) resolved["validation"] = validation_to_json(e.validation, e.t0, e.t1);
}

} // namespace

ResolvedExperiment resolve_experiment(const Experiment &experiment) {
    ResolvedExperiment r{
        experiment,
        PluginRegistry(PluginRegistry::default_folders(experiment.plugin_paths), PluginLoading::on_demand),
        {},
        {},
        {},
        {},
        GradientMethod::none,
        false,
        false,
        json::object()};
    const Experiment &e = r.experiment;
    json resolved = e.source;
    const PluginMaker make(r);
    r.system = make.system(e.system, resolved["system"]);
    r.forcing = make.forcing(e.forcing, resolved["forcing"]);
    r.extractors = make.extractors(e.extractors, resolved["extractors"]);
    r.slice = resolve_slice(e, r.system.info());
    if (e.validation.section && e.validation.section->normal.size() != r.system.dimension())
        throw ConfigError("/validation/section/normal", "has " + std::to_string(e.validation.section->normal.size()) +
                                                            " components, and system '" + r.system.info().name +
                                                            "' has " + std::to_string(r.system.dimension()) +
                                                            " (the seeds likewise)");
    plan_stages(r);
    // Refuse up front a grid the machine cannot hold (the estimate of the tiled run errs on the high side).
    check_memory(estimate_run_memory(e.grid, e.integrator, plan_fields(r)), available_memory(), e.grid);
    echo_settings(r, resolved);
    if (e.convergence) { // the defaults the check uses
        resolved["convergence"]["threshold"] = e.convergence->threshold;
        resolved["convergence"]["spacings"] = e.convergence->spacings;
    }
    r.resolved = resolved;
    (void)detail::convergence_changes(r); // a changed run that could not run is refused now, not after this one
    return r;
}

} // namespace geobarrier
