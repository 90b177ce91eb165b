// The Python module's native part, geobarrier._geobarrier: runs experiments on the C++ core with the GIL released,
// turns Ctrl-C into the core's cooperative cancellation, and hands fields back as NumPy arrays without a copy.
// Experiments and results cross the boundary as JSON text (the experiment format is JSON anyway); the Python package
// (python/geobarrier/__init__.py) builds dicts, xarray Datasets and barrier objects from them. One translation unit
// that instantiates no heavy template: the core does the work.
#include "interrupt_scope.hpp"
#include <geobarrier/cancel.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/output.hpp>
#include <geobarrier/plugin.hpp>

#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <omp.h>

#include <chrono>
#include <csignal>
#include <exception>
#include <mutex>
#include <new>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <signal.h>

namespace py = pybind11;
namespace fs = std::filesystem;
using geobarrier::python::InterruptScope;
using nlohmann::json;

// The array functions (flow_map, cauchy_green, ftle, systems and forcings as objects): arrays.cpp.
void register_array_functions(py::module_ &m);

namespace {

// A NumPy array of the given shape that owns `values` (moved, not copied): the capsule frees them with the array.
template <typename T> py::array_t<T> to_array(std::vector<T> values, std::vector<py::ssize_t> shape) {
    auto *owned = new std::vector<T>(std::move(values));
    py::capsule free_when_done(owned, [](void *p) { delete static_cast<std::vector<T> *>(p); });
    return py::array_t<T>(std::move(shape), owned->data(), free_when_done);
}

// The experiment as the core reads it: from a file (`text` empty), or from JSON text, with `file` naming it in
// messages and resolving its relative paths ("" = the current folder).
geobarrier::Experiment read_experiment(const std::string &text, const std::string &file) {
    if (text.empty()) return geobarrier::load_experiment(file);
    return geobarrier::parse_experiment_text(text, file);
}

// Thrown through the core (which passes exceptions of its worker threads on) when the Python progress callback
// raised; the Python exception itself is kept and raised once the GIL is held again.
struct CallbackFailed : std::exception {
    const char *what() const noexcept override { return "the progress callback raised an exception"; }
};

// Calls a Python progress callback from the core's threads: with the GIL, one call at a time, at most ten a second
// (and always for a finished stage), so that a fine-grained stage costs nothing noticeable.
class ProgressRelay {
  public:
    explicit ProgressRelay(py::object callback) : m_callback(std::move(callback)) {}
    ~ProgressRelay() {
        py::gil_scoped_acquire gil; // the callback and a kept exception are Python objects
        m_callback = py::object();
        m_error = nullptr;
    }
    ProgressRelay(const ProgressRelay &) = delete;
    ProgressRelay &operator=(const ProgressRelay &) = delete;

    void operator()(const std::string &stage, std::size_t done, std::size_t total) {
        {
            std::lock_guard<std::mutex> lock(m_mutex);
            const auto now = std::chrono::steady_clock::now();
            if (m_error || (stage == m_stage && done < total && now - m_last < std::chrono::milliseconds(100))) return;
            m_stage = stage;
            m_last = now;
        }
        py::gil_scoped_acquire gil;
        try {
            m_callback(stage, done, total);
        } catch (py::error_already_set &) {
            std::lock_guard<std::mutex> lock(m_mutex);
            if (!m_error) m_error = std::current_exception();
            throw CallbackFailed();
        }
    }
    // Raises the callback's exception, if it raised one (with the GIL held).
    void rethrow() const {
        if (m_error) std::rethrow_exception(m_error);
    }

