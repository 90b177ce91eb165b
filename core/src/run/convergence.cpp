// "convergence": the changed runs' experiments and the persistence of each barrier under them (convergence.hpp).
#include "run/convergence.hpp"
#include "run/barrier_matching.hpp"

#include <geobarrier/curves.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/segment_index.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace geobarrier {

using nlohmann::json;

double detail::barrier_share_near(const std::vector<double> &xy, bool closed, const SegmentIndex &others,
                                  double distance) {
    const std::size_t n = xy.size() / 2;
    if (n < 2 || others.segments().empty() || !(distance > 0)) return 0.0;
    const double piece = distance / 4.0;
    double near = 0.0, total = 0.0;
    for (std::size_t k = 0; k < (closed && n > 2 ? n : n - 1); ++k) {
        const std::size_t next = (k + 1) % n;
        const double ax = xy[2 * k], ay = xy[2 * k + 1], dx = xy[2 * next] - ax, dy = xy[2 * next + 1] - ay;
        const double length = std::hypot(dx, dy);
        if (!(length > 0)) continue;
        const auto parts = static_cast<std::size_t>(std::max(1.0, std::ceil(length / piece)));
        const double w = length / static_cast<double>(parts);
        for (std::size_t p = 0; p < parts; ++p) {
            const double f = (static_cast<double>(p) + 0.5) / static_cast<double>(parts);
            total += w;
            // Asked with twice the distance: SegmentIndex::distance answers r itself when nothing is nearer.
            if (others.distance(ax + f * dx, ay + f * dy, 2.0 * distance) <= distance) near += w;
        }
    }
    return total > 0 ? near / total : 0.0;
}

namespace {

// The JSON path of factor k of "grid" or "horizon": the key itself when one factor was given as a number.
std::string factor_path(const json &section, const std::string &key, std::size_t k) {
    const std::string path = "/convergence/" + key;
    return section.at(key).is_array() ? path + "/" + std::to_string(k) : path;
}

// The experiment as written without what the changed runs do not repeat: the convergence check itself, the validation
// products and the field products (a changed run keeps its barriers only).
json changed_base(const Experiment &e) {
    json source = e.source;
    source.erase("convergence");
    source.erase("validation");
    source.erase("products");
    return source;
}

// Parses the changed experiment; its errors come out at the change's JSON path, saying what the change made.
void check_parses(const detail::ConvergenceChange &c, const Experiment &e) {
    try {
        (void)parse_experiment(c.source, e.file);
    } catch (const ConfigError &error) {
        throw ConfigError(c.json_path, "the changed run " + c.label + " is not a valid experiment: " + error.what());
    }
}

// The changed run with extractor_keys[k] set in every extractor of r that declares each key.
detail::ConvergenceChange extractor_keys_change(const ResolvedExperiment &r, const json &keys, std::size_t k) {
    detail::ConvergenceChange c{"extractor_keys " + keys.dump(), "/convergence/extractor_keys/" + std::to_string(k),
                                changed_base(r.experiment), true};
    for (const auto &[key, value] : keys.items()) {
        bool declared = false;
        std::vector<std::string> names;
        for (std::size_t x = 0; x < r.extractors.size(); ++x) {
            const PluginInfo &info = r.extractors[x].info();
            for (const ParamSpec &p : info.params) names.push_back(p.name);
            if (std::none_of(info.params.begin(), info.params.end(), [&](const ParamSpec &p) { return p.name == key; }))
                continue;
            declared = true;
            json &use = c.source["extractors"][x];
            json &params = use["params"];
            if (!params.is_object()) params = json::object();
            params[key] = value;
            try {
                (void)validate_params(info, params, "/extractors/" + std::to_string(x) + "/params");
            } catch (const ConfigError &error) {
                throw ConfigError(c.json_path + "/" + key,
                                  "extractor '" + info.name + "' does not take this value: " + error.what());
            }
        }
        if (!declared) {
            const std::string hint = did_you_mean(key, names);
            throw ConfigError(c.json_path + "/" + key,
                              "no extractor of this experiment declares this key" +
                                  (hint.empty() ? std::string(" (geobarrier plugins lists each one's keys)")
                                                : "; did you mean \"" + hint + "\"?"));
        }
    }
    return c;
}

} // namespace

