#include "whole_curves.hpp"

#include <geobarrier/curves.hpp>
#include <geobarrier/segment_index.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace geobarrier::hyperbolic {

namespace {

// An end of a polyline: where it is and the direction in which the curve leaves through it.
struct End {
    double x = 0.0, y = 0.0;
    double tx = 0.0, ty = 0.0; // unit outward tangent; zero for a polyline of one point
};

// End 0 is the first point, end 1 the last; the tangent runs from the point `tangent_length` inside (or the far end
// of a shorter curve) to the end.
End end_of(const std::vector<double> &xy, int which, double tangent_length) {
    const std::size_t n = xy.size() / 2;
    End e;
    const std::size_t at = which == 0 ? 0 : n - 1;
    e.x = xy[2 * at];
    e.y = xy[2 * at + 1];
    double run = 0.0;
    std::size_t k = at;
    while (run < tangent_length) {
        const std::size_t next = which == 0 ? k + 1 : k - 1;
        if ((which == 0 && k + 1 >= n) || (which == 1 && k == 0)) break;
        run += std::hypot(xy[2 * next] - xy[2 * k], xy[2 * next + 1] - xy[2 * k + 1]);
        k = next;
    }
    const double dx = e.x - xy[2 * k], dy = e.y - xy[2 * k + 1], d = std::hypot(dx, dy);
    if (d > 0.0) {
        e.tx = dx / d;
        e.ty = dy / d;
    }
    return e;
}

// Whether `to` lies ahead of end `from` within 45 degrees of its outward tangent, or the two practically coincide.
bool ahead(const End &from, const End &to, double close) {
    const double dx = to.x - from.x, dy = to.y - from.y;
    if (std::hypot(dx, dy) <= close) return true;
    const double along = dx * from.tx + dy * from.ty, across = std::abs(dx * from.ty - dy * from.tx);
    return along > 0.0 && along >= across;
}

// Whether `to` lies within `beside` of end `from`'s tangent line and at most `beside` behind it.
bool in_line(const End &from, const End &to, double beside) {
    const double dx = to.x - from.x, dy = to.y - from.y;
    const double along = dx * from.tx + dy * from.ty, across = std::abs(dx * from.ty - dy * from.tx);
    return across <= beside && along >= -beside;
}

std::size_t find_root(std::vector<std::size_t> &parent, std::size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
}

} // namespace

