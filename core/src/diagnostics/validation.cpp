// Validation products (paper section 3): period-map iterates, tracer clouds, trajectories, the forcing, and
// barriers advected with adaptive point insertion (their length, delta_l of eq. `rel_def`, enclosed area and
// their tube in extended phase space). This unit runs the stage: each product computes with the building blocks
// (validation_compute.cpp), writes its table (validation_csv.cpp), summarises for the manifest and draws
// (validation_plots.cpp); the "validation" object is read in validation_parse.cpp, tube.vtp written in
// validation_vtk.cpp.
#include <geobarrier/curves.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/output.hpp>
#include <geobarrier/validation.hpp>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "diagnostics/validation_internal.hpp"

namespace fs = std::filesystem;
using nlohmann::json;

namespace geobarrier {

namespace validation_detail {

void Stage::warn(const std::string &w) {
    spdlog::warn("{}", w);
    result.warnings.push_back(w);
}

void Stage::write_table(const std::string &name, const std::string &csv) {
    write_text_file(out / name, csv);
    add_file(out / name);
}

std::vector<std::size_t> Stage::choose_barriers(const std::string &which, const std::vector<std::size_t> &indices,
                                                const std::string &json_path) const {
    std::vector<std::size_t> chosen;
    if (which == "indices") {
        for (std::size_t i : indices) {
            if (i >= barriers.size())
                throw ConfigError(json_path, fmt::format("barrier index {} is out of range: the extractors found {} "
                                                         "barriers",
                                                         i, barriers.size()));
            chosen.push_back(i);
        }
        return chosen;
    }
    const std::vector<const Barrier *> outer = outermost_elliptic(barriers);
    for (std::size_t i = 0; i < barriers.size(); ++i)
        if (which == "all" || std::find(outer.begin(), outer.end(), &barriers[i]) != outer.end()) chosen.push_back(i);
    return chosen;
}

namespace {

// The period map's seeds: the given points, the lattice, and points spread evenly along the chosen barriers;
// `origin` says where each came from, `from_barriers` how many lie on barriers.
struct PoincareSeeds {
    std::vector<double> xy;
    std::vector<std::string> origin;
    std::size_t from_barriers = 0;
};

void seed_along_barriers(const PoincareSpec &spec, const std::vector<Barrier> &barriers,
                         const std::vector<std::size_t> &chosen, PoincareSeeds &seeds) {
    for (std::size_t b : chosen) {
        const Barrier &barrier = barriers[b];
        const double length = polyline_length(barrier.xy, barrier.closed);
        if (!(length > 0.0)) continue;
        const std::size_t want = spec.barrier_points;
        std::vector<double> pts = resample_polyline(
            barrier.xy, length / static_cast<double>(barrier.closed ? want : want - 1 + (want == 1)), barrier.closed);
        for (std::size_t p = 0; p < pts.size() / 2 && p < want; ++p) {
            seeds.xy.insert(seeds.xy.end(), {pts[2 * p], pts[2 * p + 1]});
            seeds.origin.push_back("barrier" + std::to_string(b));
            ++seeds.from_barriers;
        }
    }
}

} // namespace

void Stage::poincare(const PoincareSpec &spec, json &summary) {
    const double t_start = spec.t_start.value_or(in.t0);
    PoincareSeeds seeds;
    for (const auto &p : spec.seeds) {
        seeds.xy.insert(seeds.xy.end(), {p[0], p[1]});
        seeds.origin.push_back("seed");
    }
    if (spec.lattice) {
        const std::vector<double> l = lattice_points(*spec.lattice);
        seeds.xy.insert(seeds.xy.end(), l.begin(), l.end());
        seeds.origin.insert(seeds.origin.end(), l.size() / 2, "lattice");
    }
    const std::vector<std::size_t> chosen =
        spec.barrier_points > 0 ? choose_barriers(spec.which, spec.indices, "/validation/poincare/barriers")
                                : std::vector<std::size_t>();
    if (spec.barrier_points > 0) {
        seed_along_barriers(spec, barriers, chosen, seeds);
        if (barriers.empty()) warn("validation poincare: barrier_points is set but no barrier was found");
    }
    const std::size_t n_seeds = seeds.xy.size() / 2;
    if (n_seeds == 0) {
        warn("validation poincare: no seeds to iterate");
        return;
    }
    spdlog::info("validation: {} iterates of the period map from {} seeds", spec.iterations, n_seeds);
    const Snapshots it =
        poincare_iterates(in.dynamics, in.integrator, in.bounds, seeds.xy, t_start, spec.period, spec.iterations);
    std::size_t rows = 0;
    write_table("poincare.csv", poincare_csv(it, seeds.origin, t_start, spec.period, spec.iterations, rows));
    summary = {{"file", "poincare.csv"},
               {"seeds", n_seeds},
               {"seeds_from_barriers", seeds.from_barriers},
               {"iterations", spec.iterations},
               {"rows", rows},
               {"masked", it.masked},
               {"t_start", t_start},
               {"period", spec.period},
               {"integrator_stats", it.stats.to_json()}};
    if (it.masked > 0)
        warn(fmt::format("validation poincare: {} of {} seeds masked (left the bounds or blew up); their iterates "
                         "stop there",
                         it.masked, n_seeds));
    if (in.plots) draw_poincare({spec, it, n_seeds, t_start, chosen});
}

void Stage::section(const SectionSpec &spec, json &summary) {
    const std::size_t dim = in.dynamics.system->dimension(); // the normal's size: checked by resolve_experiment
    const double t_start = spec.t_start.value_or(in.t0), t_end = spec.t_end.value_or(in.t1);
    if (!(t_end > t_start))
        throw ConfigError("/validation/section/t_end", "must be after t_start (sections run forward in time)");
    std::vector<double> seeds;
    for (const auto &s : spec.seeds) seeds.insert(seeds.end(), s.begin(), s.end());
    spdlog::info("validation: section crossings of {} seeds over [{}, {}]", spec.seeds.size(), t_start, t_end);
    const SectionCrossings c = section_crossings(in.dynamics, in.integrator, in.bounds, seeds, t_start, t_end,
                                                 spec.normal, spec.offset, spec.direction, spec.crossings, spec.sample);
    std::string csv = "seed,crossing,t";
    for (std::size_t i = 0; i < dim; ++i) csv += ",s" + std::to_string(i);
    csv += "\n";
    for (std::size_t k = 0; k < c.times.size(); ++k) {
        csv += fmt::format("{},{},{}", c.seeds[k], k, csv_number(c.times[k]));
        for (std::size_t i = 0; i < dim; ++i) csv += "," + csv_number(c.states[dim * k + i]);
        csv += "\n";
    }
    write_table("section.csv", csv);
    summary = {{"file", "section.csv"},
               {"seeds", spec.seeds.size()},
               {"crossings", c.times.size()},
               {"masked", c.masked},
               {"t_start", t_start},
               {"t_end", t_end},
               {"integrator_stats", c.stats.to_json()}};
    if (c.masked > 0)
        warn(fmt::format("validation section: {} of {} seeds masked before t_end", c.masked, spec.seeds.size()));
    if (in.plots) draw_section(spec, c);
}

void Stage::tracers(const std::vector<TracerCloudSpec> &clouds, json &summary) {
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
        csv += tracer_csv_rows(c, snaps, all_times, release);
        const json pictures = in.plots ? draw_tracers(c, snaps, all_times) : json::array();
        summary["clouds"].push_back({{"tracers", n},
                                     {"release", release},
                                     {"times", times},
                                     {"masked", snaps.masked},
                                     {"pictures", pictures},
                                     {"integrator_stats", snaps.stats.to_json()}});
        if (snaps.masked > 0)
            warn(fmt::format("validation tracers: {} of {} tracers of cloud {} masked (left the bounds or blew up)",
                             snaps.masked, n, c));
    }
    write_table("tracers.csv", csv);
}

namespace {

// Inside the outermost elliptic barriers (1) or not (0), for each start; -1 throughout when unknown.
std::vector<int> inside_outermost(const std::vector<std::array<double, 2>> &states,
                                  const std::vector<const Barrier *> &outer, bool classify) {
    std::vector<int> inside(states.size(), -1);
    if (!classify) return inside;
    for (std::size_t s = 0; s < states.size(); ++s) {
        inside[s] = 0;
        for (const Barrier *b : outer)
            if (point_in_polygon(states[s][0], states[s][1], b->xy)) inside[s] = 1;
    }
    return inside;
}

json trajectory_list(const std::vector<double> &xy, const Snapshots &snaps, const std::vector<int> &inside) {
    json list = json::array();
    for (std::size_t s = 0; s < inside.size(); ++s) {
        double max_excursion = 0.0;
        for (const std::vector<double> &positions : snaps.positions)
            if (std::isfinite(positions[2 * s]))
                max_excursion = std::max(
                    max_excursion, std::hypot(positions[2 * s] - xy[2 * s], positions[2 * s + 1] - xy[2 * s + 1]));
        list.push_back({{"state", {xy[2 * s], xy[2 * s + 1]}},
                        {"inside", inside[s] < 0 ? json(nullptr) : json(inside[s] == 1)},
                        {"max_distance_from_start", max_excursion}});
    }
    return list;
}

} // namespace

void Stage::trajectories(const TrajectoriesSpec &spec, json &summary) {
    const double t_start = spec.t_start.value_or(in.t0), t_end = spec.t_end.value_or(in.t1);
    std::vector<double> xy;
    for (const auto &p : spec.states) xy.insert(xy.end(), {p[0], p[1]});
    const std::vector<double> times = even_times(t_start, t_end, spec.samples);
    const Snapshots snaps = advect_snapshots(in.dynamics, in.integrator, in.bounds, xy, t_start, times);
    // Inside the outermost elliptic barrier? Only meaningful for states at the barriers' time t0.
    const std::vector<const Barrier *> outer = outermost_elliptic(barriers);
    const bool can_classify = !outer.empty() && same_time(t_start, in.t0);
    const std::vector<int> inside = inside_outermost(spec.states, outer, can_classify);
    write_table("trajectories.csv", trajectories_csv(snaps, times, inside));
    summary = {{"file", "trajectories.csv"},
               {"t_start", t_start},
               {"t_end", t_end},
               {"samples", spec.samples},
               {"trajectories", trajectory_list(xy, snaps, inside)},
               {"masked", snaps.masked},
               {"elliptic_barriers_used", outer.size()},
               {"integrator_stats", snaps.stats.to_json()}};
    if (!outer.empty() && !can_classify)
        warn("validation trajectories: t_start differs from t0, where the elliptic barriers are; the inside "
             "column is left empty");
    if (in.plots) draw_trajectories({t_start, t_end, xy, times, snaps, inside, outer, can_classify});
}

void Stage::forcing(const ForcingSpec &spec, json &summary) {
    const double t_start = spec.t_start.value_or(in.t0), t_end = spec.t_end.value_or(in.t1);
    const std::vector<double> times = even_times(t_start, t_end, spec.samples);
    std::vector<double> f(times.size(), 0.0);
    if (in.dynamics.forcing) in.dynamics.forcing->evaluate(times.size(), times.data(), f.data());
    double low = std::numeric_limits<double>::infinity(), high = -low;
    for (double value : f) {
        low = std::min(low, value);
        high = std::max(high, value);
    }
    write_table("forcing.csv", forcing_csv(times, f));
    summary = {{"file", "forcing.csv"},   {"t_start", t_start}, {"t_end", t_end},
               {"samples", spec.samples}, {"min", low},         {"max", high}};
    if (in.plots) draw_forcing(times, f);
}

namespace {

// The manifest's record of one advected barrier: lengths, the largest |delta_l| and area change, convergence.
json advected_summary(std::size_t b, const Barrier &barrier, const StretchingHistory &h, bool &converged) {
    double worst = 0.0, worst_area = 0.0;
    converged = true;
    for (const StretchingSample &s : h.samples) {
        const double change = area_change(barrier, h, s);
        worst = std::max(worst, std::abs(s.delta_l));
        if (std::isfinite(change)) worst_area = std::max(worst_area, std::abs(change));
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
    return item;
}

} // namespace

void Stage::advect_barriers(const AdvectBarriersSpec &spec, json &summary) {
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
        StretchingHistory h = stretching_history(in.dynamics, in.integrator, in.bounds, barrier.xy, barrier.closed,
                                                 in.t0, times, spec.max_gap);
        csv += stretching_csv_rows(b, barrier, h);
        bool converged = true;
        summary["barriers"].push_back(advected_summary(b, barrier, h, converged));
        if (!converged)
            warn(fmt::format("validation advect_barriers: barrier {}: curve advection did not converge at some "
                             "time (gaps above max_gap remain, or points were masked); see stretching.csv",
                             b));
        if (spec.tube) {
            const auto [t_first, t_last] = std::minmax_element(times.begin(), times.end());
            BarrierTube tube = barrier_tube(in.dynamics, in.integrator, in.bounds, barrier.xy, barrier.closed, in.t0,
                                            even_times(*t_first, *t_last, spec.tube_rows), spec.tube_columns);
            for (const StretchingSample &s : h.samples) {
                tube.slice_times.push_back(s.t);
                tube.slices.push_back(s.xy);
            }
            tubes.push_back(std::move(tube));
        }
        histories.push_back(std::move(h));
    }
    write_table("stretching.csv", csv);
    if (spec.tube && !tubes.empty()) {
        write_tubes_vtp(out / "tube.vtp", tubes);
        add_file(out / "tube.vtp");
        summary["tube"] = "tube.vtp";
    }
    if (in.plots && !chosen.empty()) draw_advected({chosen, times, histories, tubes});
}

} // namespace validation_detail

namespace {

// Each product's wall time goes into its summary.
class ProductTimer {
  public:
    explicit ProductTimer(json &summary) : m_summary(summary) {}
    ~ProductTimer() {
        m_summary["wall_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
    }

  private:
    json &m_summary;
    std::chrono::steady_clock::time_point m_start = std::chrono::steady_clock::now();
};

} // namespace

ValidationOutput run_validation(const ValidationSpec &spec, const ValidationInput &input, const fs::path &out_dir) {
    ValidationOutput result;
    static const std::vector<Barrier> no_barriers;
    validation_detail::Stage stage{input, out_dir, result, input.barriers ? *input.barriers : no_barriers};
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
    if (spec.section) {
        json &s = result.summary["section"];
        ProductTimer timer(s);
        stage.section(*spec.section, s);
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

} // namespace geobarrier
