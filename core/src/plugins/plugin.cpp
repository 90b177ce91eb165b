// Loading plugin libraries (Boost.DLL), checking what they declare, validating
// parameters against their schemas, and the wrappers that call across the ABI.
#include "plot/plot_service.hpp"
#include "plugins/library_check.hpp"
#include "plugins/plugin_entry.hpp"

#include <geobarrier/cancel.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/flow_map.hpp>
#include <geobarrier/plugin.hpp>
#include <geobarrier/sdk.hpp>

#include <dlfcn.h>

#include <boost/dll/runtime_symbol_info.hpp>
#include <boost/dll/shared_library.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
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

namespace {

// Boost.DLL and dlopen are not documented as safe to call concurrently.
std::mutex &load_mutex() {
    static std::mutex m;
    return m;
}

// PluginRegistry::find is const but may add a plugin loaded from a path; this lock makes concurrent calls safe (a
// library embedded in Python may resolve experiments from several threads). One lock for every registry: find is
// cheap next to what follows it.
std::mutex &registry_mutex() {
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

std::vector<std::string> split(const std::string &s, char sep) {
    std::vector<std::string> out;
    std::string item;
    std::istringstream in(s);
    while (std::getline(in, item, sep))
        if (!item.empty()) out.push_back(item);
    return out;
}

bool looks_like_shared_library(const fs::path &p) {
    const std::string name = p.filename().string();
    return p.extension() == ".so" || name.find(".so.") != std::string::npos || p.extension() == ".dylib" ||
           p.extension() == ".dll";
}

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
        if (s.choices) p.choices = split(s.choices, '|');
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

// ------------------------------------------------------------ param values

ParamValues::ParamValues(std::vector<double> values, std::vector<std::string> strings, std::vector<bool> is_string)
    : m_values(std::move(values)), m_strings(std::move(strings)), m_is_string(std::move(is_string)) {
    rebuild_view();
}
ParamValues::ParamValues(const ParamValues &other)
    : m_values(other.m_values), m_strings(other.m_strings), m_is_string(other.m_is_string) {
    rebuild_view();
}
ParamValues &ParamValues::operator=(const ParamValues &other) {
    if (this != &other) {
        m_values = other.m_values;
        m_strings = other.m_strings;
        m_is_string = other.m_is_string;
        rebuild_view();
    }
    return *this;
}
void ParamValues::rebuild_view() {
    m_string_ptrs.assign(m_values.size(), nullptr);
    for (std::size_t i = 0; i < m_values.size(); ++i)
        if (i < m_is_string.size() && m_is_string[i]) m_string_ptrs[i] = m_strings[i].c_str();
    m_view = gb_param_values{static_cast<std::uint32_t>(m_values.size()), m_values.data(), m_string_ptrs.data()};
}

std::string did_you_mean(const std::string &word, const std::vector<std::string> &candidates) {
    // Optimal-string-alignment distance: a transposition ("detla") costs one edit.
    auto distance = [](const std::string &a, const std::string &b) {
        const auto same = [](char p, char q) { return std::tolower(p) == std::tolower(q); };
        std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
        for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
        for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
        for (std::size_t i = 1; i <= a.size(); ++i)
            for (std::size_t j = 1; j <= b.size(); ++j) {
                d[i][j] =
                    std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (same(a[i - 1], b[j - 1]) ? 0 : 1)});
                if (i > 1 && j > 1 && same(a[i - 1], b[j - 2]) && same(a[i - 2], b[j - 1]))
                    d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
            }
        return d[a.size()][b.size()];
    };
    std::string best;
    std::size_t best_d = std::string::npos;
    for (const auto &c : candidates) {
        const std::size_t d = distance(word, c);
        if (d < best_d) {
            best_d = d;
            best = c;
        }
    }
    // Close enough: at most a third of the word's letters changed (and at least one allowed).
    if (best_d == std::string::npos || best_d > std::max<std::size_t>(1, (word.size() + 2) / 3)) return {};
    return best;
}

