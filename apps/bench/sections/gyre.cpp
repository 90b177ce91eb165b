// Section "gyre" (full mode): the double gyre's default and paper-like settings against its exact field.
#include "../sections.hpp"

namespace geobarrier::bench {

// The double gyre: the default and the paper-like settings against its exact field.
void gyre_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    const std::vector<double> exact_g = bench.exact_gyre(o.n);
    for (const Config &c : std::vector<Config>{
             {"default", json::object(), 2},
             {"quality draft", {{"quality", "draft"}}, 2},
             {"dopri5 1e-6/1e-4, aux 1e-4", with(integrator("dopri5", 1e-6, 1e-4), aux(1e-4)), 2},
             {"dopri5 1e-6/1e-4, variational", with(integrator("dopri5", 1e-6, 1e-4), variational), 2},
             {"dopri5 1e-8/1e-10, variational", with(integrator("dopri5", 1e-8, 1e-10), variational), 2}}) {
        Row r = bench.run("gyre", "double gyre", workload_gyre(o.n), c, exact_g, nan_value, o.best_of(1));
        bench.add(r);
        res.gyre.push_back(r);
    }
}

void report_gyre(Bench &bench, const BenchOptions &o, const BenchResults &res) {
    if (res.gyre.empty()) return;
    std::ostream &md = bench.md;
    md << "## The double gyre\n\n`experiments/double-gyre.json` (A = 0.1, ε = 0.25, ω = 2π/10, T = 15) on an " << o.n
       << " × " << o.n / 2
       << " grid, against its exact field (geobarrier, rkf78 at 1e-12 on the variational equations).\n\n";
    bench.table(res.gyre);
}

} // namespace geobarrier::bench
