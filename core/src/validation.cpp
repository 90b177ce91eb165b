// Validation products (paper section 3): period-map iterates, tracer clouds, trajectories, the forcing, and
// barriers advected with adaptive point insertion (their length, delta_l of eq. `rel_def`, enclosed area and
// their tube in extended phase space). Reading the "validation" object of an experiment, computing, and writing
// CSV files, pictures and a VTK file, each atomically.
#include <geobarrier/curves.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/output.hpp>
#include <geobarrier/validation.hpp>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <numeric>
#include <set>
#include <sstream>

#include "json_reader.hpp"

namespace fs = std::filesystem;
using nlohmann::json;

namespace geobarrier {

namespace {

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

// ------------------------------------------------------------------------------------------------ reading JSON

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

std::vector<double> read_times(const json &v, const std::string &path) {
    if (!v.is_array() || v.empty()) throw ConfigError(path, short_dump(v) + " must be a non-empty array of times");
    std::vector<double> out;
    for (std::size_t i = 0; i < v.size(); ++i) {
        if (!v[i].is_number() || !std::isfinite(v[i].get<double>()))
            throw ConfigError(path + "/" + std::to_string(i), short_dump(v[i]) + " must be a finite time");
        out.push_back(v[i].get<double>());
    }
    return out;
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

// Times and coordinates in titles and legends: four significant digits read well (t = 3.142, not 3.14159).
std::string fmt_g(double v) { return fmt::format("{:.4g}", v); }

// ------------------------------------------------------------------------------------------------ CSV

// Full precision, so a CSV round-trips the doubles it holds; non-finite values are written as empty fields.
std::string csv_number(double v) {
    if (!std::isfinite(v)) return "";
    return fmt::format("{:.17g}", v);
}

// ------------------------------------------------------------------------------------------------ pictures

// The colours used across every validation picture: barriers red, data (iterates, tracers, forcing) blue, and a
// palette without red for several series of data.
const char *barrier_color = "red";
const char *data_color = "blue";
const std::vector<std::string> &series_palette() {
    static const std::vector<std::string> palette{"blue",  "green", "orange", "purple", "cyan",
                                                  "brown", "magenta", "pink", "grey",  "black"};
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
    for (int c = 0; c < 3; ++c)
        rgb[c] = static_cast<int>(std::lround(stops[i][c] * (1 - f) + stops[i + 1][c] * f));
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
        if (k == 0) s.label = barriers.size() == 1 && label.rfind("barriers", 0) == 0 ? "barrier" + label.substr(8) : label;
        out.push_back(std::move(s));
    }
    return out;
}

bool same_time(double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(1.0, std::max(std::abs(a), std::abs(b))); }

std::string barrier_attribute(const Barrier &b, const std::string &name) {
    for (const auto &[key, value] : b.attributes)
        if (key == name) return value;
    return "";
}

// The closed elliptic barriers that bound the regular regions: those marked outermost, or all closed elliptic
// ones when the extractor marked none.
std::vector<const Barrier *> outermost_elliptic(const std::vector<Barrier> &barriers) {
    std::vector<const Barrier *> closed, outermost;
    for (const Barrier &b : barriers) {
        if (b.kind != "elliptic" || !b.closed || b.xy.size() < 6) continue;
        closed.push_back(&b);
        if (barrier_attribute(b, "outermost") == "true") outermost.push_back(&b);
    }
    return outermost.empty() ? closed : outermost;
}

class ProductTimer {
  public:
    explicit ProductTimer(json &summary) : m_summary(summary) {}
    ~ProductTimer() {
        m_summary["wall_seconds"] =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
    }

