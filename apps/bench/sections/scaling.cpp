// Section "scaling": the default from N = 200 to 2000. Reports microseconds per point (wall and flow-map stage) and
// the flow-map time per point against N = 1000's.
#include "../sections.hpp"

#include "../tables.hpp"

#include <algorithm>
#include <cmath>
#include <iostream>

namespace geobarrier::bench {

// Scaling in the number of grid points: the default from N = 200 to 2000, best of two runs each (five below
// N = 1000: a run of a few tens of milliseconds on a shared machine needs more tries to show its cost), with errors
// where an exact field is cached or cheap enough to compute. The interior max error is set by a handful of points on
// razor-thin FTLE ridges, so which grid lands on them is luck: N = 700 and 1400 are always checked besides the
// headline's N (their exact fields are computed once, then cached).
void scaling_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    for (std::size_t s : {200, 400, 700, 1000, 1400, 2000}) {
        const std::vector<double> e = s == o.n ? res.exact : bench.exact_w(s, !o.quick || s == 700 || s == 1400);
        Row r = bench.run("scaling", "W", workload_w(s), {"default", json::object(), 2}, e, nan_value,
                          o.best_of(s < 1000 ? 5 : 2));
        bench.add(r);
        res.scaling.push_back(r);
    }
}

void report_scaling(std::ostream &md, const std::vector<Row> &scaling_rows) {
    if (scaling_rows.empty()) return;
    md << "## Scaling in the number of grid points\n\nThe default on 2 threads (best of five runs below N = 1000, of "
          "two from there). Time per point should not depend on N (linear within 15%); the flow-map stage leaves "
          "out the process start-up and the output, which weigh on small grids. The errors at N = 700 and 1400 "
          "check that the default's accuracy is no accident of the headline grid: the interior max comes from "
          "one or two points on razor-thin FTLE ridges.\n\n"
          "| N | points | wall (s) | flow map (s) | µs per point (wall) | µs per point "
          "(flow map) | flow map per point / N = 1000's | peak RSS (MiB) | mean err | interior max |\n"
          "|---|---|---|---|---|---|---|---|---|---|\n";
    double reference = nan_value;
    for (const Row &r : scaling_rows)
        if (r.nx == 1000) reference = r.flow_map / 1e6;
    double lo = HUGE_VAL, hi = 0;
    for (const Row &r : scaling_rows) {
        const double points = static_cast<double>(r.nx * r.ny), per = r.flow_map / points;
        md << "| " << r.nx << " | " << r.nx * r.ny << " | " << fixed(r.wall, 2) << " | " << fixed(r.flow_map, 2)
           << " | " << fixed(1e6 * r.wall / points, 3) << " | " << fixed(1e6 * per, 3) << " | "
           << fixed(per / reference, 2) << " | " << fixed(r.peak_mib, 0) << " | " << sci(r.err.mean) << " | "
           << sci(r.err.interior_max) << " |\n";
        if (std::isfinite(per)) {
            lo = std::min(lo, per);
            hi = std::max(hi, per);
        }
    }
    md << "\nFlow-map time per point varies by " << fixed(100 * (hi / lo - 1), 0)
       << "% between the fastest and the slowest N.\n\n";
    std::cout << "scaling 200..2000: flow-map time per point varies by " << fixed(100 * (hi / lo - 1), 0) << "%\n";
}

} // namespace geobarrier::bench
