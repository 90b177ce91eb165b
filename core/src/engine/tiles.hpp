// The flow map and the Cauchy–Green fields over a grid, computed tile by tile (blocks of grid rows): a tile's
// trajectories, gradient and Cauchy–Green tensor live only while it is computed, and only the fields the run keeps
// for the whole grid (the requested products and what extractors and derived fields read) are held throughout, so
// memory is bounded by the output fields themselves. The gradient (variational equations or auxiliary grid) and
// C = DF^T DF (paper eq. `cg`) are pointwise, so tiles need no halo; fields that differentiate along the grid (strain
// and shear deviations) are computed afterwards from whole-grid Cauchy–Green fields, which the plan then keeps.
#ifndef GEOBARRIER_TILES_HPP
#define GEOBARRIER_TILES_HPP

#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/flow_map.hpp>
#include <geobarrier/grid.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace geobarrier {

struct ResolvedExperiment;
struct RunOptions;
struct RunSummary;

// The Cauchy–Green variables a run can keep for the whole grid (CauchyGreenField's members, fields.nc's names).
const std::vector<std::string> &cauchy_green_variables();
// The member of `cg` that holds variable `name` (one of cauchy_green_variables()).
std::vector<double> &cauchy_green_member(CauchyGreenField &cg, const std::string &name);

// What a run computes and keeps for the whole grid.
struct FieldPlan {
    bool cauchy_green = false;                      // the gradient and the Cauchy–Green fields
    GradientMethod gradient = GradientMethod::none; // how the gradient is computed (when cauchy_green)
    double aux_offset = 0.0;                        // auxiliary-grid offset, relative to the grid spacing
    bool positions = false;                         // F(x0): flow_x, flow_y
    bool exit_times = false;                        // bounds with ExitRule::stop: exit_time per point
    std::vector<std::string> keep;                  // Cauchy–Green variables kept, from cauchy_green_variables()
    bool plot = false;                              // the FTLE picture (its buffers, for the estimate)
    bool derived = false;               // extractors or derived fields (their grid fields, for the estimate)
    std::size_t tile_points = 1u << 18; // points per tile, before rounding to whole rows and batches
};

// The plan of a resolved experiment: its products, its extractors' required fields and its pictures.
FieldPlan plan_fields(const ResolvedExperiment &experiment);

// Rows per tile: about plan.tile_points points, at least one row, and a multiple of whole lockstep batches
// (points_per_batch) so that every point has the batch-mates it has in an untiled run and the numbers are the same
// bit for bit (see flow_map_at_points). Never more than grid.ny.
std::size_t tile_rows(const Grid &grid, const IntegratorSettings &settings, const FieldPlan &plan);

struct GridFields {
    FlowMap flow;        // flow_x, flow_y (when plan.positions), mask (trajectory bits), stats; dF is never kept
    CauchyGreenField cg; // the kept variables only (the others empty), mask with mask_degenerate, degenerate_count
    std::size_t tiles = 0, rows_per_tile = 0;
};

// The flow map and the kept Cauchy–Green fields over `grid`, tile by tile. Progress counts grid points across all
// tiles. Throws NumericalError, naming the reasons, when every grid point is masked.
GridFields compute_grid_fields(const Dynamics &dynamics, const Grid &grid, double t0, double t1,
                               const IntegratorSettings &settings, const std::optional<Bounds> &bounds,
                               const FieldPlan &plan, const ProgressFn &progress = {});

// Under mpirun, `geobarrier run` on the ranks other than 0 (mpi.hpp): their share of the flow map's tiles, sent to
// rank 0, which runs everything else (extractors, validation, output) once. Writes nothing; returns no files.
RunSummary run_as_tile_worker(const ResolvedExperiment &experiment, const RunOptions &options);

} // namespace geobarrier

#endif // GEOBARRIER_TILES_HPP
