// The core's side of the plugin boundary: loading plugin libraries with
// Boost.DLL, finding plugins by kind and name, validating parameters against
// their schemas, and C++ objects (System, Forcing, Extractor) that wrap a
// created plugin instance and keep its library loaded for as long as they live.
#ifndef GEOBARRIER_PLUGIN_HPP
#define GEOBARRIER_PLUGIN_HPP

#include <geobarrier/abi.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace geobarrier {

enum class PluginKind { system, forcing, extractor };
const char *to_string(PluginKind kind);

enum class ParamType { real, integer, boolean, string };
const char *to_string(ParamType type);

// A parameter declaration, copied out of the plugin's gb_param_spec.
struct ParamSpec {
    std::string name;
    ParamType type = ParamType::real;
    double default_value = 0.0;
    double min_value = 0.0;
    double max_value = 0.0;
    std::string default_string;
    std::vector<std::string> choices; // strings only; empty = any string
    std::string unit;
    std::string doc;
};

// A plugin library kept loaded (the boost::dll::shared_library lives inside).
class PluginLibrary;

// One plugin found in a library: its descriptor and a copy of what it declares.
struct PluginInfo {
    PluginKind kind = PluginKind::system;
    std::string name;
    std::string version;
    std::string doc;
    std::vector<ParamSpec> params;
    std::uint32_t thread_safety = 0;
    std::filesystem::path file;
    std::uint32_t abi_major = 0, abi_minor = 0;
    std::string core_version; // non-empty when the plugin links the core's C++ library
    // How the library was compiled (ABI 1.3 extension GB_EXTENSION_BUILD_INFO); struct_size 0 when it does not say.
    gb_build_info build{};
    // Systems only.
    std::uint32_t dimension = 0;
    bool has_jacobian = false, has_divergence = false, uses_forcing = false;
    bool jacobian_derived = false; // the SDK derived the Jacobian by automatic differentiation (informational)
    std::vector<double> domain_min, domain_max; // the documented domain (ABI 1.1); empty when not declared
    // Name and unit of each state component (ABI 1.2; "" = nondimensional); both empty when not declared.
    std::vector<std::string> state_names, state_units;
    // Forcings only: a composite forcing (ABI 1.1) combines min_terms..max_terms other forcings; 0 = plain.
    std::uint32_t min_terms = 0, max_terms = 0;
    bool composite() const { return max_terms > 0; }
    // Extractors only.
    std::vector<std::string> required_fields;
};

struct PluginHandle {
    std::shared_ptr<const PluginLibrary> library;
    const gb_plugin_descriptor *descriptor = nullptr;
    PluginInfo info;
};

// The most a plugin's descriptor may declare, checked as the loader reads it, before anything is sized from it: a
// system's dimension (the engine integrates 2 .. max_dimension of flow_map.hpp; a larger one up to this still loads
// and is listed, and an experiment using it is refused), its parameters, the extractor's required fields, and the
// length of a plugin's, a parameter's and a state component's name. A descriptor beyond them is malformed.
constexpr std::uint32_t max_declared_dimension = 64;
constexpr std::uint32_t max_declared_params = 256;
constexpr std::uint32_t max_declared_fields = 64;
constexpr std::size_t max_declared_name_length = 64;

// Loads one plugin library and returns every plugin it declares. Throws
// PluginError "<file>: <reason>" for a file that is not a loadable library, has
// no entry symbol, was built for another ABI major version, or declares
// malformed descriptors (beyond the limits above, among others); LibraryFileError (errors.hpp) for a file refused
// before it is mapped (truncated, unreadable, another machine's).
std::vector<PluginHandle> load_plugin_library(const std::filesystem::path &file);

// Parameter values validated against a schema, in declaration order.
class ParamValues {
  public:
    ParamValues() = default;
    ParamValues(std::vector<double> values, std::vector<std::string> strings, std::vector<bool> is_string);
    // The C view handed to a factory; valid while this object lives.
    const gb_param_values *c_view() const { return &m_view; }
    ParamValues(const ParamValues &other);
    ParamValues &operator=(const ParamValues &other);
    double value(std::size_t i) const { return m_values.at(i); }
    const std::string &string(std::size_t i) const { return m_strings.at(i); }

  private:
    void rebuild_view();
    std::vector<double> m_values;
    std::vector<std::string> m_strings;
    std::vector<bool> m_is_string;
    std::vector<const char *> m_string_ptrs;
    gb_param_values m_view{0, nullptr, nullptr};
};

// Validates `params` (a JSON object, or null for all defaults) against the
// plugin's schema: unknown names (with a "did you mean" hint), wrong types and
// values outside the declared range are ConfigErrors naming json_path/name.
ParamValues validate_params(const PluginInfo &info, const nlohmann::json &params, const std::string &json_path);

