// The `elliptic` extractor: elliptic transport barriers (generalized KAM tori) as closed shearlines whose mean
// geodesic shear deviation is small (paper Alg. 2), in regions found from the Cauchy–Green field itself; then the
// theory's checks on each barrier: arclength and enclosed area kept under advection (eq. `rel_def`) and, for
// periodic forcing, Poincaré iterates staying on the curve.
#include "closed_shearlines.hpp"

#include <geobarrier/curves.hpp>
#include <geobarrier/extractor_keys.hpp>
#include <geobarrier/line_field.hpp>
#include <geobarrier/output.hpp>
#include <geobarrier/sdk.hpp>
#include <geobarrier/sdk_plot.hpp>
#include <geobarrier/shear.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using namespace geobarrier;
using namespace geobarrier::elliptic;
using geobarrier::sdk::bool_param;
using geobarrier::sdk::integer_param;
using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;
using geobarrier::sdk::string_param;
using nlohmann::json;

// A kept closed shearline covers at least this fraction of its length with finite d_g (the rest sits in cells
// where the derivatives are undefined); otherwise its mean is not trusted.
constexpr double min_deviation_coverage = 0.9;

// The flow map counts as area-preserving (conservation of arclength and area expected) when |ln det DF| is below
// this at 99% of the grid points: det DF within 0.01% of 1, two orders below the 1.5% arclength change the paper
// accepts (eq. `rel_def`), while a damping delta gives |ln det DF| = delta |T| everywhere (3.8 for the paper's
// delta = 0.15 over 8 pi). The quantile, not the maximum, so that a few points where an auxiliary-grid DF lost
// its accuracy do not decide.
constexpr double max_log_det_conservative = 1e-4;

std::vector<Section> parse_sections(const std::string &text) {
    std::vector<Section> out;
    std::stringstream all(text);
    std::string item;
    while (std::getline(all, item, ';')) {
        if (item.find_first_not_of(" \t,") == std::string::npos) continue;
        for (char &c : item)
            if (c == ',') c = ' ';
        std::stringstream one(item);
        Section s;
        if (!(one >> s.x0 >> s.y0 >> s.x1 >> s.y1) || !(s.length() > 0.0))
            throw std::invalid_argument("elliptic: sections: \"" + item +
                                        "\" is not \"x0 y0 x1 y1\" with two distinct points");
        std::string rest;
        if (one >> rest) throw std::invalid_argument("elliptic: sections: \"" + item + "\" has more than 4 numbers");
        out.push_back(s);
    }
    return out;
}

std::string fmt(double v, int digits = 4) {
    std::ostringstream s;
    s.precision(digits);
    s << v;
    return s.str();
}

// d_g^eta± at (x, y) from exact Cauchy–Green tensors: the 3 x 3 patch of DF `spacing` apart around it (dF, mask:
// the patch's 9 points), the patch's tensor and shear fields (the grid's own formulas: shear_fields, centred
// differences), the deviation at the centre.
double patch_centre_deviation(const double *dF, const std::uint8_t *mask, double x, double y, double spacing,
                              double duration, int sign, ShearDeviationForm form) {
    constexpr std::size_t side = 3, per_vertex = side * side;
    Grid patch;
    patch.nx = patch.ny = side;
    patch.x_min = x - spacing;
    patch.x_max = x + spacing;
    patch.y_min = y - spacing;
    patch.y_max = y + spacing;
    const std::vector<double> patch_dF(dF, dF + 4 * per_vertex);
    const std::vector<std::uint8_t> patch_mask(mask, mask + per_vertex);
    const CauchyGreenField cg = cauchy_green_field(patch, patch_dF, patch_mask, duration);
    const ShearFields shear = shear_fields(cg, form);
    return (sign > 0 ? shear.deviation_plus : shear.deviation_minus)[per_vertex / 2];
}

// <d_g^eta±> along closed curves (each with its family's sign) from exact Cauchy–Green tensors instead of the
// grid's: at every vertex, DF on a 3 x 3 patch `spacing` apart (host advection with the experiment's integrator)
// and d_g at its centre (patch_centre_deviation); arclength-weighted mean per curve. Removes the grid's O(h^2)
// derivative error and the bilinear interpolation, which grow with T next to the chaotic layer. Every curve's
// patches go in one advection and one parallel loop: the engine sees one large batch, and the threads meet once
// instead of at every vertex's small tensor fields.
std::vector<double> exact_mean_deviations(const sdk::Host &host, const gb_extract_input &in,
                                          const std::vector<std::vector<double>> &curves, const std::vector<int> &signs,
                                          double spacing, ShearDeviationForm form) {
    constexpr std::size_t side = 3, per_vertex = side * side;
    std::vector<std::size_t> first(curves.size() + 1, 0); // each curve's first vertex in the batch
    for (std::size_t c = 0; c < curves.size(); ++c) first[c + 1] = first[c] + curves[c].size() / 2;
    const std::size_t total = first.back();
    std::vector<double> centres, patch_points(2 * per_vertex * total);
    std::vector<int> vertex_sign(total);
    centres.reserve(2 * total);
    for (std::size_t c = 0; c < curves.size(); ++c) {
        centres.insert(centres.end(), curves[c].begin(), curves[c].end());
        std::fill(vertex_sign.begin() + first[c], vertex_sign.begin() + first[c + 1], signs[c]);
    }
    for (std::size_t k = 0; k < total; ++k)
        for (std::size_t q = 0; q < per_vertex; ++q) {
            patch_points[2 * (k * per_vertex + q)] = centres[2 * k] + spacing * (static_cast<double>(q % side) - 1.0);
            patch_points[2 * (k * per_vertex + q) + 1] =
                centres[2 * k + 1] + spacing * (static_cast<double>(q / side) - 1.0);
        }
    std::vector<double> moved, dF;
    std::vector<std::uint8_t> mask;
    host.advect(patch_points, in.t0, in.t1, moved, mask, &dF);
    std::vector<double> values(total);
    const double duration = std::abs(in.t1 - in.t0);
#pragma omp parallel for schedule(static)
    for (long long kk = 0; kk < static_cast<long long>(total); ++kk) {
        const std::size_t k = static_cast<std::size_t>(kk);
        values[k] = patch_centre_deviation(dF.data() + 4 * k * per_vertex, mask.data() + k * per_vertex, centres[2 * k],
                                           centres[2 * k + 1], spacing, duration, vertex_sign[k], form);
    }
    std::vector<double> means(curves.size());
    for (std::size_t c = 0; c < curves.size(); ++c) {
        const std::vector<double> curve_values(values.begin() + first[c], values.begin() + first[c + 1]);
        const CurveStats st = curve_statistics(curves[c], curve_values, true);
        means[c] = st.finite_points ? st.mean : std::numeric_limits<double>::quiet_NaN();
    }
    return means;
}

json finite_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

// One closed shearline found, with what is measured on it.
struct Found {
    std::size_t candidate = 0;
    ClosedShearline orbit;
    double length = 0.0, area = 0.0, mean_deviation = 0.0, max_deviation = 0.0, coverage = 0.0;
    // <d_g> from exact Cauchy-Green tensors, when the selection uses it (NaN: not computed, or masked throughout)
    double exact_mean_deviation = std::numeric_limits<double>::quiet_NaN();
    double max_ftle = 0.0, mean_ftle = 0.0;
    bool kept = false;
    std::size_t island = 0;
    bool outermost = false;
    double centroid_x = 0.0, centroid_y = 0.0;
    double lambda = 0.0; // > 0: a closed generalized lambda-line of this lambda (no <d_g> test)
    double stretching = std::numeric_limits<double>::quiet_NaN(); // lambda-line fallback: advected length / length
};

// What Alg. 2's steps 2-3 produced over every region and family.
struct Search {
    std::vector<Found> found;                       // every closed shearline, kept or not
    std::vector<std::vector<double>> picture_lines; // launched shearlines kept for the picture
    json regions = json::array();                   // elliptic-sections.json: one entry per region and family
    std::size_t dropped_ftle = 0;                   // passed the <d_g> test but lie on the chaotic side
    json lambda_fallback = json::array();           // elliptic-sections.json: each lambda tried by the fallback
};

// One lambda tried by the lambda-line fallback in one region and family: how many closed lambda-lines its return map
// gave, the median return displacement P(sigma) - sigma (its sign says which way the lambda-lines spiral), and the
// closed lambda-lines kept (the FTLE bound of step 6 only).
struct LambdaTrial {
    double lambda = 0.0;
    int sign = +1;
    std::size_t region = 0, closed = 0;
    double displacement = std::numeric_limits<double>::quiet_NaN();
    std::vector<Found> kept;
};

