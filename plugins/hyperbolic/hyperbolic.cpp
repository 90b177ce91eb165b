// The `hyperbolic` BarrierExtractor: the paper's Algorithm 1 (section 2.2). Strainlines r' = xi1(r) (eq. `strline`)
// seeded on a lattice, truncated to segments where the geodesic strain deviation (eq. `gdev_str`, general form)
// stays below max_deviation, ranked by relative stretching q = l(gamma_t1) / l(gamma_t0) (eq. `rel_stretch`); the
// local minima of q are the barriers: repelling for t1 > t0, attracting for t1 < t0. Links the core's C++ library
// for line fields, tensor lines, curve advection and pictures.
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/curves.hpp>
#include <geobarrier/extractor_keys.hpp>
#include <geobarrier/line_field.hpp>
#include <geobarrier/output.hpp>
#include <geobarrier/sdk.hpp>
#include <geobarrier/sdk_plot.hpp>
#include <geobarrier/segment_index.hpp>
#include <geobarrier/tensor_lines.hpp>

#include "exit_edges.hpp"
#include "whole_curves.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace {

using namespace geobarrier;
using geobarrier::sdk::bool_param;
using geobarrier::sdk::integer_param;
using geobarrier::sdk::real_param;
using geobarrier::sdk::string_param;

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

// Largest sqrt(lambda2 / lambda1) along a barrier for which its advected length is measured (advect_barriers):
// with tangent errors theta ~ 5e-4 the image length then stays within kappa^2 theta^2 / 2 ~ 1e-3 of the barrier's.
constexpr double max_condition = 100.0;

// A strainline at t0: its points. For the opposite-time route, xy_t1 holds the matching points of the stretchline at
// t1 whose image it is. The fields along it (d_g^xi1, sqrt(lambda1)) are not kept: SegmentMeter samples them line by
// line while it truncates, and again along the few pieces measured later (on W, 18 million points: keeping them
// doubled what the strainlines hold, 290 MB more written and read again).
struct Strainline {
    std::vector<double> xy, xy_t1;
    bool exit_seeded = false; // seeded where the exit time jumps (exit_seeds)
    bool traced = false;      // no strainline: the captured set's edge itself (exit_edge_barriers)
    // Whether its first (backward) and last (forward) point is where it ran to max_length: there its curve is cut by
    // the computation, not by the flow (d_g, a singular point, the box), and a barrier ending there is unfinished.
    bool ran_out[2] = {false, false};
};

// A compact strainline segment with d_g^xi1 < max_deviation at every point: a barrier candidate.
struct Segment {
    std::size_t line = 0;            // the strainline it came from
    std::size_t first = 0, last = 0; // its points in that strainline (not copied: thousands of segments overlap)
    double length = 0.0;             // l(gamma_t0)
    double stretched_length = 0.0;   // l(gamma_t1): int sqrt(lambda1) ds (direct) or the t1 length (opposite-time)
    double q = 0.0;
    double mean_deviation = 0.0, max_deviation = 0.0;
    double mid_x = 0.0, mid_y = 0.0; // the point at half its arc length
    double longest_step = 0.0;       // the longest distance between consecutive points (candidates only)
};

// A segment's points, copied out of its strainline.
std::vector<double> points_of(const std::vector<Strainline> &lines, const Segment &s) {
    const std::vector<double> &xy = lines[s.line].xy;
    return std::vector<double>(xy.begin() + 2 * static_cast<std::ptrdiff_t>(s.first),
                               xy.begin() + 2 * static_cast<std::ptrdiff_t>(s.last + 1));
}

// A segment's first point, where its run of points in its strainline starts.
const double *first_point(const std::vector<Strainline> &lines, const Segment &s) {
    return lines[s.line].xy.data() + 2 * s.first;
}

std::string format(double v) {
    std::ostringstream s;
    s.precision(4);
    s << v;
    return s.str();
}

// Buckets (squares of side r) for "which polylines pass within r of this point" queries. A bucket holds runs of
// consecutive points of one polyline (a pointer into its points, not a copy), which keeps the index small where
// thousands of strainlines crowd onto an attractor. Not the kit's SegmentIndex (segment_index.hpp), which the other
// extractors and the core share: that one copies every point into an immutable index, where this one points into
// the ~18 million points of W's strainlines, grows as barriers are kept (chunk by chunk in the selection), and
// answers "a point of a polyline of smaller key" from buckets sorted by that key, stopping at the first hit.
class RunIndex {
  public:
    RunIndex(const Grid &box, double r) : m_r(r), m_x0(box.x_min), m_y0(box.y_min) {
        m_nx = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil((box.x_max - box.x_min) / r)) + 1);
        m_ny = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil((box.y_max - box.y_min) / r)) + 1);
        m_buckets.resize(m_nx * m_ny);
        m_occupied_around.resize(m_nx * m_ny, 0);
    }
    // The n points (x, y interleaved) at xy, which must outlive the index, as polyline `id`.
    void add(const double *xy, std::size_t n, std::size_t id) {
        std::size_t k = 0, b = 0;
        bool inside = n > 0 && bucket(xy[0], xy[1], b);
        while (k < n) {
            // The run of points from k on in the same bucket (or outside), each point's bucket found once.
            Run run{xy + 2 * k, 0, id, HUGE_VAL, -HUGE_VAL, HUGE_VAL, -HUGE_VAL};
            std::size_t end = k, next_b = 0;
            bool next_inside = false;
            while (true) {
                run.x_lo = std::min(run.x_lo, xy[2 * end]);
                run.x_hi = std::max(run.x_hi, xy[2 * end]);
                run.y_lo = std::min(run.y_lo, xy[2 * end + 1]);
                run.y_hi = std::max(run.y_hi, xy[2 * end + 1]);
                if (++end == n) break;
                next_inside = bucket(xy[2 * end], xy[2 * end + 1], next_b);
                if (next_inside != inside || (inside && next_b != b)) break;
            }
            run.n = end - k;
            if (inside) add_run(b, run);
            k = end;
            inside = next_inside;
            b = next_b;
        }
    }
    // Sorts every bucket by key(id), ascending (ties by id), for any_near_below.
    template <class Key> void sort_buckets(Key &&key) {
        for (auto &b : m_buckets)
            std::sort(b.begin(), b.end(), [&](const Run &a, const Run &c) {
                return key(a.id) < key(c.id) || (!(key(c.id) < key(a.id)) && a.id < c.id);
            });
    }
    // Whether a point of a polyline with id != self and key(id) < limit lies within r of (x, y). The buckets must
    // be sorted by the same key: a scan stops at the first run at or above the limit, and at the first hit.
    template <class Key> bool any_near_below(double x, double y, double limit, std::size_t self, Key &&key) const {
        return any_near_below_within(x, y, m_r, limit, self, key);
    }
    // The same within `radius` <= r (the buckets' side, so that the 3 x 3 buckets around the point hold every hit).
    template <class Key>
    bool any_near_below_within(double x, double y, double radius, double limit, std::size_t self, Key &&key) const {
        const double r2 = radius * radius;
        const long bx = static_cast<long>(std::floor((x - m_x0) / m_r)),
                   by = static_cast<long>(std::floor((y - m_y0) / m_r));
        // Most queries of the selection fall where no run is near (thousands of candidates, a few barriers): one
        // flag answers them for the same 3 x 3 buckets the scan below would find empty.
        if (bx >= 0 && by >= 0 && bx < static_cast<long>(m_nx) && by < static_cast<long>(m_ny) &&
            !m_occupied_around[static_cast<std::size_t>(by) * m_nx + static_cast<std::size_t>(bx)])
            return false;
        // The point's own bucket first: that is where a neighbour is most likely found.
        static constexpr int order[9][2] = {{0, 0},   {-1, 0}, {1, 0},  {0, -1}, {0, 1},
                                            {-1, -1}, {1, -1}, {-1, 1}, {1, 1}};
        for (const auto &o : order) {
            const long i = bx + o[0], j = by + o[1];
            if (i < 0 || j < 0 || i >= static_cast<long>(m_nx) || j >= static_cast<long>(m_ny)) continue;
            for (const Run &run : m_buckets[static_cast<std::size_t>(j) * m_nx + static_cast<std::size_t>(i)]) {
                if (!(key(run.id) < limit)) break;
                if (run.id == self) continue;
                const double gx = std::max({run.x_lo - x, x - run.x_hi, 0.0}),
                             gy = std::max({run.y_lo - y, y - run.y_hi, 0.0});
                if (gx * gx + gy * gy > r2) continue; // the run's bounding box is out of reach
                for (std::size_t k = 0; k < run.n; ++k) {
                    const double ex = run.xy[2 * k] - x, ey = run.xy[2 * k + 1] - y;
                    if (ex * ex + ey * ey <= r2) return true;
                }
            }
        }
        return false;
    }
    // Whether any point lies within r of (x, y).
    bool any_near(double x, double y, double radius) const {
        return any_near_below_within(x, y, std::min(radius, m_r), HUGE_VAL, std::numeric_limits<std::size_t>::max(),
                                     [](std::size_t) { return 0.0; });
    }

  private:
    struct Run {
        const double *xy;
        std::size_t n;
        std::size_t id;
        double x_lo, x_hi, y_lo, y_hi; // bounding box of its points
    };
    void add_run(std::size_t b, const Run &run) {
        m_buckets[b].push_back(run);
        mark_occupied_around(b);
    }
    bool bucket(double x, double y, std::size_t &b) const {
        const double fx = std::floor((x - m_x0) / m_r), fy = std::floor((y - m_y0) / m_r);
        if (!(fx >= 0 && fy >= 0 && fx < static_cast<double>(m_nx) && fy < static_cast<double>(m_ny))) return false;
        b = static_cast<std::size_t>(fy) * m_nx + static_cast<std::size_t>(fx);
        return true;
    }
    // Sets the flag of b's 3 x 3 neighbourhood: b and its eight neighbours now have a run in reach.
    void mark_occupied_around(std::size_t b) {
        const std::size_t i = b % m_nx, j = b / m_nx;
        for (std::size_t jj = j > 0 ? j - 1 : 0; jj <= std::min(j + 1, m_ny - 1); ++jj)
            for (std::size_t ii = i > 0 ? i - 1 : 0; ii <= std::min(i + 1, m_nx - 1); ++ii)
                m_occupied_around[jj * m_nx + ii] = 1;
    }
    double m_r, m_x0, m_y0;
    std::size_t m_nx = 1, m_ny = 1;
    std::vector<std::vector<Run>> m_buckets;
    std::vector<std::uint8_t> m_occupied_around; // per bucket: 1 when it or a neighbour holds a run
};

// The fields along the points of a strainline (or of a piece of one), sampled by SegmentMeter::sample: d_g^xi1 at
// each point (NaN outside the usable field) and, direct route, sqrt(lambda1) (NaN where masked or unknown).
struct Sampled {
    std::vector<double> fields[2]; // deviation, root
    const std::vector<double> &deviation() const { return fields[0]; }
    const std::vector<double> &root() const { return fields[1]; }
};

// What truncation and selection measure along a piece of a strainline: l(gamma_t0), d_g^xi1, l(gamma_t1) and q
// (eq. `rel_stretch`), the midpoint; and the grid fields they read, sampled along the points.
struct SegmentMeter {
    bool opposite; // l(gamma_t1) is the stretchline's measured length at t1, else int sqrt(lambda1) ds
    const Grid &grid;
    // On the grid, interleaved: d_g^xi1 and, direct route, log lambda1 (NaN where masked). Interpolating log lambda1
    // is exact for exponential variation across a cell.
    const std::vector<double> &fields;

    // The fields at the points (x, y interleaved), in one pass that finds each point's cell once.
    void sample(const std::vector<double> &xy, Sampled &out) const {
        sample_interleaved_along(grid, fields, opposite ? 1 : 2, xy, out.fields);
        if (!opposite)
            for (double &v : out.fields[1]) v = std::exp(0.5 * v);
    }

    // Fills everything but `length` (set by the caller, which drops short pieces first) from the piece's points xy,
    // the fields sampled there and (opposite-time) its points at t1, each from the piece's first point on; false
    // when sqrt(lambda1) is unknown on part of the piece or q is not finite. `steps`, when given, holds the lengths of
    // the piece's segments (steps[k] joins its points k and k + 1), so that a strainline's thousands of pieces do not
    // measure the same points again for every statistic; the figures are the same bit for bit either way.
    bool measure(const double *xy, const double *deviation, const double *root, const double *xy_t1, Segment &s,
                 const double *steps) const {
        const std::size_t n = s.last - s.first + 1;
        // The piece's own segment lengths: the strainline's from s.first on, or measured here.
        std::vector<double> measured;
        if (!steps) {
            measured.resize(n > 1 ? n - 1 : 0);
            segment_lengths(xy, 0, n - 1, measured.data());
        }
        const double *piece_steps = steps ? steps : measured.data();
        const CurveStats ds = curve_statistics(deviation, n, piece_steps, n - 1);
        s.mean_deviation = ds.mean;
        s.max_deviation = ds.max;
        if (opposite) {
            s.stretched_length = polyline_length(std::vector<double>(xy_t1, xy_t1 + 2 * n));
        } else {
            const CurveStats rs = curve_statistics(root, n, piece_steps, n - 1);
            if (rs.covered_length < 0.999 * s.length) return false;
            s.stretched_length = rs.integral;
        }
        s.q = s.stretched_length / s.length;
        // The point at half the arc length: the first whose running length reaches it (cumulative_length's sums).
        std::size_t mid = 0;
        double run = 0.0;
        while (mid + 1 < n && run < 0.5 * s.length) run += piece_steps[mid++];
        s.mid_x = xy[2 * mid];
        s.mid_y = xy[2 * mid + 1];
        return std::isfinite(s.q);
    }

    // The same for a piece of a strainline whose fields are not at hand (a remainder of the selection): sampled
    // again at the piece's points only.
    bool measure(const std::vector<Strainline> &lines, Segment &s) const {
        const Strainline &line = lines[s.line];
        Sampled along;
        sample(points_of(lines, s), along);
        return measure(first_point(lines, s), along.deviation().data(), along.root().data(),
                       line.xy_t1.empty() ? nullptr : line.xy_t1.data() + 2 * s.first, s, nullptr);
    }
};

// The length of points first..last of a strainline from its segment lengths (steps[k] joins points k and k + 1),
// summed in order as polyline_length does.
double length_from_steps(const std::vector<double> &steps, std::size_t first, std::size_t last) {
    double total = 0.0;
    for (std::size_t k = first; k < last; ++k) total += steps[k];
    return total;
}

// The walls of the computation: the box's four edges and the edge of the mask (where trajectories left `bounds` or
// failed). A strainline running along a wall is shaped by the wall (the field stops there, one-sided differences,
// strainlines stopped at the edge) rather than by the flow, so it is no barrier unless the wall is an invariant line
// of the flow, which the experiment declares (`invariant_walls`).
struct Walls {
    bool left = true, right = true, bottom = true, top = true, mask = true; // walls NOT declared invariant

