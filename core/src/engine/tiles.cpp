// The flow map and Cauchy–Green fields tile by tile (see tiles.hpp).
#include "engine/tiles.hpp"
#include "run/mpi.hpp"
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <type_traits>

#include <omp.h>

namespace geobarrier {

namespace {

void add_unique(std::vector<std::string> &names, const std::string &name) {
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
}

} // namespace

std::vector<double> &cauchy_green_member(CauchyGreenField &cg, const std::string &name) {
    if (name == "ftle") return cg.ftle;
    if (name == "lambda1") return cg.lambda1;
    if (name == "lambda2") return cg.lambda2;
    if (name == "xi1_x") return cg.xi1_x;
    if (name == "xi1_y") return cg.xi1_y;
    if (name == "xi2_x") return cg.xi2_x;
    if (name == "xi2_y") return cg.xi2_y;
    throw Error("no Cauchy-Green variable \"" + name + "\"");
}

const std::vector<std::string> &cauchy_green_variables() {
    static const std::vector<std::string> names = {"ftle", "lambda1", "lambda2", "xi1_x", "xi1_y", "xi2_x", "xi2_y"};
    return names;
}

FieldPlan plan_fields(const ResolvedExperiment &r) {
    const Experiment &e = r.experiment;
    FieldPlan plan;
    plan.cauchy_green = r.need_cauchy_green;
    plan.gradient = r.need_cauchy_green ? r.gradient : GradientMethod::none;
    plan.aux_offset = e.aux_offset;
    plan.positions = r.need_positions;
    plan.exit_times = (r.need_cauchy_green || r.need_positions) && e.bounds && e.bounds->exits == ExitRule::stop;
    plan.plot = e.plots && r.need_cauchy_green;
    if (!r.need_cauchy_green) return plan;
    const auto &cg_names = cauchy_green_variables();
    const auto is_cg = [&](const std::string &n) {
        return std::find(cg_names.begin(), cg_names.end(), n) != cg_names.end();
    };
    std::vector<std::string> wanted; // every whole-grid field the outputs and extractors read
    for (const auto &product : known_products())
        if (e.wants(product.name))
            for (const char *name : product.variables) wanted.push_back(name);
    for (const Extractor &x : r.extractors)
        for (const auto &name : x.required_fields()) wanted.push_back(name);
    if (plan.plot) wanted.push_back("ftle");
    for (const auto &name : wanted) {
        if (is_cg(name)) {
            add_unique(plan.keep, name);
        } else if (name != "flow_x" && name != "flow_y") {
            // Strain and shear deviations differentiate the eigen-fields along the grid: they need them whole.
            plan.derived = true;
            for (const auto &n : cg_names) add_unique(plan.keep, n);
        }
    }
    if (!r.extractors.empty()) plan.derived = true;
    // In the order of cauchy_green_variables(), whatever asked first.
    std::vector<std::string> ordered;
    for (const auto &n : cg_names)
        if (std::find(plan.keep.begin(), plan.keep.end(), n) != plan.keep.end()) ordered.push_back(n);
    plan.keep = ordered;
    return plan;
}

std::size_t tile_rows(const Grid &grid, const IntegratorSettings &settings, const FieldPlan &plan) {
    const std::size_t nx = std::max<std::size_t>(grid.nx, 1);
    FlowMapRequest batches; // the batch layout of the request compute_grid_fields makes from the plan
    batches.settings = settings;
    batches.gradient = plan.gradient;
    batches.want_positions = plan.positions;
    const std::size_t align = std::max<std::size_t>(points_per_batch(batches), 1);
    const std::size_t step = align / std::gcd(nx, align); // rows whose points fill whole batches
    std::size_t rows = std::max<std::size_t>(plan.tile_points / nx, 1);
    rows = (rows + step - 1) / step * step;
    return std::min(rows, std::max<std::size_t>(grid.ny, 1));
}

namespace {

// What every tile of one grid computation shares.
struct TileJob {
    FlowMapRequest request; // the whole grid's; each tile adds its progress
    const Grid &grid;
    const FieldPlan &plan;
    double abs_duration;
};

// Integrates the `rows` grid rows from `row` and writes their flow map and kept Cauchy–Green fields into `flow` and
// `cg` from point `at` on (their vectors already hold those points): the whole grid's fields at the tile's own place,
// or an MPI rank's buffer of its tiles. `buffers` is reused from tile to tile.
void compute_tile(const TileJob &job, std::size_t row, std::size_t rows, std::size_t at, FlowMap &buffers,
                  FlowMap &flow, CauchyGreenField &cg, const ProgressFn &progress) {
    const Grid &grid = job.grid;
    const std::size_t nx = grid.nx, first = row * nx, points = rows * nx, count = grid.size();
    // The full grid's coordinates, so that a tile's points start exactly where they do untiled.
    const StartFn start = [&](std::size_t k, double &x, double &y) {
        const std::size_t p = first + k;
        x = grid.x(p % nx);
        y = grid.y(p / nx);
    };
    ProgressFn tile_progress;
    if (progress)
        tile_progress = [&](std::size_t done, std::size_t total) {
            progress(first + (total > 0 ? points * done / total : points), count);
        };
    FlowMapRequest request = job.request;
    request.progress = tile_progress;
    buffers = flow_map_at_points(request, points, start, std::move(buffers));
    const auto to = static_cast<std::ptrdiff_t>(at);
    flow.stats.add(buffers.stats);
    std::copy(buffers.mask.begin(), buffers.mask.end(), flow.mask.begin() + to);
    if (job.plan.positions) {
        std::copy(buffers.flow_x.begin(), buffers.flow_x.end(), flow.flow_x.begin() + to);
        std::copy(buffers.flow_y.begin(), buffers.flow_y.end(), flow.flow_y.begin() + to);
    }
    if (job.plan.exit_times && buffers.exit_time.size() == points)
        std::copy(buffers.exit_time.begin(), buffers.exit_time.end(), flow.exit_time.begin() + to);
    if (!job.plan.cauchy_green) return;
    // Straight into the fields, only those kept (the others are empty in cg).
    cg.degenerate_count +=
        cauchy_green_into(cg, at, points, buffers.dF.data(), buffers.mask.data(),
                          buffers.dF_exponent.empty() ? nullptr : buffers.dF_exponent.data(),
                          buffers.log_det.empty() ? nullptr : buffers.log_det.data(), job.abs_duration);
}

// `flow` and `cg` sized for `count` points with the plan's fields (NaN until computed).
void allocate_fields(const FieldPlan &plan, std::size_t count, FlowMap &flow, CauchyGreenField &cg) {
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    flow.mask.resize(count, 0);
    if (plan.positions) {
        flow.flow_x.resize(count, nan);
        flow.flow_y.resize(count, nan);
    }
    if (plan.exit_times) flow.exit_time.resize(count, nan);
    if (plan.cauchy_green) {
        cg.mask.resize(count, 0);
        for (const auto &name : plan.keep) cauchy_green_member(cg, name).resize(count, nan);
    }
}

// The whole-grid arrays a rank sends rank 0 for its tiles, in this order (tiles in the order computed).
template <class Visit>
void for_each_shared_array(const FieldPlan &plan, FlowMap &flow, CauchyGreenField &cg, Visit visit) {
    visit(flow.mask);
    if (plan.positions) {
        visit(flow.flow_x);
        visit(flow.flow_y);
    }
    if (plan.exit_times) visit(flow.exit_time);
    if (!plan.cauchy_green) return;
    visit(cg.mask);
    for (const auto &name : plan.keep) visit(cauchy_green_member(cg, name));
}

// The tiles shared among MPI ranks (mpi.hpp): each rank takes the next tile from the work queue until none is left
// (rank 0 straight into the whole-grid fields, the others into a buffer of their tiles), then the others send rank 0
// their tiles' fields, statistics and degenerate counts. Rank 0 returns the whole grid's fields, the others only
// their tile count. Tiles are whole lockstep batches, so every point's numbers are those of the single process.
void share_tiles(const TileJob &job, GridFields &out, const ProgressFn &progress) {
    const Grid &grid = job.grid;
    const std::size_t nx = grid.nx, count = grid.size();
    const bool root = mpi::rank() == 0;
    const std::size_t tiles = (grid.ny + out.rows_per_tile - 1) / out.rows_per_tile;
    if (root) allocate_fields(job.plan, count, out.flow, out.cg);
    FlowMap mine; // a worker's tiles, one after the other
    CauchyGreenField mine_cg;
    std::vector<std::uint64_t> my_tiles;
    std::size_t my_points = 0;
    FlowMap buffers;
    {
        mpi::WorkQueue queue(tiles);
        while (const auto tile = queue.next()) {
            const std::size_t row = *tile * out.rows_per_tile, rows = std::min(out.rows_per_tile, grid.ny - row);
            if (root) {
                compute_tile(job, row, rows, row * nx, buffers, out.flow, out.cg, progress);
            } else {
                allocate_fields(job.plan, my_points + rows * nx, mine, mine_cg);
                compute_tile(job, row, rows, my_points, buffers, mine, mine_cg, {});
                my_points += rows * nx;
            }
            my_tiles.push_back(*tile);
        }
    }
    out.tiles = my_tiles.size();
    if (!root) {
        mpi::send_vector(0, my_tiles);
        mpi::send_bytes(0, &mine.stats, sizeof mine.stats);
        mpi::send_bytes(0, &mine_cg.degenerate_count, sizeof mine_cg.degenerate_count);
        for_each_shared_array(job.plan, mine, mine_cg, [](const auto &v) { mpi::send_vector(0, v); });
        return;
    }
    static_assert(std::is_trivially_copyable_v<IntegratorStats>, "sent as bytes between ranks of one build");
    for (int from = 1; from < mpi::size(); ++from) {
        const std::vector<std::uint64_t> their_tiles = mpi::receive_vector<std::uint64_t>(from);
        IntegratorStats stats;
        std::uint64_t degenerate = 0;
        mpi::receive_bytes(from, &stats, sizeof stats);
        mpi::receive_bytes(from, &degenerate, sizeof degenerate);
        out.flow.stats.add(stats);
        out.cg.degenerate_count += degenerate;
        out.tiles += their_tiles.size();
        for_each_shared_array(job.plan, out.flow, out.cg, [&](auto &whole) {
            using T = typename std::decay_t<decltype(whole)>::value_type;
            const std::vector<T> received = mpi::receive_vector<T>(from);
            std::size_t at = 0;
            for (const std::uint64_t tile : their_tiles) {
                const std::size_t row = tile * out.rows_per_tile, rows = std::min(out.rows_per_tile, grid.ny - row);
                const std::size_t points = rows * nx;
                if (at + points > received.size())
                    throw Error("MPI rank " + std::to_string(from) + " sent fewer values than its tiles hold");
                std::copy(received.begin() + static_cast<std::ptrdiff_t>(at),
                          received.begin() + static_cast<std::ptrdiff_t>(at + points),
                          whole.begin() + static_cast<std::ptrdiff_t>(row * nx));
                at += points;
            }
        });
    }
}

} // namespace

GridFields compute_grid_fields(const Dynamics &dynamics, const Grid &grid, double t0, double t1,
                               const IntegratorSettings &settings, const std::optional<Bounds> &bounds,
                               const FieldPlan &plan, const ProgressFn &progress) {
    if (grid.nx < 2 || grid.ny < 2)
        throw EngineSettingError(EngineSetting::grid, "the grid needs at least 2 points per direction (got " +
                                                          std::to_string(grid.nx) + " x " + std::to_string(grid.ny) +
                                                          ")");
    const GradientMethod gradient = plan.cauchy_green ? plan.gradient : GradientMethod::none;
    if (gradient == GradientMethod::auxiliary_grid && !(plan.aux_offset > 0.0 && std::isfinite(plan.aux_offset)))
        throw EngineSettingError(EngineSetting::offset, std::to_string(plan.aux_offset) + " is not a positive offset");
    const std::size_t count = grid.size();
    const TileJob job{
        with_grid_offset({dynamics, t0, t1, settings, gradient, plan.positions, bounds}, grid, plan.aux_offset), grid,
        plan, std::abs(t1 - t0)};

    GridFields out;
    out.flow.grid = grid;
    if (plan.cauchy_green) out.cg.grid = grid;
    if (mpi::sharing_tiles()) {
        // About 8 tiles per rank, so that the queue can even out ranks whose rows cost more (trajectories leaving
        // the box early, adaptive steps), and never larger than the plan's tiles.
        FieldPlan shared = plan;
        const std::size_t ranks = static_cast<std::size_t>(mpi::size());
        shared.tile_points = std::min(plan.tile_points, std::max<std::size_t>(count / (8 * ranks), 1));
        out.rows_per_tile = tile_rows(grid, settings, shared);
        share_tiles(job, out, progress);
        if (mpi::rank() != 0) return out;
    } else {
        allocate_fields(plan, count, out.flow, out.cg);
        out.rows_per_tile = tile_rows(grid, settings, plan);
        // One tile's buffers, reused by the next tile: fresh ones would cost page faults, serially, at every tile.
        FlowMap buffers;
        for (std::size_t row = 0; row < grid.ny; row += out.rows_per_tile, ++out.tiles)
            compute_tile(job, row, std::min(out.rows_per_tile, grid.ny - row), row * grid.nx, buffers, out.flow, out.cg,
                         progress);
    }
    if (std::none_of(out.flow.mask.begin(), out.flow.mask.end(), [](std::uint8_t m) { return m == 0; }))
        throw NumericalError("every one of the " + std::to_string(count) + " grid points was masked: " +
                             describe_masking(out.flow.stats, settings, dynamics.system->has_jacobian()) +
                             "; check the grid, the time interval, the bounds and the system");
    return out;
}

RunSummary run_as_tile_worker(const ResolvedExperiment &r, const RunOptions &options) {
    // The same decision as the runner's on rank 0, so that every rank takes part in the same grid computation.
    if (options.threads > 0) omp_set_num_threads(options.threads);
    const Experiment &e = r.experiment;
    if (r.need_cauchy_green || r.need_positions) {
        const Dynamics dynamics = r.dynamics();
        compute_grid_fields(dynamics, e.grid, e.t0, e.t1, e.integrator, e.bounds, plan_fields(r));
    }
    return {};
}

} // namespace geobarrier