// What every region's search uses besides its own section and family.
struct SearchInputs {
    const CauchyGreenField &cg;
    const ReturnMapSettings &return_map;
    double island_threshold; // FTLE above which an island ends (step 6)
    bool lambda_lines;       // generalized lambda-lines: no <d_g> test
    const gb_extract_input &in;
    double h; // the smaller grid spacing
};

using Metrics = std::vector<std::pair<std::string, double>>;

// A closed shearline's geometry and the grid's fields along it: length, enclosed area, <d_g^eta> (arclength mean
// of the grid's pointwise deviation of the family, with the fraction of the length where it is finite), FTLE
// along it, centroid.
Found measure_closed_shearline(const CauchyGreenField &cg, const std::vector<double> &deviation, std::size_t candidate,
                               ClosedShearline &&orbit) {
    const Grid &grid = cg.grid;
    Found f;
    f.candidate = candidate;
    f.length = polyline_length(orbit.xy, true);
    f.area = std::abs(shoelace_area(orbit.xy));
    const std::vector<double> values = sample_along(grid, deviation, cg.mask, orbit.xy, mask_trajectory_bits);
    const CurveStats st = curve_statistics(orbit.xy, values, true);
    f.mean_deviation = st.finite_points ? st.mean : std::numeric_limits<double>::quiet_NaN();
    f.max_deviation = st.max;
    f.coverage = f.length > 0.0 ? st.covered_length / f.length : 0.0;
    const CurveStats ft =
        curve_statistics(orbit.xy, sample_along(grid, cg.ftle, cg.mask, orbit.xy, mask_trajectory_bits), true);
    f.max_ftle = ft.max;
    f.mean_ftle = ft.mean;
    double cx = 0.0, cy = 0.0;
    const std::size_t np = orbit.xy.size() / 2;
    for (std::size_t k = 0; k < np; ++k) {
        cx += orbit.xy[2 * k];
        cy += orbit.xy[2 * k + 1];
    }
    f.centroid_x = cx / static_cast<double>(np);
    f.centroid_y = cy / static_cast<double>(np);
    f.orbit = std::move(orbit);
    return f;
}

json closed_shearline_json(const Found &f) {
    return {{"sigma", f.orbit.sigma},
            {"fixed_point", f.orbit.fixed_point},
            {"closure_error", f.orbit.closure_error},
            {"extrapolated_gap", finite_or_null(f.orbit.extrapolated_gap)},
            {"length", f.length},
            {"enclosed_area", f.area},
            {"mean_geodesic_deviation", finite_or_null(f.mean_deviation)},
            {"mean_geodesic_deviation_exact", finite_or_null(f.exact_mean_deviation)},
            {"mean_ftle", finite_or_null(f.mean_ftle)},
            {"kept", f.kept}};
}

// One region and family in elliptic-sections.json: the section, the return map's samples (sigma, P(sigma), its
// Richardson extrapolation) and the closed shearlines found on it.
json region_json(std::size_t region, const Candidate &cand, int sign, const ReturnMap &map, std::size_t kept,
                 json closed) {
    json samples = json::array();
    for (std::size_t k = 0; k < map.sigma.size(); ++k)
        samples.push_back({map.sigma[k], finite_or_null(map.image[k]), finite_or_null(map.extrapolated[k])});
    return {{"region", region},
            {"family", sign > 0 ? "+" : "-"},
            {"origin", cand.origin},
            {"centre", {cand.x, cand.y}},
            {"section", {{cand.section.x0, cand.section.y0}, {cand.section.x1, cand.section.y1}}},
            {"returned", map.returned},
            {"brackets", map.brackets},
            {"failed_brackets", map.failed_brackets},
            {"closed", map.closed.size()},
            {"kept", kept},
            {"closed_shearlines", std::move(closed)},
            {"return_map", std::move(samples)}};
}

// The log line of one region and family: how many launched shearlines returned, why the others did not, how many
// closed and passed.
std::string region_summary(std::size_t region, const Candidate &cand, int sign, const ReturnMap &map, std::size_t kept,
                           const std::string &deviation_rule) {
    std::size_t stops[7] = {0, 0, 0, 0, 0, 0, 0}; // by StopReason
    for (std::size_t k = 0; k < map.sigma.size(); ++k)
        if (!std::isfinite(map.image[k])) ++stops[static_cast<int>(map.stop[k])];
    return "region " + std::to_string(region) + " (" + cand.origin + " at " + fmt(cand.x) + ", " + fmt(cand.y) +
           "), eta" + (sign > 0 ? "+" : "-") + ": " + std::to_string(map.returned) + "/" +
           std::to_string(map.sigma.size()) + " shearlines returned (not: " + std::to_string(stops[0]) + " edge, " +
           std::to_string(stops[1]) + " masked, " + std::to_string(stops[2]) + " singular, " +
           std::to_string(stops[3] + stops[5]) + " too long); " + std::to_string(map.closed.size()) + " closed, " +
           std::to_string(kept) + " with " + deviation_rule +
           (map.failed_brackets ? "; " + std::to_string(map.failed_brackets) + " secant failure(s)" : "");
}

// Near-identical curves (same family, within half a grid spacing everywhere, e.g. from two regions of one island)
// are one: the first of them is kept.
std::vector<std::size_t> drop_near_identical(const std::vector<Found> &found, const std::vector<std::size_t> &order,
                                             double h) {
    std::vector<std::size_t> kept;
    for (std::size_t i : order) {
        bool duplicate = false;
        for (std::size_t j : kept) {
            const Found &a = found[i], &b = found[j];
            if (a.orbit.sign != b.orbit.sign || std::abs(a.area - b.area) > 0.05 * std::max(a.area, b.area) ||
                std::hypot(a.centroid_x - b.centroid_x, a.centroid_y - b.centroid_y) > h)
                continue;
            if (curve_distance(a.orbit.xy, b.orbit.xy, 8) < 0.5 * h) {
                duplicate = true;
                break;
            }
        }
        if (!duplicate) kept.push_back(i);
    }
    return kept;
}

// Islands: a region whose centre lies inside a barrier of another region belongs to the same island (union-find
// over the regions). Islands are numbered in the order their first kept barrier appears; each barrier gets its
// region's island.
void assign_islands(std::vector<Found> &found, const std::vector<std::size_t> &kept,
                    const std::vector<Candidate> &candidates) {
    std::vector<std::size_t> parent(candidates.size());
    std::iota(parent.begin(), parent.end(), 0);
    auto root = [&](std::size_t a) {
        while (parent[a] != a) a = parent[a] = parent[parent[a]];
        return a;
    };
    for (std::size_t i : kept)
        for (std::size_t c = 0; c < candidates.size(); ++c)
            if (root(c) != root(found[i].candidate) && encloses(found[i].orbit.xy, candidates[c].x, candidates[c].y))
                parent[root(c)] = root(found[i].candidate);
    std::vector<std::size_t> label(candidates.size(), SIZE_MAX);
    std::size_t next = 0;
    for (std::size_t i : kept) {
        const std::size_t r = root(found[i].candidate);
        if (label[r] == SIZE_MAX) label[r] = next++;
    }
    for (std::size_t i : kept) found[i].island = label[root(found[i].candidate)];
}

// The outermost barrier of each island: the largest enclosed area (the first found on a tie).
void mark_outermost(std::vector<Found> &found, const std::vector<std::size_t> &kept) {
    for (std::size_t i : kept) {
        bool largest = true;
        for (std::size_t j : kept)
            if (j != i && found[j].island == found[i].island &&
                (found[j].area > found[i].area || (found[j].area == found[i].area && j < i)))
                largest = false;
        found[i].outermost = largest;
    }
}

// Eq. rel_def: the barrier advected to t1 (a, from advect_curves) keeps its arclength and enclosed area when the
// flow is conservative.
void add_advection_metrics(const sdk::Host &host, const AdvectedCurve &a, std::size_t index, Metrics &metrics) {
    metrics.emplace_back("relative_length_change", (a.length1 - a.length0) / a.length0);
    metrics.emplace_back("relative_area_change", (std::abs(a.area1) - std::abs(a.area0)) / std::abs(a.area0));
    metrics.emplace_back("advected_points", static_cast<double>(a.xy1.size() / 2));
    if (!a.converged)
        host.warn("barrier " + std::to_string(index) + ": the advected curve is not fully resolved (" +
                  std::to_string(a.masked) + " masked points, largest gap " + fmt(a.max_gap) + ")");
}

