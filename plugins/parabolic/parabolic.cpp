// The `parabolic` BarrierExtractor: parabolic barriers, by one of two methods.
// - "shearless" (default): jet cores, the shearless barriers of Farazmand, Blazevski & Haller (2014): material
//   lines of locally weakest stretching, traced as trenches of the FTLE field (trenches.hpp). At a jet core the
//   shear vanishes and C = I, so no shearline passes there; the trench does.
// - "shearline": the paper's section 2.1 (Haller & Beron-Vera 2012): open shearlines r' = eta±(r) (eq. `shrline`)
//   whose pointwise geodesic shear deviation d_g^eta± (eq. `dg_shr`, general form) stays below a small threshold.
//   Shearlines are seeded on a lattice, truncated to the compact segments where d_g < max_deviation, and the
//   segments whose mean deviation is locally minimal across their neighbours are the barriers: in a jet, the lines
//   of strongest shear on either side of the core.
// Built on the core's shear fields (shear.hpp), tensor lines and curves; links the core's C++ library.
#include <geobarrier/curves.hpp>
#include <geobarrier/extractor_keys.hpp>
#include <geobarrier/line_field.hpp>
#include <geobarrier/output.hpp>
#include <geobarrier/sdk.hpp>
#include <geobarrier/sdk_plot.hpp>
#include <geobarrier/segment_index.hpp>
#include <geobarrier/shear.hpp>
#include <geobarrier/tensor_lines.hpp>

#include "trenches.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using namespace geobarrier;
using geobarrier::sdk::integer_param;
using geobarrier::sdk::real_param;
using geobarrier::sdk::string_param;

// A mean FTLE along a trench below this fraction of the FTLE's range over the box is zero to the precision of the
// numbers: the flow map resolves lambda2 to its tolerance (rtol >= 1e-14) at best, and rounding alone gave 2.6e-16.
constexpr double unresolved_ftle = 1e-12;

// A compact shearline segment with d_g^eta < max_deviation at every point: a barrier candidate.
struct Candidate {
    int family = 1; // +1: eta+, -1: eta-
    std::vector<double> xy;
    double length = 0.0;
    double mean_deviation = 0.0, max_deviation = 0.0;
    double mid_x = 0.0, mid_y = 0.0; // the point at half its arc length
};

std::string format(double v) {
    std::ostringstream s;
    s.precision(4);
    s << v;
    return s.str();
}

// The FTLE picture's mask: the FTLE is a scalar, defined at degenerate points too (C = I on a steady jet core).
std::vector<std::uint8_t> ftle_mask(const CauchyGreenField &cg) {
    std::vector<std::uint8_t> mask(cg.mask);
    for (std::uint8_t &m : mask) m &= mask_trajectory_bits;
    return mask;
}

// The candidates' points, indexed by candidate: "which candidates pass within r of (x, y)". Their points are at
// most half a grid cell apart, so testing the points is enough for radii of a few cells.
SegmentIndex candidate_points(const std::vector<Candidate> &candidates, double radius) {
    std::vector<Segment> points;
    for (std::size_t c = 0; c < candidates.size(); ++c)
        append_points(candidates[c].xy.data(), candidates[c].xy.size() / 2, c, points);
    return SegmentIndex(std::move(points), radius);
}

// The shearlines found so far (both families) and their candidate segments.
struct Shearlines {
    std::vector<std::vector<double>> open_lines; // for the picture
    std::vector<Candidate> candidates;
    std::size_t closed_lines = 0;   // closed shearlines: elliptic, left to the elliptic extractor
    std::size_t short_segments = 0; // segments with d_g < epsilon shorter than min_length
};