namespace {
std::string format_number(double v) {
    std::ostringstream s;
    s.precision(17);
    s << v;
    return s.str();
}
std::string range_text(const ParamSpec &p) {
    return "[" + format_number(p.min_value) + ", " + format_number(p.max_value) + "]";
}
} // namespace

ParamValues validate_params(const PluginInfo &info, const nlohmann::json &params, const std::string &json_path) {
    if (!params.is_null() && !params.is_object())
        throw ConfigError(json_path, "expected an object of parameters for " + std::string(to_string(info.kind)) +
                                         " '" + info.name + "', got " + params.dump());
    std::vector<std::string> names;
    for (const auto &p : info.params) names.push_back(p.name);
    if (params.is_object()) {
        for (const auto &item : params.items()) {
            if (std::find(names.begin(), names.end(), item.key()) != names.end()) continue;
            std::string msg = "unknown parameter of " + std::string(to_string(info.kind)) + " '" + info.name + "'";
            const std::string hint = did_you_mean(item.key(), names);
            if (!hint.empty())
                msg += "; did you mean \"" + hint + "\"?";
            else if (names.empty())
                msg += "; it takes no parameters";
            else {
                msg += "; it takes:";
                for (const auto &n : names) msg += " " + n;
            }
            throw ConfigError(json_path + "/" + item.key(), msg);
        }
    }
    std::vector<double> values;
    std::vector<std::string> strings;
    std::vector<bool> is_string;
    for (const ParamSpec &p : info.params) {
        const std::string path = json_path + "/" + p.name;
        const bool given = params.is_object() && params.contains(p.name);
        const nlohmann::json v = given ? params.at(p.name) : nlohmann::json();
        double number = p.default_value;
        std::string text = p.default_string;
        switch (p.type) {
        case ParamType::real:
        case ParamType::integer:
            if (given) {
                if (!v.is_number())
                    throw ConfigError(path, v.dump() + " is not a number (" + to_string(p.type) + " expected)");
                number = v.get<double>();
                if (!std::isfinite(number)) throw ConfigError(path, v.dump() + " is not finite");
                if (p.type == ParamType::integer && number != std::floor(number))
                    throw ConfigError(path, v.dump() + " is not an integer");
            }
            if (number < p.min_value || number > p.max_value)
                throw ConfigError(path, format_number(number) + " is outside the allowed range " + range_text(p) +
                                            (p.unit.empty() ? "" : " " + p.unit));
            break;
        case ParamType::boolean:
            if (given) {
                if (!v.is_boolean()) throw ConfigError(path, v.dump() + " is not true or false");
                number = v.get<bool>() ? 1.0 : 0.0;
            }
            break;
        case ParamType::string:
            if (given) {
                if (!v.is_string()) throw ConfigError(path, v.dump() + " is not a string");
                text = v.get<std::string>();
            }
            if (!p.choices.empty() && std::find(p.choices.begin(), p.choices.end(), text) == p.choices.end()) {
                std::string msg = "\"" + text + "\" is not one of:";
                for (const auto &c : p.choices) msg += " \"" + c + "\"";
                const std::string hint = did_you_mean(text, p.choices);
                if (!hint.empty()) msg += "; did you mean \"" + hint + "\"?";
                throw ConfigError(path, msg);
            }
            break;
        }
        values.push_back(number);
        strings.push_back(text);
        is_string.push_back(p.type == ParamType::string);
    }
    return ParamValues(std::move(values), std::move(strings), std::move(is_string));
}

nlohmann::json params_to_json(const PluginInfo &info, const ParamValues &values) {
    nlohmann::json out = nlohmann::json::object();
    for (std::size_t i = 0; i < info.params.size(); ++i) {
        const ParamSpec &p = info.params[i];
        switch (p.type) {
        case ParamType::real:
            out[p.name] = values.value(i);
            break;
        case ParamType::integer:
            out[p.name] = static_cast<long long>(values.value(i));
            break;
        case ParamType::boolean:
            out[p.name] = values.value(i) != 0.0;
            break;
        case ParamType::string:
            out[p.name] = values.string(i);
            break;
        }
    }
    return out;
}