// The Poincaré check's figures of one barrier (drifts relative to its diameter).
struct PoincareDrift {
    double median = 0.0, worst = 0.0, diameter = 0.0;
};

struct Elliptic {
    static constexpr const char *name = "elliptic";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc =
        "elliptic barriers: closed shearlines with small geodesic deviation (paper Alg. 2), regions found "
        "automatically";
    static constexpr const char *required_fields[] = {"lambda1", "lambda2", "xi1_x", "xi1_y", "ftle", nullptr};
    static constexpr gb_param_spec params[] = {
        real_param("max_mean_deviation", 0.7, 0.0, HUGE_VAL, "",
                   "keep closed shearlines whose mean geodesic shear deviation is below this (paper: 0.7)"),
        integer_param("launch_points", 500, 4, 1000000, "shearlines launched from each Poincare section (paper: 500)"),
        shearline_families_param("shearline families searched: eta+, eta- or both"),
        string_param("sections", "", nullptr,
                     "Poincare sections by hand, \"x0 y0 x1 y1; ...\" from the region's centre outwards; when given, "
                     "no regions are searched"),
        real_param(
            "max_anisotropy", 0.3, 0.0, 1.0, "",
            "a CG singularity counts only where (l2-l1)/(l2+l1) around it is below this (resolved, not aliased)"),
        real_param("ftle_threshold", 0.0, 0.0, HUGE_VAL, "1/time",
                   "FTLE above which an elliptic island ends; 0 = automatic (Otsu split of the FTLE values)"),
        real_param("section_margin", 1.25, 1.0, 10.0, "", "section length as a multiple of the island's reach"),
        real_param("max_turns", 1.5, 1.0, 1000.0, "",
                   "longest shearline followed, in turns around a circle whose radius is the section length"),
        singular_gap_param("shearlines stop in cells where lambda2 - lambda1 <= singular_gap * lambda2"),
        deviation_form_param("d_g formula: general (any flow) or the paper's eq. dg_shr (lambda1 lambda2 = 1 only)"),
        string_param("advect", "all", "all|outermost|none",
                     "barriers advected to t1 to measure their arclength and area change (paper eq. rel_def)"),
        real_param("poincare_period", 0.0, 0.0, HUGE_VAL, "time",
                   "forcing period: iterate barrier points with the Poincare map F_t0^(t0+period); 0 = off"),
        integer_param("poincare_iterates", 20, 1, 100000, "Poincare map iterates of each barrier's points"),
        integer_param("poincare_points", 200, 8, 100000, "points per barrier iterated by the Poincare map"),
        integer_param("plot_shearlines", 24, 0, 100000, "launched shearlines drawn per section and family"),
        line_method_param(),
        real_param("line_rtol", 1e-6, 1e-14, 1e-2, "",
                   "relative tolerance of shearline integration (adaptive line_method only)"),
        real_param("barrier_spacing", 0.05, 0.0, 1.0, "",
                   "nested barriers of one region and family reported this far apart, as a fraction of the "
                   "outermost's equivalent radius (0 = all)"),
        real_param("resolution_gap", 0.1, 0.0, HUGE_VAL, "grid spacings",
                   "shearlines returning this close to their launch point count as closed (0 = fixed points only)"),
        real_param(
            "lambda", 0.0, 0.0, HUGE_VAL, "",
            "0: shearlines (eq. shrvec); > 0: closed generalized lambda-lines, |DF e| = lambda |e| (Haller & "
            "Beron-Vera 2013; lambda = 1 gives the shearlines of a conservative system), kept without a d_g test"),
        bool_param("lambda_fallback", true,
                   "in a region where no closed shearline passes the <d_g> test, report the outermost closed "
                   "lambda-line over lambda_min..lambda_max instead (Haller & Beron-Vera 2013); off: report nothing"),
        real_param("lambda_min", 0.9, 0.01, 1.0, "", "smallest lambda the fallback tries (the range holds 1)"),
        real_param("lambda_max", 1.1, 1.0, 100.0, "", "largest lambda the fallback tries"),
        real_param("lambda_step", 0.02, 1e-4, 1.0, "",
                   "the fallback tries lambda = 1, 1 +- step, 1 +- 2 step, ... within [lambda_min, lambda_max]"),
        integer_param("lambda_bisections", 8, 0, 60,
                      "where no tried lambda closes a lambda-line but the lambda-lines turn from spiralling in to "
                      "spiralling out between two neighbouring lambdas, halve that interval up to this many times"),
        string_param("conservative", "auto", "auto|yes|no",
                     "whether arclength and area conservation is expected: auto = decided from det DF = "
                     "sqrt(lambda1 lambda2) on the grid (Liouville: the system's divergence over [t0, t1])"),
        bool_param(
            "ftle_filter", true,
            "keep only closed shearlines whose arclength-mean FTLE is below the island threshold (ftle_threshold "
            "or Otsu): barriers on the regular side of the chaotic layer, whatever the grid resolution"),
        real_param("exact_deviation_spacing", 0.0, 0.0, 1.0, "grid spacings",
                   "0: off (a quarter with selection_deviation exact); > 0: also report each barrier's <d_g> from "
                   "exact Cauchy-Green tensors on 3 x 3 patches this many grid spacings apart around its vertices "
                   "(mean_geodesic_deviation_exact)"),
        string_param("selection_deviation", "grid", "grid|exact",
                     "the <d_g> that Alg. 2's test compares with max_mean_deviation: the grid's fields along the "
                     "curve, or exact Cauchy-Green tensors around it (for every closed shearline the rest of the test "
                     "would keep: 9 trajectories per point at exact_deviation_points points; the grid's <d_g> loses "
                     "accuracy next to the chaotic layer as T grows)"),
        integer_param("exact_deviation_points", 256, 0, 1000000,
                      "points per barrier, evenly spaced in arclength, where the exact <d_g> is evaluated (9 "
                      "trajectories each); 0 = every vertex (their number grows with the grid)"),
        bool_param("extrapolate_gap", true,
                   "compare the Richardson-extrapolated return gap (field at h and 2h) with resolution_gap, not the "
                   "gap on the grid, whose O(h^2) interpolation error grows towards the island's edge"),
    };

    explicit Elliptic(const Params &p)
        : m_max_mean_deviation(p.real("max_mean_deviation")),
          m_launch_points(static_cast<std::size_t>(p.integer("launch_points"))), m_families(p.string("families")),
          m_sections(parse_sections(p.string("sections"))), m_max_anisotropy(p.real("max_anisotropy")),
          m_ftle_threshold(p.real("ftle_threshold")), m_section_margin(p.real("section_margin")),
          m_max_turns(p.real("max_turns")), m_singular_gap(p.real("singular_gap")),
          m_area_preserving(p.string("deviation_form") == "area-preserving"), m_advect(p.string("advect")),
          m_poincare_period(p.real("poincare_period")),
          m_poincare_iterates(static_cast<std::size_t>(p.integer("poincare_iterates"))),
          m_poincare_points(static_cast<std::size_t>(p.integer("poincare_points"))),
          m_plot_shearlines(static_cast<std::size_t>(p.integer("plot_shearlines"))), m_line_rtol(p.real("line_rtol")),
          m_resolution_gap(p.real("resolution_gap")), m_barrier_spacing(p.real("barrier_spacing")),
          m_extrapolate_gap(p.flag("extrapolate_gap")), m_ftle_filter(p.flag("ftle_filter")),
          m_conservative(p.string("conservative")), m_lambda(p.real("lambda")),
          m_exact_deviation_spacing(p.real("exact_deviation_spacing")),
          m_exact_selection(p.string("selection_deviation") == "exact"),
          m_exact_deviation_points(static_cast<std::size_t>(p.integer("exact_deviation_points"))),
          m_line_method(tensor_line_method(p.string("line_method"))), m_lambda_fallback(p.flag("lambda_fallback")),
          m_lambda_min(p.real("lambda_min")), m_lambda_max(p.real("lambda_max")), m_lambda_step(p.real("lambda_step")),
          m_lambda_bisections(static_cast<std::size_t>(p.integer("lambda_bisections"))) {}

    void extract(const sdk::Host &host, const gb_extract_input &in) const;

