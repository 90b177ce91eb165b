// Section "memory": W on a large grid with the defaults. Reports the peak resident memory (GNU time).
#include "../sections.hpp"

namespace geobarrier::bench {

// Memory: a large grid of W (FTLE only, no picture) with the defaults.
void memory_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    res.memory = bench.run("memory", "W", workload_w(o.memory_n), {"default", json::object(), 2}, {});
    bench.add(*res.memory);
}

void report_memory(Bench &bench, const BenchOptions &o, const BenchResults &res) {
    if (!res.memory) return;
    bench.md << "## Memory\n\nW on a " << o.memory_n << " × " << o.memory_n
             << " grid (FTLE only, no picture), the defaults, 2 threads; flow map and Cauchy–Green fields computed "
                "in tiles of grid rows, only the FTLE kept for the whole grid. Peak resident memory by GNU time.\n\n";
    bench.table({*res.memory});
}

} // namespace geobarrier::bench