nlohmann::json plugin_info_to_json(const PluginInfo &info) {
    nlohmann::json j;
    j["kind"] = to_string(info.kind);
    j["name"] = info.name;
    j["version"] = info.version;
    j["doc"] = info.doc;
    j["file"] = info.file.string();
    j["abi"] = std::to_string(info.abi_major) + "." + std::to_string(info.abi_minor);
    if (!info.core_version.empty()) j["core_version"] = info.core_version;
    j["thread_safety"] = info.thread_safety == GB_THREAD_SAFE_CONCURRENT ? "concurrent" : "per-instance";
    // JSON has no infinity: an unbounded side of a range is null (docs/plugins.md, "plugins --json").
    auto json_number = [](double v) -> nlohmann::json {
        if (std::isinf(v)) return nullptr;
        return v;
    };
    nlohmann::json params = nlohmann::json::array();
    for (const ParamSpec &p : info.params) {
        nlohmann::json q;
        q["name"] = p.name;
        q["type"] = to_string(p.type);
        if (p.type == ParamType::string) {
            q["default"] = p.default_string;
            if (!p.choices.empty()) q["choices"] = p.choices;
        } else if (p.type == ParamType::boolean) {
            q["default"] = p.default_value != 0.0;
        } else {
            q["default"] = p.type == ParamType::integer ? nlohmann::json(static_cast<long long>(p.default_value))
                                                        : nlohmann::json(p.default_value);
            q["min"] = json_number(p.min_value);
            q["max"] = json_number(p.max_value);
        }
        q["unit"] = p.unit;
        q["doc"] = p.doc;
        params.push_back(q);
    }
    j["params"] = params;
    if (info.kind == PluginKind::system) {
        j["dimension"] = info.dimension;
        j["jacobian"] = info.has_jacobian;
        j["divergence"] = info.has_divergence;
        j["uses_forcing"] = info.uses_forcing;
        if (!info.domain_min.empty()) j["domain"] = {{"min", info.domain_min}, {"max", info.domain_max}};
        if (!info.state_names.empty()) j["state"] = {{"names", info.state_names}, {"units", info.state_units}};
    }
    if (info.kind == PluginKind::forcing && info.composite())
        j["terms"] = {{"min", info.min_terms}, {"max", info.max_terms}};
    if (info.kind == PluginKind::extractor) j["required_fields"] = info.required_fields;
    return j;
}

std::string state_axis_label(const PluginInfo &system, std::size_t i) {
    if (i >= system.state_names.size() || system.state_names[i].empty()) return i == 0 ? "x" : i == 1 ? "y" : "z";
    const std::string &unit = i < system.state_units.size() ? system.state_units[i] : std::string();
    return system.state_names[i] + " [" + (unit.empty() ? std::string("–") : unit) + "]"; // [–]: nondimensional
}

std::string time_axis_label(const PluginInfo &system) {
    if (system.state_names.empty()) return "t";
    for (const std::string &unit : system.state_units)
        if (!unit.empty()) return "t [time]"; // the unit the parameter schemas call "time"
    return "t [–]"; // every state component is nondimensional: a scaled model (Duffing, Van der Pol)
}

void check_plugin_status(gb_status status, const PluginInfo &info, const char *what, const char *message) {
    if (status == GB_OK) return;
    throw PluginError(info.file.string() + ": " + to_string(info.kind) + " '" + info.name + "' failed in " + what +
                      ": " + (message && *message ? message : "no message"));
}

// ------------------------------------------------------------ instances

PluginInstance::PluginInstance(const PluginHandle &handle, const ParamValues &values)
    : m_handle(std::make_shared<const PluginHandle>(handle)) {
    char text[512] = {0};
    gb_message msg{text, sizeof text};
    void *self = handle.descriptor->create(values.c_view(), &msg);
    if (!self)
        throw PluginError(handle.info.file.string() + ": " + to_string(handle.info.kind) + " '" + handle.info.name +
                          "' could not be created: " + (text[0] ? text : "no message"));
    // The deleter holds the handle (and so the library) until the object is gone.
    auto keep = m_handle;
    m_self = std::shared_ptr<void>(self, [keep](void *p) { keep->descriptor->destroy(p); });
}

