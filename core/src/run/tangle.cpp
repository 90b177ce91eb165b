// Both directions in one run and the transverse crossings of their barriers (tangle.hpp).
#include "run/mpi.hpp"
#include <geobarrier/errors.hpp>
#include <geobarrier/output.hpp>
#include <geobarrier/tangle.hpp>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

namespace geobarrier {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double min_crossing_angle = 10.0; // degrees (transverse_crossings)

struct Segment {
    double ax, ay, bx, by;
    std::size_t barrier;
};

// The segments of every barrier of a list, closed curves closed.
std::vector<Segment> segments_of(const json &barriers) {
    std::vector<Segment> out;
    for (std::size_t b = 0; b < barriers.size(); ++b) {
        const json &points = barriers[b].at("points");
        const std::size_t n = points.size();
        for (std::size_t k = 0; k + 1 < n; ++k)
            out.push_back({points[k][0], points[k][1], points[k + 1][0], points[k + 1][1], b});
        if (n > 2 && barriers[b].value("closed", false))
            out.push_back({points[n - 1][0], points[n - 1][1], points[0][0], points[0][1], b});
    }
    return out;
}

// Cells of a uniform grid over the segments' bounding box, a segment listed in every cell its own box touches.
class SegmentIndex {
  public:
    explicit SegmentIndex(const std::vector<Segment> &segments) {
        double x0 = inf, x1 = -inf, y0 = inf, y1 = -inf, length = 0.0;
        for (const Segment &s : segments) {
            x0 = std::min({x0, s.ax, s.bx}), x1 = std::max({x1, s.ax, s.bx});
            y0 = std::min({y0, s.ay, s.by}), y1 = std::max({y1, s.ay, s.by});
            length += std::hypot(s.bx - s.ax, s.by - s.ay);
        }
        if (segments.empty()) return;
        m_x0 = x0, m_y0 = y0;
        // Cells of about two mean segment lengths, at most 1024 per side.
        const double span = std::max(x1 - x0, y1 - y0);
        m_h = std::max({2.0 * length / static_cast<double>(segments.size()), span / 1024.0, 1e-300});
        for (std::size_t i = 0; i < segments.size(); ++i)
            for_cells(segments[i], [&](long long cell) { m_entries.emplace_back(cell, i); });
        std::sort(m_entries.begin(), m_entries.end());
    }
    // Calls visit(i) for every indexed segment sharing a cell with s (a segment may come more than once).
    template <class Visit> void candidates(const Segment &s, Visit visit) const {
        if (m_entries.empty()) return;
        for_cells(s, [&](long long cell) {
            auto it = std::lower_bound(m_entries.begin(), m_entries.end(), std::make_pair(cell, std::size_t{0}));
            for (; it != m_entries.end() && it->first == cell; ++it) visit(it->second);
        });
    }

