// Conformance checks every plugin must pass: ABI version, a well-formed schema, batch evaluation equal to
// one-lane evaluation, analytic Jacobian against finite differences, divergence against the Jacobian's trace,
// determinism and finite values on a sample box. One source of truth for `geobarrier check-plugin` and for the
// plugins' own unit tests.
#ifndef GEOBARRIER_CONFORMANCE_HPP
#define GEOBARRIER_CONFORMANCE_HPP

#include <geobarrier/plugin.hpp>

#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace geobarrier {

// The outcome of one check. A skipped check (e.g. the Jacobian check for a system without a Jacobian) counts as
// passed; `detail` says why it was skipped, or what failed, with the offending values. A passed check with a
// warning (WARN) works but not as well as it could, e.g. a plugin compiled for a lesser CPU than the core.
struct ConformanceCheck {
    std::string name;
    bool passed = false;
    std::string detail;
    bool skipped = false;
    bool warning = false;
};

struct ConformanceOptions {
    // Plugin parameters as in an experiment's "params"; parameters left out take their defaults.
    nlohmann::json params = nlohmann::json::object();
    // Box of states for systems: one bound per state component, or a single bound for all of them. Left empty,
    // the system's documented domain (PluginInfo::domain_min/max), or [-2, 2] when it declares none.
    std::vector<double> state_min;
    std::vector<double> state_max;
    // Times for systems and forcings are drawn from [t_min, t_max].
    double t_min = -10.0;
    double t_max = 10.0;
    // Batch layout of the batch-versus-one-lane check: n lanes in rows of ld (ld > n tests the stride).
    std::size_t lanes = 37;
    std::size_t ld = 40;
    // States (systems) or times (forcings) of the finite-values sweep, on top of the box's corners and centre.
    std::size_t samples = 1000;
    // Seed of the checks' own random numbers (a fixed generator: the same draws on every platform).
    std::uint64_t seed = 20130416;
    // Batch and one-lane results agree bit for bit or to this relative difference.
    double batch_rtol = 1e-15;
    // Finite-difference step, relative to the box's width in each component, and the Jacobian's allowed
    // difference relative to the largest Jacobian entry of the lane. Centred differences err by O(h^2) from
    // truncation and O(eps |v| / h) from rounding: about 1e-10 relative at these defaults.
    double fd_step = 1e-6;
    double jacobian_rtol = 1e-6;
    // |divergence - trace J| <= divergence_rtol * sum_i |J_ii| (so exact zeros must match exactly).
    double divergence_rtol = 1e-12;
};

// Runs every check that applies to the plugin's kind, in a fixed order. Never throws for a misbehaving plugin:
// its failures are failed checks. Throws Error for unusable options (e.g. a box of the wrong dimension).
std::vector<ConformanceCheck> check_plugin(const PluginHandle &handle, const ConformanceOptions &options = {});

// "10 passed, 1 skipped, 0 failed" (and ", 1 warning" when a passed check warns): each check counted once.
std::string count_checks(const std::vector<ConformanceCheck> &checks);

// True when every check passed (skipped ones included).
bool all_passed(const std::vector<ConformanceCheck> &checks);

// A pass/fail table, one line per check: "PASS  name  detail" (PASS, WARN, SKIP or FAIL).
std::string format_checks(const std::vector<ConformanceCheck> &checks);

} // namespace geobarrier

#endif // GEOBARRIER_CONFORMANCE_HPP
