// Field pictures: a scalar field on the grid G0 as a colour map with a colour bar and curves over it.
#include "plot/plot_internal.hpp"

namespace geobarrier {

using namespace plot_internal;

namespace {

Layout make_layout(int width_px, double x0, double x1, double y0, double y1, double v0, double v1,
                   const FieldPlot &plot) {
    Layout layout;
    layout.width = width_px;
    const double ch = char_px_for(width_px);
    layout.char_px = ch;
    layout.bar_gap = 2.0 * ch;
    layout.bar_width = 1.6 * ch;
    layout.top = plot.title.empty() ? 1.5 * ch : 4.0 * ch;
    layout.bottom = 5.4 * ch;
    // The box keeps the data's aspect ratio (one unit of x as long as one of y) unless that would make the
    // picture absurdly tall or flat; then it is clamped to 1:4 or 4:1.
    const double aspect = std::clamp((y1 - y0) / (x1 - x0), 0.25, 4.0);
    // The margins depend on the tick labels, which depend on the box's size: two rounds settle it.
    layout.left = 10.0 * ch;
    layout.right = 12.0 * ch;
    for (int round = 0; round < 2; ++round) {
        const double box_w = width_px - layout.left - layout.right;
        const double box_h = box_w * aspect;
        layout.x_ticks = make_ticks(x0, x1, std::clamp(box_w / (7.0 * ch), 3.0, 10.0));
        layout.y_ticks = make_ticks(y0, y1, std::clamp(box_h / (5.0 * ch), 2.0, 10.0));
        layout.bar_ticks = make_ticks(v0, v1, std::clamp(box_h / (5.0 * ch), 2.0, 10.0));
        const double y_labels = char_width * ch * label_chars(y0, y1, layout.y_ticks);
        const double bar_labels = char_width * ch * label_chars(v0, v1, layout.bar_ticks);
        // Tick labels sit about 0.7 character heights from the axis; the rotated label's baseline is one gap further.
        const double y_label_px = 0.7 * ch + y_labels + 1.0 * ch + label_scale * ch;
        layout.left = y_label_px + 1.0 * ch;
        layout.y_label_disp = y_label_px / (label_scale * ch);
        const double bar_label_px = layout.bar_gap + layout.bar_width + 0.7 * ch + bar_labels + 1.0 * ch +
                                    (plot.colorbar_label.empty() ? 0.0 : label_scale * ch);
        layout.right = bar_label_px + 1.5 * ch;
        layout.bar_label_disp = bar_label_px / (label_scale * ch);
    }
    layout.height = static_cast<int>(std::lround(layout.box_width() * aspect + layout.top + layout.bottom));
    return layout;
}

void check_arguments(const Grid &grid, const std::vector<double> &values, const std::vector<std::uint8_t> &mask,
                     const FieldPlot &plot) {
    const std::string where = "plot_field_png: ";
    if (grid.nx < 2 || grid.ny < 2)
        throw Error(where + "the grid needs at least 2 x 2 points, got " + std::to_string(grid.nx) + " x " +
                    std::to_string(grid.ny));
    if (!(std::isfinite(grid.x_min) && std::isfinite(grid.x_max) && grid.x_min < grid.x_max &&
          std::isfinite(grid.y_min) && std::isfinite(grid.y_max) && grid.y_min < grid.y_max))
        throw Error(where + "the grid's bounds must be finite with min < max");
    if (values.size() != grid.size() || mask.size() != grid.size())
        throw Error(where + std::to_string(values.size()) + " values and " + std::to_string(mask.size()) +
                    " mask entries for a grid of " + std::to_string(grid.size()) + " points");
    check_width("plot_field_png", plot.width_px);
    for (const PlotCurve &curve : plot.curves) {
        if (curve.xy.size() % 2 != 0)
            throw Error(where + "a curve has an odd number of coordinates (" + std::to_string(curve.xy.size()) + ")");
        check_line_width("plot_field_png", curve.width);
        if (curve.points_only) check_marker("plot_field_png", curve.marker_px);
        parse_color(curve.color);
    }
}

// ------------------------------------------------------------------------------------------------ field pictures

// Draws one curve over a field, split wherever a point is not finite (a curve may carry NaN as a gap).
void draw_curve(const PlotCurve &curve, double px_x, double px_y) {
    set_color(slot_curve, parse_color(curve.color));
    plwidth(curve.width);
    std::vector<double> x, y;
    split_xy(curve.xy, x, y);
    if (curve.points_only)
        draw_markers(x, y, curve.marker_px, px_x, px_y);
    else
        draw_polyline(x, y, curve.closed, px_x, px_y);
}

void draw_field(const std::filesystem::path &file, const Grid &grid, const std::vector<double> &values,
                const std::vector<std::uint8_t> &mask, const FieldPlot &plot, PlplotErrors &errors) {
    // The image's cells are centred on the grid points, so the box reaches half a cell beyond the outer points.
    const double half_dx = 0.5 * grid.dx(), half_dy = 0.5 * grid.dy();
    const double x0 = grid.x_min - half_dx, x1 = grid.x_max + half_dx;
    const double y0 = grid.y_min - half_dy, y1 = grid.y_max + half_dy;
    const ColorRange range = color_range(values, mask);
    const Layout layout = make_layout(plot.width_px, x0, x1, y0, y1, range.low, range.high, plot);
    const double w = layout.width, h = layout.height;
    const double char_mm = px_to_mm(layout.char_px);

    begin_page(file, layout.width, layout.height, slot_count, errors);
    plvpor(layout.left / w, 1.0 - layout.right / w, layout.bottom / h, 1.0 - layout.top / h);
    plwind(x0, x1, y0, y1);

    // Masked points show the grey underneath: they are given a value above zmax, which plimagefr skips.
    plcol0(slot_masked);
    const std::array<PLFLT, 4> box_x{x0, x1, x1, x0}, box_y{y0, y0, y1, y1};
    plfill(4, box_x.data(), box_y.data());
    const double skip = range.high + 1.0 + std::abs(range.high - range.low);
    std::vector<PLFLT> column_major(grid.size());
    std::vector<const PLFLT *> columns(grid.nx);
    for (std::size_t j = 0; j < grid.nx; ++j) {
        for (std::size_t i = 0; i < grid.ny; ++i) {
            const double v = values[i * grid.nx + j];
            column_major[j * grid.ny + i] = (mask[i * grid.nx + j] != 0 || !plottable(v)) ? skip : v;
        }
        columns[j] = column_major.data() + j * grid.ny;
    }
    // plimagefr without a transform spreads the nx values over nx - 1 steps of (xmax - xmin) / (nx - 1) and draws
    // value j on [xmin + j step, xmin + (j + 1) step]: with xmax one cell short of x1, cell j is centred on x(j).
    plimagefr(columns.data(), static_cast<PLINT>(grid.nx), static_cast<PLINT>(grid.ny), x0, x1 - grid.dx(), y0,
              y1 - grid.dy(), range.low, range.high, range.low, range.high, nullptr, nullptr);

    const double px_x = (x1 - x0) / layout.box_width(), px_y = (y1 - y0) / layout.box_height();
    for (const PlotCurve &curve : plot.curves) draw_curve(curve, px_x, px_y);

    // Axes: PLplot's x and y tick labels both go through one label function, pointed at each axis's format.
    const AxisFormats main_axes{layout.x_ticks, layout.y_ticks};
    draw_box(main_axes, "bcnst", "bcnstv", char_mm, layout.y_label_disp, plot.x_label, plot.y_label, plot.title,
             place_title(plot.title, layout.char_px, layout.left, layout.box_width(), layout.width));

    // Colour bar to the right of the box, as tall as the box; its label is placed here rather than by
    // plcolorbar, which does not know how wide our custom tick labels are. The colour bar's axis is a y axis.
    plschr(char_mm, 1.0);
    const AxisFormats bar_axis{layout.bar_ticks, layout.bar_ticks};
    plslabelfunc(label_both_axes, const_cast<AxisFormats *>(&bar_axis));
    const char *axis_opts = "bcvtmo";
    const PLFLT bar_step = layout.bar_ticks.step;
    const PLINT sub_ticks = 0;
    const PLINT n_values = 2;
    const std::array<PLFLT, 2> bar_values{range.low, range.high};
    const PLFLT *bar_values_ptr = bar_values.data();
    const double box_w = layout.box_width();
    PLFLT bar_width = 0.0, bar_height = 0.0;
    plcolorbar(&bar_width, &bar_height, PL_COLORBAR_GRADIENT,
               PL_POSITION_RIGHT | PL_POSITION_OUTSIDE | PL_POSITION_VIEWPORT, layout.bar_gap / box_w, 0.0,
               layout.bar_width / box_w, 1.0, slot_background, slot_ink, 1, 0.0, 0.0, slot_ink, 1.0, 0, nullptr,
               nullptr, 1, &axis_opts, &bar_step, &sub_ticks, &n_values, &bar_values_ptr);
    plslabelfunc(nullptr, nullptr);
    if (!plot.colorbar_label.empty()) {
        plvpor(layout.left / w, 1.0 - layout.right / w, layout.bottom / h, 1.0 - layout.top / h);
        plschr(char_mm, label_scale);
        plmtex("r", layout.bar_label_disp, 0.5, 0.5, plain_text(plot.colorbar_label).c_str());
    }
    if (errors.code != 0) throw IoError("'" + file.string() + "': PLplot failed: " + errors.message);
}

} // namespace

void plot_field_png(const std::filesystem::path &file, const Grid &grid, const std::vector<double> &values,
                    const std::vector<std::uint8_t> &mask, const FieldPlot &plot) {
    check_arguments(grid, values, mask, plot);
    write_picture(file, [&](const std::filesystem::path &name, PlplotErrors &errors) {
        draw_field(name, grid, values, mask, plot, errors);
    });
}

} // namespace geobarrier
