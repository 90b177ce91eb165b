// The sections of the bench (sections/*.cpp): each runs its configurations through the harness and reports its own
// table and ratios; report.cpp puts the reports together in the order of docs/performance.md.
#pragma once

#include "harness.hpp"
#include "options.hpp"

#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace geobarrier::bench {

// The rows of every section, for the report.
struct BenchResults {
    std::vector<double> exact; // W's exact FTLE at N
    Row base;                  // the naive Boost.Odeint baseline at N
    std::vector<Row> headline, scipy, threads, widths, scaling, extraction, sweep, gyre;
    std::optional<Row> default_row, unchecked_row, memory;
    std::string suite_md, ndim_md, frames_md, equations_md;
};

// Headline (sections/headline.cpp): W at N, the baseline and the defaults, presets and paper settings, side by side;
// and the --try patches. Always runs: the other sections of W compare against its baseline and exact field.
void headline_section(Bench &bench, const BenchOptions &o, BenchResults &res);
void report_trade(Bench &bench, const BenchOptions &o, const BenchResults &res);
// The full sweep (sections/sweep.cpp): tolerance, stepper, gradient method, offset, rk4 steps, block size.
void sweep_section(Bench &bench, const BenchOptions &o, BenchResults &res);
void report_sweep(Bench &bench, const BenchResults &res);
// SciPy (sections/scipy.cpp), when installed, with the baseline and the default at the same grid.
void scipy_section(Bench &bench, const BenchOptions &o, BenchResults &res);
void report_scipy(Bench &bench, const BenchOptions &o, const BenchResults &res);
// Threads (sections/threads.cpp): the default on 1 and 2 threads.
void threads_section(Bench &bench, const BenchOptions &o, BenchResults &res);
void report_threads(Bench &bench, const BenchOptions &o, const std::vector<Row> &thread_rows);
// Vector widths (sections/widths.cpp): the native build against an AVX2-only build, and the machine's limit.
void widths_section(Bench &bench, const BenchOptions &o, BenchResults &res);
void report_widths(std::ostream &md, std::size_t n, const std::vector<Row> &width_rows);
// Scaling in the number of grid points (sections/scaling.cpp).
void scaling_section(Bench &bench, const BenchOptions &o, BenchResults &res);
void report_scaling(std::ostream &md, const std::vector<Row> &scaling_rows);
// Memory on a large grid (sections/memory.cpp).
void memory_section(Bench &bench, const BenchOptions &o, BenchResults &res);
void report_memory(Bench &bench, const BenchOptions &o, const BenchResults &res);
// Extraction costs (sections/extraction.cpp): the extractors' stages against the same run's flow map.
void extraction_section(Bench &bench, const BenchOptions &o, BenchResults &res);
void report_extraction(std::ostream &md, std::size_t extraction_n, const std::vector<Row> &extraction_rows);
// The double gyre (sections/gyre.cpp) against its exact field.
void gyre_section(Bench &bench, const BenchOptions &o, BenchResults &res);
void report_gyre(Bench &bench, const BenchOptions &o, const BenchResults &res);

// The sections that need no baseline and return their markdown: the accuracy suite (sections/suite.cpp), systems of
// more than two components (sections/ndim.cpp), frames against separate runs (sections/frames.cpp) and the
// equations system against the built-in plugin (sections/equations.cpp).
std::string suite_section(Bench &bench, std::size_t n);
std::string ndim_section(Bench &bench, std::size_t n, int repeat);
std::string frames_section(Bench &bench, int repeat);
std::string equations_section(const Bench &bench, std::size_t n, int repeat);

// The report (report.cpp): the opening (conditions and verdicts), then every section that ran.
void report_headline(std::ostream &md, const BenchOptions &o, const BenchResults &res, const std::string &load_before,
                     double bench_minutes);
void report_sections(Bench &bench, const BenchOptions &o, const BenchResults &res);
// The Pareto picture (pareto.cpp): W's FTLE error against wall time at N, its fronts and the targets.
void pareto_picture(const fs::path &file, const std::vector<Row> &rows, std::size_t n);

} // namespace geobarrier::bench