struct Parabolic {
    static constexpr const char *name = "parabolic";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc =
        "parabolic barriers: jet cores as trenches of the FTLE (shearless barriers, Farazmand, Blazevski & Haller "
        "2014), or the paper's open shearlines of small geodesic shear deviation (section 2.1)";
    static constexpr const char *required_fields[] = {"lambda1", "lambda2", "xi1_x", "xi1_y", "ftle", nullptr};
    static constexpr gb_param_spec params[] = {
        string_param("method", "shearless", "shearless|shearline",
                     "shearless: jet cores, trenches of the FTLE; shearline: the paper's open shearlines of small d_g"),
        real_param("min_depth", 0.05, 0.0, 1.0, "",
                   "shearless: trench depth (FTLE 3 grid spacings across minus FTLE on it), as a fraction of the "
                   "FTLE range"),
        real_param("max_deviation", 0.1, 0.0, HUGE_VAL, "",
                   "shearline: epsilon: shearlines are cut where the pointwise d_g^eta >= this"),
        shearline_families_param("shearline: shearline families searched"),
        integer_param("seed_spacing", 2, 1, 1e6,
                      "shearline: grid cells between neighbouring seeds (seeds sit on grid points)"),
        real_param("max_length", 0.0, 0.0, HUGE_VAL, "state",
                   "longest shearline or trench, per direction from its seed; 0 = 2 box diagonals"),
        real_param("min_length", 0.0, 0.0, HUGE_VAL, "state",
                   "shorter segments or trenches are no barriers; 0 = 1/4 of the box diagonal"),
        real_param("neighbour_distance", 0.0, 0.0, HUGE_VAL, "state",
                   "shearline: neighbours of a segment pass within this of its midpoint; 0 = 3 seed spacings"),
        integer_param("max_barriers", 0, 0, 1e9,
                      "report at most this many barriers, the best first (deepest trench, least mean deviation); "
                      "0 = all"),
        singular_gap_param(
            "shearline: shearlines stop where lambda2 - lambda1 <= singular_gap lambda2 (eta± undefined)"),
        deviation_form_param(
            "shearline: d_g formula: general (any flow) or the paper's eq. dg_shr (lambda1 lambda2 = 1 only)"),
        line_method_param(),
    };

    explicit Parabolic(const sdk::Params &p)
        : m_shearless(p.string("method") == "shearless"), m_min_depth(p.real("min_depth")),
          m_epsilon(p.real("max_deviation")), m_families(p.string("families")),
          m_seed_spacing(static_cast<std::size_t>(p.integer("seed_spacing"))), m_max_length(p.real("max_length")),
          m_min_length(p.real("min_length")), m_neighbour_distance(p.real("neighbour_distance")),
          m_max_barriers(static_cast<std::size_t>(p.integer("max_barriers"))), m_singular_gap(p.real("singular_gap")),
          m_area_preserving(p.string("deviation_form") == "area-preserving"),
          m_line_method(tensor_line_method(p.string("line_method"))) {}

    void extract(const sdk::Host &host, const gb_extract_input &in) const;
    void extract_shearless(const sdk::Host &host, const gb_extract_input &in) const;

    bool m_shearless;
    double m_min_depth;
    double m_epsilon;
    std::string m_families;
    std::size_t m_seed_spacing;
    double m_max_length, m_min_length, m_neighbour_distance;
    std::size_t m_max_barriers;
    double m_singular_gap;
    bool m_area_preserving;
    TensorLineMethod m_line_method;

  private:
    std::vector<double> shearline_seeds(const Grid &g, const LineField &field,
                                        const std::vector<double> &deviation) const;
    std::vector<TwoWayLine> distinct_shearlines(const Grid &g, const LineField &field, const std::vector<double> &seeds,
                                                double max_length) const;
    void add_segments(const Grid &g, const std::vector<double> &line, const std::vector<double> &deviation, int family,
                      double min_length, Shearlines &out) const;
    Shearlines shearlines(const sdk::Host &host, const CauchyGreenField &cg, const ShearFields &shear,
                          double max_length, double min_length) const;
    void draw_shearlines(const sdk::Host &host, const gb_extract_input &in, const CauchyGreenField &cg,
                         const Shearlines &found, const std::vector<std::size_t> &barriers) const;
};

