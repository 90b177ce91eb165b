#include "options.hpp"

#include <CLI/CLI.hpp>

#include <sstream>

namespace geobarrier::bench {

std::optional<int> parse_options(int argc, char **argv, BenchOptions &o) {
    CLI::App app{"geobarrier-bench: speed and accuracy of the flow-map engine on workload W"};
    std::string sections_text;
    app.add_option("--n", o.n, "grid points per direction of the headline runs")->check(CLI::Range(10, 20000));
    app.add_option("--out", o.out_dir,
                   "folder for bench.csv, bench.md, pareto.png, the cached exact fields and scratch");
    app.add_option("--peers", o.peers_dir, "folder with the built peers (reference, odeint_baseline)")->required();
    app.add_option("--peers-source", o.peers_source, "folder with the baselines' sources (scipy_baseline.py)");
    app.add_option("--program", o.program, "the geobarrier program")->required();
    app.add_option("--source", o.source, "the source tree (experiments/ for the extraction section)");
    app.add_option("--machine", o.machine, "one line describing the machine, for the report");
    app.add_option("--memory-n", o.memory_n, "grid points per direction of the memory run");
    app.add_option("--scipy-n", o.scipy_n, "grid of the SciPy comparison (default: --n; 300 with --quick)");
    app.add_option("--extraction-n", o.extraction_n, "grid points per direction of the extraction runs");
    app.add_option("--sections", sections_text,
                   "comma-separated: headline,threads,widths,scaling,memory,extraction,scipy,equations,suite,ndim,"
                   "frames,sweep,gyre (default: all but sweep and gyre with --quick, all without); suite, ndim, "
                   "frames or equations alone need no baseline");
    app.add_option("--repeat", o.repeat,
                   "runs per configuration, the fastest kept (default: 2 for threads and scaling, 1 elsewhere)");
    app.add_option("--try", o.tries,
                   "NAME=JSON: also run W with this patch merged into the experiment (RFC 7386, e.g. "
                   "'step 0.4={\"integrator\":{\"step\":0.4}}'), next to the headline; repeatable");
    app.add_option("--suite-n", o.suite_n, "grid points per direction of the accuracy suite (default 101)");
    app.add_option("--program-avx2", o.program_avx2,
                   "the geobarrier program of an AVX2-only build (-march=x86-64-v3) of the same source: section "
                   "'widths' times W's default with it beside the native build, and 'extraction' W's hyperbolic "
                   "extractor");
    app.add_flag("--quick", o.quick, "the short run for the docs (a few minutes): no sweep, no double gyre");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError &e) {
        return app.exit(e);
    }
    const std::string text =
        sections_text.empty()
            ? std::string(o.quick ? "headline,threads,widths,scaling,memory,extraction,scipy,equations,suite,ndim,"
                                    "frames"
                                  : "headline,threads,widths,scaling,memory,extraction,scipy,equations,suite,ndim,"
                                    "frames,sweep,gyre")
            : sections_text;
    std::istringstream in(text);
    for (std::string section; std::getline(in, section, ',');) o.sections.insert(section);
    if (o.scipy_n == 0) o.scipy_n = o.quick ? 300 : o.n;
    return std::nullopt;
}

} // namespace geobarrier::bench