namespace {
// One message buffer per call keeps the wrappers thread-safe.
// Only the first byte is cleared: this runs on every batched call.
struct CallMessage {
    char text[512];
    gb_message msg{text, sizeof text};
    CallMessage() { text[0] = '\0'; }
};
} // namespace

System::System(const PluginHandle &handle, const ParamValues &values) : m_instance(handle, values) {
    if (handle.info.kind != PluginKind::system)
        throw PluginError(handle.info.file.string() + ": '" + handle.info.name + "' is not a system");
    m_table = handle.descriptor->system;
    if (handle.info.abi_minor >= 2) m_advance = m_table->advance;
}

void System::rhs(std::size_t n, std::size_t ld, const double *t, const double *x, const double *f, double *dxdt,
                 std::int32_t *lane_status) const {
    CallMessage m;
    check_plugin_status(m_table->rhs(m_instance.self(), n, ld, t, x, f, dxdt, lane_status, &m.msg), info(), "rhs",
                        m.text);
}

void System::jacobian(std::size_t n, std::size_t ld, const double *t, const double *x, const double *f, double *jac,
                      std::int32_t *lane_status) const {
    if (!m_table->jacobian) throw PluginError(info().file.string() + ": system '" + info().name + "' has no Jacobian");
    CallMessage m;
    check_plugin_status(m_table->jacobian(m_instance.self(), n, ld, t, x, f, jac, lane_status, &m.msg), info(),
                        "jacobian", m.text);
}

void System::divergence(std::size_t n, std::size_t ld, const double *t, const double *x, const double *f, double *div,
                        std::int32_t *lane_status) const {
    if (!m_table->divergence)
        throw PluginError(info().file.string() + ": system '" + info().name + "' has no divergence");
    CallMessage m;
    check_plugin_status(m_table->divergence(m_instance.self(), n, ld, t, x, f, div, lane_status, &m.msg), info(),
                        "divergence", m.text);
}

bool System::advance(const gb_advance_request &request) const {
    if (!m_advance) return false;
    CallMessage m;
    // The request names the numerics the core expects (ABI 1.3): a plugin compiled with other ones declines.
    gb_advance_request named = request;
    named.tableau_revision = GB_ADVANCE_TABLEAU_REVISION;
    const gb_status status = m_advance(m_instance.self(), &named, &m.msg);
    if (status == GB_UNSUPPORTED) return false;
    check_plugin_status(status, info(), "advance", m.text);
    return true;
}

Forcing::Forcing(const PluginHandle &handle, const ParamValues &values) : m_instance(handle, values) {
    if (handle.info.kind != PluginKind::forcing)
        throw PluginError(handle.info.file.string() + ": '" + handle.info.name + "' is not a forcing");
    m_table = handle.descriptor->forcing;
}

struct Forcing::Composite {
    std::vector<Forcing> terms;
    PluginInfo info; // the plugin's, with the weakest thread safety of the tree
};

Forcing::Forcing(const PluginHandle &handle, const ParamValues &values, std::vector<Forcing> terms)
    : Forcing(handle, values) {
    const PluginInfo &own = handle.info;
    const std::string who = own.file.string() + ": forcing '" + own.name + "'";
    if (!own.composite()) throw PluginError(who + " is not a composite forcing; it takes no terms");
    if (terms.size() < own.min_terms || terms.size() > own.max_terms)
        throw PluginError(who + " takes " + std::to_string(own.min_terms) + " to " + std::to_string(own.max_terms) +
                          " terms, not " + std::to_string(terms.size()));
    auto composite = std::make_shared<Composite>();
    composite->info = own;
    for (const Forcing &term : terms)
        if (term.info().thread_safety != GB_THREAD_SAFE_CONCURRENT)
            composite->info.thread_safety = GB_THREAD_SAFE_PER_INSTANCE;
    composite->terms = std::move(terms);
    m_composite = std::move(composite);
}

