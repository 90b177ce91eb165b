// 3-D pictures: curves and shaded tubes in extended phase space, painted far to near.
#include "plot/plot_internal.hpp"

namespace geobarrier {

using namespace plot_internal;

namespace {

// ------------------------------------------------------------------------------------------------ 3-D pictures

void check_xyz(const XYZPlot &plot) {
    const char *where = "plot_xyz_png";
    check_width(where, plot.width_px);
    if (!(plot.altitude_deg >= 0.0 && plot.altitude_deg <= 90.0))
        throw Error(std::string(where) + ": altitude " + std::to_string(plot.altitude_deg) + " is outside [0, 90]");
    if (!std::isfinite(plot.azimuth_deg)) throw Error(std::string(where) + ": the azimuth must be finite");
    for (const PlotSeries3D &s : plot.series) {
        if (s.xyz.size() % 3 != 0)
            throw Error(std::string(where) + ": a series' coordinates are not triples (" +
                        std::to_string(s.xyz.size()) + " values)");
        check_line_width(where, s.width);
        parse_color(s.color, where);
    }
    for (const PlotSurface3D &s : plot.surfaces) {
        if (s.xyz.size() != 3 * s.rows * s.cols)
            throw Error(std::string(where) + ": a surface of " + std::to_string(s.rows) + " x " +
                        std::to_string(s.cols) + " points has " + std::to_string(s.xyz.size()) + " values");
        if (!(s.opacity >= 0.0 && s.opacity <= 1.0))
            throw Error(std::string(where) + ": opacity " + std::to_string(s.opacity) + " is outside [0, 1]");
        parse_color(s.color, where);
    }
}

// PLplot's world-to-viewer transform of plw3d (plot3d.c): the third row gives the depth, larger = nearer.
struct View3D {
    double xmid = 0, ymid = 0, zmid = 0, czx = 0, czy = 0, czz = 0;
    // Direction towards the viewer in the box's normalised coordinates, for shading.
    double depth(double x, double y, double z) const { return (x - xmid) * czx + (y - ymid) * czy + (z - zmid) * czz; }
};

// One thing to draw in the painter's algorithm: a quad face or a line segment.
struct Primitive {
    double depth = 0.0;
    bool face = false;
    std::array<double, 12> xyz{}; // a face: 4 corners; a segment: 2 ends
    Rgb rgb;
    double alpha = 1.0;
    double width = 1.0;
};

// The data's box: each coordinate's range over every series and surface, widened where empty or degenerate.
std::pair<std::array<double, 3>, std::array<double, 3>> data_box(const XYZPlot &plot) {
    std::array<double, 3> low{}, high{};
    low.fill(std::numeric_limits<double>::infinity());
    high.fill(-std::numeric_limits<double>::infinity());
    auto extend = [&](const std::vector<double> &xyz) {
        for (std::size_t p = 0; p + 2 < xyz.size(); p += 3)
            if (std::isfinite(xyz[p]) && std::isfinite(xyz[p + 1]) && std::isfinite(xyz[p + 2]))
                for (int c = 0; c < 3; ++c) {
                    low[c] = std::min(low[c], xyz[p + c]);
                    high[c] = std::max(high[c], xyz[p + c]);
                }
    };
    for (const auto &s : plot.series) extend(s.xyz);
    for (const auto &s : plot.surfaces) extend(s.xyz);
    for (int c = 0; c < 3; ++c) {
        if (!(low[c] <= high[c])) {
            low[c] = 0.0;
            high[c] = 1.0;
        } else if (high[c] - low[c] <= 1e-12 * std::max(std::abs(low[c]), std::abs(high[c]))) {
            const double half = std::abs(low[c]) > 0.0 ? 0.05 * std::abs(low[c]) : 0.5;
            low[c] -= half;
            high[c] += half;
        }
    }
    return {low, high};
}

// The quad faces of the surfaces, each shaded by how squarely it faces the viewer (normals in the box's normalised
// coordinates, `scale` per world unit; `toward` the viewer), from 55% to 100% of its colour.
void add_surface_faces(const XYZPlot &plot, const View3D &view, const std::array<double, 3> &scale,
                       const std::array<double, 3> &toward, std::vector<Primitive> &primitives) {
    for (const PlotSurface3D &s : plot.surfaces) {
        if (s.rows < 2 || s.cols < 2) continue;
        const Rgb base = parse_color(s.color, "plot_xyz_png");
        const std::size_t col_end = s.wrap_cols ? s.cols : s.cols - 1;
        for (std::size_t r = 0; r + 1 < s.rows; ++r)
            for (std::size_t c = 0; c < col_end; ++c) {
                const std::size_t c1 = (c + 1) % s.cols;
                const std::array<std::size_t, 4> corners{r * s.cols + c, r * s.cols + c1, (r + 1) * s.cols + c1,
                                                         (r + 1) * s.cols + c};
                Primitive p;
                p.face = true;
                bool finite = true;
                double depth = 0.0;
                for (int k = 0; k < 4; ++k)
                    for (int d = 0; d < 3; ++d) {
                        p.xyz[3 * k + d] = s.xyz[3 * corners[k] + d];
                        finite = finite && std::isfinite(p.xyz[3 * k + d]);
                    }
                if (!finite) continue;
                for (int k = 0; k < 4; ++k) depth += view.depth(p.xyz[3 * k], p.xyz[3 * k + 1], p.xyz[3 * k + 2]);
                p.depth = depth / 4.0;
                // Normal from the diagonals, in normalised box units.
                const double ax = (p.xyz[6] - p.xyz[0]) * scale[0], ay = (p.xyz[7] - p.xyz[1]) * scale[1],
                             az_ = (p.xyz[8] - p.xyz[2]) * scale[2];
                const double bx = (p.xyz[9] - p.xyz[3]) * scale[0], by = (p.xyz[10] - p.xyz[4]) * scale[1],
                             bz = (p.xyz[11] - p.xyz[5]) * scale[2];
                const double n0 = ay * bz - az_ * by, n1 = az_ * bx - ax * bz, n2 = ax * by - ay * bx;
                const double norm = std::sqrt(n0 * n0 + n1 * n1 + n2 * n2);
                const double facing =
                    norm > 0.0 ? std::abs(n0 * toward[0] + n1 * toward[1] + n2 * toward[2]) / norm : 0.0;
                const double shade = 0.55 + 0.45 * facing;
                p.rgb = {static_cast<int>(std::lround(base.r * shade)), static_cast<int>(std::lround(base.g * shade)),
                         static_cast<int>(std::lround(base.b * shade))};
                p.alpha = s.opacity;
                primitives.push_back(p);
            }
    }
}

// The line segments of the series.
void add_series_segments(const XYZPlot &plot, const View3D &view, std::vector<Primitive> &primitives) {
    for (const PlotSeries3D &s : plot.series) {
        const Rgb rgb = parse_color(s.color, "plot_xyz_png");
        const std::size_t n = s.xyz.size() / 3;
        const std::size_t segments = (s.closed && n >= 3) ? n : (n > 0 ? n - 1 : 0);
        for (std::size_t k = 0; k < segments; ++k) {
            const std::size_t a = k, b = (k + 1) % n;
            Primitive p;
            bool finite = true;
            for (int d = 0; d < 3; ++d) {
                p.xyz[d] = s.xyz[3 * a + d];
                p.xyz[3 + d] = s.xyz[3 * b + d];
                finite = finite && std::isfinite(p.xyz[d]) && std::isfinite(p.xyz[3 + d]);
            }
            if (!finite) continue;
            // Lines lying on a surface (a barrier drawn on its own tube) must not vanish under the faces they
            // share a depth with: they count as nearer by 2% of the box.
            p.depth =
                0.5 * (view.depth(p.xyz[0], p.xyz[1], p.xyz[2]) + view.depth(p.xyz[3], p.xyz[4], p.xyz[5])) + 0.02;
            p.rgb = rgb;
            p.width = s.width;
            primitives.push_back(p);
        }
    }
}

// The painter's algorithm: faces and segments drawn far to near.
void paint_far_to_near(std::vector<Primitive> &primitives) {
    std::stable_sort(primitives.begin(), primitives.end(),
                     [](const Primitive &a, const Primitive &b) { return a.depth < b.depth; });
    for (const Primitive &p : primitives) {
        set_color(slot_scratch, p.rgb, p.alpha);
        if (p.face) {
            std::array<PLFLT, 4> xs{p.xyz[0], p.xyz[3], p.xyz[6], p.xyz[9]},
                ys{p.xyz[1], p.xyz[4], p.xyz[7], p.xyz[10]}, zs{p.xyz[2], p.xyz[5], p.xyz[8], p.xyz[11]};
            plfill3(4, xs.data(), ys.data(), zs.data());
        } else {
            plwidth(p.width);
            std::array<PLFLT, 2> xs{p.xyz[0], p.xyz[3]}, ys{p.xyz[1], p.xyz[4]}, zs{p.xyz[2], p.xyz[5]};
            plline3(2, xs.data(), ys.data(), zs.data());
        }
    }
}

// Title and legend of a 3-D picture, in page coordinates (w x h pixels; `top` the title's margin).
void draw_xyz_title_and_legend(const XYZPlot &plot, const std::vector<std::size_t> &listed, double ch, double w,
                               double h, double top) {
    const double char_mm = px_to_mm(ch);
    plvpor(0.0, 1.0, 0.0, 1.0);
    plwind(0.0, 1.0, 0.0, 1.0);
    plcol0(slot_ink);
    if (!plot.title.empty()) {
        plschr(char_mm, title_scale);
        plptex(0.5, 1.0 - 2.2 * ch / h, 1.0, 0.0, 0.5, plain_text(plot.title).c_str());
    }
    if (listed.empty()) return;
    const PLINT n = static_cast<PLINT>(listed.size());
    std::vector<PLINT> opts(n, PL_LEGEND_LINE), text_colors(n, slot_ink), line_colors(n), line_styles(n, 1),
        zeros(n, 0);
    std::vector<PLFLT> line_widths(n), zero_scales(n, 0.0);
    std::vector<std::string> texts(n);
    std::vector<const char *> text_ptrs(n), no_symbols(n, "");
    for (PLINT e = 0; e < n; ++e) {
        const PlotSeries3D &s = plot.series[listed[e]];
        const PLINT slot = slot_xy_count + static_cast<PLINT>(listed[e]);
        plscol0(slot, parse_color(s.color).r, parse_color(s.color).g, parse_color(s.color).b);
        line_colors[e] = slot;
        line_widths[e] = s.width;
        texts[e] = plain_text(s.label);
        text_ptrs[e] = texts[e].c_str();
    }
    set_color(slot_legend, {160, 160, 160});
    plschr(char_mm, 1.0);
    plwidth(1.0);
    PLFLT legend_width = 0.0, legend_height = 0.0;
    pllegend(&legend_width, &legend_height, PL_LEGEND_BACKGROUND | PL_LEGEND_BOUNDING_BOX,
             PL_POSITION_INSIDE | PL_POSITION_VIEWPORT | PL_POSITION_TOP | PL_POSITION_RIGHT, 1.0 * ch / w, top / h,
             3.0 * ch / w, slot_background, slot_legend, 1, 0, 0, n, opts.data(), 1.0, 1.0, 2.0, 0.0,
             text_colors.data(), text_ptrs.data(), zeros.data(), zeros.data(), zero_scales.data(), zero_scales.data(),
             line_colors.data(), line_styles.data(), line_widths.data(), zeros.data(), zero_scales.data(), zeros.data(),
             no_symbols.data());
}

void draw_xyz(const std::filesystem::path &file, const XYZPlot &plot, PlplotErrors &errors) {
    const auto [low, high] = data_box(plot);
    const double ch = char_px_for(plot.width_px);
    const double char_mm = px_to_mm(ch);
    std::vector<std::size_t> listed;
    for (std::size_t k = 0; k < plot.series.size(); ++k)
        if (!plot.series[k].label.empty()) listed.push_back(k);
    // plw3d maps the data into a 1.15 x 1.15 x 1.1 box, whose projection (with its labels) fills a window of
    // [-1, 1] x [-0.45, 1.3] for the usual viewing angles, drawn with 1.32 times as many pixels per unit across as
    // up. A legend gets its own column on the right and the page is made less tall to match, so the box keeps its
    // proportions.
    double widest_label = 0.0;
    for (std::size_t k : listed) widest_label = std::max(widest_label, visible_chars(plot.series[k].label));
    const double legend_px =
        listed.empty() ? 0.0 : (3.0 + 1.0 + 2.0) * ch + legend_char_width * ch * widest_label + 2.0 * ch;
    const double top = plot.title.empty() ? 1.5 * ch : 4.0 * ch;
    // Text outside the viewport is clipped: the window reaches 0.12 units left of the box's projection, where the
    // rotated z label goes.
    const double left = 0.02 * plot.width_px;
    const double drawing_w = 0.98 * plot.width_px - left - legend_px, drawing_h = 0.625 * drawing_w;
    const int height = static_cast<int>(std::lround((drawing_h + top) / 0.98));
    begin_page(file, plot.width_px, height, slot_xy_count + static_cast<PLINT>(plot.series.size()), errors);
    const double w = plot.width_px, h = height;
    plvpor(left / w, (left + drawing_w) / w, 0.02, 1.0 - top / h);
    plwind(-1.12, 1.0, -0.45, 1.3);
    const double alt = plot.altitude_deg, az = plot.azimuth_deg;
    plw3d(1.15, 1.15, 1.1, low[0], high[0], low[1], high[1], low[2], high[2], alt, az);
    View3D view;
    view.xmid = 0.5 * (low[0] + high[0]);
    view.ymid = 0.5 * (low[1] + high[1]);
    view.zmid = 0.5 * (low[2] + high[2]);
    const double rad = M_PI / 180.0;
    const double cx = 1.15 / (high[0] - low[0]), cy = 1.15 / (high[1] - low[1]), cz = 1.1 / (high[2] - low[2]);
    view.czx = -cx * std::cos(alt * rad) * std::sin(az * rad);
    view.czy = -cy * std::cos(alt * rad) * std::cos(az * rad);
    view.czz = cz * std::sin(alt * rad);

    plwidth(1.0);
    plcol0(slot_ink);
    plschr(char_mm, 1.0);
    plsmaj(0.6 * char_mm, 1.0);
    plsmin(0.3 * char_mm, 1.0);
    // Nice steps, few enough that the slanted horizontal axes' labels do not run into each other; PLplot writes
    // 3-D tick labels with one significant decimal, so a step of 2.5 x 10^k becomes 5 x 10^k.
    auto step_3d = [](double lo, double hi, double count) {
        const double step = make_ticks(lo, hi, count).step;
        const double mantissa = step / std::pow(10.0, std::floor(std::log10(step)));
        return std::abs(mantissa - 2.5) < 1e-9 ? 2.0 * step : step;
    };
    const double x_step = step_3d(low[0], high[0], 4.0), y_step = step_3d(low[1], high[1], 4.0),
                 z_step = step_3d(low[2], high[2], 6.0);
    plbox3("bnstu", plain_text(plot.x_label).c_str(), x_step, 0, "bnstu", plain_text(plot.y_label).c_str(), y_step, 0,
           "bnstu", plain_text(plot.z_label).c_str(), z_step, 0);

    std::vector<Primitive> primitives;
    const std::array<double, 3> toward{-std::cos(alt * rad) * std::sin(az * rad),
                                       -std::cos(alt * rad) * std::cos(az * rad), std::sin(alt * rad)};
    add_surface_faces(plot, view, {cx, cy, cz}, toward, primitives);
    add_series_segments(plot, view, primitives);
    paint_far_to_near(primitives);
    draw_xyz_title_and_legend(plot, listed, ch, w, h, top);
    if (errors.code != 0) throw IoError("'" + file.string() + "': PLplot failed: " + errors.message);
}

} // namespace

void plot_xyz_png(const std::filesystem::path &file, const XYZPlot &plot) {
    check_xyz(plot);
    write_picture(file, [&](const std::filesystem::path &name, PlplotErrors &errors) { draw_xyz(name, plot, errors); });
}

} // namespace geobarrier