    static Walls parse(const std::string &text) {
        Walls w;
        std::stringstream all(text);
        std::string item;
        while (std::getline(all, item, ',')) {
            item.erase(0, item.find_first_not_of(" \t"));
            item.erase(item.find_last_not_of(" \t") + 1);
            if (item.empty()) continue;
            if (item == "all")
                w.left = w.right = w.bottom = w.top = w.mask = false;
            else if (item == "box")
                w.left = w.right = w.bottom = w.top = false;
            else if (item == "left")
                w.left = false;
            else if (item == "right")
                w.right = false;
            else if (item == "bottom")
                w.bottom = false;
            else if (item == "top")
                w.top = false;
            else if (item == "mask")
                w.mask = false;
            else
                throw std::invalid_argument("hyperbolic: invariant_walls: \"" + item +
                                            "\" is not one of left, right, bottom, top, mask, box, all");
        }
        return w;
    }
};

// Distance from every grid point to the nearest masked point (8-neighbour chamfer transform: exact along grid lines
// and diagonals, within 8% elsewhere, which is plenty for "within the neighbour distance of the mask"); empty when
// nothing is masked (no mask wall: the wall filter then looks up no point). Asked before the field is made: in a
// closed system nothing is masked, and making the 8 MB field of a 1000 x 1000 grid only to drop it (its page faults
// and the fill) took about 2.5% of unforced Duffing's extractor samples (perf).
std::vector<double> distance_to_mask(const Grid &g, const std::vector<std::uint8_t> &mask) {
    const std::size_t n = std::min(g.size(), mask.size());
    const auto masked = [&](std::uint8_t m) { return (m & mask_trajectory_bits) != 0; };
    if (std::none_of(mask.begin(), mask.begin() + static_cast<std::ptrdiff_t>(n), masked)) return {};
    std::vector<double> d(g.size(), HUGE_VAL);
    for (std::size_t p = 0; p < n; ++p)
        if (masked(mask[p])) d[p] = 0.0;
    const double dx = g.dx(), dy = g.dy(), dd = std::hypot(dx, dy);
    const auto relax = [&](std::size_t i, std::size_t j, long di, long dj, double w) {
        const long ii = static_cast<long>(i) + di, jj = static_cast<long>(j) + dj;
        if (ii < 0 || jj < 0 || ii >= static_cast<long>(g.ny) || jj >= static_cast<long>(g.nx)) return;
        double &here = d[i * g.nx + j];
        here = std::min(here, d[static_cast<std::size_t>(ii) * g.nx + static_cast<std::size_t>(jj)] + w);
    };
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            relax(i, j, 0, -1, dx);
            relax(i, j, -1, -1, dd);
            relax(i, j, -1, 0, dy);
            relax(i, j, -1, 1, dd);
        }
    for (std::size_t i = g.ny; i-- > 0;)
        for (std::size_t j = g.nx; j-- > 0;) {
            relax(i, j, 0, 1, dx);
            relax(i, j, 1, 1, dd);
            relax(i, j, 1, 0, dy);
            relax(i, j, 1, -1, dd);
        }
    return d;
}

// Which grid points lie within `reach` of the mask (distance_to_mask); empty when nothing is masked. One byte a point
// instead of the distance's eight: the wall filter looks up every point of thousands of strainline segments here,
// and the lookups missed the cache of the 8 MB distance field at 1000 x 1000.
std::vector<std::uint8_t> within_reach_of_mask(const Grid &g, const std::vector<std::uint8_t> &mask, double reach) {
    const std::vector<double> to_mask = distance_to_mask(g, mask);
    std::vector<std::uint8_t> within(to_mask.size());
    for (std::size_t p = 0; p < to_mask.size(); ++p) within[p] = to_mask[p] < reach ? 1 : 0;
    return within;
}

// The wall filter: segments running along a wall that is not declared invariant (more than half their length within
// the neighbour distance of it) are flagged. They are no candidates for reporting but stay in the neighbourhoods of
// the selection, so that the strainlines beside them do not become local minima in their place.
struct WallFilter {
    const Grid &grid;
    Walls walls;
    double reach;                        // the neighbour distance
    std::vector<std::uint8_t> near_mask; // within_reach_of_mask for reach, when the mask is a wall

    WallFilter(const CauchyGreenField &cg, const Walls &w, double r)
        : grid(cg.grid), walls(w), reach(r),
          near_mask(w.mask ? within_reach_of_mask(cg.grid, cg.mask, r) : std::vector<std::uint8_t>()) {}

    // Whether more than half of a segment's arc length (its n points at xy, steps[k] the length from point k to
    // k + 1) lies within reach of a wall. `near` is a buffer.
    bool along(const double *xy, std::size_t n, const double *steps, std::vector<double> &near) const;
};

bool WallFilter::along(const double *xy, std::size_t n, const double *steps, std::vector<double> &near) const {
    const Grid &g = grid;
    near.assign(n, 0.0);
    bool any_near = false;
    for (std::size_t k = 0; k < n; ++k) {
        const double x = xy[2 * k], y = xy[2 * k + 1];
        double d = HUGE_VAL;
        if (walls.left) d = std::min(d, x - g.x_min);
        if (walls.right) d = std::min(d, g.x_max - x);
        if (walls.bottom) d = std::min(d, y - g.y_min);
        if (walls.top) d = std::min(d, g.y_max - y);
        bool within = d < reach;
        if (!within && walls.mask && !near_mask.empty()) within = near_mask[g.nearest_point(x, y)] != 0;
        near[k] = within ? 1.0 : 0.0;
        any_near = any_near || within;
    }
    if (!any_near) return false; // most segments: no wall in reach, and the integral below would be 0
    const CurveStats st = curve_statistics(near.data(), n, steps, n - 1);
    return (st.covered_length > 0.0 ? st.integral / st.covered_length : 0.0) > 0.5;
}

// Points about `spacing` apart along a polyline of n points (at least 3, at most 64), at the middles of equal
// arc-length parts; arc holds cumulative_length's lengths from the first point (n of them).
std::vector<double> probe_points(const double *xy, const double *arc, std::size_t n, double spacing) {
    const double total = arc[n - 1];
    const std::size_t count = std::clamp<std::size_t>(static_cast<std::size_t>(std::ceil(total / spacing)), 3, 64);
    std::vector<double> out(2 * count);
    for (std::size_t j = 0; j < count; ++j) {
        const double at = (static_cast<double>(j) + 0.5) / static_cast<double>(count) * total;
        const std::size_t m = std::min(static_cast<std::size_t>(std::lower_bound(arc, arc + n, at) - arc), n - 1);
        out[2 * j] = xy[2 * m];
        out[2 * j + 1] = xy[2 * m + 1];
    }
    return out;
}
std::vector<double> probe_points(const std::vector<double> &xy, double spacing) {
    return probe_points(xy.data(), cumulative_length(xy).data(), xy.size() / 2, spacing);
}

// Barrier candidates: segments, each with what the selection asks of it (its probe points, whether it runs along a
// wall), found while its points are at hand.
struct Candidates {
    std::vector<Segment> segments;
    std::vector<std::vector<double>> probes;
    std::vector<char> along_wall; // WallFilter::along

    void add(const Segment &s, std::vector<double> segment_probes, bool wall) {
        segments.push_back(s);
        probes.push_back(std::move(segment_probes));
        along_wall.push_back(wall ? 1 : 0);
    }
    // Moves `more` after these.
    void append(Candidates &&more) {
        segments.insert(segments.end(), more.segments.begin(), more.segments.end());
        for (std::vector<double> &p : more.probes) probes.push_back(std::move(p));
        along_wall.insert(along_wall.end(), more.along_wall.begin(), more.along_wall.end());
    }
};

// Alg. 1, step 2, line by line: each strainline's compact segments with d_g^xi1 < epsilon at least min_length long.
struct Truncation {
    std::vector<Candidates> per_line;        // in order along the line
    std::vector<std::size_t> short_per_line; // how many shorter ones were left out
    explicit Truncation(std::size_t lines = 0) : per_line(lines), short_per_line(lines, 0) {}
};

// A barrier chosen by the selection rule (step 5 of docs/extractors.md).
struct Selected {
    Segment piece;             // what is reported: a whole candidate segment, or the part of one not yet covered
    std::size_t candidate = 0; // the candidate segment it was selected with
    bool remainder = false;    // a part only: the rest of the candidate lies along barriers of smaller q
    bool leftover = false;     // a remainder shorter than a third of its candidate (whole_curves)
    std::size_t probes = 0;    // probe points along the piece, about a neighbour distance apart
    std::size_t dominated = 0; // probes with a segment of smaller q within the neighbour distance
    bool exit_edge = false;    // chosen along the exit time's jumps (exit_edge_barriers), not as a local minimum
    bool along_jumps = false;  // at least half its points on the exit time's jumps (on_jumps): significant
    bool parallels = true;     // a local minimum of q among its parallel curves (open systems: supported_picks)
    // A remainder that runs on past an end of a barrier kept before it, along the same strainline (continues_barrier):
    // that barrier's index in the selection (none otherwise), the barrier's end it continues and its own end there
    // (0: the first point, 1: the last). whole_curves joins the two there, as one curve.
    static constexpr std::size_t none = static_cast<std::size_t>(-1);
    std::size_t continues = none;
    int continued_end = 0, own_end = 0;
};

// The lengths and distances of Alg. 1 in state units, from the parameters or the box.
struct Scales {
    double max_length; // longest strainline, per direction from its seed
    double min_length; // shortest candidate segment
    double radius;     // the neighbour distance of the selection rule
};

// The check of the shortcut l(gamma_t1) = int sqrt(lambda1) ds: each barrier advected to t1 with point insertion.
struct AdvectionCheck {
    std::vector<double> condition;       // max sqrt(lambda2 / lambda1) along each barrier; HUGE_VAL if unknown
    std::vector<AdvectedCurve> advected; // the images of the barriers advected (was_advected)
    std::vector<char> was_advected;
};

// A barrier as reported: one piece the selection chose, or several joined end to end (whole_curves.hpp), with the
// figures of the whole and the significance test. `significant` curves are barriers; the others are candidates.
struct ReportedCurve {
    std::vector<double> xy;
    std::vector<hyperbolic::JoinedPart> parts; // indices into the selection, in order along the curve
    std::size_t least_q_part = 0;              // the selection's index of the part of least q
    double length = 0.0, stretched_length = 0.0, q = 0.0, mean_deviation = 0.0, max_deviation = 0.0;
    double own_q = 0.0; // q of its parts that are no leftovers: what the contraction test measures (whole_curves)
    std::size_t probes = 0, dominated = 0;
    double transverse_ratio = nan_value; // transverse_q_ratio (whole_curves.hpp)
    double strength = nan_value;         // log q / log q_best (whole_curves)
    bool exit_edge = false;              // at least half its length chosen along the exit time's jumps
    bool along_jumps = false;            // at least half its length along the exit time's jumps: significant
    bool bundled = false;                // along barriers of smaller q (bundled_curves): a candidate
    bool significant = false;
};

struct Hyperbolic {
    static constexpr const char *name = "hyperbolic";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "hyperbolic barriers (paper Alg. 1): least-stretching strainline segments; "
                                       "repelling for forward time, attracting for backward time";
    // exit_time: all NaN unless trajectories can leave the experiment's bounds (exit_edges.hpp).
    static constexpr const char *required_fields[] = {"lambda1", "lambda2",          "xi1_x",     "xi1_y",
                                                      "ftle",    "strain_deviation", "exit_time", nullptr};
    static constexpr gb_param_spec params[] = {
        real_param("max_deviation", 1e-3, 0.0, HUGE_VAL, "1/state",
                   "epsilon: strainlines are truncated where d_g^xi1 >= this (paper: 1e-3, 1e-5)"),
        real_param("seed_distance", 0.0, 0.0, HUGE_VAL, "state",
                   "distance between neighbouring seeds of the seed lattice; 0 = 1/50 of the box's longer side"),
        integer_param("seed_spacing", 0, 0, 1e6,
                      "grid cells between neighbouring seeds, overriding seed_distance; 0 = use seed_distance"),
        real_param("max_length", 0.0, 0.0, HUGE_VAL, "state",
                   "longest strainline, per direction from its seed; 0 = 4 box diagonals"),
        real_param("min_length", 0.0, 0.0, HUGE_VAL, "state",
                   "segments shorter than this are no candidates; 0 = 1/10 of the box diagonal"),
        real_param("neighbour_distance", 0.0, 0.0, HUGE_VAL, "state",
                   "neighbours of a segment pass within this of its midpoint; 0 = 1/50 of the box diagonal"),
        integer_param("max_barriers", 0, 0, 1e9, "report at most this many barriers, least q first; 0 = all"),
        singular_gap_param(
            "points with lambda2 - lambda1 <= singular_gap lambda2 are singular: strainlines stop there"),
        string_param("route", "direct", "direct|opposite-time",
                     "direct: integrate xi1 at t0; opposite-time: advect stretchlines of the opposite-time "
                     "Cauchy-Green tensor from t1 to t0 (paper, section 2.2, last paragraph)"),
        line_method_param(),
        real_param("line_step", 0.0, 0.0, HUGE_VAL, "state",
                   "strainline step (largest step of the adaptive methods), direct route; 0 = half a grid cell, "
                   "but at least 1/16 of the seed distance unless seed_spacing is given"),
        bool_param("validate", true, "advect every barrier to t1 with point insertion and report its true length"),
        real_param("max_gap_fraction", 0.005, 1e-6, 0.5, "",
                   "curve advection: no gap in an image longer than this fraction of the image's size"),
        string_param("invariant_walls", "", nullptr,
                     "walls that are invariant lines of the flow, comma-separated from left, right, bottom, top, "
                     "mask, box, all: segments along them are reported; along any other wall they are artefacts"),
        real_param("min_transverse_ratio", 1.0, 0.0, HUGE_VAL, "",
                   "a barrier is a local minimum of q among its parallel curves: the least q of those 2 grid cells "
                   "to neighbour_distance away over the least within 2 cells is at least this (transverse_q_ratio)"),
        real_param("exit_jump", 0.1, 0.0, HUGE_VAL, "",
                   "open systems (bounds), backward time: strainlines are also seeded on the grid edges across which "
                   "the time to "
                   "leave the bounds jumps by more than this fraction of |t1 - t0| (or from leaving to staying), "
                   "and their runs along those edges are barriers (selection exit-time); 0 = off; direct route only"),
        real_param("exit_stay_jump", 0.02, 0.0, HUGE_VAL, "",
                   "open systems, backward time: an edge between a point that stays and one that leaves is a jump "
                   "when the latter leaves more than this fraction of |t1 - t0| before the horizon (nearer, it is "
                   "taken for the horizon's cut through a smooth exit time)"),
        real_param("early_exit", 0.3, 0.0, 1.0, "",
                   "open systems (bounds): no lattice seed where every trajectory within a lattice step left the "
                   "bounds within this fraction of |t1 - t0| (their Cauchy-Green tensors are of that short stretch "
                   "only); 0 = seed there too; direct route only"),
        real_param("min_strength", 0.9, 0.0, 1.0, "",
                   "a barrier contracts at least this power of the best barrier's contraction: log q / log q_best "
                   ">= this (relative_strength); curves failing either test are reported as candidates"),
    };

