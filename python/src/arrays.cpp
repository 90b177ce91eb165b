// The array functions of the Python module (docs/python.md, "Arrays"): systems and forcings made from a plugin name,
// a plugin file or equations, the flow map of given states on the engine's batch API (flow_map_of_states, the
// integration the runner does, with a quality preset's settings), and the Cauchy–Green tensor and FTLE of given
// gradients with the core's own code (cauchy_green.hpp). Arrays cross as NumPy buffers, never as JSON; the GIL is
// released while the core computes. The Python side (python/geobarrier/_arrays.py) checks the arguments and names
// them in its errors; the checks here are the last line, so that no call can crash the interpreter.
#include "equations/equations.hpp"
#include "interrupt_scope.hpp"
#include <geobarrier/cancel.hpp>
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/extraction.hpp>
#include <geobarrier/flow_map.hpp>
#include <geobarrier/plugin.hpp>
#include <geobarrier/threads.hpp>

#include <Eigen/Dense>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <csignal>
#include <cstring>
#include <exception>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <signal.h>
#include <unistd.h>

namespace py = pybind11;
namespace fs = std::filesystem;
using geobarrier::python::InterruptScope;
using nlohmann::json;

namespace {

using namespace geobarrier;

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

// A system as Python holds it: the created plugin instance (which keeps its library loaded), its schema and its
// parameters with the defaults filled in.
struct NativeSystem {
    System system;
    json schema; // plugin_info_to_json of the plugin (the equations' generated plugin: its constants)
    json params; // resolved parameters
    // A plugin that is not GB_THREAD_SAFE_CONCURRENT may be called from one thread at a time (abi.h): calls from
    // several Python threads with the same object take turns on it.
    std::shared_ptr<std::mutex> turns = std::make_shared<std::mutex>();
};

struct NativeForcing {
    Forcing forcing;
    json schema;
    json params; // resolved parameters; a composite's terms under "terms"
    std::shared_ptr<std::mutex> turns = std::make_shared<std::mutex>();
};

// The turn of an object whose plugin must not be called from several threads at once; no lock for the others.
std::unique_lock<std::mutex> turn_of(const PluginInfo &info, std::mutex &turns) {
    return info.thread_safety == GB_THREAD_SAFE_CONCURRENT ? std::unique_lock<std::mutex>()
                                                           : std::unique_lock<std::mutex>(turns);
}

// Parameters as the experiment layer reads them: string parameters with the unit "path" made absolute, here against
// the current folder (an experiment's are against its file's folder).
json absolute_path_params(const PluginInfo &info, json params) {
    if (!params.is_object()) return params;
    for (const ParamSpec &p : info.params) {
        if (p.type != ParamType::string || p.unit != "path" || !params.contains(p.name) || !params[p.name].is_string())
            continue;
        const fs::path value = params[p.name].get<std::string>();
        if (!value.empty() && value.is_relative())
            params[p.name] = (fs::current_path() / value).lexically_normal().string();
    }
    return params;
}

std::vector<fs::path> folders_of(const std::vector<std::string> &plugin_paths) {
    return PluginRegistry::default_folders(std::vector<fs::path>(plugin_paths.begin(), plugin_paths.end()));
}

json parse_params(const std::string &text) {
    json j = json::parse(text, nullptr, false);
    if (j.is_discarded() || !j.is_object()) throw ConfigError("params", "not a JSON object of parameters");
    return j;
}

// geobarrier._geobarrier.make_system: a system plugin by name (or plugin file), its parameters checked against its
// schema; errors are ConfigErrors at "name" and "/<parameter>".
NativeSystem make_system(const std::string &name, const std::string &params_text,
                         const std::vector<std::string> &plugin_paths) {
    const json params = parse_params(params_text);
    py::gil_scoped_release no_gil;
    const PluginRegistry registry(folders_of(plugin_paths), PluginLoading::on_demand); // only what it names
    const PluginHandle &h = registry.find(PluginKind::system, name, "name");
    const ParamValues values = validate_params(h.info, absolute_path_params(h.info, params), "");
    NativeSystem s{System(h, values), plugin_info_to_json(h.info), params_to_json(h.info, values)};
    if (s.system.dimension() < 2 || s.system.dimension() > max_dimension)
        throw ConfigError("name", "system '" + h.info.name + "' has dimension " + std::to_string(s.system.dimension()) +
                                      "; the flow map engine handles 2 to " + std::to_string(max_dimension));
    return s;
}

// geobarrier._geobarrier.make_equations_system: the "equations" system (equations.hpp), compiled or taken from the
// cache; errors are ConfigErrors at "/state", "/rhs/1, column 9", "/constants/d".
NativeSystem make_equations_system(const std::string &params_text) {
    const json params = parse_params(params_text);
    py::gil_scoped_release no_gil;
    const equations::Compiled compiled = equations::compile(params, "");
    json resolved = params;
    resolved["constants"] = params_to_json(compiled.handle.info, compiled.values);
    return NativeSystem{System(compiled.handle, compiled.values), plugin_info_to_json(compiled.handle.info), resolved};
}

// geobarrier._geobarrier.make_forcing: a forcing plugin by name; a composite one (sum, ramp) gets its terms.
NativeForcing make_forcing(const std::string &name, const std::string &params_text,
                           const std::vector<const NativeForcing *> &terms,
                           const std::vector<std::string> &plugin_paths) {
    const json params = parse_params(params_text);
    std::vector<Forcing> term_objects;
    json term_params = json::array();
    for (const NativeForcing *t : terms) {
        if (!t) throw ConfigError("terms", "a term is None; give Forcing objects");
        term_objects.push_back(t->forcing);
        term_params.push_back(t->params);
    }
    py::gil_scoped_release no_gil;
    const PluginRegistry registry(folders_of(plugin_paths), PluginLoading::on_demand); // only what it names
    const PluginHandle &h = registry.find(PluginKind::forcing, name, "name");
    const ParamValues values = validate_params(h.info, absolute_path_params(h.info, params), "");
    json resolved = params_to_json(h.info, values);
    if (!h.info.composite()) {
        if (!term_objects.empty())
            throw ConfigError("terms", "forcing '" + h.info.name + "' is not a composite forcing and takes no terms");
        return NativeForcing{Forcing(h, values), plugin_info_to_json(h.info), resolved};
    }
    if (term_objects.size() < h.info.min_terms || term_objects.size() > h.info.max_terms)
        throw ConfigError(
            "terms",
            "forcing '" + h.info.name + "' combines " + std::to_string(h.info.min_terms) +
                (h.info.min_terms == h.info.max_terms ? std::string() : " to " + std::to_string(h.info.max_terms)) +
                " other forcing(s), given " + std::to_string(term_objects.size()));
    return NativeForcing{Forcing(h, values, std::move(term_objects)), plugin_info_to_json(h.info),
                         json{{"params", resolved}, {"terms", term_params}}};
}

// A setting the engine refuses, named by the Python argument that set it.
const char *argument_of(EngineSetting setting) {
    switch (setting) {
    case EngineSetting::system:
        return "system";
    case EngineSetting::time:
        return "t1";
    case EngineSetting::gradient:
        return "derivative";
    case EngineSetting::grid:
        return "points";
    default:
        return "quality";
    }
}

template <typename T> py::array_t<T> owned_array(std::vector<T> values, std::vector<py::ssize_t> shape) {
    auto *owned = new std::vector<T>(std::move(values));
    py::capsule free_when_done(owned, [](void *p) { delete static_cast<std::vector<T> *>(p); });
    return py::array_t<T>(std::move(shape), owned->data(), free_when_done);
}

using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;

// geobarrier._geobarrier.flow_map: the final states (count x n) of `points` (count x n, C order) integrated from t0
// to t1 with the quality preset's integrator, and with `derivative` DF (count x n x n, row-major, 2^exponent
// applied) and the mask (MaskBits per point). Masked points' rows are NaN.
py::tuple flow_map(const NativeSystem &system, const NativeForcing &forcing, const Doubles &points, double t0,
                   double t1, bool derivative, const std::string &quality, int threads, bool handle_interrupt) {
    const unsigned n = system.system.dimension();
    if (points.ndim() != 2 || points.shape(1) != static_cast<py::ssize_t>(n))
        throw ConfigError("points", "expected an array of shape (N, " + std::to_string(n) + ")");
    if (threads < 0 || threads > max_threads)
        throw ConfigError("threads", std::to_string(threads) + " worker threads asked for; give 1 to " +
                                         std::to_string(max_threads) + " (or None: one per core)");
    if (!std::isfinite(t0)) throw ConfigError("t0", "must be finite");
    if (!std::isfinite(t1)) throw ConfigError("t1", "must be finite");
    if (t0 == t1) throw ConfigError("t1", "equals t0; give an interval of non-zero length");
    if (derivative && !system.system.has_jacobian())
        throw ConfigError("derivative", "system '" + system.system.info().name +
                                            "' provides no Jacobian, which DF from the variational equations needs");
    IntegratorSettings settings;
    try {
        settings = quality_preset(quality);
    } catch (const ConfigError &e) {
        throw ConfigError("quality", std::string(e.what()).substr(e.json_path().size() + 2));
    }
    const std::size_t count = static_cast<std::size_t>(points.shape(0));
    const double *start = points.data();
    const Dynamics dynamics{&system.system, &forcing.forcing, nullptr};

    FlowMapRequest request{dynamics, t0, t1, settings};
    request.gradient = derivative ? GradientMethod::variational : GradientMethod::none;
    FlowMap result;
    std::exception_ptr failure;
    int interrupted = 0;
    {
        py::gil_scoped_release no_gil;
        const InterruptScope interrupts(handle_interrupt);
        try {
            const std::unique_lock<std::mutex> system_turn = turn_of(system.system.info(), *system.turns);
            const std::unique_lock<std::mutex> forcing_turn = turn_of(forcing.forcing.info(), *forcing.turns);
            const ScopedThreadCount scoped(threads);
            result = flow_map_of_states(
                request, count, [&](std::size_t k, double *state) { std::memcpy(state, start + n * k, n * 8); });
        } catch (const EngineSettingError &e) {
            try {
                throw ConfigError(argument_of(e.setting()), e.message());
            } catch (...) {
                failure = std::current_exception();
            }
        } catch (...) {
            failure = std::current_exception();
        }
        if (handle_interrupt) {
            interrupted = cancel_requested();
            clear_cancel();
        }
    }
    if (failure) std::rethrow_exception(failure);
    if (interrupted) {
        PyErr_SetNone(PyExc_KeyboardInterrupt);
        throw py::error_already_set();
    }
    const auto N = static_cast<py::ssize_t>(count), dim = static_cast<py::ssize_t>(n);
    py::object dF = py::none(), log_det = py::none();
    if (derivative) {
        const std::size_t nn = std::size_t{n} * n;
        {
            py::gil_scoped_release no_gil;
            for (std::size_t k = 0; k < count; ++k) {
                if (result.mask[k] != 0 || result.dF_exponent[k] == 0) continue;
                for (std::size_t q = 0; q < nn; ++q)
                    result.dF[nn * k + q] = std::ldexp(result.dF[nn * k + q], result.dF_exponent[k]);
            }
        }
        dF = owned_array(std::move(result.dF), {N, dim, dim});
        log_det = owned_array(std::move(result.log_det), {N});
    }
    return py::make_tuple(owned_array(std::move(result.state), {N, dim}), dF, log_det,
                          owned_array(std::move(result.mask), {N}), result.stats.to_json().dump());
}

// The gradients or tensors of a (count, n, n) array, checked.
struct Tensors {
    std::size_t count = 0;
    unsigned n = 0;
    const double *data = nullptr;
};
Tensors tensors_of(const Doubles &a, const char *name) {
    if (a.ndim() != 3 || a.shape(1) != a.shape(2) || a.shape(1) < 2 || a.shape(1) > 64)
        throw ConfigError(name, "expected an array of shape (N, n, n) with 2 <= n <= 64");
    return Tensors{static_cast<std::size_t>(a.shape(0)), static_cast<unsigned>(a.shape(1)), a.data()};
}

double checked_duration(double T) {
    if (!std::isfinite(T) || T == 0.0) throw ConfigError("T", "must be finite and non-zero (the integration time)");
    return std::abs(T);
}

// geobarrier._geobarrier.ftle_of_gradients: the FTLE log(lambda_max(DF^T DF)) / (2|T|) of each gradient, with the
// core's code (cauchy_green_at for n = 2, as the runner computes its fields; cauchy_green_nd otherwise). A gradient
// with NaN or Inf entries (a masked point) gives NaN.
py::array_t<double> ftle_of_gradients(const Doubles &dF, double T) {
    const Tensors t = tensors_of(dF, "DF");
    const double duration = checked_duration(T);
    std::vector<double> out(t.count, nan_value);
    {
        py::gil_scoped_release no_gil;
        const std::size_t nn = std::size_t{t.n} * t.n;
#pragma omp parallel for schedule(static)
        for (long long i = 0; i < static_cast<long long>(t.count); ++i) {
            const double *f = t.data + nn * static_cast<std::size_t>(i);
            double ftle = nan_value;
            if (t.n == 2)
                ftle = cauchy_green_at(f[0], f[1], f[2], f[3], duration, 0, nan_value, CauchyGreenParts{false, false})
                           .ftle;
            else
                ftle = cauchy_green_nd(f, t.n, duration).ftle;
            out[static_cast<std::size_t>(i)] = std::isfinite(ftle) ? ftle : nan_value;
        }
    }
    return owned_array(std::move(out), {static_cast<py::ssize_t>(t.count)});
}

// geobarrier._geobarrier.ftle_of_tensors: the same from Cauchy–Green tensors C (symmetric; the upper triangle is
// read): for n = 2 the dominant root 0.5 (c11 + c22) + hypot(0.5 (c11 - c22), c12), as the core computes it from
// DF; otherwise Eigen's symmetric eigensolver. A tensor with NaN or Inf entries, or whose largest eigenvalue is not
// positive, gives NaN.
py::array_t<double> ftle_of_tensors(const Doubles &C, double T) {
    const Tensors t = tensors_of(C, "C");
    const double duration = checked_duration(T);
    std::vector<double> out(t.count, nan_value);
    {
        py::gil_scoped_release no_gil;
        const std::size_t nn = std::size_t{t.n} * t.n;
#pragma omp parallel for schedule(static)
        for (long long i = 0; i < static_cast<long long>(t.count); ++i) {
            const double *c = t.data + nn * static_cast<std::size_t>(i);
            bool finite = true;
            for (std::size_t q = 0; q < nn; ++q) finite = finite && std::isfinite(c[q]);
            if (!finite) continue;
            double largest;
            if (t.n == 2) {
                largest = 0.5 * (c[0] + c[3]) + std::hypot(0.5 * (c[0] - c[3]), c[1]);
            } else {
                Eigen::MatrixXd M(t.n, t.n);
                for (unsigned r = 0; r < t.n; ++r)
                    for (unsigned s = r; s < t.n; ++s) M(r, s) = M(s, r) = c[r * t.n + s];
                largest =
                    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(M, Eigen::EigenvaluesOnly).eigenvalues()(t.n - 1);
            }
            const double ftle = std::log(largest) / (2.0 * duration);
            out[static_cast<std::size_t>(i)] = largest > 0.0 && std::isfinite(ftle) ? ftle : nan_value;
        }
    }
    return owned_array(std::move(out), {static_cast<py::ssize_t>(t.count)});
}

// geobarrier._geobarrier.cauchy_green: C = DF^T DF, its eigenvalues (ascending) and unit eigenvectors (column i of
// a point's matrix belongs to eigenvalue i, as numpy.linalg.eigh gives them) with the core's code: for n = 2
// cauchy_green_at (lambda2 from the dominant root, lambda1 = det(DF)^2 / lambda2, xi1 = rotated xi2; a degenerate
// point gets the axes), otherwise cauchy_green_nd (singular value decomposition of DF). With log_det (log|det DF| by
// Liouville's formula, as flow_map gives it) the smallest eigenvalue comes from it, as the runner's fields do: free of
// the cancellation that det DF from the entries suffers at strongly stretched points. NaN where DF is not finite.
py::tuple cauchy_green(const Doubles &dF, const std::optional<Doubles> &log_det) {
    const Tensors t = tensors_of(dF, "DF");
    if (log_det && (log_det->ndim() != 1 || log_det->shape(0) != static_cast<py::ssize_t>(t.count)))
        throw ConfigError("log_det", "expected an array of shape (N,), one log|det DF| per gradient");
    const double *log_dets = log_det ? log_det->data() : nullptr;
    const std::size_t nn = std::size_t{t.n} * t.n;
    std::vector<double> C(nn * t.count, nan_value), lambda(std::size_t{t.n} * t.count, nan_value),
        vectors(nn * t.count, nan_value);
    {
        py::gil_scoped_release no_gil;
        const unsigned n = t.n;
#pragma omp parallel for schedule(static)
        for (long long i = 0; i < static_cast<long long>(t.count); ++i) {
            const std::size_t k = static_cast<std::size_t>(i);
            const double *f = t.data + nn * k;
            bool finite = true;
            for (std::size_t q = 0; q < nn; ++q) finite = finite && std::isfinite(f[q]);
            if (!finite) continue;
            for (unsigned r = 0; r < n; ++r)
                for (unsigned s = 0; s < n; ++s) {
                    double sum = 0.0;
                    for (unsigned q = 0; q < n; ++q) sum += f[q * n + r] * f[q * n + s];
                    C[nn * k + r * n + s] = sum;
                }
            double *l = lambda.data() + std::size_t{n} * k, *v = vectors.data() + nn * k;
            if (n == 2) {
                const CauchyGreenPoint p =
                    cauchy_green_at(f[0], f[1], f[2], f[3], 1.0, 0, log_dets ? log_dets[k] : nan_value);
                if (!std::isfinite(p.lambda2)) continue;
                l[0] = p.lambda1;
                l[1] = p.lambda2;
                v[0] = p.xi1_x, v[1] = p.xi2_x; // columns: xi1, xi2
                v[2] = p.xi1_y, v[3] = p.xi2_y;
            } else {
                const CauchyGreenND r = cauchy_green_nd(f, n, 1.0, 0, log_dets ? log_dets[k] : nan_value);
                for (unsigned a = 0; a < n; ++a) {
                    l[a] = r.lambda[a];
                    for (unsigned j = 0; j < n; ++j) v[j * n + a] = r.eigenvectors[std::size_t{a} * n + j];
                }
            }
        }
    }
    const auto N = static_cast<py::ssize_t>(t.count), n = static_cast<py::ssize_t>(t.n);
    return py::make_tuple(owned_array(std::move(C), {N, n, n}), owned_array(std::move(lambda), {N, n}),
                          owned_array(std::move(vectors), {N, n, n}));
}

// geobarrier._geobarrier.extract_barriers: one extractor on fields computed before (a run's, or fields.nc's), with
// the experiment they were computed with (fields.nc's "experiment" attribute, its extractors replaced by this one):
// the extractor, the system, forcing and integrator its advection uses, and the grid are those of resolve_experiment,
// and the extractor runs as in a run (extraction.hpp: run_extractor, advection_services), so a run's fields give the
// run's barriers. `fields` maps names to (ny, nx) arrays; the extractor's required fields must be there. Returns the
// barriers and the candidates as JSON text (barriers.json's items).
py::tuple extract_barriers(const std::string &experiment_text,
                           const py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast> &mask,
                           const py::dict &field_dict, int threads, bool handle_interrupt) {
    if (threads < 0 || threads > max_threads)
        throw ConfigError("threads", std::to_string(threads) + " worker threads asked for; give 1 to " +
                                         std::to_string(max_threads) + " (or None: one per core)");
    std::map<std::string, Doubles> fields;
    for (const auto &item : field_dict)
        fields.emplace(py::cast<std::string>(item.first), py::cast<Doubles>(item.second));
    json items = json::array(), candidates = json::array();
    std::exception_ptr failure;
    int interrupted = 0;
    {
        py::gil_scoped_release no_gil;
        const InterruptScope interrupts(handle_interrupt);
        fs::path scratch;
        try {
            const ScopedThreadCount scoped(threads);
            const ResolvedExperiment r = resolve_experiment(parse_experiment_text(experiment_text));
            const Experiment &e = r.experiment;
            if (r.extractors.size() != 1) throw ConfigError("extractor", "give one extractor");
            if (r.slice)
                throw ConfigError("fields", "fields over a slice of a higher-dimensional system are not "
                                            "supported here; run the extractor in the experiment");
            const auto ny = static_cast<py::ssize_t>(e.grid.ny), nx = static_cast<py::ssize_t>(e.grid.nx);
            if (mask.ndim() != 2 || mask.shape(0) != ny || mask.shape(1) != nx)
                throw ConfigError("fields", "the mask's shape is not the experiment's grid (" + std::to_string(ny) +
                                                ", " + std::to_string(nx) + ")");
            const Extractor &x = r.extractors.front();
            std::vector<gb_field> inputs;
            // exit_time may be left out: as in a run without bounds, nothing exits (all NaN; abi.h).
            std::vector<double> no_exit;
            for (const auto &name : x.required_fields()) {
                if (name == "exit_time" && fields.find(name) == fields.end()) {
                    no_exit.assign(e.grid.size(), std::numeric_limits<double>::quiet_NaN());
                    inputs.push_back({"exit_time", no_exit.data()});
                    continue;
                }
                const auto it = fields.find(name);
                if (it == fields.end())
                    throw ConfigError("fields", "extractor '" + x.info().name + "' needs the field \"" + name +
                                                    "\", which the fields lack: run with the product that writes it "
                                                    "(docs/experiment-format.md, products)");
                const Doubles &a = it->second;
                if (a.ndim() != 2 || a.shape(0) != ny || a.shape(1) != nx)
                    throw ConfigError("fields", "\"" + name + "\" is not of the grid's shape (" + std::to_string(ny) +
                                                    ", " + std::to_string(nx) + ")");
                inputs.push_back({it->first.c_str(), a.data()});
            }
            // The extractor's own files (pictures: none are asked for) go to a private folder, removed afterwards.
            scratch = fs::temp_directory_path() / ("geobarrier-extract-" + std::to_string(::getpid()) + "-" +
                                                   std::to_string(reinterpret_cast<std::uintptr_t>(&scratch)));
            fs::create_directories(scratch);
            FoundBarriers found;
            run_extractor(r, x, inputs, mask.data(), scratch.string(), false, advection_services(r), found);
            items = std::move(found.items);
            candidates = std::move(found.candidates);
        } catch (const EngineSettingError &e) {
            try {
                throw ConfigError(json_path_of(e.setting()), e.message());
            } catch (...) {
                failure = std::current_exception();
            }
        } catch (...) {
            failure = std::current_exception();
        }
        if (!scratch.empty()) {
            std::error_code ec;
            fs::remove_all(scratch, ec);
        }
        if (handle_interrupt) {
            interrupted = cancel_requested();
            clear_cancel();
        }
    }
    if (failure) std::rethrow_exception(failure);
    if (interrupted) {
        PyErr_SetNone(PyExc_KeyboardInterrupt);
        throw py::error_already_set();
    }
    return py::make_tuple(items.dump(), candidates.dump());
}

} // namespace

