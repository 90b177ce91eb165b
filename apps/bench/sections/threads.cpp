// Section "threads": the default on 1 and 2 threads. Reports the speed-up of the whole process and of the flow-map
// stage (1-thread time / 2-thread time).
#include "../sections.hpp"

#include "../tables.hpp"

#include <iostream>

namespace geobarrier::bench {

// Threads: the default on 1 and 2 threads, best of two runs each (ratios between runs are the point).
void threads_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    for (int t : {1, 2}) {
        Row r = bench.run("threads", "W", workload_w(o.n), {"default", json::object(), t}, res.exact, res.base.wall,
                          o.best_of(2));
        r.name = "default, " + std::to_string(t) + (t == 1 ? " thread" : " threads");
        bench.add(r);
        res.threads.push_back(r);
    }
}

void report_threads(Bench &bench, const BenchOptions &o, const std::vector<Row> &thread_rows) {
    if (thread_rows.size() != 2) return;
    const double speedup = thread_rows[0].wall / thread_rows[1].wall;
    const double engine = thread_rows[0].flow_map / thread_rows[1].flow_map;
    bench.md << "## Threads\n\nThe default at N = " << o.n
             << " on 1 and 2 threads (best of two runs each): " << fixed(speedup, 2) << "× for the whole process, "
             << fixed(engine, 2) << "× for the flow-map stage (target ≥ 1.8×).\n\n";
    bench.table(thread_rows);
    std::cout << "threads: 2 vs 1 at N = " << o.n << ": " << fixed(speedup, 2) << "x (flow map " << fixed(engine, 2)
              << "x)\n";
}

} // namespace geobarrier::bench
