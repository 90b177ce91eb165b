// Tests of the data forcing: the natural cubic spline (a hand-solved case, exact knots and lines, fourth-order
// convergence), the CSV dialects it reads, every input error naming its line, the time range, and the shared
// conformance checks.
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <geobarrier/errors.hpp>
#include <test_support.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

using namespace geobarrier;
namespace fs = std::filesystem;

namespace {
constexpr double pi = 3.141592653589793;

const PluginHandle &data() { return test::registry().find(PluginKind::forcing, "data", "/forcing/plugin"); }

// A CSV file in a fresh folder under the system's temporary folder.
fs::path write_csv(const std::string &name, const std::string &text) {
    static const fs::path dir = [] {
        const fs::path d = fs::temp_directory_path() / ("geobarrier-test-data-" + std::to_string(::getpid()));
        fs::create_directories(d);
        return d;
    }();
    const fs::path file = dir / name;
    std::ofstream(file) << text;
    return file;
}

Forcing make_data(const fs::path &file, nlohmann::json params = nlohmann::json::object()) {
    params["file"] = file.string();
    return test::make_forcing("data", params);
}

std::string creation_error(const std::string &name, const std::string &text,
                           nlohmann::json params = nlohmann::json::object()) {
    const fs::path file = write_csv(name, text);
    try {
        make_data(file, params);
    } catch (const PluginError &e) {
        return e.what();
    }
    return "(no error)";
}
} // namespace

TEST_CASE("data: the natural cubic spline") {
    SUBCASE("three points (0, 0), (1, 1), (2, 0): M1 = -3, S = 1.5 t - 0.5 t^3 on [0, 1]") {
        const Forcing f = make_data(write_csv("tent.csv", "t,f\n0,0\n1,1\n2,0\n"));
        CHECK(f(0.5) == doctest::Approx(0.6875).epsilon(1e-15));
        CHECK(f(1.5) == doctest::Approx(0.6875).epsilon(1e-15));
        CHECK(f(0.25) == doctest::Approx(1.5 * 0.25 - 0.5 * 0.25 * 0.25 * 0.25).epsilon(1e-15));
        CHECK(f(0.0) == 0.0);
        CHECK(f(1.0) == 1.0);
        CHECK(f(2.0) == 0.0);
    }
    SUBCASE("through every sample, and exact on straight lines (all M = 0)") {
        std::string text = "# a line, unevenly sampled\n";
        const std::vector<double> t = {-1.0, -0.2, 0.5, 0.6, 2.0, 3.5};
        for (double ti : t) text += std::to_string(ti) + "," + std::to_string(0.25 * ti - 1.0) + "\n";
        const Forcing f = make_data(write_csv("line.csv", text), {{"gap_factor", 0}});
        for (double ti : t) CHECK(f(ti) == doctest::Approx(0.25 * ti - 1.0).epsilon(1e-14));
        for (double ti = -1.0; ti <= 3.5; ti += 0.01) CHECK(std::fabs(f(ti) - (0.25 * ti - 1.0)) <= 1e-14);
    }
    SUBCASE("fourth order on sin t over [0, 2 pi] (sin'' = 0 at both ends, as the natural spline assumes)") {
        double previous = 0.0;
        for (int n : {20, 40, 80}) {
            std::string text;
            char line[64];
            for (int i = 0; i <= n; ++i) {
                const double ti = 2 * pi * i / n;
                std::snprintf(line, sizeof line, "%.17g,%.17g\n", ti, std::sin(ti));
                text += line;
            }
            const Forcing f = make_data(write_csv("sin" + std::to_string(n) + ".csv", text));
            double worst = 0.0;
            for (double t = 0.0; t <= 2 * pi; t += 0.001) worst = std::max(worst, std::fabs(f(t) - std::sin(t)));
            const double h = 2 * pi / n;
            CAPTURE(n);
            CHECK(worst <= h * h * h * h); // the spline error is C h^4 max|f''''| with C well below 1
            if (previous > 0.0) CHECK(previous / worst == doctest::Approx(16.0).epsilon(0.15)); // halving h: / 16
            previous = worst;
        }
    }
    SUBCASE("scale, other columns, semicolons and blanks") {
        const Forcing a = make_data(write_csv("semi.csv", "time;x;force\n0;9;1\n1;9;2\n2;9;3\n"),
                                    {{"value_column", 2}, {"scale", -2.0}});
        CHECK(a(1.0) == -4.0);
        const Forcing b = make_data(write_csv("blank.txt", "  0   5\n 1 6 \n\n2\t7\n"));
        CHECK(b(1.0) == 6.0);
        const Forcing c = make_data(write_csv("crlf.csv", "t,f\r\n0,1\r\n1,3\r\n"));
        CHECK(c(0.5) == 2.0);
    }
}