// Called from PYBIND11_MODULE (bindings.cpp).
void register_array_functions(py::module_ &m) {
    py::class_<NativeSystem>(m, "_System")
        .def_property_readonly("name", [](const NativeSystem &s) { return s.system.info().name; })
        .def_property_readonly("dimension", [](const NativeSystem &s) { return s.system.dimension(); })
        .def_property_readonly("has_jacobian", [](const NativeSystem &s) { return s.system.has_jacobian(); })
        .def_property_readonly("uses_forcing", [](const NativeSystem &s) { return s.system.uses_forcing(); })
        .def_property_readonly("state_names", [](const NativeSystem &s) { return s.system.info().state_names; })
        .def_property_readonly("state_units", [](const NativeSystem &s) { return s.system.info().state_units; })
        .def_property_readonly("schema", [](const NativeSystem &s) { return s.schema.dump(); })
        .def_property_readonly("params", [](const NativeSystem &s) { return s.params.dump(); });
    py::class_<NativeForcing>(m, "_Forcing")
        .def_property_readonly("name", [](const NativeForcing &f) { return f.forcing.info().name; })
        .def_property_readonly("schema", [](const NativeForcing &f) { return f.schema.dump(); })
        .def_property_readonly("params", [](const NativeForcing &f) { return f.params.dump(); })
        .def(
            "evaluate",
            [](const NativeForcing &f, const Doubles &t) {
                if (t.ndim() != 1) throw ConfigError("t", "expected a one-dimensional array of times");
                std::vector<double> out(static_cast<std::size_t>(t.shape(0)));
                {
                    py::gil_scoped_release no_gil;
                    const std::unique_lock<std::mutex> turn = turn_of(f.forcing.info(), *f.turns);
                    f.forcing.evaluate(out.size(), t.data(), out.data());
                }
                return owned_array(std::move(out), {t.shape(0)});
            },
            py::arg("t"));
    m.def("make_system", &make_system, py::arg("name"), py::arg("params"), py::arg("plugin_paths"));
    m.def("make_equations_system", &make_equations_system, py::arg("params"));
    m.def("make_forcing", &make_forcing, py::arg("name"), py::arg("params"), py::arg("terms"), py::arg("plugin_paths"));
    m.def("flow_map", &flow_map, py::arg("system"), py::arg("forcing"), py::arg("points"), py::arg("t0"), py::arg("t1"),
          py::arg("derivative"), py::arg("quality"), py::arg("threads"), py::arg("handle_interrupt"));
    m.def("ftle_of_gradients", &ftle_of_gradients, py::arg("DF"), py::arg("T"));
    m.def("ftle_of_tensors", &ftle_of_tensors, py::arg("C"), py::arg("T"));
    m.def("cauchy_green", &cauchy_green, py::arg("DF"), py::arg("log_det"));
    m.def("extract_barriers", &extract_barriers, py::arg("experiment"), py::arg("mask"), py::arg("fields"),
          py::arg("threads"), py::arg("handle_interrupt"));
}