  private:
    py::object m_callback;
    std::mutex m_mutex;
    std::string m_stage;
    std::chrono::steady_clock::time_point m_last{};
    std::exception_ptr m_error;
};

py::dict results_of(geobarrier::RunSummary &summary);

// geobarrier._geobarrier.run: see python/geobarrier/__init__.py, run().
py::dict run(const std::string &text, const std::string &file, std::optional<std::string> out, bool write, int threads,
             py::object progress, bool handle_interrupt) {
    // The command line's cap (experiment.hpp), checked here with the GIL held and before any thread is started: far
    // more threads than that abort the interpreter inside OpenMP (libgomp) or crash it.
    if (threads < 0 || threads > geobarrier::max_threads)
        throw geobarrier::ConfigError("threads", std::to_string(threads) + " worker threads asked for; give 1 to " +
                                                     std::to_string(geobarrier::max_threads) + " (or 0: one per core)");
    geobarrier::RunOptions options;
    if (out) options.output_dir = fs::path(*out);
    options.threads = threads;
    options.quiet = true; // no terminal progress bar of the core's own: Python draws its own when asked
    options.write_files = write;
    options.keep_results = true;
    std::optional<ProgressRelay> relay;
    if (!progress.is_none()) {
        relay.emplace(progress);
        options.progress = [&relay](const std::string &stage, std::size_t done, std::size_t total) {
            (*relay)(stage, done, total);
        };
    }

    geobarrier::RunSummary summary;
    std::exception_ptr failure;
    int interrupted = 0;
    {
        py::gil_scoped_release no_gil;
        const InterruptScope interrupts(handle_interrupt);
        try {
            const geobarrier::ResolvedExperiment resolved = geobarrier::resolve_experiment(read_experiment(text, file));
            summary = geobarrier::run_experiment(resolved, options);
        } catch (...) {
            failure = std::current_exception();
        }
        if (handle_interrupt) { // a Ctrl-C that came too late to stop the run still reaches Python
            interrupted = geobarrier::cancel_requested();
            geobarrier::clear_cancel();
        }
    }
    if (relay) relay->rethrow();
    if (failure) std::rethrow_exception(failure); // the exception translator (below) picks the Python class
    if (interrupted) {
        PyErr_SetNone(PyExc_KeyboardInterrupt);
        throw py::error_already_set();
    }

    py::dict result = results_of(summary);
    // "directions": "both": each direction's results as a run of one direction gives them, and the tangle.
    if (!summary.directions.empty()) {
        py::dict directions;
        directions["forward"] = results_of(summary.directions[0]);
        directions["backward"] = results_of(summary.directions[1]);
        result["directions"] = directions;
        result["tangle"] = summary.tangle.dump();
    }
    return result;
}

// What a run keeps (RunOptions::keep_results) as the dict geobarrier.Result reads; the arrays move out of the summary.
py::dict results_of(geobarrier::RunSummary &summary) {
    const std::size_t nx = summary.grid.nx, ny = summary.grid.ny;
    const std::vector<py::ssize_t> shape{static_cast<py::ssize_t>(ny), static_cast<py::ssize_t>(nx)};
    py::list fields;
    for (geobarrier::FieldResult &f : summary.fields)
        fields.append(py::make_tuple(f.name, f.long_name, f.units, f.masked_by, to_array(std::move(f.values), shape)));
    py::list coordinates;
    for (geobarrier::FieldResult &c : summary.coordinates) {
        const auto n = static_cast<py::ssize_t>(c.values.size());
        coordinates.append(py::make_tuple(c.name, c.long_name, c.units, to_array(std::move(c.values), {n})));
    }
    py::list files;
    for (const fs::path &f : summary.files) files.append(f.string());

    py::dict result;
    result["manifest"] = summary.manifest.dump();
    result["barriers"] = summary.barriers.dump();
    result["candidates"] = summary.candidates.dump();
    result["attributes"] = summary.field_attributes.dump();
    result["fields"] = fields;
    result["mask"] =
        summary.mask.empty() ? py::object(py::none()) : py::object(to_array(std::move(summary.mask), shape));
    result["coordinates"] = coordinates;
    result["output_dir"] = summary.output_dir.string();
    result["files"] = files;
    return result;
}

// geobarrier._geobarrier.validate: the checks of `geobarrier validate` (parsing, plugins, parameters); a summary as
// JSON text.
std::string validate(const std::string &text, const std::string &file) {
    py::gil_scoped_release no_gil;
    const geobarrier::Experiment experiment = read_experiment(text, file);
    const geobarrier::ResolvedExperiment r = geobarrier::resolve_experiment(experiment);
    json extractors = json::array();
    for (const auto &x : r.extractors) extractors.push_back(x.info().name);
    json validation = json::array();
    for (const auto &item : geobarrier::validation_to_json(experiment.validation, experiment.t0, experiment.t1).items())
        validation.push_back(item.key());
    return json{{"system", r.system.info().name},
                {"forcing", r.forcing.info().name},
                {"grid", {experiment.grid.nx, experiment.grid.ny}},
                {"products", experiment.products},
                {"extractors", extractors},
                {"validation", validation},
                {"warnings", experiment.warnings},
                {"resolved", r.resolved}}
        .dump();
}

// geobarrier._geobarrier.plugins: what `geobarrier plugins --json` prints.
std::string plugins(const std::vector<std::string> &extra) {
    py::gil_scoped_release no_gil;
    const std::vector<fs::path> folders(extra.begin(), extra.end());
    const geobarrier::PluginRegistry registry(geobarrier::PluginRegistry::default_folders(folders));
    json j;
    j["folders"] = json::array();
    for (const auto &f : registry.folders()) j["folders"].push_back(f.string());
    j["plugins"] = json::array();
    for (const auto &h : registry.plugins()) j["plugins"].push_back(geobarrier::plugin_info_to_json(h.info));
    j["warnings"] = registry.warnings();
    return j.dump();
}

void set_log_level(const std::string &level) {
    const spdlog::level::level_enum parsed = spdlog::level::from_str(level);
    if (parsed == spdlog::level::off && level != "off")
        throw geobarrier::ConfigError("level",
                                      "\"" + level + "\" is not a log level (trace, debug, info, warning, error, off)");
    spdlog::set_level(parsed);
}

// The core's exceptions as the Python classes of geobarrier._errors (ConfigError carries the JSON path).
void raise_python(const char *name, const std::string &message, const py::object &path = py::none()) {
    const py::object errors = py::module_::import("geobarrier._errors");
    const py::object type = errors.attr(name);
    const py::object instance = path.is_none() ? type(message) : type(message, path);
    PyErr_SetObject(type.ptr(), instance.ptr());
}

void translate_exception(std::exception_ptr p) {
    try {
        std::rethrow_exception(p);
    } catch (const geobarrier::Cancelled &e) {
        PyErr_SetString(PyExc_KeyboardInterrupt, e.what());
    } catch (const geobarrier::ConfigError &e) {
        raise_python("ConfigError", e.what(), py::str(e.json_path()));
    } catch (const geobarrier::PluginError &e) {
        raise_python("PluginError", e.what());
    } catch (const geobarrier::NumericalError &e) {
        raise_python("NumericalError", e.what());
    } catch (const geobarrier::IoError &e) {
        raise_python("IoError", e.what());
    } catch (const geobarrier::Error &e) {
        raise_python("Error", e.what());
    } catch (const CallbackFailed &e) {
        raise_python("Error", e.what());
    }
    // Everything else (std::bad_alloc -> MemoryError, std::exception -> RuntimeError) is pybind11's default.
}

} // namespace

