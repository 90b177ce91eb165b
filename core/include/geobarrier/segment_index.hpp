// The one spatial index of the barrier stage: "which curves pass near this point", "how far is the nearest curve",
// "which segments may cross this one". Square cells over line segments (a point is a segment of zero length), each
// segment listed in every cell its bounding box touches. Queries answer exactly what a scan of every segment would
// (tests/test_segment_index.cpp checks that against brute force); the cells only decide which segments are looked at.
// Part of the extractor kit: the core (tangles, frame tracking) and the extractors (parabolic) share it.
#ifndef GEOBARRIER_SEGMENT_INDEX_HPP
#define GEOBARRIER_SEGMENT_INDEX_HPP

#include <algorithm>
#include <cstddef>
#include <utility>
#include <vector>

namespace geobarrier {

// A line segment from (ax, ay) to (bx, by) of the curve numbered `id` (a barrier, a candidate); a == b is a point.
struct Segment {
    double ax = 0.0, ay = 0.0, bx = 0.0, by = 0.0;
    std::size_t id = 0;
};

// The distance from (x, y) to the segment (to its point when it has zero length).
double distance_to_segment(double x, double y, const Segment &s);

// The segments of an interleaved polyline (x0, y0, x1, y1, ...), point k to k + 1, and the last back to the first
// when `closed` (and it has more than two points), appended to `out` with the curve's id.
void append_polyline_segments(const double *xy, std::size_t points, bool closed, std::size_t id,
                              std::vector<Segment> &out);
// A polyline's points as zero-length segments, for "does this curve have a point within r" (not its chords).
void append_points(const double *xy, std::size_t points, std::size_t id, std::vector<Segment> &out);

class SegmentIndex {
  public:
    // Cells of side `cell` (> 0) from the segments' lower-left corner, at most 2^20 per side (farther cells are
    // merged into the outermost one: answers stay exact, only slower). Non-finite coordinates are not supported.
    SegmentIndex(std::vector<Segment> segments, double cell);

    // Cells of about two mean segment lengths, at most 1024 per side: each cell holds a few segments of each curve
    // passing through it, for crossing searches (sharing_cells) between many long polylines.
    static double two_mean_lengths(const std::vector<Segment> &segments);

    const std::vector<Segment> &segments() const { return m_segments; }

    // The distance from (x, y) to the nearest segment, or r when none is nearer (r > 0).
    double distance(double x, double y, double r) const;
    // The ids of the curves with a segment within r of (x, y) (distance <= r), ascending, each once.
    std::vector<std::size_t> ids_within(double x, double y, double r) const;
    // Whether curve `id` has a segment within r of (x, y).
    bool id_within(std::size_t id, double x, double y, double r) const;

    // Calls visit(k) for every indexed segment k (position in segments()) sharing a cell with s: cell by cell, row
    // by row from the bottom, ascending within a cell; a segment sharing several cells with s comes once per cell.
    // The segments that cross s are among them.
    template <class Visit> void sharing_cells(const Segment &s, Visit visit) const {
        if (m_entries.empty()) return;
        for_cells(std::min(s.ax, s.bx), std::min(s.ay, s.by), std::max(s.ax, s.bx), std::max(s.ay, s.by),
                  [&](long long cell) { visit_cell(cell, visit); });
    }

  private:
    static constexpr long long side = 1 << 20;
    long long column(double v, double origin) const;
    // visit(cell) for the cells touching the box [x0, x1] x [y0, y1], row by row from the bottom.
    template <class Visit> void for_cells(double x0, double y0, double x1, double y1, Visit visit) const {
        const long long i0 = column(x0, m_x0), i1 = column(x1, m_x0), j0 = column(y0, m_y0), j1 = column(y1, m_y0);
        for (long long j = j0; j <= j1; ++j)
            for (long long i = i0; i <= i1; ++i) visit((j + 1) * side + (i + 1));
    }
    template <class Visit> void visit_cell(long long cell, Visit visit) const {
        auto it = std::lower_bound(m_entries.begin(), m_entries.end(), std::make_pair(cell, std::size_t{0}));
        for (; it != m_entries.end() && it->first == cell; ++it) visit(it->second);
    }
    // visit(k) for the segments of the cells touching the square of half side r around (x, y), the square widened by
    // far more than the rounding error of a distance (relative to the coordinates' magnitude, m_scale) so that no
    // segment that distance_to_segment puts within r is left out.
    template <class Visit> void around(double x, double y, double r, Visit visit) const;

    std::vector<Segment> m_segments;
    double m_x0 = 0.0, m_y0 = 0.0, m_h = 1.0, m_scale = 0.0;
    std::vector<std::pair<long long, std::size_t>> m_entries; // (cell, segment), sorted
};

} // namespace geobarrier

#endif