// Jet cores: trenches of the FTLE (a monotone function of lambda2, on a log scale), at least min_length long,
// deepest first.
void Parabolic::extract_shearless(const sdk::Host &host, const gb_extract_input &in) const {
    const auto started = std::chrono::steady_clock::now();
    const CauchyGreenField cg = cauchy_green_from_input(in);
    const Grid &g = cg.grid;
    const double diagonal = std::hypot(g.x_max - g.x_min, g.y_max - g.y_min);
    const double min_length = m_min_length > 0 ? m_min_length : 0.25 * diagonal;
    // The FTLE is a scalar: it stays usable at degenerate points (C = I at a steady jet core, FTLE = 0).
    double low = HUGE_VAL, high = -HUGE_VAL;
    for (std::size_t k = 0; k < g.size(); ++k)
        if (!(cg.mask[k] & mask_trajectory_bits) && std::isfinite(cg.ftle[k])) {
            low = std::min(low, cg.ftle[k]);
            high = std::max(high, cg.ftle[k]);
        }
    parabolic::TrenchSettings settings;
    settings.min_depth = high > low ? m_min_depth * (high - low) : HUGE_VAL;
    settings.max_length = m_max_length > 0 ? m_max_length : 2.0 * diagonal;
    const std::vector<parabolic::Trench> all =
        parabolic::trace_trenches(g, cg.ftle, cg.mask, mask_trajectory_bits, settings);
    if (host.progress(0.8)) throw std::runtime_error("parabolic: stopped on request");
    std::vector<const parabolic::Trench *> kept;
    for (const parabolic::Trench &t : all)
        if (t.length >= min_length) kept.push_back(&t);
    std::stable_sort(kept.begin(), kept.end(), [](const parabolic::Trench *a, const parabolic::Trench *b) {
        return a->mean_depth > b->mean_depth;
    });
    if (m_max_barriers > 0 && kept.size() > m_max_barriers) kept.resize(m_max_barriers);
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    host.info(std::to_string(all.size()) + " FTLE trenches at least " + format(settings.min_depth) + " deep, " +
              std::to_string(kept.size()) + " at least " + format(min_length) +
              " long: parabolic barriers (jet cores) in " + format(elapsed) + " s");
    // A jet core's FTLE is zero in theory (C = I on it); what the grid then holds is rounding (2.6e-16 against
    // 2.3e-16 in two builds on parallel-shear-jet, FTLE range 0.2), no figure of the barrier. A mean below this
    // floor is reported as the bound `mean_ftle_below` instead of a value.
    const double ftle_floor = high > low ? unresolved_ftle * (high - low) : 0.0;
    for (std::size_t b = 0; b < kept.size(); ++b) {
        const parabolic::Trench &t = *kept[b];
        const CurveStats ftle =
            curve_statistics(t.xy, sample_along(g, cg.ftle, cg.mask, t.xy, mask_trajectory_bits), t.closed);
        std::vector<std::pair<std::string, double>> metrics = {{"length", t.length}};
        if (std::abs(ftle.mean) < ftle_floor)
            metrics.emplace_back("mean_ftle_below", ftle_floor);
        else
            metrics.emplace_back("mean_ftle", ftle.mean);
        metrics.emplace_back("trench_depth", t.mean_depth);
        metrics.emplace_back("rank", static_cast<double>(b + 1));
        host.add_barrier("parabolic", t.closed, t.xy, metrics);
        host.set_barrier_attributes({{"method", "\"shearless\""}});
    }
    // The picture: trenches too short (black) and the barriers (red) over the FTLE.
    if (in.plots && in.output_dir) {
        FieldPlot plot;
        plot.title = "Parabolic barriers (jet cores, red): FTLE trenches; shorter trenches black";
        plot.colorbar_label = "FTLE";
        plot.x_label = sdk::axis_label(in, 0);
        plot.y_label = sdk::axis_label(in, 1);
        for (const parabolic::Trench &t : all)
            if (t.length < min_length) plot.curves.push_back({t.xy, "black", 0.8, t.closed});
        for (const parabolic::Trench *t : kept) plot.curves.push_back({t->xy, "red", 2.5, t->closed});
        sdk::draw_field_png(host, std::filesystem::path(in.output_dir) / "parabolic.png", g, cg.ftle, ftle_mask(cg),
                            plot);
    }
}

