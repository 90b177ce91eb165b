// The validation products' pictures: period-map iterates, tracer clouds, trajectories (phase plane, time series,
// extended phase space), the forcing, and advected barriers (delta_l(t), the curves in the phase plane, their tube).
// One set of colours across all of them: barriers red, data blue, a palette without red for several series.
#include <geobarrier/curves.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "diagnostics/validation_internal.hpp"

namespace fs = std::filesystem;

namespace geobarrier::validation_detail {

namespace {

// The colours used across every validation picture: barriers red, data (iterates, tracers, forcing) blue, and a
// palette without red for several series of data.
const char *barrier_color = "red";
const char *data_color = "blue";
const std::vector<std::string> &series_palette() {
    static const std::vector<std::string> palette{"blue",  "green",   "orange", "purple", "cyan",
                                                  "brown", "magenta", "pink",   "grey",   "black"};
    return palette;
}
// Discrete viridis-like colours for a sequence in time (early dark blue to late yellow).
std::string time_color(std::size_t k, std::size_t n) {
    static const std::array<std::array<int, 3>, 8> stops{{{68, 1, 84},
                                                          {70, 50, 126},
                                                          {54, 92, 141},
                                                          {39, 127, 142},
                                                          {31, 161, 135},
                                                          {74, 193, 109},
                                                          {160, 218, 57},
                                                          {253, 231, 37}}};
    const double u = n <= 1 ? 0.0 : static_cast<double>(k) / static_cast<double>(n - 1) * 7.0;
    const std::size_t i = std::min<std::size_t>(6, static_cast<std::size_t>(u));
    const double f = u - static_cast<double>(i);
    int rgb[3];
    for (int c = 0; c < 3; ++c) rgb[c] = static_cast<int>(std::lround(stops[i][c] * (1 - f) + stops[i + 1][c] * f));
    return fmt::format("#{:02x}{:02x}{:02x}", rgb[0], rgb[1], rgb[2]);
}

// Marker size for a cloud of n points: small enough that a dense cloud still shows its structure.
double cloud_marker_px(std::size_t n) { return n > 50000 ? 1.6 : n > 10000 ? 2.2 : n > 2000 ? 3.0 : 4.5; }

std::vector<PlotSeries> barrier_series(const std::vector<Barrier> &barriers, const std::string &label) {
    std::vector<PlotSeries> out;
    for (std::size_t k = 0; k < barriers.size(); ++k) {
        PlotSeries s;
        s.xy = barriers[k].xy;
        s.closed = barriers[k].closed;
        s.color = barrier_color;
        // A few barriers are drawn boldly; many (a family of nested closed shearlines) thinly, so the data under
        // them still shows.
        s.width = barriers.size() <= 4 ? 2.2 : 1.0;
        // "barriers at ..." names one barrier in the singular.
        if (k == 0)
            s.label = barriers.size() == 1 && label.rfind("barriers", 0) == 0 ? "barrier" + label.substr(8) : label;
        out.push_back(std::move(s));
    }
    return out;
}

} // namespace

std::string Stage::base_title() const { return in.title.empty() ? std::string() : in.title + ": "; }

// Axis labels "name [unit]" from the system's declared state names and units (ABI 1.2), "t [time]" for time.
std::string Stage::state_label(std::size_t i) const {
    const std::size_t component = in.dynamics.slice ? in.dynamics.slice->axes[i] : i; // a slice's axes
    return in.dynamics.system ? state_axis_label(in.dynamics.system->info(), component)
                              : std::string(i == 0 ? "x" : "y");
}

std::string Stage::time_label() const {
    return in.dynamics.system ? time_axis_label(in.dynamics.system->info()) : std::string("t");
}

void Stage::label_phase_plane(XYPlot &plot) const {
    plot.x_label = state_label(0);
    plot.y_label = state_label(1);
}

void Stage::label_extended(XYZPlot &plot) const {
    plot.x_label = state_label(0);
    plot.y_label = state_label(1);
    plot.z_label = time_label();
}

// A phase-plane picture: state axes, one unit of x as long as one of y, the legend beside the box.
XYPlot Stage::phase_plot(const std::string &title) const {
    XYPlot plot;
    plot.title = base_title() + title;
    label_phase_plane(plot);
    plot.equal_aspect = true;
    plot.legend = XYPlot::Legend::outside_right;
    return plot;
}

namespace {

// A cloud of points (iterates, tracers) in the data colour.
PlotSeries data_cloud(const char *label) {
    PlotSeries cloud;
    cloud.style = PlotSeries::Style::points;
    cloud.color = data_color;
    cloud.label = label;
    return cloud;
}

} // namespace

void Stage::save(const XYPlot &plot, const std::string &name) {
    plot_xy_png(out / name, plot);
    add_file(out / name);
}

void Stage::save(const XYZPlot &plot, const std::string &name) {
    plot_xyz_png(out / name, plot);
    add_file(out / name);
}

void Stage::draw_poincare(const PoincarePicture &p) {
    XYPlot plot = phase_plot(fmt::format("period map, {} iterates of {} seeds", p.spec.iterations, p.seeds));
    PlotSeries cloud = data_cloud("iterates");
    for (std::size_t k = 0; k <= p.spec.iterations; ++k)
        for (std::size_t s = 0; s < p.seeds; ++s)
            if (std::isfinite(p.iterates.positions[k][2 * s]))
                cloud.xy.insert(cloud.xy.end(), {p.iterates.positions[k][2 * s], p.iterates.positions[k][2 * s + 1]});
    cloud.marker_px = cloud_marker_px(cloud.xy.size() / 2);
    plot.series.push_back(cloud);
    // Barriers live at t0; they belong on the picture when the map's section is at t0 too. When the seeds came
    // from barriers, those barriers are shown; otherwise all.
    if (same_time(p.t_start, in.t0)) {
        std::vector<Barrier> shown;
        if (p.spec.barrier_points > 0)
            for (std::size_t b : p.seeded_from) shown.push_back(barriers[b]);
        for (PlotSeries &s : barrier_series(p.spec.barrier_points > 0 ? shown : barriers, "barriers at t₀"))
            plot.series.push_back(s);
    }
    save(plot, "poincare.png");
}

// The crossings on the grid's plane (a slice's axes, else the first two components).
void Stage::draw_section(const SectionSpec &spec, const SectionCrossings &c) {
    XYPlot plot = phase_plot(fmt::format("event section, {} crossings of {} seeds", c.times.size(), spec.seeds.size()));
    PlotSeries cloud = data_cloud("crossings");
    const std::size_t ax = in.dynamics.slice ? in.dynamics.slice->axes[0] : 0;
    const std::size_t ay = in.dynamics.slice ? in.dynamics.slice->axes[1] : 1;
    for (std::size_t k = 0; k < c.times.size(); ++k)
        cloud.xy.insert(cloud.xy.end(), {c.states[c.dimension * k + ax], c.states[c.dimension * k + ay]});
    cloud.marker_px = cloud_marker_px(cloud.xy.size() / 2);
    plot.series.push_back(cloud);
    save(plot, "section.png");
}

nlohmann::json Stage::draw_tracers(std::size_t cloud_index, const Snapshots &snaps, const std::vector<double> &times) {
    nlohmann::json pictures = nlohmann::json::array();
    const std::size_t n = snaps.positions.empty() ? 0 : snaps.positions[0].size() / 2;
    for (std::size_t k = 1; k < times.size(); ++k) {
        XYPlot plot =
            phase_plot(fmt::format("{} tracers released at t = {}, at t = {}", n, fmt_g(times[0]), fmt_g(times[k])));
        PlotSeries cloud = data_cloud("tracers");
        for (std::size_t p = 0; p < n; ++p)
            if (std::isfinite(snaps.positions[k][2 * p]))
                cloud.xy.insert(cloud.xy.end(), {snaps.positions[k][2 * p], snaps.positions[k][2 * p + 1]});
        cloud.marker_px = cloud_marker_px(n);
        plot.series.push_back(cloud);
        if (same_time(times[k], in.t0))
            for (PlotSeries &s : barrier_series(barriers, "barriers at t₀")) plot.series.push_back(s);
        const std::string name = fmt::format("tracers_{}_{}.png", cloud_index, k - 1);
        save(plot, name);
        pictures.push_back(name);
    }
    return pictures;
}

std::string Stage::trajectory_label(const TrajectoryPictures &t, std::size_t s) const {
    std::string text = fmt::format("({}, {})", fmt_g(t.starts[2 * s]), fmt_g(t.starts[2 * s + 1]));
    if (t.inside[s] >= 0) text += t.inside[s] ? " inside" : " outside";
    return text;
}

void Stage::draw_trajectories(const TrajectoryPictures &t) {
    draw_trajectory_phase(t);
    for (int c = 0; c < 2; ++c) draw_trajectory_series(t, c);
    draw_trajectory_3d(t);
}

// Phase plane: the trajectories, their starting points and the outermost elliptic barriers.
void Stage::draw_trajectory_phase(const TrajectoryPictures &t) {
    const auto &palette = series_palette();
    const std::size_t n = t.inside.size();
    XYPlot plot = phase_plot(fmt::format("trajectories, t = {} to {}", fmt_g(t.t_start), fmt_g(t.t_end)));
    for (std::size_t s = 0; s < n; ++s) {
        PlotSeries line;
        line.color = palette[s % palette.size()];
        line.width = 1.0;
        if (n <= 12) line.label = trajectory_label(t, s);
        for (std::size_t k = 0; k < t.times.size(); ++k)
            line.xy.insert(line.xy.end(), {t.snaps.positions[k][2 * s], t.snaps.positions[k][2 * s + 1]});
        plot.series.push_back(line);
        PlotSeries start;
        start.style = PlotSeries::Style::points;
        start.color = line.color;
        start.marker_px = 9.0;
        start.xy = {t.starts[2 * s], t.starts[2 * s + 1]};
        plot.series.push_back(start);
    }
    std::vector<Barrier> outer_copy;
    for (const Barrier *b : t.outermost) outer_copy.push_back(*b);
    for (PlotSeries &s : barrier_series(outer_copy, "outermost elliptic barriers at t₀")) plot.series.push_back(s);
    save(plot, "trajectories_phase.png");
}

// Time series of one coordinate.
void Stage::draw_trajectory_series(const TrajectoryPictures &t, int c) {
    const auto &palette = series_palette();
    const std::size_t n = t.inside.size();
    XYPlot plot;
    const std::string coordinate = c == 0 ? "x" : "y";
    plot.title = base_title() + coordinate + "(t) of the trajectories";
    plot.x_label = time_label();
    plot.y_label = state_label(static_cast<std::size_t>(c));
    plot.aspect = 0.45;
    plot.legend = XYPlot::Legend::outside_right;
    for (std::size_t s = 0; s < n; ++s) {
        PlotSeries line;
        line.color = palette[s % palette.size()];
        line.width = 1.2;
        if (n <= 12) line.label = trajectory_label(t, s);
        for (std::size_t k = 0; k < t.times.size(); ++k)
            line.xy.insert(line.xy.end(), {t.times[k], t.snaps.positions[k][2 * s + c]});
        plot.series.push_back(line);
    }
    save(plot, "trajectories_" + coordinate + ".png");
}

// Extended phase space (x, y, t) with the outermost barriers at t_start and advected to t_end (paper, figure
// "stability").
void Stage::draw_trajectory_3d(const TrajectoryPictures &t) {
    const auto &palette = series_palette();
    const std::size_t n = t.inside.size();
    XYZPlot plot;
    plot.title = base_title() + "trajectories in extended phase space";
    label_extended(plot);
    for (std::size_t s = 0; s < n; ++s) {
        PlotSeries3D line;
        line.color = palette[s % palette.size()];
        line.width = 1.2;
        if (n <= 12) line.label = trajectory_label(t, s);
        for (std::size_t k = 0; k < t.times.size(); ++k)
            line.xyz.insert(line.xyz.end(), {t.snaps.positions[k][2 * s], t.snaps.positions[k][2 * s + 1], t.times[k]});
        plot.series.push_back(line);
    }
    if (t.classified) {
        const double t_end = t.t_end;
        bool first = true;
        for (const Barrier *b : t.outermost) {
            const StretchingHistory h =
                stretching_history(in.dynamics, in.integrator, in.bounds, b->xy, true, in.t0, {t_end}, 0.005);
            for (const auto &[curve, time] : {std::make_pair(b->xy, in.t0), std::make_pair(h.samples[0].xy, t_end)}) {
                PlotSeries3D ring;
                ring.color = barrier_color;
                ring.width = 2.2;
                ring.closed = true;
                if (first) ring.label = "outermost elliptic barrier";
                first = false;
                for (std::size_t p = 0; p + 1 < curve.size(); p += 2)
                    ring.xyz.insert(ring.xyz.end(), {curve[p], curve[p + 1], time});
                plot.series.push_back(ring);
            }
        }
    }
    save(plot, "trajectories_3d.png");
}

void Stage::draw_forcing(const std::vector<double> &times, const std::vector<double> &f) {
    XYPlot plot;
    plot.title = base_title() + "the forcing f(t)";
    plot.x_label = time_label();
    plot.y_label = "f(t)";
    plot.aspect = 0.4;
    PlotSeries line;
    line.color = data_color;
    line.width = 1.2;
    for (std::size_t k = 0; k < times.size(); ++k) line.xy.insert(line.xy.end(), {times[k], f[k]});
    plot.series.push_back(line);
    save(plot, "forcing.png");
}

void Stage::draw_advected(const AdvectedPictures &a) {
    draw_stretching(a);
    draw_barriers_advected(a);
    if (!a.tubes.empty()) draw_tubes(a);
}

// delta_l(t) x 100 (the paper's figure "length-ex3").
void Stage::draw_stretching(const AdvectedPictures &a) {
    const auto &palette = series_palette();
    XYPlot plot;
    plot.title = base_title() + "relative stretching of the advected barriers";
    plot.x_label = time_label();
    plot.y_label = "δℓ(t) [%]";
    plot.aspect = 0.5;
    plot.legend = XYPlot::Legend::outside_right;
    for (std::size_t k = 0; k < a.chosen.size(); ++k) {
        PlotSeries line;
        line.style = PlotSeries::Style::line_points;
        line.marker_px = 5.0;
        line.color = palette[k % palette.size()];
        if (a.chosen.size() <= 12) line.label = fmt::format("barrier {} ({})", a.chosen[k], barriers[a.chosen[k]].kind);
        for (const StretchingSample &s : a.histories[k].samples)
            line.xy.insert(line.xy.end(), {s.t, 100.0 * s.delta_l});
        plot.series.push_back(line);
    }
    save(plot, "stretching.png");
}

// The advected barriers in the phase plane, one colour per time: at most 9 of the times, evenly chosen (first and
// last included), so the curves stay apart.
void Stage::draw_barriers_advected(const AdvectedPictures &a) {
    XYPlot plot = phase_plot("barriers advected from t₀ = " + fmt_g(in.t0));
    const std::size_t shown = std::min<std::size_t>(a.times.size(), 9);
    for (std::size_t m = 0; m < shown; ++m) {
        const std::size_t r = shown == 1
                                  ? 0
                                  : static_cast<std::size_t>(std::lround(static_cast<double>(m * (a.times.size() - 1)) /
                                                                         static_cast<double>(shown - 1)));
        for (std::size_t k = 0; k < a.chosen.size(); ++k) {
            PlotSeries line;
            line.xy = a.histories[k].samples[r].xy;
            line.closed = barriers[a.chosen[k]].closed;
            line.color = m == 0 ? barrier_color : time_color(m, shown);
            line.width = m == 0 ? 2.2 : 1.4;
            if (k == 0) line.label = "t = " + fmt_g(a.times[r]);
            plot.series.push_back(line);
        }
    }
    save(plot, "barriers_advected.png");
}

// Each tube as a shaded surface, its barrier at t0 in the barrier colour and its last advected slice in the tube's
// colour, which names it in the legend with the colour the same barrier has in stretching.png.
void Stage::draw_tubes(const AdvectedPictures &a) {
    const auto &palette = series_palette();
    XYZPlot plot;
    plot.title = base_title() + "barriers swept through extended phase space";
    label_extended(plot);
    for (std::size_t k = 0; k < a.tubes.size(); ++k) {
        const BarrierTube &tube = a.tubes[k];
        PlotSurface3D surface;
        surface.xyz = tube.xyz;
        surface.rows = tube.rows;
        surface.cols = tube.columns;
        surface.wrap_cols = tube.closed;
        surface.color = palette[k % palette.size()];
        surface.opacity = 0.8;
        plot.surfaces.push_back(surface);
        const Barrier &barrier = barriers[a.chosen[k]];
        PlotSeries3D ring;
        ring.color = barrier_color;
        ring.width = 2.2;
        ring.closed = tube.closed;
        if (k == 0) ring.label = "barriers at t₀";
        for (std::size_t p = 0; p + 1 < barrier.xy.size(); p += 2)
            ring.xyz.insert(ring.xyz.end(), {barrier.xy[p], barrier.xy[p + 1], in.t0});
        plot.series.push_back(ring);
        if (tube.slices.empty()) continue;
        PlotSeries3D last;
        last.color = surface.color;
        last.width = 1.6;
        last.closed = tube.closed;
        if (a.chosen.size() <= 12) last.label = fmt::format("barrier {} ({})", a.chosen[k], barrier.kind);
        const std::vector<double> &curve = tube.slices.back();
        for (std::size_t p = 0; p + 1 < curve.size(); p += 2)
            last.xyz.insert(last.xyz.end(), {curve[p], curve[p + 1], tube.slice_times.back()});
        plot.series.push_back(last);
    }
    save(plot, "tube.png");
}

} // namespace geobarrier::validation_detail
