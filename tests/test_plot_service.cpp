// The picture service extractors reach through the C ABI (GB_EXTENSION_PLOT, ABI 1.4): what it draws from the plain C
// structs is byte for byte what plot_field_png and plot_xy_png draw from the C++ ones (the SDK's draw_field_png and
// draw_xy_png convert one into the other); a bad struct is refused with a message naming the field; and an extractor
// loaded by a core without the service draws nothing and says so in one log line.
#include "plot/plot_service.hpp"

#include <geobarrier/output.hpp>
#include <geobarrier/sdk_plot.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <unistd.h>

namespace fs = std::filesystem;
using namespace geobarrier;

namespace {

fs::path fresh_dir() {
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-plot-service-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

std::string bytes(const fs::path &file) {
    std::ifstream in(file, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// A gb_host whose log lines the test reads.
struct LogHost {
    std::vector<std::string> lines;
    gb_host host{};
    LogHost() {
        host.context = this;
        host.log = [](void *context, std::int32_t, const char *line) {
            static_cast<LogHost *>(context)->lines.emplace_back(line);
        };
    }
};

// The host info of a core of this ABI whose extensions are the real picture service, or of a 1.3 core (none).
const void *with_service(const char *id) {
    return std::string(id) == GB_EXTENSION_PLOT ? static_cast<const void *>(plot_service()) : nullptr;
}
const void *without_extensions(const char *) { return nullptr; }

struct LoadedBy { // sets sdk::detail::loaded_by for one test, as the plugin entry does, and restores it
    gb_host_info info;
    explicit LoadedBy(std::uint32_t minor, const void *(*extension)(const char *))
        : info{sizeof(gb_host_info), GB_ABI_VERSION_MAJOR, minor, GB_ADVANCE_TABLEAU_REVISION, "test", extension} {
        sdk::detail::loaded_by = &info;
    }
    ~LoadedBy() { sdk::detail::loaded_by = nullptr; }
};

Grid small_grid() {
    Grid g;
    g.x_min = -1.0;
    g.x_max = 2.0;
    g.y_min = 0.0;
    g.y_max = 1.5;
    g.nx = 31;
    g.ny = 16;
    return g;
}

} // namespace

TEST_CASE("the picture service draws the same bytes as plot_field_png and plot_xy_png") {
    const fs::path dir = fresh_dir();
    const Grid g = small_grid();
    std::vector<double> values(g.size());
    std::vector<std::uint8_t> mask(g.size(), 0);
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) values[i * g.nx + j] = std::sin(g.x(j)) * std::cos(2.0 * g.y(i));
    mask[5] = mask_left_bounds;
    FieldPlot field;
    field.title = "a field";
    field.x_label = "p [m]";
    field.colorbar_label = "FTLE";
    field.width_px = 400;
    field.curves.push_back({{-0.5, 0.2, 1.5, 1.2, 0.5, 1.4}, "white", 2.0, true});
    field.curves.push_back({{0.0, 0.5, 1.0, 0.5}, "#ff8000", 1.0, false, true, 6.0});

    XYPlot xy;
    xy.title = "series";
    xy.width_px = 400;
    xy.log_y = true;
    xy.legend = XYPlot::Legend::bottom_left;
    xy.x_range = std::make_pair(0.0, 4.0);
    PlotSeries a;
    a.xy = {0.0, 1.0, 1.0, 10.0, 2.0, 100.0};
    a.label = "a";
    a.color = "red";
    a.style = PlotSeries::Style::line_points;
    a.dash = PlotSeries::Dash::dashed;
    PlotSeries b;
    b.xy = {1.0, 5.0, 3.0, 50.0};
    b.label = "b";
    b.style = PlotSeries::Style::points;
    b.marker_px = 8.0;
    xy.series = {a, b};

    plot_field_png(dir / "direct-field.png", g, values, mask, field);
    plot_xy_png(dir / "direct-xy.png", xy);
    LogHost log;
    const sdk::Host host(&log.host);
    {
        const LoadedBy core(GB_ABI_VERSION_MINOR, &with_service);
        REQUIRE(sdk::plot_service() == plot_service());
        CHECK(sdk::draw_field_png(host, dir / "service-field.png", g, values, mask, field));
        CHECK(sdk::draw_xy_png(host, dir / "service-xy.png", xy));
    }
    CHECK(log.lines.empty());
    const std::string direct_field = bytes(dir / "direct-field.png");
    REQUIRE(direct_field.size() > 1000);
    CHECK(bytes(dir / "service-field.png") == direct_field);
    const std::string direct_xy = bytes(dir / "direct-xy.png");
    REQUIRE(direct_xy.size() > 1000);
    CHECK(bytes(dir / "service-xy.png") == direct_xy);
    fs::remove_all(dir);
}

TEST_CASE("the picture service refuses a bad struct with a message naming the field") {
    const gb_plot_service *service = plot_service();
    REQUIRE(service->struct_size == sizeof(gb_plot_service));
    const fs::path dir = fresh_dir();
    const std::string file = (dir / "bad.png").string();
    char text[256] = "";
    gb_message msg{text, sizeof text};

    gb_plot_field field{};
    field.struct_size = sizeof field;
    field.x_max = field.y_max = 1.0;
    field.nx = field.ny = 2;
    CHECK(service->field_png(file.c_str(), &field, &msg) == GB_ERROR);
    CHECK(std::string(text) == "gb_plot_field.values is NULL");

    const double values[4] = {0.0, 1.0, 2.0, 3.0};
    field.values = values;
    field.curve_count = 2;
    CHECK(service->field_png(file.c_str(), &field, &msg) == GB_ERROR);
    CHECK(std::string(text) == "gb_plot_field: curve_count 2 but curves is NULL");

    field.struct_size = 8;
    CHECK(service->field_png(file.c_str(), &field, &msg) == GB_ERROR);
    CHECK(std::string(text).find("gb_plot_field.struct_size 8 is smaller than this core's") == 0);

    gb_plot_series series{};
    const double points[4] = {0.0, 0.0, 1.0, 1.0};
    series.xy = points;
    series.count = 2;
    series.style = 7;
    gb_plot_xy xy{};
    xy.struct_size = sizeof xy;
    xy.series_count = 1;
    xy.series = &series;
    xy.aspect = 0.6;
    xy.width_px = 400;
    CHECK(service->xy_png(file.c_str(), &xy, &msg) == GB_ERROR);
    CHECK(std::string(text) == "gb_plot_xy.series[0].style: 7 is not a gb_plot_style");
    series.style = GB_PLOT_LINE;
    xy.legend = 9;
    CHECK(service->xy_png(file.c_str(), &xy, &msg) == GB_ERROR);
    CHECK(std::string(text) == "gb_plot_xy.legend: 9 is not a gb_plot_legend");
    CHECK_FALSE(fs::exists(file)); // nothing written
    fs::remove_all(dir);
}

TEST_CASE("an extractor on a core without the picture service draws nothing and says so") {
    const fs::path dir = fresh_dir();
    const Grid g = small_grid();
    const std::vector<double> values(g.size(), 1.0);
    LogHost log;
    const sdk::Host host(&log.host);
    for (std::uint32_t minor : {3u, GB_ABI_VERSION_MINOR}) { // a 1.3 core; a core whose extensions lack it
        CAPTURE(minor);
        const LoadedBy core(minor, &without_extensions);
        CHECK(sdk::plot_service() == nullptr);
        CHECK_FALSE(sdk::draw_field_png(host, dir / "field.png", g, values, {}, FieldPlot{}));
        CHECK_FALSE(sdk::draw_xy_png(host, dir / "xy.png", XYPlot{}));
    }
    CHECK_FALSE(sdk::draw_field_png(host, dir / "field.png", g, values, {}, FieldPlot{})); // a core before 1.3
    CHECK(fs::is_empty(dir));
    REQUIRE(log.lines.size() == 5);
    CHECK(log.lines[0] == "no picture field.png: the geobarrier core that loaded this extractor draws no pictures for "
                          "plugins (plugin ABI 1.4)");
    CHECK(log.lines[1].find("no picture xy.png") == 0);
    fs::remove_all(dir);
}