  private:
    json &m_summary;
    std::chrono::steady_clock::time_point m_start = std::chrono::steady_clock::now();
};

}  // namespace

// ------------------------------------------------------------------------------------------------ parsing

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
        throw ConfigError(path, "{} asks for nothing; give one of poincare, tracers, trajectories, forcing, "
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

std::vector<double> default_times(const AdvectBarriersSpec &spec, double t0, double t1) {
    if (!spec.times.empty()) return spec.times;
    std::vector<double> times;
    for (std::size_t k = 0; k < spec.samples; ++k)
        times.push_back(t0 + (t1 - t0) * static_cast<double>(k) / static_cast<double>(spec.samples - 1));
    return times;
}

std::vector<double> even_times(double a, double b, std::size_t n) {
    std::vector<double> times(n);
    for (std::size_t k = 0; k < n; ++k) times[k] = a + (b - a) * static_cast<double>(k) / static_cast<double>(n - 1);
    return times;
}

}  // namespace

json validation_to_json(const ValidationSpec &spec, double t0, double t1) {
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
    if (!spec.tracers.empty()) {
        json clouds = json::array();
        for (const TracerCloudSpec &c : spec.tracers) {
            json j = {{"release", c.release.value_or(t0)}, {"times", c.times.empty() ? std::vector<double>{t1} : c.times}};
            if (c.box) j["box"] = lattice_json(*c.box);
            if (c.disc)
                j["disc"] = {{"center", {c.disc->center_x, c.disc->center_y}}, {"radius", c.disc->radius}, {"n", c.disc->n}};
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
        out["advect_barriers"] = {{"times", default_times(s, t0, t1)}, {"max_gap", s.max_gap}, {"tube", s.tube},
                                  {"tube_columns", s.tube_columns}, {"tube_rows", s.tube_rows}, {"barriers", which}};
    }
    return out;
}

// ------------------------------------------------------------------------------------------------ building blocks

std::vector<double> lattice_points(const SeedLattice &l) {
    std::vector<double> xy;
    xy.reserve(2 * l.nx * l.ny);
    auto coord = [](double lo, double hi, std::size_t k, std::size_t n) {
        return n == 1 ? 0.5 * (lo + hi) : lo + (hi - lo) * static_cast<double>(k) / static_cast<double>(n - 1);
    };
    for (std::size_t i = 0; i < l.ny; ++i)
        for (std::size_t j = 0; j < l.nx; ++j) {
            xy.push_back(coord(l.x_min, l.x_max, j, l.nx));
            xy.push_back(coord(l.y_min, l.y_max, i, l.ny));
        }
    return xy;
}

std::vector<double> disc_points(const SeedDisc &d) {
    const double golden_angle = M_PI * (3.0 - std::sqrt(5.0));
    std::vector<double> xy;
    xy.reserve(2 * d.n);
    for (std::size_t k = 0; k < d.n; ++k) {
        const double r = d.radius * std::sqrt((static_cast<double>(k) + 0.5) / static_cast<double>(d.n));
        const double a = golden_angle * static_cast<double>(k);
        xy.push_back(d.center_x + r * std::cos(a));
        xy.push_back(d.center_y + r * std::sin(a));
    }
    return xy;
}

bool point_in_polygon(double x, double y, const std::vector<double> &xy) {
    const std::size_t n = xy.size() / 2;
    if (n < 3) return false;
    bool inside = false;
    for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
        const double xi = xy[2 * i], yi = xy[2 * i + 1], xj = xy[2 * j], yj = xy[2 * j + 1];
        // Edges that straddle the horizontal line through y (half-open, so a vertex is counted once) and cross
        // it to the right of x.
        if ((yi > y) != (yj > y) && x < xj + (y - yj) * (xi - xj) / (yi - yj)) inside = !inside;
    }
    return inside;
}

Snapshots advect_snapshots(const Dynamics &dynamics, const IntegratorSettings &settings,
                           const std::optional<Bounds> &bounds, const std::vector<double> &xy, double t_from,
                           const std::vector<double> &times) {
    const std::size_t n = xy.size() / 2;
    Snapshots out;
    out.positions.assign(times.size(), std::vector<double>());
    std::vector<bool> masked(n, false);
    // Forward chain (times >= t_from, ascending), then backward chain (times < t_from, descending).
    std::vector<std::size_t> forward, backward;
    for (std::size_t k = 0; k < times.size(); ++k) (times[k] >= t_from ? forward : backward).push_back(k);
    std::sort(forward.begin(), forward.end(), [&](std::size_t a, std::size_t b) { return times[a] < times[b]; });
    std::sort(backward.begin(), backward.end(), [&](std::size_t a, std::size_t b) { return times[a] > times[b]; });
    for (const auto *chain : {&forward, &backward}) {
        std::vector<double> current = xy;
        std::vector<bool> dead(n, false);
        double t_current = t_from;
        for (std::size_t idx : *chain) {
            const double t = times[idx];
            if (t != t_current) {
                std::vector<double> x0, y0;
                std::vector<std::size_t> alive;
                for (std::size_t p = 0; p < n; ++p)
                    if (!dead[p]) {
                        alive.push_back(p);
                        x0.push_back(current[2 * p]);
                        y0.push_back(current[2 * p + 1]);
                    }
                if (!alive.empty()) {
                    const AdvectResult a = advect_points(dynamics, x0, y0, t_current, t, settings, false, bounds);
                    out.stats.add(a.stats);
                    for (std::size_t q = 0; q < alive.size(); ++q) {
                        const std::size_t p = alive[q];
                        if (a.mask[q] != 0) {
                            dead[p] = true;
                            masked[p] = true;
                            current[2 * p] = current[2 * p + 1] = nan_value;
                        } else {
                            current[2 * p] = a.x[q];
                            current[2 * p + 1] = a.y[q];
                        }
                    }
                }
                t_current = t;
            }
            out.positions[idx] = current;
        }
    }
    out.masked = static_cast<std::size_t>(std::count(masked.begin(), masked.end(), true));
    return out;
}

Snapshots poincare_iterates(const Dynamics &dynamics, const IntegratorSettings &settings,
                            const std::optional<Bounds> &bounds, const std::vector<double> &seeds, double t_start,
                            double period, std::size_t iterations) {
    std::vector<double> times(iterations + 1);
    for (std::size_t k = 0; k <= iterations; ++k) times[k] = t_start + static_cast<double>(k) * period;
    return advect_snapshots(dynamics, settings, bounds, seeds, t_start, times);
}

StretchingHistory stretching_history(const Dynamics &dynamics, const IntegratorSettings &settings,
                                     const std::optional<Bounds> &bounds, const std::vector<double> &xy, bool closed,
                                     double t0, const std::vector<double> &times, double max_gap) {
    StretchingHistory h;
    h.length0 = polyline_length(xy, closed);
    h.area0 = closed ? std::abs(shoelace_area(xy)) : nan_value;
    CurveAdvectionSettings curve_settings;
    curve_settings.max_gap_fraction = max_gap;
    for (double t : times) {
        StretchingSample s;
        s.t = t;
        if (t == t0) {
            s.xy = s.xy0 = xy;
            s.length = h.length0;
            s.area = h.area0;
            s.points = xy.size() / 2;
            s.converged = true;
        } else {
            const AdvectedCurve c = advect_curve(xy, closed, make_advect_points_fn(dynamics, t0, t, settings, bounds),
                                                 curve_settings);
            s.xy = c.xy1;
            s.xy0 = c.xy0;
            s.length = c.length1;
            s.area = closed ? std::abs(c.area1) : nan_value;
            s.points = c.xy1.size() / 2;
            s.converged = c.converged;
        }
        s.delta_l = h.length0 > 0.0 ? (s.length - h.length0) / h.length0 : nan_value;
        h.samples.push_back(std::move(s));
    }
    return h;
}

BarrierTube barrier_tube(const Dynamics &dynamics, const IntegratorSettings &settings,
                         const std::optional<Bounds> &bounds, const std::vector<double> &xy, bool closed, double t0,
                         const std::vector<double> &times, std::size_t columns) {
    BarrierTube tube;
    tube.closed = closed;
    tube.times = times;
    const std::size_t n = xy.size() / 2;
    if (n < 2 || columns < 2) return tube;
    // Material points equally spaced in arc length along the barrier.
    const std::vector<double> s0 = cumulative_length(xy, closed);
    const double total = s0.back();
    if (!(total > 0.0)) return tube;
    std::vector<double> material;
    std::size_t k = 0;
    for (std::size_t c = 0; c < columns; ++c) {
        const double target = total * static_cast<double>(c) / static_cast<double>(closed ? columns : columns - 1);
        while (k + 2 < s0.size() && s0[k + 1] < target) ++k;
        const std::size_t a = k % n, b = (k + 1) % n;
        const double len = s0[k + 1] - s0[k];
        const double u = len > 0.0 ? std::clamp((target - s0[k]) / len, 0.0, 1.0) : 0.0;
        material.push_back(xy[2 * a] + u * (xy[2 * b] - xy[2 * a]));
        material.push_back(xy[2 * a + 1] + u * (xy[2 * b + 1] - xy[2 * a + 1]));
    }
    const Snapshots snaps = advect_snapshots(dynamics, settings, bounds, material, t0, times);
    tube.columns = columns;
    tube.rows = times.size();
    for (std::size_t r = 0; r < times.size(); ++r)
        for (std::size_t c = 0; c < columns; ++c)
            tube.xyz.insert(tube.xyz.end(), {snaps.positions[r][2 * c], snaps.positions[r][2 * c + 1], times[r]});
    return tube;
}

void write_tubes_vtp(const fs::path &file, const std::vector<BarrierTube> &tubes) {
    // Points: every slice's own points, then every tube's mesh points.
    std::ostringstream points, point_time, point_barrier, line_conn, line_off, line_cell, poly_conn, poly_off,
        poly_cell;
    points.precision(17);
    point_time.precision(17);
    std::size_t n_points = 0, n_lines = 0, n_polys = 0, line_offset = 0, poly_offset = 0;
    for (std::size_t b = 0; b < tubes.size(); ++b) {
        const BarrierTube &tube = tubes[b];
        for (std::size_t r = 0; r < tube.slices.size() && r < tube.slice_times.size(); ++r) {
            const std::vector<double> &xy = tube.slices[r];
            const std::size_t n = xy.size() / 2;
            if (n < 2) continue;
            const std::size_t first = n_points;
            for (std::size_t p = 0; p < n; ++p) {
                points << xy[2 * p] << ' ' << xy[2 * p + 1] << ' ' << tube.slice_times[r] << '\n';
                point_time << tube.slice_times[r] << '\n';
                point_barrier << b << '\n';
                line_conn << first + p << ' ';
            }
            n_points += n;
            line_offset += n;
            if (tube.closed && n >= 3) {
                line_conn << first;
                ++line_offset;
            }
            line_conn << '\n';
            line_off << line_offset << '\n';
            line_cell << b << '\n';
            ++n_lines;
        }
        if (tube.rows < 2 || tube.columns < 2) continue;
        const std::size_t first = n_points;
        for (std::size_t q = 0; q < tube.rows * tube.columns; ++q) {
            points << tube.xyz[3 * q] << ' ' << tube.xyz[3 * q + 1] << ' ' << tube.xyz[3 * q + 2] << '\n';
            point_time << tube.xyz[3 * q + 2] << '\n';
            point_barrier << b << '\n';
        }
        n_points += tube.rows * tube.columns;
        const std::size_t col_end = tube.closed ? tube.columns : tube.columns - 1;
        for (std::size_t r = 0; r + 1 < tube.rows; ++r)
            for (std::size_t c = 0; c < col_end; ++c) {
                const std::size_t c1 = (c + 1) % tube.columns;
                poly_conn << first + r * tube.columns + c << ' ' << first + r * tube.columns + c1 << ' '
                          << first + (r + 1) * tube.columns + c1 << ' ' << first + (r + 1) * tube.columns + c << '\n';
                poly_offset += 4;
                poly_off << poly_offset << '\n';
                poly_cell << b << '\n';
                ++n_polys;
            }
    }
    std::ostringstream doc;
    doc << "<?xml version=\"1.0\"?>\n"
        << "<!-- geobarrier: barriers advected through extended phase space (x, y, t) -->\n"
        << "<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
        << "  <PolyData>\n"
        << "    <Piece NumberOfPoints=\"" << n_points << "\" NumberOfVerts=\"0\" NumberOfLines=\"" << n_lines
        << "\" NumberOfStrips=\"0\" NumberOfPolys=\"" << n_polys << "\">\n"
        << "      <PointData Scalars=\"time\">\n"
        << "        <DataArray type=\"Float64\" Name=\"time\" format=\"ascii\">\n"
        << point_time.str() << "        </DataArray>\n"
        << "        <DataArray type=\"Int32\" Name=\"barrier\" format=\"ascii\">\n"
        << point_barrier.str() << "        </DataArray>\n"
        << "      </PointData>\n"
        << "      <CellData Scalars=\"barrier\">\n"
        << "        <DataArray type=\"Int32\" Name=\"barrier\" format=\"ascii\">\n"
        << line_cell.str() << poly_cell.str() << "        </DataArray>\n"
        << "      </CellData>\n"
        << "      <Points>\n"
        << "        <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n"
        << points.str() << "        </DataArray>\n"
        << "      </Points>\n"
        << "      <Lines>\n"
        << "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n"
        << line_conn.str() << "        </DataArray>\n"
        << "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n"
        << line_off.str() << "        </DataArray>\n"
        << "      </Lines>\n"
        << "      <Polys>\n"
        << "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n"
        << poly_conn.str() << "        </DataArray>\n"
        << "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n"
        << poly_off.str() << "        </DataArray>\n"
        << "      </Polys>\n"
        << "    </Piece>\n"
        << "  </PolyData>\n"
        << "</VTKFile>\n";
    write_text_file(file, doc.str());
}

// ------------------------------------------------------------------------------------------------ the stage

namespace {

struct Stage {
    const ValidationInput &in;
    const fs::path &out;
    ValidationOutput &result;
    const std::vector<Barrier> &barriers;

