// Plugin parameters (plugin.hpp): values checked against a plugin's schema (JSON paths, ranges, choices, "did you
// mean"), back to JSON, a plugin's description as JSON, its axis labels, and its status codes as errors.
#include <geobarrier/errors.hpp>
#include <geobarrier/plugin.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

namespace geobarrier {

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

} // namespace geobarrier
