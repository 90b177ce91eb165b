// The experiment's "validation" object (docs/experiment-format.md, "validation"): reading it into a ValidationSpec
// with the experiment file's rules (every error names the JSON path, the value and the rule) and writing it back
// with every default filled in, for the manifest.
#include <geobarrier/errors.hpp>
#include <geobarrier/validation.hpp>

#include <cmath>
#include <tuple>

#include "diagnostics/validation_internal.hpp"
#include "experiment/json_reader.hpp"

using nlohmann::json;

namespace geobarrier {

namespace {

using detail::short_dump;
// The experiment file's reader: the same rules and messages everywhere.
using Reader = detail::ObjectReader;

std::array<double, 2> read_point(const json &v, const std::string &path) {
    if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number())
        throw ConfigError(path, short_dump(v) + " must be a point [x, y]");
    const std::array<double, 2> p{v[0].get<double>(), v[1].get<double>()};
    if (!std::isfinite(p[0]) || !std::isfinite(p[1])) throw ConfigError(path, short_dump(v) + " is not finite");
    return p;
}

std::vector<std::array<double, 2>> read_points(const json &v, const std::string &path) {
    if (!v.is_array() || v.empty()) throw ConfigError(path, short_dump(v) + " must be a non-empty array of [x, y]");
    std::vector<std::array<double, 2>> out;
    for (std::size_t i = 0; i < v.size(); ++i) out.push_back(read_point(v[i], path + "/" + std::to_string(i)));
    return out;
}

// An array of at least `min_size` finite numbers: `what` names the array, `item` one entry, in messages.
std::vector<double> read_numbers(const json &v, const std::string &path, std::size_t min_size, const std::string &what,
                                 const std::string &item) {
    if (!v.is_array() || v.size() < min_size) throw ConfigError(path, short_dump(v) + " must be " + what);
    std::vector<double> out;
    for (std::size_t i = 0; i < v.size(); ++i) {
        if (!v[i].is_number() || !std::isfinite(v[i].get<double>()))
            throw ConfigError(path + "/" + std::to_string(i), short_dump(v[i]) + " must be a finite " + item);
        out.push_back(v[i].get<double>());
    }
    return out;
}

std::vector<double> read_times(const json &v, const std::string &path) {
    return read_numbers(v, path, 1, "a non-empty array of times", "time");
}

// [lo, hi] with lo <= hi (equal is allowed: a lattice of one column).
std::pair<double, double> read_range(const Reader &r, const std::string &key) {
    const json &v = r.get(key);
    if (!v.is_array() || v.size() != 2 || !v[0].is_number() || !v[1].is_number())
        throw ConfigError(r.child(key), short_dump(v) + " must be an array of two numbers [min, max]");
    const double lo = v[0].get<double>(), hi = v[1].get<double>();
    if (!std::isfinite(lo) || !std::isfinite(hi) || lo > hi)
        throw ConfigError(r.child(key), short_dump(v) + " must satisfy min <= max (finite)");
    return {lo, hi};
}

constexpr std::size_t max_seeds = 10000000;

SeedLattice read_lattice(const json &v, const std::string &path) {
    Reader r(v, path);
    SeedLattice l;
    std::tie(l.x_min, l.x_max) = read_range(r, "x");
    std::tie(l.y_min, l.y_max) = read_range(r, "y");
    const json &n = r.get("n");
    if (!n.is_array() || n.size() != 2 || !n[0].is_number_integer() || !n[1].is_number_integer() ||
        n[0].get<long long>() < 1 || n[1].get<long long>() < 1)
        throw ConfigError(r.child("n"), short_dump(n) + " must be two integers [nx, ny], each at least 1");
    l.nx = n[0].get<std::size_t>();
    l.ny = n[1].get<std::size_t>();
    if (l.nx * l.ny > max_seeds)
        throw ConfigError(r.child("n"), short_dump(n) + " gives more than " + std::to_string(max_seeds) + " points");
    r.finish();
    return l;
}

SeedDisc read_disc(const json &v, const std::string &path) {
    Reader r(v, path);
    SeedDisc d;
    const std::array<double, 2> c = read_point(r.get("center"), r.child("center"));
    d.center_x = c[0];
    d.center_y = c[1];
    d.radius = r.number("radius");
    if (!(d.radius > 0.0)) throw ConfigError(r.child("radius"), short_dump(r.get("radius")) + " must be > 0");
    d.n = r.count("n", 0, 1, max_seeds);
    if (!r.has("n")) r.get("n");
    r.finish();
    return d;
}

TracerCloudSpec read_cloud(const json &v, const std::string &path) {
    Reader r(v, path);
    TracerCloudSpec c;
    if (r.has("box")) c.box = read_lattice(r.get("box"), r.child("box"));
    if (r.has("disc")) c.disc = read_disc(r.get("disc"), r.child("disc"));
    if (c.box.has_value() == c.disc.has_value())
        throw ConfigError(path, "give the cloud as exactly one of \"box\": {\"x\", \"y\", \"n\"} or "
                                "\"disc\": {\"center\", \"radius\", \"n\"}");
    c.release = r.optional_number("release");
    if (r.has("times")) c.times = read_times(r.get("times"), r.child("times"));
    r.finish();
    return c;
}

// "barriers": "all" | "outermost" | [indices]: which found barriers a product works on.
void read_barrier_choice(const Reader &r, std::string &which, std::vector<std::size_t> &indices) {
    if (!r.has("barriers")) return;
    const json &b = r.get("barriers");
    if (b.is_string()) {
        which = b.get<std::string>();
        if (which != "all" && which != "outermost")
            throw ConfigError(r.child("barriers"), "\"" + which +
                                                       "\" is not one of: \"all\" \"outermost\" (or give an array "
                                                       "of barrier indices)");
    } else if (b.is_array() && !b.empty()) {
        which = "indices";
        for (std::size_t i = 0; i < b.size(); ++i) {
            if (!b[i].is_number_integer() || b[i].get<long long>() < 0)
                throw ConfigError(r.child("barriers") + "/" + std::to_string(i),
                                  short_dump(b[i]) + " must be a barrier index (an integer >= 0)");
            indices.push_back(b[i].get<std::size_t>());
        }
    } else {
        throw ConfigError(r.child("barriers"),
                          short_dump(b) + " must be \"all\", \"outermost\" or a non-empty array of barrier indices");
    }
}

// Either `true` (every default) or an object.
bool enabled_or_object(const json &v, const std::string &path) {
    if (v.is_boolean()) {
        if (!v.get<bool>())
            throw ConfigError(path, "false: leave the key out instead, or give true or an object of settings");
        return false;
    }
    if (!v.is_object()) throw ConfigError(path, short_dump(v) + " must be true or an object of settings");
    return true;
}

// The "section" product: the plane (one normal entry per state component), the direction and whole-state seeds.
SectionSpec read_section(const json &v, const std::string &path) {
    Reader r(v, path);
    SectionSpec s;
    const auto numbers = [](const json &a, const std::string &where, const char *what) {
        return read_numbers(a, where, 2, std::string(what) + " (an array of numbers, one per state component)",
                            "number");
    };
    s.normal = numbers(r.get("normal"), r.child("normal"), "the plane's normal");
    if (std::all_of(s.normal.begin(), s.normal.end(), [](double v) { return v == 0.0; }))
        throw ConfigError(r.child("normal"), "is zero; the plane needs a normal");
    s.offset = r.number("offset", 0.0);
    const double direction = r.number("direction", 1.0);
    if (direction != 1.0 && direction != -1.0 && direction != 0.0)
        throw ConfigError(r.child("direction"), short_dump(r.get("direction")) +
                                                    " must be 1 (normal . x "
                                                    "increasing), -1 (decreasing) or 0 (both)");
    s.direction = static_cast<int>(direction);
    const json &seeds = r.get("seeds");
    if (!seeds.is_array() || seeds.empty())
        throw ConfigError(r.child("seeds"), short_dump(seeds) + " must be a non-empty array of whole states");
    for (std::size_t i = 0; i < seeds.size(); ++i) {
        const std::string where = r.child("seeds") + "/" + std::to_string(i);
        s.seeds.push_back(numbers(seeds[i], where, "a whole state"));
        if (s.seeds.back().size() != s.normal.size())
            throw ConfigError(where, "has " + std::to_string(s.seeds.back().size()) +
                                         " components and the "
                                         "normal " +
                                         std::to_string(s.normal.size()));
    }
    s.t_start = r.optional_number("t_start");
    s.t_end = r.optional_number("t_end");
    s.crossings = r.count("crossings", s.crossings, 1, 10000000);
    s.sample = r.positive("sample", s.sample);
    r.finish();
    return s;
}

} // namespace

