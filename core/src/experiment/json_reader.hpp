// Reading one JSON object of an experiment file with the project's rules: every
// key read is remembered, the rest are errors with a "did you mean" hint, and
// every error names the JSON path, the value and the rule. Private to the core.
#ifndef GEOBARRIER_SRC_JSON_READER_HPP
#define GEOBARRIER_SRC_JSON_READER_HPP

#include <geobarrier/errors.hpp>
#include <geobarrier/plugin.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace geobarrier::detail {

using nlohmann::json;

inline std::string type_name(const json &v) {
    if (v.is_null()) return "null";
    if (v.is_boolean()) return "a boolean";
    if (v.is_number()) return "a number";
    if (v.is_string()) return "a string";
    if (v.is_array()) return "an array";
    return "an object";
}

inline std::string short_dump(const json &v) {
    std::string s = v.dump();
    if (s.size() > 60) s = s.substr(0, 57) + "...";
    return s;
}

// A JSON object being read: remembers which keys were used so the rest can be
// reported as unknown, with a hint.
class ObjectReader {
  public:
    ObjectReader(const json &j, std::string path) : m_j(j), m_path(std::move(path)) {
        if (!j.is_object())
            throw ConfigError(path_or_root(), short_dump(j) + " is " + type_name(j) + "; expected an object");
    }
    std::string path_or_root() const { return m_path.empty() ? "/" : m_path; }
    std::string child(const std::string &key) const { return m_path + "/" + key; }
    bool has(const std::string &key) const {
        m_known.insert(key);
        return m_j.contains(key) && !m_j.at(key).is_null();
    }
    const json &get(const std::string &key) const {
        m_known.insert(key);
        if (!m_j.contains(key)) throw ConfigError(path_or_root(), "missing required key \"" + key + "\"");
        return m_j.at(key);
    }
    double number(const std::string &key, std::optional<double> fallback = std::nullopt) const {
        if (!has(key)) {
            if (fallback) return *fallback;
            get(key);
        }
        const json &v = m_j.at(key);
        if (!v.is_number())
            throw ConfigError(child(key), short_dump(v) + " is " + type_name(v) + "; expected a number");
        const double d = v.get<double>();
        if (!std::isfinite(d)) throw ConfigError(child(key), short_dump(v) + " is not finite");
        return d;
    }
    double positive(const std::string &key, std::optional<double> fallback = std::nullopt) const {
        const double d = number(key, fallback);
        if (!(d > 0)) throw ConfigError(child(key), short_dump(m_j.at(key)) + " must be greater than 0");
        return d;
    }
    std::optional<double> optional_number(const std::string &key) const {
        if (!has(key)) return std::nullopt;
        return number(key);
    }
    std::size_t count(const std::string &key, std::size_t fallback, std::size_t min_value,
                      std::size_t max_value = std::numeric_limits<std::size_t>::max()) const {
        if (!has(key)) return fallback;
        const json &v = m_j.at(key);
        const bool bounded = max_value != std::numeric_limits<std::size_t>::max();
        if (!v.is_number_integer() || v.get<long long>() < static_cast<long long>(min_value) ||
            (bounded && v.get<long long>() > static_cast<long long>(max_value)))
            throw ConfigError(child(key),
                              short_dump(v) + " must be an integer " +
                                  (bounded ? "from " + std::to_string(min_value) + " to " + std::to_string(max_value)
                                           : ">= " + std::to_string(min_value)));
        return v.get<std::size_t>();
    }
    std::string string(const std::string &key, std::optional<std::string> fallback,
                       const std::vector<std::string> &choices = {}) const {
        if (!has(key)) {
            if (fallback) return *fallback;
            get(key);
        }
        const json &v = m_j.at(key);
        if (!v.is_string())
            throw ConfigError(child(key), short_dump(v) + " is " + type_name(v) + "; expected a string");
        const std::string s = v.get<std::string>();
        if (!choices.empty() && std::find(choices.begin(), choices.end(), s) == choices.end()) {
            std::string msg = "\"" + s + "\" is not one of:";
            for (const auto &c : choices) msg += " \"" + c + "\"";
            const std::string hint = did_you_mean(s, choices);
            if (!hint.empty()) msg += "; did you mean \"" + hint + "\"?";
            throw ConfigError(child(key), msg);
        }
        return s;
    }
    bool boolean(const std::string &key, bool fallback) const {
        if (!has(key)) return fallback;
        const json &v = m_j.at(key);
        if (!v.is_boolean())
            throw ConfigError(child(key), short_dump(v) + " is " + type_name(v) + "; expected true or false");
        return v.get<bool>();
    }
    // [lo, hi] with lo < hi.
    std::pair<double, double> interval(const std::string &key) const {
        const json &v = get(key);
        if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number())
            throw ConfigError(child(key), short_dump(v) + " must be an array of two numbers [min, max]");
        const double lo = v[0].get<double>(), hi = v[1].get<double>();
        if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi))
            throw ConfigError(child(key), short_dump(v) + " must satisfy min < max (finite)");
        return {lo, hi};
    }
    // Every key not read is an error, with a hint.
    void finish() const {
        std::vector<std::string> known(m_known.begin(), m_known.end());
        for (const auto &item : m_j.items()) {
            if (m_known.count(item.key())) continue;
            std::string msg = "unknown key";
            const std::string hint = did_you_mean(item.key(), known);
            if (!hint.empty())
                msg += "; did you mean \"" + hint + "\"?";
            else {
                msg += " (allowed here:";
                for (const auto &k : known) msg += " " + k;
                msg += ")";
            }
            throw ConfigError(child(item.key()), msg);
        }
    }

  private:
    const json &m_j;
    std::string m_path;
    mutable std::set<std::string> m_known;
};

} // namespace geobarrier::detail

#endif // GEOBARRIER_SRC_JSON_READER_HPP