// The resolved parameters as JSON (defaults filled in), for the manifest.
nlohmann::json params_to_json(const PluginInfo &info, const ParamValues &values);

// The schema as JSON, for `geobarrier plugins --json` and generated docs.
nlohmann::json plugin_info_to_json(const PluginInfo &info);

// Axis labels for pictures of a system's states: "name [unit]" for component i ("name [–]" when the unit is "":
// nondimensional; "x" / "y" when the system declares no names); for time "t [time]" when any state component has a
// unit, "t [–]" when none has, "t" when the system declares no names. Short, so that 3-D axes have room.
std::string state_axis_label(const PluginInfo &system, std::size_t i);
std::string time_axis_label(const PluginInfo &system);

// Turns a failed call's status into a PluginError naming the plugin.
void check_plugin_status(gb_status status, const PluginInfo &info, const char *what, const char *message);

// A created plugin instance, destroyed (and its library released) with the last copy.
class PluginInstance {
  public:
    PluginInstance() = default;
    PluginInstance(const PluginHandle &handle, const ParamValues &values);
    const PluginInfo &info() const { return m_handle->info; }
    void *self() const { return m_self.get(); }
    const gb_plugin_descriptor &descriptor() const { return *m_handle->descriptor; }
    explicit operator bool() const { return static_cast<bool>(m_self); }

  private:
    std::shared_ptr<const PluginHandle> m_handle;
    std::shared_ptr<void> m_self;
};

// A dynamical system x' = v(x, t; f). Calls throw PluginError when the plugin fails.
class System {
  public:
    System() = default;
    System(const PluginHandle &handle, const ParamValues &values);
    const PluginInfo &info() const { return m_instance.info(); }
    unsigned dimension() const { return m_table->dimension; }
    bool has_jacobian() const { return m_table->jacobian != nullptr; }
    bool has_divergence() const { return m_table->divergence != nullptr; }
    bool uses_forcing() const { return (m_table->capabilities & GB_SYSTEM_USES_FORCING) != 0; }
    // See gb_system_vtable for the layouts; lane_status receives n entries.
    void rhs(std::size_t n, std::size_t ld, const double *t, const double *x, const double *f, double *dxdt,
             std::int32_t *lane_status) const;
    void jacobian(std::size_t n, std::size_t ld, const double *t, const double *x, const double *f, double *jac,
                  std::int32_t *lane_status) const;
    void divergence(std::size_t n, std::size_t ld, const double *t, const double *x, const double *f, double *div,
                    std::int32_t *lane_status) const;
    // ABI 1.2: the plugin's fused Runge-Kutta step (gb_advance_request), when it has one.
    bool has_advance() const { return m_advance != nullptr; }
    // One fused step; false when the plugin does not offer the request's method (nothing written). Throws on error.
    bool advance(const gb_advance_request &request) const;

  private:
    PluginInstance m_instance;
    const gb_system_vtable *m_table = nullptr;
    decltype(gb_system_vtable::advance) m_advance = nullptr; // read only from plugins of ABI 1.2 or newer
};

// A forcing f(t). A composite forcing (info().composite(), e.g. "sum", "ramp") owns its terms: evaluate() evaluates
// them and hands their values to the plugin's combine(), so plugins never call each other and the flow-map engine
// sees one Forcing either way.
class Forcing {
  public:
    Forcing() = default;
    Forcing(const PluginHandle &handle, const ParamValues &values);
    // A composite forcing with its terms; throws PluginError unless min_terms <= terms.size() <= max_terms.
    Forcing(const PluginHandle &handle, const ParamValues &values, std::vector<Forcing> terms);
    // For a composite, thread_safety is the weakest of the tree's.
    const PluginInfo &info() const;
    const std::vector<Forcing> &terms() const;
    void evaluate(std::size_t n, const double *t, double *f) const;
    double operator()(double t) const {
        double f = 0.0;
        evaluate(1, &t, &f);
        return f;
    }
    // The composite plugin's own call: terms[j * ld + k] is term j at t[k]. Throws for a plain forcing.
    void combine(std::size_t n, const double *t, std::size_t term_count, std::size_t ld, const double *terms,
                 double *f) const;

  private:
    struct Composite;
    PluginInstance m_instance;
    const gb_forcing_vtable *m_table = nullptr;
    std::shared_ptr<const Composite> m_composite; // null for a plain forcing
};

// One barrier reported by an extractor.
struct Barrier {
    std::string kind;
    bool closed = false;
    std::vector<double> xy; // x0, y0, x1, y1, ...
    std::vector<std::pair<std::string, double>> metrics;
    std::vector<std::pair<std::string, std::string>> attributes; // name -> one JSON literal (ABI 1.1)
};