std::vector<std::vector<JoinedPart>> join_end_to_end(const std::vector<std::vector<double>> &curves,
                                                     const JoinRules &rules) {
    const double join_distance = rules.join_distance, tangent_length = rules.tangent_length;
    const double min_alignment = rules.min_alignment, beside = rules.beside, reach = rules.reach;
    const std::vector<char> &loose = rules.loose;
    const std::vector<int> &group = rules.group;
    const std::size_t n = curves.size();
    std::vector<End> ends(2 * n);
    std::vector<char> usable(n, 0);
    for (std::size_t c = 0; c < n; ++c) {
        if (curves[c].size() < 4) continue;
        usable[c] = 1;
        ends[2 * c] = end_of(curves[c], 0, tangent_length);
        ends[2 * c + 1] = end_of(curves[c], 1, tangent_length);
    }
    struct Pair {
        double distance;
        std::size_t a, b; // ends
    };
    std::vector<Pair> pairs;
    const double close = 0.25 * join_distance;
    for (std::size_t a = 0; a < 2 * n; ++a)
        for (std::size_t b = a + 1; b < 2 * n; ++b) {
            if (a / 2 == b / 2 || !usable[a / 2] || !usable[b / 2]) continue;
            if (!group.empty() && group[a / 2] != group[b / 2]) continue;
            const End &ea = ends[a], &eb = ends[b];
            const double d = std::hypot(ea.x - eb.x, ea.y - eb.y);
            const bool may_be_beside = beside > 0.0 && (loose.empty() || (loose[a / 2] && loose[b / 2]));
            if (d > std::max(join_distance, may_be_beside ? reach : 0.0)) continue;
            if (ea.tx * eb.tx + ea.ty * eb.ty > -min_alignment) continue; // they do not run on into each other
            const bool meet = d <= join_distance && ahead(ea, eb, close) && ahead(eb, ea, close);
            if (!meet && !(may_be_beside && in_line(ea, eb, beside) && in_line(eb, ea, beside))) continue;
            pairs.push_back({d, a, b});
        }
    std::stable_sort(pairs.begin(), pairs.end(), [](const Pair &p, const Pair &q) { return p.distance < q.distance; });
    // The known joins after the measured ones, where both ends are still free.
    for (const auto &[a, b] : rules.joined)
        if (a < 2 * n && b < 2 * n && a / 2 != b / 2 && usable[a / 2] && usable[b / 2] &&
            (group.empty() || group[a / 2] == group[b / 2]))
            pairs.push_back({HUGE_VAL, a, b});
    constexpr std::size_t none = std::numeric_limits<std::size_t>::max();
    std::vector<std::size_t> partner(2 * n, none), parent(n);
    std::iota(parent.begin(), parent.end(), std::size_t{0});
    for (const Pair &p : pairs) {
        if (partner[p.a] != none || partner[p.b] != none) continue;
        const std::size_t ra = find_root(parent, p.a / 2), rb = find_root(parent, p.b / 2);
        if (ra == rb) continue; // the chain would close on itself
        parent[std::max(ra, rb)] = std::min(ra, rb);
        partner[p.a] = p.b;
        partner[p.b] = p.a;
    }
    // Walk each chain from a free end of its lowest-indexed terminal polyline (every chain has two free ends).
    std::vector<char> done(n, 0);
    std::vector<std::vector<JoinedPart>> chains;
    for (std::size_t c = 0; c < n; ++c) {
        if (done[c] || (partner[2 * c] != none && partner[2 * c + 1] != none)) continue;
        std::vector<JoinedPart> chain;
        std::size_t enter = partner[2 * c] == none ? 2 * c : 2 * c + 1;
        while (true) {
            const std::size_t curve = enter / 2;
            done[curve] = 1;
            const bool reversed = enter % 2 == 1;
            chain.push_back({curve, reversed});
            const std::size_t exit = reversed ? 2 * curve : 2 * curve + 1;
            if (partner[exit] == none) break;
            enter = partner[exit];
        }
        chains.push_back(std::move(chain));
    }
    std::sort(chains.begin(), chains.end(), [](const std::vector<JoinedPart> &a, const std::vector<JoinedPart> &b) {
        const auto lowest = [](const std::vector<JoinedPart> &ch) {
            std::size_t m = ch.front().index;
            for (const JoinedPart &p : ch) m = std::min(m, p.index);
            return m;
        };
        return lowest(a) < lowest(b);
    });
    return chains;
}

std::vector<double> chain_points(const std::vector<std::vector<double>> &curves, const std::vector<JoinedPart> &chain) {
    std::vector<double> xy;
    for (const JoinedPart &part : chain) {
        const std::vector<double> &c = curves[part.index];
        const std::size_t n = c.size() / 2;
        const auto point = [&](std::size_t i) { return part.reversed ? n - 1 - i : i; };
        // The part's first point nearest the chain's end: past the run of points that approach it.
        std::size_t first = 0;
        if (!xy.empty()) {
            const double ex = xy[xy.size() - 2], ey = xy.back();
            const auto distance = [&](std::size_t i) {
                return std::hypot(c[2 * point(i)] - ex, c[2 * point(i) + 1] - ey);
            };
            while (first + 1 < n && distance(first + 1) < distance(first)) ++first;
        }
        for (std::size_t i = first; i < n; ++i) {
            const std::size_t k = point(i);
            if (!xy.empty() && xy[xy.size() - 2] == c[2 * k] && xy.back() == c[2 * k + 1]) continue;
            xy.push_back(c[2 * k]);
            xy.push_back(c[2 * k + 1]);
        }
    }
    return xy;
}