    explicit Hyperbolic(const sdk::Params &p)
        : m_epsilon(p.real("max_deviation")), m_seed_distance(p.real("seed_distance")),
          m_seed_spacing(static_cast<std::size_t>(p.integer("seed_spacing"))), m_max_length(p.real("max_length")),
          m_min_length(p.real("min_length")), m_neighbour_distance(p.real("neighbour_distance")),
          m_max_barriers(static_cast<std::size_t>(p.integer("max_barriers"))), m_singular_gap(p.real("singular_gap")),
          m_route(p.string("route")), m_validate(p.flag("validate")), m_max_gap_fraction(p.real("max_gap_fraction")),
          m_walls(Walls::parse(p.string("invariant_walls"))),
          m_line_method(tensor_line_method(p.string("line_method"))), m_line_step(p.real("line_step")),
          m_min_transverse_ratio(p.real("min_transverse_ratio")), m_min_strength(p.real("min_strength")),
          m_exit_jump(p.real("exit_jump")), m_exit_stay_jump(p.real("exit_stay_jump")),
          m_early_exit(p.real("early_exit")) {}

    void extract(const sdk::Host &host, const gb_extract_input &in) const;

    double m_epsilon;
    double m_seed_distance;
    std::size_t m_seed_spacing;
    double m_max_length, m_min_length, m_neighbour_distance;
    std::size_t m_max_barriers;
    double m_singular_gap;
    std::string m_route;
    bool m_validate;
    double m_max_gap_fraction;
    Walls m_walls;
    TensorLineMethod m_line_method;
    double m_line_step;
    double m_min_transverse_ratio, m_min_strength;
    double m_exit_jump, m_exit_stay_jump;
    double m_early_exit;

  private:
    // When the exit time jumps (exit_edges.hpp), from exit_jump and exit_stay_jump, fractions of |t1 - t0|.
    hyperbolic::ExitJumps exit_jumps(const gb_extract_input &in) const {
        const double horizon = std::fabs(in.t1 - in.t0);
        return {in.t0, horizon, m_exit_jump * horizon, m_exit_stay_jump * horizon};
    }
    std::vector<double> seeds(const Grid &g, const LineField &field, const std::vector<double> *deviation) const;
    double seed_distance(const Grid &g) const {
        return m_seed_distance > 0 ? m_seed_distance : std::max(g.x_max - g.x_min, g.y_max - g.y_min) / 50.0;
    }
    // The seed lattice's steps along x and y in grid cells (seeds): seed_spacing, or seed_distance but at least one
    // grid cell (denser seeds than grid points add nothing).
    std::pair<double, double> lattice_steps(const Grid &g) const {
        if (m_seed_spacing > 0) return {static_cast<double>(m_seed_spacing), static_cast<double>(m_seed_spacing)};
        const double d = seed_distance(g);
        return {std::max(d / g.dx(), 1.0), std::max(d / g.dy(), 1.0)};
    }
    std::vector<double> exit_seeds(const sdk::Host &host, const gb_extract_input &in, const Grid &g,
                                   std::vector<hyperbolic::JumpEdge> &jumps) const;
    std::vector<double> without_early_exits(const sdk::Host &host, const gb_extract_input &in, const Grid &g,
                                            const std::vector<double> &seeds) const;
    void exit_edge_barriers(const sdk::Host &host, const gb_extract_input &in,
                            const std::vector<hyperbolic::JumpEdge> &jumps, std::vector<Strainline> &lines,
                            const Candidates &found, const SegmentMeter &meter, const WallFilter &walls,
                            const Scales &scale, std::vector<Selected> &selected) const;
    std::vector<Strainline> direct_strainlines(const sdk::Host &host, const gb_extract_input &in,
                                               const CauchyGreenField &cg, const std::vector<double> &deviation,
                                               const Scales &scale, const SegmentMeter &meter, const WallFilter &walls,
                                               const std::vector<double> &more_seeds, Truncation &truncation) const;
    std::vector<Strainline> opposite_time_strainlines(const sdk::Host &host, const gb_extract_input &in,
                                                      double max_length) const;
    Scales scales(const Grid &g) const;
    void truncate(const std::vector<Strainline> &lines, std::size_t first, std::size_t end, const SegmentMeter &meter,
                  const WallFilter &walls, const Scales &scale, Truncation &out) const;
    Candidates gathered_candidates(const sdk::Host &host, Truncation &truncation, double min_length) const;
    std::vector<Selected> local_minima(const sdk::Host &host, const Grid &g, const std::vector<Strainline> &lines,
                                       const Candidates &found, const SegmentMeter &meter, const WallFilter &walls,
                                       const Scales &scale) const;
    void on_jumps(const Grid &g, const gb_extract_input &in, std::vector<Selected> &selected,
                  const std::vector<Strainline> &lines, std::size_t first) const;
    void supported_picks(const CauchyGreenField &cg, const std::vector<Strainline> &lines,
                         std::vector<Selected> &selected) const;
    std::vector<ReportedCurve> whole_curves(const sdk::Host &host, const CauchyGreenField &cg,
                                            const std::vector<Strainline> &lines,
                                            const std::vector<Selected> &selected) const;
    AdvectionCheck advect_barriers(const sdk::Host &host, const gb_extract_input &in, const CauchyGreenField &cg,
                                   const std::vector<ReportedCurve> &curves) const;
    void draw_strainlines(const sdk::Host &host, const gb_extract_input &in, const SegmentMeter &meter,
                          const std::vector<Strainline> &lines, const std::vector<Selected> &selected,
                          const std::vector<ReportedCurve> &curves) const;
};

// The seed lattice: points (steps_x, steps_y) grid cells apart, starting half a step in from the box's lower
// edges, in the given field's usable cells and (when `deviation` is given) where d_g^xi1 < epsilon, since a seed
// above it would be cut away.
std::vector<double> seed_lattice(const Grid &g, double steps_x, double steps_y, const LineField &field,
                                 const std::vector<double> *deviation, double epsilon) {
    std::vector<double> seeds;
    for (double fi = 0.5 * steps_y; fi <= static_cast<double>(g.ny - 1); fi += steps_y)
        for (double fj = 0.5 * steps_x; fj <= static_cast<double>(g.nx - 1); fj += steps_x) {
            const double x = g.x_min + fj * g.dx(), y = g.y_min + fi * g.dy();
            if (field.status_at(x, y) != LineStatus::ok) continue;
            if (deviation) {
                const double d = sample_field(g, *deviation, {}, x, y);
                if (!(d < epsilon)) continue;
            }
            seeds.push_back(x);
            seeds.push_back(y);
        }
    return seeds;
}

// The seeds: a lattice seed_distance apart in state units (by default 1/50 of the box's longer side), so that
// their number, and with it the extraction's cost, does not grow with the grid; seed_spacing > 0 asks for a
// lattice in grid cells instead. The default is 12 cells of the 601 x 401 damped-Duffing grid; about four seeds fall
// in each neighbourhood disc of the selection rule. It was 1/75 until whole curves were joined (whole_curves.hpp):
// since then the coarser lattice finds the same barriers on the suite's cases at a third of the cost
// (docs/extractors.md, step 1).
std::vector<double> Hyperbolic::seeds(const Grid &g, const LineField &field,
                                      const std::vector<double> *deviation) const {
    const auto [steps_x, steps_y] = lattice_steps(g);
    return seed_lattice(g, steps_x, steps_y, field, deviation, m_epsilon);
}

// d_g^xi1 and log lambda1 interleaved on the grid (log lambda1 NaN where masked): the direct route's SegmentMeter
// fields.
std::vector<double> deviation_and_log_lambda1(const CauchyGreenField &cg, const std::vector<double> &deviation) {
    const std::size_t n = cg.grid.size();
    std::vector<double> fields(2 * n);
#pragma omp parallel for schedule(static)
    for (std::size_t p = 0; p < n; ++p) {
        fields[2 * p] = deviation[p];
        fields[2 * p + 1] = cg.mask[p] ? nan_value : std::log(cg.lambda1[p]);
    }
    return fields;
}

// Open systems: seeds on the grid edges where the exit time jumps (exit_edges.hpp), seed_distance apart. Backward
// time only: there the attracting barriers are one-sided ridges the lattice's strainlines miss (docs/extractors.md,
// step 1). Forward, the lattice already finds the repelling ones (the escape oscillator below Melnikov's threshold:
// precision 0.974, recall 0.975 without these seeds), and above the threshold (1.1 gamma_c, 141 x 121) these seeds
// added a second barrier, ranked first and scored against no truth, crossing the unstable manifold 0.06 from where
// the lattice's barrier crosses it, next to the saddle orbit.
// `jumps` receives those edges, for exit_edge_barriers (one pass over the grid for both).
std::vector<double> Hyperbolic::exit_seeds(const sdk::Host &host, const gb_extract_input &in, const Grid &g,
                                           std::vector<hyperbolic::JumpEdge> &jumps) const {
    const double *exit_time = find_field(in, "exit_time");
    if (!exit_time || !(m_exit_jump > 0) || m_route != "direct" || !(in.t1 < in.t0)) return {};
    const hyperbolic::ExitJumps rule = exit_jumps(in);
    jumps = hyperbolic::exit_jump_edges(g, exit_time, in.mask, rule);
    std::vector<double> seeds = hyperbolic::exit_jump_seeds(g, jumps, seed_distance(g));
    if (!seeds.empty())
        host.info("" + std::to_string(seeds.size() / 2) + " strainline seeds where the exit time jumps by more than " +
                  format(rule.jump) + " (exit_jump " + format(m_exit_jump) + " of |t1 - t0|), or from staying to " +
                  "leaving more than " + format(rule.stay_jump) + " before the horizon (exit_stay_jump " +
                  format(m_exit_stay_jump) + ")");
    return seeds;
}

// Open systems: the lattice seeds but those in a region where trajectories left the bounds early, every grid point
// within a lattice step of the seed (along x and along y) leaving within early_exit of |t1 - t0|. A Cauchy-Green
// tensor there is of a short stretch only, while the barriers of the horizon lie where trajectories stay long: beside
// a saddle orbit's manifolds, which they follow for a long time before they leave, and along the captured set's edge
// (exit_seeds); a seed a lattice step from a point that stays longer is kept, as the strainline from it may run on
// to where that point lies. On the escape oscillator run backward (1000 x 1000) 1606 of the 2082 lattice seeds go,
// and 1.8 of the 3.2 million strainline points (the lines from the other seeds cross there too), with the same
// barriers, as on every scored case of the barrier suite (docs/extractor-measurements.md, "Open systems: no lattice
// seeds where trajectories left early"). Without the lattice step's margin, 0.25 instead of 0.2 already changed van
// der Pol's barriers (recall 0.968 -> 0.964 on 361 x 361); with it, 0.4 changed the escape oscillator's.
std::vector<double> Hyperbolic::without_early_exits(const sdk::Host &host, const gb_extract_input &in, const Grid &g,
                                                    const std::vector<double> &seeds) const {
    const double *exit_time = find_field(in, "exit_time");
    if (!exit_time || !(m_early_exit > 0)) return seeds;
    const double early = m_early_exit * std::fabs(in.t1 - in.t0);
    const auto [steps_x, steps_y] = lattice_steps(g);
    const auto reach_x = static_cast<std::size_t>(steps_x), reach_y = static_cast<std::size_t>(steps_y);
    // Whether the point left within `early` (NaN: it stayed in the bounds).
    const auto left_early = [&](std::size_t p) {
        return !std::isnan(exit_time[p]) && std::fabs(exit_time[p] - in.t0) < early;
    };
    const auto all_left_early = [&](std::size_t p) {
        const std::size_t i = p / g.nx, j = p % g.nx;
        for (std::size_t a = i > reach_y ? i - reach_y : 0; a <= std::min(g.ny - 1, i + reach_y); ++a)
            for (std::size_t b = j > reach_x ? j - reach_x : 0; b <= std::min(g.nx - 1, j + reach_x); ++b)
                if (!left_early(a * g.nx + b)) return false;
        return true;
    };
    std::vector<double> kept;
    kept.reserve(seeds.size());
    for (std::size_t k = 0; k + 1 < seeds.size(); k += 2)
        if (!all_left_early(g.nearest_point(seeds[k], seeds[k + 1]))) kept.insert(kept.end(), {seeds[k], seeds[k + 1]});
    if (kept.size() < seeds.size())
        host.info("" + std::to_string((seeds.size() - kept.size()) / 2) + " of " + std::to_string(seeds.size() / 2) +
                  " lattice seeds left out: the trajectories within a lattice step of theirs left the bounds within " +
                  format(early) + " (early_exit " + format(m_early_exit) + " of |t1 - t0|)");
    return kept;
}