    void add_file(const fs::path &file) { result.files.push_back(file); }
    void warn(const std::string &w) {
        spdlog::warn("{}", w);
        result.warnings.push_back(w);
    }
    std::string base_title() const { return in.title.empty() ? std::string() : in.title + ": "; }
    // Axis labels "name [unit]" from the system's declared state names and units (ABI 1.2), "t [time]" for time.
    std::string state_label(std::size_t i) const {
        return in.dynamics.system ? state_axis_label(in.dynamics.system->info(), i) : std::string(i == 0 ? "x" : "y");
    }
    std::string time_label() const {
        return in.dynamics.system ? time_axis_label(in.dynamics.system->info()) : std::string("t");
    }
    void label_phase_plane(XYPlot &plot) const {
        plot.x_label = state_label(0);
        plot.y_label = state_label(1);
    }
    void label_extended(XYZPlot &plot) const {
        plot.x_label = state_label(0);
        plot.y_label = state_label(1);
        plot.z_label = time_label();
    }

    // The found barriers a product works on ("all", "outermost", or given indices).
    std::vector<std::size_t> choose_barriers(const std::string &which, const std::vector<std::size_t> &indices,
                                             const std::string &json_path) const {
        std::vector<std::size_t> chosen;
        if (which == "indices") {
            for (std::size_t i : indices) {
                if (i >= barriers.size())
                    throw ConfigError(json_path, fmt::format("barrier index {} is out of range: the extractors "
                                                             "found {} barriers",
                                                             i, barriers.size()));
                chosen.push_back(i);
            }
            return chosen;
        }
        const std::vector<const Barrier *> outer = outermost_elliptic(barriers);
        for (std::size_t i = 0; i < barriers.size(); ++i)
            if (which == "all" || std::find(outer.begin(), outer.end(), &barriers[i]) != outer.end())
                chosen.push_back(i);
        return chosen;
    }

