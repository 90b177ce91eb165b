// x-y pictures: lines, point clouds and time series, with a legend.
#include "plot/plot_internal.hpp"

namespace geobarrier {

using namespace plot_internal;

namespace {

// ------------------------------------------------------------------------------------------------ x-y pictures

// A series in plotting units (log10 of the data on logarithmic axes; non-plottable values become NaN gaps).
struct PreparedSeries {
    std::vector<double> x, y;
};

PreparedSeries prepare_series(const PlotSeries &series, bool log_x, bool log_y) {
    PreparedSeries out;
    split_xy(series.xy, out.x, out.y);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    auto transform = [&](double &v, bool log) {
        if (!std::isfinite(v) || !plottable(v))
            v = nan;
        else if (log)
            v = v > 0.0 ? std::log10(v) : nan;
    };
    for (std::size_t p = 0; p < out.x.size(); ++p) {
        transform(out.x[p], log_x);
        transform(out.y[p], log_y);
        if (std::isnan(out.x[p]) || std::isnan(out.y[p])) out.x[p] = out.y[p] = nan;
    }
    return out;
}

// The plotted range of one axis: the requested one (in plotting units), or the data's padded by 3% each side;
// an empty or degenerate range is widened so the axis still has ticks.
std::pair<double, double> axis_range(const std::optional<std::pair<double, double>> &requested, bool log,
                                     const std::vector<PreparedSeries> &data, bool is_x) {
    if (requested)
        return log ? std::make_pair(std::log10(requested->first), std::log10(requested->second)) : *requested;
    double low = std::numeric_limits<double>::infinity(), high = -low;
    for (const PreparedSeries &s : data)
        for (double v : is_x ? s.x : s.y)
            if (std::isfinite(v)) {
                low = std::min(low, v);
                high = std::max(high, v);
            }
    if (!(low <= high)) return {0.0, 1.0};
    if (high - low <= 1e-12 * std::max(std::abs(low), std::abs(high))) {
        const double half = std::abs(low) > 0.0 ? 0.05 * std::abs(low) : 0.5;
        return {low - half, high + half};
    }
    const double pad = 0.03 * (high - low);
    return {low - pad, high + pad};
}

void check_xy(const XYPlot &plot) {
    const char *where = "plot_xy_png";
    check_width(where, plot.width_px);
    if (!(plot.aspect >= 0.1 && plot.aspect <= 10.0))
        throw Error(std::string(where) + ": aspect " + std::to_string(plot.aspect) + " is outside [0.1, 10]");
    for (const auto *range : {&plot.x_range, &plot.y_range}) {
        if (!*range) continue;
        const bool log = range == &plot.x_range ? plot.log_x : plot.log_y;
        if (!(std::isfinite((*range)->first) && std::isfinite((*range)->second) && (*range)->first < (*range)->second))
            throw Error(std::string(where) + ": an axis range must be finite with min < max");
        if (log && !((*range)->first > 0.0))
            throw Error(std::string(where) + ": a logarithmic axis needs a positive range");
    }
    for (const PlotSeries &s : plot.series) {
        if (s.xy.size() % 2 != 0)
            throw Error(std::string(where) + ": a series has an odd number of coordinates (" +
                        std::to_string(s.xy.size()) + ")");
        check_line_width(where, s.width);
        check_marker(where, s.marker_px);
        parse_color(s.color, where);
    }
}

PLINT dash_style(PlotSeries::Dash dash) {
    switch (dash) {
    case PlotSeries::Dash::dashed:
        return 3; // PLplot's long dashes
    case PlotSeries::Dash::dotted:
        return 2; // short dashes, the closest to dots that scales with the line
    default:
        return 1;
    }
}

// The legend of an x-y picture: the `listed` series (those with a label), where plot.legend says; `ch` is the
// character height in pixels, the data box box_w pixels wide and box_w * aspect tall.
void draw_xy_legend(const XYPlot &plot, const std::vector<std::size_t> &listed, double ch, double box_w,
                    double aspect) {
    const bool outside_legend = plot.legend == XYPlot::Legend::outside_right;
    const double char_mm = px_to_mm(ch);
    const PLINT n = static_cast<PLINT>(listed.size());
    std::vector<PLINT> opts(n), text_colors(n, slot_ink), line_colors(n), line_styles(n), symbol_colors(n),
        symbol_numbers(n, 1), box_colors(n, 0), box_patterns(n, 0);
    std::vector<PLFLT> line_widths(n), symbol_scales(n), box_scales(n, 0.0), box_line_widths(n, 0.0);
    std::vector<std::string> texts(n);
    std::vector<const char *> text_ptrs(n), symbol_ptrs(n);
    for (PLINT e = 0; e < n; ++e) {
        const PlotSeries &s = plot.series[listed[e]];
        opts[e] = (s.style != PlotSeries::Style::points ? PL_LEGEND_LINE : 0) |
                  (s.style != PlotSeries::Style::line ? PL_LEGEND_SYMBOL : 0);
        line_colors[e] = symbol_colors[e] = slot_xy_count + static_cast<PLINT>(listed[e]);
        line_styles[e] = dash_style(s.dash);
        line_widths[e] = s.width;
        // U+25CF (black circle) is about 0.6 character heights across in DejaVu Sans: scale it to the
        // markers' size, but keep it visible.
        symbol_scales[e] = std::max(s.marker_px, 0.5 * ch) / (0.6 * ch);
        symbol_ptrs[e] = "\u25cf";
        texts[e] = plain_text(s.label);
        text_ptrs[e] = texts[e].c_str();
    }
    PLINT position = PL_POSITION_INSIDE | PL_POSITION_VIEWPORT;
    switch (plot.legend) {
    case XYPlot::Legend::top_left:
        position |= PL_POSITION_TOP | PL_POSITION_LEFT;
        break;
    case XYPlot::Legend::bottom_left:
        position |= PL_POSITION_BOTTOM | PL_POSITION_LEFT;
        break;
    case XYPlot::Legend::bottom_right:
        position |= PL_POSITION_BOTTOM | PL_POSITION_RIGHT;
        break;
    case XYPlot::Legend::outside_right:
        position = PL_POSITION_OUTSIDE | PL_POSITION_VIEWPORT | PL_POSITION_RIGHT;
        break;
    default:
        position |= PL_POSITION_TOP | PL_POSITION_RIGHT;
    }
    set_color(slot_legend, {160, 160, 160});
    plschr(char_mm, 1.0);
    plwidth(1.0);
    PLFLT legend_width = 0.0, legend_height = 0.0;
    const double offset_x = (outside_legend ? 1.5 : 0.8) * ch / box_w;
    const double offset_y = (outside_legend ? 0.0 : 0.8) * ch / (box_w * aspect);
    pllegend(&legend_width, &legend_height, PL_LEGEND_BACKGROUND | PL_LEGEND_BOUNDING_BOX, position, offset_x, offset_y,
             3.0 * ch / box_w, slot_background, slot_legend, 1, 0, 0, n, opts.data(), 1.0, 1.0, 2.0, 0.0,
             text_colors.data(), text_ptrs.data(), box_colors.data(), box_patterns.data(), box_scales.data(),
             box_line_widths.data(), line_colors.data(), line_styles.data(), line_widths.data(), symbol_colors.data(),
             symbol_scales.data(), symbol_numbers.data(), symbol_ptrs.data());
}

void draw_xy(const std::filesystem::path &file, const XYPlot &plot, PlplotErrors &errors) {
    std::vector<PreparedSeries> data;
    for (const PlotSeries &s : plot.series) data.push_back(prepare_series(s, plot.log_x, plot.log_y));
    const auto [x0, x1] = axis_range(plot.x_range, plot.log_x, data, true);
    const auto [y0, y1] = axis_range(plot.y_range, plot.log_y, data, false);

    std::vector<std::size_t> listed; // series shown in the legend
    for (std::size_t k = 0; k < plot.series.size(); ++k)
        if (!plot.series[k].label.empty()) listed.push_back(k);
    const bool outside_legend = !listed.empty() && plot.legend == XYPlot::Legend::outside_right;

    // Layout, as for fields: margins from the tick labels, the box's aspect from the data or `aspect`.
    const double ch = char_px_for(plot.width_px);
    double widest_label = 0.0;
    for (std::size_t k : listed) widest_label = std::max(widest_label, visible_chars(plot.series[k].label));
    const double legend_px = (3.0 + 1.0 + 2.0) * ch + legend_char_width * ch * widest_label;
    const double top = plot.title.empty() ? 1.5 * ch : 4.0 * ch;
    const double bottom = 5.4 * ch;
    const double right = outside_legend ? legend_px + 2.5 * ch : 2.5 * ch;
    const double aspect = plot.equal_aspect ? std::clamp((y1 - y0) / (x1 - x0), 0.25, 4.0) : plot.aspect;
    double left = 10.0 * ch, y_label_disp = 0.0;
    Ticks x_ticks, y_ticks;
    for (int round = 0; round < 2; ++round) {
        const double box_w = plot.width_px - left - right;
        const double box_h = box_w * aspect;
        x_ticks = plot.log_x ? make_log_ticks(x0, x1, std::clamp(box_w / (7.0 * ch), 3.0, 10.0))
                             : make_ticks(x0, x1, std::clamp(box_w / (7.0 * ch), 3.0, 10.0));
        y_ticks = plot.log_y ? make_log_ticks(y0, y1, std::clamp(box_h / (5.0 * ch), 2.0, 10.0))
                             : make_ticks(y0, y1, std::clamp(box_h / (5.0 * ch), 2.0, 10.0));
        const double y_label_px =
            0.7 * ch + char_width * ch * label_chars(y0, y1, y_ticks) + 1.0 * ch + label_scale * ch;
        left = y_label_px + 1.0 * ch;
        y_label_disp = y_label_px / (label_scale * ch);
    }
    const double box_w = plot.width_px - left - right;
    const int height = static_cast<int>(std::lround(box_w * aspect + top + bottom));
    const double w = plot.width_px, h = height;
    const double char_mm = px_to_mm(ch);

    begin_page(file, plot.width_px, height, slot_xy_count + static_cast<PLINT>(plot.series.size()), errors);
    plvpor(left / w, 1.0 - right / w, bottom / h, 1.0 - top / h);
    plwind(x0, x1, y0, y1);

    // Light grid lines under the data at the major ticks (and decades on log axes).
    const AxisFormats formats{x_ticks, y_ticks};
    set_color(slot_grid, {225, 225, 225});
    plwidth(1.0);
    plbox((std::string("g") + (plot.log_x ? "l" : "")).c_str(), x_ticks.step, 0,
          (std::string("g") + (plot.log_y ? "l" : "")).c_str(), y_ticks.step, 0);

    const double px_x = (x1 - x0) / box_w, px_y = (y1 - y0) / (box_w * aspect);
    for (std::size_t k = 0; k < plot.series.size(); ++k) {
        const PlotSeries &s = plot.series[k];
        const PLINT slot = slot_xy_count + static_cast<PLINT>(k);
        set_color(slot, parse_color(s.color, "plot_xy_png"));
        if (s.style != PlotSeries::Style::points) {
            plwidth(s.width);
            pllsty(dash_style(s.dash));
            draw_polyline(data[k].x, data[k].y, s.closed, px_x, px_y);
            pllsty(1);
        }
        if (s.style != PlotSeries::Style::line) draw_markers(data[k].x, data[k].y, s.marker_px, px_x, px_y);
    }

    const std::string log_x = plot.log_x ? "l" : "", log_y = plot.log_y ? "l" : "";
    draw_box(formats, "bcnst" + log_x, "bcnstv" + log_y, char_mm, y_label_disp, plot.x_label, plot.y_label, plot.title,
             place_title(plot.title, ch, left, box_w, plot.width_px));

    if (!listed.empty()) draw_xy_legend(plot, listed, ch, box_w, aspect);
    if (errors.code != 0) throw IoError("'" + file.string() + "': PLplot failed: " + errors.message);
}

} // namespace

void plot_xy_png(const std::filesystem::path &file, const XYPlot &plot) {
    check_xy(plot);
    write_picture(file, [&](const std::filesystem::path &name, PlplotErrors &errors) { draw_xy(name, plot, errors); });
}

} // namespace geobarrier