    // The stages of extract, in the order they run (paper Alg. 2, then the theory's checks).
    ShearDeviationForm deviation_form() const;
    ShearFields search_fields(const sdk::Host &host, const CauchyGreenField &cg) const;
    bool conservation_expected(const sdk::Host &host, const AreaPreservation &area) const;
    std::vector<Candidate> candidate_regions(const sdk::Host &host, const CauchyGreenField &cg,
                                             CandidateReport &report) const;
    std::vector<int> families() const;
    ReturnMapSettings return_map_settings(const gb_extract_input &in, double h) const;
    Search search_closed_shearlines(const sdk::Host &host, const SearchInputs &inputs, const ShearFields &shear,
                                    const std::vector<Candidate> &candidates, const std::vector<int> &signs) const;
    void search_region(const sdk::Host &host, const SearchInputs &inputs, const LineField &eta, const LineField *coarse,
                       const std::vector<double> &deviation, int sign, std::size_t region, const Candidate &cand,
                       Search &search) const;
    bool decide_kept(Found &f, double island_threshold, bool lambda_lines) const;
    bool on_chaotic_side(const Found &f, double island_threshold) const;
    bool passes_all_but_deviation(const Found &f, double island_threshold) const;
    // The <d_g> that Alg. 2's test uses (selection_deviation), and the test in words.
    double selection_deviation(const Found &f) const {
        return m_exact_selection ? f.exact_mean_deviation : f.mean_deviation;
    }
    std::string deviation_rule() const {
        return std::string(m_exact_selection ? "exact " : "") + "<d_g> < " + fmt(m_max_mean_deviation);
    }
    void lambda_fallback(const sdk::Host &host, const gb_extract_input &in, const SearchInputs &inputs,
                         const std::vector<Candidate> &candidates, const std::vector<int> &signs, Search &search) const;
    const Found *outermost_lambda_line(const sdk::Host &host, const gb_extract_input &in,
                                       std::vector<LambdaTrial> &trials, std::size_t region,
                                       std::size_t &rejected) const;
    std::vector<double> lambda_scan_values() const;
    std::vector<LambdaTrial> lambda_trials(const SearchInputs &inputs, double lambda,
                                           const std::vector<std::size_t> &regions,
                                           const std::vector<Candidate> &candidates,
                                           const std::vector<int> &signs) const;
    std::vector<LambdaTrial> lambda_bisection(const SearchInputs &inputs, std::size_t region, int sign,
                                              const std::vector<LambdaTrial> &scan,
                                              const std::vector<Candidate> &candidates) const;
    std::string selection(const Found &f) const;
    std::vector<std::size_t> select_barriers(std::vector<Found> &found, const std::vector<Candidate> &candidates,
                                             const std::vector<int> &signs, double h) const;
    std::vector<std::size_t> thin_nested(const std::vector<Found> &found, std::size_t regions,
                                         const std::vector<int> &signs) const;
    Metrics barrier_metrics(const Found &f, const double *exact_deviation) const;
    std::vector<double> exact_deviations(const sdk::Host &host, const gb_extract_input &in,
                                         const std::vector<const Found *> &curves, double h) const;
    std::vector<PoincareDrift> poincare_drifts(const sdk::Host &host, const gb_extract_input &in,
                                               const std::vector<const Found *> &barriers) const;
    void report_barriers(const sdk::Host &host, const gb_extract_input &in, const std::vector<Found> &found,
                         const std::vector<std::size_t> &kept, double h, bool conservative) const;
    void draw_shearlines_picture(const sdk::Host &host, const std::filesystem::path &out_dir,
                                 const CauchyGreenField &cg, const gb_extract_input &in, const Search &search,
                                 const std::vector<Candidate> &candidates, const std::vector<std::size_t> &kept) const;

    double m_max_mean_deviation;
    std::size_t m_launch_points;
    std::string m_families;
    std::vector<Section> m_sections;
    double m_max_anisotropy, m_ftle_threshold, m_section_margin, m_max_turns, m_singular_gap;
    bool m_area_preserving;
    std::string m_advect;
    double m_poincare_period;
    std::size_t m_poincare_iterates, m_poincare_points, m_plot_shearlines;
    double m_line_rtol, m_resolution_gap, m_barrier_spacing;
    bool m_extrapolate_gap, m_ftle_filter;
    std::string m_conservative;
    double m_lambda, m_exact_deviation_spacing;
    bool m_exact_selection;
    std::size_t m_exact_deviation_points;
    TensorLineMethod m_line_method;
    bool m_lambda_fallback;
    double m_lambda_min, m_lambda_max, m_lambda_step;
    std::size_t m_lambda_bisections;
};

void Elliptic::extract(const sdk::Host &host, const gb_extract_input &in) const {
    using clock = std::chrono::steady_clock;
    const auto t_start = clock::now();
    auto seconds_since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };

    const CauchyGreenField cg = cauchy_green_from_input(in);
    const double h = std::min(cg.grid.dx(), cg.grid.dy());
    const bool lambda_lines = m_lambda > 0.0;
    const ShearFields shear = search_fields(host, cg);
    const AreaPreservation area = area_preservation(cg);
    const bool conservative = conservation_expected(host, area);

    // Step 2: candidate regions and their Poincaré sections.
    CandidateReport report;
    const std::vector<Candidate> candidates = candidate_regions(host, cg, report);
    const double t_candidates = seconds_since(t_start);
    // The island threshold also bounds the barriers (step 6): the one the search used, or the same rule's value.
    const double island_threshold =
        m_sections.empty() ? report.ftle_threshold : island_ftle_threshold(cg, m_ftle_threshold);

    // Steps 2-3: return maps, fixed points, closed shearlines and their <d_g>.
    const std::vector<int> signs = families();
    const ReturnMapSettings return_map = return_map_settings(in, h);
    const SearchInputs inputs{cg, return_map, island_threshold, lambda_lines, in, h};
    Search search = search_closed_shearlines(host, inputs, shear, candidates, signs);
    const double t_search = seconds_since(t_start) - t_candidates;
    // Where the eta-lines gave no barrier: the outermost closed lambda-line (step 8).
    if (m_lambda_fallback && !lambda_lines) lambda_fallback(host, in, inputs, candidates, signs, search);
    const double t_fallback = seconds_since(t_start) - t_candidates - t_search;

    // Step 4, then the theory's checks on each barrier.
    const std::vector<std::size_t> kept = select_barriers(search.found, candidates, signs, h);
    report_barriers(host, in, search.found, kept, h, conservative);
    std::size_t islands = 0;
    for (std::size_t i : kept) islands = std::max(islands, search.found[i].island + 1);
    host.info(
        std::to_string(kept.size()) + " elliptic barrier(s) in " + std::to_string(islands) + " island(s) from " +
        std::to_string(search.found.size()) + " closed shearline(s); regions " + fmt(t_candidates, 3) +
        " s, shearlines " + fmt(t_search, 3) + " s, " +
        (!search.lambda_fallback.empty() ? "lambda-line fallback " + fmt(t_fallback, 3) + " s, " : std::string()) +
        "checks " + fmt(seconds_since(t_start) - t_candidates - t_search - t_fallback, 3) + " s");

    const std::filesystem::path out_dir =
        in.output_dir ? std::filesystem::path(in.output_dir) : std::filesystem::path();
    if (out_dir.empty()) return;
    json doc = {{"regions", search.regions},
                {"lambda_fallback", search.lambda_fallback},
                {"ftle_threshold", island_threshold},
                {"ftle_filter", m_ftle_filter},
                {"area_preserving", conservative},
                {"log_det_dF", {{"median", area.median}, {"q99", area.q99}, {"max", area.max}}}};
    json singularities = json::array();
    for (const auto &s : report.singularities)
        if (s.anisotropy < m_max_anisotropy) singularities.push_back({s.x, s.y, 0.5 * s.twice_index, s.anisotropy});
    doc["resolved_singularities"] = singularities;
    write_text_file(out_dir / "elliptic-sections.json", doc.dump(1) + "\n");
    if (in.plots) draw_shearlines_picture(host, out_dir, cg, in, search, candidates, kept);
}

ShearDeviationForm Elliptic::deviation_form() const {
    return m_area_preserving ? ShearDeviationForm::area_preserving : ShearDeviationForm::general;
}