    void poincare(const PoincareSpec &spec, json &summary) {
        const double t_start = spec.t_start.value_or(in.t0);
        std::vector<double> seeds;
        std::vector<std::string> origin;
        for (const auto &p : spec.seeds) {
            seeds.insert(seeds.end(), {p[0], p[1]});
            origin.push_back("seed");
        }
        if (spec.lattice) {
            const std::vector<double> l = lattice_points(*spec.lattice);
            seeds.insert(seeds.end(), l.begin(), l.end());
            origin.insert(origin.end(), l.size() / 2, "lattice");
        }
        std::size_t from_barriers = 0;
        const std::vector<std::size_t> chosen =
            spec.barrier_points > 0 ? choose_barriers(spec.which, spec.indices, "/validation/poincare/barriers")
                                    : std::vector<std::size_t>();
        if (spec.barrier_points > 0) {
            for (std::size_t b : chosen) {
                const Barrier &barrier = barriers[b];
                const double length = polyline_length(barrier.xy, barrier.closed);
                if (!(length > 0.0)) continue;
                const std::size_t want = spec.barrier_points;
                std::vector<double> pts =
                    resample_polyline(barrier.xy, length / static_cast<double>(barrier.closed ? want : want - 1 + (want == 1)),
                                      barrier.closed);
                for (std::size_t p = 0; p < pts.size() / 2 && p < want; ++p) {
                    seeds.insert(seeds.end(), {pts[2 * p], pts[2 * p + 1]});
                    origin.push_back("barrier" + std::to_string(b));
                    ++from_barriers;
                }
            }
            if (barriers.empty()) warn("validation poincare: barrier_points is set but no barrier was found");
        }
        const std::size_t n_seeds = seeds.size() / 2;
        if (n_seeds == 0) {
            warn("validation poincare: no seeds to iterate");
            return;
        }
        spdlog::info("validation: {} iterates of the period map from {} seeds", spec.iterations, n_seeds);
        const Snapshots it = poincare_iterates(in.dynamics, in.integrator, in.bounds, seeds, t_start, spec.period,
                                               spec.iterations);
        std::string csv = "seed,origin,iteration,t,x,y\n";
        std::size_t rows = 0;
        for (std::size_t s = 0; s < n_seeds; ++s)
            for (std::size_t k = 0; k <= spec.iterations; ++k) {
                const double x = it.positions[k][2 * s], y = it.positions[k][2 * s + 1];
                if (!std::isfinite(x)) break; // masked from here on
                csv += fmt::format("{},{},{},{},{},{}\n", s, origin[s], k,
                                   csv_number(t_start + static_cast<double>(k) * spec.period), csv_number(x),
                                   csv_number(y));
                ++rows;
            }
        const fs::path file = out / "poincare.csv";
        write_text_file(file, csv);
        add_file(file);
        summary = {{"file", "poincare.csv"}, {"seeds", n_seeds}, {"seeds_from_barriers", from_barriers},
                   {"iterations", spec.iterations}, {"rows", rows}, {"masked", it.masked},
                   {"t_start", t_start}, {"period", spec.period}, {"integrator_stats", it.stats.to_json()}};
        if (it.masked > 0)
            warn(fmt::format("validation poincare: {} of {} seeds masked (left the bounds or blew up); their iterates "
                             "stop there",
                             it.masked, n_seeds));
        if (!in.plots) return;
        XYPlot plot;
        plot.title = base_title() + fmt::format("period map, {} iterates of {} seeds", spec.iterations, n_seeds);
        label_phase_plane(plot);
        plot.equal_aspect = true;
        plot.legend = XYPlot::Legend::outside_right;
        PlotSeries cloud;
        cloud.style = PlotSeries::Style::points;
        cloud.color = data_color;
        cloud.label = "iterates";
        for (std::size_t k = 0; k <= spec.iterations; ++k)
            for (std::size_t s = 0; s < n_seeds; ++s)
                if (std::isfinite(it.positions[k][2 * s]))
                    cloud.xy.insert(cloud.xy.end(), {it.positions[k][2 * s], it.positions[k][2 * s + 1]});
        cloud.marker_px = cloud_marker_px(cloud.xy.size() / 2);
        plot.series.push_back(cloud);
        // Barriers live at t0; they belong on the picture when the map's section is at t0 too. When the seeds came
        // from barriers, those barriers are shown; otherwise all.
        if (same_time(t_start, in.t0)) {
            std::vector<Barrier> shown;
            if (spec.barrier_points > 0)
                for (std::size_t b : chosen) shown.push_back(barriers[b]);
            for (PlotSeries &s : barrier_series(spec.barrier_points > 0 ? shown : barriers, "barriers at t₀"))
                plot.series.push_back(s);
        }
        const fs::path picture = out / "poincare.png";
        plot_xy_png(picture, plot);
        add_file(picture);
    }

