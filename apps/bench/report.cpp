// The report: its opening (the run's conditions and the headline's verdicts), then every section that ran, in the
// order of docs/performance.md.
#include "process.hpp"
#include "sections.hpp"
#include "tables.hpp"

#include <unistd.h>

#include <cmath>
#include <iostream>

namespace geobarrier::bench {

// The report's opening: the run's conditions and the headline's verdicts (also on stdout).
void report_headline(std::ostream &md, const BenchOptions &o, const BenchResults &res, const std::string &load_before,
                     double bench_minutes) {
    const std::size_t n = o.n;
    md << "Workload W at N = " << n << " (" << n * n << " grid points), T = 8π";
    if (!o.machine.empty()) md << ", on " << o.machine;
    md << ". Load average " << load_before << " before the bench, " << load_average() << " after; the bench took "
       << fixed(bench_minutes, 1) << " min" << (o.quick ? " (--quick)" : "") << ".";
    if (std::stod(load_before) > static_cast<double>(::sysconf(_SC_NPROCESSORS_ONLN)))
        md << " **The machine was busy** (load above its core count): times are inflated and thread ratios "
              "understated; the ratios between rows of one table are what to compare.";
    md << "\n\n";
    const std::optional<Row> &memory_row = res.memory;
    if (res.default_row) {
        const Row &d = *res.default_row;
        const bool fast = d.ratio >= 30, accurate = d.err.mean <= 1e-4 && d.err.interior_max <= 0.05;
        md << "**Headline.** The default (no `integrator`, no `cauchy_green` keys) at N = " << n << ": "
           << fixed(d.wall, 2) << " s for the whole process, " << fixed(d.ratio, 1)
           << "× faster than the naive Boost.Odeint baseline (" << fixed(res.base.wall, 2)
           << " s, same run; target ≥ 30×: " << (fast ? "met" : "NOT met") << "); FTLE error mean " << sci(d.err.mean)
           << ", interior max " << sci(d.err.interior_max)
           << " (targets ≤ 1e-4 and ≤ 0.05: " << (accurate ? "met" : "NOT met") << ").";
        if (res.unchecked_row)
            md << " The step check (the default's error control) costs "
               << fixed(100.0 * (d.wall / res.unchecked_row->wall - 1.0), 1) << "% against the same steps unchecked (`"
               << unchecked_config << "`, " << fixed(res.unchecked_row->wall, 2) << " s; fastest of 3 runs each).";
        if (memory_row)
            md << " The " << o.memory_n << " × " << o.memory_n << " grid: peak resident memory "
               << fixed(memory_row->peak_mib, 0) << " MiB (target < 2048 MiB: "
               << (std::isfinite(memory_row->peak_mib) && memory_row->peak_mib < 2048 ? "met" : "NOT met") << "), "
               << fixed(memory_row->wall, 1) << " s.";
        md << "\n\n";
        std::cout << "default at N = " << n << ": " << fixed(d.wall, 2) << " s, " << fixed(d.ratio, 1)
                  << "x the baseline (" << fixed(res.base.wall, 2) << " s), FTLE error mean " << sci(d.err.mean)
                  << ", interior max " << sci(d.err.interior_max) << "\n";
    }
    if (memory_row)
        std::cout << o.memory_n << " x " << o.memory_n << " grid: peak " << fixed(memory_row->peak_mib, 0) << " MiB, "
                  << fixed(memory_row->wall, 1) << " s" << (memory_row->note.empty() ? "" : " " + memory_row->note)
                  << "\n";
}

// The report after the headline: every section that ran, in the order of docs/performance.md.
void report_sections(Bench &bench, const BenchOptions &o, const BenchResults &res) {
    std::ostream &md = bench.md;
    report_trade(bench, o, res);
    report_sweep(bench, res);
    report_scipy(bench, o, res);
    report_threads(bench, o, res.threads);
    report_widths(md, o.n, res.widths);
    if (!res.suite_md.empty()) md << res.suite_md;
    if (!res.ndim_md.empty()) md << res.ndim_md;
    report_scaling(md, res.scaling);
    report_memory(bench, o, res);
    report_extraction(md, o.extraction_n, res.extraction);
    if (!res.frames_md.empty()) md << res.frames_md;
    report_gyre(bench, o, res);
    if (!res.equations_md.empty()) md << res.equations_md;
}

} // namespace geobarrier::bench