// The line fields whose closed lines are searched: shearlines (eq. shrvec) with their geodesic deviation d_g
// (eq. dg_shr), or generalized lambda-lines, which need none.
ShearFields Elliptic::search_fields(const sdk::Host &host, const CauchyGreenField &cg) const {
    if (!(m_lambda > 0.0)) return shear_fields(cg, strain_derivatives(cg), deviation_form());
    ShearFields fields = lambda_line_fields(cg, m_lambda);
    host.info("closed lambda-lines with lambda = " + fmt(m_lambda) + " (|DF e| = lambda |e|), kept without a d_g test");
    return fields;
}

// Is the flow map area-preserving (paper section 2.1, "conservative": div v = 0)? Only then does the theory say
// that barriers keep their arclength and enclosed area; otherwise both are still measured, as information.
bool Elliptic::conservation_expected(const sdk::Host &host, const AreaPreservation &area) const {
    const bool conservative =
        m_conservative == "auto" ? area.points > 0 && area.q99 <= max_log_det_conservative : m_conservative == "yes";
    host.info(std::string("flow map ") + (conservative ? "" : "not ") + "area-preserving (|ln det DF| median " +
              fmt(area.median) + ", 99% " + fmt(area.q99) + ", max " + fmt(area.max) + " over " +
              std::to_string(area.points) + " points" +
              (m_conservative == "auto" ? "" : "; set by the \"conservative\" parameter") + ")" +
              (conservative ? ": barriers must keep arclength and area"
                            : ": the arclength and area changes of barriers are reported, not expected to vanish"));
    return conservative;
}

// Step 2 of Alg. 2 without looking: candidate regions and their sections, given by hand or found around resolved
// CG singularities in low-FTLE islands (closed_shearlines.hpp, find_candidates).
std::vector<Candidate> Elliptic::candidate_regions(const sdk::Host &host, const CauchyGreenField &cg,
                                                   CandidateReport &report) const {
    std::vector<Candidate> candidates;
    if (!m_sections.empty()) {
        for (const Section &s : m_sections) candidates.push_back({s.x0, s.y0, "section given", s.length(), s});
        host.info(std::to_string(candidates.size()) + " section(s) given; no regions searched");
        return candidates;
    }
    CandidateSettings cs;
    cs.max_anisotropy = m_max_anisotropy;
    cs.ftle_threshold = m_ftle_threshold;
    cs.section_margin = m_section_margin;
    candidates = find_candidates(cg, cs, &report);
    host.info(std::to_string(report.singularities.size()) + " CG singularities, " + std::to_string(report.resolved) +
              " resolved (anisotropy < " + fmt(m_max_anisotropy) + "); FTLE island threshold " +
              fmt(report.ftle_threshold) + "; " + std::to_string(candidates.size()) + " candidate region(s)" +
              (report.rejected_high_ftle
                   ? ", " + std::to_string(report.rejected_high_ftle) + " centre(s) outside low-FTLE islands"
                   : std::string()));
    if (candidates.empty())
        host.warn("no candidate elliptic region (no resolved index +1 singularity or wedge pair in a "
                  "low-FTLE island); give sections by hand with the \"sections\" parameter, or refine the grid");
    return candidates;
}

// The shearline families searched, eta+ (sign +1) before eta- (eq. shrvec).
std::vector<int> Elliptic::families() const { return shearline_family_signs(m_families); }

ReturnMapSettings Elliptic::return_map_settings(const gb_extract_input &in, double h) const {
    ReturnMapSettings rs;
    rs.launch_points = m_launch_points;
    rs.max_turns = m_max_turns;
    rs.keep_lines = in.plots ? m_plot_shearlines : 0;
    rs.line.method = m_line_method;
    rs.line.rtol = m_line_rtol;
    rs.line.atol = 1e-5 * h;
    rs.resolution_gap = m_resolution_gap * h;
    return rs;
}

// Steps 2-3 of Alg. 2 over every family and region (the first 70% of the progress).
Search Elliptic::search_closed_shearlines(const sdk::Host &host, const SearchInputs &inputs, const ShearFields &shear,
                                          const std::vector<Candidate> &candidates,
                                          const std::vector<int> &signs) const {
    Search search;
    const bool richardson_gap = m_extrapolate_gap && m_resolution_gap > 0.0;
    const std::size_t total_maps = candidates.size() * signs.size();
    std::size_t maps_done = 0;
    for (int sign : signs) {
        const LineField eta = shear_line_field(inputs.cg, shear, sign, m_singular_gap);
        const LineField coarse = richardson_gap ? coarsened(eta) : LineField();
        const std::vector<double> &deviation = sign > 0 ? shear.deviation_plus : shear.deviation_minus;
        for (std::size_t c = 0; c < candidates.size(); ++c) {
            search_region(host, inputs, eta, richardson_gap ? &coarse : nullptr, deviation, sign, c, candidates[c],
                          search);
            ++maps_done;
            if (host.progress(0.7 * static_cast<double>(maps_done) /
                              static_cast<double>(std::max<std::size_t>(total_maps, 1))))
                throw std::runtime_error("elliptic: stopped on request");
        }
    }
    if (search.dropped_ftle)
        host.info(std::to_string(search.dropped_ftle) + " closed shearline(s) with " + deviation_rule() +
                  " dropped: arclength-mean FTLE above the island threshold " + fmt(inputs.island_threshold));
    return search;
}

// One region and family: the return map on its section, its fixed points and the closed shearlines through them
// (closed_shearlines), each measured and tested.
void Elliptic::search_region(const sdk::Host &host, const SearchInputs &inputs, const LineField &eta,
                             const LineField *coarse, const std::vector<double> &deviation, int sign,
                             std::size_t region, const Candidate &cand, Search &search) const {
    ReturnMap map = closed_shearlines(eta, sign, cand.section, inputs.return_map, coarse);
    std::size_t kept_here = 0;
    json closed = json::array();
    std::vector<Found> measured;
    for (ClosedShearline &orbit : map.closed)
        measured.push_back(measure_closed_shearline(inputs.cg, deviation, region, std::move(orbit)));
    if (m_exact_selection && !inputs.lambda_lines) {
        // In one advection, the region's closed shearlines that the rest of the test would keep.
        std::vector<const Found *> curves;
        std::vector<std::size_t> which;
        for (std::size_t k = 0; k < measured.size(); ++k)
            if (passes_all_but_deviation(measured[k], inputs.island_threshold)) {
                curves.push_back(&measured[k]);
                which.push_back(k);
            }
        if (!curves.empty()) {
            const std::vector<double> exact = exact_deviations(host, inputs.in, curves, inputs.h);
            for (std::size_t k = 0; k < which.size(); ++k) measured[which[k]].exact_mean_deviation = exact[k];
        }
    }
    for (Found &f : measured) {
        if (inputs.lambda_lines) f.lambda = m_lambda;
        search.dropped_ftle += decide_kept(f, inputs.island_threshold, inputs.lambda_lines) ? 1 : 0;
        kept_here += f.kept ? 1 : 0;
        closed.push_back(closed_shearline_json(f));
        search.found.push_back(std::move(f));
    }
    host.info(region_summary(region, cand, sign, map, kept_here, deviation_rule()));
    search.regions.push_back(region_json(region, cand, sign, map, kept_here, std::move(closed)));
    for (auto &line : map.lines) search.picture_lines.push_back(std::move(line));
}

// Alg. 2's test, <d_g> below max_mean_deviation over at least min_deviation_coverage of the curve (lambda-lines
// have none), then step 6's bound: not on the chaotic side of the island threshold on average (past the regular
// region's edge). Returns whether that bound dropped a curve the <d_g> test kept.
bool Elliptic::decide_kept(Found &f, double island_threshold, bool lambda_lines) const {
    // The exact <d_g> is a mean over the curve's finite values like the grid's; the grid's coverage still says
    // whether the curve lies in the usable field.
    const bool passes_deviation =
        lambda_lines || (f.coverage >= min_deviation_coverage && selection_deviation(f) < m_max_mean_deviation);
    const bool chaotic_side = on_chaotic_side(f, island_threshold);
    f.kept = passes_deviation && !chaotic_side;
    return passes_deviation && chaotic_side;
}

// Step 6's bound: on average on the chaotic side of the island threshold (with ftle_filter).
bool Elliptic::on_chaotic_side(const Found &f, double island_threshold) const {
    return m_ftle_filter && !(f.mean_ftle < island_threshold);
}