// The seeds of one family: every seed_spacing-th grid point where d_g < epsilon and eta is defined.
std::vector<double> Parabolic::shearline_seeds(const Grid &g, const LineField &field,
                                               const std::vector<double> &deviation) const {
    std::vector<double> seeds;
    for (std::size_t i = 0; i < g.ny; i += m_seed_spacing)
        for (std::size_t j = 0; j < g.nx; j += m_seed_spacing) {
            const double d = deviation[i * g.nx + j];
            if (!(d < m_epsilon) || field.status_at(g.x(j), g.y(i)) != LineStatus::ok) continue;
            seeds.insert(seeds.end(), {g.x(j), g.y(i)});
        }
    return seeds;
}

// Shearlines r' = eta(r) (eq. `shrline`) from the seeds, both ways. Seeds whose grid point a line of this family
// already passed (its nearest grid point) would give that line again: they are skipped. Blocks of seeds are
// integrated in parallel, then their lines marked.
std::vector<TwoWayLine> Parabolic::distinct_shearlines(const Grid &g, const LineField &field,
                                                       const std::vector<double> &seeds, double max_length) const {
    const std::size_t n = seeds.size() / 2;
    TensorLineSettings settings;
    settings.method = m_line_method;
    settings.max_length = max_length;
    settings.detect_closure = true;
    std::vector<std::uint8_t> visited(g.size(), 0);
    std::vector<TwoWayLine> lines;
    const std::size_t block = 64;
    for (std::size_t start = 0; start < n; start += block) {
        std::vector<std::size_t> unvisited_seeds;
        for (std::size_t k = start; k < std::min(n, start + block); ++k) {
            if (!visited[g.nearest_point(seeds[2 * k], seeds[2 * k + 1])]) unvisited_seeds.push_back(k);
        }
        std::vector<double> block_seeds;
        for (const std::size_t k : unvisited_seeds)
            block_seeds.insert(block_seeds.end(), {seeds[2 * k], seeds[2 * k + 1]});
        std::vector<TwoWayLine> block_lines = integrate_tensor_lines_both_ways(field, block_seeds, settings);
        for (TwoWayLine &line : block_lines) {
            for (std::size_t p = 0; p + 1 < line.xy.size(); p += 2) {
                // Not Grid::nearest_point: a point more than half a cell off the grid marks no grid point.
                const long j = std::lround((line.xy[p] - g.x_min) / g.dx());
                const long i = std::lround((line.xy[p + 1] - g.y_min) / g.dy());
                if (i >= 0 && j >= 0 && i < static_cast<long>(g.ny) && j < static_cast<long>(g.nx))
                    visited[static_cast<std::size_t>(i) * g.nx + static_cast<std::size_t>(j)] = 1;
            }
            lines.push_back(std::move(line));
        }
    }
    return lines;
}

// A segment of a shearline with its figures: mean and max d_g^eta (eq. `dg_shr`), midpoint, bounding box.
Candidate measured_segment(int family, std::vector<double> xy, double length, const std::vector<double> &deviation) {
    Candidate s;
    s.family = family;
    s.xy = std::move(xy);
    s.length = length;
    const CurveStats stats = curve_statistics(s.xy, deviation);
    s.mean_deviation = stats.mean;
    s.max_deviation = stats.max;
    const std::vector<double> c = cumulative_length(s.xy);
    const std::size_t mid = std::min<std::size_t>(
        c.size() - 1, static_cast<std::size_t>(std::lower_bound(c.begin(), c.end(), 0.5 * s.length) - c.begin()));
    s.mid_x = s.xy[2 * mid];
    s.mid_y = s.xy[2 * mid + 1];
    return s;
}

