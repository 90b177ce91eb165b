// Section "ndim": W's grid on a four-component system's slice beside planar W. Reports core-microseconds per
// trajectory and the ratio to planar W.
#include "../sections.hpp"

#include "../tables.hpp"

#include <cmath>
#include <iostream>
#include <sstream>

namespace geobarrier::bench {

// Systems of more than two state components: W's grid, horizon and forcing with the four-component coupled Duffing
// system (systems/coupled-duffing, k = 0.1) on its (x1, v1) slice, the other oscillator at rest at the origin, beside
// planar W, both with the defaults (the standard preset: checked fixed dop853 steps, fused) and the whole n x n
// Cauchy-Green tensor; per trajectory from the flow-map stage's time. Rows go to bench.csv (section "ndim").
std::string ndim_section(Bench &bench, std::size_t n, int repeat) {
    json slice = workload_w(n);
    slice["description"] = "workload W's grid on the (x1, v1) slice of coupled-duffing";
    slice["system"] = {{"plugin", "coupled-duffing"}, {"params", {{"k", 0.1}}}};
    slice["grid"] = {{"axes", {"x1", "v1"}},
                     {"x1", {-1.8, 1.8}},
                     {"v1", {-1.2, 1.2}},
                     {"n", {n, n}},
                     {"fixed", {{"x2", 0}, {"v2", 0}}}};
    std::vector<Row> rows;
    for (const auto &[workload, experiment] :
         {std::pair<std::string, json>{"W (planar duffing, 2 components)", workload_w(n)},
          std::pair<std::string, json>{"coupled-duffing slice (4 components)", slice}}) {
        Row r = bench.run("ndim", workload, experiment, {"default", json::object(), 2}, {}, nan_value, repeat);
        bench.add(r);
        rows.push_back(r);
    }
    std::ostringstream md;
    md << "## Systems of more than two components\n\nW's grid (N = " << n
       << "), horizon and forcing with the four-component `coupled-duffing` system (k = 0.1) on its (x1, v1) slice "
          "(x2 = v2 = 0), beside planar W, both with the defaults (checked fixed dop853 steps, the SDK's fused step, "
          "the whole Cauchy–Green tensor), 2 threads, best of "
       << repeat
       << ". The variational equations carry 4 + 16 + 1 components per trajectory against 2 + 4 + 1.\n\n"
          "| system | wall (s) | flow map (s) | core-µs per trajectory | steps per trajectory | × planar |\n"
          "|---|---|---|---|---|---|\n";
    const double trajectories = static_cast<double>(n) * static_cast<double>(n);
    for (const Row &r : rows) {
        const double per = 1e6 * r.flow_map * r.threads / trajectories;
        const double planar = 1e6 * rows[0].flow_map * rows[0].threads / trajectories;
        md << "| " << r.workload << " | " << fixed(r.wall, 2) << " | " << fixed(r.flow_map, 2) << " | " << fixed(per, 1)
           << " | " << fixed(r.steps / std::ceil(trajectories / 64.0), 0) << " | " << fixed(per / planar, 2) << " |\n";
        std::cout << "ndim: " << r.workload << ": " << fixed(per, 1) << " core-us per trajectory\n";
    }
    md << "\n";
    return md.str();
}

} // namespace geobarrier::bench
