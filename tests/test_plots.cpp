// x-y, field and 3-D pictures: PNGs of the requested width whose height follows the box's aspect, read back pixel by
// pixel to check what they show (a field's colour ramp, lines drawn where their coordinates say), point markers over
// a field, log axes, and bad arguments refused before anything is written; curves thinned to the picture's pixels.
#include <geobarrier/errors.hpp>
#include <geobarrier/output.hpp>

#include "plot/plot_internal.hpp"

#include <doctest/doctest.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include <unistd.h>

namespace fs = std::filesystem;
using namespace geobarrier;

namespace {

fs::path fresh_dir(const std::string &name) {
    const fs::path dir =
        fs::temp_directory_path() / ("geobarrier-test-plots-" + name + "-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

// Width and height from a PNG's IHDR chunk (0, 0 when the file is not a PNG).
std::pair<std::uint32_t, std::uint32_t> png_size(const fs::path &file) {
    std::ifstream in(file, std::ios::binary);
    const std::string png((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (png.size() < 24 || png.substr(0, 8) != std::string("\x89PNG\r\n\x1a\n", 8) || png.substr(12, 4) != "IHDR")
        return {0, 0};
    auto be32 = [&](std::size_t at) {
        std::uint32_t v = 0;
        for (std::size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(png[at + i]);
        return v;
    };
    return {be32(16), be32(20)};
}

// A picture read back as 8-bit RGB, row by row from the top.
struct Image {
    std::uint32_t width = 0, height = 0;
    std::vector<std::uint8_t> rgb;
    const std::uint8_t *at(std::uint32_t column, std::uint32_t row) const { return &rgb[3 * (row * width + column)]; }
};

Image read_png(const fs::path &file) {
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    Image image;
    REQUIRE_MESSAGE(png_image_begin_read_from_file(&png, file.c_str()) != 0, file);
    png.format = PNG_FORMAT_RGB;
    image.width = png.width;
    image.height = png.height;
    image.rgb.resize(PNG_IMAGE_SIZE(png));
    REQUIRE_MESSAGE(png_image_finish_read(&png, nullptr, image.rgb.data(), 0, nullptr) != 0, file);
    return image;
}

bool is_colour(const std::uint8_t *p, int r, int g, int b, int tolerance = 40) {
    return std::abs(p[0] - r) <= tolerance && std::abs(p[1] - g) <= tolerance && std::abs(p[2] - b) <= tolerance;
}

// Rows and columns holding pixels of one colour: their range and mean, for finding a drawn line.
struct Extent {
    std::size_t count = 0;
    double first_row = 1e9, last_row = -1, first_column = 1e9, last_column = -1, mean_row = 0, mean_column = 0;
};
Extent extent_of(const Image &image, int r, int g, int b, int tolerance = 40) {
    Extent e;
    for (std::uint32_t row = 0; row < image.height; ++row)
        for (std::uint32_t column = 0; column < image.width; ++column) {
            if (!is_colour(image.at(column, row), r, g, b, tolerance)) continue;
            ++e.count;
            e.first_row = std::min<double>(e.first_row, row);
            e.last_row = std::max<double>(e.last_row, row);
            e.first_column = std::min<double>(e.first_column, column);
            e.last_column = std::max<double>(e.last_column, column);
            e.mean_row += row;
            e.mean_column += column;
        }
    if (e.count > 0) {
        e.mean_row /= static_cast<double>(e.count);
        e.mean_column /= static_cast<double>(e.count);
    }
    return e;
}

// Viridis and the other colour-map entries are saturated; white paper, black text and grey axes are not.
bool colourful(const std::uint8_t *p) { return std::max({p[0], p[1], p[2]}) - std::min({p[0], p[1], p[2]}) > 40; }

double luminance(const std::uint8_t *p) { return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]; }

PlotSeries circle(double cx, double cy, double rx, double ry, const std::string &label) {
    PlotSeries s;
    s.label = label;
    s.closed = true;
    for (int k = 0; k < 64; ++k)
        s.xy.insert(s.xy.end(), {cx + rx * std::cos(M_PI * k / 32), cy + ry * std::sin(M_PI * k / 32)});
    return s;
}

} // namespace

TEST_CASE("plot_xy_png: lines, markers and a legend; the height follows the aspect") {
    const fs::path dir = fresh_dir("xy");
    XYPlot plot;
    plot.title = "two ellipses # and a cloud";
    plot.equal_aspect = true;
    plot.series.push_back(circle(0, 0, 2, 1, "wide"));
    PlotSeries cloud;
    cloud.style = PlotSeries::Style::points;
    cloud.color = "#1f77b4";
    cloud.label = "points";
    for (int k = 0; k < 500; ++k) cloud.xy.insert(cloud.xy.end(), {std::sin(k * 0.37), 0.5 * std::cos(k * 0.91)});
    cloud.xy.insert(cloud.xy.end(), {NAN, 0.0}); // a non-finite point is skipped
    plot.series.push_back(cloud);
    plot.width_px = 800;
    plot_xy_png(dir / "wide.png", plot);
    const auto wide = png_size(dir / "wide.png");
    CHECK(wide.first == 800u);

    plot.series[0] = circle(0, 0, 1, 2, "tall"); // the data range is now taller than wide
    plot_xy_png(dir / "tall.png", plot);
    const auto tall = png_size(dir / "tall.png");
    CHECK(tall.first == 800u);
    CHECK(tall.second > wide.second);

    // Fixed aspect: the same picture whatever the data's shape.
    plot.equal_aspect = false;
    plot.aspect = 0.5;
    plot_xy_png(dir / "a.png", plot);
    plot.series[0] = circle(0, 0, 2, 1, "wide");
    plot_xy_png(dir / "b.png", plot);
    CHECK(png_size(dir / "a.png").second == png_size(dir / "b.png").second);
    CHECK(png_size(dir / "a.png").second < 800u);
    fs::remove_all(dir);
}

TEST_CASE("plot_xy_png: logarithmic axes, dashes, legend outside; bad input is refused") {
    const fs::path dir = fresh_dir("log");
    XYPlot plot;
    plot.log_x = plot.log_y = true;
    plot.legend = XYPlot::Legend::outside_right;
    PlotSeries a, b;
    a.label = "second order";
    a.style = PlotSeries::Style::line_points;
    b.label = "fourth order";
    b.dash = PlotSeries::Dash::dashed;
    b.color = "orange";
    for (int k = 0; k < 8; ++k) {
        const double h = std::pow(2.0, -k);
        a.xy.insert(a.xy.end(), {h, h * h});
        b.xy.insert(b.xy.end(), {h, std::pow(h, 4)});
    }
    b.xy.insert(b.xy.end(), {-1.0, 1.0}); // not plottable on a log axis: left out
    plot.series = {a, b};
    plot_xy_png(dir / "log.png", plot);
    CHECK(png_size(dir / "log.png").first == 1200u);

    XYPlot bad = plot;
    bad.series[0].color = "no-such-colour";
    CHECK_THROWS_AS(plot_xy_png(dir / "bad.png", bad), Error);
    bad = plot;
    bad.series[0].xy.push_back(1.0); // odd count
    CHECK_THROWS_AS(plot_xy_png(dir / "bad.png", bad), Error);
    bad = plot;
    bad.x_range = std::make_pair(0.0, 1.0); // log axis from 0
    CHECK_THROWS_AS(plot_xy_png(dir / "bad.png", bad), Error);
    bad = plot;
    bad.width_px = 50;
    CHECK_THROWS_AS(plot_xy_png(dir / "bad.png", bad), Error);
    CHECK_FALSE(fs::exists(dir / "bad.png"));
    // An empty picture (no series) still has axes.
    plot_xy_png(dir / "empty.png", XYPlot{});
    CHECK(png_size(dir / "empty.png").first == 1200u);
    fs::remove_all(dir);
}

TEST_CASE("plot_xyz_png: a shaded tube with curves") {
    const fs::path dir = fresh_dir("xyz");
    XYZPlot plot;
    plot.title = "tube";
    PlotSurface3D tube;
    tube.rows = 10;
    tube.cols = 24;
    for (std::size_t r = 0; r < tube.rows; ++r)
        for (std::size_t c = 0; c < tube.cols; ++c)
            tube.xyz.insert(tube.xyz.end(),
                            {std::cos(2 * M_PI * c / 24), 0.5 * std::sin(2 * M_PI * c / 24), static_cast<double>(r)});
    plot.surfaces.push_back(tube);
    PlotSeries3D helix;
    helix.label = "helix";
    helix.color = "red";
    for (int k = 0; k < 200; ++k)
        helix.xyz.insert(helix.xyz.end(), {1.5 * std::cos(k * 0.2), std::sin(k * 0.2), k * 0.045});
    plot.series.push_back(helix);
    plot.width_px = 600;
    plot_xyz_png(dir / "tube.png", plot);
    const auto size = png_size(dir / "tube.png");
    CHECK(size.first == 600u);
    // A legend takes a column on the right; the page is made less tall so that the box keeps its proportions.
    XYZPlot unlabelled = plot;
    unlabelled.series[0].label.clear();
    plot_xyz_png(dir / "plain.png", unlabelled);
    const auto plain = png_size(dir / "plain.png");
    CHECK(plain.first == 600u);
    CHECK(size.second < plain.second);
    XYZPlot bad = plot;
    bad.surfaces[0].rows = 11; // 11 x 24 points promised, 10 x 24 given
    CHECK_THROWS_AS(plot_xyz_png(dir / "bad.png", bad), Error);
    bad = plot;
    bad.altitude_deg = 100;
    CHECK_THROWS_AS(plot_xyz_png(dir / "bad.png", bad), Error);
    CHECK_FALSE(fs::exists(dir / "bad.png"));
    fs::remove_all(dir);
}

TEST_CASE("plot_field_png: point markers over a field") {
    const fs::path dir = fresh_dir("markers");
    Grid grid;
    grid.nx = 20;
    grid.ny = 10;
    std::vector<double> values(grid.size());
    for (std::size_t k = 0; k < values.size(); ++k) values[k] = static_cast<double>(k % 7);
    FieldPlot plot;
    plot.width_px = 500;
    PlotCurve dots;
    dots.points_only = true;
    dots.color = "black";
    dots.marker_px = 6;
    dots.xy = {0.2, 0.2, 0.5, 0.5, 0.8, 0.3};
    plot.curves.push_back(dots);
    plot_field_png(dir / "f.png", grid, values, std::vector<std::uint8_t>(grid.size(), 0), plot);
    CHECK(png_size(dir / "f.png").first == 500u);
    plot.curves[0].marker_px = 0.0;
    CHECK_THROWS_AS(plot_field_png(dir / "g.png", grid, values, std::vector<std::uint8_t>(grid.size(), 0), plot),
                    Error);
    fs::remove_all(dir);
}

TEST_CASE("plot_xy_png: lines are drawn where their coordinates say") {
    const fs::path dir = fresh_dir("geometry");
    XYPlot plot;
    plot.x_range = std::make_pair(-1.0, 1.0);
    plot.y_range = std::make_pair(-1.0, 1.0);
    plot.width_px = 800;
    const auto line = [](std::vector<double> xy, const char *colour) {
        PlotSeries s;
        s.xy = std::move(xy);
        s.color = colour;
        s.width = 3;
        return s;
    };
    // Three horizontal lines at y = 0.5, 0, -0.5 across the whole box, one vertical line at x = 0.5.
    plot.series = {line({-1, 0.5, 1, 0.5}, "#0000ff"), line({-1, 0, 1, 0}, "#ff0000"),
                   line({-1, -0.5, 1, -0.5}, "#00c000"), line({0.5, -1, 0.5, 1}, "#ff00ff")};
    plot_xy_png(dir / "lines.png", plot);
    const Image image = read_png(dir / "lines.png");
    REQUIRE(image.width == 800u);
    // A tight tolerance: the lines' own colour, not the blend of their anti-aliased edges with the paper.
    const Extent blue = extent_of(image, 0, 0, 255, 20), red = extent_of(image, 255, 0, 0, 20),
                 green = extent_of(image, 0, 192, 0, 20), magenta = extent_of(image, 255, 0, 255, 20);
    REQUIRE(blue.count > 100);
    REQUIRE(red.count > 100);
    REQUIRE(green.count > 100);
    REQUIRE(magenta.count > 100);
    // Horizontal lines are thin bands, y up the page, equally spaced; they span the same columns (the box).
    for (const Extent *e : {&blue, &red, &green}) CHECK(e->last_row - e->first_row <= 8);
    CHECK(blue.mean_row < red.mean_row);
    CHECK(red.mean_row < green.mean_row);
    CHECK(std::abs((red.mean_row - blue.mean_row) - (green.mean_row - red.mean_row)) <= 2.0);
    CHECK(std::abs(blue.first_column - green.first_column) <= 4.0);
    CHECK(std::abs(blue.last_column - green.last_column) <= 4.0);
    // The box spans most of the picture; the vertical line at x = 0.5 stands three quarters across it and runs
    // from the y = -1 edge to the y = 1 edge: centred on y = 0 and reaching a gap (0.5 in y) beyond the lines at
    // 0.5 and -0.5, less the frame drawn over its ends.
    const double box_left = red.first_column, box_right = red.last_column;
    CHECK(box_right - box_left > 0.6 * image.width);
    CHECK(magenta.last_column - magenta.first_column <= 8);
    CHECK(std::abs(magenta.mean_column - (box_left + 0.75 * (box_right - box_left))) <= 5.0);
    const double gap = red.mean_row - blue.mean_row;
    CHECK(std::abs(magenta.mean_row - red.mean_row) <= 3.0);
    CHECK(magenta.first_row < blue.mean_row - 0.9 * gap);
    CHECK(magenta.last_row > green.mean_row + 0.9 * gap);
    fs::remove_all(dir);
}

TEST_CASE("plot_field_png: the field's colour ramp fills the box, masked points are grey, a curve lies on it") {
    const fs::path dir = fresh_dir("field");
    const Grid grid{0.0, 1.0, 0.0, 1.0, 60, 30};
    std::vector<double> values(grid.size());
    std::vector<std::uint8_t> mask(grid.size(), 0);
    for (std::size_t i = 0; i < grid.ny; ++i)
        for (std::size_t j = 0; j < grid.nx; ++j) {
            values[i * grid.nx + j] = grid.x(j); // a ramp in x: viridis grows brighter from left to right
            if (grid.y(i) > 0.8 && grid.x(j) < 0.2) mask[i * grid.nx + j] = mask_left_bounds; // top-left corner
        }
    FieldPlot plot;
    plot.width_px = 900;
    PlotCurve vertical;
    vertical.xy = {0.5, 0.0, 0.5, 0.6};
    vertical.color = "#ff0000";
    vertical.width = 3;
    plot.curves.push_back(vertical);
    plot_field_png(dir / "ramp.png", grid, values, mask, plot);
    const Image image = read_png(dir / "ramp.png");
    REQUIRE(image.width == 900u);

    // The field is the first run of columns holding colour-mapped pixels; the colour bar is a second one.
    std::vector<std::size_t> per_column(image.width, 0);
    for (std::uint32_t column = 0; column < image.width; ++column)
        for (std::uint32_t row = 0; row < image.height; ++row)
            per_column[column] += colourful(image.at(column, row)) && !is_colour(image.at(column, row), 255, 0, 0);
    const std::size_t tall = image.height / 4;
    std::uint32_t left = 0;
    while (left < image.width && per_column[left] < tall) ++left;
    std::uint32_t right = left;
    while (right + 1 < image.width && per_column[right + 1] >= tall) ++right;
    REQUIRE(left < image.width);
    CHECK(right - left > image.width / 2);
    std::uint32_t bar = right + 1;
    while (bar < image.width && per_column[bar] < tall) ++bar;
    CHECK(bar < image.width); // the colour bar

    const Extent red = extent_of(image, 255, 0, 0, 60);
    REQUIRE(red.count > 50);
    // Along a row through the lower half of the box, the colour brightens steadily from dark to bright (away from
    // the red curve and its anti-aliased edges).
    std::uint32_t top = 0, bottom = image.height - 1;
    const std::uint32_t middle_column = (left + right) / 2 - 10;
    while (top < image.height && !colourful(image.at(middle_column, top))) ++top;
    while (bottom > top && !colourful(image.at(middle_column, bottom))) --bottom;
    const std::uint32_t row = top + 3 * (bottom - top) / 4;
    double previous = -1, drops = 0;
    for (std::uint32_t column = left + 2; column + 2 <= right; ++column) {
        if (column + 4 >= red.first_column && column <= red.last_column + 4) continue;
        const double l = luminance(image.at(column, row));
        if (previous >= 0 && l < previous - 2) ++drops;
        previous = l;
    }
    CHECK(drops == 0);
    CHECK(luminance(image.at(right - 2, row)) - luminance(image.at(left + 2, row)) > 120);

    // The masked top-left corner is light grey; the same corner at the bottom is not.
    const std::uint32_t corner_column = left + (right - left) / 20;
    CHECK(is_colour(image.at(corner_column, top + (bottom - top) / 20), 211, 211, 211, 6));
    CHECK_FALSE(is_colour(image.at(corner_column, bottom - (bottom - top) / 20), 211, 211, 211, 6));

    // The red curve x = 0.5, y from 0 to 0.6, where the box's scale puts those: the cells are centred on the grid
    // points, so the box spans y from -dy/2 to 1 + dy/2, and x symmetrically about 0.5.
    const double half_cell = 0.5 / static_cast<double>(grid.ny - 1);
    const auto row_of = [&](double y) {
        return bottom - (y + half_cell) / (1.0 + 2.0 * half_cell) * static_cast<double>(bottom - top);
    };
    CHECK(std::abs(red.mean_column - 0.5 * (left + right)) <= 3.0);
    CHECK(std::abs(red.last_row - row_of(0.0)) <= 4.0);
    CHECK(std::abs(red.first_row - row_of(0.6)) <= 4.0);
    fs::remove_all(dir);
}

namespace {

// Distance in pixels from (x, y) to the segment a-b (world units; px_x, px_y world units per pixel).
double pixels_to_segment(double x, double y, double ax, double ay, double bx, double by, double px_x, double px_y) {
    const double qx = (x - ax) / px_x, qy = (y - ay) / px_y, dx = (bx - ax) / px_x, dy = (by - ay) / px_y;
    const double len2 = dx * dx + dy * dy;
    const double s = len2 > 0 ? std::clamp((qx * dx + qy * dy) / len2, 0.0, 1.0) : 0.0;
    return std::hypot(qx - s * dx, qy - s * dy);
}

// The thinned polyline (tx, ty) against the original (x, y): it keeps the ends and only original points, in order;
// every dropped point lies within `tolerance` pixels of the chord that replaces it, and every point of a chord within
// `tolerance` of the stretch of the original it replaces (sampled a tenth of a pixel apart).
void check_thinned(const std::vector<double> &x, const std::vector<double> &y, const std::vector<double> &tx,
                   const std::vector<double> &ty, double px_x, double px_y, double tolerance) {
    REQUIRE(tx.size() >= 2);
    REQUIRE(tx.size() == ty.size());
    std::vector<std::size_t> kept;
    for (std::size_t p = 0, t = 0; p < x.size() && t < tx.size(); ++p)
        if (x[p] == tx[t] && y[p] == ty[t]) {
            kept.push_back(p);
            ++t;
        }
    REQUIRE(kept.size() == tx.size());
    CHECK(kept.front() == 0);
    CHECK(kept.back() == x.size() - 1);
    double dropped_worst = 0.0, chord_worst = 0.0;
    for (std::size_t c = 0; c + 1 < kept.size(); ++c) {
        const std::size_t a = kept[c], b = kept[c + 1];
        for (std::size_t p = a + 1; p < b; ++p)
            dropped_worst = std::max(dropped_worst, pixels_to_segment(x[p], y[p], x[a], y[a], x[b], y[b], px_x, px_y));
        const double chord_px = std::hypot((x[b] - x[a]) / px_x, (y[b] - y[a]) / px_y);
        const int samples = 1 + static_cast<int>(chord_px / 0.1);
        for (int k = 0; k <= samples; ++k) {
            const double s = static_cast<double>(k) / samples;
            const double cx = x[a] + s * (x[b] - x[a]), cy = y[a] + s * (y[b] - y[a]);
            double nearest = std::numeric_limits<double>::infinity();
            for (std::size_t p = a; p < b; ++p)
                nearest = std::min(nearest, pixels_to_segment(cx, cy, x[p], y[p], x[p + 1], y[p + 1], px_x, px_y));
            chord_worst = std::max(chord_worst, nearest);
        }
    }
    CHECK(dropped_worst <= tolerance);
    CHECK(chord_worst <= tolerance + 1e-9);
}

} // namespace

TEST_CASE("decimate_polyline: a dense curve thinned within the tolerance both ways; a straight line to its ends; a "
          "zigzag of a pixel kept whole") {
    using plot_internal::decimate_polyline;
    const double tolerance = plot_internal::decimation_tolerance_px;
    // A spiral of 6 turns with a small wiggle, 40001 points, on a picture of 800 x 500 pixels over [-3, 3] x [-1, 1]
    // (a pixel is 3 times wider in x than in y, in world units): thinned within a quarter of a pixel, the smooth
    // stretches need a chord per several pixels, so far fewer points remain.
    const double px_x = 6.0 / 800, px_y = 2.0 / 500;
    std::vector<double> x, y;
    for (int k = 0; k <= 40000; ++k) {
        const double s = k / 40000.0, r = 0.1 + 0.85 * s, angle = 12.0 * M_PI * s;
        x.push_back(3.0 * r * std::cos(angle));
        y.push_back(r * std::sin(angle) + 0.003 * std::sin(400.0 * M_PI * s));
    }
    std::vector<double> tx = x, ty = y;
    decimate_polyline(tx, ty, px_x, px_y, tolerance);
    CHECK(tx.size() < x.size() / 10);
    check_thinned(x, y, tx, ty, px_x, px_y, tolerance);

    // Collinear points: only the ends are needed.
    std::vector<double> lx, ly;
    for (int k = 0; k < 1000; ++k) {
        lx.push_back(-1.0 + 0.002 * k);
        ly.push_back(2.0 * lx.back() + 1.0);
    }
    decimate_polyline(lx, ly, px_x, px_y, tolerance);
    REQUIRE(lx.size() == 2);
    CHECK(lx[0] == -1.0);
    CHECK(ly[1] == 2.0 * (-1.0 + 0.002 * 999) + 1.0);

    // A zigzag one pixel high with a pixel between its points: every chord across more than two points misses one
    // of them by more than half a pixel, so all 50 points stay.
    std::vector<double> zx, zy;
    for (int k = 0; k < 50; ++k) {
        zx.push_back(k * px_x);
        zy.push_back((k % 2) * px_y);
    }
    const std::vector<double> zx0 = zx, zy0 = zy;
    decimate_polyline(zx, zy, px_x, px_y, tolerance);
    CHECK(zx == zx0);
    CHECK(zy == zy0);
}