// decide_kept's test for a closed shearline but the <d_g> comparison: in the usable field, not on the chaotic side.
// Only these need the exact <d_g> of selection_deviation exact.
bool Elliptic::passes_all_but_deviation(const Found &f, double island_threshold) const {
    return f.coverage >= min_deviation_coverage && !on_chaotic_side(f, island_threshold);
}

// How a barrier was selected (barriers.json's "selection", as the hyperbolic extractor's).
std::string Elliptic::selection(const Found &f) const {
    if (!(f.lambda > 0.0)) return "eta-line, " + deviation_rule();
    if (m_lambda > 0.0) return "lambda-line, lambda = " + fmt(m_lambda) + " (the lambda parameter)";
    return "lambda-line fallback (no eta-line barrier in region " + std::to_string(f.candidate) +
           "): the outermost closed lambda-line, lambda = " + fmt(f.lambda, 6);
}

// The lambdas the fallback tries first: 1 (the shearlines of a conservative system), then 1 -+ k lambda_step
// outwards, within [lambda_min, lambda_max]; in increasing order.
std::vector<double> Elliptic::lambda_scan_values() const {
    std::vector<double> values{1.0};
    for (std::size_t k = 1;; ++k) {
        const double below = 1.0 - static_cast<double>(k) * m_lambda_step,
                     above = 1.0 + static_cast<double>(k) * m_lambda_step;
        const bool any = below >= m_lambda_min || above <= m_lambda_max;
        if (below >= m_lambda_min) values.push_back(below);
        if (above <= m_lambda_max) values.push_back(above);
        if (!any) break;
    }
    std::sort(values.begin(), values.end());
    return values;
}

// The median of P(sigma) - sigma over the launch points that returned (NaN when none did): its sign says whether
// the lines of the field spiral inwards or outwards across the section.
double median_displacement(const ReturnMap &map) {
    std::vector<double> d;
    for (std::size_t k = 0; k < map.sigma.size(); ++k)
        if (std::isfinite(map.image[k])) d.push_back(map.image[k] - map.sigma[k]);
    if (d.empty()) return std::numeric_limits<double>::quiet_NaN();
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
    return d[d.size() / 2];
}

// One lambda in the given regions and every family: the lambda-line fields eta_lambda± (step 8), the return map on
// each region's section as for the shearlines (closed_shearlines: all launches of a section in one batch of
// lockstep lanes), and the closed lambda-lines kept by the FTLE bound of step 6.
std::vector<LambdaTrial> Elliptic::lambda_trials(const SearchInputs &inputs, double lambda,
                                                 const std::vector<std::size_t> &regions,
                                                 const std::vector<Candidate> &candidates,
                                                 const std::vector<int> &signs) const {
    const ShearFields fields = lambda_line_fields(inputs.cg, lambda);
    const bool richardson_gap = m_extrapolate_gap && m_resolution_gap > 0.0;
    std::vector<LambdaTrial> trials;
    for (int sign : signs) {
        const LineField eta = shear_line_field(inputs.cg, fields, sign, m_singular_gap);
        const LineField coarse = richardson_gap ? coarsened(eta) : LineField();
        for (std::size_t region : regions) {
            ReturnMap map = closed_shearlines(eta, sign, candidates[region].section, inputs.return_map,
                                              richardson_gap ? &coarse : nullptr);
            LambdaTrial trial;
            trial.lambda = lambda;
            trial.sign = sign;
            trial.region = region;
            trial.closed = map.closed.size();
            trial.displacement = median_displacement(map);
            for (ClosedShearline &orbit : map.closed) {
                Found f = measure_closed_shearline(inputs.cg, fields.deviation_plus, region, std::move(orbit));
                f.lambda = lambda;
                decide_kept(f, inputs.island_threshold, true);
                if (f.kept) trial.kept.push_back(std::move(f));
            }
            trials.push_back(std::move(trial));
        }
    }
    return trials;
}

// Closed lambda-lines of a single lambda are isolated when the lambda-lines elsewhere spiral (a circle shrunk
// uniformly by e^(-cT) is a lambda-line of that lambda only): where the median return displacement changes sign
// between two neighbouring lambdas of the scan (`scan`: one region and family, increasing lambda) and neither
// closed a lambda-line, the interval is halved (bisection on the sign) until a closed lambda-line is kept or
// lambda_bisections halvings are spent.
std::vector<LambdaTrial> Elliptic::lambda_bisection(const SearchInputs &inputs, std::size_t region, int sign,
                                                    const std::vector<LambdaTrial> &scan,
                                                    const std::vector<Candidate> &candidates) const {
    std::vector<LambdaTrial> out;
    for (std::size_t k = 0; k + 1 < scan.size(); ++k) {
        double lo = scan[k].lambda, hi = scan[k + 1].lambda, d_lo = scan[k].displacement;
        if (!(d_lo * scan[k + 1].displacement < 0.0)) continue;
        for (std::size_t halving = 0; halving < m_lambda_bisections; ++halving) {
            const double mid = 0.5 * (lo + hi);
            out.push_back(std::move(lambda_trials(inputs, mid, {region}, candidates, {sign}).front()));
            const LambdaTrial &t = out.back();
            if (!t.kept.empty() || !std::isfinite(t.displacement)) break;
            if ((t.displacement < 0.0) == (d_lo < 0.0)) {
                lo = mid;
                d_lo = t.displacement;
            } else {
                hi = mid;
            }
        }
    }
    return out;
}

// The region's outermost closed lambda-line over every lambda tried that is one in fact: advected to t1 (host
// advection with point insertion, as the checks), its length must have changed by the factor lambda to within half
// a lambda_step (|DF e| = lambda |e| along it). Near an island's edge l2 >> 1, and a tangent error theta of the
// integrated curve adds l2 theta^2 / 2 to its stretching, so an outer curve closed for one lambda may be stretched
// by another (the double gyre at 201 x 101, test_lambda_fallback: closed at lambda = 0.96, enclosed area 0.214,
// stretched by 1.0014). Candidates are checked
// a round at a time, each lambda's and family's next outermost curve in one batch, while one may still be larger
// than the largest that passed (at most max_rounds rounds); the stretching is recorded.
const Found *Elliptic::outermost_lambda_line(const sdk::Host &host, const gb_extract_input &in,
                                             std::vector<LambdaTrial> &trials, std::size_t region,
                                             std::size_t &rejected) const {
    constexpr std::size_t max_rounds = 8;
    std::vector<std::vector<Found *>> by_lambda; // each trial's kept curves, outermost first
    for (LambdaTrial &t : trials) {
        if (t.region != region || t.kept.empty()) continue;
        std::vector<Found *> curves;
        for (Found &f : t.kept) curves.push_back(&f);
        std::sort(curves.begin(), curves.end(), [](const Found *a, const Found *b) { return a->area > b->area; });
        by_lambda.push_back(std::move(curves));
    }
    const AdvectPointsFn advect_to_t1 = [&](const std::vector<double> &xy, std::vector<double> &out,
                                            std::vector<std::uint8_t> &mask) {
        host.advect(xy, in.t0, in.t1, out, mask);
    };
    const Found *best = nullptr;
    for (std::size_t round = 0; round < max_rounds; ++round) {
        std::vector<Found *> batch;
        std::vector<std::vector<double>> curves;
        for (const auto &curves_of_lambda : by_lambda)
            if (round < curves_of_lambda.size() && (!best || curves_of_lambda[round]->area > best->area)) {
                batch.push_back(curves_of_lambda[round]);
                curves.push_back(batch.back()->orbit.xy);
            }
        if (batch.empty()) break;
        const std::vector<AdvectedCurve> images =
            advect_curves(curves, std::vector<bool>(curves.size(), true), advect_to_t1);
        for (std::size_t b = 0; b < batch.size(); ++b) {
            batch[b]->stretching = images[b].length1 / images[b].length0;
            const bool is_lambda_line = std::abs(batch[b]->stretching - batch[b]->lambda) <= 0.5 * m_lambda_step;
            rejected += is_lambda_line ? 0 : 1;
            if (is_lambda_line && (!best || batch[b]->area > best->area)) best = batch[b];
        }
    }
    return best;
}