    void tracers(const std::vector<TracerCloudSpec> &clouds, json &summary) {
        std::string csv = "cloud,tracer,t,x,y\n";
        summary = {{"file", "tracers.csv"}, {"clouds", json::array()}};
        for (std::size_t c = 0; c < clouds.size(); ++c) {
            const TracerCloudSpec &spec = clouds[c];
            const double release = spec.release.value_or(in.t0);
            const std::vector<double> times = spec.times.empty() ? std::vector<double>{in.t1} : spec.times;
            const std::vector<double> xy = spec.box ? lattice_points(*spec.box) : disc_points(*spec.disc);
            const std::size_t n = xy.size() / 2;
            spdlog::info("validation: tracer cloud {} ({} tracers) from t = {:g}", c, n, release);
            std::vector<double> all_times = times;
            all_times.insert(all_times.begin(), release);
            const Snapshots snaps = advect_snapshots(in.dynamics, in.integrator, in.bounds, xy, release, all_times);
            for (std::size_t k = 0; k < all_times.size(); ++k) {
                if (k > 0 && same_time(all_times[k], release)) continue;
                for (std::size_t p = 0; p < n; ++p)
                    if (std::isfinite(snaps.positions[k][2 * p]))
                        csv += fmt::format("{},{},{},{},{}\n", c, p, csv_number(all_times[k]),
                                           csv_number(snaps.positions[k][2 * p]),
                                           csv_number(snaps.positions[k][2 * p + 1]));
            }
            json pictures = json::array();
            if (in.plots)
                for (std::size_t k = 1; k < all_times.size(); ++k) {
                    XYPlot plot;
                    plot.title = base_title() + fmt::format("{} tracers released at t = {}, at t = {}", n,
                                                            fmt_g(release), fmt_g(all_times[k]));
                    label_phase_plane(plot);
                    plot.equal_aspect = true;
                    plot.legend = XYPlot::Legend::outside_right;
                    PlotSeries cloud;
                    cloud.style = PlotSeries::Style::points;
                    cloud.color = data_color;
                    cloud.label = "tracers";
                    for (std::size_t p = 0; p < n; ++p)
                        if (std::isfinite(snaps.positions[k][2 * p]))
                            cloud.xy.insert(cloud.xy.end(), {snaps.positions[k][2 * p], snaps.positions[k][2 * p + 1]});
                    cloud.marker_px = cloud_marker_px(n);
                    plot.series.push_back(cloud);
                    if (same_time(all_times[k], in.t0))
                        for (PlotSeries &s : barrier_series(barriers, "barriers at t₀")) plot.series.push_back(s);
                    const std::string name = fmt::format("tracers_{}_{}.png", c, k - 1);
                    plot_xy_png(out / name, plot);
                    add_file(out / name);
                    pictures.push_back(name);
                }
            summary["clouds"].push_back({{"tracers", n}, {"release", release}, {"times", times},
                                         {"masked", snaps.masked}, {"pictures", pictures},
                                         {"integrator_stats", snaps.stats.to_json()}});
            if (snaps.masked > 0)
                warn(fmt::format("validation tracers: {} of {} tracers of cloud {} masked (left the bounds or blew up)",
                                 snaps.masked, n, c));
        }
        const fs::path file = out / "tracers.csv";
        write_text_file(file, csv);
        add_file(file);
    }

