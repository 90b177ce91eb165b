// The Pareto picture: W's FTLE error against the whole process's wall time, through the core's plot layer.
#include "sections.hpp"

#include <geobarrier/output.hpp>

#include <algorithm>
#include <cmath>

namespace geobarrier::bench {

namespace {

// The Pareto front (fastest for its error) of (time, error) points: sorted by time, error strictly decreasing.
std::vector<double> pareto_front(std::vector<std::pair<double, double>> points) {
    std::sort(points.begin(), points.end());
    std::vector<double> xy;
    double best = HUGE_VAL;
    for (const auto &[t, e] : points)
        if (e < best) {
            best = e;
            xy.push_back(t);
            xy.push_back(e);
        }
    return xy;
}

} // namespace

void pareto_picture(const fs::path &file, const std::vector<Row> &rows, std::size_t n) {
    geobarrier::XYPlot plot;
    plot.title = "Workload W, N = " + std::to_string(n) + ": FTLE error against time";
    plot.aspect = 0.8;
    plot.width_px = 1400;
    plot.x_label = "wall time of the whole process (s)";
    plot.y_label = "FTLE error";
    plot.log_x = plot.log_y = true;
    plot.legend = geobarrier::XYPlot::Legend::outside_right;
    using Series = geobarrier::PlotSeries;
    Series mean{{}, "mean error", "blue", 1.5, Series::Style::points};
    Series interior{{}, "interior max", "red", 1.5, Series::Style::points};
    // The default and the peers stand out, each as two markers: its mean error (lower) and interior max (upper).
    Series defaults{{}, "default", "#00a000", 1.5, Series::Style::points};
    Series odeint{{}, "Boost.Odeint", "#ff8000", 1.5, Series::Style::points};
    Series scipy{{}, "SciPy", "#a000c0", 1.5, Series::Style::points};
    defaults.marker_px = odeint.marker_px = scipy.marker_px = 10;
    std::vector<std::pair<double, double>> front_mean, front_interior;
    for (const Row &r : rows) {
        if (r.workload != "W" || r.nx != n || !std::isfinite(r.wall) || !std::isfinite(r.err.mean)) continue;
        if (r.section != "headline" && r.section != "sweep" && r.name.rfind("SciPy", 0) != 0) continue; // repeats
        Series *highlight = r.name.rfind("odeint", 0) == 0  ? &odeint
                            : r.name.rfind("SciPy", 0) == 0 ? &scipy
                            : r.name == "default"           ? &defaults
                                                            : nullptr;
        if (highlight) highlight->xy.insert(highlight->xy.end(), {r.wall, r.err.mean, r.wall, r.err.interior_max});
        if (highlight == &odeint || highlight == &scipy) continue;
        mean.xy.insert(mean.xy.end(), {r.wall, r.err.mean});
        interior.xy.insert(interior.xy.end(), {r.wall, r.err.interior_max});
        front_mean.emplace_back(r.wall, r.err.mean);
        front_interior.emplace_back(r.wall, r.err.interior_max);
    }
    Series fm{pareto_front(front_mean), "front, mean", "blue", 1.2, Series::Style::line, Series::Dash::dashed};
    Series fi{pareto_front(front_interior), "front, interior", "red", 1.2, Series::Style::line, Series::Dash::dashed};
    // The targets: mean error 1e-4, interior max 0.05.
    Series target_mean{{}, "target 1e-4", "blue", 1.0, Series::Style::line, Series::Dash::dotted};
    Series target_interior{{}, "target 0.05", "red", 1.0, Series::Style::line, Series::Dash::dotted};
    double t_min = HUGE_VAL, t_max = 0;
    for (const Row &r : rows)
        if (r.workload == "W" && r.nx == n && std::isfinite(r.wall) && std::isfinite(r.err.mean)) {
            t_min = std::min(t_min, r.wall);
            t_max = std::max(t_max, r.wall);
        }
    if (t_max <= 0) return;
    target_mean.xy = {t_min, 1e-4, t_max, 1e-4};
    target_interior.xy = {t_min, 0.05, t_max, 0.05};
    plot.series = {mean, interior, fm, fi, target_mean, target_interior, defaults, odeint};
    if (!scipy.xy.empty()) plot.series.push_back(scipy);
    geobarrier::plot_xy_png(file, plot);
}

} // namespace geobarrier::bench