// Step 8 as a fallback (Haller & Beron-Vera 2013; CoherentStructures.jl): in each region where no closed shearline
// passed the <d_g> test, closed generalized lambda-lines over lambda_min..lambda_max (scan, then bisection where
// the scan closed none), and the outermost of them (largest enclosed area, over every lambda) is the region's
// barrier, as the literature takes the outermost closed lambda-line for the vortex boundary. Regions with an
// eta-line barrier, or inside another region's (one island, step 6), are not searched again, so runs whose
// eta-lines succeed do not change.
void Elliptic::lambda_fallback(const sdk::Host &host, const gb_extract_input &in, const SearchInputs &inputs,
                               const std::vector<Candidate> &candidates, const std::vector<int> &signs,
                               Search &search) const {
    std::vector<std::size_t> regions;
    for (std::size_t c = 0; c < candidates.size(); ++c) {
        std::size_t closed = 0;
        bool kept = false;
        double least = HUGE_VAL;
        for (const Found &f : search.found)
            if (f.candidate == c) {
                ++closed;
                kept = kept || f.kept;
                if (f.coverage >= min_deviation_coverage) least = std::min(least, selection_deviation(f));
            }
        if (kept) continue;
        // A region whose centre lies inside another region's eta-line barrier is in an island that has one.
        bool inside_barrier = false;
        for (const Found &f : search.found)
            inside_barrier = inside_barrier || (f.kept && encloses(f.orbit.xy, candidates[c].x, candidates[c].y));
        if (inside_barrier) {
            host.info("region " + std::to_string(c) +
                      ": no eta-line barrier of its own, but its centre lies inside "
                      "another region's: no lambda-line fallback");
            continue;
        }
        regions.push_back(c);
        host.info("region " + std::to_string(c) + ": no eta-line barrier (" + std::to_string(closed) +
                  " closed shearline(s)" + (closed ? ", least <d_g> " + fmt(least) : std::string()) + ", needed < " +
                  fmt(m_max_mean_deviation) + "): lambda-line fallback over lambda in [" + fmt(m_lambda_min) + ", " +
                  fmt(m_lambda_max) + "], step " + fmt(m_lambda_step));
    }
    std::vector<LambdaTrial> trials;
    for (double lambda : regions.empty() ? std::vector<double>() : lambda_scan_values()) {
        for (LambdaTrial &t : lambda_trials(inputs, lambda, regions, candidates, signs)) trials.push_back(std::move(t));
        if (host.progress(0.7)) throw std::runtime_error("elliptic: stopped on request");
    }
    const std::size_t scanned = trials.size();
    for (std::size_t region : regions) {
        bool any = false;
        for (std::size_t k = 0; k < scanned; ++k) any = any || (trials[k].region == region && !trials[k].kept.empty());
        for (int sign : any ? std::vector<int>() : signs) {
            std::vector<LambdaTrial> scan;
            for (std::size_t k = 0; k < scanned; ++k)
                if (trials[k].region == region && trials[k].sign == sign) scan.push_back(trials[k]);
            for (LambdaTrial &t : lambda_bisection(inputs, region, sign, scan, candidates))
                trials.push_back(std::move(t));
        }
    }
    for (std::size_t region : regions) {
        std::size_t kept = 0, tried = 0;
        for (const LambdaTrial &t : trials) {
            if (t.region != region) continue;
            ++tried;
            kept += t.kept.size();
            search.lambda_fallback.push_back({{"region", region},
                                              {"family", t.sign > 0 ? "+" : "-"},
                                              {"lambda", t.lambda},
                                              {"closed", t.closed},
                                              {"kept", t.kept.size()},
                                              {"median_displacement", finite_or_null(t.displacement)}});
        }
        std::size_t rejected = 0;
        const Found *outermost = outermost_lambda_line(host, in, trials, region, rejected);
        if (outermost) search.found.push_back(*outermost);
        host.info("region " + std::to_string(region) + ": " + std::to_string(kept) + " closed lambda-line(s) over " +
                  std::to_string(tried) + " return maps, " + std::to_string(rejected) +
                  " outer one(s) not stretched by their lambda to lambda_step / 2 (advected); " +
                  (outermost ? "outermost at lambda = " + fmt(outermost->lambda, 6) + ", enclosed area " +
                                   fmt(outermost->area) + ", length " + fmt(outermost->length)
                             : std::string("none, nothing reported")));
    }
}

// Step 4: the barriers reported, out of the kept closed shearlines: thinned, near-identical ones merged, grouped
// into islands with the outermost of each marked; in report order (by island, inner barriers first).
std::vector<std::size_t> Elliptic::select_barriers(std::vector<Found> &found, const std::vector<Candidate> &candidates,
                                                   const std::vector<int> &signs, double h) const {
    std::vector<std::size_t> kept = drop_near_identical(found, thin_nested(found, candidates.size(), signs), h);
    assign_islands(found, kept, candidates);
    mark_outermost(found, kept);
    std::sort(kept.begin(), kept.end(), [&](std::size_t a, std::size_t b) {
        if (found[a].island != found[b].island) return found[a].island < found[b].island;
        return found[a].area < found[b].area;
    });
    return kept;
}

// Closed shearlines of one region and family are nested; walking outwards-in, one is reported when its equivalent
// radius sqrt(area / pi) lies barrier_spacing * (the outermost's) inside the last one reported, so the outermost
// is always among them.
std::vector<std::size_t> Elliptic::thin_nested(const std::vector<Found> &found, std::size_t regions,
                                               const std::vector<int> &signs) const {
    std::vector<std::size_t> thinned;
    for (std::size_t c = 0; c < regions; ++c)
        for (int sign : signs) {
            std::vector<std::size_t> group;
            for (std::size_t i = 0; i < found.size(); ++i)
                if (found[i].kept && found[i].candidate == c && found[i].orbit.sign == sign) group.push_back(i);
            std::sort(group.begin(), group.end(),
                      [&](std::size_t a, std::size_t b) { return found[a].area > found[b].area; });
            double last = 0.0, step = 0.0;
            for (std::size_t k = 0; k < group.size(); ++k) {
                const double r = std::sqrt(found[group[k]].area / 3.14159265358979323846);
                if (k == 0) step = m_barrier_spacing * r;
                if (k == 0 || last - r >= step) {
                    thinned.push_back(group[k]);
                    last = r;
                }
            }
        }
    return thinned;
}

// What barriers.json says of a barrier before the checks: geometry, island, where it crossed its section, its
// <d_g> (grid and, when computed, exact) or lambda, its closure and FTLE.
Metrics Elliptic::barrier_metrics(const Found &f, const double *exact_deviation) const {
    Metrics metrics = {
        {"length", f.length},
        {"enclosed_area", f.area},
        {"island", static_cast<double>(f.island)},
        {"closure_error", f.orbit.closure_error},
        {"section_sigma", f.orbit.sigma},
    };
    if (f.lambda > 0.0) {
        metrics.emplace_back("lambda", f.lambda);
        if (std::isfinite(f.stretching)) metrics.emplace_back("advected_stretching", f.stretching);
    } else {
        metrics.emplace_back("mean_geodesic_deviation", f.mean_deviation);
        metrics.emplace_back("max_geodesic_deviation", f.max_deviation);
    }
    if (std::isfinite(f.orbit.extrapolated_gap)) metrics.emplace_back("extrapolated_gap", f.orbit.extrapolated_gap);
    if (exact_deviation) metrics.emplace_back("mean_geodesic_deviation_exact", *exact_deviation);
    if (std::isfinite(f.max_ftle)) metrics.emplace_back("max_ftle", f.max_ftle);
    if (std::isfinite(f.mean_ftle)) metrics.emplace_back("mean_ftle", f.mean_ftle);
    return metrics;
}

// <d_g> of closed shearlines from exact Cauchy–Green tensors (exact_mean_deviations), at exact_deviation_points
// points per curve evenly spaced in arclength (every vertex when 0 or when the curve has fewer).
std::vector<double> Elliptic::exact_deviations(const sdk::Host &host, const gb_extract_input &in,
                                               const std::vector<const Found *> &curves, double h) const {
    std::vector<std::vector<double>> points;
    std::vector<int> signs;
    for (const Found *f : curves) {
        const bool resample = m_exact_deviation_points > 0 && m_exact_deviation_points < f->orbit.xy.size() / 2;
        points.push_back(resample ? resample_polyline(f->orbit.xy, f->length / m_exact_deviation_points, true)
                                  : f->orbit.xy);
        signs.push_back(f->orbit.sign);
    }
    // A quarter of a grid spacing unless given: well inside the cell, far above the trajectories' tolerance.
    const double spacing = m_exact_deviation_spacing > 0.0 ? m_exact_deviation_spacing : 0.25;
    return exact_mean_deviations(host, in, points, signs, spacing * h, deviation_form());
}