    void trajectories(const TrajectoriesSpec &spec, json &summary) {
        const double t_start = spec.t_start.value_or(in.t0), t_end = spec.t_end.value_or(in.t1);
        std::vector<double> xy;
        for (const auto &p : spec.states) xy.insert(xy.end(), {p[0], p[1]});
        const std::size_t n = spec.states.size();
        const std::vector<double> times = even_times(t_start, t_end, spec.samples);
        const Snapshots snaps = advect_snapshots(in.dynamics, in.integrator, in.bounds, xy, t_start, times);
        // Inside the outermost elliptic barrier? Only meaningful for states at the barriers' time t0.
        const std::vector<const Barrier *> outer = outermost_elliptic(barriers);
        const bool can_classify = !outer.empty() && same_time(t_start, in.t0);
        std::vector<int> inside(n, -1);
        if (can_classify)
            for (std::size_t s = 0; s < n; ++s) {
                inside[s] = 0;
                for (const Barrier *b : outer)
                    if (point_in_polygon(spec.states[s][0], spec.states[s][1], b->xy)) inside[s] = 1;
            }
        std::string csv = "trajectory,sample,t,x,y,inside\n";
        for (std::size_t s = 0; s < n; ++s)
            for (std::size_t k = 0; k < times.size(); ++k) {
                const double x = snaps.positions[k][2 * s], y = snaps.positions[k][2 * s + 1];
                if (!std::isfinite(x)) break;
                csv += fmt::format("{},{},{},{},{},{}\n", s, k, csv_number(times[k]), csv_number(x), csv_number(y),
                                   inside[s] < 0 ? std::string() : std::to_string(inside[s]));
            }
        const fs::path file = out / "trajectories.csv";
        write_text_file(file, csv);
        add_file(file);
        json list = json::array();
        for (std::size_t s = 0; s < n; ++s) {
            double max_excursion = 0.0;
            for (std::size_t k = 0; k < times.size(); ++k)
                if (std::isfinite(snaps.positions[k][2 * s]))
                    max_excursion = std::max(max_excursion, std::hypot(snaps.positions[k][2 * s] - xy[2 * s],
                                                                       snaps.positions[k][2 * s + 1] - xy[2 * s + 1]));
            list.push_back({{"state", {xy[2 * s], xy[2 * s + 1]}},
                            {"inside", inside[s] < 0 ? json(nullptr) : json(inside[s] == 1)},
                            {"max_distance_from_start", max_excursion}});
        }
        summary = {{"file", "trajectories.csv"}, {"t_start", t_start}, {"t_end", t_end}, {"samples", spec.samples},
                   {"trajectories", list}, {"masked", snaps.masked}, {"elliptic_barriers_used", outer.size()},
                   {"integrator_stats", snaps.stats.to_json()}};
        if (!outer.empty() && !can_classify)
            warn("validation trajectories: t_start differs from t0, where the elliptic barriers are; the inside "
                 "column is left empty");
        if (!in.plots) return;

        auto label = [&](std::size_t s) {
            std::string text = fmt::format("({}, {})", fmt_g(xy[2 * s]), fmt_g(xy[2 * s + 1]));
            if (inside[s] >= 0) text += inside[s] ? " inside" : " outside";
            return text;
        };
        const auto &palette = series_palette();
        const bool legend = n <= 12;
        // Phase plane: the trajectories, their starting points and the outermost elliptic barriers.
        {
            XYPlot plot;
            plot.title = base_title() + fmt::format("trajectories, t = {} to {}", fmt_g(t_start), fmt_g(t_end));
            label_phase_plane(plot);
            plot.equal_aspect = true;
            plot.legend = XYPlot::Legend::outside_right;
            for (std::size_t s = 0; s < n; ++s) {
                PlotSeries line;
                line.color = palette[s % palette.size()];
                line.width = 1.0;
                if (legend) line.label = label(s);
                for (std::size_t k = 0; k < times.size(); ++k)
                    line.xy.insert(line.xy.end(), {snaps.positions[k][2 * s], snaps.positions[k][2 * s + 1]});
                plot.series.push_back(line);
                PlotSeries start;
                start.style = PlotSeries::Style::points;
                start.color = line.color;
                start.marker_px = 9.0;
                start.xy = {xy[2 * s], xy[2 * s + 1]};
                plot.series.push_back(start);
            }
            std::vector<Barrier> outer_copy;
            for (const Barrier *b : outer) outer_copy.push_back(*b);
            for (PlotSeries &s : barrier_series(outer_copy, "outermost elliptic barriers at t₀"))
                plot.series.push_back(s);
            plot_xy_png(out / "trajectories_phase.png", plot);
            add_file(out / "trajectories_phase.png");
        }
        // Time series of each coordinate.
        for (int c = 0; c < 2; ++c) {
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
                if (legend) line.label = label(s);
                for (std::size_t k = 0; k < times.size(); ++k)
                    line.xy.insert(line.xy.end(), {times[k], snaps.positions[k][2 * s + c]});
                plot.series.push_back(line);
            }
            const std::string name = "trajectories_" + coordinate + ".png";
            plot_xy_png(out / name, plot);
            add_file(out / name);
        }
        // Extended phase space (x, y, t) with the outermost barriers at t_start and advected to t_end (paper,
        // figure "stability").
        {
            XYZPlot plot;
            plot.title = base_title() + "trajectories in extended phase space";
            label_extended(plot);
            for (std::size_t s = 0; s < n; ++s) {
                PlotSeries3D line;
                line.color = palette[s % palette.size()];
                line.width = 1.2;
                if (legend) line.label = label(s);
                for (std::size_t k = 0; k < times.size(); ++k)
                    line.xyz.insert(line.xyz.end(),
                                    {snaps.positions[k][2 * s], snaps.positions[k][2 * s + 1], times[k]});
                plot.series.push_back(line);
            }
            if (can_classify) {
                bool first = true;
                for (const Barrier *b : outer) {
                    const StretchingHistory h = stretching_history(in.dynamics, in.integrator, in.bounds, b->xy, true,
                                                                   in.t0, {t_end}, 0.005);
                    for (const auto &[curve, t] : {std::make_pair(b->xy, in.t0), std::make_pair(h.samples[0].xy, t_end)}) {
                        PlotSeries3D ring;
                        ring.color = barrier_color;
                        ring.width = 2.2;
                        ring.closed = true;
                        if (first) ring.label = "outermost elliptic barrier";
                        first = false;
                        for (std::size_t p = 0; p + 1 < curve.size(); p += 2)
                            ring.xyz.insert(ring.xyz.end(), {curve[p], curve[p + 1], t});
                        plot.series.push_back(ring);
                    }
                }
            }
            plot_xyz_png(out / "trajectories_3d.png", plot);
            add_file(out / "trajectories_3d.png");
        }
    }

