// Section "headline" (always run: the sections of W take its baseline and exact field): W at N, the naive Boost.Odeint
// baseline beside the defaults, the quality presets, the paper's settings and any --try patch. Reports the trade
// table: wall, flow-map stage, × baseline (baseline wall / this wall), errors against the exact field.
#include "../sections.hpp"

#include "../tables.hpp"

#include <iostream>
#include <stdexcept>

namespace geobarrier::bench {

// Headline: W at N, the baseline and the defaults, presets and paper settings, side by side; and the --try patches.
void headline_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    res.exact = bench.exact_w(o.n, true);
    res.base = bench.baseline("headline", o.n, res.exact);
    bench.add(res.base);
    res.headline = {res.base};
    if (o.wants("headline")) {
        for (const Config &c : headline_configs()) {
            // The default and its unchecked twin are compared with each other (the step check's cost, a few
            // percent): the fastest of 3 runs each, where one run's noise would swamp the difference.
            const bool pair = c.name == "default" || c.name == unchecked_config;
            Row r = bench.run("headline", "W", workload_w(o.n), c, res.exact, res.base.wall, o.best_of(pair ? 3 : 1));
            bench.add(r);
            res.headline.push_back(r);
            if (c.name == "default") res.default_row = r;
            if (c.name == unchecked_config) res.unchecked_row = r;
        }
    }
    for (const std::string &t : o.tries) {
        const std::size_t eq = t.find('=');
        if (eq == std::string::npos || eq == 0) throw std::runtime_error("--try " + t + ": expected NAME=JSON");
        json patch;
        try {
            patch = json::parse(t.substr(eq + 1));
        } catch (const json::parse_error &e) {
            throw std::runtime_error("--try " + t.substr(0, eq) + ": the patch is not JSON (" + e.what() + ")");
        }
        Row r = bench.run("headline", "W", workload_w(o.n), {t.substr(0, eq), patch, 2}, res.exact, res.base.wall,
                          o.best_of(1));
        bench.add(r);
        res.headline.push_back(r);
    }
}

// The trade at N: the headline rows.
void report_trade(Bench &bench, const BenchOptions &o, const BenchResults &res) {
    std::ostream &md = bench.md;
    md << "## The trade at N = " << o.n
       << "\n\nWall time of the whole process (start-up, plugin loading and NetCDF output included); flow map = "
          "the manifest's flow-map stage (trajectories, gradient and Cauchy–Green fields); × baseline = baseline "
          "wall time / this wall time. Errors against the exact field (rkf78 1e-12, variational); interior leaves "
          "out 2% of the box on each side.\n\n";
    md << "![FTLE error against wall time, log-log](images/performance-pareto.png)\n\n";
    bench.table(res.headline);
}

} // namespace geobarrier::bench
