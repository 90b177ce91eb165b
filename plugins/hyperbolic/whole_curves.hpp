// The hyperbolic extractor's last stage: what the selection of local minima of q (Alg. 1, step 3) found, made into
// the barriers a user can trust. Two things the selection cannot see on its own:
//  - Pieces of one invariant curve. The selection reports the part of a strainline segment that runs on past a
//    barrier of smaller q as a barrier of its own (a remainder), and strainlines stop at singular points: an
//    attractor or a homoclinic loop comes out as several pieces laid end to end. join_end_to_end joins them.
//  - Curves that are local minima of q only because the strainlines beside them were cut short by d_g and so are no
//    candidates. Next to a separatrix, the level sets of an integrable flow are less stretched the closer they lie
//    to it (shear grows towards it), so a level set is a local minimum of q among candidates whenever its neighbours
//    nearer the separatrix were truncated. transverse_q_ratio tests the local minimum against the curves parallel
//    to the barrier instead, from the field.
// Pure functions of polylines and grid fields, so that tests build them without the plugin.
#pragma once

#include <geobarrier/grid.hpp>

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace geobarrier::hyperbolic {

// One part of a joined curve: a polyline of the input, in its own direction or reversed.
struct JoinedPart {
    std::size_t index = 0;
    bool reversed = false;
};

// How join_end_to_end joins ends: the rules as named fields, since several are vectors that a positional call could
// bind to the wrong parameter.
struct JoinRules {
    double join_distance = 0.0;  // ends this close join when they run on into each other
    double tangent_length = 0.0; // each end's outward tangent is measured over this length from it
    double min_alignment = 0.8;  // the tangents at least 180 degrees minus acos(min_alignment) apart
    double beside = 0.0;         // > 0: ends up to `reach` apart also join when each lies within `beside` of the
    double reach = 0.0;          // other's tangent line and at most `beside` behind it
    std::vector<char> loose;     // the polylines that may join so (all when empty)
    std::vector<int> group;      // only polylines of the same group join (all when empty)
    // Pairs of ends known to be one curve (end 2 c is curve c's first point, 2 c + 1 its last), joined after the
    // measured ones where both are still free and of one group, however far apart and whatever their tangents.
    std::vector<std::pair<std::size_t, std::size_t>> joined;
};

// Chains of the given polylines (x, y interleaved) whose ends meet: an end of one within `join_distance` of an end of
// another, the two running on into each other (their outward tangents, measured over `tangent_length` from each end,
// at an angle of at least 180 degrees minus acos(min_alignment) apart, and each end's partner ahead of it, not
// behind). With `beside` > 0, two ends also meet up to `reach` apart when each lies within `beside` of the other's
// tangent line and at most `beside` behind it: pieces of one curve that the strainlines traced a cell or two off each
// other, side by side where they overlap, or in line across a gap; only between polylines flagged in `loose` (all
// when it is empty). With `group` given, only polylines of the same group join. Nearest ends are joined first; then
// the pairs of ends in `joined`: pieces known to be one curve (a remainder of the selection that runs on from a
// barrier's end along the same strainline). Each end joins at most once, and no chain closes on itself. Every
// polyline is in exactly one chain; a polyline no end of which meets another is a chain of one. Chains are in order
// of their first polyline's index, and each chain's parts in order along it.
std::vector<std::vector<JoinedPart>> join_end_to_end(const std::vector<std::vector<double>> &curves,
                                                     const JoinRules &rules);

// The same with only the distance and tangent rules (the others at their defaults).
inline std::vector<std::vector<JoinedPart>> join_end_to_end(const std::vector<std::vector<double>> &curves,
                                                            double join_distance, double tangent_length) {
    JoinRules rules;
    rules.join_distance = join_distance;
    rules.tangent_length = tangent_length;
    return join_end_to_end(curves, rules);
}

// The points of a chain: its parts' points in order, each reversed where the chain says. Where a part begins beside
// the chain's end (the two overlap), it joins at its point nearest that end: its points before it, which run back
// along the chain, are left out.
std::vector<double> chain_points(const std::vector<std::vector<double>> &curves, const std::vector<JoinedPart> &chain);

// One representative of each bundle: which of the curves (in order of preference, the best first) lie along the
// curves before them that are kept. A curve is bundled when none of its runs of points farther than `distance` from
// every kept curve before it is `min_length` long: what it adds is shorter than a candidate may be (the selection's
// rule for the part of a candidate not yet covered, docs/extractors.md step 6). 1 for bundled, else 0.
std::vector<char> bundled_curves(const std::vector<std::vector<double>> &curves, double distance, double min_length);

// How clearly the curve is a local minimum of relative stretching q among the curves parallel to it (Alg. 1's local
// minimum, tested against the field itself rather than against the strainlines that happen to be candidates): the
// curve is resampled `spacing` apart and moved along its normal by s = -far, ..., -spacing, 0, spacing, ..., far
// (steps of `spacing`); q(s) is the mean of `root` (sqrt(lambda1)) along each moved copy. Returns the least q(s)
// with near < |s| <= far over the least q(s) with |s| <= near: above 1, no parallel curve farther than `near` and
// within `far` is less stretched. Points where any copy meets NaN (the mask, outside the box) are left out of every
// copy alike; NaN when fewer than half of the points remain.
double transverse_q_ratio(const Grid &grid, const std::vector<double> &root, const std::vector<std::uint8_t> &mask,
                          const std::vector<double> &xy, double spacing, double near, double far);

} // namespace geobarrier::hyperbolic
