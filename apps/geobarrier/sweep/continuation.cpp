// Continuation across a sweep's parameter (continuation.hpp).
#include "sweep/continuation.hpp"

#include "run/barrier_matching.hpp"

#include <geobarrier/curves.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/output.hpp>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>

namespace geobarrier {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// members[from]'s barriers matched to members[to]'s, compared in members[to]'s grid.
std::vector<detail::BarrierMatch> match_members(const ContinuationMember &from, const ContinuationMember &to,
                                                double tolerance) {
    std::vector<std::vector<double>> curves;
    std::vector<bool> closed;
    std::vector<std::size_t> curve_of;
    for (std::size_t b = 0; b < from.barriers.size(); ++b) {
        if (from.barriers[b].at("points").size() < 2) continue;
        curves.push_back(detail::barrier_points(from.barriers[b]));
        closed.push_back(from.barriers[b].value("closed", false));
        curve_of.push_back(b);
    }
    return detail::match_barriers(curves, closed, curve_of, from.barriers, to.barriers, to.grid, tolerance);
}

// A track's figures in one member: the sum of its barriers' lengths and areas, the mean of their stretching figures.
void member_figures(json &entry) {
    double length = 0.0, area = 0.0, stretching = 0.0;
    std::size_t closed = 0, stretched = 0;
    for (const json &b : entry.at("barriers")) {
        length += b.at("length").get<double>();
        if (b.contains("area")) area += b["area"].get<double>(), ++closed;
        if (b.contains("stretching")) stretching += b["stretching"].get<double>(), ++stretched;
    }
    entry["length"] = length;
    entry["area"] = closed > 0 ? json(area) : json(nullptr);
    entry["stretching"] = stretched > 0 ? json(stretching / static_cast<double>(stretched)) : json(nullptr);
}

// The tracks over the available members (`order`: their indices), from the matches' components.
json assemble(const std::vector<ContinuationMember> &members, const std::vector<std::size_t> &order,
              detail::TrackComponents &components, const std::vector<std::size_t> &offset,
              const std::vector<double> &match_distance) {
    std::map<std::size_t, std::size_t> track_of_root;
    json tracks = json::array();
    for (std::size_t i = 0; i < order.size(); ++i) {
        const ContinuationMember &m = members[order[i]];
        for (std::size_t b = 0; b < m.barriers.size(); ++b) {
            const auto [it, fresh] = track_of_root.emplace(components.root(offset[i] + b), tracks.size());
            const json &item = m.barriers[b];
            if (fresh)
                tracks.push_back({{"id", tracks.size()},
                                  {"extractor", item.value("extractor", "")},
                                  {"kind", item.value("kind", "")},
                                  {"closed", item.value("closed", false)},
                                  {"birth", order[i]},
                                  {"death", nullptr},
                                  {"members", json::array()}});
            json &per_member = tracks[it->second]["members"];
            if (per_member.empty() || per_member.back()["member"] != order[i])
                per_member.push_back(
                    {{"member", order[i]}, {"name", m.name}, {"value", m.value}, {"barriers", json::array()}});
            json entry = detail::barrier_track_entry(item, m.indices.at(b), match_distance[offset[i] + b]);
            if (!m.runs.at(b).empty()) entry["run"] = m.runs[b];
            per_member.back()["barriers"].push_back(std::move(entry));
        }
    }
    for (json &t : tracks) {
        for (json &entry : t["members"]) member_figures(entry);
        const std::size_t last = t["members"].back()["member"];
        const auto at = std::find(order.begin(), order.end(), last);
        if (at + 1 != order.end()) t["death"] = *(at + 1); // the first available member without it
    }
    return tracks;
}

// Whether the closed polygon `xy` encloses (x, y) (even-odd rule).
bool encloses(const std::vector<double> &xy, double x, double y) {
    bool inside = false;
    for (std::size_t i = 0, n = xy.size() / 2, j = n - 1; i < n; j = i++) {
        const double xi = xy[2 * i], yi = xy[2 * i + 1], xj = xy[2 * j], yj = xy[2 * j + 1];
        if ((yi > y) != (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi) inside = !inside;
    }
    return inside;
}

struct Outermost {
    std::size_t barrier = 0, track = 0;
    std::vector<double> xy;
    double cx = 0.0, cy = 0.0;    // the mean of its points
    std::size_t missed = 0;       // members in a row without it since it was last seen (carried across a gap)
    std::size_t first_missed = 0; // the first of them, as a position in `order`
};

// Islands: the regions inside the elliptic extractor's outermost tori ("outermost": true). A generalized KAM torus
// moves with the parameter by more than the matching tolerance, and each member's nested tori are a different
// family of curves, so an island is continued by position instead: two neighbouring members' outermost tori bound the
// same island when each encloses the other's mean point; one to one, the closest mean points first. An island the
// extractor misses in up to `max_gap` members in a row is carried across them (its last torus compared with the next
// members'), as frames' tracks bridge a missed frame: one member where the extractor finds no closed shearline around
// an island that is there again in the next is no breakup. Its `skipped` members say where; its `death` is the first
// member of a gap it does not come back from (or the first member without it at the end of the series).
json continue_islands(const std::vector<ContinuationMember> &members, const std::vector<std::size_t> &order,
                      std::size_t max_gap) {
    json islands = json::array();
    std::vector<Outermost> before;
    for (std::size_t i = 0; i < order.size(); ++i) {
        const std::size_t k = order[i];
        const ContinuationMember &m = members[k];
        std::vector<Outermost> now;
        for (std::size_t b = 0; b < m.barriers.size(); ++b)
            if (m.barriers[b].value("closed", false) && m.barriers[b].value("outermost", false)) {
                Outermost o{b, 0, detail::barrier_points(m.barriers[b])};
                for (std::size_t q = 0; q + 1 < o.xy.size(); q += 2) o.cx += o.xy[q], o.cy += o.xy[q + 1];
                o.cx /= static_cast<double>(o.xy.size() / 2), o.cy /= static_cast<double>(o.xy.size() / 2);
                now.push_back(std::move(o));
            }
        std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;
        for (std::size_t p = 0; p < before.size(); ++p)
            for (std::size_t c = 0; c < now.size(); ++c)
                if (encloses(before[p].xy, now[c].cx, now[c].cy) && encloses(now[c].xy, before[p].cx, before[p].cy))
                    pairs.emplace_back(std::hypot(now[c].cx - before[p].cx, now[c].cy - before[p].cy), p, c);
        std::sort(pairs.begin(), pairs.end());
        std::vector<bool> continued(before.size(), false), reached(now.size(), false);
        for (const auto &[d, p, c] : pairs)
            if (!continued[p] && !reached[c]) {
                continued[p] = reached[c] = true;
                now[c].track = before[p].track;
                for (std::size_t g = 0; g < before[p].missed; ++g) // the members it was carried across
                    islands[now[c].track]["skipped"].push_back(order[before[p].first_missed + g]);
            }
        std::vector<Outermost> carried;
        for (std::size_t p = 0; p < before.size(); ++p) {
            if (continued[p]) continue;
            if (before[p].missed < max_gap) {
                Outermost o = before[p];
                if (o.missed++ == 0) o.first_missed = i;
                carried.push_back(std::move(o));
            } else {
                islands[before[p].track]["death"] = before[p].missed > 0 ? order[before[p].first_missed] : k;
            }
        }
        for (std::size_t c = 0; c < now.size(); ++c) {
            if (!reached[c]) {
                now[c].track = islands.size();
                islands.push_back({{"id", islands.size()},
                                   {"birth", k},
                                   {"death", nullptr},
                                   {"skipped", json::array()},
                                   {"members", json::array()}});
            }
            const json &b = m.barriers[now[c].barrier];
            islands[now[c].track]["members"].push_back(
                {{"member", k},
                 {"name", m.name},
                 {"value", m.value},
                 {"barrier", m.indices.at(now[c].barrier)},
                 {"area", b.value("enclosed_area", std::abs(shoelace_area(now[c].xy)))},
                 {"centre", {now[c].cx, now[c].cy}}});
        }
        before = std::move(now);
        for (Outermost &o : carried) before.push_back(std::move(o));
    }
    for (const Outermost &o : before) // missing at the end of the series: gone from the first member without it
        if (o.missed > 0) islands[o.track]["death"] = order[o.first_missed];
    return islands;
}

// The events of a series, in member order: torus-breakup (a closed barrier's track ends), track-end (an open one's),
// track-split (a track has more barriers than in the member before), island-breakup (an island's last torus is gone),
// tangle-onset (the tangle's crossings count turns from 0 to more).
json series_events(const std::vector<ContinuationMember> &members, const std::vector<std::size_t> &order,
                   const json &tracks, const json &islands) {
    std::vector<std::pair<std::size_t, json>> events;
    for (const json &island : islands)
        if (!island["death"].is_null())
            events.push_back({island["death"],
                              {{"event", "island-breakup"},
                               {"island", island["id"]},
                               {"last_member", island["members"].back()["name"]},
                               {"last_value", island["members"].back()["value"]},
                               {"last_area", island["members"].back()["area"]}}});
    for (const json &t : tracks) {
        const json &per_member = t["members"];
        for (std::size_t i = 1; i < per_member.size(); ++i)
            if (per_member[i]["barriers"].size() > per_member[i - 1]["barriers"].size())
                events.push_back(
                    {per_member[i]["member"],
                     {{"event", "track-split"}, {"track", t["id"]}, {"pieces", per_member[i]["barriers"].size()}}});
        if (t["death"].is_null()) continue;
        const json &last = per_member.back();
        const bool closed = t["closed"].get<bool>() && !last["area"].is_null();
        json e = {{"event", closed ? "torus-breakup" : "track-end"},
                  {"track", t["id"]},
                  {"last_member", last["name"]},
                  {"last_value", last["value"]}};
        if (closed) e["last_area"] = last["area"];
        events.push_back({t["death"], std::move(e)});
    }
    for (std::size_t i = 1, before = 0; i < order.size(); ++i) {
        const ContinuationMember &m = members[order[i]];
        if (!m.tangle_crossings) continue;
        const ContinuationMember &p = members[order[before]];
        if (p.tangle_crossings && *p.tangle_crossings == 0 && *m.tangle_crossings > 0)
            events.push_back({order[i],
                              {{"event", "tangle-onset"},
                               {"crossings", *m.tangle_crossings},
                               {"last_member", p.name},
                               {"last_value", p.value}}});
        before = i;
    }
    std::stable_sort(events.begin(), events.end(), [](const auto &a, const auto &b) { return a.first < b.first; });
    json out = json::array();
    for (auto &[k, e] : events) {
        e["member"] = members[k].name;
        e["value"] = members[k].value;
        out.push_back(std::move(e));
    }
    return out;
}

} // namespace

json continue_series(const std::vector<ContinuationMember> &members, const TrackSettings &settings) {
    std::vector<std::size_t> order;
    for (std::size_t k = 0; k < members.size(); ++k)
        if (members[k].available) order.push_back(k);
    std::vector<std::size_t> offset = {0};
    for (const std::size_t k : order) offset.push_back(offset.back() + members[k].barriers.size());
    detail::TrackComponents components(offset.back());
    std::vector<double> match_distance(offset.back(), NAN);
    for (std::size_t i = 0; i + 1 < order.size(); ++i)
        for (const detail::BarrierMatch &m :
             match_members(members[order[i]], members[order[i + 1]], settings.tolerance)) {
            components.join(offset[i] + m.from, offset[i + 1] + m.to);
            double &d = match_distance[offset[i + 1] + m.to];
            d = std::isnan(d) ? m.distance : std::min(d, m.distance);
        }
    json listed = json::array();
    for (std::size_t k = 0; k < members.size(); ++k) {
        const ContinuationMember &m = members[k];
        listed.push_back({{"member", m.name},
                          {"value", m.value},
                          {"available", m.available},
                          {"barriers", m.barriers.size()},
                          {"tangle_crossings", m.tangle_crossings ? json(*m.tangle_crossings) : json(nullptr)}});
    }
    const json tracks = assemble(members, order, components, offset, match_distance);
    const json islands = continue_islands(members, order, settings.max_gap);
    return {{"members", listed},
            {"tracks", tracks},
            {"islands", islands},
            {"events", series_events(members, order, tracks, islands)}};
}

namespace {

// A sweep's matching rule: the frames' tolerance, and islands carried across up to two members in a row where the
// elliptic extractor finds no outermost torus. On the KAM amplitude sweep it misses the right island's at two
// neighbouring amplitudes (0.14 and 0.16) and finds it again at 0.18 where its centre was heading; an island is
// continued only when each outermost torus encloses the other's mean point, so a gap cannot join two islands.
TrackSettings sweep_track_settings() {
    TrackSettings settings;
    settings.max_gap = 2;
    return settings;
}

json read_json_file(const fs::path &file) {
    std::ifstream in(file);
    if (!in) throw IoError(file.string() + ": cannot read it");
    std::stringstream text;
    text << in.rdbuf();
    return json::parse(text.str());
}

bool both_directions(const json &experiment) {
    return experiment.contains("time") && experiment["time"].is_object() &&
           experiment["time"].value("directions", json()) == "both";
}

// A finished member's barriers (both directions: forward's, then backward's), grid and tangle count.
void read_member(const Sweep &s, const SweepMember &m, const fs::path &folder, ContinuationMember &c) {
    c.grid = parse_experiment(m.experiment, s.relative_to).grid;
    const bool both = both_directions(m.experiment);
    for (const char *run : both ? std::vector<const char *>{"forward", "backward"} : std::vector<const char *>{""}) {
        const json barriers = read_json_file(folder / run / "barriers.json").at("barriers");
        for (std::size_t b = 0; b < barriers.size(); ++b) {
            c.barriers.push_back(barriers[b]);
            c.runs.push_back(run);
            c.indices.push_back(b);
        }
    }
    if (both) {
        const json manifest = read_json_file(folder / "manifest.json");
        const json::json_pointer tangle("/crossings/tangle");
        if (manifest.contains(tangle) && manifest.at(tangle).is_number())
            c.tangle_crossings = manifest.at(tangle).get<long long>();
    }
    c.available = true;
}

// Each island's area (the elliptic extractor's outermost tori, when any), else each closed track's area, else each
// track's length, against the parameter.
bool plot_continuation(const fs::path &file, const json &continuation) {
    bool any_island = false, any_closed = false;
    for (const json &series : continuation["series"]) {
        any_island = any_island || !series["islands"].empty();
        for (const json &t : series["tracks"]) any_closed = any_closed || t["closed"].get<bool>();
    }
    const std::string name = continuation["parameter"]["name"].get<std::string>();
    const char *figure = any_island || any_closed ? "area" : "length";
    XYPlot plot;
    plot.title = any_island   ? "continuation: the area of each island's outermost torus against " + name
                 : any_closed ? "continuation: each closed track's area against " + name
                              : "continuation: each track's length against " + name;
    plot.x_label = name;
    plot.y_label = figure;
    static const char *colors[] = {"blue", "red", "green", "black", "magenta", "cyan", "orange", "brown"};
    for (const json &series : continuation["series"])
        for (const json &t : series[any_island ? "islands" : "tracks"]) {
            if (!any_island && any_closed && !t["closed"].get<bool>()) continue;
            PlotSeries line;
            line.style = PlotSeries::Style::line_points;
            line.color = colors[plot.series.size() % (sizeof colors / sizeof *colors)];
            for (const json &m : t["members"])
                if (m[figure].is_number()) line.xy.insert(line.xy.end(), {m["value"], m[figure]});
            if (!line.xy.empty()) plot.series.push_back(std::move(line));
        }
    if (plot.series.empty()) return false;
    plot_xy_png(file, plot);
    return true;
}

// The events as lines for summary.md.
std::string events_markdown(const json &continuation) {
    const std::string name = continuation["parameter"]["name"].get<std::string>();
    std::string md = "\n## Continuation over " + name + " (continuation.json)\n\n";
    std::size_t count = 0;
    for (const json &series : continuation["series"]) {
        const json &events = series["events"];
        for (std::size_t i = 0; i < events.size(); ++i) {
            const json &e = events[i];
            // A member's torus-breakups in one line: a generalized KAM torus family is replaced as a whole (the
            // islands say what persists).
            std::size_t tori = 1;
            while (e["event"] == "torus-breakup" && i + tori < events.size() &&
                   events[i + tori]["event"] == "torus-breakup" && events[i + tori]["member"] == e["member"])
                ++tori;
            md += fmt::format("- {} at {} ({} = {})", e["event"].get<std::string>(), e["member"].get<std::string>(),
                              name, e["value"].dump());
            if (tori > 1)
                md += fmt::format(", {} tracks", tori);
            else if (e.contains("track"))
                md += fmt::format(", track {}", e["track"].dump());
            if (e.contains("island")) md += fmt::format(", island {}", e["island"].dump());
            if (e.contains("last_value")) md += fmt::format(", last seen at {}", e["last_value"].dump());
            if (e.contains("crossings")) md += fmt::format(", {} crossings", e["crossings"].dump());
            md += "\n";
            count += tori;
            i += tori - 1;
        }
    }
    return count ? md : md + "No events.\n";
}

} // namespace

std::vector<fs::path> write_continuation(const Sweep &s, const fs::path &out,
                                         const std::vector<SweepMemberResult> &results) {
    if (!s.base.contains("extractors") || !s.base["extractors"].is_array() || s.base["extractors"].empty() ||
        s.parameters.empty())
        return {}; // no barriers to continue
    const std::size_t x = s.plot_figure.empty() ? s.parameters.size() - 1 : s.plot_parameter;
    const SweepParameter &p = s.parameters[x];
    for (const json &v : p.values)
        if (!v.is_number()) return {}; // a parameter without an order has no neighbours
    json all = json::array();
    std::vector<ContinuationMember> series;
    const auto others_equal = [&](const SweepMember &a, const SweepMember &b) {
        for (std::size_t q = 0; q < s.parameters.size(); ++q)
            if (q != x && s.parameters[q].values[a.choice[q]] != s.parameters[q].values[b.choice[q]]) return false;
        return true;
    };
    const TrackSettings settings = sweep_track_settings();
    const auto flush = [&](std::size_t first) {
        json fixed = json::object();
        for (std::size_t q = 0; q < s.parameters.size(); ++q)
            if (q != x) fixed[s.parameters[q].name] = s.parameters[q].values[s.members[first].choice[q]];
        json one = continue_series(series, settings);
        one["fixed"] = fixed;
        all.push_back(std::move(one));
        series.clear();
    };
    std::size_t first = 0;
    for (std::size_t k = 0; k < s.members.size(); ++k) {
        const SweepMember &m = s.members[k];
        if (k > 0 && !others_equal(m, s.members[k - 1])) flush(first), first = k;
        ContinuationMember c;
        c.name = m.name;
        c.value = p.values[m.choice[x]].get<double>();
        if (results[k].status == "done" || results[k].status == "reused") {
            try {
                read_member(s, m, out / m.name, c);
            } catch (const std::exception &e) { // a member without barriers is a gap in the series, not a failure
                spdlog::warn("continuation: {} left out ({})", m.name, e.what());
                const double value = c.value;
                c = ContinuationMember();
                c.name = m.name;
                c.value = value;
            }
        }
        series.push_back(std::move(c));
    }
    flush(first);
    const json continuation = {{"parameter", {{"name", p.name}, {"path", p.path}}},
                               {"tolerance_grid_spacings", settings.tolerance},
                               {"island_max_gap_members", settings.max_gap},
                               {"distance",
                                "between neighbouring members' barriers (same t0, no advection): the frames' rule "
                                "(docs/experiment-format.md, Frames), in grid spacings of the later member"},
                               {"series", all}};
    std::vector<fs::path> files = {out / "continuation.json"};
    write_text_file(files[0], continuation.dump(1) + "\n");
    std::ofstream(out / "summary.md", std::ios::app) << events_markdown(continuation);
    if (!s.plot_figure.empty()) {
        if (plot_continuation(out / "continuation.png", continuation)) files.push_back(out / "continuation.png");
    }
    return files;
}

} // namespace geobarrier
