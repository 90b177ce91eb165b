// Section "sweep" (full mode): W at N over tolerance × stepper × gradient method, auxiliary-grid offsets, fixed rk4
// steps and block sizes. Reports its rows under the trade table, × baseline as there.
#include "../sections.hpp"

namespace geobarrier::bench {

void sweep_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    for (const Config &c : sweep_configs()) {
        Row r = bench.run("sweep", "W", workload_w(o.n), c, res.exact, res.base.wall, o.best_of(1));
        bench.add(r);
        res.sweep.push_back(r);
    }
}

// The sweep's table, under the trade at N.
void report_sweep(Bench &bench, const BenchResults &res) {
    std::ostream &md = bench.md;
    if (!res.sweep.empty()) {
        md << "### The sweep: tolerance, stepper, gradient method, offset, fixed steps, block size\n\n";
        bench.table(res.sweep);
    }
}

} // namespace geobarrier::bench