  private:
    static constexpr double inf = std::numeric_limits<double>::infinity();
    static constexpr long long side = 1 << 20;
    template <class Visit> void for_cells(const Segment &s, Visit visit) const {
        const auto cell = [&](double v, double origin) {
            return static_cast<long long>(std::clamp(std::floor((v - origin) / m_h), -1.0, double(side - 2)));
        };
        const long long i0 = cell(std::min(s.ax, s.bx), m_x0), i1 = cell(std::max(s.ax, s.bx), m_x0);
        const long long j0 = cell(std::min(s.ay, s.by), m_y0), j1 = cell(std::max(s.ay, s.by), m_y0);
        for (long long j = j0; j <= j1; ++j)
            for (long long i = i0; i <= i1; ++i) visit((j + 1) * side + (i + 1));
    }
    double m_x0 = 0.0, m_y0 = 0.0, m_h = 1.0;
    std::vector<std::pair<long long, std::size_t>> m_entries;
};

// Where segment a crosses segment b: the parameters along a and b, each in [0, 1) (half-open, so that a crossing
// at a shared vertex is counted once), or nothing (parallel, or apart).
bool crossing(const Segment &a, const Segment &b, double &s, double &t) {
    const double dax = a.bx - a.ax, day = a.by - a.ay, dbx = b.bx - b.ax, dby = b.by - b.ay;
    const double det = dax * dby - day * dbx;
    if (det == 0.0) return false;
    const double ex = b.ax - a.ax, ey = b.ay - a.ay;
    s = (ex * dby - ey * dbx) / det;
    t = (ex * day - ey * dax) / det;
    return s >= 0.0 && s < 1.0 && t >= 0.0 && t < 1.0;
}

json crossings_json(const std::vector<BarrierCrossing> &crossings) {
    json out = json::array();
    for (const BarrierCrossing &c : crossings)
        out.push_back({{"point", {c.x, c.y}},
                       {"forward", c.forward},
                       {"backward", c.backward},
                       {"angle_degrees", c.angle_degrees}});
    return out;
}

// The run of one direction: the experiment as written with t1 = t0 + sign |T|, into `folder`.
RunSummary run_direction(const Experiment &e, double sign, const fs::path &folder, const RunOptions &options) {
    json source = e.source;
    source["time"]["t1"] = e.t0 + sign * std::abs(e.t1 - e.t0);
    source["time"].erase("directions");
    const ResolvedExperiment r = resolve_experiment(parse_experiment(source, e.file));
    RunOptions o = options;
    o.output_dir = folder;
    o.keep_results = true; // the FTLE field and the barriers for the tangle
    spdlog::info("{} run: t = {} to {}, into {}", sign > 0 ? "forward" : "backward", r.experiment.t0, r.experiment.t1,
                 folder.string());
    return run_experiment(r, o);
}

const FieldResult *field_named(const RunSummary &s, const std::string &name) {
    for (const FieldResult &f : s.fields)
        if (f.name == name) return &f;
    return nullptr;
}

void append_curves(const json &barriers, const char *color, std::vector<PlotCurve> &curves) {
    for (const json &b : barriers) {
        PlotCurve c;
        c.color = color;
        c.width = 2.0;
        c.closed = b.value("closed", false);
        for (const json &p : b.at("points")) {
            c.xy.push_back(p[0]);
            c.xy.push_back(p[1]);
        }
        curves.push_back(std::move(c));
    }
}

// tangle.png: the larger of the two FTLE fields, the repelling barriers (red), the attracting ones (white) and the
// crossings (magenta discs).
void plot_tangle(const fs::path &file, const Experiment &e, const RunSummary &forward, const RunSummary &backward,
                 const std::vector<BarrierCrossing> &crossings) {
    const FieldResult *f = field_named(forward, "ftle"), *b = field_named(backward, "ftle");
    if (!f || !b) return;
    std::vector<double> values(f->values.size());
    std::vector<std::uint8_t> mask(f->values.size(), 0);
    for (std::size_t k = 0; k < values.size(); ++k) {
        values[k] = std::fmax(f->values[k], b->values[k]); // fmax: the other where one is NaN
        mask[k] = static_cast<std::uint8_t>(forward.mask[k] & backward.mask[k]);
    }
    FieldPlot plot;
    plot.title = fmt::format("repelling (red, t = {:g} to {:g}) and attracting (white) barriers, {} crossings", e.t0,
                             e.t0 + std::abs(e.t1 - e.t0), crossings.size());
    plot.colorbar_label = "max(forward FTLE, backward FTLE)";
    append_curves(forward.barriers, "red", plot.curves);
    append_curves(backward.barriers, "white", plot.curves);
    if (!crossings.empty()) {
        PlotCurve dots;
        dots.color = "magenta";
        dots.points_only = true;
        dots.marker_px = 9.0;
        for (const BarrierCrossing &c : crossings) {
            dots.xy.push_back(c.x);
            dots.xy.push_back(c.y);
        }
        plot.curves.push_back(std::move(dots));
    }
    plot_field_png(file, e.grid, values, mask, plot);
}

} // namespace

