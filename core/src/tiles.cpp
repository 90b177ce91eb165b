// The flow map and Cauchy–Green fields tile by tile (see tiles.hpp).
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/tiles.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

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
    const std::size_t align = std::max<std::size_t>(points_per_batch(settings, plan.gradient, plan.positions), 1);
    const std::size_t step = align / std::gcd(nx, align); // rows whose points fill whole batches
    std::size_t rows = std::max<std::size_t>(plan.tile_points / nx, 1);
    rows = (rows + step - 1) / step * step;
    return std::min(rows, std::max<std::size_t>(grid.ny, 1));
}

GridFields compute_grid_fields(const Dynamics &dynamics, const Grid &grid, double t0, double t1,
                               const IntegratorSettings &settings, const std::optional<Bounds> &bounds,
                               const FieldPlan &plan, const ProgressFn &progress) {
    if (grid.nx < 2 || grid.ny < 2)
        throw ConfigError("/grid/n", "the grid needs at least 2 points per direction (got " + std::to_string(grid.nx) +
                                         " x " + std::to_string(grid.ny) + ")");
    const GradientMethod gradient = plan.cauchy_green ? plan.gradient : GradientMethod::none;
    if (gradient == GradientMethod::auxiliary_grid && !(plan.aux_offset > 0.0 && std::isfinite(plan.aux_offset)))
        throw ConfigError("/cauchy_green/offset", std::to_string(plan.aux_offset) + " is not a positive offset");
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    const std::size_t count = grid.size(), nx = grid.nx;
    const double abs_duration = std::abs(t1 - t0);

    GridFields out;
    out.flow.grid = grid;
    out.flow.mask.assign(count, 0);
    if (plan.positions) {
        out.flow.flow_x.assign(count, nan);
        out.flow.flow_y.assign(count, nan);
    }
    if (plan.cauchy_green) {
        out.cg.grid = grid;
        out.cg.mask.assign(count, 0);
        for (const auto &name : plan.keep) cauchy_green_member(out.cg, name).assign(count, nan);
    }
    out.rows_per_tile = tile_rows(grid, settings, plan);
    const double offset_x = plan.aux_offset * grid.dx(), offset_y = plan.aux_offset * grid.dy();

    // One tile's buffers, reused by the next tile: fresh ones would cost page faults, serially, at every tile.
    GridFlowMap tile;
    for (std::size_t row = 0; row < grid.ny; row += out.rows_per_tile) {
        const std::size_t rows = std::min(out.rows_per_tile, grid.ny - row);
        const std::size_t first = row * nx, points = rows * nx;
        ++out.tiles;
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
        tile = flow_map_at_points(dynamics, points, start, t0, t1, settings, gradient, offset_x, offset_y,
                                  plan.positions, bounds, tile_progress, std::move(tile));
        out.flow.stats.add(tile.stats);
        std::copy(tile.mask.begin(), tile.mask.end(), out.flow.mask.begin() + static_cast<std::ptrdiff_t>(first));
        if (plan.positions) {
            std::copy(tile.flow_x.begin(), tile.flow_x.end(),
                      out.flow.flow_x.begin() + static_cast<std::ptrdiff_t>(first));
            std::copy(tile.flow_y.begin(), tile.flow_y.end(),
                      out.flow.flow_y.begin() + static_cast<std::ptrdiff_t>(first));
        }
        if (!plan.cauchy_green) continue;
        // Straight into the whole-grid fields, only those kept (the others are empty in out.cg).
        out.cg.degenerate_count += cauchy_green_into(
            out.cg, first, points, tile.dF.data(), tile.mask.data(),
            tile.dF_exponent.empty() ? nullptr : tile.dF_exponent.data(),
            tile.log_det.empty() ? nullptr : tile.log_det.data(), abs_duration);
    }
    if (std::none_of(out.flow.mask.begin(), out.flow.mask.end(), [](std::uint8_t m) { return m == 0; }))
        throw NumericalError("every one of the " + std::to_string(count) + " grid points was masked: " +
                             describe_masking(out.flow.stats, settings, dynamics.system->has_jacobian()) +
                             "; check the grid, the time interval, the bounds and the system");
    return out;
}

} // namespace geobarrier