TEST_CASE("data: bad input is an error naming the file and the line") {
    CHECK(creation_error("unsorted.csv", "t,f\n0,0\n1,1\n0.5,2\n3,0\n")
              .find("unsorted.csv:4: time 0.5 comes before 1 (line 3)") != std::string::npos);
    CHECK(creation_error("repeat.csv", "0,0\n# note\n1,1\n1,2\n").find("repeat.csv:4: time 1 repeats line 3") !=
          std::string::npos);
    // A missing sample: spacing 2 against a median of 1.
    const std::string gap = creation_error("gap.csv", "0,0\n1,1\n2,0\n4,1\n5,0\n6,1\n");
    CHECK(gap.find("gap.csv:4: gap in the data: time jumps from 2 (line 3) to 4") != std::string::npos);
    CHECK(gap.find("gap_factor") != std::string::npos);
    // ... which gap_factor 0 accepts.
    CHECK(creation_error("gap-ok.csv", "0,0\n1,1\n2,0\n4,1\n5,0\n6,1\n", {{"gap_factor", 0}}) == "(no error)");
    CHECK(creation_error("hole.csv", "0,0\n1,\n2,0\n").find("hole.csv:2: missing or non-numeric value \"\"") !=
          std::string::npos);
    CHECK(creation_error("nan.csv", "0,0\n1,nan\n2,0\n").find("nan.csv:2: missing or non-numeric value \"nan\"") !=
          std::string::npos);
    CHECK(creation_error("short.csv", "0,0\n1\n2,0\n").find("short.csv:2: has 1 field(s)") != std::string::npos);
    CHECK(creation_error("text.csv", "t,f\n0,0\nabc,1\n").find("text.csv:3: time \"abc\" is not a finite number") !=
          std::string::npos);
    CHECK(creation_error("one.csv", "t,f\n0,1\n").find("needs at least 2 samples, found 1") != std::string::npos);
    CHECK(creation_error("missing.csv", "").find("at least 2 samples") != std::string::npos);
    try {
        test::make_forcing("data", {{"file", "/nonexistent/series.csv"}});
        FAIL("no error for a missing file");
    } catch (const PluginError &e) {
        CHECK(std::string(e.what()).find("/nonexistent/series.csv: cannot open the data file") != std::string::npos);
    }
    CHECK_THROWS_WITH_AS(test::make_forcing("data"), doctest::Contains("parameter \"file\" is required"), PluginError);
}

TEST_CASE("data: defined on the series' time range only") {
    const Forcing f = make_data(write_csv("range.csv", "0,0\n1,1\n2,4\n"));
    CHECK_NOTHROW(f(0.0));
    CHECK_NOTHROW(f(2.0));
    CHECK_THROWS_WITH_AS(f(2.5), doctest::Contains("t = 2.5 is outside the data's time range [0, 2]"), PluginError);
    CHECK_THROWS_WITH_AS(f(-0.1), doctest::Contains("outside the data's time range"), PluginError);
}

TEST_CASE("data: passes the conformance checks on its time range") {
    std::string text = "t,f\n";
    for (int i = 0; i <= 400; ++i)
        text += std::to_string(-10.0 + 0.05 * i) + "," + std::to_string(std::cos(0.3 * i)) + "\n";
    ConformanceOptions options;
    options.params = {{"file", write_csv("conformance.csv", text).string()}};
    options.t_min = -10.0;
    options.t_max = 10.0;
    const auto checks = check_plugin(data(), options);
    INFO(format_checks(checks));
    CHECK(all_passed(checks));
}
