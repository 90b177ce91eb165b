// The bench's workloads (W, the paper's first example, and the double gyre) and its configurations: JSON patches merged
// into a workload (RFC 7386), the headline's and the full sweep's.
#pragma once

#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>
#include <vector>

namespace geobarrier::bench {

using nlohmann::json;

inline constexpr double two_pi = 6.283185307179586;
inline constexpr double horizon = 4 * two_pi; // T = 8 pi

// Workload W (apps/bench/baselines/README.md): the reference and the baselines integrate exactly this.
json workload_w(std::size_t n);
// The double gyre of experiments/double-gyre.json (Shadden, Lekien & Marsden 2005) on an n x n/2 grid.
json workload_gyre(std::size_t n);

struct Config {
    std::string name;
    json settings = json::object(); // merged into the workload (RFC 7386: integrator, cauchy_green, quality, grid...)
    int threads = 2;
};

json integrator(const std::string &method, double rtol, double atol);
// `a` with `b` merged into it (RFC 7386).
json with(json a, const json &b);
inline const json variational = {{"cauchy_green", {{"method", "variational"}}}};
json aux(double offset);

inline constexpr const char *unchecked_config = "default, unchecked steps";

// The headline configurations: the defaults, the presets, and the paper's settings.
std::vector<Config> headline_configs();
// The full sweep: tolerance x stepper x gradient method, aux offsets, fixed-step rk4, block sizes.
std::vector<Config> sweep_configs();

} // namespace geobarrier::bench