ValidationSpec parse_validation(const json &j, const std::string &path) {
    Reader root(j, path);
    ValidationSpec spec;
    if (root.has("poincare")) {
        Reader r(root.get("poincare"), root.child("poincare"));
        PoincareSpec p;
        p.period = r.number("period");
        if (!(p.period > 0.0)) throw ConfigError(r.child("period"), short_dump(r.get("period")) + " must be > 0");
        p.iterations = r.count("iterations", p.iterations, 1, 1000000);
        p.t_start = r.optional_number("t_start");
        if (r.has("seeds")) p.seeds = read_points(r.get("seeds"), r.child("seeds"));
        if (r.has("lattice")) p.lattice = read_lattice(r.get("lattice"), r.child("lattice"));
        p.barrier_points = r.count("barrier_points", 0, 0, 100000);
        read_barrier_choice(r, p.which, p.indices);
        r.finish();
        if (p.seeds.empty() && !p.lattice && p.barrier_points == 0)
            throw ConfigError(root.child("poincare"),
                              "no seeds: give \"seeds\": [[x, y], ...], a \"lattice\" or \"barrier_points\" > 0");
        spec.poincare = p;
    }
    if (root.has("section")) spec.section = read_section(root.get("section"), root.child("section"));
    if (root.has("tracers")) {
        const json &t = root.get("tracers");
        if (t.is_array()) {
            if (t.empty()) throw ConfigError(root.child("tracers"), "[] is empty; give at least one cloud");
            for (std::size_t i = 0; i < t.size(); ++i)
                spec.tracers.push_back(read_cloud(t[i], root.child("tracers") + "/" + std::to_string(i)));
        } else {
            spec.tracers.push_back(read_cloud(t, root.child("tracers")));
        }
    }
    if (root.has("trajectories")) {
        Reader r(root.get("trajectories"), root.child("trajectories"));
        TrajectoriesSpec s;
        s.states = read_points(r.get("states"), r.child("states"));
        s.t_start = r.optional_number("t_start");
        s.t_end = r.optional_number("t_end");
        s.samples = r.count("samples", s.samples, 2, 10000000);
        if (s.t_start && s.t_end && *s.t_start == *s.t_end)
            throw ConfigError(r.child("t_end"), "equals t_start; the interval must have nonzero length");
        r.finish();
        spec.trajectories = s;
    }
    if (root.has("forcing")) {
        ForcingSpec s;
        if (enabled_or_object(root.get("forcing"), root.child("forcing"))) {
            Reader r(root.get("forcing"), root.child("forcing"));
            s.t_start = r.optional_number("t_start");
            s.t_end = r.optional_number("t_end");
            s.samples = r.count("samples", s.samples, 2, 100000000);
            if (s.t_start && s.t_end && *s.t_start == *s.t_end)
                throw ConfigError(r.child("t_end"), "equals t_start; the interval must have nonzero length");
            r.finish();
        }
        spec.forcing = s;
    }
    if (root.has("advect_barriers")) {
        AdvectBarriersSpec s;
        if (enabled_or_object(root.get("advect_barriers"), root.child("advect_barriers"))) {
            Reader r(root.get("advect_barriers"), root.child("advect_barriers"));
            if (r.has("times")) s.times = read_times(r.get("times"), r.child("times"));
            s.samples = r.count("samples", s.samples, 2, 100000);
            if (r.has("times") && r.has("samples"))
                throw ConfigError(r.child("samples"), "give either \"times\" or \"samples\", not both");
            if (r.has("max_gap")) {
                s.max_gap = r.number("max_gap");
                if (!(s.max_gap > 0.0 && s.max_gap <= 0.5))
                    throw ConfigError(r.child("max_gap"), short_dump(r.get("max_gap")) +
                                                              " must be in (0, 0.5] (a fraction of the curve's size)");
            }
            s.tube = r.boolean("tube", s.tube);
            s.tube_columns = r.count("tube_columns", s.tube_columns, 8, 100000);
            s.tube_rows = r.count("tube_rows", s.tube_rows, 2, 100000);
            read_barrier_choice(r, s.which, s.indices);
            r.finish();
        }
        spec.advect_barriers = s;
    }
    root.finish();
    if (spec.empty())
        throw ConfigError(path, "{} asks for nothing; give one of poincare, section, tracers, trajectories, forcing, "
                                "advect_barriers");
    return spec;
}

