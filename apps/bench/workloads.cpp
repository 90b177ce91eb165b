#include "workloads.hpp"

namespace geobarrier::bench {

json workload_w(std::size_t n) {
    return {{"description", "workload W (apps/bench/baselines/README.md)"},
            {"system", {{"plugin", "duffing"}}},
            {"forcing", {{"plugin", "cosine"}, {"params", {{"amplitude", 0.08}}}}},
            {"grid", {{"x", {-1.8, 1.8}}, {"y", {-1.2, 1.2}}, {"n", {n, n}}}},
            {"time", {{"t0", 0}, {"t1", horizon}}},
            {"products", {"ftle"}},
            {"output", {{"plots", false}}}};
}

json workload_gyre(std::size_t n) {
    return {{"description", "double gyre (experiments/double-gyre.json)"},
            {"system", {{"plugin", "double-gyre"}}},
            {"grid", {{"x", {0, 2}}, {"y", {0, 1}}, {"n", {n, n / 2}}}},
            {"time", {{"t0", 0}, {"t1", 15}}},
            {"products", {"ftle"}},
            {"output", {{"plots", false}}}};
}

json integrator(const std::string &method, double rtol, double atol) {
    return {{"integrator", {{"method", method}, {"rtol", rtol}, {"atol", atol}}}};
}
json with(json a, const json &b) {
    a.merge_patch(b);
    return a;
}
json aux(double offset) { return {{"cauchy_green", {{"method", "auxiliary-grid"}, {"offset", offset}}}}; }

std::vector<Config> headline_configs() {
    return {
        {"default", json::object(), 2},
        {"quality draft", {{"quality", "draft"}}, 2},
        {"quality standard", {{"quality", "standard"}}, 2},
        {"quality publication", {{"quality", "publication"}}, 2},
        {"default, adaptive steps", {{"integrator", {{"adaptive", true}}}}, 2},
        // What the step check costs where every step passes (W): the default with the check off.
        {unchecked_config, {{"integrator", {{"step_tolerance", 0}}}}, 2},
        {"paper tolerances, aux 1e-4", with(integrator("dopri5", 1e-6, 1e-4), aux(1e-4)), 2},
        {"paper tolerances, variational", with(integrator("dopri5", 1e-6, 1e-4), variational), 2},
    };
}

std::vector<Config> sweep_configs() {
    std::vector<Config> configs;
    for (double tol : {1e-4, 1e-6, 1e-8, 1e-10}) {
        const std::string t = json(tol).dump();
        for (const char *method : {"dopri5", "rkf78"}) {
            configs.push_back({std::string(method) + " tol " + t + ", variational",
                               with(integrator(method, tol, tol), variational), 2});
            configs.push_back(
                {std::string(method) + " tol " + t + ", aux 1e-3", with(integrator(method, tol, tol), aux(1e-3)), 2});
        }
    }
    for (double offset : {1e-5, 1e-4, 1e-2, 1e-1})
        configs.push_back(
            {"dopri5 tol 1e-8, aux " + json(offset).dump(), with(integrator("dopri5", 1e-8, 1e-8), aux(offset)), 2});
    for (int steps : {200, 400, 800, 1600})
        configs.push_back({"rk4 " + std::to_string(steps) + " steps, variational",
                           with({{"integrator", {{"method", "rk4"}, {"step", horizon / steps}}}}, variational), 2});
    for (int batch : {1, 8, 16, 32, 64, 128, 256})
        configs.push_back({"default, batch " + std::to_string(batch), {{"integrator", {{"batch", batch}}}}, 2});
    return configs;
}

} // namespace geobarrier::bench
