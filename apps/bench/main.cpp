// geobarrier-bench: the speed/accuracy trade of the flow-map engine on workload W (the paper's first example,
// apps/bench/baselines/README.md) and on the double gyre, measured as whole processes side by side with the naive
// Boost.Odeint baseline (and SciPy when it is installed), against exact fields. Sections: the headline
// configurations, threads, scaling in the number of grid points, memory on a large grid, the extraction stages, and
// (full mode) the sweep over tolerance, stepper, gradient method, offset, block size and the double gyre. Writes
// bench.csv, bench.md and the Pareto picture (error against time); timings live here, never in tests.
//
// The harness (harness.hpp: a run as a whole process, best of repeats, its stages and errors; peers.cpp: the exact
// reference and the baselines; process.hpp: launching and timing; repeat.hpp: the least and the median of repeated,
// interleaved runs), the sections (sections/*.cpp: what each runs and which ratios it reports) and the report
// (report.cpp, tables.cpp, pareto.cpp). test_bench_harness checks the arithmetic on known answers.
#include "process.hpp"
#include "sections.hpp"

#include <chrono>
#include <iostream>

using namespace geobarrier::bench;

namespace {

// Opens the output folder and bench.csv with its header, and names the programs and folders the runs use.
void open_bench(Bench &bench, const BenchOptions &o) {
    bench.open(fs::absolute(o.out_dir));
    bench.peers = fs::absolute(o.peers_dir);
    bench.program = fs::absolute(o.program);
    bench.source = fs::absolute(o.source);
    bench.set_peers_source(o.peers_source.empty() ? bench.source / "apps" / "bench" / "baselines"
                                                  : fs::path(o.peers_source));
}

} // namespace

int main(int argc, char **argv) {
    BenchOptions o;
    if (const std::optional<int> code = parse_options(argc, argv, o)) return *code;
    Bench bench;
    open_bench(bench, o);
    const std::string load_before = load_average();
    const auto bench_start = std::chrono::steady_clock::now();
    BenchResults res;

    // The equations system against the built-in plugin; alone, it needs neither the reference nor the baseline.
    if (o.wants("equations")) {
        res.equations_md = equations_section(bench, o.n, o.best_of(2));
        if (o.sections.size() == 1) {
            bench.md << res.equations_md;
            std::ofstream(bench.out / "bench.md") << bench.md.str();
            std::cerr << "wrote " << (bench.out / "bench.md").string() << "\n";
            return 0;
        }
    }
    // The accuracy suite alone (--sections suite) needs no baseline and no peers' reference.
    if (o.wants("suite")) res.suite_md = suite_section(bench, o.suite_n > 0 ? o.suite_n : 101);
    if (o.sections == std::set<std::string>{"suite"}) {
        std::ofstream(bench.out / "bench.md") << res.suite_md;
        std::cerr << "wrote " << (bench.out / "bench.csv").string() << " and bench.md\n";
        return 0;
    }

    // Systems of more than two components (section "ndim"); alone, it needs no baseline either.
    if (o.wants("ndim")) res.ndim_md = ndim_section(bench, std::min<std::size_t>(o.n, 300), o.best_of(2));
    if (o.sections == std::set<std::string>{"ndim"}) {
        std::ofstream(bench.out / "bench.md") << res.ndim_md;
        std::cerr << "wrote " << (bench.out / "bench.csv").string() << " and bench.md\n";
        return 0;
    }

    // Frames against separate runs (section "frames"); alone, it needs no baseline either.
    if (o.wants("frames")) res.frames_md = frames_section(bench, o.best_of(o.quick ? 1 : 2));
    if (o.sections == std::set<std::string>{"frames"}) {
        std::ofstream(bench.out / "bench.md") << res.frames_md;
        std::cerr << "wrote " << (bench.out / "bench.csv").string() << " and bench.md\n";
        return 0;
    }

    headline_section(bench, o, res);
    if (o.wants("scipy")) scipy_section(bench, o, res);
    if (o.wants("threads")) threads_section(bench, o, res);
    if (o.wants("widths") && !o.program_avx2.empty()) widths_section(bench, o, res);
    if (o.wants("scaling")) scaling_section(bench, o, res);
    if (o.wants("memory")) memory_section(bench, o, res);
    if (o.wants("extraction")) extraction_section(bench, o, res);
    if (o.wants("sweep")) sweep_section(bench, o, res);
    if (o.wants("gyre")) gyre_section(bench, o, res);
    const double bench_minutes =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - bench_start).count() / 60;

    report_headline(bench.md, o, res, load_before, bench_minutes);
    report_sections(bench, o, res);
    const fs::path picture = bench.out / "pareto.png";
    try {
        pareto_picture(picture, bench.rows, o.n);
    } catch (const std::exception &e) {
        std::cerr << "no Pareto picture: " << e.what() << "\n";
    }
    std::ofstream(bench.out / "bench.md") << bench.md.str();
    std::cerr << "wrote " << (bench.out / "bench.csv").string() << ", bench.md and pareto.png\n";
    return 0;
}