PYBIND11_MODULE(_geobarrier, m) {
    m.doc() = "geobarrier's native part; use the geobarrier package";
    m.attr("version") = GEOBARRIER_VERSION;
    m.attr("max_threads") = geobarrier::max_threads;
    m.def("run", &run, py::arg("text"), py::arg("file"), py::arg("out"), py::arg("write"), py::arg("threads"),
          py::arg("progress"), py::arg("handle_interrupt"));
    m.def("validate", &validate, py::arg("text"), py::arg("file"));
    // The OpenMP thread count of the calling thread's later parallel regions (omp_set_num_threads). The package sets 1
    // in a child forked after the forking thread ran parallel code: libgomp keeps that thread's pool of worker
    // threads, which the fork did not copy, and a parallel region of more than one thread waits for them forever.
    m.def(
        "set_default_threads",
        [](int threads) {
            if (threads < 1 || threads > geobarrier::max_threads)
                throw py::value_error("threads: " + std::to_string(threads) + "; give 1 to " +
                                      std::to_string(geobarrier::max_threads));
            omp_set_num_threads(threads);
        },
        py::arg("threads"));
    m.def("plugins", &plugins, py::arg("extra_folders"));
    m.def("set_log_level", &set_log_level, py::arg("level"));
    // fields.nc's mask attributes, from the one definition the NetCDF writer uses.
    m.def("mask_attributes", [] {
        const geobarrier::MaskAttributes a = geobarrier::mask_attributes();
        py::dict d;
        d["flag_masks"] = std::vector<int>(a.flag_masks.begin(), a.flag_masks.end());
        d["flag_meanings"] = a.flag_meanings;
        d["long_name"] = a.long_name;
        return d;
    });
    register_array_functions(m);
    py::register_exception_translator(&translate_exception);
    // The core logs to stderr (spdlog's default logger would write to stdout); in Python only warnings and errors by
    // default (set_log_level("info") for more).
    if (!spdlog::get("geobarrier")) {
        auto logger = spdlog::stderr_color_mt("geobarrier");
        logger->set_pattern("%^[geobarrier %l]%$ %v");
        spdlog::set_default_logger(logger);
    }
    spdlog::set_level(spdlog::level::warn);
}