const PluginInfo &Forcing::info() const { return m_composite ? m_composite->info : m_instance.info(); }

const std::vector<Forcing> &Forcing::terms() const {
    static const std::vector<Forcing> none;
    return m_composite ? m_composite->terms : none;
}

void Forcing::evaluate(std::size_t n, const double *t, double *f) const {
    if (m_composite) {
        // The flow-map engine asks for one time per stage: the terms' values fit on the stack.
        const std::vector<Forcing> &terms = m_composite->terms;
        constexpr std::size_t small = 64;
        double stack_values[small];
        std::vector<double> heap_values;
        double *values = stack_values;
        if (terms.size() * n > small) {
            heap_values.resize(terms.size() * n);
            values = heap_values.data();
        }
        for (std::size_t j = 0; j < terms.size(); ++j) terms[j].evaluate(n, t, values + j * n);
        combine(n, t, terms.size(), n, values, f);
        return;
    }
    if (info().composite())
        throw PluginError(info().file.string() + ": composite forcing '" + info().name +
                          "' was created without its terms");
    CallMessage m;
    check_plugin_status(m_table->evaluate(m_instance.self(), n, t, f, &m.msg), info(), "evaluate", m.text);
}

void Forcing::combine(std::size_t n, const double *t, std::size_t term_count, std::size_t ld, const double *terms,
                      double *f) const {
    if (!info().composite())
        throw PluginError(info().file.string() + ": forcing '" + info().name + "' is not a composite forcing");
    CallMessage m;
    check_plugin_status(
        m_table->combine(m_instance.self(), n, t, static_cast<std::uint32_t>(term_count), ld, terms, f, &m.msg), info(),
        "combine", m.text);
}

Extractor::Extractor(const PluginHandle &handle, const ParamValues &values) : m_instance(handle, values) {
    if (handle.info.kind != PluginKind::extractor)
        throw PluginError(handle.info.file.string() + ": '" + handle.info.name + "' is not an extractor");
    m_table = handle.descriptor->extractor;
}

namespace {
struct ExtractContext {
    std::string plugin;
    const ExtractServices *services;
    std::vector<Barrier> barriers;
};
void host_log(void *context, std::int32_t level, const char *line) {
    auto *c = static_cast<ExtractContext *>(context);
    if (level >= 2)
        spdlog::warn("{}: {}", c->plugin, line ? line : "");
    else if (level == 1)
        spdlog::info("{}: {}", c->plugin, line ? line : "");
    else
        spdlog::debug("{}: {}", c->plugin, line ? line : "");
}
// Nonzero asks the extractor to stop: the user interrupted the run (SIGINT/SIGTERM, cancel.hpp).
std::int32_t host_progress(void *, double) { return cancel_requested() != 0; }
gb_status host_add_barrier(void *context, const char *kind, std::int32_t closed, std::uint64_t count, const double *xy,
                           std::uint32_t metric_count, const char *const *names, const double *values) {
    auto *c = static_cast<ExtractContext *>(context);
    if (!kind || (count > 0 && !xy) || (metric_count > 0 && (!names || !values))) return GB_ERROR;
    Barrier b;
    b.kind = kind;
    b.closed = closed != 0;
    b.xy.assign(xy, xy + 2 * count);
    for (std::uint32_t i = 0; i < metric_count; ++i) b.metrics.emplace_back(names[i] ? names[i] : "", values[i]);
    c->barriers.push_back(std::move(b));
    return GB_OK;
}
gb_status host_advect(void *context, std::uint64_t n, const double *xy, double t_from, double t_to, double *xy_out,
                      double *dF_out, std::uint8_t *mask_out, gb_message *msg) {
    auto *c = static_cast<ExtractContext *>(context);
    try {
        if (!c->services->advect) throw Error("this host offers no advection");
        c->services->advect(n, xy, t_from, t_to, xy_out, dF_out, mask_out);
        return GB_OK;
    } catch (const std::exception &e) {
        if (msg && msg->text && msg->capacity) {
            std::strncpy(msg->text, e.what(), msg->capacity - 1);
            msg->text[msg->capacity - 1] = '\0';
        }
        return GB_ERROR;
    }
}
gb_status host_set_barrier_attributes(void *context, std::uint32_t count, const char *const *names,
                                      const char *const *json_values) {
    auto *c = static_cast<ExtractContext *>(context);
    if (c->barriers.empty() || (count > 0 && (!names || !json_values))) return GB_ERROR;
    std::vector<std::pair<std::string, std::string>> parsed;
    for (std::uint32_t i = 0; i < count; ++i) {
        if (!names[i] || !json_values[i]) return GB_ERROR;
        const auto value = nlohmann::json::parse(json_values[i], nullptr, false);
        if (value.is_discarded() || value.is_object() || value.is_array()) return GB_ERROR;
        parsed.emplace_back(names[i], value.dump());
    }
    auto &attributes = c->barriers.back().attributes;
    attributes.insert(attributes.end(), parsed.begin(), parsed.end());
    return GB_OK;
}
} // namespace

