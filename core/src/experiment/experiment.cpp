// Reading and validating experiment files, structure and values (each error names the JSON path, the value and the
// rule), and the settings' defaults (quality presets, the engine's settings by JSON path). What the experiment's
// plugins and products then need is experiment_resolve.cpp's.
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/frames.hpp>

#include "experiment/json_reader.hpp"
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>

namespace fs = std::filesystem;
using nlohmann::json;

namespace geobarrier {

const std::vector<ProductInfo> &known_products() {
    static const std::vector<ProductInfo> products = {
        {"ftle", {"ftle"}, "finite-time Lyapunov exponent log(lambda2) / (2 |t1 - t0|)"},
        {"eigenvalues", {"lambda1", "lambda2"}, "Cauchy-Green eigenvalues lambda1 <= lambda2"},
        {"eigenvectors", {"xi1_x", "xi1_y", "xi2_x", "xi2_y"}, "unit Cauchy-Green eigenvectors, xi2 = Omega xi1"},
        {"flow_map", {"flow_x", "flow_y"}, "the flow map F(x0) at t1"},
        {"strain_deviation",
         {"strain_deviation"},
         "geodesic strain deviation d_g^xi1 of strainlines (paper eq. gdev_str, general form for damped systems)"},
        {"shear_deviation_plus",
         {"shear_deviation_plus"},
         "geodesic shear deviation d_g^eta+ of eta+ shearlines (paper eq. dg_shr, general form for damped systems)"},
        {"shear_deviation_minus",
         {"shear_deviation_minus"},
         "geodesic shear deviation d_g^eta- of eta- shearlines (paper eq. dg_shr, general form for damped systems)"},
    };
    return products;
}

bool Experiment::wants(const std::string &product) const {
    return std::find(products.begin(), products.end(), product) != products.end();
}

namespace {

using detail::ObjectReader;
using detail::short_dump;
using detail::type_name;

// Composite forcings may nest (a ramp of a sum, say), this deep at most.
constexpr int max_forcing_depth = 8;

// `forcing_depth` >= 0 reads a forcing, which may name the terms of a composite forcing in "terms": [...] or, for
// one term, "base": {...}; whether the plugin is composite is checked once it is found (resolve_experiment).
PluginUse read_plugin_use(const json &j, const std::string &path, int forcing_depth = -1) {
    ObjectReader r(j, path);
    PluginUse use;
    use.plugin = r.string("plugin", std::nullopt);
    if (use.plugin.empty()) throw ConfigError(r.child("plugin"), "\"\" is empty; expected a plugin name");
    if (r.has("params")) {
        use.params = r.get("params");
        if (!use.params.is_object())
            throw ConfigError(r.child("params"), short_dump(use.params) + " is " + type_name(use.params) +
                                                     "; expected an object of parameters");
    }
    if (forcing_depth >= 0) {
        const bool has_base = r.has("base"), has_terms = r.has("terms");
        if (has_base && has_terms)
            throw ConfigError(r.child("base"), "give either \"base\" (one forcing) or \"terms\" (a list), not both");
        if ((has_base || has_terms) && forcing_depth + 1 >= max_forcing_depth)
            throw ConfigError(r.child(has_base ? "base" : "terms"),
                              "composite forcings nested more than " + std::to_string(max_forcing_depth) + " deep");
        if (has_base) {
            use.terms_key = "base";
            use.terms.push_back(read_plugin_use(r.get("base"), r.child("base"), forcing_depth + 1));
        } else if (has_terms) {
            const json &t = r.get("terms");
            if (!t.is_array() || t.empty())
                throw ConfigError(r.child("terms"), short_dump(t) + " must be a non-empty array of forcings " +
                                                        "[{\"plugin\": ...}, ...]");
            use.terms_key = "terms";
            for (std::size_t i = 0; i < t.size(); ++i)
                use.terms.push_back(
                    read_plugin_use(t[i], r.child("terms") + "/" + std::to_string(i), forcing_depth + 1));
        }
    }
    use.json_path = path;
    r.finish();
    return use;
}

} // namespace

IntegratorSettings quality_preset(const std::string &quality) {
    // Measured on the paper's first example at N = 1000 (docs/experiment-format.md, "Quality presets"). The fixed
    // steps are in time units (ceil(|T| / step) equal steps); the tolerances are the ones the presets' adaptive
    // runs use, and the auxiliary-grid offset rule reads (default_aux_offset).
    IntegratorSettings s;
    s.engine = "lockstep";
    s.method = "dop853";
    if (quality == "draft") {
        s.adaptive = false;
        s.step = 0.6;
        s.step_tolerance = 3e-3;
        s.rtol = 1e-6;
        s.atol = 1e-8;
    } else if (quality == "standard") {
        s.adaptive = false;
        s.step = 0.33;
        s.step_tolerance = 2e-4;
        s.rtol = 1e-8;
        s.atol = 1e-10;
    } else if (quality == "publication") {
        // About twice standard's steps: FTLE error 4e-9 mean, 4e-5 max on W. (Adaptive dop853 reaches 2.5e-3 max
        // at rtol = atol = 1e-6 for 2.6x the time of this.)
        s.adaptive = false;
        s.step = 0.18;
        s.step_tolerance = 2e-5;
        s.rtol = 1e-10;
        s.atol = 1e-12;
    } else {
        const std::vector<std::string> choices{"draft", "standard", "publication"};
        std::string msg = "\"" + quality + "\" is not one of: \"draft\" \"standard\" \"publication\"";
        const std::string hint = did_you_mean(quality, choices);
        if (!hint.empty()) msg += "; did you mean \"" + hint + "\"?";
        throw ConfigError("/quality", msg);
    }
    return s;
}

double default_aux_offset(const IntegratorSettings &integrator, const Grid &grid) {
    // The centred difference D = (F(x + d) - F(x - d)) / 2d has three errors. Integration: the four neighbours share
    // a lockstep batch and the step-size control bounds the error of D itself by the tolerances (flow_map.cpp,
    // DifferenceControl), so the tol / d noise that makes a tiny offset with loose tolerances noisy in
    // one-trajectory-at-a-time codes is not there. Rounding: independent per lane, ~ u sqrt(N) |x| / d (u = 1.1e-16,
    // N ~ 100 steps), which must stay below tau, so d >= 1e-14 / tau with a factor 3 to spare; else the control would
    // shrink the steps chasing rounding noise. Nonlinearity: grows with d where |DF| d approaches 1 (the most
    // stretched points), so d stays small: 1e-3 of the grid spacing unless the rounding bound needs more.
    const double tau = std::max(integrator.rtol, integrator.atol);
    const double spacing = std::min(grid.dx(), grid.dy());
    const double rounding = spacing > 0.0 ? 1e-14 / (tau * spacing) : 0.0;
    return std::min(0.5, std::max(1e-3, rounding));
}

std::string json_path_of(EngineSetting setting) {
    switch (setting) {
    case EngineSetting::system:
        return "/system/plugin";
    case EngineSetting::method:
        return "/integrator/method";
    case EngineSetting::engine:
        return "/integrator/engine";
    case EngineSetting::rtol:
        return "/integrator/rtol";
    case EngineSetting::atol:
        return "/integrator/atol";
    case EngineSetting::step:
        return "/integrator/step";
    case EngineSetting::batch:
        return "/integrator/batch";
    case EngineSetting::max_steps:
        return "/integrator/max_steps";
    case EngineSetting::time:
        return "/time";
    case EngineSetting::gradient:
        return "/cauchy_green/method";
    case EngineSetting::offset:
        return "/cauchy_green/offset";
    case EngineSetting::grid:
        return "/grid/n";
    }
    return "";
}

namespace {

// The sections of an experiment file, one reader each, in the order parse_experiment reads them.

// `slice` receives the grid's "axes" and "fixed" when it names axes.
Grid read_grid(const json &section, std::optional<GridSliceSpec> &slice_out) {
    ObjectReader g(section, "/grid");
    Grid grid;
    // A slice names its two axes (state components, checked against the system's names in resolve_experiment)
    // and gives their intervals under those names; a planar grid uses "x" and "y".
    std::array<std::string, 2> axis_keys{"x", "y"};
    if (g.has("axes")) {
        const json &axes = g.get("axes");
        if (!axes.is_array() || axes.size() != 2 || !axes[0].is_string() || !axes[1].is_string())
            throw ConfigError("/grid/axes", short_dump(axes) + " must be an array of two state component names");
        GridSliceSpec slice;
        for (int k = 0; k < 2; ++k) slice.axes[k] = axes[k].get<std::string>();
        if (slice.axes[0] == slice.axes[1])
            throw ConfigError("/grid/axes/1", "\"" + slice.axes[1] +
                                                  "\" is the grid's first axis too; name two "
                                                  "different state components");
        for (int k = 0; k < 2; ++k)
            if (slice.axes[k] == "axes" || slice.axes[k] == "n" || slice.axes[k] == "fixed")
                throw ConfigError("/grid/axes/" + std::to_string(k),
                                  "\"" + slice.axes[k] + "\" is a key of the grid, not a state component name");
        axis_keys = slice.axes;
        if (g.has("fixed")) {
            const json &fixed = g.get("fixed");
            if (!fixed.is_object())
                throw ConfigError("/grid/fixed", short_dump(fixed) + " must be an object {component: value}");
            for (const auto &[name, value] : fixed.items()) {
                const std::string path = "/grid/fixed/" + name;
                if (name == slice.axes[0] || name == slice.axes[1])
                    throw ConfigError(path, "fixes \"" + name +
                                                "\", which is an axis of the grid; a component "
                                                "is either on an axis or fixed");
                if (!value.is_number() || !std::isfinite(value.get<double>()))
                    throw ConfigError(path, short_dump(value) + " must be a finite number");
                slice.fixed.emplace_back(name, value.get<double>());
            }
        }
        slice_out = slice;
    } else if (g.has("fixed")) {
        throw ConfigError("/grid/fixed", "fixes components of a grid that names no \"axes\"; give \"axes\": "
                                         "[the two components the grid spans]");
    }
    std::tie(grid.x_min, grid.x_max) = g.interval(axis_keys[0]);
    std::tie(grid.y_min, grid.y_max) = g.interval(axis_keys[1]);
    const json &n = g.get("n");
    if (!n.is_array() || n.size() != 2 || !n[0].is_number_integer() || !n[1].is_number_integer())
        throw ConfigError("/grid/n", short_dump(n) + " must be an array of two integers [nx, ny]");
    // At least 3 points per direction: the centred differences of the fields (gradient of lambda2, curvatures
    // of the line fields) need a neighbour on each side.
    for (int k = 0; k < 2; ++k)
        if (n[k].get<long long>() < 3 || n[k].get<long long>() > 100000)
            throw ConfigError("/grid/n/" + std::to_string(k),
                              short_dump(n[k]) + " must be between 3 and 100000 (points, endpoints included)");
    grid.nx = n[0].get<std::size_t>();
    grid.ny = n[1].get<std::size_t>();
    g.finish();
    return grid;
}

void read_time(const json &section, Experiment &e) {
    ObjectReader t(section, "/time");
    // Frames (frames.hpp): several initial times, one horizon "T"; a single t0 takes "t1" or "T".
    if (t.has("t0") && (t.get("t0").is_array() || t.get("t0").is_object())) {
        e.frames = frame_initial_times(t.get("t0"), "/time/t0");
        e.t0 = e.frames.front();
    } else {
        e.t0 = t.number("t0");
    }
    if (t.has("T") && t.has("t1"))
        throw ConfigError("/time/T", "gives the horizon and \"t1\" the final time: give one of them (t1 = t0 + T)");
    if (!e.frames.empty() && !t.has("T"))
        throw ConfigError(t.has("t1") ? "/time/t1" : "/time",
                          "several initial times take one horizon \"T\" (t1 = t0 + T, negative for "
                          "backward time), not \"t1\"");
    e.t1 = t.has("T") ? e.t0 + t.number("T") : t.number("t1");
    if (e.t1 == e.t0)
        throw ConfigError(t.has("T") ? "/time/T" : "/time/t1", "equals t0; the interval must have nonzero length");
    // "both": the forward (t0 to t0 + |t1 - t0|) and the backward (t0 to t0 - |t1 - t0|) runs in one (tangle.hpp).
    e.both_directions = t.string("directions", "one", {"one", "both"}) == "both";
    if (t.has("period")) {
        e.forcing_period = t.positive("period");
        if (!e.both_directions)
            throw ConfigError("/time/period", "classifies the crossings of \"directions\": \"both\"; this experiment "
                                              "runs one direction");
    }
    if (!e.frames.empty() && e.both_directions)
        throw ConfigError("/time/directions", "\"both\" is not supported with several initial times: run the frames "
                                              "of each direction as two experiments");
    e.grow_periods = t.count("grow_periods", 0, 1, 10);
    if (e.grow_periods > 0 && !e.forcing_period)
        throw ConfigError("/time/grow_periods", "grows barriers over whole forcing periods; give the forcing's "
                                                "\"period\" too");
    t.finish();
}

Bounds read_bounds(const json &section, const std::optional<GridSliceSpec> &slice) {
    ObjectReader b(section, "/bounds");
    Bounds box{};
    // Over a slice the box limits the grid's axes, named as in the grid.
    std::tie(box.x_min, box.x_max) = b.interval(slice ? slice->axes[0] : "x");
    std::tie(box.y_min, box.y_max) = b.interval(slice ? slice->axes[1] : "y");
    // Trajectories that leave are data by default (open systems: escape, dissipative systems in backward time).
    box.exits = b.string("exits", "stop", {"stop", "mask"}) == "stop" ? ExitRule::stop : ExitRule::mask;
    b.finish();
    return box;
}

// Bounds that leave no grid point inside would stop (or mask) every trajectory before its first step: refused.
void check_grid_within(const Bounds &box, const Grid &grid) {
    const auto inside = [](double lo, double hi, double a, double b) { return b >= lo && a <= hi; };
    if (inside(box.x_min, box.x_max, grid.x_min, grid.x_max) && inside(box.y_min, box.y_max, grid.y_min, grid.y_max))
        return;
    throw ConfigError("/bounds", fmt::format("the box [{:g}, {:g}] x [{:g}, {:g}] holds no point of the grid [{:g}, "
                                             "{:g}] x [{:g}, {:g}]: every trajectory would start outside it",
                                             box.x_min, box.x_max, box.y_min, box.y_max, grid.x_min, grid.x_max,
                                             grid.y_min, grid.y_max));
}

// The experiment's own integrator keys, applied one by one over the quality preset's settings `s`; `warnings` gets
// what was adjusted.
void read_integrator(const json &section, IntegratorSettings &s, std::vector<std::string> &warnings) {
    ObjectReader r(section, "/integrator");
    s.method = r.string("method", s.method, {"dop853", "dopri5", "rkf78", "rk4", "rosenbrock4"});
    s.engine = r.string("engine", s.engine, {"lockstep", "odeint"});
    // Naming a method with an error estimate, or a tolerance, asks for adaptive steps unless "adaptive" says
    // otherwise; rk4 is fixed-step only and rosenbrock4 adaptive only.
    if (r.has("method") || r.has("rtol") || r.has("atol")) s.adaptive = s.method != "rk4";
    s.adaptive = r.boolean("adaptive", s.adaptive);
    if (s.adaptive && s.method == "rk4")
        throw ConfigError("/integrator/adaptive", "true, but rk4 has no error estimate: it runs fixed steps; use "
                                                  "dop853, dopri5 or rkf78 for adaptive steps");
    if (!s.adaptive && s.method == "rosenbrock4")
        throw ConfigError("/integrator/adaptive", "false, but rosenbrock4 runs adaptive steps only");
    if (s.engine == "odeint" && s.method == "dop853")
        throw ConfigError("/integrator/engine", "\"odeint\" has no dop853; use \"lockstep\" or the method dopri5, "
                                                "rkf78 or rk4");
    s.rtol = r.positive("rtol", s.rtol);
    if (s.rtol >= 1.0)
        throw ConfigError("/integrator/rtol", short_dump(r.get("rtol")) + " must be below 1 (a relative tolerance)");
    if (s.rtol < min_rtol) {
        // Double precision cannot honour it: each step's rounding error alone is ~1e-16 |x|.
        warnings.push_back("/integrator/rtol: " + short_dump(r.get("rtol")) +
                           " is below what double precision "
                           "can honour; clamped to 1e-14");
        s.rtol = min_rtol;
    }
    s.atol = r.positive("atol", s.atol);
    s.step = r.positive("step", s.step);
    if (r.has("step_tolerance")) {
        s.step_tolerance = r.number("step_tolerance");
        if (!(s.step_tolerance >= 0.0 && s.step_tolerance < 1.0))
            throw ConfigError("/integrator/step_tolerance",
                              short_dump(r.get("step_tolerance")) + " must be in [0, 1) (0 turns the step check off)");
    }
    s.batch = r.count("batch", s.batch, 1);
    s.max_steps = r.count("max_steps", s.max_steps, 1);
    if (s.method == "rk4" && !r.has("step"))
        throw ConfigError("/integrator", "method \"rk4\" is fixed-step: give \"step\" (a time step, e.g. 0.01)");
    r.finish();
}

void read_cauchy_green(const json &section, Experiment &e) {
    ObjectReader r(section, "/cauchy_green");
    e.gradient_method = r.string("method", e.gradient_method, {"auto", "auxiliary-grid", "variational"});
    if (r.has("slice_tensor")) {
        const std::string tensor = r.string("slice_tensor", "full", {"full", "restricted", "projected"});
        if (!e.slice)
            throw ConfigError("/cauchy_green/slice_tensor",
                              "\"" + tensor +
                                  "\" applies to grids over a slice "
                                  "(\"grid\": {\"axes\": ...}), and this grid names no axes");
        e.slice->tensor = tensor == "restricted"  ? SliceTensor::restricted
                          : tensor == "projected" ? SliceTensor::projected
                                                  : SliceTensor::full;
    }
    e.aux_offset = r.positive("offset", default_aux_offset(e.integrator, e.grid));
    if (e.aux_offset > 0.5)
        throw ConfigError("/cauchy_green/offset",
                          std::to_string(e.aux_offset) + " must be at most 0.5 (a fraction of the grid spacing)");
    r.finish();
}

// The requested products, each once, in the order written.
std::vector<std::string> read_products(const json &p) {
    if (!p.is_array()) throw ConfigError("/products", short_dump(p) + " must be an array of product names");
    std::vector<std::string> names, products;
    for (const auto &info : known_products()) names.push_back(info.name);
    for (std::size_t i = 0; i < p.size(); ++i) {
        const std::string path = "/products/" + std::to_string(i);
        if (!p[i].is_string()) throw ConfigError(path, short_dump(p[i]) + " must be a product name (a string)");
        const std::string name = p[i].get<std::string>();
        if (std::find(names.begin(), names.end(), name) == names.end()) {
            std::string msg = "unknown product \"" + name + "\"";
            const std::string hint = did_you_mean(name, names);
            if (!hint.empty()) msg += "; did you mean \"" + hint + "\"?";
            msg += " (known:";
            for (const auto &n : names) msg += " " + n;
            throw ConfigError(path, msg + ")");
        }
        if (std::find(products.begin(), products.end(), name) == products.end()) products.push_back(name);
    }
    return products;
}

std::vector<PluginUse> read_extractors(const json &x) {
    if (!x.is_array()) throw ConfigError("/extractors", short_dump(x) + " must be an array of {\"plugin\": ...}");
    std::vector<PluginUse> extractors;
    for (std::size_t i = 0; i < x.size(); ++i)
        extractors.push_back(read_plugin_use(x[i], "/extractors/" + std::to_string(i)));
    return extractors;
}

void read_validation(const json &section, Experiment &e) {
    e.validation = parse_validation(section, "/validation");
    // Products built on the found barriers need an extractor to find them.
    const bool barrier_seeds = e.validation.poincare && e.validation.poincare->barrier_points > 0;
    if ((e.validation.advect_barriers || barrier_seeds) && e.extractors.empty())
        throw ConfigError(barrier_seeds ? "/validation/poincare/barrier_points" : "/validation/advect_barriers",
                          "works on the barriers the extractors find, and there is no extractor: add one to "
                          "\"extractors\" (e.g. {\"plugin\": \"elliptic\"})");
}

// One factor of "convergence"'s "grid" or "horizon": finite, in (0, max_factor], not 1 (that repeats the run).
double convergence_factor(const json &v, const std::string &path, double max_factor, const char *what) {
    if (!v.is_number())
        throw ConfigError(path, short_dump(v) + " is " + type_name(v) + "; expected a factor of the " + what);
    const double f = v.get<double>();
    if (!std::isfinite(f) || !(f > 0) || f > max_factor || f == 1.0)
        throw ConfigError(path, short_dump(v) + " must be a factor of the " + what + " greater than 0, at most " +
                                    fmt::format("{:g}", max_factor) + " and other than 1 (1 repeats the run)");
    return f;
}

// A factor or an array of factors (each a changed run).
std::vector<double> convergence_factors(const ObjectReader &c, const std::string &key, double max_factor,
                                        const char *what) {
    if (!c.has(key)) return {};
    const json &v = c.get(key);
    if (!v.is_array()) return {convergence_factor(v, c.child(key), max_factor, what)};
    if (v.empty()) throw ConfigError(c.child(key), "[] is empty; give a factor or leave the key out");
    std::vector<double> factors;
    for (std::size_t k = 0; k < v.size(); ++k)
        factors.push_back(convergence_factor(v[k], c.child(key) + "/" + std::to_string(k), max_factor, what));
    return factors;
}

// "convergence": the changed runs (docs/experiment-format.md, "Convergence"). Whether an extractor declares each
// of "extractor_keys" and takes its value is checked when the experiment is resolved (run/convergence.hpp).
ConvergenceSpec read_convergence(const json &section, const Experiment &e) {
    if (e.extractors.empty())
        throw ConfigError("/convergence", "compares the barriers of changed runs, and the experiment has no "
                                          "\"extractors\": add one or leave \"convergence\" out");
    ObjectReader c(section, "/convergence");
    ConvergenceSpec spec;
    // A grid 4 times finer costs 16 flow maps; a horizon 10 times longer is another experiment.
    spec.grid = convergence_factors(c, "grid", 4.0, "grid's intervals");
    spec.horizon = convergence_factors(c, "horizon", 10.0, "horizon t1 - t0");
    if (c.has("extractor_keys")) {
        const json &keys = c.get("extractor_keys");
        if (!keys.is_array() || keys.empty())
            throw ConfigError("/convergence/extractor_keys",
                              short_dump(keys) + " must be a non-empty array of objects, each {key: value, ...} of "
                                                 "extractor parameters for one changed run");
        for (std::size_t k = 0; k < keys.size(); ++k) {
            if (!keys[k].is_object() || keys[k].empty())
                throw ConfigError("/convergence/extractor_keys/" + std::to_string(k),
                                  short_dump(keys[k]) + " must be a non-empty object {key: value, ...} of extractor "
                                                        "parameters (e.g. {\"line_step\": 0.004})");
            spec.extractor_keys.push_back(keys[k]);
        }
    }
    spec.threshold = c.number("threshold", spec.threshold);
    if (!(spec.threshold > 0) || spec.threshold > 1)
        throw ConfigError("/convergence/threshold",
                          short_dump(c.get("threshold")) + " must be a share of a barrier's length, in (0, 1]");
    spec.spacings = c.positive("spacings", spec.spacings);
    c.finish();
    if (spec.grid.empty() && spec.horizon.empty() && spec.extractor_keys.empty())
        throw ConfigError("/convergence", "asks for no changed run: give at least one of \"grid\", \"horizon\" and "
                                          "\"extractor_keys\" (e.g. {\"grid\": 1.5, \"horizon\": [0.9, 1.1]})");
    return spec;
}

// Folders relative to the experiment's folder `base`.
std::vector<fs::path> read_plugin_paths(const json &p, const fs::path &base) {
    if (!p.is_array()) throw ConfigError("/plugin_paths", short_dump(p) + " must be an array of folder paths");
    std::vector<fs::path> folders;
    for (std::size_t i = 0; i < p.size(); ++i) {
        if (!p[i].is_string())
            throw ConfigError("/plugin_paths/" + std::to_string(i), short_dump(p[i]) + " must be a folder path");
        const fs::path folder = p[i].get<std::string>();
        folders.push_back(folder.is_absolute() ? folder : base / folder);
    }
    return folders;
}

void read_output(const ObjectReader &root, const fs::path &file, Experiment &e) {
    const std::string stem = file.empty() ? std::string("experiment") : file.stem().string();
    if (!root.has("output")) {
        e.output_dir = "out/" + stem;
        return;
    }
    ObjectReader o(root.get("output"), "/output");
    e.output_dir = o.string("dir", "out/" + stem);
    if (e.output_dir.empty()) throw ConfigError("/output/dir", "\"\" is empty; expected a folder path");
    e.plots = o.boolean("plots", e.plots);
    o.finish();
}

} // namespace

Experiment parse_experiment(const json &j, const fs::path &file) {
    Experiment e;
    e.file = file;
    e.source = j;
    ObjectReader root(j, "");
    const fs::path base = file.empty() ? fs::current_path() : fs::absolute(file).parent_path();

    e.description = root.string("description", std::string());
    e.system = read_plugin_use(root.get("system"), "/system");
    if (root.has("forcing"))
        e.forcing = read_plugin_use(root.get("forcing"), "/forcing", 0);
    else
        e.forcing = PluginUse{"none", json::object(), "/forcing", {}, ""};
    e.grid = read_grid(root.get("grid"), e.slice);
    read_time(root.get("time"), e);
    if (root.has("bounds")) {
        e.bounds = read_bounds(root.get("bounds"), e.slice);
        check_grid_within(*e.bounds, e.grid);
    }
    // The quality preset sets the integrator; the experiment's own integrator keys override it one by one.
    e.quality = root.string("quality", e.quality, {"draft", "standard", "publication"});
    e.integrator = quality_preset(e.quality);
    if (root.has("integrator")) read_integrator(root.get("integrator"), e.integrator, e.warnings);
    if (root.has("cauchy_green"))
        read_cauchy_green(root.get("cauchy_green"), e);
    else
        e.aux_offset = default_aux_offset(e.integrator, e.grid);
    if (root.has("products")) e.products = read_products(root.get("products"));
    if (root.has("extractors")) e.extractors = read_extractors(root.get("extractors"));
    if (e.both_directions && e.extractors.empty()) // before anything runs: validate and a sweep's checks say so
        throw ConfigError("/time/directions",
                          "\"both\" looks for crossings of barriers, but the experiment has no \"extractors\"");
    if (root.has("validation")) read_validation(root.get("validation"), e);
    if (!e.frames.empty() && root.has("validation")) // its times are the run's: not defined for several frames yet
        throw ConfigError("/validation", "validation products are not supported with several initial times "
                                         "(\"time\": {\"t0\": [...]}): run them on a single t0");
    if (root.has("convergence")) e.convergence = read_convergence(root.get("convergence"), e);
    if (root.has("plugin_paths")) e.plugin_paths = read_plugin_paths(root.get("plugin_paths"), base);
    read_output(root, file, e);
    if (e.products.empty() && e.extractors.empty() && e.validation.empty())
        throw ConfigError("/products", "nothing to compute: request at least one product (e.g. [\"ftle\"]), an "
                                       "extractor or a validation product");
    root.finish();
    return e;
}

namespace {

// Deeper JSON would meet recursive code further on (dumps in messages, comparisons); no experiment needs more than a
// few levels, so the parser refuses more (100000 nested brackets crashed the program by stack overflow).
constexpr int max_json_depth = 64;
struct TooDeep {};

// "line:col" of byte `offset` (0-based) in `text`.
std::string line_column(const std::string &text, std::size_t offset) {
    std::size_t line = 1, col = 1;
    for (std::size_t k = 0; k < offset && k < text.size(); ++k) {
        if (text[k] == '\n') {
            ++line;
            col = 1;
        } else {
            ++col;
        }
    }
    return std::to_string(line) + ":" + std::to_string(col);
}

} // namespace

json parse_json_text(const std::string &text, const std::string &where) {
    const json::parser_callback_t depth_guard = [](int depth, json::parse_event_t, json &) {
        if (depth > max_json_depth) throw TooDeep{};
        return true;
    };
    json j;
    try {
        j = json::parse(text, depth_guard, true, /*ignore_comments=*/true);
    } catch (const json::parse_error &e) {
        // nlohmann's message names the byte offset; give line and column too.
        std::string what = e.what();
        const auto pos = what.find("parse error");
        throw ConfigError(where + ":" + line_column(text, e.byte > 0 ? e.byte - 1 : 0),
                          "not valid JSON: " + (pos == std::string::npos ? what : what.substr(pos)));
    } catch (const json::out_of_range &e) {
        // 406: a number beyond the double range ("number overflow parsing '1e999'"): point at its first occurrence.
        const std::string what = e.what();
        const auto open = what.find('\''), close = what.rfind('\'');
        const std::string token =
            open != std::string::npos && close > open ? what.substr(open + 1, close - open - 1) : std::string();
        const std::size_t at = token.empty() ? std::string::npos : text.find(token);
        throw ConfigError(where + (at == std::string::npos ? std::string() : ":" + line_column(text, at)),
                          "not valid JSON: the number " + (token.empty() ? std::string("given") : token) +
                              " is beyond the range of a double");
    } catch (const TooDeep &) {
        throw ConfigError(where, "JSON nested deeper than " + std::to_string(max_json_depth) +
                                     " levels; an experiment needs a few");
    }
    return j;
}

Experiment parse_experiment_text(const std::string &text, const fs::path &file) {
    const json j = parse_json_text(text, file.empty() ? std::string("<experiment>") : file.string());
    if (file.empty()) return parse_experiment(j, file);
    try {
        return parse_experiment(j, file);
    } catch (const ConfigError &e) {
        throw ConfigError(file.string() + ": " + e.json_path(), std::string(e.what()).substr(e.json_path().size() + 2));
    }
}

Experiment load_experiment(const fs::path &file) {
    std::error_code ec;
    if (fs::is_directory(file, ec)) throw IoError(file.string() + ": is a folder, not an experiment file");
    std::ifstream in(file, std::ios::binary);
    if (!in) throw IoError(file.string() + ": cannot open the experiment file");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) throw IoError(file.string() + ": cannot read the experiment file");
    return parse_experiment_text(text, file);
}

} // namespace geobarrier
