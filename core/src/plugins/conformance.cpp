// The plugin conformance checks of <geobarrier/conformance.hpp>: each check calls the plugin through the same
// System/Forcing wrappers the runner uses and reports what it found, with the offending values. This file holds the
// checks every plugin gets (ABI, schema, code generation, an instance) and check_plugin, which then runs those of the
// plugin's kind: conformance_systems.cpp, conformance_forcings.cpp, conformance_extractors.cpp.
#include "plugins/conformance_internal.hpp"
#include <geobarrier/conformance.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/sdk.hpp>

#include <algorithm>
#include <cmath>
#include <memory>
#include <regex>
#include <set>
#include <string>
#include <vector>

namespace geobarrier {

namespace {

using namespace detail::conformance;

ConformanceCheck check_abi(const PluginInfo &info) {
    const std::string versions = "plugin ABI " + std::to_string(info.abi_major) + "." + std::to_string(info.abi_minor) +
                                 ", core ABI " + std::to_string(GB_ABI_VERSION_MAJOR) + "." +
                                 std::to_string(GB_ABI_VERSION_MINOR);
    if (info.abi_major != GB_ABI_VERSION_MAJOR) return fail("abi_version", versions);
    return pass("abi_version", versions);
}

ConformanceCheck check_schema(const PluginInfo &info) {
    static const std::regex plugin_name_rule("[a-z0-9][a-z0-9-]*");
    static const std::regex param_name_rule("[a-z0-9_]+");
    std::vector<std::string> problems;
    if (!std::regex_match(info.name, plugin_name_rule))
        problems.push_back("plugin name '" + info.name + "' does not match [a-z0-9][a-z0-9-]*");
    if (info.version.empty()) problems.push_back("no version");
    if (info.doc.empty()) problems.push_back("no doc line");
    if (info.doc.find('\n') != std::string::npos) problems.push_back("doc is more than one line");
    if (info.thread_safety != GB_THREAD_SAFE_CONCURRENT && info.thread_safety != GB_THREAD_SAFE_PER_INSTANCE)
        problems.push_back("unknown thread_safety " + std::to_string(info.thread_safety));
    if (info.kind == PluginKind::system && info.dimension == 0) problems.push_back("dimension 0");
    // State names and units (ABI 1.2): when declared, one non-empty, distinct name per component (axis labels
    // "name [unit]"); a unit may be "" (nondimensional). The loader copied `dimension` entries, NULL ones as "".
    if (info.kind == PluginKind::system && !info.state_names.empty()) {
        if (info.state_names.size() != info.dimension || info.state_units.size() != info.dimension)
            problems.push_back(std::to_string(info.state_names.size()) + " state names and " +
                               std::to_string(info.state_units.size()) + " units for dimension " +
                               std::to_string(info.dimension));
        std::set<std::string> names;
        for (std::size_t i = 0; i < info.state_names.size(); ++i) {
            if (info.state_names[i].empty())
                problems.push_back("state component " + std::to_string(i) + " has no name");
            else if (!names.insert(info.state_names[i]).second)
                problems.push_back("state name '" + info.state_names[i] + "' used twice");
        }
    }
    std::set<std::string> seen;
    for (const ParamSpec &p : info.params) {
        const std::string who = "parameter '" + p.name + "'";
        if (!std::regex_match(p.name, param_name_rule)) problems.push_back(who + ": name does not match [a-z0-9_]+");
        if (!seen.insert(p.name).second) problems.push_back(who + ": declared twice");
        if (p.doc.empty()) problems.push_back(who + ": no doc line");
        if (p.doc.find('\n') != std::string::npos) problems.push_back(who + ": doc is more than one line");
        switch (p.type) {
        case ParamType::real:
        case ParamType::integer:
            if (std::isnan(p.min_value) || std::isnan(p.max_value) || std::isnan(p.default_value))
                problems.push_back(who + ": NaN in default or range");
            else if (!(p.min_value <= p.default_value && p.default_value <= p.max_value))
                problems.push_back(who + ": default " + num(p.default_value) + " outside its range [" +
                                   num(p.min_value) + ", " + num(p.max_value) + "]");
            if (!std::isfinite(p.default_value)) problems.push_back(who + ": default is not finite");
            if (p.type == ParamType::integer && std::isfinite(p.default_value) &&
                p.default_value != std::floor(p.default_value))
                problems.push_back(who + ": integer default " + num(p.default_value) + " is not an integer");
            break;
        case ParamType::boolean:
            if (p.default_value != 0.0 && p.default_value != 1.0)
                problems.push_back(who + ": bool default " + num(p.default_value) + " is not 0 or 1");
            break;
        case ParamType::string:
            if (!p.choices.empty() &&
                std::find(p.choices.begin(), p.choices.end(), p.default_string) == p.choices.end())
                problems.push_back(who + ": default \"" + p.default_string + "\" is not one of its choices");
            break;
        }
    }
    if (problems.empty()) {
        std::string state;
        if (info.kind == PluginKind::system) {
            if (info.state_names.empty()) {
                state = "; no state names declared (axes read x, y)";
            } else {
                state = "; state";
                for (std::size_t i = 0; i < info.state_names.size(); ++i)
                    state += (i ? ", " : " ") + state_axis_label(info, i);
            }
        }
        return pass("schema", std::to_string(info.params.size()) + " parameter(s), all well-formed" + state);
    }
    std::string detail;
    for (const auto &p : problems) detail += (detail.empty() ? "" : "; ") + p;
    return fail("schema", detail);
}

// How the plugin was compiled against how the core was (the GB_EXTENSION_BUILD_INFO extension, ABI 1.3): a plugin
// built for narrower vectors or without FMA runs its fused step slower than the built-ins (2.4x seen), so say so.
ConformanceCheck check_code_generation(const PluginInfo &info) {
    const std::string name = "code_generation";
    const gb_build_info core = sdk::build_info(), &own = info.build;
    const auto describe = [](const gb_build_info &b) {
        return std::to_string(b.vector_bits) + "-bit vectors, " + (b.fma ? "FMA" : "no FMA");
    };
    if (own.struct_size == 0)
        return skip(name, "the plugin does not say how it was compiled (built for ABI " +
                              std::to_string(info.abi_major) + "." + std::to_string(info.abi_minor) +
                              " or without the SDK)");
    if (own.vector_bits < core.vector_bits || (core.fma && !own.fma))
        return warn(name, "compiled for " + describe(own) + ", the core for " + describe(core) +
                              ": its fused step runs slower than the built-in plugins' (build it with "
                              "geobarrier_add_plugin without PORTABLE, or add -march=native)");
    return pass(name, "compiled for " + describe(own) + ", as the core (" + describe(core) + ")");
}

} // namespace

std::vector<ConformanceCheck> check_plugin(const PluginHandle &handle, const ConformanceOptions &options) {
    if (!handle.descriptor) throw Error("check_plugin: the plugin handle holds no descriptor");
    if (options.lanes == 0) throw Error("conformance options: lanes must be at least 1");
    if (!(options.t_min <= options.t_max))
        throw Error("conformance options: t_min " + num(options.t_min) + " is after t_max " + num(options.t_max));
    const PluginInfo &info = handle.info;
    std::vector<ConformanceCheck> out;
    out.push_back(check_abi(info));
    out.push_back(check_schema(info));
    if (!out[0].passed) return out; // nothing else may be read from a plugin of another ABI
    out.push_back(check_code_generation(info));
    const Box box = info.kind == PluginKind::system ? make_box(options, info) : Box{};

    std::unique_ptr<ParamValues> values;
    out.push_back(guarded("create", [&] {
        values = std::make_unique<ParamValues>(validate_params(info, options.params, "/params"));
        switch (info.kind) {
        case PluginKind::system:
            (void)System(handle, *values);
            break;
        case PluginKind::forcing:
            (void)Forcing(handle, *values);
            break;
        case PluginKind::extractor:
            (void)Extractor(handle, *values);
            break;
        }
        return pass("create",
                    "an instance was created from " +
                        std::string(options.params.empty() ? "the default parameters" : "the given parameters"));
    }));
    if (!out.back().passed) {
        // A parameter no default can stand for (a string, e.g. the data forcing's file, whose default is empty)
        // needs a value from the user: without one the plugin is skipped with the reason, not failed.
        std::string required;
        for (const ParamSpec &p : info.params)
            if (p.type == ParamType::string && p.default_string.empty() && p.choices.empty())
                required += (required.empty() ? "\"" : ", \"") + p.name + "\"";
        if (options.params.empty() && !required.empty())
            out.back() = skip("create", "not checked: parameter " + required +
                                            " has no default, so no instance can be made from the defaults (" +
                                            out.back().detail + "); give a value with --params, e.g. --params '{\"" +
                                            info.name + "\": {...}}', to run the remaining checks");
        return out;
    }

    try {
        switch (info.kind) {
        case PluginKind::system:
            check_system(handle, *values, box, options, out);
            break;
        case PluginKind::forcing:
            check_forcing(handle, *values, options, out);
            break;
        case PluginKind::extractor:
            out.push_back(
                guarded("synthetic_field", [&] { return check_extractor_behaviour(Extractor(handle, *values)); }));
            break;
        }
    } catch (const std::exception &e) {
        out.push_back(fail("instances", std::string("creating the instances under test failed: ") + e.what()));
    }
    return out;
}

std::string count_checks(const std::vector<ConformanceCheck> &checks) {
    std::size_t passed = 0, skipped = 0, failed = 0, warnings = 0;
    for (const auto &c : checks) {
        if (c.skipped)
            ++skipped;
        else if (c.passed)
            ++passed;
        else
            ++failed;
        warnings += c.passed && c.warning;
    }
    return std::to_string(passed) + " passed, " + std::to_string(skipped) + " skipped, " + std::to_string(failed) +
           " failed" + (warnings ? ", " + std::to_string(warnings) + (warnings == 1 ? " warning" : " warnings") : "");
}

bool all_passed(const std::vector<ConformanceCheck> &checks) {
    return std::all_of(checks.begin(), checks.end(), [](const ConformanceCheck &c) { return c.passed; });
}

std::string format_checks(const std::vector<ConformanceCheck> &checks) {
    std::size_t width = 0;
    for (const auto &c : checks) width = std::max(width, c.name.size());
    std::string out;
    for (const auto &c : checks) {
        out += c.skipped ? "SKIP  " : !c.passed ? "FAIL  " : c.warning ? "WARN  " : "PASS  ";
        out += c.name + std::string(width - c.name.size() + 2, ' ') + c.detail + "\n";
    }
    return out;
}

} // namespace geobarrier
