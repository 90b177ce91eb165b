// The barrier stage's spatial index (segment_index.hpp) against a scan of every segment: on random polylines, points
// and radii, each query gives exactly the scan's answer (the cells only choose what is looked at).
#include <geobarrier/segment_index.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

using namespace geobarrier;

namespace {

// `curves` random walks of 2..40 points with steps up to `step`, from points in [0, 10]^2; every third is closed.
std::vector<Segment> random_curves(std::mt19937_64 &rng, std::size_t curves, double step, bool as_points) {
    std::uniform_real_distribution<double> start(0.0, 10.0), move(-step, step);
    std::uniform_int_distribution<std::size_t> count(2, 40);
    std::vector<Segment> out;
    for (std::size_t c = 0; c < curves; ++c) {
        std::vector<double> xy = {start(rng), start(rng)};
        for (std::size_t k = 1, n = count(rng); k < n; ++k)
            xy.insert(xy.end(), {xy[xy.size() - 2] + move(rng), xy[xy.size() - 1] + move(rng)});
        if (as_points)
            append_points(xy.data(), xy.size() / 2, c, out);
        else
            append_polyline_segments(xy.data(), xy.size() / 2, c % 3 == 0, c, out);
    }
    return out;
}

double brute_distance(const std::vector<Segment> &segments, double x, double y, double r) {
    double best = r;
    for (const Segment &s : segments) best = std::min(best, distance_to_segment(x, y, s));
    return best;
}

std::vector<std::size_t> brute_ids(const std::vector<Segment> &segments, double x, double y, double r) {
    std::set<std::size_t> ids;
    for (const Segment &s : segments)
        if (distance_to_segment(x, y, s) <= r) ids.insert(s.id);
    return {ids.begin(), ids.end()};
}

// Whether the closed segments a and b share a point (proper crossings, touching, collinear overlap).
bool intersect(const Segment &a, const Segment &b) {
    const auto orient = [](double px, double py, double qx, double qy, double rx, double ry) {
        const double v = (qx - px) * (ry - py) - (qy - py) * (rx - px);
        return (v > 0) - (v < 0);
    };
    const auto on = [](double px, double py, double qx, double qy, double rx, double ry) {
        return std::min(px, qx) <= rx && rx <= std::max(px, qx) && std::min(py, qy) <= ry && ry <= std::max(py, qy);
    };
    const int o1 = orient(a.ax, a.ay, a.bx, a.by, b.ax, b.ay), o2 = orient(a.ax, a.ay, a.bx, a.by, b.bx, b.by);
    const int o3 = orient(b.ax, b.ay, b.bx, b.by, a.ax, a.ay), o4 = orient(b.ax, b.ay, b.bx, b.by, a.bx, a.by);
    if (o1 != o2 && o3 != o4) return true;
    return (o1 == 0 && on(a.ax, a.ay, a.bx, a.by, b.ax, b.ay)) || (o2 == 0 && on(a.ax, a.ay, a.bx, a.by, b.bx, b.by)) ||
           (o3 == 0 && on(b.ax, b.ay, b.bx, b.by, a.ax, a.ay)) || (o4 == 0 && on(b.ax, b.ay, b.bx, b.by, a.bx, a.by));
}

} // namespace

TEST_CASE("distance and curves within r are a full scan's, for segments and for points") {
    std::mt19937_64 rng(36);
    std::uniform_real_distribution<double> where(-1.0, 11.0), radius(0.01, 2.0);
    for (const bool as_points : {false, true})
        for (const double cell : {0.05, 0.3, 1.0, 7.0}) {
            const std::vector<Segment> segments = random_curves(rng, 60, 0.4, as_points);
            const SegmentIndex index(segments, cell);
            std::size_t hits = 0;
            for (int q = 0; q < 400; ++q) {
                const double x = where(rng), y = where(rng), r = radius(rng);
                CHECK(index.distance(x, y, r) == brute_distance(segments, x, y, r));
                const std::vector<std::size_t> ids = index.ids_within(x, y, r);
                CHECK(ids == brute_ids(segments, x, y, r));
                hits += ids.size();
                for (std::size_t id : {std::size_t{0}, std::size_t{17}, std::size_t{59}})
                    CHECK(index.id_within(id, x, y, r) == std::binary_search(ids.begin(), ids.end(), id));
            }
            CHECK(hits > 100); // the queries did find curves (the random walks cover the box)
        }
}

TEST_CASE("a point at exactly distance r counts as within r, a vertex exactly on a cell edge included") {
    // Segment from (1, 0) to (1, 2) with cells of side 1 from x = 1: the query at (0, 1) with r = 1 touches it.
    const SegmentIndex index({{1.0, 0.0, 1.0, 2.0, 4}, {3.0, 3.0, 3.0, 3.0, 5}}, 1.0);
    CHECK(index.ids_within(0.0, 1.0, 1.0) == std::vector<std::size_t>{4});
    CHECK(index.distance(0.0, 1.0, 1.0) == 1.0);
    CHECK(index.distance(0.5, 1.0, 1.0) == 0.5);
    CHECK(index.ids_within(3.0, 5.0, 2.0) == std::vector<std::size_t>{5});
    CHECK(index.ids_within(3.0, 5.0, 1.999).empty());
}

TEST_CASE("every segment that meets a segment shares a cell with it") {
    std::mt19937_64 rng(7);
    for (const double cell : {0.1, 0.5, SegmentIndex::two_mean_lengths(random_curves(rng, 40, 0.5, false))}) {
        const std::vector<Segment> a = random_curves(rng, 40, 0.5, false), b = random_curves(rng, 40, 0.5, false);
        const SegmentIndex index(b, cell);
        std::size_t crossings = 0;
        for (const Segment &s : a) {
            std::set<std::size_t> near;
            index.sharing_cells(s, [&](std::size_t k) { near.insert(k); });
            for (std::size_t k = 0; k < b.size(); ++k)
                if (intersect(s, b[k])) {
                    ++crossings;
                    CHECK(near.count(k) == 1);
                }
        }
        CHECK(crossings > 50);
    }
}

TEST_CASE("an empty index and a bad cell side") {
    const SegmentIndex empty({}, 1.0);
    CHECK(empty.distance(0.0, 0.0, 0.5) == 0.5);
    CHECK(empty.ids_within(0.0, 0.0, 0.5).empty());
    int visits = 0;
    empty.sharing_cells({0.0, 0.0, 1.0, 1.0, 0}, [&](std::size_t) { ++visits; });
    CHECK(visits == 0);
    CHECK_THROWS_WITH(SegmentIndex({}, 0.0), doctest::Contains("expected a finite number > 0"));
    CHECK(SegmentIndex::two_mean_lengths({{0.0, 0.0, 3.0, 4.0, 0}}) == 10.0);
}