// Alg. 1, step 1 (and step 2 batch by batch, truncation): strainlines integrated both ways from the seed lattice and
// `more_seeds` (those of exit_seeds, where xi1 is defined).
std::vector<Strainline> Hyperbolic::direct_strainlines(const sdk::Host &host, const gb_extract_input &in,
                                                       const CauchyGreenField &cg, const std::vector<double> &deviation,
                                                       const Scales &scale, const SegmentMeter &meter,
                                                       const WallFilter &walls, const std::vector<double> &more_seeds,
                                                       Truncation &truncation) const {
    const LineField xi1 = LineField::from_cauchy_green(cg, 1, m_singular_gap);
    std::vector<double> seed = without_early_exits(host, in, cg.grid, seeds(cg.grid, xi1, &deviation));
    const std::size_t lattice = seed.size() / 2;
    for (std::size_t k = 0; k + 1 < more_seeds.size(); k += 2)
        if (xi1.status_at(more_seeds[k], more_seeds[k + 1]) == LineStatus::ok)
            seed.insert(seed.end(), {more_seeds[k], more_seeds[k + 1]});
    const std::size_t n = seed.size() / 2;
    host.info("" + std::to_string(n) + " strainline seeds (lattice " +
              (m_seed_spacing > 0 ? std::to_string(m_seed_spacing) + " cells" : format(seed_distance(cg.grid))) +
              " apart, where d_g < " + format(m_epsilon) + ")");
    TensorLineSettings settings;
    settings.method = m_line_method;
    settings.max_length = scale.max_length;
    settings.detect_closure = true;
    // Steps of at most half a grid cell, as long as that is not finer than 1/16 of the seed distance: finer
    // grids resolve the fields better, but strainlines sampled more densely than that only cost more (on the
    // damped Duffing attractor, 1000 x 1000, docs/extractor-measurements.md: the same barrier, 2.5 times fewer points).
    // With the default seed distance it is half a cell of the 601 x 401 grid the extractor was validated on.
    const double half_cell = 0.5 * std::min(cg.grid.dx(), cg.grid.dy());
    settings.max_step = m_line_step > 0      ? m_line_step
                        : m_seed_spacing > 0 ? half_cell
                                             : std::max(half_cell, seed_distance(cg.grid) / 16.0);
    // The step in full (scripts/hyperbolic-conditioning reads it to halve and double it).
    std::ostringstream step;
    step.precision(17);
    step << settings.max_step;
    host.info("strainline step " + step.str() + " (state units)");
    std::vector<Strainline> lines(n);
    truncation = Truncation(n);
    // Batches of at most 4096 seeds, of equal size: every batch ends with its threads' lanes draining (the last lines
    // run with the other lanes idle), so batches are few (on W at 1000 x 1000, 2316 seeds in one batch keep the lanes
    // 99% busy; batches of 1024, 96%), and equal so that no small one is left at the end.
    const std::size_t batches = std::max<std::size_t>((n + 4095) / 4096, 1);
    const std::size_t block = (n + batches - 1) / batches;
    // What the lines hold, for the log: the stage's cost grows with the points (docs/extractor-measurements.md).
    std::size_t points = 0, closed = 0, at_max_length = 0;
    for (std::size_t start = 0; start < n; start += block) {
        const std::size_t end = std::min(n, start + block);
        // No arc lengths: the segments measure their own lengths, only where d_g < epsilon.
        std::vector<TwoWayLine> batch = integrate_tensor_lines_both_ways(
            xi1, std::vector<double>(seed.begin() + 2 * start, seed.begin() + 2 * end), settings, ArcLengths::drop);
        for (std::size_t k = 0; k < batch.size(); ++k) {
            points += batch[k].size();
            closed += batch[k].closed ? 1 : 0;
            at_max_length += (batch[k].stop_forward == StopReason::max_length ? 1 : 0) +
                             (batch[k].stop_backward == StopReason::max_length ? 1 : 0);
            lines[start + k].xy = std::move(batch[k].xy);
            lines[start + k].exit_seeded = start + k >= lattice;
            lines[start + k].ran_out[0] = batch[k].stop_backward == StopReason::max_length;
            lines[start + k].ran_out[1] = !batch[k].closed && batch[k].stop_forward == StopReason::max_length;
        }
        // Truncated now, batch by batch, rather than after all of them: the fields sampled along a line live only in
        // its thread's buffers, and a batch's points are read again soon after they were written.
        truncate(lines, start, end, meter, walls, scale, truncation);
        if (host.progress(0.6 * static_cast<double>(end) / static_cast<double>(std::max<std::size_t>(n, 1))))
            throw std::runtime_error("stopped by the user");
    }
    host.info("" + std::to_string(points) + " strainline points; " + std::to_string(closed) + " lines closed, " +
              std::to_string(at_max_length) + " of " + std::to_string(2 * n) + " branches ran to max_length");
    return lines;
}

std::vector<Strainline> Hyperbolic::opposite_time_strainlines(const sdk::Host &host, const gb_extract_input &in,
                                                              double max_length) const {
    // Stretchlines of the opposite-time tensor C_{t1}^{t0} (tangent to its xi2) at t1, advected to t0, are
    // strainlines of C_{t0}^{t1} (Farazmand & Haller 2012), and more accurate than integrating xi1 at t0 because
    // xi2 is the attracting, well-conditioned eigenvector. The t1 grid is the t0 grid's box and resolution.
    const Grid g = grid_of(in);
    const std::size_t n = g.size();
    std::vector<double> xy(2 * n);
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            xy[2 * (i * g.nx + j)] = g.x(j);
            xy[2 * (i * g.nx + j) + 1] = g.y(i);
        }
    std::vector<double> image, dF;
    std::vector<std::uint8_t> mask;
    host.info("opposite-time Cauchy-Green tensor on the grid at t1 = " + format(in.t1));
    host.advect(xy, in.t1, in.t0, image, mask, &dF);
    if (host.progress(0.2)) throw std::runtime_error("stopped by the user");
    CauchyGreenField cg = cauchy_green_field(g, dF, mask, std::abs(in.t0 - in.t1));
    const LineField xi2 = LineField::from_cauchy_green(cg, 2, m_singular_gap);
    const std::vector<double> seeds = this->seeds(g, xi2, nullptr);
    const std::size_t count = seeds.size() / 2;
    host.info("" + std::to_string(count) + " stretchline seeds at t1");
    // Stretchlines at t1 are short: their images are stretched by about sqrt(lambda2). Each direction runs until
    // its estimated image length int sqrt(lambda2) ds reaches max_length (checked after integration by truncating).
    TensorLineSettings settings;
    settings.method = m_line_method;
    settings.max_length = max_length;
    std::vector<std::vector<double>> stretchlines(count);
    std::vector<double> sqrt_l2(n);
    for (std::size_t p = 0; p < n; ++p) sqrt_l2[p] = std::sqrt(cg.lambda2[p]);
    const std::vector<TwoWayLine> two_way = integrate_tensor_lines_both_ways(xi2, seeds, settings);
#pragma omp parallel for schedule(dynamic)
    for (std::size_t k = 0; k < count; ++k) {
        const TwoWayLine &t = two_way[k];
        // Keep the part around the seed whose predicted image length stays within max_length each way.
        const std::vector<double> stretch = sample_along(g, sqrt_l2, cg.mask, t.xy);
        std::size_t lo = t.seed_index, hi = t.seed_index;
        double grown = 0.0;
        while (hi + 1 < t.size() && grown < max_length) {
            const double f = std::isfinite(stretch[hi]) && std::isfinite(stretch[hi + 1])
                                 ? 0.5 * (stretch[hi] + stretch[hi + 1])
                                 : 0.0;
            grown += f * (t.s[hi + 1] - t.s[hi]);
            ++hi;
        }
        grown = 0.0;
        while (lo > 0 && grown < max_length) {
            const double f = std::isfinite(stretch[lo]) && std::isfinite(stretch[lo - 1])
                                 ? 0.5 * (stretch[lo] + stretch[lo - 1])
                                 : 0.0;
            grown += f * (t.s[lo] - t.s[lo - 1]);
            --lo;
        }
        stretchlines[k].assign(t.xy.begin() + 2 * lo, t.xy.begin() + 2 * (hi + 1));
    }
    if (host.progress(0.3)) throw std::runtime_error("stopped by the user");
    // Advect every stretchline to t0 with point insertion, all curves' new points in one call per round.
    const AdvectPointsFn advect = [&](const std::vector<double> &pts, std::vector<double> &out,
                                      std::vector<std::uint8_t> &m) { host.advect(pts, in.t1, in.t0, out, m); };
    CurveAdvectionSettings cs;
    cs.max_gap_fraction = m_max_gap_fraction;
    cs.max_points = 20000;
    std::vector<Strainline> lines;
    std::vector<std::vector<double>> usable;
    for (auto &s : stretchlines)
        if (s.size() >= 4) usable.push_back(std::move(s));
    const std::vector<AdvectedCurve> images =
        advect_curves(usable, std::vector<bool>(usable.size(), false), advect, cs);
    // An image is split where two consecutive points are more than two grid cells apart: there the insertion ran
    // out of budget or a masked trajectory was dropped, and the chord between them is no strainline.
    const double split_gap = 2.0 * std::max(g.dx(), g.dy());
    for (const AdvectedCurve &a : images) {
        const std::size_t m = a.xy1.size() / 2;
        std::size_t first = 0;
        for (std::size_t k = 1; k <= m; ++k) {
            if (k < m && std::hypot(a.xy1[2 * k] - a.xy1[2 * k - 2], a.xy1[2 * k + 1] - a.xy1[2 * k - 1]) <= split_gap)
                continue;
            if (k - first >= 2) {
                Strainline l;
                l.xy.assign(a.xy1.begin() + 2 * first, a.xy1.begin() + 2 * k);
                l.xy_t1.assign(a.xy0.begin() + 2 * first, a.xy0.begin() + 2 * k);
                lines.push_back(std::move(l));
            }
            first = k;
        }
    }
    if (host.progress(0.6)) throw std::runtime_error("stopped by the user");
    return lines;
}

Scales Hyperbolic::scales(const Grid &g) const {
    const double diagonal = std::hypot(g.x_max - g.x_min, g.y_max - g.y_min);
    return {m_max_length > 0 ? m_max_length : 4.0 * diagonal, m_min_length > 0 ? m_min_length : 0.1 * diagonal,
            m_neighbour_distance > 0 ? m_neighbour_distance : 0.02 * diagonal};
}

// Alg. 1, step 2: strainlines first..end - 1 truncated to the compact segments with d_g^xi1 < epsilon at every point,
// those at least min_length long measured (relative stretching q, eq. `rel_stretch`) and probed, into `out` (sized for
// all the lines). Line by line in parallel, each line's fields sampled into its thread's buffers and read at once.
void Hyperbolic::truncate(const std::vector<Strainline> &lines, std::size_t first, std::size_t end,
                          const SegmentMeter &meter, const WallFilter &walls, const Scales &scale,
                          Truncation &out) const {
#pragma omp parallel
    {
        // Per thread, reused line by line (not fresh vectors per line): the fields along the line, its segment
        // lengths (steps[k] joins its points k and k + 1), measured only along its pieces with d_g < epsilon, and a
        // segment's cumulative lengths.
        Sampled along;
        std::vector<double> steps, arc, near_wall;
        std::vector<PointRun> pieces;
#pragma omp for schedule(dynamic)
        for (std::size_t l = first; l < end; ++l) {
            const Strainline &line = lines[l];
            const std::size_t n = line.xy.size() / 2;
            meter.sample(line.xy, along);
            const std::vector<double> &deviation = along.deviation();
            if (steps.size() < n) steps.resize(n);
            runs_below(deviation.data(), n, m_epsilon, pieces);
            for (const PointRun &piece : pieces) {
                const std::size_t begin = piece.first, k = piece.end; // points begin..k - 1
                segment_lengths(line.xy.data(), begin, k - 1, steps.data());
                Segment s;
                s.line = l;
                s.first = begin;
                s.last = k - 1;
                s.length = length_from_steps(steps, s.first, s.last);
                if (s.length < scale.min_length) {
                    ++out.short_per_line[l];
                    continue;
                }
                if (!meter.measure(line.xy.data() + 2 * begin, deviation.data() + begin,
                                   meter.opposite ? nullptr : along.root().data() + begin,
                                   meter.opposite ? line.xy_t1.data() + 2 * begin : nullptr, s, steps.data() + begin))
                    continue;
                // cumulative_length's sums, from the steps measured already.
                const std::size_t n_piece = k - begin;
                arc.resize(n_piece);
                arc[0] = 0.0;
                s.longest_step = 0.0;
                for (std::size_t j = 1; j < n_piece; ++j) {
                    arc[j] = arc[j - 1] + steps[begin + j - 1];
                    s.longest_step = std::max(s.longest_step, steps[begin + j - 1]);
                }
                out.per_line[l].add(s, probe_points(line.xy.data() + 2 * begin, arc.data(), n_piece, scale.radius),
                                    walls.along(line.xy.data() + 2 * begin, n_piece, steps.data() + begin, near_wall));
            }
        }
    }
}

// The candidates: every line's segments, in line order (moved out of the truncation), and the log's line on them.
Candidates Hyperbolic::gathered_candidates(const sdk::Host &host, Truncation &truncation, double min_length) const {
    Candidates all;
    std::size_t short_segments = 0;
    for (std::size_t l = 0; l < truncation.per_line.size(); ++l) {
        all.append(std::move(truncation.per_line[l]));
        short_segments += truncation.short_per_line[l];
    }
    host.info("" + std::to_string(truncation.per_line.size()) + " strainlines, " + std::to_string(all.segments.size()) +
              " segments with d_g < " + format(m_epsilon) + " at least " + format(min_length) + " long (" +
              std::to_string(short_segments) + " shorter ones left out)");
    const auto count = static_cast<std::size_t>(std::count(all.along_wall.begin(), all.along_wall.end(), char{1}));
    if (count)
        host.info("" + std::to_string(count) +
                  " segments run along the box's edge or the mask's and are not "
                  "reported (declare invariant walls with \"invariant_walls\")");
    return all;
}

// Within two grid cells (at most the neighbour distance) a point lies along another curve: it covers the point.
double cover_distance(const Grid &g, double radius) { return std::min(radius, 2.0 * std::max(g.dx(), g.dy())); }

// Which of the points (x, y interleaved) lie within `cover` of a curve in the index.
std::vector<char> near_points(const RunIndex &index, const double *xy, std::size_t n, double cover) {
    std::vector<char> near(n);
    for (std::size_t k = 0; k < n; ++k) near[k] = index.any_near(xy[2 * k], xy[2 * k + 1], cover) ? 1 : 0;
    return near;
}
std::vector<char> near_points(const RunIndex &index, const std::vector<double> &xy, double cover) {
    return near_points(index, xy.data(), xy.size() / 2, cover);
}

// Marks the points not yet marked near that lie within `cover` of a curve in the index; whether it marked any.
bool add_near_points(const RunIndex &index, const double *xy, double cover, std::vector<char> &near) {
    bool marked = false;
    for (std::size_t k = 0; k < near.size(); ++k)
        if (!near[k] && index.any_near(xy[2 * k], xy[2 * k + 1], cover)) near[k] = marked = true;
    return marked;
}
bool add_near_points(const RunIndex &index, const std::vector<double> &xy, double cover, std::vector<char> &near) {
    return add_near_points(index, xy.data(), cover, near);
}

