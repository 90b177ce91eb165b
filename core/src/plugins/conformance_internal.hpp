// The conformance checks' shared parts (private to core/src/plugins/conformance*.cpp): the checks' own random
// numbers, number formatting, the pass/fail/skip/warn outcomes, and the checks of each kind of plugin, which
// check_plugin (conformance.cpp) runs after the checks every plugin gets.
#ifndef GEOBARRIER_PLUGINS_CONFORMANCE_INTERNAL_HPP
#define GEOBARRIER_PLUGINS_CONFORMANCE_INTERNAL_HPP

#include <geobarrier/conformance.hpp>
#include <geobarrier/plugin.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

namespace geobarrier::detail::conformance {

// splitmix64: the checks draw the same states on every platform (std:: distributions are implementation-defined).
class Random {
  public:
    explicit Random(std::uint64_t seed) : m_state(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (m_state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    double uniform(double lo, double hi) { return lo + (hi - lo) * (static_cast<double>(next() >> 11) * 0x1.0p-53); }

  private:
    std::uint64_t m_state;
};

// Written into outputs before a call, to see which entries a plugin wrote.
inline constexpr double output_sentinel = -1.2345678901234567e301;
inline constexpr std::int32_t status_sentinel = 0x5A5A5A5A;

inline std::string num(double v) {
    std::ostringstream s;
    s.precision(17);
    s << v;
    return s.str();
}
inline std::string short_num(double v) {
    std::ostringstream s;
    s.precision(3);
    s << v;
    return s.str();
}

inline bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Equal, both NaN, or within rtol of the larger magnitude.
inline bool close(double a, double b, double rtol) {
    if (a == b || (std::isnan(a) && std::isnan(b))) return true;
    return std::fabs(a - b) <= rtol * std::max(std::fabs(a), std::fabs(b));
}

inline ConformanceCheck pass(const std::string &name, std::string detail) {
    return {name, true, std::move(detail), false};
}
inline ConformanceCheck fail(const std::string &name, std::string detail) {
    return {name, false, std::move(detail), false};
}
inline ConformanceCheck skip(const std::string &name, std::string detail) {
    return {name, true, std::move(detail), true};
}
inline ConformanceCheck warn(const std::string &name, std::string detail) {
    return {name, true, std::move(detail), false, true};
}

// Runs one check; an exception from the plugin (a failed call) is a failed check, not a crash of the checker.
inline ConformanceCheck guarded(const std::string &name, const std::function<ConformanceCheck()> &body) {
    try {
        return body();
    } catch (const std::exception &e) {
        return fail(name, e.what());
    }
}

// The box of states, one bound per component.
struct Box {
    std::vector<double> lo, hi;
};

// The options' box for a system of info's dimension, or its documented domain, or [-2, 2]; throws Error for a box
// of the wrong dimension, empty or not finite (conformance_systems.cpp).
Box make_box(const ConformanceOptions &given, const PluginInfo &info);

// The checks of one kind of plugin, appended to `out` (conformance_systems.cpp, conformance_forcings.cpp).
void check_system(const PluginHandle &handle, const ParamValues &values, const Box &box, const ConformanceOptions &o,
                  std::vector<ConformanceCheck> &out);
void check_forcing(const PluginHandle &handle, const ParamValues &values, const ConformanceOptions &o,
                   std::vector<ConformanceCheck> &out);
// An extractor on a synthetic flow with a known answer (conformance_extractors.cpp).
ConformanceCheck check_extractor_behaviour(const Extractor &extractor);

} // namespace geobarrier::detail::conformance

#endif // GEOBARRIER_PLUGINS_CONFORMANCE_INTERNAL_HPP
