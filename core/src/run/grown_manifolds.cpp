// Barriers grown along their manifolds by curve advection with point insertion (tangle.hpp).
#include <geobarrier/curves.hpp>
#include <geobarrier/flow_map.hpp>
#include <geobarrier/tangle.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace geobarrier {

using nlohmann::json;

GrownBarriers grow_barriers(const ResolvedExperiment &r, const json &barriers, double t_to) {
    const Experiment &e = r.experiment;
    const Grid &g = e.grid;
    std::vector<std::vector<double>> curves;
    std::vector<bool> closed;
    std::vector<std::size_t> index; // barrier of each curve
    for (std::size_t b = 0; b < barriers.size(); ++b) {
        const json &points = barriers[b].at("points");
        if (points.size() < 2) continue;
        std::vector<double> xy;
        for (const json &p : points) xy.insert(xy.end(), {p[0].get<double>(), p[1].get<double>()});
        curves.push_back(std::move(xy));
        closed.push_back(barriers[b].value("closed", false));
        index.push_back(b);
    }
    GrownBarriers grown;
    if (curves.empty()) return grown;
    // A grid spacing between neighbouring image points inside the box: as fine as the fields the barriers came from.
    CurveAdvectionSettings settings;
    settings.max_gap = std::min(g.dx(), g.dy());
    settings.refine_box = std::array<double, 4>{g.x_min, g.x_max, g.y_min, g.y_max};
    settings.max_points = 1000000;
    const std::vector<AdvectedCurve> advected = advect_curves(
        curves, closed, make_advect_points_fn(r.dynamics(), e.t0, t_to, e.integrator, masking(e.bounds)), settings);
    const auto inside = [&](double x, double y) {
        return x >= g.x_min && x <= g.x_max && y >= g.y_min && y <= g.y_max;
    };
    for (std::size_t c = 0; c < advected.size(); ++c) {
        const AdvectedCurve &a = advected[c];
        // The image inside the box, cut where it leaves the box or where a gap stayed open (a trajectory that left
        // the bounds dropped out between two points, or the point budget ran out).
        json piece = json::array();
        std::size_t pieces = 0;
        double length_in_box = 0.0, max_gap_in_box = 0.0;
        const auto flush = [&] {
            if (piece.size() >= 2) {
                grown.pieces.push_back({{"points", piece}, {"closed", false}, {"barrier", index[c]}});
                ++pieces;
            }
            piece = json::array();
        };
        const std::size_t m = a.xy1.size() / 2;
        for (std::size_t k = 0; k < m; ++k) {
            const double x = a.xy1[2 * k], y = a.xy1[2 * k + 1];
            if (!inside(x, y)) {
                flush();
                continue;
            }
            if (!piece.empty()) {
                const double gap = std::hypot(x - piece.back()[0].get<double>(), y - piece.back()[1].get<double>());
                if (gap > 4.0 * settings.max_gap) {
                    flush();
                } else {
                    length_in_box += gap;
                    max_gap_in_box = std::max(max_gap_in_box, gap);
                }
            }
            piece.push_back({x, y});
        }
        flush();
        grown.report.push_back({{"barrier", index[c]},
                                {"length", polyline_length(curves[c], closed[c])},
                                {"grown_length", a.length1},
                                {"length_in_box", length_in_box},
                                {"pieces_in_box", pieces},
                                {"points", m},
                                {"left_bounds", a.masked},
                                {"max_gap_in_box", max_gap_in_box},
                                {"refined", max_gap_in_box <= settings.max_gap * (1 + 1e-9)}});
    }
    return grown;
}

GrownBarriers grow_barriers_over_periods(const ResolvedExperiment &r, const json &barriers, int direction,
                                         std::size_t periods, double period) {
    GrownBarriers all;
    for (std::size_t b = 0; b < barriers.size(); ++b)
        all.pieces.push_back({{"points", barriers[b].at("points")},
                              {"closed", barriers[b].value("closed", false)},
                              {"barrier", b},
                              {"periods", 0}});
    for (std::size_t j = 1; j <= periods; ++j) {
        GrownBarriers grown = grow_barriers(r, barriers, r.experiment.t0 + direction * static_cast<double>(j) * period);
        for (json &piece : grown.pieces) {
            piece["periods"] = j;
            all.pieces.push_back(std::move(piece));
        }
        for (json &entry : grown.report) {
            entry["periods"] = j;
            all.report.push_back(std::move(entry));
        }
    }
    return all;
}

} // namespace geobarrier