// The neighbours of a segment in the selection are the other strainlines running beside it, not the same curve found
// again from another seed and cut elsewhere by d_g or by where its strainline left the curve: comparing such pieces
// by q would favour the shortest piece where sqrt(lambda1) is least (along a homoclinic loop, the branch entering the
// saddle) and drop the rest of the curve. So a segment lying along longer ones (at least 90% of its probes, about a
// neighbour distance apart, within two grid cells of them) is a piece: it can be chosen, but it is nobody's
// neighbour; the longer segments stand for it. Visited longest first, so that the index holds only the distinct
// curves (a few hundred where thousands of strainlines crowd onto an attractor).
std::vector<char> pieces_of_longer(const Grid &g, const std::vector<Strainline> &lines, const Candidates &found,
                                   double radius) {
    const std::vector<Segment> &candidates = found.segments;
    const std::vector<std::vector<double>> &probes = found.probes;
    std::vector<char> piece(candidates.size(), 0);
    std::vector<std::size_t> by_length(candidates.size());
    std::iota(by_length.begin(), by_length.end(), std::size_t{0});
    std::stable_sort(by_length.begin(), by_length.end(),
                     [&](std::size_t a, std::size_t b) { return candidates[a].length > candidates[b].length; });
    const double cover = cover_distance(g, radius);
    RunIndex distinct(g, cover);
    // In chunks: the probes of a chunk are tested in parallel against the index as it was before the chunk, and in
    // order only those not near it again, once the chunk itself added segments (the same answers as one by one: the
    // index had no point near them before the chunk).
    const std::size_t chunk = 256;
    for (std::size_t start = 0; start < by_length.size(); start += chunk) {
        const std::size_t end = std::min(by_length.size(), start + chunk);
        std::vector<std::vector<char>> near(end - start);
#pragma omp parallel for schedule(dynamic)
        for (std::size_t i = start; i < end; ++i) near[i - start] = near_points(distinct, probes[by_length[i]], cover);
        bool any_added = false;
        for (std::size_t i = start; i < end; ++i) {
            const std::size_t c = by_length[i];
            std::vector<char> &along = near[i - start];
            if (any_added) add_near_points(distinct, probes[c], cover, along);
            const std::size_t count = along.size();
            const auto hits = static_cast<std::size_t>(std::count(along.begin(), along.end(), char{1}));
            if (static_cast<double>(hits) >= 0.9 * static_cast<double>(count)) {
                piece[c] = 1;
                continue;
            }
            distinct.add(first_point(lines, candidates[c]), candidates[c].last - candidates[c].first + 1, c);
            any_added = true;
        }
    }
    return piece;
}

// The order in which the selection visits candidates: those not along a wall, by increasing q (ties: the longer
// first, then the earlier).
std::vector<std::size_t> selection_order(const std::vector<Segment> &candidates, const std::vector<char> &along_wall) {
    std::vector<std::size_t> order;
    for (std::size_t c = 0; c < candidates.size(); ++c)
        if (!along_wall[c]) order.push_back(c);
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        if (candidates[a].q != candidates[b].q) return candidates[a].q < candidates[b].q;
        if (candidates[a].length != candidates[b].length) return candidates[a].length > candidates[b].length;
        return a < b;
    });
    return order;
}

// Which of a candidate's points lie within `cover` of a barrier kept, as far as the selection can use it; empty when
// it can select nothing from the candidate. With steps of at most h = longest_step between points, a run of
// m = min_length / h points or more holds a point whose index is a multiple of m, and a shorter run is shorter than
// min_length (the margin 1e-9 outweighs rounding), which uncovered_minima drops. So only those points are tested
// first, and then the runs around the uncovered ones, grown point by point up to the first covered point either way:
// they come out exactly as a test of every point gives them. The points left untested are marked covered; they lie in
// shorter runs only, and the barriers kept later only cover more. Where candidates crowd along barriers already chosen
// (an attractor) this tests one point in ~100.
std::vector<char> covered_points(const RunIndex &kept, const double *xy, std::size_t n, double longest_step,
                                 double cover, double min_length) {
    const double stride = std::floor(min_length / (longest_step * (1.0 + 1e-9)));
    if (!(stride >= 2.0)) return near_points(kept, xy, n, cover);
    const auto m = static_cast<std::size_t>(std::min(stride, static_cast<double>(n)));
    const auto near = [&](std::size_t k) { return kept.any_near(xy[2 * k], xy[2 * k + 1], cover); };
    std::vector<char> covered(n, 1);
    bool any_uncovered = false;
    for (std::size_t k = 0; k < n; k += m) {
        if (near(k)) continue;
        any_uncovered = true;
        covered[k] = 0;
        // Back to the previous multiple of m (tested already), unless the run from there reached this point.
        for (std::size_t j = k; j-- > (k >= m ? k - m + 1 : 0) && covered[j] && !near(j);) covered[j] = 0;
        // On up to the next multiple of m, which the loop tests itself.
        for (std::size_t j = k + 1; j < std::min(k + m, n) && !near(j); ++j) covered[j] = 0;
    }
    if (!any_uncovered) return {};
    return covered;
}

// The runs of at least two points of candidate c's first n points where in_run(k) holds, in order, as picks: the
// piece each covers, and whether it is a remainder (less than the whole candidate).
template <class InRun>
std::vector<Selected> picks_of_runs(std::size_t c, const Segment &cand, std::size_t n, const InRun &in_run) {
    std::vector<Selected> picks;
    for (std::size_t k = 0; k < n;) {
        while (k < n && !in_run(k)) ++k;
        const std::size_t begin = k;
        while (k < n && in_run(k)) ++k;
        if (k - begin < 2) continue;
        Selected pick;
        pick.candidate = c;
        pick.piece = cand;
        pick.piece.first = cand.first + begin;
        pick.piece.last = cand.first + k - 1;
        pick.remainder = begin > 0 || k < n;
        picks.push_back(pick);
    }
    return picks;
}

// The distance from (x, y) to the polyline of n points at xy (x, y interleaved): the extractor kit's segment distance.
double distance_to_polyline(double x, double y, const double *xy, std::size_t n) {
    if (n == 1) return std::hypot(x - xy[0], y - xy[1]);
    double best = HUGE_VAL;
    for (std::size_t k = 0; k + 1 < n; ++k)
        best = std::min(best, distance_to_segment(x, y, {xy[2 * k], xy[2 * k + 1], xy[2 * k + 2], xy[2 * k + 3], 0}));
    return best;
}

// Whether the remainder `pick` of candidate `cand` (`covered`: which of the candidate's points lie along barriers
// kept) continues a barrier kept past that barrier's end up to the box's edge, and which (pick.continues): next to
// one of its ends the candidate runs along barrier b, every point of its last `along` of arc length before the
// remainder within `cover` of b, up to within 2 cover of an end of b, and then on uncovered to its own end, within a
// grid cell of the box's edge. The remainder is then the same invariant curve as b, traced on by a strainline that
// b's own left (cut by d_g, or stopped where it turned through a saddle's sector), up to where the box cuts it: one
// curve, which whole_curves joins, and short only because the box cuts it (the pendulum's separatrix branches from a
// saddle to the box's edge, 1.17 long, past the heteroclinic orbit into the saddle: docs/extractor-measurements.md).
// Not in the interior: there the same test let the rests of strainlines that leave a curve near its end (the double
// gyre's innermost turn) or run beside the best barrier (the damped Duffing attractor) on as barriers.
bool continues_barrier(const Grid &g, const std::vector<Strainline> &lines, const Segment &cand,
                       const std::vector<char> &covered, const std::vector<Selected> &selected, double cover,
                       double along, Selected &pick) {
    const double *xy = first_point(lines, cand);
    const std::size_t n = cand.last - cand.first + 1, begin = pick.piece.first - cand.first,
                      end = pick.piece.last - cand.first; // the remainder's points begin..end of the candidate
    const double cell = std::max(g.dx(), g.dy());
    const auto at_edge = [&](std::size_t k) {
        const double x = xy[2 * k], y = xy[2 * k + 1];
        return std::min({x - g.x_min, g.x_max - x, y - g.y_min, g.y_max - y}) <= cell;
    };
    for (int own = 0; own < 2; ++own) {
        // The covered point next to the remainder; the remainder's other end must be the candidate's, at the edge.
        if (own == 0 ? begin == 0 : end + 1 >= n) continue;
        if (own == 0 ? end + 1 != n || !at_edge(end) : begin != 0 || !at_edge(begin)) continue;
        const std::size_t next = own == 0 ? begin - 1 : end + 1;
        if (!covered[next]) continue;
        const double px = xy[2 * next], py = xy[2 * next + 1];
        for (std::size_t b = 0; b < selected.size(); ++b) {
            if (selected[b].leftover) continue; // no barrier (local_minima)
            const Segment &piece = selected[b].piece;
            const double *bxy = first_point(lines, piece);
            const std::size_t bn = piece.last - piece.first + 1;
            for (int bend = 0; bend < 2; ++bend) {
                const double *e = bxy + (bend == 0 ? 0 : 2 * (bn - 1));
                if (std::hypot(px - e[0], py - e[1]) > 2.0 * cover) continue;
                // The candidate's points back from `next` over `along`, each within `cover` of b.
                bool beside = true;
                double run = 0.0;
                std::size_t k = next;
                while (beside && run < along) {
                    beside = distance_to_polyline(xy[2 * k], xy[2 * k + 1], bxy, bn) <= cover;
                    if (own == 0 ? k == 0 : k + 1 >= n) break;
                    const std::size_t k2 = own == 0 ? k - 1 : k + 1;
                    run += std::hypot(xy[2 * k2] - xy[2 * k], xy[2 * k2 + 1] - xy[2 * k + 1]);
                    k = k2;
                }
                if (!beside || run < along) continue;
                pick.continues = b;
                pick.continued_end = bend;
                pick.own_end = own;
                return true;
            }
        }
    }
    return false;
}

// The runs of candidate c's points not covered by a barrier of smaller q (at least two points) that pass the
// selection rule of local_minima, in order along the candidate; a remainder's own q is not measured yet (the caller
// does, for the few that are kept). `index` holds the segments that are no pieces, its buckets sorted by q. A
// remainder is held to the wall test of its candidate (WallFilter::along) on its own: a candidate mostly in the
// interior can leave, once its interior part is covered, a remainder along a wall that is no invariant line, whose
// q (small there: the wall stops the stretching across it) would then be the best and push the true barriers below
// min_strength (the double gyre's suite case on 451 x 226: 2.2 units along the bottom and left walls, ranked first).
std::vector<Selected> uncovered_minima(const std::vector<Strainline> &lines, const Candidates &found, std::size_t c,
                                       const std::vector<char> &covered, const RunIndex &index, const Scales &scale,
                                       const WallFilter &walls, const Grid &g, const std::vector<Selected> &selected,
                                       double cover) {
    std::vector<Selected> picks;
    const std::vector<Segment> &candidates = found.segments;
    const auto q_of = [&](std::size_t d) { return candidates[d].q; };
    const Segment &cand = candidates[c];
    for (Selected pick : picks_of_runs(c, cand, covered.size(), [&](std::size_t k) { return !covered[k]; })) {
        // The whole candidate (the usual case away from the barriers kept) has its length and probes already.
        std::vector<double> piece_probes;
        if (pick.remainder) {
            const std::vector<double> piece_xy = points_of(lines, pick.piece);
            const std::vector<double> steps = segment_lengths(piece_xy);
            pick.piece.length = length_from_steps(steps, 0, steps.size());
            if (pick.piece.length < scale.min_length) continue;
            // The rule against tiling (local_minima) makes a remainder shorter than a third of its candidate a
            // leftover, unless it extends a barrier past its end to the box's edge (continues_barrier).
            pick.leftover = 3.0 * pick.piece.length < cand.length &&
                            !continues_barrier(g, lines, cand, covered, selected, cover, scale.radius, pick);
            std::vector<double> near_wall;
            if (walls.along(piece_xy.data(), piece_xy.size() / 2, steps.data(), near_wall)) continue;
            piece_probes = probe_points(piece_xy, scale.radius);
        }
        const std::vector<double> &probes = pick.remainder ? piece_probes : found.probes[c];
        pick.probes = probes.size() / 2;
        for (std::size_t j = 0; j < pick.probes; ++j)
            if (index.any_near_below(probes[2 * j], probes[2 * j + 1], cand.q, c, q_of)) ++pick.dominated;
        if (2 * pick.dominated > pick.probes) continue;
        picks.push_back(pick);
    }
    return picks;
}

// Alg. 1, step 3: the local minima of q, disjoint. Visited in order of increasing q (selection_order), a segment's
// points within two grid cells of a barrier already chosen are covered: that stretch of it is a barrier of smaller q
// already. Each uncovered run at least min_length long is probed about every neighbour distance; it is a local
// minimum of q among its own neighbours, and a barrier, when at most half of its probes have a segment of smaller q
// (not a piece, pieces_of_longer) within the neighbour distance. A remainder shorter than a third of its segment is
// a leftover: the shorter leftovers of pieces cut at different places would otherwise tile a curve already reported,
// so a leftover covers nothing and is no barrier of its own; whole_curves only runs a barrier on by one past an end
// where the barrier's strainline ran to max_length (run_on_past_max_length). A short remainder that runs on from a
// barrier's end to the box's edge (continues_barrier) is no leftover: nothing is left there to tile. So
// a family of strainlines whose q falls monotonically across it yields only its least member, while two curves that
// merely touch (the two homoclinic loops of a double well at its saddle) are both barriers, and so is the part of a
// segment that runs on past a barrier of smaller q (`selection` "remainder"). Ranked by the q of what is reported
// (a remainder's own q).
std::vector<Selected> Hyperbolic::local_minima(const sdk::Host &host, const Grid &g,
                                               const std::vector<Strainline> &lines, const Candidates &found,
                                               const SegmentMeter &meter, const WallFilter &walls,
                                               const Scales &scale) const {
    const std::vector<Segment> &candidates = found.segments;
    const std::vector<char> piece_of_longer = pieces_of_longer(g, lines, found, scale.radius);
    RunIndex index(g, scale.radius);
    for (std::size_t c = 0; c < candidates.size(); ++c)
        if (!piece_of_longer[c])
            index.add(first_point(lines, candidates[c]), candidates[c].last - candidates[c].first + 1, c);
    const auto q_of = [&](std::size_t c) { return candidates[c].q; };
    index.sort_buckets(q_of);
    const double cover = cover_distance(g, scale.radius);
    const std::vector<std::size_t> order = selection_order(candidates, found.along_wall);
    std::vector<Selected> selected;
    RunIndex kept(g, cover);
    const std::size_t min_chunk = 128, max_chunk = 8192;
    // In chunks of the order, as in pieces_of_longer: each candidate's points are tested in parallel against the
    // barriers kept before its chunk, and so is the selection rule on its uncovered runs; then in order the rest
    // against the barriers its chunk added, the rule again only where they covered more of it. Barriers are rare (a
    // few among thousands of candidates): a chunk that adds none doubles the next one (fewer parallel regions, each
    // with its wait at the end), one that adds some halves it (less serial work on the rest of a chunk).
    std::size_t chunk = min_chunk, barriers = 0; // barriers: the picks that are no leftovers
    for (std::size_t start = 0, end = 0; start < order.size(); start = end) {
        if (m_max_barriers > 0 && barriers >= m_max_barriers) break;
        end = std::min(order.size(), start + chunk);
        std::vector<std::vector<char>> covered(end - start);
        std::vector<std::vector<Selected>> picks(end - start);
#pragma omp parallel for schedule(dynamic)
        for (std::size_t i = start; i < end; ++i) {
            const Segment &cand = candidates[order[i]];
            const double *xy = first_point(lines, cand);
            const std::size_t n = cand.last - cand.first + 1;
            covered[i - start] = covered_points(kept, xy, n, cand.longest_step, cover, scale.min_length);
            if (!covered[i - start].empty())
                picks[i - start] = uncovered_minima(lines, found, order[i], covered[i - start], index, scale, walls, g,
                                                    selected, cover);
        }
        std::optional<RunIndex> added; // the barriers this chunk added, made with its first
        const std::size_t kept_before = barriers;
        for (std::size_t i = start; i < end; ++i) {
            if (m_max_barriers > 0 && barriers >= m_max_barriers) break;
            const std::size_t c = order[i];
            if (covered[i - start].empty()) continue; // no uncovered run min_length long: nothing to select
            if (added && add_near_points(*added, first_point(lines, candidates[c]), cover, covered[i - start]))
                picks[i - start] =
                    uncovered_minima(lines, found, c, covered[i - start], index, scale, walls, g, selected, cover);
            const std::size_t first_new = selected.size();
            for (Selected &pick : picks[i - start])
                if (!pick.remainder || meter.measure(lines, pick.piece)) selected.push_back(pick);
            // This candidate's pieces cover only from now on, not the rest of the same candidate.
            if (selected.size() > first_new && !added) added.emplace(g, cover);
            for (std::size_t b = first_new; b < selected.size(); ++b) {
                if (selected[b].leftover) continue;
                ++barriers;
                const std::size_t n = selected[b].piece.last - selected[b].piece.first + 1;
                kept.add(first_point(lines, selected[b].piece), n, b);
                added->add(first_point(lines, selected[b].piece), n, b);
            }
        }
        chunk = barriers > kept_before ? std::max(min_chunk, chunk / 2) : std::min(max_chunk, 2 * chunk);
    }
    // Ranked by q; each continuation's barrier followed to its new place.
    std::vector<std::size_t> by_q(selected.size()), place(selected.size());
    std::iota(by_q.begin(), by_q.end(), std::size_t{0});
    std::stable_sort(by_q.begin(), by_q.end(),
                     [&](std::size_t a, std::size_t b) { return selected[a].piece.q < selected[b].piece.q; });
    std::vector<Selected> sorted;
    sorted.reserve(selected.size());
    for (std::size_t i = 0; i < by_q.size(); ++i) {
        place[by_q[i]] = i;
        sorted.push_back(selected[by_q[i]]);
    }
    for (Selected &pick : sorted)
        if (pick.continues != Selected::none) pick.continues = place[pick.continues];
    selected = std::move(sorted);
    std::size_t remainders = 0, continuations = 0;
    for (const Selected &p : selected) {
        remainders += p.remainder && !p.leftover ? 1 : 0;
        continuations += p.continues != Selected::none ? 1 : 0;
    }
    host.info("" + std::to_string(barriers) + " barriers: disjoint local minima of q (neighbour distance " +
              format(scale.radius) + "), " + std::to_string(remainders) + " of them remainders of a segment past a " +
              "barrier of smaller q (" + std::to_string(continuations) + " running on past a barrier's end); " +
              std::to_string(selected.size() - barriers) + " leftovers (less than a third of their segment)");
    return selected;
}