// Periodic forcing: points of a barrier iterated by the Poincaré map P = F_t0^(t0 + period) stay on it if it is a
// KAM curve. The drift of a point is its largest distance from the barrier over the iterates (infinite once its
// trajectory is masked). Every barrier's points are iterated together (one advection per iterate) and the
// distances, points x iterates x curve vertices (the check's largest cost), are taken at the end in one parallel
// loop.
std::vector<PoincareDrift> Elliptic::poincare_drifts(const sdk::Host &host, const gb_extract_input &in,
                                                     const std::vector<const Found *> &barriers) const {
    std::vector<PoincareDrift> out(barriers.size());
    std::vector<std::size_t> first(barriers.size() + 1, 0), barrier_of;
    std::vector<double> cur;
    for (std::size_t b = 0; b < barriers.size(); ++b) {
        const Found &f = *barriers[b];
        const std::vector<double> pts = resample_polyline(f.orbit.xy, f.length / m_poincare_points, true);
        out[b].diameter = curve_diameter(pts);
        cur.insert(cur.end(), pts.begin(), pts.end());
        first[b + 1] = first[b] + pts.size() / 2;
        barrier_of.insert(barrier_of.end(), pts.size() / 2, b);
    }
    const std::size_t total = first.back();
    std::vector<double> iterates, next;
    iterates.reserve(2 * total * m_poincare_iterates);
    std::vector<std::uint8_t> mask, masked(total, 0);
    for (std::size_t it = 0; it < m_poincare_iterates; ++it) {
        host.advect(cur, in.t0, in.t0 + m_poincare_period, next, mask);
        cur.swap(next);
        iterates.insert(iterates.end(), cur.begin(), cur.end());
        for (std::size_t k = 0; k < total; ++k) masked[k] |= mask[k] ? 1 : 0;
    }
    std::vector<CurveDistance> distance_to;
    for (const Found *f : barriers) distance_to.emplace_back(f->orbit.xy);
    std::vector<double> drift(total, 0.0);
#pragma omp parallel for schedule(dynamic, 16)
    for (long long kk = 0; kk < static_cast<long long>(total); ++kk) {
        const std::size_t k = static_cast<std::size_t>(kk);
        const CurveDistance &distance = distance_to[barrier_of[k]];
        if (masked[k]) {
            drift[k] = std::numeric_limits<double>::infinity();
            continue;
        }
        for (std::size_t it = 0; it < m_poincare_iterates; ++it) {
            const double *p = iterates.data() + 2 * (it * total + k);
            drift[k] = std::max(drift[k], distance(p[0], p[1]));
        }
    }
    for (std::size_t b = 0; b < barriers.size(); ++b) {
        std::vector<double> sorted(drift.begin() + first[b], drift.begin() + first[b + 1]);
        std::sort(sorted.begin(), sorted.end());
        out[b].median = sorted[sorted.size() / 2];
        out[b].worst = sorted.back();
    }
    return out;
}

// Each barrier into barriers.json with the theory's checks: advected length and area (eq. rel_def) and Poincaré
// iterates (the last 30% of the progress). Each check runs on every barrier at once, so that the host's advection
// sees a few large batches rather than many small ones.
void Elliptic::report_barriers(const sdk::Host &host, const gb_extract_input &in, const std::vector<Found> &found,
                               const std::vector<std::size_t> &kept, double h, bool conservative) const {
    auto progress = [&](double fraction) {
        if (host.progress(0.7 + 0.3 * fraction)) throw std::runtime_error("elliptic: stopped on request");
    };
    if (kept.empty()) return;
    std::vector<const Found *> barriers, shearlines; // shearlines: those with a <d_g> (not lambda-lines)
    for (std::size_t i : kept) barriers.push_back(&found[i]);
    for (const Found *f : barriers)
        if (!(f->lambda > 0.0)) shearlines.push_back(f);
    // Computed again only when the selection did not (it has every closed shearline's already).
    const bool exact_wanted = (m_exact_deviation_spacing > 0.0 || m_exact_selection) && !shearlines.empty();
    const std::vector<double> exact =
        exact_wanted && !m_exact_selection ? exact_deviations(host, in, shearlines, h) : std::vector<double>();
    std::vector<Metrics> metrics;
    for (std::size_t b = 0, s = 0; b < barriers.size(); ++b) {
        const bool has_exact = exact_wanted && !(barriers[b]->lambda > 0.0);
        const double *exact_value = !has_exact          ? nullptr
                                    : m_exact_selection ? &barriers[b]->exact_mean_deviation
                                                        : &exact[s++];
        metrics.push_back(barrier_metrics(*barriers[b], exact_value));
    }
    progress(0.25);

    std::vector<std::size_t> advected;
    std::vector<std::vector<double>> curves;
    for (std::size_t b = 0; b < barriers.size(); ++b)
        if (m_advect == "all" || (m_advect == "outermost" && barriers[b]->outermost)) {
            advected.push_back(b);
            curves.push_back(barriers[b]->orbit.xy);
        }
    const AdvectPointsFn advect_to_t1 = [&](const std::vector<double> &xy, std::vector<double> &out,
                                            std::vector<std::uint8_t> &mask) {
        host.advect(xy, in.t0, in.t1, out, mask);
    };
    const std::vector<AdvectedCurve> images =
        advect_curves(curves, std::vector<bool>(curves.size(), true), advect_to_t1);
    for (std::size_t a = 0; a < advected.size(); ++a)
        add_advection_metrics(host, images[a], kept[advected[a]], metrics[advected[a]]);
    progress(0.5);

    if (m_poincare_period > 0.0) {
        const std::vector<PoincareDrift> drifts = poincare_drifts(host, in, barriers);
        for (std::size_t b = 0; b < barriers.size(); ++b) {
            metrics[b].emplace_back("poincare_drift_median", drifts[b].median / drifts[b].diameter);
            if (std::isfinite(drifts[b].worst))
                metrics[b].emplace_back("poincare_drift_max", drifts[b].worst / drifts[b].diameter);
            metrics[b].emplace_back("diameter", drifts[b].diameter);
        }
    }
    progress(0.9);

    for (std::size_t b = 0; b < barriers.size(); ++b) {
        const Found &f = *barriers[b];
        host.add_barrier("elliptic", true, f.orbit.xy, metrics[b]);
        host.set_barrier_attributes({{"family", f.orbit.sign > 0 ? "\"+\"" : "\"-\""},
                                     {"outermost", f.outermost ? "true" : "false"},
                                     {"conservation_expected", conservative ? "true" : "false"},
                                     {"fixed_point", f.orbit.fixed_point ? "true" : "false"},
                                     {"selection", json(selection(f)).dump()}});
    }
    progress(1.0);
}

// The paper's figure "shearlines-ex1": shearlines in black, closed ones in red, over the FTLE.
void Elliptic::draw_shearlines_picture(const sdk::Host &host, const std::filesystem::path &out_dir,
                                       const CauchyGreenField &cg, const gb_extract_input &in, const Search &search,
                                       const std::vector<Candidate> &candidates,
                                       const std::vector<std::size_t> &kept) const {
    FieldPlot plot;
    bool lambda_lines = false, shearlines = false; // lambda-lines (parameter or fallback) have no <d_g> test
    for (std::size_t i : kept) (search.found[i].lambda > 0.0 ? lambda_lines : shearlines) = true;
    const std::string shearline_rule = "with " + deviation_rule();
    plot.title = "Shearlines; closed " +
                 (lambda_lines ? (shearlines ? shearline_rule + " and lambda-lines" : std::string("lambda-lines"))
                               : shearline_rule) +
                 " red (outermost thick)";
    plot.colorbar_label = "FTLE";
    plot.x_label = sdk::axis_label(in, 0); // "name [unit]" of the system's states (ABI 1.2)
    plot.y_label = sdk::axis_label(in, 1);
    for (const auto &line : search.picture_lines) plot.curves.push_back({line, "black", 0.6, false});
    for (const Candidate &c : candidates)
        plot.curves.push_back({{c.section.x0, c.section.y0, c.section.x1, c.section.y1}, "white", 0.8, false});
    for (std::size_t i : kept)
        plot.curves.push_back({search.found[i].orbit.xy, "red", search.found[i].outermost ? 2.6 : 1.2, true});
    sdk::draw_field_png(host, out_dir / "elliptic-shearlines.png", cg.grid, cg.ftle, cg.mask, plot);
}

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::extractor<Elliptic>())