// One open shearline truncated to the compact segments with d_g^eta < epsilon at every point; those at least
// min_length long with a finite mean deviation become candidates.
void Parabolic::add_segments(const Grid &g, const std::vector<double> &line, const std::vector<double> &deviation,
                             int family, double min_length, Shearlines &out) const {
    const std::vector<double> dev = sample_along(g, deviation, {}, line);
    for (const auto &[first, end] : runs_below(dev, m_epsilon)) {
        std::vector<double> xy(line.begin() + 2 * first, line.begin() + 2 * end);
        const double length = polyline_length(xy);
        if (length < min_length) {
            ++out.short_segments;
            continue;
        }
        Candidate s = measured_segment(family, std::move(xy), length,
                                       std::vector<double>(dev.begin() + first, dev.begin() + end));
        if (std::isfinite(s.mean_deviation)) out.candidates.push_back(std::move(s));
    }
}

// Step 1: shearlines of each family searched, from a lattice of grid points where d_g < epsilon, truncated to
// their candidate segments. Closed shearlines are elliptic, not parabolic: left out.
Shearlines Parabolic::shearlines(const sdk::Host &host, const CauchyGreenField &cg, const ShearFields &shear,
                                 double max_length, double min_length) const {
    Shearlines found;
    for (const int sign : shearline_family_signs(m_families)) {
        const LineField field = shear_line_field(cg, shear, sign, m_singular_gap);
        const std::vector<double> &deviation = sign > 0 ? shear.deviation_plus : shear.deviation_minus;
        const std::vector<double> seeds = shearline_seeds(cg.grid, field, deviation);
        for (const TwoWayLine &line : distinct_shearlines(cg.grid, field, seeds, max_length)) {
            if (line.closed) {
                ++found.closed_lines;
                continue;
            }
            found.open_lines.push_back(line.xy);
            add_segments(cg.grid, line.xy, deviation, sign, min_length, found);
        }
        if (host.progress(sign > 0 ? 0.4 : 0.8)) throw std::runtime_error("parabolic: stopped on request");
    }
    return found;
}

// Step 2a: the segments whose mean deviation is a local minimum among their neighbours (the segments passing within
// `radius` of their midpoint, either family).
std::vector<std::size_t> minima_of_mean_deviation(const std::vector<Candidate> &candidates, const SegmentIndex &points,
                                                  double radius) {
    std::vector<std::size_t> minima;
    for (std::size_t c = 0; c < candidates.size(); ++c) {
        const std::vector<std::size_t> near = points.ids_within(candidates[c].mid_x, candidates[c].mid_y, radius);
        const bool minimal = std::none_of(near.begin(), near.end(), [&](std::size_t d) {
            return d != c && candidates[d].mean_deviation < candidates[c].mean_deviation;
        });
        if (minimal) minima.push_back(c);
    }
    return minima;
}

// Step 2b: the minima thinned so that one barrier stands for all the copies found from seeds along it: visited from
// the least mean deviation up (ties: the longer first), those passing within `radius` of a kept barrier's midpoint or
// whose midpoint a kept one passes near are dropped; at most max_barriers (0: all) kept.
std::vector<std::size_t> disjoint_minima(const std::vector<Candidate> &candidates, const SegmentIndex &points,
                                         std::vector<std::size_t> minima, double radius, std::size_t max_barriers) {
    std::sort(minima.begin(), minima.end(), [&](std::size_t a, std::size_t b) {
        if (candidates[a].mean_deviation != candidates[b].mean_deviation)
            return candidates[a].mean_deviation < candidates[b].mean_deviation;
        return candidates[a].length > candidates[b].length;
    });
    std::vector<std::size_t> barriers;
    for (std::size_t c : minima) {
        bool taken = false;
        for (std::size_t b : barriers)
            taken = taken || points.id_within(b, candidates[c].mid_x, candidates[c].mid_y, radius) ||
                    points.id_within(c, candidates[b].mid_x, candidates[b].mid_y, radius);
        if (taken) continue;
        barriers.push_back(c);
        if (max_barriers > 0 && barriers.size() >= max_barriers) break;
    }
    return barriers;
}