std::vector<char> bundled_curves(const std::vector<std::vector<double>> &curves, double distance, double min_length) {
    std::vector<Segment> segments;
    for (std::size_t c = 0; c < curves.size(); ++c)
        append_polyline_segments(curves[c].data(), curves[c].size() / 2, false, c, segments);
    std::vector<char> bundled(curves.size(), 0);
    if (segments.empty()) return bundled;
    const SegmentIndex index(std::move(segments), distance);
    for (std::size_t c = 0; c < curves.size(); ++c) {
        const std::vector<double> &xy = curves[c];
        const std::size_t n = xy.size() / 2;
        // 0 where the point is farther than `distance` from every kept curve before this one, else 1: the runs of
        // free points are the runs below 0.5, as the strainlines' compact pieces are found (runs_below).
        std::vector<double> near(n, 0.0);
        for (std::size_t k = 0; k < n; ++k)
            for (const std::size_t other : index.ids_within(xy[2 * k], xy[2 * k + 1], distance))
                if (other < c && !bundled[other]) near[k] = 1.0;
        const std::vector<double> steps = segment_lengths(xy);
        double longest = 0.0;
        for (const PointRun &run : runs_below(near, 0.5)) {
            double length = 0.0;
            for (std::size_t k = run.first; k + 1 < run.end; ++k) length += steps[k];
            longest = std::max(longest, length);
        }
        bundled[c] = n > 0 && longest < min_length ? 1 : 0;
    }
    return bundled;
}

double transverse_q_ratio(const Grid &grid, const std::vector<double> &root, const std::vector<std::uint8_t> &mask,
                          const std::vector<double> &xy, double spacing, double near, double far) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    if (xy.size() < 4 || !(spacing > 0.0) || !(far > near)) return nan;
    const std::vector<double> p = resample_polyline(xy, spacing);
    const std::size_t n = p.size() / 2;
    const auto steps = static_cast<long>(std::floor(far / spacing + 1e-9));
    const std::size_t copies = static_cast<std::size_t>(2 * steps + 1);
    std::vector<double> sums(copies, 0.0), values(copies);
    std::size_t kept = 0;
    for (std::size_t k = 0; k < n; ++k) {
        const std::size_t a = k > 0 ? k - 1 : 0, b = k + 1 < n ? k + 1 : n - 1;
        const double tx = p[2 * b] - p[2 * a], ty = p[2 * b + 1] - p[2 * a + 1], t = std::hypot(tx, ty);
        if (!(t > 0.0)) continue;
        const double nx = -ty / t, ny = tx / t;
        bool finite = true;
        for (long s = -steps; s <= steps && finite; ++s) {
            const double d = static_cast<double>(s) * spacing;
            const double v = sample_field(grid, root, mask, p[2 * k] + d * nx, p[2 * k + 1] + d * ny);
            values[static_cast<std::size_t>(s + steps)] = v;
            finite = std::isfinite(v);
        }
        if (!finite) continue;
        ++kept;
        for (std::size_t c = 0; c < copies; ++c) sums[c] += values[c];
    }
    if (2 * kept < n) return nan;
    double least_near = HUGE_VAL, least_far = HUGE_VAL;
    for (long s = -steps; s <= steps; ++s) {
        const double q = sums[static_cast<std::size_t>(s + steps)];
        if (std::abs(static_cast<double>(s) * spacing) <= near * (1.0 + 1e-9))
            least_near = std::min(least_near, q);
        else
            least_far = std::min(least_far, q);
    }
    if (!(least_far < HUGE_VAL)) return nan; // `far` within `near`: nothing to compare with
    return least_far / least_near;
}

} // namespace geobarrier::hyperbolic