    void forcing(const ForcingSpec &spec, json &summary) {
        const double t_start = spec.t_start.value_or(in.t0), t_end = spec.t_end.value_or(in.t1);
        const std::vector<double> times = even_times(t_start, t_end, spec.samples);
        std::vector<double> f(times.size(), 0.0);
        if (in.dynamics.forcing) in.dynamics.forcing->evaluate(times.size(), times.data(), f.data());
        std::string csv = "t,f\n";
        double low = std::numeric_limits<double>::infinity(), high = -low;
        for (std::size_t k = 0; k < times.size(); ++k) {
            csv += csv_number(times[k]) + "," + csv_number(f[k]) + "\n";
            low = std::min(low, f[k]);
            high = std::max(high, f[k]);
        }
        const fs::path file = out / "forcing.csv";
        write_text_file(file, csv);
        add_file(file);
        summary = {{"file", "forcing.csv"}, {"t_start", t_start}, {"t_end", t_end}, {"samples", spec.samples},
                   {"min", low}, {"max", high}};
        if (!in.plots) return;
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
        plot_xy_png(out / "forcing.png", plot);
        add_file(out / "forcing.png");
    }

    void advect_barriers(const AdvectBarriersSpec &spec, json &summary) {
        const std::vector<std::size_t> chosen =
            choose_barriers(spec.which, spec.indices, "/validation/advect_barriers/barriers");
        const std::vector<double> times = default_times(spec, in.t0, in.t1);
        summary = {{"file", "stretching.csv"}, {"times", times}, {"barriers", json::array()}};
        if (chosen.empty()) warn("validation advect_barriers: no barrier to advect");
        std::string csv = "barrier,kind,closed,t,length,delta_l,area,area_change,points,converged\n";
        std::vector<BarrierTube> tubes;
        std::vector<StretchingHistory> histories;
        for (std::size_t b : chosen) {
            const Barrier &barrier = barriers[b];
            spdlog::info("validation: advecting barrier {} ({} points) to {} times", b, barrier.xy.size() / 2,
                         times.size());
            const StretchingHistory h = stretching_history(in.dynamics, in.integrator, in.bounds, barrier.xy,
                                                           barrier.closed, in.t0, times, spec.max_gap);
            double worst = 0.0, worst_area = 0.0;
            bool converged = true;
            for (const StretchingSample &s : h.samples) {
                const double area_change = barrier.closed && h.area0 > 0.0 ? (s.area - h.area0) / h.area0 : nan_value;
                csv += fmt::format("{},{},{},{},{},{},{},{},{},{}\n", b, barrier.kind, barrier.closed ? 1 : 0,
                                   csv_number(s.t), csv_number(s.length), csv_number(s.delta_l), csv_number(s.area),
                                   csv_number(area_change), s.points, s.converged ? 1 : 0);
                worst = std::max(worst, std::abs(s.delta_l));
                if (std::isfinite(area_change)) worst_area = std::max(worst_area, std::abs(area_change));
                converged = converged && s.converged;
            }
            const StretchingSample &last = h.samples.back();
            json item = {{"barrier", b},
                         {"kind", barrier.kind},
                         {"closed", barrier.closed},
                         {"length_t0", h.length0},
                         {"length_last", last.length},
                         {"delta_l_last", last.delta_l},
                         {"max_abs_delta_l", worst},
                         {"converged", converged}};
            if (barrier.closed) {
                item["area_t0"] = h.area0;
                item["area_last"] = last.area;
                item["max_abs_area_change"] = worst_area;
            }
            summary["barriers"].push_back(item);
            if (!converged)
                warn(fmt::format("validation advect_barriers: barrier {}: curve advection did not converge at some "
                                 "time (gaps above max_gap remain, or points were masked); see stretching.csv",
                                 b));
            if (spec.tube) {
                const auto [t_first, t_last] = std::minmax_element(times.begin(), times.end());
                BarrierTube tube = barrier_tube(in.dynamics, in.integrator, in.bounds, barrier.xy, barrier.closed,
                                                in.t0, even_times(*t_first, *t_last, spec.tube_rows),
                                                spec.tube_columns);
                for (const StretchingSample &s : h.samples) {
                    tube.slice_times.push_back(s.t);
                    tube.slices.push_back(s.xy);
                }
                tubes.push_back(std::move(tube));
            }
            histories.push_back(h);
        }
        const fs::path file = out / "stretching.csv";
        write_text_file(file, csv);
        add_file(file);
        if (spec.tube && !tubes.empty()) {
            write_tubes_vtp(out / "tube.vtp", tubes);
            add_file(out / "tube.vtp");
            summary["tube"] = "tube.vtp";
        }
        if (!in.plots || chosen.empty()) return;
        const auto &palette = series_palette();
        const bool legend = chosen.size() <= 12;
        // delta_l(t) x 100 (the paper's figure "length-ex3").
        {
            XYPlot plot;
            plot.title = base_title() + "relative stretching of the advected barriers";
            plot.x_label = time_label();
            plot.y_label = "δℓ(t) [%]";
            plot.aspect = 0.5;
            plot.legend = XYPlot::Legend::outside_right;
            for (std::size_t k = 0; k < chosen.size(); ++k) {
                PlotSeries line;
                line.style = PlotSeries::Style::line_points;
                line.marker_px = 5.0;
                line.color = palette[k % palette.size()];
                if (legend) line.label = fmt::format("barrier {} ({})", chosen[k], barriers[chosen[k]].kind);
                for (const StretchingSample &s : histories[k].samples)
                    line.xy.insert(line.xy.end(), {s.t, 100.0 * s.delta_l});
                plot.series.push_back(line);
            }
            plot_xy_png(out / "stretching.png", plot);
            add_file(out / "stretching.png");
        }
        // The advected barriers in the phase plane, one colour per time: at most 9 of the times, evenly chosen
        // (first and last included), so the curves stay apart.
        {
            XYPlot plot;
            plot.title = base_title() + "barriers advected from t₀ = " + fmt_g(in.t0);
            label_phase_plane(plot);
            plot.equal_aspect = true;
            plot.legend = XYPlot::Legend::outside_right;
            const std::size_t shown = std::min<std::size_t>(times.size(), 9);
            for (std::size_t m = 0; m < shown; ++m) {
                const std::size_t r =
                    shown == 1 ? 0 : static_cast<std::size_t>(std::lround(static_cast<double>(m * (times.size() - 1)) /
                                                                          static_cast<double>(shown - 1)));
                for (std::size_t k = 0; k < chosen.size(); ++k) {
                    PlotSeries line;
                    line.xy = histories[k].samples[r].xy;
                    line.closed = barriers[chosen[k]].closed;
                    line.color = m == 0 ? barrier_color : time_color(m, shown);
                    line.width = m == 0 ? 2.2 : 1.4;
                    if (k == 0) line.label = "t = " + fmt_g(times[r]);
                    plot.series.push_back(line);
                }
            }
            plot_xy_png(out / "barriers_advected.png", plot);
            add_file(out / "barriers_advected.png");
        }
        if (spec.tube && !tubes.empty()) {
            XYZPlot plot;
            plot.title = base_title() + "barriers swept through extended phase space";
            label_extended(plot);
            for (std::size_t k = 0; k < tubes.size(); ++k) {
                const BarrierTube &tube = tubes[k];
                PlotSurface3D surface;
                surface.xyz = tube.xyz;
                surface.rows = tube.rows;
                surface.cols = tube.columns;
                surface.wrap_cols = tube.closed;
                surface.color = palette[k % palette.size()];
                surface.opacity = 0.8;
                plot.surfaces.push_back(surface);
                // The barrier itself at t0, in the barrier colour.
                const Barrier &barrier = barriers[chosen[k]];
                PlotSeries3D ring;
                ring.color = barrier_color;
                ring.width = 2.2;
                ring.closed = tube.closed;
                if (k == 0) ring.label = "barriers at t₀";
                for (std::size_t p = 0; p + 1 < barrier.xy.size(); p += 2)
                    ring.xyz.insert(ring.xyz.end(), {barrier.xy[p], barrier.xy[p + 1], in.t0});
                plot.series.push_back(ring);
                // Its last advected slice in the tube's colour names the tube in the legend, with the colour the
                // same barrier has in stretching.png.
                if (!tube.slices.empty()) {
                    PlotSeries3D last;
                    last.color = surface.color;
                    last.width = 1.6;
                    last.closed = tube.closed;
                    if (legend) last.label = fmt::format("barrier {} ({})", chosen[k], barrier.kind);
                    const std::vector<double> &curve = tube.slices.back();
                    for (std::size_t p = 0; p + 1 < curve.size(); p += 2)
                        last.xyz.insert(last.xyz.end(), {curve[p], curve[p + 1], tube.slice_times.back()});
                    plot.series.push_back(last);
                }
            }
            plot_xyz_png(out / "tube.png", plot);
            add_file(out / "tube.png");
        }
    }
};

}  // namespace

ValidationOutput run_validation(const ValidationSpec &spec, const ValidationInput &input, const fs::path &out_dir) {
    ValidationOutput result;
    static const std::vector<Barrier> no_barriers;
    Stage stage{input, out_dir, result, input.barriers ? *input.barriers : no_barriers};
    if (spec.forcing) {
        json &s = result.summary["forcing"];
        ProductTimer timer(s);
        stage.forcing(*spec.forcing, s);
    }
    if (spec.poincare) {
        json &s = result.summary["poincare"];
        ProductTimer timer(s);
        stage.poincare(*spec.poincare, s);
    }
    if (!spec.tracers.empty()) {
        json &s = result.summary["tracers"];
        ProductTimer timer(s);
        stage.tracers(spec.tracers, s);
    }
    if (spec.trajectories) {
        json &s = result.summary["trajectories"];
        ProductTimer timer(s);
        stage.trajectories(*spec.trajectories, s);
    }
    if (spec.advect_barriers) {
        json &s = result.summary["advect_barriers"];
        ProductTimer timer(s);
        stage.advect_barriers(*spec.advect_barriers, s);
    }
    return result;
}

}  // namespace geobarrier