std::vector<Barrier> Extractor::extract(const gb_extract_input &input, const ExtractServices &services) const {
    ExtractContext context{info().name, &services, {}};
    const gb_host host{&context,          &host_log,    &host_progress,
                       &host_add_barrier, &host_advect, &host_set_barrier_attributes};
    CallMessage m;
    check_plugin_status(m_table->extract(m_instance.self(), &host, &input, &m.msg), info(), "extract", m.text);
    return std::move(context.barriers);
}

// ------------------------------------------------------------ registry

fs::path PluginRegistry::builtin_folder() {
    // This library lives in <prefix>/lib, plugins in <prefix>/lib/geobarrier/plugins, in the build tree and in an
    // install alike. Found from the library, not the program, so that a host program anywhere (python3, the tests
    // in build/tests) finds the same plugins as the geobarrier program in <prefix>/bin.
    const fs::path library = boost::dll::this_line_location().string(); // as the loader found it: "lib/x/../.."
    return (library.parent_path() / "geobarrier" / "plugins").lexically_normal();
}

std::vector<fs::path> PluginRegistry::default_folders(const std::vector<fs::path> &extra) {
    std::vector<fs::path> folders = extra;
    if (const char *env = std::getenv("GEOBARRIER_PLUGIN_PATH"))
        for (const auto &p : split(env, ':')) folders.emplace_back(p);
    folders.push_back(builtin_folder());
    return folders;
}

namespace {

// The libraries of a folder, sorted; none when it is not a folder.
std::vector<fs::path> library_files(const fs::path &folder) {
    std::vector<fs::path> files;
    std::error_code ec;
    if (!fs::is_directory(folder, ec)) return files;
    for (const auto &e : fs::directory_iterator(folder, ec))
        if (e.is_regular_file() && looks_like_shared_library(e.path())) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    return files;
}

// The files of `folder` named after plugin `name`, in the order they are tried (plugin.hpp, PluginRegistry).
std::vector<fs::path> files_named_after(const fs::path &folder, const std::string &name) {
    static const std::regex name_rule("[a-z0-9][a-z0-9-]*");
    std::vector<fs::path> out;
    if (!std::regex_match(name, name_rule)) return out;
    for (const std::string &file : {"geobarrier-" + name + ".so", "lib" + name + ".so", name + ".so"}) {
        std::error_code ec;
        if (fs::is_regular_file(folder / file, ec)) out.push_back(folder / file);
    }
    return out;
}

// The plugin name a library's file name stands for: geobarrier-NAME.so, libNAME.so, NAME.so.
std::string name_of_file(const fs::path &file) {
    std::string stem = file.stem().string();
    for (const std::string prefix : {"geobarrier-", "lib"})
        if (stem.rfind(prefix, 0) == 0 && stem.size() > prefix.size()) return stem.substr(prefix.size());
    return stem;
}

bool same_folder(const fs::path &a, const fs::path &b) {
    std::error_code ec;
    return fs::equivalent(a, b, ec) && !ec;
}

} // namespace

