// Tests of the output writers: atomic file replacement, the fields.nc layout (read back with the netCDF C API),
// and the PNG field picture's format and size.
#include <geobarrier/errors.hpp>
#include <geobarrier/output.hpp>

#include <doctest/doctest.h>
#include <netcdf.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

namespace fs = std::filesystem;
using geobarrier::FieldPlot;
using geobarrier::FieldVariable;
using geobarrier::Grid;
using geobarrier::PlotCurve;

namespace {

// A fresh folder per test case, removed afterwards.
class ScratchDir {
  public:
    explicit ScratchDir(const std::string &name)
        : m_path(fs::temp_directory_path() / ("geobarrier-test-output-" + std::to_string(::getpid()) + "-" + name)) {
        fs::remove_all(m_path);
        fs::create_directories(m_path);
    }
    ~ScratchDir() {
        std::error_code ignored;
        fs::remove_all(m_path, ignored);
    }
    const fs::path &path() const { return m_path; }
    std::vector<std::string> entries() const {
        std::vector<std::string> names;
        for (const auto &entry : fs::directory_iterator(m_path)) names.push_back(entry.path().filename().string());
        return names;
    }

  private:
    fs::path m_path;
};

std::string read_all(const fs::path &path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void nc_ok(int status) {
    if (status != NC_NOERR) FAIL(nc_strerror(status));
}

std::string text_attribute(int ncid, int varid, const char *name) {
    std::size_t length = 0;
    nc_ok(nc_inq_attlen(ncid, varid, name, &length));
    std::string text(length, '\0');
    nc_ok(nc_get_att_text(ncid, varid, name, text.data()));
    return text;
}

} // namespace

TEST_CASE("write_file_atomically: the target appears only when complete") {
    ScratchDir dir("complete");
    const fs::path target = dir.path() / "result.txt";
    const std::string text(100000, 'a');
    geobarrier::write_file_atomically(target, [&](const fs::path &temp) {
        CHECK(temp.parent_path() == target.parent_path());
        CHECK(temp.filename().string().rfind(".result.txt.tmp-", 0) == 0);
        std::ofstream out(temp, std::ios::binary);
        out << text.substr(0, 50000);
        out.flush();
        CHECK_FALSE(fs::exists(target)); // half-written: nothing under the target's name yet
        out << text.substr(50000);
    });
    CHECK(read_all(target) == text);
    CHECK(dir.entries() == std::vector<std::string>{"result.txt"});

    // Replacing: while the new content is being written, the old one is still whole under the target's name.
    geobarrier::write_file_atomically(target, [&](const fs::path &temp) {
        std::ofstream out(temp, std::ios::binary);
        out << "new";
        CHECK(read_all(target) == text);
    });
    CHECK(read_all(target) == "new");

    geobarrier::write_text_file(target, "line 1\nline 2\n");
    CHECK(read_all(target) == "line 1\nline 2\n");
    CHECK(dir.entries() == std::vector<std::string>{"result.txt"});
}

TEST_CASE("write_file_atomically: a failing writer leaves the target untouched and no temporary file") {
    ScratchDir dir("failing");
    const fs::path target = dir.path() / "fields.nc";
    geobarrier::write_text_file(target, "old content");
    CHECK_THROWS_WITH_AS(geobarrier::write_file_atomically(target,
                                                           [](const fs::path &temp) {
                                                               std::ofstream(temp) << "partial";
                                                               throw std::runtime_error("writer failed");
                                                           }),
                         "writer failed", std::runtime_error);
    CHECK(read_all(target) == "old content");
    CHECK(dir.entries() == std::vector<std::string>{"fields.nc"});

    // A writer that creates no file is an IoError naming the target; nothing is left behind either.
    CHECK_THROWS_AS(geobarrier::write_file_atomically(target, [](const fs::path &) {}), geobarrier::IoError);
    CHECK(read_all(target) == "old content");
    CHECK(dir.entries() == std::vector<std::string>{"fields.nc"});

    // A missing folder is reported, not created.
    CHECK_THROWS_AS(geobarrier::write_text_file(dir.path() / "missing" / "a.txt", "x"), geobarrier::IoError);
    CHECK_FALSE(fs::exists(dir.path() / "missing"));
}

TEST_CASE("write_fields_netcdf: round trip of a 4 x 3 grid with two variables and a mask") {
    ScratchDir dir("netcdf");
    const fs::path file = dir.path() / "fields.nc";
    const Grid grid{-1.5, 1.5, 0.0, 2.0, 4, 3}; // x range, y range, nx, ny
    const double nan = std::numeric_limits<double>::quiet_NaN();
    // Row-major, row = y. a has a NaN at an unmasked point (k = 3): it must become _FillValue too.
    const std::vector<double> a{0.5, 1.0, 1.5, nan, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5, 6.0};
    std::vector<double> b(grid.size());
    for (std::size_t k = 0; k < b.size(); ++k) b[k] = -0.1 * static_cast<double>(k) + 1e-17;
    const std::vector<std::uint8_t> mask{0,
                                         geobarrier::mask_left_bounds,
                                         0,
                                         0,
                                         geobarrier::mask_degenerate,
                                         0,
                                         geobarrier::mask_non_finite,
                                         0,
                                         0,
                                         geobarrier::mask_step_limit | geobarrier::mask_invalid_state,
                                         0,
                                         0};
    std::vector<FieldVariable> variables(2);
    variables[0] = {"lambda2", "largest eigenvalue of the Cauchy-Green tensor", "1", &a,
                    geobarrier::mask_trajectory_bits};
    variables[1] = {"ftle", "finite-time Lyapunov exponent", "1/s", &b,
                    geobarrier::mask_trajectory_bits | geobarrier::mask_degenerate};
    const nlohmann::json globals{{"title", "test fields"},
                                 {"t0", 0.25},
                                 {"n_steps", 40},
                                 {"converged", true},
                                 {"forcing", {{"name", "cosine"}}}};
    geobarrier::write_fields_netcdf(file, grid, variables, mask, globals);
    CHECK(dir.entries() == std::vector<std::string>{"fields.nc"});

    int ncid = -1;
    nc_ok(nc_open(file.c_str(), NC_NOWRITE, &ncid));
    int format = 0;
    nc_ok(nc_inq_format(ncid, &format));
    CHECK(format == NC_FORMAT_NETCDF4);

    int dim_y = -1, dim_x = -1;
    std::size_t ny = 0, nx = 0;
    nc_ok(nc_inq_dimid(ncid, "y", &dim_y));
    nc_ok(nc_inq_dimid(ncid, "x", &dim_x));
    nc_ok(nc_inq_dimlen(ncid, dim_y, &ny));
    nc_ok(nc_inq_dimlen(ncid, dim_x, &nx));
    CHECK(ny == 3);
    CHECK(nx == 4);

    // Coordinates: computed by the same Grid formulas, so equal to the last bit.
    int var_x = -1, var_y = -1;
    nc_ok(nc_inq_varid(ncid, "x", &var_x));
    nc_ok(nc_inq_varid(ncid, "y", &var_y));
    std::array<double, 4> xs{};
    std::array<double, 3> ys{};
    nc_ok(nc_get_var_double(ncid, var_x, xs.data()));
    nc_ok(nc_get_var_double(ncid, var_y, ys.data()));
    CHECK(xs == std::array<double, 4>{-1.5, -0.5, 0.5, 1.5});
    CHECK(ys == std::array<double, 3>{0.0, 1.0, 2.0});
    CHECK(text_attribute(ncid, var_x, "axis") == "X");
    CHECK(text_attribute(ncid, var_y, "axis") == "Y");
    CHECK(text_attribute(ncid, var_x, "units") == "1");

    // Data: shape (y, x); a value is stored bit-exactly unless masked or non-finite, then it is _FillValue.
    const double fill = 9.969209968386869e36;
    for (std::size_t v = 0; v < variables.size(); ++v) {
        CAPTURE(variables[v].name);
        int id = -1;
        nc_ok(nc_inq_varid(ncid, variables[v].name.c_str(), &id));
        int ndims = 0;
        std::array<int, NC_MAX_VAR_DIMS> dims{};
        nc_type type = NC_NAT;
        nc_ok(nc_inq_var(ncid, id, nullptr, &type, &ndims, dims.data(), nullptr));
        CHECK(type == NC_DOUBLE);
        REQUIRE(ndims == 2);
        CHECK(dims[0] == dim_y);
        CHECK(dims[1] == dim_x);
        int no_fill = 1;
        double fill_value = 0.0;
        nc_ok(nc_inq_var_fill(ncid, id, &no_fill, &fill_value));
        CHECK(no_fill == 0);
        CHECK(fill_value == fill);
        int shuffle = 0, deflate = 0, level = 0;
        nc_ok(nc_inq_var_deflate(ncid, id, &shuffle, &deflate, &level));
        // Double fields are stored uncompressed (deflate cost 17% of a default run for 20% of the size).
        CHECK(deflate == 0);
        CHECK(text_attribute(ncid, id, "long_name") == variables[v].long_name);
        CHECK(text_attribute(ncid, id, "units") == variables[v].units);

        std::vector<double> data(grid.size());
        nc_ok(nc_get_var_double(ncid, id, data.data()));
        const std::vector<double> &expected = *variables[v].values;
        for (std::size_t k = 0; k < data.size(); ++k) {
            CAPTURE(k);
            const bool masked = (mask[k] & variables[v].masked_by) != 0 || !std::isfinite(expected[k]);
            CHECK(data[k] == (masked ? fill : expected[k]));
        }
    }
    // lambda2 ignores mask_degenerate (k = 4 keeps its value), ftle does not.
    std::vector<double> ftle(grid.size());
    int var_ftle = -1;
    nc_ok(nc_inq_varid(ncid, "ftle", &var_ftle));
    nc_ok(nc_get_var_double(ncid, var_ftle, ftle.data()));
    CHECK(ftle[4] == fill);

    int var_mask = -1;
    nc_ok(nc_inq_varid(ncid, "mask", &var_mask));
    {
        // The mask is mostly zeros: deflate squeezes it at little cost.
        int shuffle = 0, deflate = 0, level = 0;
        nc_ok(nc_inq_var_deflate(ncid, var_mask, &shuffle, &deflate, &level));
        CHECK(deflate == 1);
        CHECK(level == 1);
    }
    nc_type mask_type = NC_NAT;
    nc_ok(nc_inq_vartype(ncid, var_mask, &mask_type));
    CHECK(mask_type == NC_UBYTE);
    std::vector<std::uint8_t> mask_back(grid.size());
    nc_ok(nc_get_var_uchar(ncid, var_mask, mask_back.data()));
    CHECK(mask_back == mask);
    std::size_t n_flags = 0;
    nc_ok(nc_inq_attlen(ncid, var_mask, "flag_masks", &n_flags));
    REQUIRE(n_flags == 6);
    std::array<unsigned char, 6> flags{};
    nc_ok(nc_get_att_uchar(ncid, var_mask, "flag_masks", flags.data()));
    CHECK(flags == std::array<unsigned char, 6>{1, 2, 4, 8, 16, 32});
    CHECK(text_attribute(ncid, var_mask, "flag_meanings") ==
          "left_bounds non_finite step_limit invalid_state degenerate_eigenvectors unstable_step");

    // Global attributes: strings as text, numbers as double, bools as int, the rest as JSON text.
    CHECK(text_attribute(ncid, NC_GLOBAL, "title") == "test fields");
    double t0 = 0.0, n_steps = 0.0;
    nc_ok(nc_get_att_double(ncid, NC_GLOBAL, "t0", &t0));
    nc_ok(nc_get_att_double(ncid, NC_GLOBAL, "n_steps", &n_steps));
    CHECK(t0 == 0.25);
    CHECK(n_steps == 40.0);
    nc_type converged_type = NC_NAT;
    nc_ok(nc_inq_atttype(ncid, NC_GLOBAL, "converged", &converged_type));
    CHECK(converged_type == NC_INT);
    int converged = 0;
    nc_ok(nc_get_att_int(ncid, NC_GLOBAL, "converged", &converged));
    CHECK(converged == 1);
    CHECK(text_attribute(ncid, NC_GLOBAL, "forcing") == R"({"name":"cosine"})");
    nc_ok(nc_close(ncid));
}

TEST_CASE("cf_units: UDUNITS-2 strings pass; the model's own scales become \"1\" with their meaning") {
    using geobarrier::cf_units;
    for (const char *unit : {"rad", "1/s", "m s-1", "rad/s", "K"}) {
        CAPTURE(unit);
        CHECK(cf_units(unit).units == unit);
        CHECK(cf_units(unit).meaning.empty());
    }
    for (const char *unit : {"", "1", "–"}) {
        CHECK(cf_units(unit).units == "1");
        CHECK(cf_units(unit).meaning.empty());
    }
    for (const char *unit : {"1/time", "state", "rad/time", "1/state", "length", "length^2/time"}) {
        CAPTURE(unit);
        CHECK(cf_units(unit).units == "1");
        CHECK(cf_units(unit).meaning == std::string(unit) + " in the model's own units");
    }
    CHECK(cf_units("times").units == "times"); // a whole word only, not a prefix
}

TEST_CASE("write_fields_netcdf: coordinate units from the system's state units, model units explained") {
    ScratchDir dir("netcdf-units");
    const fs::path file = dir.path() / "fields.nc";
    const Grid grid{-3.0, 3.0, -2.0, 2.0, 3, 2};
    const std::vector<double> ftle(grid.size(), 0.5);
    const std::vector<std::uint8_t> mask(grid.size(), 0);
    geobarrier::write_fields_netcdf(file, grid, {{"ftle", "finite-time Lyapunov exponent", "1/time", &ftle}}, mask,
                                    nlohmann::json::object(), {{"theta", "omega"}, {"rad", "rad/time"}});
    int ncid = -1;
    nc_ok(nc_open(file.c_str(), NC_NOWRITE, &ncid));
    int var_x = -1, var_y = -1, var_ftle = -1;
    nc_ok(nc_inq_varid(ncid, "x", &var_x));
    nc_ok(nc_inq_varid(ncid, "y", &var_y));
    nc_ok(nc_inq_varid(ncid, "ftle", &var_ftle));
    CHECK(text_attribute(ncid, var_x, "units") == "rad");
    CHECK(text_attribute(ncid, var_x, "long_name") == "theta of the initial condition");
    CHECK(text_attribute(ncid, var_y, "units") == "1");
    CHECK(text_attribute(ncid, var_y, "long_name") ==
          "omega of the initial condition [rad/time in the model's own units]");
    CHECK(text_attribute(ncid, var_ftle, "units") == "1");
    CHECK(text_attribute(ncid, var_ftle, "long_name") ==
          "finite-time Lyapunov exponent [1/time in the model's own units]");
    nc_ok(nc_close(ncid));
}

TEST_CASE("write_fields_netcdf: bad arguments are refused before anything is written") {
    ScratchDir dir("netcdf-bad");
    Grid grid;
    grid.nx = 4;
    grid.ny = 3;
    const std::vector<double> short_values(5, 1.0);
    const std::vector<std::uint8_t> mask(grid.size(), 0);
    CHECK_THROWS_AS(geobarrier::write_fields_netcdf(dir.path() / "f.nc", grid, {{"a", "a", "1", &short_values}}, mask,
                                                    nlohmann::json::object()),
                    geobarrier::Error);
    const std::vector<double> values(grid.size(), 1.0);
    CHECK_THROWS_AS(geobarrier::write_fields_netcdf(dir.path() / "f.nc", grid, {{"mask", "m", "1", &values}}, mask,
                                                    nlohmann::json::object()),
                    geobarrier::Error);
    CHECK(dir.entries().empty());
}

TEST_CASE("plot_field_png: a PNG of the requested width") {
    ScratchDir dir("png");
    const fs::path file = dir.path() / "lambda2.png";
    const Grid grid{-2.0, 2.0, -1.0, 1.0, 41, 21}; // x range, y range, nx, ny
    std::vector<double> values(grid.size());
    std::vector<std::uint8_t> mask(grid.size(), 0);
    for (std::size_t i = 0; i < grid.ny; ++i)
        for (std::size_t j = 0; j < grid.nx; ++j)
            values[i * grid.nx + j] = std::sin(grid.x(j)) * std::cos(2.0 * grid.y(i));
    mask[0] = geobarrier::mask_left_bounds;
    values[5] = std::numeric_limits<double>::infinity(); // must not break the colour range
    FieldPlot plot;
    plot.title = "test field";
    plot.colorbar_label = "value";
    plot.width_px = 640;
    PlotCurve circle;
    for (int p = 0; p < 32; ++p)
        circle.xy.insert(circle.xy.end(), {0.5 * std::cos(p * M_PI / 16), 0.5 * std::sin(p * M_PI / 16)});
    circle.closed = true;
    circle.color = "#ffffff";
    plot.curves.push_back(circle);
    geobarrier::plot_field_png(file, grid, values, mask, plot);

    const std::string png = read_all(file);
    REQUIRE(png.size() > 24);
    CHECK(png.substr(0, 8) == std::string("\x89PNG\r\n\x1a\n", 8));
    CHECK(png.substr(12, 4) == "IHDR");
    auto be32 = [&](std::size_t at) {
        std::uint32_t v = 0;
        for (std::size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(png[at + i]);
        return v;
    };
    CHECK(be32(16) == 640u);
    CHECK(be32(20) > 0u);
    CHECK(dir.entries() == std::vector<std::string>{"lambda2.png"});

    // An unknown colour is refused before PLplot starts, and nothing is written.
    plot.curves[0].color = "chartreuse-ish";
    CHECK_THROWS_AS(geobarrier::plot_field_png(dir.path() / "other.png", grid, values, mask, plot), geobarrier::Error);
    CHECK(dir.entries() == std::vector<std::string>{"lambda2.png"});
}

TEST_CASE("plot_field_png: concurrent calls are serialised and each picture is whole") {
    ScratchDir dir("png-threads");
    Grid grid;
    grid.nx = 8;
    grid.ny = 8;
    std::vector<double> values(grid.size());
    for (std::size_t k = 0; k < values.size(); ++k) values[k] = static_cast<double>(k);
    const std::vector<std::uint8_t> mask(grid.size(), 0);
    FieldPlot plot;
    plot.width_px = 300;
    std::vector<std::thread> threads;
    std::vector<int> failures(4, 0);
    for (int t = 0; t < 4; ++t)
        threads.emplace_back([&, t] {
            try {
                geobarrier::plot_field_png(dir.path() / ("p" + std::to_string(t) + ".png"), grid, values, mask, plot);
            } catch (...) {
                failures[t] = 1;
            }
        });
    for (std::thread &thread : threads) thread.join();
    CHECK(failures == std::vector<int>(4, 0));
    for (int t = 0; t < 4; ++t) {
        const std::string png = read_all(dir.path() / ("p" + std::to_string(t) + ".png"));
        REQUIRE(png.size() > 24);
        CHECK(png.substr(0, 8) == std::string("\x89PNG\r\n\x1a\n", 8));
    }
    CHECK(dir.entries().size() == 4);
}
