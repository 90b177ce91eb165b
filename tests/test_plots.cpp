// x-y and 3-D pictures: PNGs of the requested width whose height follows the box's aspect, point markers over a
// field, log axes, and bad arguments refused before anything is written.
#include <geobarrier/errors.hpp>
#include <geobarrier/output.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <string>

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

PlotSeries circle(double cx, double cy, double rx, double ry, const std::string &label) {
    PlotSeries s;
    s.label = label;
    s.closed = true;
    for (int k = 0; k < 64; ++k)
        s.xy.insert(s.xy.end(), {cx + rx * std::cos(M_PI * k / 32), cy + ry * std::sin(M_PI * k / 32)});
    return s;
}

}  // namespace

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
            tube.xyz.insert(tube.xyz.end(), {std::cos(2 * M_PI * c / 24), 0.5 * std::sin(2 * M_PI * c / 24),
                                             static_cast<double>(r)});
    plot.surfaces.push_back(tube);
    PlotSeries3D helix;
    helix.label = "helix";
    helix.color = "red";
    for (int k = 0; k < 200; ++k) helix.xyz.insert(helix.xyz.end(), {1.5 * std::cos(k * 0.2), std::sin(k * 0.2), k * 0.045});
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