PluginRegistry::PluginRegistry(const std::vector<fs::path> &folders, PluginLoading loading)
    : m_folders(folders), m_loading(loading) {
    for (const fs::path &folder : folders) {
        std::error_code ec;
        if (!fs::is_directory(folder, ec)) {
            m_warnings.push_back(folder.string() + ": plugin folder does not exist");
            continue;
        }
        for (const auto &f : library_files(folder)) {
            if (loading == PluginLoading::all) {
                add_library(f, false, "every library of the folder is listed");
                continue;
            }
            // On demand, every library is still checked (plain reads, no code run): a damaged one is refused as
            // when it is mapped, since whoever put it there meant it to be loaded.
            const LibraryFileCheck checked = check_library_file(f);
            if (checked.problem == LibraryFileProblem::damaged)
                throw LibraryFileError(f.string() + ": not a loadable shared library (" + checked.reason + ")");
        }
    }
}

void PluginRegistry::add_library(const fs::path &file, bool strict, const std::string &reason) const {
    m_libraries.push_back(LoadedLibrary{file, {}, reason});
    std::vector<PluginHandle> found;
    try {
        found = load_plugin_library(file);
    } catch (const LibraryFileError &) {
        throw; // a damaged library is refused, not skipped: whoever put it there meant it to be loaded
    } catch (const PluginError &e) {
        if (strict) throw;
        m_warnings.push_back(e.what());
        return;
    }
    for (auto &h : found) {
        m_libraries.back().plugins.push_back(std::string(to_string(h.info.kind)) + " '" + h.info.name + "'");
        const auto same = std::find_if(m_plugins.begin(), m_plugins.end(), [&](const PluginHandle &o) {
            return o.info.kind == h.info.kind && o.info.name == h.info.name;
        });
        if (same != m_plugins.end()) {
            if (same->info.file != h.info.file)
                m_warnings.push_back(h.info.file.string() + ": " + to_string(h.info.kind) + " '" + h.info.name +
                                     "' is shadowed by " + same->info.file.string());
            continue;
        }
        m_plugins.push_back(std::move(h));
    }
}

const PluginHandle *PluginRegistry::find_loaded(PluginKind kind, const std::string &name, const fs::path *file) const {
    for (const PluginHandle &h : m_plugins)
        if (h.info.kind == kind && h.info.name == name && (!file || h.info.file == *file)) return &h;
    return nullptr;
}

// Only the libraries the lookup needs (plugin.hpp, PluginRegistry): the first one named after the plugin, else the
// folders' others one at a time. Null when no folder holds the plugin.
const PluginHandle *PluginRegistry::find_on_demand(PluginKind kind, const std::string &name,
                                                   const std::string &json_path) const {
    const auto was_loaded = [&](const fs::path &file) {
        return std::any_of(m_libraries.begin(), m_libraries.end(),
                           [&](const LoadedLibrary &l) { return l.file == file; });
    };
    const fs::path builtin = builtin_folder();
    const std::vector<fs::path> builtin_named = files_named_after(builtin, name);
    bool named_file_exists = false;
    for (const fs::path &folder : m_folders)
        for (const fs::path &file : files_named_after(folder, name)) {
            named_file_exists = true;
            // Refused before it is mapped: a folder's library named like a built-in plugin would replace it.
            if (!builtin_named.empty() && !same_folder(folder, builtin))
                throw ConfigError(json_path, file.string() + " is named like the built-in " + to_string(kind) + " '" +
                                                 name + "' (" + builtin_named.front().string() +
                                                 ") and would shadow it; to use it, name the library by path: "
                                                 "\"plugin\": \"" +
                                                 file.string() + "\"");
            if (!was_loaded(file)) {
                try {
                    add_library(file, true, "named after the " + std::string(to_string(kind)));
                } catch (const PluginError &e) {
                    throw ConfigError(json_path, e.what()); // the library named after the plugin is not one
                }
            }
            if (const PluginHandle *h = find_loaded(kind, name, &file)) return h;
        }
    if (const PluginHandle *h = find_loaded(kind, name)) return h; // a library mapped for an earlier lookup
    if (named_file_exists) return nullptr;
    // No file is named after the plugin: the folders' other libraries, one at a time; a warning for each that ran
    // and did not hold it.
    for (const fs::path &folder : m_folders)
        for (const fs::path &file : library_files(folder)) {
            if (was_loaded(file)) continue;
            add_library(file, false, "looked for " + std::string(to_string(kind)) + " '" + name + "'");
            if (const PluginHandle *h = find_loaded(kind, name, &file)) return h;
            m_warnings.push_back(file.string() + ": mapped (its code run) while looking for " + to_string(kind) + " '" +
                                 name + "', which it does not hold: no library in the plugin folders is " +
                                 "named after it; name its library geobarrier-" + name +
                                 ".so so that no other library is mapped");
        }
    return nullptr;
}