std::vector<BarrierCrossing> transverse_crossings(const json &forward, const json &backward, double min_angle_degrees,
                                                  double merge_distance) {
    const std::vector<Segment> fs_ = segments_of(forward), bs = segments_of(backward);
    const SegmentIndex index(bs);
    const double pi = std::acos(-1.0);
    std::vector<std::pair<double, BarrierCrossing>> found; // (position along the forward barriers, crossing)
    std::vector<std::size_t> seen;
    for (std::size_t i = 0; i < fs_.size(); ++i) {
        const Segment &a = fs_[i];
        seen.clear();
        index.candidates(a, [&](std::size_t j) {
            if (std::find(seen.begin(), seen.end(), j) != seen.end()) return;
            seen.push_back(j);
            const Segment &b = bs[j];
            double s = 0.0, t = 0.0;
            if (!crossing(a, b, s, t)) return;
            const double dax = a.bx - a.ax, day = a.by - a.ay, dbx = b.bx - b.ax, dby = b.by - b.ay;
            const double cos_angle = std::abs(dax * dbx + day * dby) / (std::hypot(dax, day) * std::hypot(dbx, dby));
            const double angle = std::acos(std::min(cos_angle, 1.0)) * 180.0 / pi;
            if (!(angle > min_angle_degrees)) return;
            found.push_back({static_cast<double>(i) + s,
                             BarrierCrossing{a.ax + s * dax, a.ay + s * day, a.barrier, b.barrier, angle}});
        });
    }
    std::sort(found.begin(), found.end(), [](const auto &p, const auto &q) { return p.first < q.first; });
    std::vector<BarrierCrossing> out;
    for (auto &p : found) {
        const BarrierCrossing &c = p.second;
        const bool near = std::any_of(out.begin(), out.end(), [&](const BarrierCrossing &o) {
            return std::hypot(o.x - c.x, o.y - c.y) <= merge_distance;
        });
        if (!near) out.push_back(c);
    }
    return out;
}

RunSummary run_both_directions(const ResolvedExperiment &r, const RunOptions &options) {
    const Experiment &e = r.experiment;
    if (!options.write_files || options.keep_results)
        throw ConfigError("/time/directions", "\"both\" writes two runs and their tangle into the output folder; "
                                              "to keep results in memory, run the two directions one by one");
    if (r.extractors.empty())
        throw ConfigError("/time/directions", "\"both\" looks for crossings of barriers, but the experiment has no "
                                              "\"extractors\"");
    const fs::path out = options.output_dir ? *options.output_dir : e.output_dir;
    const RunSummary forward = run_direction(e, +1.0, out / "forward", options);
    const RunSummary backward = run_direction(e, -1.0, out / "backward", options);
    RunSummary summary;
    if (mpi::rank() != 0) return summary; // the other ranks only shared the flow map's tiles
    summary.output_dir = out;
    summary.files = forward.files;
    summary.files.insert(summary.files.end(), backward.files.begin(), backward.files.end());
    // Within two grid spacings, two crossings are one: a barrier folded back on itself, or two pieces ending there.
    const double merge = 2.0 * std::max(e.grid.dx(), e.grid.dy());
    const std::vector<BarrierCrossing> crossings =
        transverse_crossings(forward.barriers, backward.barriers, min_crossing_angle, merge);
    const json tangle = {{"t0", e.t0},
                         {"horizon", std::abs(e.t1 - e.t0)},
                         {"forward", "forward/barriers.json"},
                         {"backward", "backward/barriers.json"},
                         {"forward_barriers", forward.barriers.size()},
                         {"backward_barriers", backward.barriers.size()},
                         {"min_angle_degrees", min_crossing_angle},
                         {"merge_distance", merge},
                         {"crossings", crossings_json(crossings)}};
    if (e.plots) {
        plot_tangle(out / "tangle.png", e, forward, backward, crossings);
        summary.files.push_back(out / "tangle.png");
    }
    write_text_file(out / "tangle.json", tangle.dump(1) + "\n");
    summary.files.push_back(out / "tangle.json");
    spdlog::info("tangle: {} repelling and {} attracting barriers, {} transverse crossings", forward.barriers.size(),
                 backward.barriers.size(), crossings.size());
    return summary;
}

} // namespace geobarrier