std::vector<detail::ConvergenceChange> detail::convergence_changes(const ResolvedExperiment &r) {
    const Experiment &e = r.experiment;
    std::vector<ConvergenceChange> changes;
    if (!e.convergence) return changes;
    const ConvergenceSpec &spec = *e.convergence;
    const json &section = e.source.at("convergence");
    for (std::size_t k = 0; k < spec.grid.size(); ++k) {
        // The grid's intervals scaled, as scripts/barrier_suite.py's refinements do: n - 1 -> round((n - 1) f).
        const auto scaled = [&](std::size_t n) {
            return static_cast<long long>(std::llround(static_cast<double>(n - 1) * spec.grid[k])) + 1;
        };
        ConvergenceChange c{fmt::format("grid x{:g} ({} x {})", spec.grid[k], scaled(e.grid.nx), scaled(e.grid.ny)),
                            factor_path(section, "grid", k), changed_base(e), false};
        c.source["grid"]["n"] = {scaled(e.grid.nx), scaled(e.grid.ny)};
        check_parses(c, e);
        changes.push_back(std::move(c));
    }
    for (std::size_t k = 0; k < spec.horizon.size(); ++k) {
        const double horizon = spec.horizon[k] * (e.t1 - e.t0);
        ConvergenceChange c{fmt::format("horizon x{:g} (T = {:g})", spec.horizon[k], horizon),
                            factor_path(section, "horizon", k), changed_base(e), false};
        json &time = c.source["time"];
        if (time.contains("T"))
            time["T"] = horizon; // frames (one horizon for every initial time) or a single t0 with T
        else
            time["t1"] = e.t0 + horizon;
        check_parses(c, e);
        changes.push_back(std::move(c));
    }
    for (std::size_t k = 0; k < spec.extractor_keys.size(); ++k) {
        ConvergenceChange c = extractor_keys_change(r, spec.extractor_keys[k], k);
        check_parses(c, e);
        changes.push_back(std::move(c));
    }
    return changes;
}

json detail::mark_convergence(json &items, const std::vector<ConvergenceChange> &changes,
                              const std::vector<json> &changed_barriers, json runs, const Grid &grid,
                              const ConvergenceSpec &spec, std::vector<std::string> &warnings) {
    const double distance = spec.spacings * std::max(grid.dx(), grid.dy());
    json not_converged = json::array();
    for (std::size_t b = 0; b < items.size(); ++b) {
        json &item = items[b];
        const std::vector<double> xy = barrier_points(item);
        const bool closed = item.value("closed", false);
        json persistence = json::array();
        std::string lost;
        for (std::size_t c = 0; c < changes.size(); ++c) {
            // The changed run's barriers of the same family: a repelling barrier is not reproduced by an attracting
            // one, nor a hyperbolic barrier by an elliptic one that lies along it.
            std::vector<Segment> segments;
            for (const json &other : changed_barriers[c]) {
                if (!same_family(item, other)) continue;
                const std::vector<double> o = barrier_points(other);
                append_polyline_segments(o.data(), o.size() / 2, other.value("closed", false), 0, segments);
            }
            const double share =
                segments.empty()
                    ? 0.0
                    : barrier_share_near(xy, closed, SegmentIndex(std::move(segments), distance), distance);
            persistence.push_back({{"change", changes[c].label}, {"share", share}});
            if (share < spec.threshold)
                lost += fmt::format("{}{}: {:.2f}", lost.empty() ? "" : ", ", changes[c].label, share);
        }
        item["persistence"] = persistence;
        item["converged"] = lost.empty();
        if (lost.empty()) continue;
        not_converged.push_back(b);
        // "hyperbolic", "elliptic closed", ...: the extractor, its kind where that says more, and the rank if given.
        const std::string extractor = item.value("extractor", ""), kind = item.value("kind", "");
        const std::string what =
            extractor + (kind.empty() || kind == extractor ? "" : " " + kind) +
            (item.contains("rank") && item["rank"].is_number() ? fmt::format(", rank {:g}", item["rank"].get<double>())
                                                               : "");
        warnings.push_back(fmt::format("barrier {} ({}, {:.3g} long) does not persist: less than {:g} of its length "
                                       "within {:g} grid spacings of the changed run's barriers under {}",
                                       b, what, polyline_length(xy, closed), spec.threshold, spec.spacings, lost));
    }
    return {{"threshold", spec.threshold},   {"spacings", spec.spacings},
            {"distance", distance},          {"runs", std::move(runs)},
            {"barriers", items.size()},      {"converged", items.size() - not_converged.size()},
            {"not_converged", not_converged}};
}

json detail::total_convergence(const std::vector<std::pair<std::string, json>> &runs) {
    json total, by_run = json::array();
    std::size_t barriers = 0, converged = 0;
    for (const auto &[run, c] : runs) {
        if (!c.is_object()) continue;
        if (total.is_null()) total = {{"threshold", c.at("threshold")}, {"spacings", c.at("spacings")}};
        barriers += c.at("barriers").get<std::size_t>();
        converged += c.at("converged").get<std::size_t>();
        by_run.push_back({{"run", run},
                          {"barriers", c.at("barriers")},
                          {"converged", c.at("converged")},
                          {"not_converged", c.at("not_converged")}});
    }
    if (total.is_null()) return total;
    total["barriers"] = barriers;
    total["converged"] = converged;
    total["runs"] = std::move(by_run);
    return total;
}

} // namespace geobarrier