// What the folders hold of a kind: the loaded plugins' names, and on demand the names the other files stand for.
std::vector<std::string> PluginRegistry::names_by_file(PluginKind kind) const {
    std::vector<std::string> names;
    for (const PluginHandle &h : m_plugins)
        if (h.info.kind == kind) names.push_back(h.info.name);
    if (m_loading == PluginLoading::on_demand)
        for (const fs::path &folder : m_folders)
            for (const fs::path &file : library_files(folder)) {
                const bool mapped = std::any_of(m_libraries.begin(), m_libraries.end(),
                                                [&](const LoadedLibrary &l) { return l.file == file; });
                if (!mapped) names.push_back(name_of_file(file));
            }
    std::sort(names.begin(), names.end());
    names.erase(std::unique(names.begin(), names.end()), names.end());
    return names;
}

const PluginHandle &PluginRegistry::find(PluginKind kind, const std::string &name, const std::string &json_path) const {
    std::lock_guard<std::mutex> lock(registry_mutex());
    const bool is_path = name.find('/') != std::string::npos || fs::path(name).extension() == ".so";
    if (is_path) {
        const fs::path file = fs::absolute(name);
        std::vector<PluginHandle> found;
        try {
            found = load_plugin_library(file);
        } catch (const PluginError &e) {
            throw ConfigError(json_path, e.what());
        }
        m_libraries.push_back(LoadedLibrary{file, {}, "named by path"});
        for (const auto &h : found)
            m_libraries.back().plugins.push_back(std::string(to_string(h.info.kind)) + " '" + h.info.name + "'");
        for (auto &h : found)
            if (h.info.kind == kind) {
                m_plugins.push_back(std::move(h));
                return m_plugins.back();
            }
        throw ConfigError(json_path, file.string() + " holds no " + to_string(kind) + " plugin");
    }
    if (m_loading == PluginLoading::on_demand) {
        if (const PluginHandle *h = find_on_demand(kind, name, json_path)) return *h;
    } else if (const PluginHandle *h = find_loaded(kind, name)) {
        return *h;
    }
    const std::vector<std::string> names = names_by_file(kind);
    std::string msg = "no " + std::string(to_string(kind)) + " plugin named \"" + name + "\"";
    const std::string hint = did_you_mean(name, names);
    if (!hint.empty()) msg += "; did you mean \"" + hint + "\"?";
    if (names.empty()) {
        msg += "; no " + std::string(to_string(kind)) + " plugins were found in:";
        for (const auto &f : m_folders) msg += " " + f.string();
    } else {
        // On demand, the libraries not mapped are known by their file names only, of any kind.
        msg +=
            m_loading == PluginLoading::on_demand ? " (plugins and libraries in the plugin folders:" : " (available:";
        for (const auto &n : names) msg += " " + n;
        msg += ")";
    }
    throw ConfigError(json_path, msg);
}

} // namespace geobarrier
