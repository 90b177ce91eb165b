// Square cells over line segments: the one spatial index of the barrier stage (segment_index.hpp).
#include <geobarrier/segment_index.hpp>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace geobarrier {

double distance_to_segment(double x, double y, const Segment &s) {
    const double dx = s.bx - s.ax, dy = s.by - s.ay, length2 = dx * dx + dy * dy;
    const double t = length2 > 0.0 ? std::clamp(((x - s.ax) * dx + (y - s.ay) * dy) / length2, 0.0, 1.0) : 0.0;
    return std::hypot(x - s.ax - t * dx, y - s.ay - t * dy);
}

void append_polyline_segments(const double *xy, std::size_t points, bool closed, std::size_t id,
                              std::vector<Segment> &out) {
    for (std::size_t k = 0; k + 1 < points; ++k)
        out.push_back({xy[2 * k], xy[2 * k + 1], xy[2 * k + 2], xy[2 * k + 3], id});
    if (closed && points > 2) out.push_back({xy[2 * points - 2], xy[2 * points - 1], xy[0], xy[1], id});
}

void append_points(const double *xy, std::size_t points, std::size_t id, std::vector<Segment> &out) {
    for (std::size_t k = 0; k < points; ++k) out.push_back({xy[2 * k], xy[2 * k + 1], xy[2 * k], xy[2 * k + 1], id});
}

SegmentIndex::SegmentIndex(std::vector<Segment> segments, double cell) : m_segments(std::move(segments)) {
    if (!(cell > 0.0) || !std::isfinite(cell))
        throw std::invalid_argument("SegmentIndex: the cell side is " + std::to_string(cell) +
                                    "; expected a finite number > 0");
    if (m_segments.empty()) return;
    double x0 = std::numeric_limits<double>::infinity(), y0 = x0;
    for (const Segment &s : m_segments) {
        x0 = std::min({x0, s.ax, s.bx}), y0 = std::min({y0, s.ay, s.by});
        m_scale = std::max({m_scale, std::abs(s.ax), std::abs(s.ay), std::abs(s.bx), std::abs(s.by)});
    }
    m_x0 = x0, m_y0 = y0, m_h = cell;
    for (std::size_t k = 0; k < m_segments.size(); ++k) {
        const Segment &s = m_segments[k];
        for_cells(std::min(s.ax, s.bx), std::min(s.ay, s.by), std::max(s.ax, s.bx), std::max(s.ay, s.by),
                  [&](long long c) { m_entries.emplace_back(c, k); });
    }
    std::sort(m_entries.begin(), m_entries.end());
}

double SegmentIndex::two_mean_lengths(const std::vector<Segment> &segments) {
    const double inf = std::numeric_limits<double>::infinity();
    double x0 = inf, x1 = -inf, y0 = inf, y1 = -inf, length = 0.0;
    for (const Segment &s : segments) {
        x0 = std::min({x0, s.ax, s.bx}), x1 = std::max({x1, s.ax, s.bx});
        y0 = std::min({y0, s.ay, s.by}), y1 = std::max({y1, s.ay, s.by});
        length += std::hypot(s.bx - s.ax, s.by - s.ay);
    }
    if (segments.empty()) return 1.0;
    const double span = std::max(x1 - x0, y1 - y0);
    return std::max({2.0 * length / static_cast<double>(segments.size()), span / 1024.0, 1e-300});
}

long long SegmentIndex::column(double v, double origin) const {
    return static_cast<long long>(std::clamp(std::floor((v - origin) / m_h), -1.0, double(side - 2)));
}

template <class Visit> void SegmentIndex::around(double x, double y, double r, Visit visit) const {
    if (m_entries.empty()) return;
    const double pad = r + 1e-12 * (std::abs(x) + std::abs(y) + r + m_scale);
    for_cells(x - pad, y - pad, x + pad, y + pad, [&](long long c) { visit_cell(c, visit); });
}

double SegmentIndex::distance(double x, double y, double r) const {
    double best = r;
    around(x, y, r, [&](std::size_t k) { best = std::min(best, distance_to_segment(x, y, m_segments[k])); });
    return best;
}

std::vector<std::size_t> SegmentIndex::ids_within(double x, double y, double r) const {
    std::vector<std::size_t> ids;
    around(x, y, r, [&](std::size_t k) {
        if (distance_to_segment(x, y, m_segments[k]) <= r) ids.push_back(m_segments[k].id);
    });
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    return ids;
}

bool SegmentIndex::id_within(std::size_t id, double x, double y, double r) const {
    bool found = false;
    around(x, y, r, [&](std::size_t k) {
        found = found || (m_segments[k].id == id && distance_to_segment(x, y, m_segments[k]) <= r);
    });
    return found;
}

} // namespace geobarrier