// The picture: open shearlines (grey), candidates (black), barriers (red) over the FTLE.
void Parabolic::draw_shearlines(const sdk::Host &host, const gb_extract_input &in, const CauchyGreenField &cg,
                                const Shearlines &found, const std::vector<std::size_t> &barriers) const {
    FieldPlot plot;
    plot.title = "Parabolic barriers (red); shearlines with d_g < " + format(m_epsilon) + " (black)";
    plot.colorbar_label = "FTLE";
    plot.x_label = sdk::axis_label(in, 0);
    plot.y_label = sdk::axis_label(in, 1);
    const std::size_t stride = std::max<std::size_t>(1, found.open_lines.size() / 150);
    for (std::size_t l = 0; l < found.open_lines.size(); l += stride)
        plot.curves.push_back({found.open_lines[l], "#b0b0b0", 0.6, false});
    for (const Candidate &s : found.candidates) plot.curves.push_back({s.xy, "black", 0.8, false});
    for (std::size_t b : barriers) plot.curves.push_back({found.candidates[b].xy, "red", 2.5, false});
    sdk::draw_field_png(host, std::filesystem::path(in.output_dir) / "parabolic.png", cg.grid, cg.ftle, ftle_mask(cg),
                        plot);
}

// The shearline method (paper, section 2.1): open shearlines and their segments with d_g^eta < epsilon (step 1), the
// disjoint local minima of the mean deviation (step 2), reported best first, and the picture.
void Parabolic::extract(const sdk::Host &host, const gb_extract_input &in) const {
    if (m_shearless) return extract_shearless(host, in);
    const auto started = std::chrono::steady_clock::now();
    const CauchyGreenField cg = cauchy_green_from_input(in);
    const Grid &g = cg.grid;
    const ShearFields shear =
        shear_fields(cg, m_area_preserving ? ShearDeviationForm::area_preserving : ShearDeviationForm::general);
    const double diagonal = std::hypot(g.x_max - g.x_min, g.y_max - g.y_min);
    const double spacing = std::max(g.dx(), g.dy()) * static_cast<double>(m_seed_spacing);
    const double max_length = m_max_length > 0 ? m_max_length : 2.0 * diagonal;
    const double min_length = m_min_length > 0 ? m_min_length : 0.25 * diagonal;
    const double radius = m_neighbour_distance > 0 ? m_neighbour_distance : 3.0 * spacing;

    const Shearlines found = shearlines(host, cg, shear, max_length, min_length);
    const std::vector<Candidate> &candidates = found.candidates;
    host.info("" + std::to_string(found.open_lines.size()) + " open shearlines (" + std::to_string(found.closed_lines) +
              " closed ones left to the elliptic extractor), " + std::to_string(candidates.size()) +
              " segments with d_g < " + format(m_epsilon) + " at least " + format(min_length) + " long (" +
              std::to_string(found.short_segments) + " shorter)");
    const SegmentIndex points = candidate_points(candidates, radius);
    const std::vector<std::size_t> minima = minima_of_mean_deviation(candidates, points, radius);
    const std::vector<std::size_t> barriers = disjoint_minima(candidates, points, minima, radius, m_max_barriers);
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    host.info("" + std::to_string(minima.size()) + " local minima of the mean deviation, " +
              std::to_string(barriers.size()) + " parabolic barriers (neighbour distance " + format(radius) + ") in " +
              format(elapsed) + " s");

    for (std::size_t b = 0; b < barriers.size(); ++b) {
        const Candidate &s = candidates[barriers[b]];
        host.add_barrier("parabolic", false, s.xy,
                         {{"length", s.length},
                          {"mean_geodesic_deviation", s.mean_deviation},
                          {"max_geodesic_deviation", s.max_deviation},
                          {"rank", static_cast<double>(b + 1)}});
        host.set_barrier_attributes({{"family", s.family > 0 ? "\"+\"" : "\"-\""}, {"method", "\"shearline\""}});
    }
    if (in.plots && in.output_dir) draw_shearlines(host, in, cg, found, barriers);
}

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::extractor<Parabolic>())
