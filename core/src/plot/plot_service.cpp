// GB_EXTENSION_PLOT: an extractor's pictures, handed over as plain C structs (abi.h) and drawn with the core's PLplot
// code, so that the extractor needs nothing of the core's C++ library. Every field is checked here, at the boundary:
// a bad struct is a GB_ERROR with a message naming the field, never a crash inside PLplot.
#include "plot/plot_service.hpp"

#include <geobarrier/output.hpp>

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

namespace geobarrier {
namespace {

// The C enums of abi.h and the C++ ones of output.hpp are converted by casts (here and in sdk_plot.hpp): same values.
static_assert(static_cast<int>(PlotSeries::Style::line) == GB_PLOT_LINE &&
              static_cast<int>(PlotSeries::Style::points) == GB_PLOT_POINTS &&
              static_cast<int>(PlotSeries::Style::line_points) == GB_PLOT_LINE_POINTS);
static_assert(static_cast<int>(PlotSeries::Dash::solid) == GB_PLOT_SOLID &&
              static_cast<int>(PlotSeries::Dash::dashed) == GB_PLOT_DASHED &&
              static_cast<int>(PlotSeries::Dash::dotted) == GB_PLOT_DOTTED);
static_assert(static_cast<int>(XYPlot::Legend::top_right) == GB_LEGEND_TOP_RIGHT &&
              static_cast<int>(XYPlot::Legend::top_left) == GB_LEGEND_TOP_LEFT &&
              static_cast<int>(XYPlot::Legend::bottom_right) == GB_LEGEND_BOTTOM_RIGHT &&
              static_cast<int>(XYPlot::Legend::bottom_left) == GB_LEGEND_BOTTOM_LEFT &&
              static_cast<int>(XYPlot::Legend::outside_right) == GB_LEGEND_OUTSIDE_RIGHT);

void set_message(gb_message *msg, const std::string &text) {
    if (!msg || !msg->text || msg->capacity == 0) return;
    const std::size_t n = std::min(text.size(), msg->capacity - 1);
    std::memcpy(msg->text, text.data(), n);
    msg->text[n] = '\0';
}

std::string text(const char *s, const char *fallback) { return s ? std::string(s) : std::string(fallback); }

// `count` points, x and y interleaved, or an error naming `what`.
std::vector<double> points(const double *xy, std::uint64_t count, const std::string &what) {
    if (count == 0) return {};
    if (!xy) throw std::invalid_argument(what + ": " + std::to_string(count) + " points but xy is NULL");
    return std::vector<double>(xy, xy + 2 * count);
}

FieldPlot field_plot(const gb_plot_field &in) {
    FieldPlot out;
    out.title = text(in.title, "");
    out.x_label = text(in.x_label, "x");
    out.y_label = text(in.y_label, "y");
    out.colorbar_label = text(in.colorbar_label, "");
    out.width_px = in.width_px;
    if (in.curve_count > 0 && !in.curves)
        throw std::invalid_argument("gb_plot_field: curve_count " + std::to_string(in.curve_count) +
                                    " but curves is NULL");
    for (std::uint32_t k = 0; k < in.curve_count; ++k) {
        const gb_plot_curve &c = in.curves[k];
        PlotCurve curve;
        curve.xy = points(c.xy, c.count, "gb_plot_field.curves[" + std::to_string(k) + "]");
        curve.color = text(c.color, "red");
        curve.width = c.width;
        curve.closed = c.closed != 0;
        curve.points_only = c.points_only != 0;
        curve.marker_px = c.marker_px;
        out.curves.push_back(std::move(curve));
    }
    return out;
}

XYPlot xy_plot(const gb_plot_xy &in) {
    XYPlot out;
    out.title = text(in.title, "");
    out.x_label = text(in.x_label, "x");
    out.y_label = text(in.y_label, "y");
    out.log_x = in.log_x != 0;
    out.log_y = in.log_y != 0;
    out.equal_aspect = in.equal_aspect != 0;
    out.aspect = in.aspect;
    if (in.has_x_range) out.x_range = std::make_pair(in.x_range[0], in.x_range[1]);
    if (in.has_y_range) out.y_range = std::make_pair(in.y_range[0], in.y_range[1]);
    if (in.legend < GB_LEGEND_TOP_RIGHT || in.legend > GB_LEGEND_OUTSIDE_RIGHT)
        throw std::invalid_argument("gb_plot_xy.legend: " + std::to_string(in.legend) + " is not a gb_plot_legend");
    out.legend = static_cast<XYPlot::Legend>(in.legend);
    out.width_px = in.width_px;
    if (in.series_count > 0 && !in.series)
        throw std::invalid_argument("gb_plot_xy: series_count " + std::to_string(in.series_count) +
                                    " but series is NULL");
    for (std::uint32_t k = 0; k < in.series_count; ++k) {
        const gb_plot_series &s = in.series[k];
        const std::string where = "gb_plot_xy.series[" + std::to_string(k) + "]";
        PlotSeries series;
        series.xy = points(s.xy, s.count, where);
        series.label = text(s.label, "");
        series.color = text(s.color, "blue");
        series.width = s.width;
        if (s.style < GB_PLOT_LINE || s.style > GB_PLOT_LINE_POINTS)
            throw std::invalid_argument(where + ".style: " + std::to_string(s.style) + " is not a gb_plot_style");
        if (s.dash < GB_PLOT_SOLID || s.dash > GB_PLOT_DOTTED)
            throw std::invalid_argument(where + ".dash: " + std::to_string(s.dash) + " is not a gb_plot_dash");
        series.style = static_cast<PlotSeries::Style>(s.style);
        series.dash = static_cast<PlotSeries::Dash>(s.dash);
        series.marker_px = s.marker_px;
        series.closed = s.closed != 0;
        out.series.push_back(std::move(series));
    }
    return out;
}

gb_status field_png(const char *file, const gb_plot_field *plot, gb_message *msg) noexcept {
    try {
        if (!file || !plot) throw std::invalid_argument("field_png: the file or the gb_plot_field is NULL");
        if (plot->struct_size < sizeof(gb_plot_field))
            throw std::invalid_argument("gb_plot_field.struct_size " + std::to_string(plot->struct_size) +
                                        " is smaller than this core's " + std::to_string(sizeof(gb_plot_field)));
        Grid grid;
        grid.x_min = plot->x_min;
        grid.x_max = plot->x_max;
        grid.y_min = plot->y_min;
        grid.y_max = plot->y_max;
        grid.nx = plot->nx;
        grid.ny = plot->ny;
        if (!plot->values) throw std::invalid_argument("gb_plot_field.values is NULL");
        const std::vector<double> values(plot->values, plot->values + grid.size());
        const std::vector<std::uint8_t> mask = plot->mask
                                                   ? std::vector<std::uint8_t>(plot->mask, plot->mask + grid.size())
                                                   : std::vector<std::uint8_t>(grid.size(), 0);
        plot_field_png(file, grid, values, mask, field_plot(*plot));
        return GB_OK;
    } catch (const std::exception &e) {
        set_message(msg, e.what());
        return GB_ERROR;
    }
}

gb_status xy_png(const char *file, const gb_plot_xy *plot, gb_message *msg) noexcept {
    try {
        if (!file || !plot) throw std::invalid_argument("xy_png: the file or the gb_plot_xy is NULL");
        if (plot->struct_size < sizeof(gb_plot_xy))
            throw std::invalid_argument("gb_plot_xy.struct_size " + std::to_string(plot->struct_size) +
                                        " is smaller than this core's " + std::to_string(sizeof(gb_plot_xy)));
        plot_xy_png(file, xy_plot(*plot));
        return GB_OK;
    } catch (const std::exception &e) {
        set_message(msg, e.what());
        return GB_ERROR;
    }
}

} // namespace

const gb_plot_service *plot_service() {
    static const gb_plot_service service{sizeof(gb_plot_service), &field_png, &xy_png};
    return &service;
}

} // namespace geobarrier
