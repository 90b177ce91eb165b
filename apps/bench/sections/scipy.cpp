// Section "scipy": SciPy's solve_ivp (RK45 at the paper's tolerances) beside the Boost.Odeint baseline and the default
// on one grid in the same run. Reports × baseline for all three.
#include "../sections.hpp"

#include <iostream>

namespace geobarrier::bench {

// SciPy, when installed, with the baseline and the default at the same grid.
void scipy_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    const std::size_t n = o.scipy_n;
    const std::vector<double> exact_s = n == o.n ? res.exact : bench.exact_w(n, true);
    std::optional<Row> s = bench.scipy("scipy", n, exact_s);
    if (!s) {
        std::cerr << "SciPy is not installed (python3-scipy): no SciPy baseline\n";
        return;
    }
    Row b = n == o.n ? res.base : bench.baseline("scipy", n, exact_s);
    Row d = n == o.n && res.default_row
                ? *res.default_row
                : bench.run("scipy", "W", workload_w(n), {"default", json::object(), 2}, exact_s, b.wall);
    s->ratio = b.wall / s->wall;
    for (Row *r : {&b, &d, &*s}) {
        r->section = "scipy";
        bench.add(*r);
        res.scipy.push_back(*r);
    }
    if (n == o.n) res.headline.push_back(*s);
}

void report_scipy(Bench &bench, const BenchOptions &o, const BenchResults &res) {
    std::ostream &md = bench.md;
    if (!res.scipy.empty()) {
        md << "## SciPy at N = " << o.scipy_n
           << "\n\nSciPy's `solve_ivp` (RK45 at the paper's tolerances, one stacked "
              "solve over all auxiliary trajectories, one thread), the Boost.Odeint "
              "baseline and the default on the same grid in the same run.\n\n";
        bench.table(res.scipy);
    }
}

} // namespace geobarrier::bench
