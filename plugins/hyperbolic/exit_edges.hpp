// Strainline seeds where the exit time jumps: the attracting barriers of open systems in backward time.
//
// In an open system (bounds whose exits stop trajectories) run backward, an attracting barrier is where the time to
// leave the bounds jumps: van der Pol's limit cycle is the edge of the captured set (inside, backward trajectories
// never leave; outside they leave within the horizon), and the far part of an escape oscillator's unstable manifold
// spirals into that edge in strands across which trajectories leave one loop apart. There the backward FTLE ridge is
// one-sided and d_g^xi1 < max_deviation only in a band about a grid cell wide, so strainlines from the seed lattice,
// started a cell or more off, drift away and are cut; a strainline started on the curve follows it. The grid edges
// across which the exit time jumps lie within half a cell of the curve: seeds there (docs/extractors.md, step 1).
// A pure function of grid fields, so that tests build it without the plugin.
#pragma once

#include <geobarrier/grid.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace geobarrier::hyperbolic {

// When the time to exit |exit_time - t0| jumps across a grid edge between two neighbouring unmasked points (mask 0).
// Between two points that leave: when their times differ by more than `jump` and the time grows towards the edge on
// the side that leaves first (its point is later than its neighbour beyond it, away from the edge). A strand of a
// saddle's manifold is such a jump: the time spent near the saddle grows without bound towards it, from both sides
// (on the escape oscillator's cases 99.6% of the jumps between leaving points rise so). A trajectory grazing the
// bounds makes a jump too, one loop long, with nothing lingering on either side: van der Pol's, 0.1-0.2 outside the
// cycle, where the time falls towards the edge on half of them; one gave an off-cycle barrier ranked first. Between one
// that stays (exit_time NaN) and one that leaves: its time is unknown, later than the `horizon` |t1 - t0|, so the jump
// is at least the horizon less the leaving one's time; it counts when that exceeds `stay_jump`. Smaller, the edge is
// taken for the horizon's cut through a smooth exit time (in a dissipative system run backward, the points that have
// not left yet: on the damped attractor's suite case the leaving side of such edges leaves within 0.018 |t1 - t0| of
// the horizon), while one that leaves well before the horizon next to one that stays lies on the edge of a captured
// set, whose exit time diverges there (van der Pol's cycle), or on a strand of a manifold whose far side leaves after
// the horizon (the escape oscillator's, next to its captured set). stay_jump below jump: a loop's duration, the jump
// across a strand, is a lower bound only once one side is cut off by the horizon.
struct ExitJumps {
    double t0;
    double horizon;
    double jump;
    double stay_jump;
};

// A grid edge across which the exit time jumps (ExitJumps): from grid point p to p + 1 (along_x) or to p + nx;
// captured when one of its points stays.
struct JumpEdge {
    std::size_t p;
    bool along_x;
    bool captured;
};

// Those edges in grid order (row by row, the edge along x before the edge along y). Empty when nothing exits
// (exit_time all NaN: a run without bounds). `mask` may be null (no point masked). Found once, they serve both
// functions below (each a pass over the whole grid otherwise).
std::vector<JumpEdge> exit_jump_edges(const Grid &g, const double *exit_time, const std::uint8_t *mask,
                                      const ExitJumps &rule);

// The midpoints (x, y interleaved) of `edges`, thinned in their order to seeds at least `separation` apart.
std::vector<double> exit_jump_seeds(const Grid &g, const std::vector<JumpEdge> &edges, double separation);

// Which grid points lie within `reach` grid points (along x and along y) of an end of such an edge: one byte a point,
// 0 far from every jump, else near_leaving_jump where both points of the edge leave, or-ed with near_captured_jump
// where one of them stays (the captured set's edge). The extractor keeps of the strainlines from those seeds what
// runs along the jumps.
constexpr std::uint8_t near_leaving_jump = 1, near_captured_jump = 2;
std::vector<std::uint8_t> near_exit_jumps(const Grid &g, const std::vector<JumpEdge> &edges, std::size_t reach);

// The edge of the captured set (the unmasked points that stay, exit_time NaN) as curves: the midpoints of the grid
// edges between a point that stays and one that does not, each joined to those of the cells it bounds (marching
// squares: a cell with two such sides links them; one with four, whose corners alternate, links each side to the
// next one round the cell that shares a point that stays with it). Each curve is closed (it ends on its first point)
// unless it meets the grid's edge. `jumps` is the share of its grid edges across which the exit time jumps
// (ExitJumps: the point that leaves does so more than stay_jump before the horizon), the rest being the horizon's cut
// or the mask. In an open system run backward a closed edge that is all jumps but for a few cuts is the attracting
// barrier itself (van der Pol's limit cycle, within half a cell of it: 0.995 to 1 of its edges jump on 181 x 181 to
// 361 x 361, where the escape oscillator's captured sets, bounded in part by the horizon's cut, have 0.43 to 0.72),
// while strainlines, along its one-sided FTLE ridge, follow it only in part.
struct EdgeCurve {
    std::vector<double> xy;
    bool closed = false;
    double jumps = 0.0;
};
std::vector<EdgeCurve> captured_set_edges(const Grid &g, const double *exit_time, const std::uint8_t *mask,
                                          const ExitJumps &rule);

// Which points of a curve (n points, x and y interleaved) lie ON a jump of the exit time: at a point, the nearest grid
// points `offset` to either side along the curve's normal (from its neighbouring points) jump (ExitJumps), the kind
// of that jump (near_leaving_jump or near_captured_jump) for the point, else 0; a point within `offset` of arc length
// of such a point gets its kind too, so that a curve along a staircase of grid edges is not cut where its normal
// happens to run along one. Unlike near_exit_jumps, which marks a band a cell wide on both sides of every jump, this
// asks whether the curve separates what the jump separates: the captured set's edge is the barrier (van der Pol's
// cycle), not a curve a cell or two inside the captured set beside it, where every point stays (there a strainline
// from a seed on the edge, drifting inwards, was the rank-1 barrier on 181 x 181: precision 0.31).
std::vector<std::uint8_t> across_exit_jumps(const Grid &g, const double *exit_time, const std::uint8_t *mask,
                                            const ExitJumps &rule, const double *xy, std::size_t n, double offset);

} // namespace geobarrier::hyperbolic