namespace {

json lattice_json(const SeedLattice &l) {
    return {{"x", {l.x_min, l.x_max}}, {"y", {l.y_min, l.y_max}}, {"n", {l.nx, l.ny}}};
}

json points_json(const std::vector<std::array<double, 2>> &points) {
    json out = json::array();
    for (const auto &p : points) out.push_back({p[0], p[1]});
    return out;
}

} // namespace

json validation_to_json(const ValidationSpec &spec, double t0, double t1) {
    using validation_detail::default_times;
    json out = json::object();
    if (spec.poincare) {
        const PoincareSpec &p = *spec.poincare;
        json j = {{"period", p.period},
                  {"iterations", p.iterations},
                  {"t_start", p.t_start.value_or(t0)},
                  {"barrier_points", p.barrier_points},
                  {"barriers", p.which == "indices" ? json(p.indices) : json(p.which)}};
        if (!p.seeds.empty()) j["seeds"] = points_json(p.seeds);
        if (p.lattice) j["lattice"] = lattice_json(*p.lattice);
        out["poincare"] = j;
    }
    if (spec.section) {
        const SectionSpec &s = *spec.section;
        out["section"] = {{"normal", s.normal},
                          {"offset", s.offset},
                          {"direction", s.direction},
                          {"seeds", s.seeds},
                          {"t_start", s.t_start.value_or(t0)},
                          {"t_end", s.t_end.value_or(t1)},
                          {"crossings", s.crossings},
                          {"sample", s.sample}};
    }
    if (!spec.tracers.empty()) {
        json clouds = json::array();
        for (const TracerCloudSpec &c : spec.tracers) {
            json j = {{"release", c.release.value_or(t0)},
                      {"times", c.times.empty() ? std::vector<double>{t1} : c.times}};
            if (c.box) j["box"] = lattice_json(*c.box);
            if (c.disc)
                j["disc"] = {
                    {"center", {c.disc->center_x, c.disc->center_y}}, {"radius", c.disc->radius}, {"n", c.disc->n}};
            clouds.push_back(j);
        }
        out["tracers"] = clouds;
    }
    if (spec.trajectories) {
        const TrajectoriesSpec &s = *spec.trajectories;
        out["trajectories"] = {{"states", points_json(s.states)},
                               {"t_start", s.t_start.value_or(t0)},
                               {"t_end", s.t_end.value_or(t1)},
                               {"samples", s.samples}};
    }
    if (spec.forcing)
        out["forcing"] = {{"t_start", spec.forcing->t_start.value_or(t0)},
                          {"t_end", spec.forcing->t_end.value_or(t1)},
                          {"samples", spec.forcing->samples}};
    if (spec.advect_barriers) {
        const AdvectBarriersSpec &s = *spec.advect_barriers;
        json which = s.which == "indices" ? json(s.indices) : json(s.which);
        out["advect_barriers"] = {{"times", default_times(s, t0, t1)}, {"max_gap", s.max_gap},     {"tube", s.tube},
                                  {"tube_columns", s.tube_columns},    {"tube_rows", s.tube_rows}, {"barriers", which}};
    }
    return out;
}

} // namespace geobarrier
