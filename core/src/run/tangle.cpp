// Both directions in one run and the transverse crossings of their barriers (tangle.hpp).
#include "run/convergence.hpp"
#include "run/mpi.hpp"
#include <geobarrier/errors.hpp>
#include <geobarrier/extraction.hpp>
#include <geobarrier/output.hpp>
#include <geobarrier/segment_index.hpp>
#include <geobarrier/tangle.hpp>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

namespace geobarrier {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double min_crossing_angle = 10.0;  // degrees (transverse_crossings)
constexpr std::size_t shooting_segments = 8; // saddle_orbits_near

// The segments of every barrier of a list, closed curves closed; a segment's id is its barrier's position.
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

// Whether a barrier (barriers.json item) passes within `within` of (x, y).
bool passes_within(const json &barrier, double x, double y, double within) {
    const json &points = barrier.at("points");
    for (std::size_t k = 0; k + 1 < points.size(); ++k)
        if (distance_to_segment(x, y, {points[k][0], points[k][1], points[k + 1][0], points[k + 1][1], 0}) <= within)
            return true;
    return points.size() == 1 && std::hypot(double(points[0][0]) - x, double(points[0][1]) - y) <= within;
}

// A 2 x 2 matrix's eigenvalues when they are real, larger magnitude first.
std::optional<std::array<double, 2>> real_eigenvalues(const std::array<double, 4> &m) {
    const double half_trace = 0.5 * (m[0] + m[3]), det = m[0] * m[3] - m[1] * m[2];
    const double disc = half_trace * half_trace - det;
    if (!(disc > 0.0)) return std::nullopt;
    const double root = std::sqrt(disc);
    std::array<double, 2> l = {half_trace + root, half_trace - root};
    if (std::abs(l[1]) > std::abs(l[0])) std::swap(l[0], l[1]);
    return l;
}

json crossings_json(const std::vector<BarrierCrossing> &crossings) {
    json out = json::array();
    for (const BarrierCrossing &c : crossings) {
        json item = {{"point", {c.x, c.y}},
                     {"forward", c.forward},
                     {"backward", c.backward},
                     {"angle_degrees", c.angle_degrees},
                     {"kind", crossing_kind_name(c.kind)}};
        if (c.kind == CrossingKind::saddle_orbit || c.kind == CrossingKind::homoclinic) item["orbit"] = c.orbit;
        out.push_back(std::move(item));
    }
    return out;
}

// The run of one direction: the experiment as written with t1 = t0 + sign |T|, into `folder`.
RunSummary run_direction(const Experiment &e, double sign, const fs::path &folder, const RunOptions &options) {
    json source = e.source;
    source["time"]["t1"] = e.t0 + sign * std::abs(e.t1 - e.t0);
    source["time"].erase("directions");
    source["time"].erase("period");
    source["time"].erase("grow_periods");
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
    const double width = barriers.size() > 50 ? 1.0 : 2.0; // grown manifolds: many pieces, thinner
    for (const json &b : barriers) {
        PlotCurve c;
        c.color = color;
        c.width = width;
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
                 const json &repelling, const json &attracting, const std::vector<BarrierCrossing> &crossings,
                 const std::string &what) {
    const FieldResult *f = field_named(forward, "ftle"), *b = field_named(backward, "ftle");
    if (!f || !b) return;
    std::vector<double> values(f->values.size());
    std::vector<std::uint8_t> mask(f->values.size(), 0);
    for (std::size_t k = 0; k < values.size(); ++k) {
        values[k] = std::fmax(f->values[k], b->values[k]); // fmax: the other where one is NaN
        mask[k] = static_cast<std::uint8_t>(forward.mask[k] & backward.mask[k]);
    }
    FieldPlot plot;
    const auto at_orbits = std::count_if(crossings.begin(), crossings.end(),
                                         [](const BarrierCrossing &c) { return c.kind == CrossingKind::saddle_orbit; });
    plot.title =
        fmt::format("{} at t = {:g}: {} crossings", what, e.t0, crossings.size() - static_cast<std::size_t>(at_orbits));
    if (at_orbits > 0) plot.title += fmt::format(", {} at saddle orbits", at_orbits);
    plot.colorbar_label = "max(forward FTLE, backward FTLE)";
    append_curves(repelling, "red", plot.curves);
    append_curves(attracting, "white", plot.curves);
    // Crossings at saddle orbits (no tangle) in cyan, the others in magenta.
    for (const bool at_orbit : {true, false}) {
        PlotCurve dots;
        dots.color = at_orbit ? "cyan" : "magenta";
        dots.points_only = true;
        dots.marker_px = 9.0;
        for (const BarrierCrossing &c : crossings)
            if ((c.kind == CrossingKind::saddle_orbit) == at_orbit) dots.xy.insert(dots.xy.end(), {c.x, c.y});
        if (!dots.xy.empty()) plot.curves.push_back(std::move(dots));
    }
    plot_field_png(file, e.grid, values, mask, plot);
}

// Counts of crossings by kind: "tangle" is every crossing but those at saddle orbits (all of them when unclassified).
json crossing_counts(const std::vector<BarrierCrossing> &crossings, bool classified) {
    const auto count = [&](CrossingKind kind) {
        return static_cast<std::size_t>(std::count_if(crossings.begin(), crossings.end(),
                                                      [&](const BarrierCrossing &c) { return c.kind == kind; }));
    };
    json counts = {{"total", crossings.size()}, {"tangle", crossings.size() - count(CrossingKind::saddle_orbit)}};
    if (classified)
        for (const CrossingKind kind : {CrossingKind::saddle_orbit, CrossingKind::homoclinic, CrossingKind::other})
            counts[crossing_kind_name(kind)] = count(kind);
    return counts;
}

// "grow_periods": both directions' barriers grown over k periods (the repelling ones backward, the attracting ones
// forward), their crossings classified as the barriers' are (a grown piece counts as its barrier: it holds the
// barrier's saddle orbit if the barrier did), and grown.png; tangle.json's "grown".
json grown_tangle(const ResolvedExperiment &r, const RunSummary &forward, const RunSummary &backward,
                  std::vector<SaddleOrbit> orbits, const fs::path &picture);

} // namespace

std::vector<BarrierCrossing> transverse_crossings(const json &forward, const json &backward, double min_angle_degrees,
                                                  double merge_distance) {
    const std::vector<Segment> fs_ = segments_of(forward);
    std::vector<Segment> backward_segments = segments_of(backward);
    const double cell = SegmentIndex::two_mean_lengths(backward_segments);
    const SegmentIndex index(std::move(backward_segments), cell);
    const std::vector<Segment> &bs = index.segments();
    const double pi = std::acos(-1.0);
    std::vector<std::pair<double, BarrierCrossing>> found; // (position along the forward barriers, crossing)
    std::vector<std::size_t> seen;
    for (std::size_t i = 0; i < fs_.size(); ++i) {
        const Segment &a = fs_[i];
        seen.clear();
        index.sharing_cells(a, [&](std::size_t j) {
            if (std::find(seen.begin(), seen.end(), j) != seen.end()) return;
            seen.push_back(j);
            const Segment &b = bs[j];
            double s = 0.0, t = 0.0;
            if (!crossing(a, b, s, t)) return;
            const double dax = a.bx - a.ax, day = a.by - a.ay, dbx = b.bx - b.ax, dby = b.by - b.ay;
            const double cos_angle = std::abs(dax * dbx + day * dby) / (std::hypot(dax, day) * std::hypot(dbx, dby));
            const double angle = std::acos(std::min(cos_angle, 1.0)) * 180.0 / pi;
            if (!(angle > min_angle_degrees)) return;
            found.push_back(
                {static_cast<double>(i) + s, BarrierCrossing{a.ax + s * dax, a.ay + s * day, a.id, b.id, angle}});
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

const char *crossing_kind_name(CrossingKind kind) {
    switch (kind) {
    case CrossingKind::saddle_orbit:
        return "saddle_orbit";
    case CrossingKind::homoclinic:
        return "homoclinic";
    case CrossingKind::other:
        return "other";
    case CrossingKind::unclassified:
        break;
    }
    return "unclassified";
}

std::vector<SaddleOrbit> saddle_orbits_near(const ResolvedExperiment &r, double period,
                                            const std::vector<double> &starts, double within) {
    const Experiment &e = r.experiment;
    const std::size_t n = starts.size() / 2;
    // Multiple shooting: the orbit's states z_0 .. z_{m-1} at t0 + i period / m, each segment's flow map F_i, and the
    // conditions F_i(z_i) = z_{i+1 mod m}. A saddle orbit's period map can stretch by hundreds (unforced Duffing's
    // saddle over 2 pi: e^(2 pi)); a start a grid spacing off is then far outside Newton's reach on P itself, but
    // within it on segments that stretch by the m-th root of that.
    constexpr std::size_t m = shooting_segments;
    using Matrix2 = std::array<double, 4>; // row-major
    const auto times = [](const Matrix2 &p, const Matrix2 &q) {
        return Matrix2{p[0] * q[0] + p[1] * q[2], p[0] * q[1] + p[1] * q[3], p[2] * q[0] + p[3] * q[2],
                       p[2] * q[1] + p[3] * q[3]};
    };
    std::vector<std::array<double, 2 * m>> z(n); // z_i of point k: z[k][2 i], z[k][2 i + 1]
    std::vector<std::uint8_t> lost(n, 0);
    // Each segment's flow map (and DF) with the host's advection service: the experiment's integrator and gradient
    // method, as extractors advect.
    const ExtractServices services = advection_services(r);
    struct SegmentMap {
        std::vector<double> xy, dF;
        std::vector<std::uint8_t> mask;
    };
    const auto segment_map = [&](std::size_t count, const std::vector<double> &from, double t_from, double t_to,
                                 bool gradient) {
        SegmentMap map{std::vector<double>(2 * count), std::vector<double>(gradient ? 4 * count : 0),
                       std::vector<std::uint8_t>(count)};
        services.advect(count, from.data(), t_from, t_to, map.xy.data(), gradient ? map.dF.data() : nullptr,
                        map.mask.data());
        return map;
    };
    // The starting states: from the start forward over the first half of the period, and, as a periodic orbit is back
    // at its start one period on, backward from t0 + period over the second half: nowhere stretched by more than the
    // square root of the period map's multiplier.
    for (std::size_t i = 0; i < m; ++i) {
        const double t = e.t0 + period * static_cast<double>(i) / static_cast<double>(m);
        const SegmentMap map = segment_map(n, starts, i <= m / 2 ? e.t0 : e.t0 + period, t, false);
        for (std::size_t k = 0; k < n; ++k) {
            if (map.mask[k]) lost[k] = 1;
            z[k][2 * i] = i == 0 ? starts[2 * k] : map.xy[2 * k];
            z[k][2 * i + 1] = i == 0 ? starts[2 * k + 1] : map.xy[2 * k + 1];
        }
    }
    // Newton stops when its step is far below the grid's resolution: the barriers it is compared with are no sharper.
    const double settled_step = 1e-4 * std::min(e.grid.dx(), e.grid.dy());
    std::vector<std::uint8_t> settled(n, 0);
    std::vector<Matrix2> dP(n);
    for (int step = 0; step < 30; ++step) {
        std::vector<std::size_t> active;
        for (std::size_t k = 0; k < n; ++k)
            if (!lost[k] && !settled[k]) active.push_back(k);
        if (active.empty()) break;
        // Newton's step for F_i(z_i) = z_{i+1}: dz_{i+1} = G_i dz_i + R_i with G_i = DF_i and R_i = F_i(z_i) - z_{i+1},
        // around the cycle: (I - G_{m-1} ... G_0) dz_0 = c, c accumulated as the recursion runs from dz_0 = 0.
        std::vector<Matrix2> product(active.size(), Matrix2{1.0, 0.0, 0.0, 1.0});
        std::vector<std::array<double, 2 * m>> offsets(active.size()); // dz_i - (G_{i-1} ... G_0) dz_0
        std::vector<std::array<Matrix2, m>> products(active.size());   // G_{i-1} ... G_0
        std::vector<double> from(2 * active.size());
        for (std::size_t i = 0; i < m; ++i) {
            for (std::size_t a = 0; a < active.size(); ++a) {
                from[2 * a] = z[active[a]][2 * i], from[2 * a + 1] = z[active[a]][2 * i + 1];
                products[a][i] = product[a];
                if (i == 0) offsets[a][0] = offsets[a][1] = 0.0;
            }
            const double t = e.t0 + period * static_cast<double>(i) / static_cast<double>(m);
            const SegmentMap map = segment_map(active.size(), from, t, t + period / static_cast<double>(m), true);
            const std::size_t next = (i + 1) % m;
            for (std::size_t a = 0; a < active.size(); ++a) {
                if (map.mask[a]) {
                    lost[active[a]] = 1;
                    continue;
                }
                const Matrix2 g = {map.dF[4 * a], map.dF[4 * a + 1], map.dF[4 * a + 2], map.dF[4 * a + 3]};
                const double rx = map.xy[2 * a] - z[active[a]][2 * next];
                const double ry = map.xy[2 * a + 1] - z[active[a]][2 * next + 1];
                const double ox = offsets[a][2 * i], oy = offsets[a][2 * i + 1];
                const double cx = g[0] * ox + g[1] * oy + rx, cy = g[2] * ox + g[3] * oy + ry;
                if (next != 0) offsets[a][2 * next] = cx, offsets[a][2 * next + 1] = cy;
                product[a] = times(g, product[a]);
                if (next == 0) offsets[a][0] = cx, offsets[a][1] = cy; // c, once around the cycle
            }
        }
        for (std::size_t a = 0; a < active.size(); ++a) {
            const std::size_t k = active[a];
            if (lost[k]) continue;
            const Matrix2 &M = product[a];
            const double a00 = 1.0 - M[0], a01 = -M[1], a10 = -M[2], a11 = 1.0 - M[3], det = a00 * a11 - a01 * a10;
            const double c0 = offsets[a][0], c1 = offsets[a][1];
            const double d0 = (a11 * c0 - a01 * c1) / det, d1 = (a00 * c1 - a10 * c0) / det;
            double largest = 0.0;
            for (std::size_t i = 0; i < m; ++i) {
                const Matrix2 &P = products[a][i];
                const double ox = i == 0 ? 0.0 : offsets[a][2 * i], oy = i == 0 ? 0.0 : offsets[a][2 * i + 1];
                const double sx = P[0] * d0 + P[1] * d1 + ox, sy = P[2] * d0 + P[3] * d1 + oy;
                z[k][2 * i] += sx, z[k][2 * i + 1] += sy;
                largest = std::max({largest, std::abs(sx), std::abs(sy)});
            }
            dP[k] = M;
            if (!std::isfinite(largest) || std::hypot(z[k][0] - starts[2 * k], z[k][1] - starts[2 * k + 1]) > within)
                lost[k] = 1;
            else if (largest < settled_step)
                settled[k] = 1;
        }
    }
    std::vector<SaddleOrbit> orbits;
    for (std::size_t k = 0; k < n; ++k) {
        if (!settled[k]) continue;
        const auto multipliers = real_eigenvalues(dP[k]);
        if (!multipliers || !(std::abs((*multipliers)[0]) > 1.0 && std::abs((*multipliers)[1]) < 1.0)) continue;
        const double x = z[k][0], y = z[k][1];
        const bool known = std::any_of(orbits.begin(), orbits.end(),
                                       [&](const SaddleOrbit &o) { return std::hypot(o.x - x, o.y - y) <= within; });
        if (!known) orbits.push_back({x, y, {(*multipliers)[0], (*multipliers)[1]}});
    }
    return orbits;
}

void classify_crossings(std::vector<BarrierCrossing> &crossings, const json &forward, const json &backward,
                        const std::vector<SaddleOrbit> &orbits, double within) {
    for (BarrierCrossing &c : crossings) {
        c.kind = CrossingKind::other;
        for (std::size_t o = 0; o < orbits.size(); ++o)
            if (std::hypot(c.x - orbits[o].x, c.y - orbits[o].y) <= within) {
                c.kind = CrossingKind::saddle_orbit, c.orbit = o;
                break;
            }
        if (c.kind != CrossingKind::other) continue;
        for (std::size_t o = 0; o < orbits.size(); ++o)
            if (passes_within(forward[c.forward], orbits[o].x, orbits[o].y, within) &&
                passes_within(backward[c.backward], orbits[o].x, orbits[o].y, within)) {
                c.kind = CrossingKind::homoclinic, c.orbit = o;
                break;
            }
    }
}

RunSummary run_both_directions(const ResolvedExperiment &r, const RunOptions &options) {
    const Experiment &e = r.experiment;
    const auto start = std::chrono::steady_clock::now();
    const fs::path out = options.output_dir ? *options.output_dir : e.output_dir;
    RunSummary forward = run_direction(e, +1.0, out / "forward", options);
    RunSummary backward = run_direction(e, -1.0, out / "backward", options);
    RunSummary summary;
    if (mpi::rank() != 0) return summary; // the other ranks only shared the flow map's tiles
    // Nothing is written (the Python module's write=False): no folder, no picture; the results are kept.
    const bool write = options.write_files;
    if (write) summary.output_dir = out;
    summary.files = forward.files;
    summary.files.insert(summary.files.end(), backward.files.begin(), backward.files.end());
    // Within two grid spacings, two crossings are one: a barrier folded back on itself, or two pieces ending there.
    const double merge = 2.0 * std::max(e.grid.dx(), e.grid.dy());
    std::vector<BarrierCrossing> crossings =
        transverse_crossings(forward.barriers, backward.barriers, min_crossing_angle, merge);
    // Barriers end or bend a few grid spacings from a saddle orbit (the strain field degenerates there), so their
    // crossing can lie that far from it: measured on damped Duffing (delta 0.1) up to 2.7 grid spacings.
    const double orbit_reach = 4.0 * std::max(e.grid.dx(), e.grid.dy());
    std::vector<SaddleOrbit> orbits;
    if (e.forcing_period) {
        std::vector<double> starts;
        for (const BarrierCrossing &c : crossings) starts.insert(starts.end(), {c.x, c.y});
        orbits = saddle_orbits_near(r, *e.forcing_period, starts, orbit_reach);
        classify_crossings(crossings, forward.barriers, backward.barriers, orbits, orbit_reach);
    }
    const json counts = crossing_counts(crossings, e.forcing_period.has_value());
    json tangle = {{"t0", e.t0},
                   {"horizon", std::abs(e.t1 - e.t0)},
                   {"forward", "forward/barriers.json"},
                   {"backward", "backward/barriers.json"},
                   {"forward_barriers", forward.barriers.size()},
                   {"backward_barriers", backward.barriers.size()},
                   {"min_angle_degrees", min_crossing_angle},
                   {"merge_distance", merge},
                   {"orbit_reach", orbit_reach},
                   {"counts", counts},
                   {"crossings", crossings_json(crossings)}};
    if (e.forcing_period) {
        tangle["period"] = *e.forcing_period;
        tangle["saddle_orbits"] = json::array();
        for (const SaddleOrbit &o : orbits)
            tangle["saddle_orbits"].push_back(
                {{"point", {o.x, o.y}}, {"multipliers", {o.multipliers[0], o.multipliers[1]}}});
    }
    json files = json::array({"forward", "backward", "tangle.json"});
    if (e.plots && write) {
        plot_tangle(out / "tangle.png", e, forward, backward, forward.barriers, backward.barriers, crossings,
                    "repelling (red) and attracting (white) barriers");
        summary.files.push_back(out / "tangle.png");
        files.push_back("tangle.png");
    }
    if (e.grow_periods > 0) {
        tangle["grown"] = grown_tangle(r, forward, backward, orbits, write ? out / "grown.png" : fs::path());
        if (e.plots && write) {
            summary.files.push_back(out / "grown.png");
            files.push_back("grown.png");
        }
    }
    if (write) {
        write_text_file(out / "tangle.json", tangle.dump(1) + "\n");
        summary.files.push_back(out / "tangle.json");
    }
    // The folder's manifest, written last: what a sweep reads (its "experiment" is the experiment as given).
    files.push_back("manifest.json");
    json manifest = {{"experiment", e.source},
                     {"directions", "both"},
                     {"runs", {{"forward", "forward/manifest.json"}, {"backward", "backward/manifest.json"}}},
                     {"crossings", counts},
                     {"grown_crossings", e.grow_periods > 0 ? tangle["grown"]["counts"] : json()},
                     {"wall_seconds", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()},
                     {"files", files}};
    // "convergence": each direction checked its own barriers; the counts of both, for `geobarrier run`'s last line.
    const json convergence = detail::total_convergence({{"forward", forward.manifest.value("convergence", json())},
                                                        {"backward", backward.manifest.value("convergence", json())}});
    if (!convergence.is_null()) manifest["convergence"] = convergence;
    if (write) {
        write_text_file(out / "manifest.json", manifest.dump(2) + "\n");
        summary.files.push_back(out / "manifest.json");
    }
    summary.manifest = manifest;
    if (e.forcing_period)
        spdlog::info(
            "tangle: {} repelling and {} attracting barriers, {} transverse crossings: {} at saddle orbits, {} "
            "of a tangle ({} homoclinic)",
            forward.barriers.size(), backward.barriers.size(), crossings.size(),
            counts["saddle_orbit"].get<std::size_t>(), counts["tangle"].get<std::size_t>(),
            counts["homoclinic"].get<std::size_t>());
    else
        spdlog::info("tangle: {} repelling and {} attracting barriers, {} transverse crossings (give \"time\": "
                     "{{\"period\": ...}} to tell the crossings at saddle orbits from those of a tangle)",
                     forward.barriers.size(), backward.barriers.size(), crossings.size());
    if (options.keep_results) { // each direction's results as its own run keeps them (run_direction keeps them all)
        summary.tangle = std::move(tangle);
        summary.directions.push_back(std::move(forward));
        summary.directions.push_back(std::move(backward));
    }
    return summary;
}

namespace {

json grown_tangle(const ResolvedExperiment &r, const RunSummary &forward, const RunSummary &backward,
                  std::vector<SaddleOrbit> orbits, const fs::path &picture) {
    const Experiment &e = r.experiment;
    spdlog::info("growing {} repelling and {} attracting barriers over {} period(s)", forward.barriers.size(),
                 backward.barriers.size(), e.grow_periods);
    const GrownBarriers repelling =
        grow_barriers_over_periods(r, forward.barriers, -1, e.grow_periods, *e.forcing_period);
    const GrownBarriers attracting =
        grow_barriers_over_periods(r, backward.barriers, +1, e.grow_periods, *e.forcing_period);
    const double merge = 2.0 * std::max(e.grid.dx(), e.grid.dy()), reach = 2.0 * merge;
    std::vector<BarrierCrossing> crossings =
        transverse_crossings(repelling.pieces, attracting.pieces, min_crossing_angle, merge);
    // Saddle orbits at the new crossings too (those of the barriers' crossings are known already).
    std::vector<double> starts;
    for (const BarrierCrossing &c : crossings) {
        const bool known = std::any_of(orbits.begin(), orbits.end(),
                                       [&](const SaddleOrbit &o) { return std::hypot(o.x - c.x, o.y - c.y) <= reach; });
        if (!known) starts.insert(starts.end(), {c.x, c.y});
    }
    for (const SaddleOrbit &o : saddle_orbits_near(r, *e.forcing_period, starts, reach)) orbits.push_back(o);
    std::vector<BarrierCrossing> by_barrier = crossings; // pieces named by their barriers, for classify_crossings
    for (BarrierCrossing &c : by_barrier) {
        c.forward = repelling.pieces[c.forward]["barrier"].get<std::size_t>();
        c.backward = attracting.pieces[c.backward]["barrier"].get<std::size_t>();
    }
    classify_crossings(by_barrier, forward.barriers, backward.barriers, orbits, reach);
    for (std::size_t k = 0; k < crossings.size(); ++k)
        crossings[k].kind = by_barrier[k].kind, crossings[k].orbit = by_barrier[k].orbit;
    if (e.plots && !picture.empty())
        plot_tangle(picture, e, forward, backward, repelling.pieces, attracting.pieces, crossings,
                    fmt::format("barriers grown over {} period(s)", e.grow_periods));
    json saddles = json::array();
    for (const SaddleOrbit &o : orbits)
        saddles.push_back({{"point", {o.x, o.y}}, {"multipliers", {o.multipliers[0], o.multipliers[1]}}});
    return {{"periods", e.grow_periods},
            {"max_gap", std::min(e.grid.dx(), e.grid.dy())},
            {"repelling", repelling.report},
            {"attracting", attracting.report},
            {"repelling_pieces", repelling.pieces},
            {"attracting_pieces", attracting.pieces},
            {"saddle_orbits", saddles},
            {"counts", crossing_counts(crossings, true)},
            {"crossings", crossings_json(crossings)}};
}

} // namespace

} // namespace geobarrier