// The picks of exit_edge_barriers, which come from no candidate segment.
constexpr std::size_t no_candidate = static_cast<std::size_t>(-1);

// The runs of the exit-seeded strainlines' points that lie near a jump (near_jump(point)), at least min_length long
// and not along a wall, measured (q, d_g, midpoint). Not cut where d_g^xi1 >= max_deviation, as the candidates are:
// along the captured set's edge the exit time itself says the curve is material, and there, where the attracting
// barrier is a one-sided ridge, d_g exceeds max_deviation along parts of it (the escape oscillator's strands next to
// its captured set: docs/extractor-measurements.md, "Open systems").
template <class NearJump>
std::vector<Segment> jump_runs(const std::vector<Strainline> &lines, const NearJump &near_jump,
                               const SegmentMeter &meter, const WallFilter &walls, const Scales &scale) {
    std::vector<Segment> runs;
    std::vector<double> steps, near_wall;
    for (std::size_t l = 0; l < lines.size(); ++l) {
        if (!lines[l].exit_seeded) continue;
        const double *xy = lines[l].xy.data();
        const std::size_t n = lines[l].xy.size() / 2;
        steps.resize(n);
        for (std::size_t k = 0; k < n;) {
            while (k < n && !near_jump(xy + 2 * k)) ++k;
            const std::size_t begin = k;
            while (k < n && near_jump(xy + 2 * k)) ++k;
            if (k - begin < 2) continue;
            Segment s;
            s.line = l;
            s.first = begin;
            s.last = k - 1;
            segment_lengths(xy, s.first, s.last, steps.data());
            s.length = length_from_steps(steps, s.first, s.last);
            if (s.length < scale.min_length ||
                walls.along(xy + 2 * begin, k - begin, steps.data() + begin, near_wall) || !meter.measure(lines, s))
                continue;
            for (std::size_t j = s.first; j < s.last; ++j) s.longest_step = std::max(s.longest_step, steps[j]);
            runs.push_back(s);
        }
    }
    return runs;
}

// Whether each pick from `first` on lies along the exit time's jumps: at least half its points ON a jump
// (across_exit_jumps: the exit time at the nearest grid points a cell to either side of the curve jumps). Such a
// curve separates trajectories that leave a loop apart, or leave from those that stay, and is material whatever its
// stretching: the tests of step 8 do not apply to it (on the escape oscillator, 421 x 361, the unstable manifold's
// middle turn was a local minimum of q, kept the exit-time runs off it, and was then demoted to a candidate by
// min_strength: recall 0.53). Near a jump is not enough: on van der Pol (181 x 181) strainlines inside the captured
// set, a cell or two off its edge where every point stays, were exempted so and joined the pieces along the cycle
// (precision 0.80); on the escape oscillator above the threshold (561 x 481) an exit-time piece in a sliver of the
// captured set, 160 times less contracted than the best barrier, was a third piece of the manifold's branch that
// covered nothing the others did not.
void Hyperbolic::on_jumps(const Grid &g, const gb_extract_input &in, std::vector<Selected> &selected,
                          const std::vector<Strainline> &lines, std::size_t first) const {
    const double *exit_time = find_field(in, "exit_time");
    const double cell = std::max(g.dx(), g.dy());
    for (std::size_t b = first; b < selected.size(); ++b) {
        Selected &pick = selected[b];
        const std::size_t n = pick.piece.last - pick.piece.first + 1;
        const std::vector<std::uint8_t> kind = hyperbolic::across_exit_jumps(g, exit_time, in.mask, exit_jumps(in),
                                                                             first_point(lines, pick.piece), n, cell);
        pick.along_jumps =
            !pick.leftover &&
            2 * static_cast<std::size_t>(std::count_if(kind.begin(), kind.end(), [](auto k) { return k != 0; })) >= n;
    }
}

// Open systems: the captured set's edge where it closes on itself and the exit time jumps across it but for a few
// grid edges (captured_set_edges: at least min_edge_jumps of them), added to `lines` as exit-seeded lines of their own
// (Strainline::traced). The boundary of a set of points whose trajectories stay in the bounds over the horizon, where
// it is not the horizon's cut through a smooth exit time (exit_stay_jump), is made of trajectories that stay as well:
// a closed invariant curve, the attracting barrier itself (van der Pol's limit cycle, within half a cell of it),
// which strainlines along its one-sided FTLE ridge follow only in part (181 x 181: they drift inwards by a cell or
// two, off the cycle). A few of its grid edges are cuts all the same, where a point next to the cycle, whose time
// to leave diverges there, leaves just before the horizon (4 of 844 on 271 x 271). An edge that the horizon cuts in
// large part (the escape oscillator's, 0.28 to 0.57 of it) or that meets the grid's edge is no such curve; the
// strainlines along its jumps are what exit_edge_barriers keeps there.
constexpr double min_edge_jumps = 0.9;
void add_closed_captured_edges(const Grid &g, const double *exit_time, const std::uint8_t *mask,
                               const hyperbolic::ExitJumps &rule, std::vector<Strainline> &lines) {
    for (hyperbolic::EdgeCurve &edge : hyperbolic::captured_set_edges(g, exit_time, mask, rule)) {
        if (!edge.closed || edge.jumps < min_edge_jumps) continue;
        Strainline line;
        line.xy = std::move(edge.xy);
        line.exit_seeded = line.traced = true;
        lines.push_back(std::move(line));
    }
}

// Open systems (exit_edges.hpp): the strainlines seeded where the exit time jumps give barriers where they run along
// the jumps, whether or not they are local minima of q. Such a curve separates trajectories that leave the bounds a
// loop apart, or leave from those that stay: a material curve, on the stable (forward) or unstable (backward)
// manifold of what the escaping trajectories pass, even where it contracts less than the best barrier (the far part
// of an escape oscillator's unstable manifold, whose strands the local-minimum rule drops: the strainlines beside
// them drift off and are cut by d_g). First the captured set's closed edges (add_closed_captured_edges), then their
// candidate segments' runs of points within a cell of a jump edge's end, then their runs along the captured set's
// edge whatever d_g (jump_runs) give their parts not within two cells of a barrier kept (the selection's picks that
// are barriers on their own, then these), at least min_length long, as barriers (`selection` "exit-time").
void Hyperbolic::exit_edge_barriers(const sdk::Host &host, const gb_extract_input &in,
                                    const std::vector<hyperbolic::JumpEdge> &jumps, std::vector<Strainline> &lines,
                                    const Candidates &found, const SegmentMeter &meter, const WallFilter &walls,
                                    const Scales &scale, std::vector<Selected> &selected) const {
    // Only the strainlines from exit_seeds, which found `jumps`, give these barriers: none without them.
    if (std::none_of(lines.begin(), lines.end(), [](const Strainline &l) { return l.exit_seeded; })) return;
    const Grid g = grid_of(in);
    const double *exit_time = find_field(in, "exit_time");
    add_closed_captured_edges(g, exit_time, in.mask, exit_jumps(in), lines);
    const std::vector<std::uint8_t> near = hyperbolic::near_exit_jumps(g, jumps, 1);
    const auto near_kind = [&](const double *p) { return near[g.nearest_point(p[0], p[1])]; };
    // First the candidates seeded there (d_g < max_deviation), by increasing q; then, by increasing q, the runs along
    // the captured set's edge whatever d_g (jump_runs). Along jumps between points that both leave, runs with larger
    // d_g added off-truth barriers on van der Pol (precision 0.55 -> 0.27 on 181 x 181), where trajectories that
    // graze the bounds leave a loop later than their neighbours.
    const std::vector<Segment> &candidates = found.segments;
    std::vector<std::size_t> order;
    for (std::size_t c = 0; c < candidates.size(); ++c)
        if (lines[candidates[c].line].exit_seeded && !found.along_wall[c]) order.push_back(c);
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return candidates[a].q < candidates[b].q; });
    std::vector<Segment> runs = jump_runs(
        lines, [&](const double *p) { return (near_kind(p) & hyperbolic::near_captured_jump) != 0; }, meter, walls,
        scale);
    std::stable_sort(runs.begin(), runs.end(), [](const Segment &a, const Segment &b) { return a.q < b.q; });
    if (order.empty() && runs.empty()) return;
    on_jumps(g, in, selected, lines, 0);
    const double cover = cover_distance(g, scale.radius);
    RunIndex kept(g, cover);
    const auto keep = [&](std::size_t b) {
        kept.add(first_point(lines, selected[b].piece), selected[b].piece.last - selected[b].piece.first + 1, b);
    };
    for (std::size_t b = 0; b < selected.size(); ++b)
        if (!selected[b].leftover && (selected[b].along_jumps || selected[b].parallels)) keep(b);
    const std::size_t before = selected.size();
    // A part of a candidate is measured here (a remainder, reported with its candidate's q too); a part of a run,
    // which has no candidate behind it, is measured as a whole of its own.
    const auto take = [&](Selected pick) {
        pick.exit_edge = true;
        if (pick.remainder) {
            pick.piece.length = polyline_length(points_of(lines, pick.piece));
            if (pick.piece.length < scale.min_length || !meter.measure(lines, pick.piece)) return;
            pick.remainder = pick.candidate != no_candidate;
        }
        selected.push_back(pick);
        keep(selected.size() - 1);
    };
    const auto take_runs = [&](bool traced) {
        for (const Segment &run : runs) {
            if (lines[run.line].traced != traced) continue;
            const std::vector<char> covered = covered_points(kept, first_point(lines, run), run.last - run.first + 1,
                                                             run.longest_step, cover, scale.min_length);
            for (const Selected &pick :
                 picks_of_runs(no_candidate, run, covered.size(), [&](std::size_t k) { return !covered[k]; }))
                take(pick);
        }
    };
    take_runs(true);
    for (const std::size_t c : order) {
        const Segment &cand = candidates[c];
        const double *xy = first_point(lines, cand);
        const std::vector<char> covered =
            covered_points(kept, xy, cand.last - cand.first + 1, cand.longest_step, cover, scale.min_length);
        // The runs of points not covered whose nearest grid point is within a cell of a jump edge's end.
        const auto free = [&](std::size_t k) { return !covered[k] && near_kind(xy + 2 * k) != 0; };
        for (const Selected &pick : picks_of_runs(c, cand, covered.size(), free)) take(pick);
    }
    take_runs(false);
    on_jumps(g, in, selected, lines, before);
    host.info("" + std::to_string(selected.size() - before) + " barriers along the exit time's jumps (of " +
              std::to_string(order.size()) + " segments seeded there, " + std::to_string(runs.size()) +
              " runs of those strainlines and of the captured set's closed edges along that edge)");
}

// Open systems: whether each pick of the selection is a local minimum of q among its parallel curves, the test
// whole_curves applies to the curves it joins (transverse_q_ratio at least min_transverse_ratio, or untestable). A
// pick that fails it and does not lie along the exit time's jumps is no barrier on its own: it keeps no exit-time
// barrier off the jumps beside it (exit_edge_barriers) and joins no piece that is one (whole_curves).
void Hyperbolic::supported_picks(const CauchyGreenField &cg, const std::vector<Strainline> &lines,
                                 std::vector<Selected> &selected) const {
    const Grid &g = cg.grid;
    const double cell = std::max(g.dx(), g.dy()), far = std::max(scales(g).radius, 3.0 * cell);
    std::vector<double> root(g.size());
    for (std::size_t p = 0; p < g.size(); ++p) root[p] = std::sqrt(cg.lambda1[p]);
#pragma omp parallel for schedule(dynamic)
    for (std::size_t b = 0; b < selected.size(); ++b) {
        const double ratio = hyperbolic::transverse_q_ratio(g, root, cg.mask, points_of(lines, selected[b].piece), cell,
                                                            2.0 * cell, far);
        selected[b].parallels = std::isnan(ratio) || ratio >= m_min_transverse_ratio * (1.0 - 1e-9);
    }
}

