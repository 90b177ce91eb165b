// The bench's command line: which sections run, on which grids, how many runs each.
#pragma once

#include <cstddef>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace geobarrier::bench {

// The command line of the bench.
struct BenchOptions {
    std::size_t n = 1000, memory_n = 4000, scipy_n = 0, extraction_n = 1000, suite_n = 0;
    std::string out_dir = "out/bench", peers_dir, peers_source, program, machine, source = ".", program_avx2;
    std::set<std::string> sections;
    std::vector<std::string> tries;
    bool quick = false;
    int repeat = 0;

    bool wants(const char *section) const { return sections.count(section) > 0; }
    // Runs per configuration, the fastest kept: --repeat, else `fallback`.
    int best_of(int fallback) const { return repeat > 0 ? repeat : fallback; }
};

// Parses the command line into `o`; returns the exit code when the program should stop (--help, a bad option).
std::optional<int> parse_options(int argc, char **argv, BenchOptions &o);

} // namespace geobarrier::bench