// What the core offers an extractor while it runs (the gb_host services).
struct ExtractServices {
    // Advects n points (x, y interleaved) from t_from to t_to; dF_out may be null. Throws on failure.
    std::function<void(std::size_t n, const double *xy, double t_from, double t_to, double *xy_out, double *dF_out,
                       std::uint8_t *mask_out)>
        advect;
};

// A barrier extractor.
class Extractor {
  public:
    Extractor() = default;
    Extractor(const PluginHandle &handle, const ParamValues &values);
    const PluginInfo &info() const { return m_instance.info(); }
    const std::vector<std::string> &required_fields() const { return info().required_fields; }
    // Runs the extractor; log lines go to spdlog, barriers are returned.
    std::vector<Barrier> extract(const gb_extract_input &input, const ExtractServices &services) const;

  private:
    PluginInstance m_instance;
    const gb_extractor_vtable *m_table = nullptr;
};

// How a registry loads the libraries of its folders. `all`: every library of every folder, up front (what
// `geobarrier plugins`, check-plugin --all and Python's plugins() list). `on_demand`: none up front; find() maps only
// the libraries a lookup needs (experiments: resolve_experiment), so that no other library's code runs.
enum class PluginLoading { all, on_demand };

// A library a registry mapped (its constructors ran), the plugins it declares ("system 'duffing'") and why it was
// loaded. `validate` lists them.
struct LoadedLibrary {
    std::filesystem::path file;
    std::vector<std::string> plugins; // empty when the library was skipped (not a plugin; see warnings())
    std::string reason;
};

// All plugins found in a list of folders. Files that are not plugins are
// skipped with a warning (see warnings()); a plugin named twice keeps the
// first one found, so earlier folders take precedence.
//
// On demand (PluginLoading::on_demand), find(kind, name) looks for a library named after the plugin, folder by
// folder: geobarrier-NAME.so (the built-in plugins' names), libNAME.so, NAME.so, and maps only that one. A folder
// library named like a built-in plugin (the built-in folder holds geobarrier-NAME.so) is refused before it is mapped:
// it would shadow the built-in one; name it by path in the experiment ("plugin": "/path/geobarrier-NAME.so") to use
// it. Only when no folder holds a file named after the plugin are the folders' other libraries mapped, one at a
// time until the plugin is found, each with a warning that says how to name the file.
class PluginRegistry {
  public:
    PluginRegistry() = default;
    explicit PluginRegistry(const std::vector<std::filesystem::path> &folders,
                            PluginLoading loading = PluginLoading::all);

    // Folders searched by default, in order: `extra` (e.g. the experiment's
    // plugin_paths), GEOBARRIER_PLUGIN_PATH (':'-separated), then the plugins
    // installed or built beside the core library (<prefix>/lib/geobarrier/plugins for <prefix>/lib/libgeobarrier.so:
    // the same folder for the geobarrier program, the tests and the Python module).
    static std::vector<std::filesystem::path> default_folders(const std::vector<std::filesystem::path> &extra = {});
    static std::filesystem::path builtin_folder();

    const std::deque<PluginHandle> &plugins() const { return m_plugins; }
    const std::vector<std::string> &warnings() const { return m_warnings; }
    const std::vector<std::filesystem::path> &folders() const { return m_folders; }
    // Every library mapped so far, in the order it was mapped. Not safe to read while find() runs in another thread.
    const std::vector<LoadedLibrary> &libraries() const { return m_libraries; }

    // Finds a plugin by kind and name, or loads it from a file when `name` is
    // a path (contains '/' or ends in ".so"). Unknown names are ConfigErrors at
    // json_path listing what exists, with a "did you mean" hint.
    // Safe to call from several threads at once.
    const PluginHandle &find(PluginKind kind, const std::string &name, const std::string &json_path) const;

  private:
    void add_library(const std::filesystem::path &file, bool strict, const std::string &reason) const;
    const PluginHandle *find_loaded(PluginKind kind, const std::string &name,
                                    const std::filesystem::path *file = nullptr) const;
    const PluginHandle *find_on_demand(PluginKind kind, const std::string &name, const std::string &json_path) const;
    std::vector<std::string> names_by_file(PluginKind kind) const;
    std::vector<std::filesystem::path> m_folders;
    PluginLoading m_loading = PluginLoading::all;
    mutable std::vector<LoadedLibrary> m_libraries;
    mutable std::deque<PluginHandle> m_plugins; // deque: find() hands out stable references
    mutable std::vector<std::string> m_warnings;
};

// Closest candidate by edit distance, or "" when nothing is close enough.
std::string did_you_mean(const std::string &word, const std::vector<std::string> &candidates);

} // namespace geobarrier

#endif // GEOBARRIER_PLUGIN_HPP