// Where a barrier's strainline ran to max_length, the curve is cut by the computation, not by the flow (d_g, a
// singular point, the box), and a longer strainline along the same curve may run on: on the double gyre (401 x 201)
// the best barrier's strainline ran out 0.57 above the bottom wall's orbit, and the stem below it was left of a
// candidate 7.5 units long, too short a part of it to be a remainder (a leftover). For each end of a piece that is no
// leftover where its strainline ran out, the leftover of least q with an end within `reach` of it (none: -1), indexed
// 2 b + end (end 0 the piece's first point).
std::vector<std::size_t> leftovers_past_max_length(const std::vector<Strainline> &lines,
                                                   const std::vector<Selected> &selected,
                                                   const std::vector<std::vector<double>> &pieces, double reach) {
    constexpr std::size_t none = Selected::none;
    std::vector<std::size_t> past(2 * selected.size(), none);
    for (std::size_t b = 0; b < selected.size(); ++b) {
        const Selected &s = selected[b];
        if (s.leftover) continue;
        const Strainline &line = lines[s.piece.line];
        const std::size_t n = line.xy.size() / 2;
        for (int end = 0; end < 2; ++end) {
            const std::size_t at = end == 0 ? s.piece.first : s.piece.last;
            if (!line.ran_out[end] || at != (end == 0 ? 0 : n - 1)) continue;
            const double x = line.xy[2 * at], y = line.xy[2 * at + 1];
            std::size_t &best = past[2 * b + static_cast<std::size_t>(end)];
            for (std::size_t c = 0; c < selected.size(); ++c) {
                const std::vector<double> &xy = pieces[c];
                const std::size_t m = xy.size();
                if (!selected[c].leftover || m < 4) continue;
                if (std::hypot(xy[0] - x, xy[1] - y) > reach && std::hypot(xy[m - 2] - x, xy[m - 1] - y) > reach)
                    continue;
                if (best == none || selected[c].piece.q < selected[best].piece.q) best = c;
            }
        }
    }
    return past;
}

// The chains of join_end_to_end (of the pieces that are no leftovers), each run on at a free end where its strainline
// ran out by the leftover found there (leftovers_past_max_length), when the two meet as join_end_to_end joins pieces;
// the other leftovers are left out. Only at a chain's free ends, after the other pieces were joined: a leftover
// joined among them took the place of a piece of the same loop (unforced Duffing: recall 0.96 -> 0.76), and past any
// other end leftovers tile a curve already reported or run on past a saddle where strainlines part (a leftover joined
// at unforced Duffing's saddle turned off the loop: precision 0.85).
std::vector<std::vector<hyperbolic::JoinedPart>>
run_on_past_max_length(const std::vector<Strainline> &lines, const std::vector<Selected> &selected,
                       const std::vector<std::vector<double>> &pieces,
                       std::vector<std::vector<hyperbolic::JoinedPart>> chains, double cell) {
    constexpr std::size_t none = Selected::none;
    const std::vector<std::size_t> past = leftovers_past_max_length(lines, selected, pieces, 4.0 * cell);
    std::vector<char> used(selected.size(), 0);
    // The leftover past end `end` of part `part` (in the part's own direction), when the two meet, and whether the
    // leftover's last point is the one at that end.
    const auto leftover_at = [&](std::size_t part, int end, std::size_t &l, bool &last_at_end) {
        l = past[2 * part + static_cast<std::size_t>(end)];
        if (l == none || used[l] ||
            hyperbolic::join_end_to_end({pieces[part], pieces[l]}, 4.0 * cell, 4.0 * cell).size() != 1)
            return false;
        const std::vector<double> &p = pieces[part], &xy = pieces[l];
        const std::size_t at = end == 0 ? 0 : p.size() - 2, m = xy.size();
        last_at_end =
            std::hypot(xy[m - 2] - p[at], xy[m - 1] - p[at + 1]) < std::hypot(xy[0] - p[at], xy[1] - p[at + 1]);
        used[l] = 1;
        return true;
    };
    std::vector<std::vector<hyperbolic::JoinedPart>> out;
    for (std::vector<hyperbolic::JoinedPart> &chain : chains) {
        if (std::all_of(chain.begin(), chain.end(),
                        [&](const hyperbolic::JoinedPart &p) { return selected[p.index].leftover; }))
            continue; // a leftover alone
        const hyperbolic::JoinedPart back = chain.back(), front = chain.front();
        std::size_t l = none;
        bool last_at_end = false;
        // After the chain, the leftover is traversed from its point at the end; before it, towards that point.
        if (leftover_at(back.index, back.reversed ? 0 : 1, l, last_at_end)) chain.push_back({l, last_at_end});
        if (leftover_at(front.index, front.reversed ? 1 : 0, l, last_at_end))
            chain.insert(chain.begin(), hyperbolic::JoinedPart{l, !last_at_end});
        out.push_back(std::move(chain));
    }
    return out;
}

// Whether every part of the curve is a remainder that continues a barrier to the box's edge (continues_barrier).
bool only_continuations(const ReportedCurve &rc, const std::vector<Selected> &selected) {
    return std::all_of(rc.parts.begin(), rc.parts.end(),
                       [&](const hyperbolic::JoinedPart &p) { return selected[p.index].continues != Selected::none; });
}

// A continuation that whole_curves could not join to the barrier it continues, because a measured join took that
// end (where four separatrix branches meet at a saddle, two pieces pass straight through it: the pendulum at
// T + 10%, 481 x 361), is still that barrier's invariant curve: it is significant when the barrier's curve is (and
// its own transverse test passed), not by its own relative_strength, which the grid's sampling of a trough narrower
// than a cell lowers on the branches leaving a saddle (0.85 there; docs/extractor-measurements.md).
void judge_continuations(std::vector<ReportedCurve> &curves, const std::vector<Selected> &selected) {
    std::vector<std::size_t> curve_of(selected.size());
    for (std::size_t c = 0; c < curves.size(); ++c)
        for (const hyperbolic::JoinedPart &p : curves[c].parts) curve_of[p.index] = c;
    for (ReportedCurve &rc : curves) {
        if (!only_continuations(rc, selected)) continue;
        const ReportedCurve &host = curves[curve_of[selected[rc.parts.front().index].continues]];
        rc.significant = rc.significant && !only_continuations(host, selected) && host.significant;
    }
}

// Alg. 1 after step 3, the barriers as wholes (whole_curves.hpp; docs/extractors.md, step 8): the pieces the
// selection chose, joined where one runs on into another (ends within four grid cells); then each whole is a barrier
// when it is a local minimum of q among its parallel copies out to the neighbour distance (transverse_q_ratio at
// least min_transverse_ratio; not rejected where the copies leave the box or meet the mask) and it contracts at
// least min_strength as strongly as the best (in log q); else it is a candidate. Barriers first, then candidates,
// each by increasing q of the whole.
std::vector<ReportedCurve> Hyperbolic::whole_curves(const sdk::Host &host, const CauchyGreenField &cg,
                                                    const std::vector<Strainline> &lines,
                                                    const std::vector<Selected> &selected) const {
    const Grid &g = cg.grid;
    const double cell = std::max(g.dx(), g.dy());
    const Scales scale = scales(g);
    const double radius = scale.radius;
    std::vector<double> root(g.size());
    for (std::size_t p = 0; p < g.size(); ++p) root[p] = std::sqrt(cg.lambda1[p]);
    std::vector<std::vector<double>> pieces(selected.size());
    for (std::size_t b = 0; b < selected.size(); ++b) pieces[b] = points_of(lines, selected[b].piece);
    // The leftovers join only past a barrier's end where its strainline ran out (run_on_past_max_length).
    std::vector<std::vector<double>> joinable = pieces;
    for (std::size_t b = 0; b < selected.size(); ++b)
        if (selected[b].leftover) joinable[b].clear();
    // Ends within four cells that run on into each other join. Pieces chosen along the exit time's jumps come from
    // strainlines on both sides of a jump, a cell or two off each other: those join also up to eight cells apart
    // when each end lies within two cells (the selection's cover distance) of the other's tangent line, side by side
    // where they overlap or in line across a gap (van der Pol's cycle came in 11 pieces). Not the local minima of
    // the selection: a level set running beside a separatrix's end would join it (unforced Duffing: precision 0.17).
    hyperbolic::JoinRules rules;
    rules.join_distance = rules.tangent_length = 4.0 * cell;
    rules.beside = 2.0 * cell;
    rules.reach = 8.0 * cell;
    rules.loose.resize(selected.size());
    for (std::size_t b = 0; b < selected.size(); ++b) rules.loose[b] = selected[b].along_jumps ? 1 : 0;
    // A piece that is no barrier on its own (not along the jumps, and no local minimum of q among its parallels)
    // joins no piece that is: joined, it would pass for part of a barrier (van der Pol, 181 x 181: strainlines inside
    // the captured set, whose ends touch the cycle, joined the pieces along it: precision 0.63).
    rules.group.resize(selected.size());
    for (std::size_t b = 0; b < selected.size(); ++b)
        rules.group[b] = selected[b].along_jumps || selected[b].parallels ? 0 : 1;
    // A remainder that runs on past a barrier's end along the same strainline to the box's edge (continues_barrier)
    // is joined to it there, where that end is still free, whatever the angle: the strainline turns through a
    // saddle's sector where the separatrix has a corner (the pendulum's, at x = +-pi).
    for (std::size_t b = 0; b < selected.size(); ++b)
        if (selected[b].continues != Selected::none)
            rules.joined.emplace_back(2 * selected[b].continues + static_cast<std::size_t>(selected[b].continued_end),
                                      2 * b + static_cast<std::size_t>(selected[b].own_end));
    const std::vector<std::vector<hyperbolic::JoinedPart>> chains =
        run_on_past_max_length(lines, selected, pieces, hyperbolic::join_end_to_end(joinable, rules), cell);
    std::vector<ReportedCurve> curves(chains.size());
#pragma omp parallel for schedule(dynamic)
    for (std::size_t c = 0; c < chains.size(); ++c) {
        ReportedCurve &rc = curves[c];
        rc.parts = chains[c];
        rc.xy = hyperbolic::chain_points(pieces, chains[c]);
        double weighted_deviation = 0.0, exit_edge_length = 0.0, along_jumps_length = 0.0, own_length = 0.0,
               own_stretched = 0.0;
        rc.least_q_part = chains[c].front().index;
        for (const hyperbolic::JoinedPart &part : chains[c]) {
            const Selected &s = selected[part.index];
            rc.length += s.piece.length;
            rc.stretched_length += s.piece.stretched_length;
            own_length += s.leftover ? 0.0 : s.piece.length;
            own_stretched += s.leftover ? 0.0 : s.piece.stretched_length;
            weighted_deviation += s.piece.mean_deviation * s.piece.length;
            rc.max_deviation = std::max(rc.max_deviation, s.piece.max_deviation);
            rc.probes += s.probes;
            rc.dominated += s.dominated;
            if (s.piece.q < selected[rc.least_q_part].piece.q) rc.least_q_part = part.index;
            exit_edge_length += s.exit_edge ? s.piece.length : 0.0;
            along_jumps_length += s.along_jumps ? s.piece.length : 0.0;
        }
        rc.q = rc.stretched_length / rc.length;
        rc.own_q = own_stretched / own_length;
        rc.mean_deviation = weighted_deviation / rc.length;
        rc.exit_edge = 2.0 * exit_edge_length >= rc.length; // mostly chosen along the exit time's jumps
        rc.along_jumps = 2.0 * along_jumps_length >= rc.length;
        rc.transverse_ratio =
            hyperbolic::transverse_q_ratio(g, root, cg.mask, rc.xy, cell, 2.0 * cell, std::max(radius, 3.0 * cell));
        rc.significant = rc.along_jumps || std::isnan(rc.transverse_ratio) ||
                         rc.transverse_ratio >= m_min_transverse_ratio * (1.0 - 1e-9);
    }
    // The contraction test against the best local minimum: a hyperbolic barrier contracts exponentially in the
    // horizon (q ~ exp(-lambda T)), a curve shaped by shear only algebraically (q ~ 1 / (s T)), so its log q is a
    // small fraction of the best's. Where even the best is not contracted (q_best >= 1) nothing is hyperbolic. Both
    // measured without the leftovers that run a barrier on past where its strainline ran out (own_q): they report
    // more of the curve, not a better or worse barrier, and a barrier diluted by one would lower the bar for the rest
    // (damped Duffing, delta 0.2, backward at 0.9 of Melnikov's threshold: a remainder passed and crossed the
    // repelling barriers, a tangle below the threshold). A curve of continuations only is judged with the barrier it
    // continues (judge_continuations).
    double q_best = HUGE_VAL;
    for (const ReportedCurve &rc : curves)
        if (rc.significant && !only_continuations(rc, selected)) q_best = std::min(q_best, rc.own_q);
    for (ReportedCurve &rc : curves) {
        rc.strength = q_best < 1.0 ? std::log(rc.own_q) / std::log(q_best) : nan_value;
        if (!only_continuations(rc, selected))
            rc.significant = rc.significant && (rc.along_jumps || rc.strength >= m_min_strength);
    }
    judge_continuations(curves, selected);
    const auto by_significance_and_q = [](const ReportedCurve &a, const ReportedCurve &b) {
        if (a.significant != b.significant) return a.significant;
        return a.q < b.q;
    };
    std::stable_sort(curves.begin(), curves.end(), by_significance_and_q);
    // One representative of each bundle: a barrier that adds no run of min_length farther than the cover distance
    // (two cells) from the barriers of smaller q is a candidate (three cells bundled distinct turns of the escape
    // oscillator's manifold, 2.8-4 cells apart on 561 x 481: recall 0.911 -> 0.856).
    std::vector<std::vector<double>> barrier_points;
    for (const ReportedCurve &rc : curves)
        if (rc.significant) barrier_points.push_back(rc.xy);
    const std::vector<char> bundled =
        hyperbolic::bundled_curves(barrier_points, cover_distance(g, radius), scale.min_length);
    for (std::size_t b = 0; b < bundled.size(); ++b)
        if (bundled[b]) {
            curves[b].bundled = true;
            curves[b].significant = false;
        }
    std::stable_sort(curves.begin(), curves.end(), by_significance_and_q);
    const auto barriers = static_cast<std::size_t>(
        std::count_if(curves.begin(), curves.end(), [](const ReportedCurve &rc) { return rc.significant; }));
    host.info("" + std::to_string(selected.size()) + " pieces joined into " + std::to_string(curves.size()) +
              " curves: " + std::to_string(barriers) +
              " barriers (local minima of q among their parallels, ratio at least " + format(m_min_transverse_ratio) +
              ", log q at least " + format(m_min_strength) +
              " of the best's, not bundled with a barrier of smaller q), " + std::to_string(curves.size() - barriers) +
              " candidates (" + std::to_string(std::count(bundled.begin(), bundled.end(), 1)) + " bundled)");
    return curves;
}

