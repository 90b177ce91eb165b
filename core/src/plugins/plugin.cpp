// Loading plugin libraries (Boost.DLL) and checking what they declare. Parameters against their schemas are
// plugin_params.cpp's, the wrappers that call across the ABI plugin_instances.cpp's, finding plugins in folders
// plugin_registry.cpp's.
#include "plot/plot_service.hpp"
#include "plugins/library_check.hpp"
#include "plugins/plugin_entry.hpp"
#include "plugins/plugin_internal.hpp"

#include <geobarrier/errors.hpp>
#include <geobarrier/flow_map.hpp>
#include <geobarrier/plugin.hpp>
#include <geobarrier/sdk.hpp>

#include <dlfcn.h>

#include <boost/dll/shared_library.hpp>

#include <cmath>
#include <cstring>
#include <mutex>
#include <regex>
#include <sstream>

namespace fs = std::filesystem;

namespace geobarrier {

class PluginLibrary {
  public:
    PluginLibrary(boost::dll::shared_library lib, fs::path file) : m_lib(std::move(lib)), m_file(std::move(file)) {}
    const fs::path &file() const { return m_file; }

  private:
    boost::dll::shared_library m_lib;
    fs::path m_file;
};

const char *to_string(PluginKind kind) {
    switch (kind) {
    case PluginKind::system:
        return "system";
    case PluginKind::forcing:
        return "forcing";
    case PluginKind::extractor:
        return "extractor";
    }
    return "?";
}

const char *to_string(ParamType type) {
    switch (type) {
    case ParamType::real:
        return "real";
    case ParamType::integer:
        return "integer";
    case ParamType::boolean:
        return "bool";
    case ParamType::string:
        return "string";
    }
    return "?";
}

namespace detail {

std::vector<std::string> split_list(const std::string &s, char sep) {
    std::vector<std::string> out;
    std::string item;
    std::istringstream in(s);
    while (std::getline(in, item, sep))
        if (!item.empty()) out.push_back(item);
    return out;
}

} // namespace detail

namespace {

// Boost.DLL and dlopen are not documented as safe to call concurrently.
std::mutex &load_mutex() {
    static std::mutex m;
    return m;
}

std::string text_or_empty(const char *s) { return s ? std::string(s) : std::string(); }

// The C++ series of a core version: "major.minor" while the major is 0 (0.x releases change the C++ API between
// minor versions), else "major". Also the library's SOVERSION (core/CMakeLists.txt).
std::string cpp_series(const std::string &version) {
    const std::size_t first = version.find('.');
    if (first == std::string::npos) return version;
    if (version.compare(0, first, "0") != 0) return version.substr(0, first);
    return version.substr(0, version.find('.', first + 1));
}

// Extensions the core offers plugins by id (gb_host_info.get_extension): its own build info, and from ABI 1.4 the
// picture service through which extractors draw (plot/plot_service.cpp).
const void *core_extension(const char *id) {
    static constexpr gb_build_info build = sdk::build_info();
    if (id && std::strcmp(id, GB_EXTENSION_BUILD_INFO) == 0) return &build;
    if (id && std::strcmp(id, GB_EXTENSION_PLOT) == 0) return plot_service();
    return nullptr;
}

// What the core tells each plugin at load time (ABI 1.3): lives as long as the process.
const gb_host_info host_info{sizeof(gb_host_info),        GB_ABI_VERSION_MAJOR, GB_ABI_VERSION_MINOR,
                             GB_ADVANCE_TABLEAU_REVISION, GEOBARRIER_VERSION,   &core_extension};

// A name the descriptor gives, read at most max_declared_name_length + 1 characters far (a name without its end is
// not read on). `what` names it in the message, e.g. "plugin 'duffing' declares a parameter".
std::string bounded_name(const char *name, const std::string &what) {
    if (!name || !*name) throw what + " without a name";
    const std::size_t length = ::strnlen(name, max_declared_name_length + 1);
    if (length > max_declared_name_length)
        throw what + " with a name longer than " + std::to_string(max_declared_name_length) + " characters ('" +
            std::string(name, 20) + "...')";
    return std::string(name, length);
}

// A system's table: its dimension (bounded before the domain and state names are read, one entry per component),
// capabilities, domain (ABI 1.1) and state names and units (ABI 1.2).
void read_system(const gb_plugin_descriptor &d, const gb_plugin_entry &entry, PluginInfo &info) {
    info.kind = PluginKind::system;
    if (!d.system || !d.system->rhs) throw "system '" + info.name + "' has no right-hand side";
    info.dimension = d.system->dimension;
    info.has_jacobian = d.system->jacobian != nullptr;
    info.has_divergence = d.system->divergence != nullptr;
    info.uses_forcing = (d.system->capabilities & GB_SYSTEM_USES_FORCING) != 0;
    info.jacobian_derived = info.has_jacobian && (d.system->capabilities & GB_SYSTEM_JACOBIAN_DERIVED) != 0;
    // Dimensions the engine does not integrate (above max_dimension) are refused when an experiment uses the system
    // (experiment.cpp, with the JSON path), so that `plugins` and check-plugin still list them; beyond
    // max_declared_dimension a descriptor is malformed.
    if (info.dimension == 0) throw "system '" + info.name + "' has dimension 0";
    if (info.dimension > max_declared_dimension)
        throw "system '" + info.name + "' declares dimension " + std::to_string(info.dimension) +
            "; a plugin may declare at most " + std::to_string(max_declared_dimension) +
            " (the flow map engine integrates 2 to " + std::to_string(max_dimension) + ")";
    // ABI 1.1 appended the domain; an older plugin's table ends before it.
    if (entry.abi_minor >= 1 && (d.system->domain_min || d.system->domain_max)) {
        if (!d.system->domain_min || !d.system->domain_max)
            throw "system '" + info.name + "' declares only one side of its domain";
        for (std::uint32_t i = 0; i < info.dimension; ++i) {
            const double lo = d.system->domain_min[i], hi = d.system->domain_max[i];
            if (!(lo < hi) || !std::isfinite(lo) || !std::isfinite(hi))
                throw "system '" + info.name + "' declares an empty or infinite domain in component " +
                    std::to_string(i);
            info.domain_min.push_back(lo);
            info.domain_max.push_back(hi);
        }
    }
    // ABI 1.2 appended the state names and units; an older plugin's table ends before them. Missing entries are
    // copied as "" here and reported by check-plugin (conformance), not refused; names are bounded like every name.
    if (entry.abi_minor >= 2 && (d.system->state_names || d.system->state_units)) {
        for (std::uint32_t i = 0; i < info.dimension; ++i) {
            const char *name = d.system->state_names ? d.system->state_names[i] : nullptr;
            info.state_names.push_back(
                name && *name ? bounded_name(name, "system '" + info.name + "' declares a state component") : "");
            info.state_units.push_back(d.system->state_units ? text_or_empty(d.system->state_units[i]) : "");
        }
    }
}

// A forcing's table: the composite-forcing fields (ABI 1.1).
void read_forcing(const gb_plugin_descriptor &d, const gb_plugin_entry &entry, PluginInfo &info) {
    info.kind = PluginKind::forcing;
    if (!d.forcing || !d.forcing->evaluate) throw "forcing '" + info.name + "' has no evaluate function";
    // ABI 1.1 appended the composite-forcing fields; an older plugin's table ends before them.
    if (entry.abi_minor >= 1 && d.forcing->max_terms > 0) {
        if (!d.forcing->combine) throw "composite forcing '" + info.name + "' has no combine function";
        if (d.forcing->min_terms < 1 || d.forcing->min_terms > d.forcing->max_terms)
            throw "composite forcing '" + info.name + "' declares " + std::to_string(d.forcing->min_terms) + " to " +
                std::to_string(d.forcing->max_terms) + " terms (need 1 <= min <= max)";
        info.min_terms = d.forcing->min_terms;
        info.max_terms = d.forcing->max_terms;
    }
}

// An extractor's table: the fields it needs, a NULL-terminated list of at most max_declared_fields names.
void read_extractor(const gb_plugin_descriptor &d, PluginInfo &info) {
    info.kind = PluginKind::extractor;
    if (!d.extractor || !d.extractor->extract) throw "extractor '" + info.name + "' has no extract function";
    if (!d.extractor->required_fields) return;
    for (const char *const *f = d.extractor->required_fields; *f; ++f) {
        if (info.required_fields.size() == max_declared_fields)
            throw "extractor '" + info.name + "' requires more than " + std::to_string(max_declared_fields) + " fields";
        info.required_fields.push_back(bounded_name(*f, "extractor '" + info.name + "' requires a field"));
    }
}

// The parameter schema: at most max_declared_params parameters (counted before one is read), each named once.
void read_params(const gb_plugin_descriptor &d, PluginInfo &info) {
    if (d.param_count > max_declared_params)
        throw "plugin '" + info.name + "' declares " + std::to_string(d.param_count) +
            " parameters; a plugin may declare at most " + std::to_string(max_declared_params);
    if (d.param_count > 0 && !d.params) throw "plugin '" + info.name + "' declares parameters but gives none";
    for (std::uint32_t i = 0; i < d.param_count; ++i) {
        const gb_param_spec &s = d.params[i];
        ParamSpec p;
        p.name = bounded_name(s.name, "plugin '" + info.name + "' has a parameter");
        switch (s.type) {
        case GB_PARAM_REAL:
            p.type = ParamType::real;
            break;
        case GB_PARAM_INTEGER:
            p.type = ParamType::integer;
            break;
        case GB_PARAM_BOOL:
            p.type = ParamType::boolean;
            break;
        case GB_PARAM_STRING:
            p.type = ParamType::string;
            break;
        default:
            throw "parameter '" + p.name + "' of '" + info.name + "' has unknown type " + std::to_string(s.type);
        }
        p.default_value = s.default_value;
        p.min_value = s.min_value;
        p.max_value = s.max_value;
        p.default_string = text_or_empty(s.default_string);
        if (s.choices) p.choices = detail::split_list(s.choices, '|');
        p.unit = text_or_empty(s.unit);
        p.doc = text_or_empty(s.doc);
        for (const ParamSpec &q : info.params)
            if (q.name == p.name) throw "plugin '" + info.name + "' declares parameter '" + p.name + "' twice";
        info.params.push_back(std::move(p));
    }
}

// Copies and checks one descriptor; throws a reason string on malformed input. Every declared limit (plugin.hpp,
// max_declared_*) is checked here, as the descriptor is read, before anything is sized from it.
PluginInfo read_descriptor(const gb_plugin_descriptor &d, const fs::path &file, const gb_plugin_entry &entry) {
    PluginInfo info;
    info.file = file;
    info.abi_major = entry.abi_major;
    info.abi_minor = entry.abi_minor;
    info.name = bounded_name(d.name, "a descriptor");
    static const std::regex name_rule("[a-z0-9][a-z0-9-]*");
    if (!std::regex_match(info.name, name_rule)) throw "plugin name '" + info.name + "' must match [a-z0-9][a-z0-9-]*";
    info.version = text_or_empty(d.version);
    info.doc = text_or_empty(d.doc);
    info.thread_safety = d.thread_safety;
    if (d.core_version) {
        // Tied to the core library's C++ series (its SOVERSION), not to the exact release: a patch release needs
        // no rebuild of the extractors that link it.
        info.core_version = d.core_version;
        if (cpp_series(info.core_version) != cpp_series(GEOBARRIER_VERSION))
            throw "plugin '" + info.name + "' links geobarrier core " + info.core_version + " (C++ series " +
                cpp_series(info.core_version) + "), this is core " + GEOBARRIER_VERSION + " (series " +
                cpp_series(GEOBARRIER_VERSION) + "; C++ interfaces change between series: rebuild the plugin)";
    }
    if (!d.create || !d.destroy) throw "plugin '" + info.name + "' has no create/destroy function";
    switch (d.kind) {
    case GB_KIND_SYSTEM:
        read_system(d, entry, info);
        break;
    case GB_KIND_FORCING:
        read_forcing(d, entry, info);
        break;
    case GB_KIND_EXTRACTOR:
        read_extractor(d, info);
        break;
    default:
        throw "plugin '" + info.name + "' has unknown kind " + std::to_string(d.kind);
    }
    read_params(d, info);
    return info;
}

} // namespace

std::vector<PluginHandle> load_plugin_library(const fs::path &file) {
    const std::string where = file.string() + ": ";
    std::error_code ec;
    if (!fs::exists(file, ec)) throw PluginError(where + "no such file");
    if (!fs::is_regular_file(file, ec)) throw PluginError(where + "not a regular file");
    // Before dlopen maps it: a library cut short would be mapped beyond its end and kill the process (SIGBUS).
    const LibraryFileCheck checked = check_library_file(file);
    if (checked.problem == LibraryFileProblem::damaged)
        throw LibraryFileError(where + "not a loadable shared library (" + checked.reason + ")");
    if (checked.problem == LibraryFileProblem::not_elf)
        throw PluginError(where + "not a loadable shared library (" + checked.reason + ")");

    std::lock_guard<std::mutex> lock(load_mutex());
    boost::dll::shared_library lib;
    boost::dll::fs::error_code dll_ec;
    lib.load(file, boost::dll::load_mode::rtld_lazy | boost::dll::load_mode::rtld_local, dll_ec);
    if (dll_ec) {
        // Boost's error code drops dlerror's text ("invalid ELF header", a
        // missing dependency...); ask dlopen once more for the real reason.
        std::string reason = dll_ec.message();
        if (void *again = ::dlopen(file.c_str(), RTLD_LAZY | RTLD_LOCAL)) {
            ::dlclose(again);
        } else if (const char *text = ::dlerror()) {
            reason = text;
            const std::string prefix = file.string() + ": ";
            if (reason.rfind(prefix, 0) == 0) reason = reason.substr(prefix.size()); // dlerror repeats the path
        }
        throw PluginError(where + "not a loadable shared library (" + reason + ")");
    }
    if (!lib.has(GB_PLUGIN_ENTRY_SYMBOL))
        throw PluginError(where + "not a geobarrier plugin (no '" GB_PLUGIN_ENTRY_SYMBOL "' entry symbol)");
    // A library built for ABI 1.3 or newer also exports the entry that receives the host's version (gb_host_info).
    const bool with_host = lib.has(GB_PLUGIN_ENTRY_WITH_HOST_SYMBOL);
    // The entry is C, but a broken C++ plugin can still throw out of it: that is a refusal naming the file, not a
    // crash or an anonymous message (nor an escape from a registry scan).
    const gb_plugin_entry *entry = nullptr;
    try {
        if (with_host)
            entry =
                lib.get<const gb_plugin_entry *(const gb_host_info *)>(GB_PLUGIN_ENTRY_WITH_HOST_SYMBOL)(&host_info);
        else
            entry = lib.get<const gb_plugin_entry *()>(GB_PLUGIN_ENTRY_SYMBOL)();
    } catch (const std::exception &e) {
        throw PluginError(where + "the entry function threw: " + e.what());
    } catch (...) {
        throw PluginError(where + "the entry function threw an exception of unknown type");
    }
    if (!entry) throw PluginError(where + "the entry function returned no entry");
    std::vector<PluginInfo> infos = detail::read_plugin_entry(*entry, file);
    // ABI 1.3 appended the library's extensions by id; an older entry ends before them.
    gb_build_info build{};
    if (entry->abi_minor >= 3 && entry->get_extension)
        if (const auto *b =
                static_cast<const gb_build_info *>(entry->get_extension(UINT32_MAX, GB_EXTENSION_BUILD_INFO)))
            if (b->struct_size >= sizeof(gb_build_info)) build = *b;

    auto shared = std::make_shared<const PluginLibrary>(std::move(lib), file);
    std::vector<PluginHandle> out;
    for (std::uint32_t i = 0; i < entry->count; ++i) {
        out.push_back(PluginHandle{shared, &entry->descriptors[i], std::move(infos[i])});
        out.back().info.build = build;
    }
    return out;
}

std::vector<PluginInfo> detail::read_plugin_entry(const gb_plugin_entry &entry, const fs::path &file) {
    const std::string where = file.string() + ": ";
    if (entry.abi_major != GB_ABI_VERSION_MAJOR)
        throw PluginError(where + "built for plugin ABI " + std::to_string(entry.abi_major) + "." +
                          std::to_string(entry.abi_minor) + ", this geobarrier speaks ABI " +
                          std::to_string(GB_ABI_VERSION_MAJOR) + "." + std::to_string(GB_ABI_VERSION_MINOR) +
                          " (rebuild the plugin against this version)");
    if (entry.count == 0 || !entry.descriptors) throw PluginError(where + "the entry declares no plugins");
    std::vector<PluginInfo> infos;
    for (std::uint32_t i = 0; i < entry.count; ++i) {
        try {
            infos.push_back(read_descriptor(entry.descriptors[i], file, entry));
        } catch (const std::string &reason) {
            throw PluginError(where + reason);
        }
    }
    return infos;
}

} // namespace geobarrier