// The condition of each curve's advected length: a polyline whose tangent is off xi1 by theta has an image longer
// than int sqrt(lambda1) ds by about kappa^2 theta^2 / 2 relatively, kappa = sqrt(lambda2 / lambda1): the curve
// advection then measures the polyline's discretisation error (theta ~ 5e-4 on a grid of h = 0.02), amplified, and
// two builds that round differently disagree on it (38.4 against 56.1 for one barrier).
std::vector<double> stretching_conditions(const CauchyGreenField &cg, const std::vector<ReportedCurve> &curves) {
    const Grid &g = cg.grid;
    std::vector<double> log_condition(g.size());
    for (std::size_t p = 0; p < g.size(); ++p) log_condition[p] = 0.5 * std::log(cg.lambda2[p] / cg.lambda1[p]);
    std::vector<double> condition(curves.size(), HUGE_VAL);
    for (std::size_t b = 0; b < curves.size(); ++b) {
        const CurveStats cs = curve_statistics(curves[b].xy, sample_along(g, log_condition, cg.mask, curves[b].xy));
        if (cs.finite_points) condition[b] = std::exp(cs.max);
    }
    return condition;
}

// Advects the barriers (not the candidates) whose condition is at most max_condition to t1 (when `validate`); the
// others get no advected figures, their stretching_condition says why.
AdvectionCheck Hyperbolic::advect_barriers(const sdk::Host &host, const gb_extract_input &in,
                                           const CauchyGreenField &cg, const std::vector<ReportedCurve> &curves) const {
    AdvectionCheck check;
    check.condition = stretching_conditions(cg, curves);
    check.advected.resize(curves.size());
    check.was_advected.assign(curves.size(), 0);
    if (!m_validate || curves.empty()) return check;
    const AdvectPointsFn advect = [&](const std::vector<double> &pts, std::vector<double> &out,
                                      std::vector<std::uint8_t> &m) { host.advect(pts, in.t0, in.t1, out, m); };
    CurveAdvectionSettings cs;
    cs.max_gap_fraction = m_max_gap_fraction;
    std::vector<std::vector<double>> to_advect;
    std::vector<std::size_t> which;
    std::size_t barriers = 0;
    for (std::size_t b = 0; b < curves.size(); ++b) {
        if (!curves[b].significant) continue;
        ++barriers;
        if (check.condition[b] <= max_condition) {
            to_advect.push_back(curves[b].xy);
            which.push_back(b);
        }
    }
    const std::vector<AdvectedCurve> images =
        advect_curves(to_advect, std::vector<bool>(to_advect.size(), false), advect, cs);
    for (std::size_t k = 0; k < which.size(); ++k) {
        check.advected[which[k]] = images[k];
        check.was_advected[which[k]] = 1;
    }
    if (which.size() < barriers)
        host.info("" + std::to_string(barriers - which.size()) + " barriers not advected: condition " +
                  "sqrt(lambda2/lambda1) above " + format(max_condition) + ", the advected length would " +
                  "measure the polyline's tangent error");
    return check;
}

// The selection attribute of a reported curve: how it came out of the selection.
std::string selection_of(const ReportedCurve &rc, const std::vector<Selected> &selected) {
    if (rc.parts.size() > 1) return "\"joined\"";
    if (rc.exit_edge) return "\"exit-time\"";
    return selected[rc.parts.front().index].remainder ? "\"remainder\"" : "\"local-minimum\"";
}

// The curves handed to the host, barriers (least q first) then candidates, with their figures and attributes, and
// the log's summary line.
void report_barriers(const sdk::Host &host, const std::vector<Segment> &candidates,
                     const std::vector<Selected> &selected, const std::vector<ReportedCurve> &curves,
                     const AdvectionCheck &check, bool backward) {
    for (std::size_t b = 0; b < curves.size(); ++b) {
        const ReportedCurve &rc = curves[b];
        std::vector<std::pair<std::string, double>> metrics = {
            {"length", rc.length},
            {"relative_stretching", rc.q},
            {"stretched_length", rc.stretched_length},
            {"mean_geodesic_deviation", rc.mean_deviation},
            {"max_geodesic_deviation", rc.max_deviation},
            {"rank", static_cast<double>(b + 1)},
            {"pieces", static_cast<double>(rc.parts.size())},
            {"neighbour_probes", static_cast<double>(rc.probes)},
            {"probes_with_smaller_q", static_cast<double>(rc.dominated)},
        };
        if (std::isfinite(rc.transverse_ratio)) metrics.push_back({"transverse_q_ratio", rc.transverse_ratio});
        if (std::isfinite(rc.strength)) metrics.push_back({"relative_strength", rc.strength});
        const Selected &single = selected[rc.parts.front().index];
        if (rc.parts.size() == 1 && single.remainder) // never a pick of no candidate (exit_edge_barriers)
            metrics.push_back({"segment_relative_stretching", candidates[single.candidate].q});
        if (std::isfinite(check.condition[b])) metrics.push_back({"stretching_condition", check.condition[b]});
        if (check.was_advected[b]) {
            const AdvectedCurve &a = check.advected[b];
            metrics.push_back({"advected_length", a.length1});
            metrics.push_back({"advected_relative_stretching", a.length1 / a.length0});
            metrics.push_back({"advected_points", static_cast<double>(a.xy1.size() / 2)});
        }
        host.add_barrier("hyperbolic", false, rc.xy, metrics);
        std::vector<std::pair<std::string, std::string>> attributes = {
            {backward ? "attracting" : "repelling", "true"},
            {"global_minimum", b == 0 && rc.significant ? "true" : "false"},
            {"selection", selection_of(rc, selected)}};
        if (!rc.significant) attributes.push_back({"candidate", "true"});
        if (rc.bundled) attributes.push_back({"bundled", "true"});
        if (check.was_advected[b])
            attributes.push_back({"advection_converged", check.advected[b].converged ? "true" : "false"});
        host.set_barrier_attributes(attributes);
    }
    if (!curves.empty() && curves[0].significant) {
        const ReportedCurve &rc = curves[0];
        std::string line = "global minimum q = " + format(rc.q) + ", length " + format(rc.length);
        if (check.was_advected[0])
            line += "; advected length " + format(check.advected[0].length1) + " vs int sqrt(lambda1) ds " +
                    format(rc.stretched_length);
        host.info(line);
    } else {
        host.warn("no barrier found" + std::string(curves.empty() ? "" : " (only candidates)") +
                  "; try a smaller min_length, a larger max_deviation or a denser seed lattice");
    }
}

// The picture barriers.png: the FTLE with the barriers, the least-stretching one red, the others white and as broad as
// they are confident (relative_strength: width 1 + 2 s px, s clamped to [0, 1]), candidates thin grey.
void draw_barriers(const sdk::Host &host, const gb_extract_input &in, const CauchyGreenField &cg,
                   const std::vector<ReportedCurve> &curves, bool backward) {
    const std::string which = backward ? "attracting" : "repelling";
    FieldPlot fp;
    fp.title = "FTLE, " + which + " barriers (width: strength; candidates grey), t = " + format(in.t0) + " to " +
               format(in.t1);
    fp.colorbar_label = "FTLE";
    fp.x_label = sdk::axis_label(in, 0); // "name [unit]" of the system's states (ABI 1.2)
    fp.y_label = sdk::axis_label(in, 1);
    for (std::size_t b = curves.size(); b-- > 0;) {
        PlotCurve c;
        c.xy = curves[b].xy;
        const bool best = b == 0 && curves[b].significant;
        c.color = best ? "red" : curves[b].significant ? "white" : "grey";
        const double strength = std::isfinite(curves[b].strength) ? std::clamp(curves[b].strength, 0.0, 1.0) : 0.0;
        c.width = best ? 3.0 : curves[b].significant ? 1.0 + 2.0 * strength : 0.75;
        fp.curves.push_back(c);
    }
    sdk::draw_field_png(host, std::filesystem::path(in.output_dir) / "barriers.png", cg.grid, cg.ftle, cg.mask, fp);
}

// The picture strainlines.png, the paper's figure strainline-ex2: all strainlines grey, the least-stretching barrier
// red on the strainline of its part of least q, the points of that strainline with d_g >= epsilon black.
void Hyperbolic::draw_strainlines(const sdk::Host &host, const gb_extract_input &in, const SegmentMeter &meter,
                                  const std::vector<Strainline> &lines, const std::vector<Selected> &selected,
                                  const std::vector<ReportedCurve> &curves) const {
    const Grid &g = meter.grid;
    XYPlot xp;
    xp.title = "strainlines (grey), least-stretching barrier (red), d_g > " + format(m_epsilon) + " (black)";
    xp.x_label = sdk::axis_label(in, 0);
    xp.y_label = sdk::axis_label(in, 1);
    xp.equal_aspect = true;
    xp.x_range = std::make_pair(g.x_min, g.x_max);
    xp.y_range = std::make_pair(g.y_min, g.y_max);
    // At most 600 grey lines, each thinned to points about a pixel apart (1200 px across the box): thousands of
    // strainlines crowd onto the same curves, and drawing all their points cost more than extracting them. The
    // stride rounds up: W's 935 lines at stride 1 (935 / 600 rounded down) drew 3.8 million points, 3 of the run's
    // 4.6 s.
    const std::size_t stride = std::max<std::size_t>(1, (lines.size() + 599) / 600);
    const double pixel = std::max(g.x_max - g.x_min, g.y_max - g.y_min) / 1200.0;
    for (std::size_t l = 0; l < lines.size(); l += stride) {
        if (lines[l].traced) continue; // no strainline (exit_edge_barriers)
        PlotSeries s;
        const std::vector<double> &xy = lines[l].xy;
        for (std::size_t k = 0; k < xy.size() / 2; ++k)
            if (k == 0 || k + 1 == xy.size() / 2 ||
                std::abs(xy[2 * k] - s.xy[s.xy.size() - 2]) + std::abs(xy[2 * k + 1] - s.xy.back()) >= pixel) {
                s.xy.push_back(xy[2 * k]);
                s.xy.push_back(xy[2 * k + 1]);
            }
        s.color = "#b0b0b0";
        s.width = 0.5;
        xp.series.push_back(std::move(s));
    }
    if (!curves.empty() && curves[0].significant) {
        const Strainline &parent = lines[selected[curves[0].least_q_part].piece.line];
        PlotSeries full;
        full.xy = parent.xy;
        full.color = "red";
        full.width = 1.0;
        xp.series.push_back(full);
        PlotSeries seg;
        seg.xy = curves[0].xy;
        seg.color = "red";
        seg.width = 3.0;
        seg.label = "barrier, q = " + format(curves[0].q);
        xp.series.push_back(seg);
        PlotSeries above;
        above.style = PlotSeries::Style::points;
        above.color = "black";
        above.marker_px = 3.0;
        above.label = "d_g > epsilon";
        Sampled along;
        meter.sample(parent.xy, along);
        for (std::size_t k = 0; k < along.deviation().size(); ++k)
            if (!(along.deviation()[k] < m_epsilon) && std::isfinite(parent.xy[2 * k])) {
                above.xy.push_back(parent.xy[2 * k]);
                above.xy.push_back(parent.xy[2 * k + 1]);
            }
        if (!above.xy.empty()) xp.series.push_back(above);
    }
    sdk::draw_xy_png(host, std::filesystem::path(in.output_dir) / "strainlines.png", xp);
}

// Alg. 1 in stages: strainlines (step 1), their segments with d_g^xi1 < epsilon and q (step 2), the wall filter, the
// disjoint local minima of q (step 3), joined into whole curves and tested for significance (whole_curves),
// ranked by q, the advection check, the report and the pictures.
void Hyperbolic::extract(const sdk::Host &host, const gb_extract_input &in) const {
    using clock = std::chrono::steady_clock;
    clock::time_point mark = clock::now();
    std::string timings; // the sub-stages' wall seconds, for the log: where a slow extraction spends its time
    const auto lap = [&](const char *name) {
        const clock::time_point now = clock::now();
        timings += std::string(timings.empty() ? "" : ", ") + name + " " +
                   format(std::chrono::duration<double>(now - mark).count()) + " s";
        mark = now;
    };
    const CauchyGreenField cg = cauchy_green_from_input(in);
    const Grid &g = cg.grid;
    const double *dev_data = find_field(in, "strain_deviation");
    if (!dev_data) throw std::invalid_argument("the core did not hand over the field \"strain_deviation\"");
    const std::vector<double> deviation(dev_data, dev_data + g.size());
    const Scales scale = scales(g);
    const bool backward = in.t1 < in.t0;
    const bool opposite = m_route == "opposite-time";

    const std::vector<double> fields = opposite ? deviation : deviation_and_log_lambda1(cg, deviation);
    const SegmentMeter meter{opposite, g, fields};
    const WallFilter walls(cg, m_walls, scale.radius);
    Truncation truncation;
    // Where the exit time jumps (exit_seeds finds them), for exit_edge_barriers.
    std::vector<hyperbolic::JumpEdge> jumps;
    lap("fields"); // the tensor fields' copies and the wall filter, before any strainline
    // The direct route truncates its strainlines batch by batch as it integrates them; the opposite-time route after
    // advecting them.
    std::vector<Strainline> lines = opposite ? opposite_time_strainlines(host, in, scale.max_length)
                                             : direct_strainlines(host, in, cg, deviation, scale, meter, walls,
                                                                  exit_seeds(host, in, g, jumps), truncation);
    if (opposite) {
        truncation = Truncation(lines.size());
        truncate(lines, 0, lines.size(), meter, walls, scale, truncation);
    }
    lap("strainlines and segments");
    const Candidates found = gathered_candidates(host, truncation, scale.min_length);
    const std::vector<Segment> &candidates = found.segments;
    if (host.progress(0.7)) throw std::runtime_error("stopped by the user");
    std::vector<Selected> selected = local_minima(host, g, lines, found, meter, walls, scale);
    if (!jumps.empty()) supported_picks(cg, lines, selected);
    exit_edge_barriers(host, in, jumps, lines, found, meter, walls, scale, selected);
    lap("selection");
    const std::vector<ReportedCurve> curves = whole_curves(host, cg, lines, selected);
    lap("whole curves");
    const AdvectionCheck check = advect_barriers(host, in, cg, curves);
    lap("advection");
    if (host.progress(0.9)) throw std::runtime_error("stopped by the user");
    report_barriers(host, candidates, selected, curves, check, backward);
    lap("report");
    host.info("stages: " + timings);
    if (!in.plots) return;
    draw_barriers(host, in, cg, curves, backward);
    draw_strainlines(host, in, meter, lines, selected, curves);
}

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::extractor<Hyperbolic>())
