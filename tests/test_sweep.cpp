// Parameter sweeps: the sweep file's checks (JSON paths in every error), the members it makes, and the program on
// a sweep: a failing member is reported while the others finish, a SIGINT leaves only whole members, and a re-run
// resumes, skipping the members already complete.
#include "sweep/sweep.hpp"
#include <geobarrier/errors.hpp>

#include <doctest/doctest.h>
#include <netcdf.h>
#include <nlohmann/json.hpp>
#include <test_support.hpp>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;
using nlohmann::json;
using namespace geobarrier;
extern char **environ;

namespace {

// A small undamped Duffing experiment; trajectories leaving [-3, 3]^2 are masked.
json small_base(int n, double t1) {
    return json::parse(R"({"system": {"plugin": "duffing"}, "forcing": {"plugin": "cosine"},
        "grid": {"x": [-1, 1], "y": [-1, 1], "n": [)" +
                       std::to_string(n) + "," + std::to_string(n) + R"(]}, "time": {"t0": 0, "t1": )" +
                       std::to_string(t1) + R"(},
        "bounds": {"x": [-3, 3], "y": [-3, 3]}, "products": ["ftle"], "output": {"plots": false}})");
}

std::string config_error(const json &sweep, bool members = false) {
    try {
        const Sweep s = parse_sweep(sweep);
        if (members) check_sweep_members(s);
    } catch (const ConfigError &e) {
        return e.what();
    }
    return "";
}

struct Exit {
    int code = -1;
    std::string out, err;
};

// Starts the program with `args`; `on_started(pid)` runs while it does (may signal it); returns its exit.
Exit run_program(const fs::path &dir, std::vector<std::string> args,
                 const std::function<void(pid_t)> &on_started = {}) {
    const std::string program = test::geobarrier_program().string();
    args.insert(args.begin(), program);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, (dir / "stdout.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, (dir / "stderr.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    std::vector<char *> argv;
    for (auto &a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = -1;
    REQUIRE(posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), environ) == 0);
    posix_spawn_file_actions_destroy(&actions);
    if (on_started) on_started(pid);
    int status = 0;
    REQUIRE(::waitpid(pid, &status, 0) == pid);
    Exit e;
    REQUIRE(WIFEXITED(status));
    e.code = WEXITSTATUS(status);
    e.out = test::read_text(dir / "stdout.txt");
    e.err = test::read_text(dir / "stderr.txt");
    return e;
}

std::vector<std::vector<std::string>> read_csv(const fs::path &file) {
    std::vector<std::vector<std::string>> rows;
    std::ifstream in(file);
    std::string line;
    while (std::getline(in, line)) {
        std::vector<std::string> cells;
        std::stringstream s(line);
        std::string cell;
        while (std::getline(s, cell, ',')) cells.push_back(cell);
        if (!line.empty() && line.back() == ',') cells.emplace_back();
        rows.push_back(cells);
    }
    return rows;
}

// The maximum FTLE over the unmasked points of a fields.nc, read here independently of the sweep's reader.
double max_ftle(const fs::path &file) {
    int ncid = -1, ftle = -1, mask = -1;
    REQUIRE(nc_open(file.c_str(), NC_NOWRITE, &ncid) == NC_NOERR);
    REQUIRE(nc_inq_varid(ncid, "ftle", &ftle) == NC_NOERR);
    REQUIRE(nc_inq_varid(ncid, "mask", &mask) == NC_NOERR);
    std::vector<double> values(21 * 21);
    std::vector<unsigned char> masks(values.size());
    REQUIRE(nc_get_var_double(ncid, ftle, values.data()) == NC_NOERR);
    REQUIRE(nc_get_var_uchar(ncid, mask, masks.data()) == NC_NOERR);
    nc_close(ncid);
    double m = -1e300;
    for (std::size_t k = 0; k < values.size(); ++k)
        if (masks[k] == 0) m = std::max(m, values[k]);
    return m;
}

bool has_partial_files(const fs::path &dir) {
    for (const auto &e : fs::recursive_directory_iterator(dir)) {
        const std::string name = e.path().filename().string();
        if (name.rfind(".geobarrier-partial-", 0) == 0 || name.find(".tmp") != std::string::npos) return true;
    }
    return false;
}

fs::path fresh_dir(const std::string &name) {
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-sweep-" + std::to_string(::getpid()) + "-" + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

} // namespace

TEST_CASE("sweep members: nested loops over the parameters, ranges with both ends, zip pairs the k-th values") {
    json sweep = {{"base", small_base(5, 1.0)},
                  {"parameters",
                   {{{"path", "/forcing/params/amplitude"}, {"range", {{"from", 0.0}, {"to", 0.1}, {"count", 3}}}},
                    {{"path", "/grid/n/0"}, {"values", {5, 7}}}}}};
    Sweep s = parse_sweep(sweep);
    REQUIRE(s.members.size() == 6);
    CHECK(s.parameters[0].name == "amplitude");
    CHECK(s.parameters[1].name == "0");
    CHECK(s.members[0].name == "member-000");
    CHECK(s.members[5].name == "member-005");
    // The first parameter varies slowest; the range's ends are exact.
    CHECK(s.members[1].experiment["forcing"]["params"]["amplitude"] == 0.0);
    CHECK(s.members[1].experiment["grid"]["n"][0] == 7);
    CHECK(s.members[2].experiment["forcing"]["params"]["amplitude"] == 0.05);
    CHECK(s.members[5].experiment["forcing"]["params"]["amplitude"] == 0.1);
    CHECK(s.members[5].experiment["grid"]["n"] == json({7, 5}));
    // Everything else is the base.
    CHECK(s.members[3].experiment["time"] == sweep["base"]["time"]);
    CHECK_NOTHROW(check_sweep_members(s));

    sweep["combine"] = "zip";
    CHECK(config_error(sweep) == "/parameters/1: 2 values, but /parameters/0 has 3; \"combine\": \"zip\" pairs the "
                                 "k-th values");
    sweep["parameters"][1]["values"] = {5, 7, 9};
    s = parse_sweep(sweep);
    REQUIRE(s.members.size() == 3);
    CHECK(s.members[2].experiment["grid"]["n"][0] == 9);
    CHECK(s.members[2].experiment["forcing"]["params"]["amplitude"] == 0.1);

    // A range over an integer of the base gives integers.
    sweep["parameters"][1] = {{"path", "/grid/n/1"}, {"range", {{"from", 5}, {"to", 9}, {"count", 3}}}};
    s = parse_sweep(sweep);
    CHECK(s.members[1].experiment["grid"]["n"][1].is_number_integer());
    CHECK(s.members[1].experiment["grid"]["n"][1] == 7);
}

TEST_CASE("sweep files are checked like experiments: JSON path, value and rule in every error") {
    const json base = small_base(5, 1.0);
    const auto with = [&](json parameters) { return json{{"base", base}, {"parameters", parameters}}; };
    CHECK(config_error(with(json::array())).rfind("/parameters: [] must be a non-empty array", 0) == 0);
    // A key missing from the base is created (a plugin parameter at its default); a misspelt one is an error of the
    // member's experiment, blamed on the pointer.
    CHECK(config_error(with({{{"path", "/forcing/parms/amplitude"}, {"values", {1}}}}), true) ==
          "/parameters/0/path: member-000 (amplitude = 1): /forcing/parms: unknown key; did you mean \"params\"?");
    CHECK(config_error(with({{{"path", "/forcing/params/amplitude"}, {"values", {1}}}}), true).empty());
    CHECK(config_error(with({{{"path", "forcing"}, {"values", {1}}}}))
              .rfind("/parameters/0/path: \"forcing\" is not "
                     "a JSON pointer",
                     0) == 0);
    CHECK(config_error(with({{{"path", "/grid/n/2"}, {"values", {1}}}})) ==
          "/parameters/0/path: \"/grid/n/2\": \"/grid/n\" is an array of 2 elements; \"2\" is not the index of one");
    CHECK(config_error(with({{{"path", "/output/dir"}, {"values", {"a"}}}})).rfind("/parameters/0/path:", 0) == 0);
    CHECK(config_error(with({{{"path", "/time/t1"}}})) ==
          "/parameters/0: missing \"values\" (a list) or \"range\" ({\"from\", \"to\", \"count\"})");
    CHECK(config_error(with({{{"path", "/time/t1"}, {"range", {{"from", 1}, {"to", 2}}}}})) ==
          "/parameters/0/range: missing required key \"count\"");
    CHECK(config_error(with({{{"path", "/time/t1"}, {"values", {1}}, {"valeus", 2}}})) ==
          "/parameters/0/valeus: unknown key; did you mean \"values\"?");
    json sweep = with({{{"path", "/time/t1"}, {"values", {1, 2}}}});
    sweep["figures"] = {"ftle_maxx"};
    CHECK(config_error(sweep).rfind("/figures/0: unknown figure \"ftle_maxx\"; did you mean \"ftle_max\"?", 0) == 0);
    sweep.erase("figures");
    sweep["plot"] = {{"parameter", "t2"}};
    CHECK(config_error(sweep) == "/plot/parameter: \"t2\" is not a swept parameter's path or name; did you mean "
                                 "\"t1\"?");
    sweep.erase("plot");
    sweep["processes"] = 0;
    CHECK(config_error(sweep) == "/processes: 0 must be an integer from 1 to 4096");

    // Each member is checked as an experiment; the error points at the value that made it invalid.
    sweep = with({{{"path", "/time/t1"}, {"values", {1, 2, 0}}}});
    CHECK(config_error(sweep, true) == "/parameters/0/values/2: member-002 (t1 = 0): /time/t1: equals t0; the "
                                       "interval must have nonzero length");
    sweep = with({{{"path", "/forcing/params/omega"}, {"values", {1, "fast"}}}});
    CHECK(config_error(sweep, true)
              .rfind("/parameters/0/values/1: member-001 (omega = fast): /forcing/params/omega:", 0) == 0);
}

TEST_CASE("a sweep of 8 members with one failing: the others finish, the failure is reported, the summary has all") {
    const fs::path dir = fresh_dir("failing");
    // Amplitude 1e6 drives every trajectory out of the bounds at once: that member fails at run time (every grid
    // point masked), the others run normally.
    // (Exits masked: stopped exits would make them data.)
    const std::vector<double> amplitudes = {0.0, 0.02, 0.04, 0.06, 1e6, 0.08, 0.1, 0.12};
    json base = small_base(21, 6.283185307179586);
    REQUIRE(base.contains("bounds"));
    base["bounds"]["exits"] = "mask";
    const json sweep = {{"base", base},
                        {"parameters", {{{"path", "/forcing/params/amplitude"}, {"values", amplitudes}}}},
                        {"figures", {"ftle_max", "masked_fraction"}},
                        {"processes", 2},
                        {"threads", 1},
                        {"output", {{"dir", (dir / "out").string()}}}};
    std::ofstream(dir / "sweep.json") << sweep.dump(1);
    const Exit e = run_program(dir, {"sweep", (dir / "sweep.json").string(), "--quiet"});
    CAPTURE(e.err);
    CHECK(e.code == 1);
    CHECK(e.err.find("1 of 8 members failed: member-004 (exit 1: every one of the 441 grid points was masked") !=
          std::string::npos);
    const fs::path out = dir / "out";
    for (std::size_t k = 0; k < amplitudes.size(); ++k) {
        const fs::path member = out / ("member-00" + std::to_string(k));
        if (k == 4) {
            CHECK_FALSE(fs::exists(member)); // the run created it and removed it again: nothing half-written
            CHECK(test::read_text(out / "logs" / "member-004.log").find("every one of the 441 grid points") !=
                  std::string::npos);
            continue;
        }
        REQUIRE(fs::exists(member / "manifest.json"));
        const json manifest = json::parse(test::read_text(member / "manifest.json"));
        // The member ran with its own amplitude.
        CHECK(manifest["resolved"]["forcing"]["params"]["amplitude"] == amplitudes[k]);
        CHECK(fs::exists(member / "fields.nc"));
    }
    CHECK_FALSE(has_partial_files(out));
    const auto rows = read_csv(out / "summary.csv");
    REQUIRE(rows.size() == 9);
    CHECK(rows[0] == std::vector<std::string>{"member", "amplitude", "status", "ftle_max", "masked_fraction",
                                              "wall_seconds", "message"});
    for (std::size_t k = 0; k < amplitudes.size(); ++k) {
        const auto &row = rows[k + 1];
        REQUIRE(row.size() >= 6);
        CHECK(row[0] == "member-00" + std::to_string(k));
        CHECK(std::stod(row[1]) == amplitudes[k]);
        if (k == 4) {
            CHECK(row[2] == "failed");
            CHECK(row[3].empty());
            continue;
        }
        CHECK(row[2] == "done");
        // The summary's figure is the member's own field's (read here independently), to the 6 digits printed.
        const double expected = max_ftle(out / ("member-00" + std::to_string(k)) / "fields.nc");
        CHECK(std::stod(row[3]) == doctest::Approx(expected).epsilon(1e-5));
        CHECK(row[4] == "0"); // no trajectory leaves [-3, 3]^2 at these amplitudes
    }
    CHECK(fs::exists(out / "summary.md"));
    CHECK(fs::exists(out / "summary.png"));
    fs::remove_all(dir);
}

TEST_CASE("SIGINT stops a sweep leaving only whole members; the re-run resumes and skips them") {
    const fs::path dir = fresh_dir("resume");
    // member-000 is quick; the others integrate 20000 time units (t1 = 200 took only 0.1 s on an idle machine, too
    // short for the signal to find it running), so the signal finds member-001 running however idle the machine is.
    const json sweep = {{"base", small_base(81, 6.0)},
                        {"parameters", {{{"path", "/time/t1"}, {"values", {6.0, 20000.0, 20000.0, 20000.0}}}}},
                        {"figures", {"ftle_max"}},
                        {"processes", 1},
                        {"threads", 2},
                        {"output", {{"dir", (dir / "out").string()}}}};
    std::ofstream(dir / "sweep.json") << sweep.dump(1);
    const fs::path out = dir / "out", first = out / "member-000" / "manifest.json";
    const Exit stopped = run_program(dir, {"sweep", (dir / "sweep.json").string()}, [&](pid_t pid) {
        int status = 0;
        for (int i = 0; i < 24000 && !fs::exists(first); ++i) {
            if (::waitpid(pid, &status, WNOHANG) == pid) FAIL("the sweep ended before member-000 finished");
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(200)); // member-001 is integrating now
        REQUIRE(::kill(pid, SIGINT) == 0);
    });
    CAPTURE(stopped.err);
    CHECK(stopped.code == 130);
    CHECK(stopped.err.find("geobarrier: interrupted by SIGINT during the sweep: 1 of 4 members are complete") !=
          std::string::npos);
    CHECK(fs::exists(first));
    CHECK_FALSE(fs::exists(out / "member-001"));
    CHECK_FALSE(fs::exists(out / "member-002"));
    CHECK_FALSE(fs::exists(out / "summary.csv"));
    CHECK_FALSE(has_partial_files(out));
    const std::string first_manifest = test::read_text(first); // holds its wall time: a re-run would change it

    // The re-run with members 1..3 made quick: member-000's experiment is unchanged, so it is skipped.
    json quicker = sweep;
    quicker["parameters"][0]["values"] = {6.0, 3.0, 4.0, 5.0};
    std::ofstream(dir / "sweep.json") << quicker.dump(1);
    const Exit resumed = run_program(dir, {"sweep", (dir / "sweep.json").string()});
    CAPTURE(resumed.err);
    CHECK(resumed.code == 0);
    CHECK(resumed.err.find("member-000 (t1 = 6.0): complete from an earlier run, skipped") != std::string::npos);
    CHECK(test::read_text(first) == first_manifest);
    const auto rows = read_csv(out / "summary.csv");
    REQUIRE(rows.size() == 5);
    CHECK(rows[1][2] == "reused");
    for (int k = 2; k <= 4; ++k) CHECK(rows[k][2] == "done");
    for (int k = 1; k <= 3; ++k) CHECK(fs::exists(out / ("member-00" + std::to_string(k)) / "manifest.json"));
    fs::remove_all(dir);
}

TEST_CASE("validate checks a sweep file, every member included: exit 2 with the JSON path") {
    const fs::path dir = fresh_dir("validate");
    json sweep = {{"base", "base.json"}, {"parameters", {{{"path", "/time/t1"}, {"values", {1.0, 0.0}}}}}};
    std::ofstream(dir / "base.json") << small_base(5, 1.0).dump();
    std::ofstream(dir / "sweep.json") << sweep.dump();
    Exit e = run_program(dir, {"validate", (dir / "sweep.json").string()});
    CHECK(e.code == 2);
    CHECK(e.err == "geobarrier: error: " + (dir / "sweep.json").string() +
                       ": /parameters/0/values/1: member-001 (t1 = 0.0): /time/t1: equals t0; the interval must have "
                       "nonzero length\n");
    sweep["parameters"][0]["values"] = {1.0, 2.0};
    std::ofstream(dir / "sweep.json") << sweep.dump();
    e = run_program(dir, {"validate", (dir / "sweep.json").string()});
    CHECK(e.code == 0);
    CHECK(e.out.find("valid sweep (2 members over /time/t1 (2 values)") != std::string::npos);
    fs::remove_all(dir);
}

TEST_CASE("experiments/sweep-kam-amplitude.json: the shipped sweep validates, its base found beside it") {
    const fs::path file = test::source_dir() / "experiments" / "sweep-kam-amplitude.json";
    const Sweep s = load_sweep(file);
    CHECK_NOTHROW(check_sweep_members(s));
    REQUIRE(s.members.size() == 15); // 0.02 to 0.30 in steps of 0.02: both islands' breakups (docs/sweeps.md)
    CHECK(s.relative_to == (test::source_dir() / "experiments" / "duffing-kam.json").lexically_normal());
    CHECK(s.members[0].experiment["forcing"]["params"]["amplitude"] == 0.02);
    CHECK(s.members[14].experiment["forcing"]["params"]["amplitude"].get<double>() == doctest::Approx(0.30));
    CHECK(s.members[14].experiment["extractors"] == s.base["extractors"]);
    CHECK(s.plot_figure == "outermost_elliptic_area");
}

TEST_CASE("members run in both directions: FTLE figures per direction, read from forward/ and backward/") {
    // Their fields.nc lie in forward/ and backward/: ftle_mean and ftle_max were empty columns before.
    const fs::path dir = fresh_dir("both-directions");
    json base = small_base(21, 2.0);
    base["time"]["directions"] = "both";
    base["extractors"] = {{{"plugin", "hyperbolic"}}};
    const json sweep = {{"base", base},
                        {"parameters", {{{"path", "/forcing/params/amplitude"}, {"values", {0.0, 0.08}}}}},
                        {"processes", 1},
                        {"threads", 1},
                        {"output", {{"dir", (dir / "out").string()}}}};
    std::ofstream(dir / "sweep.json") << sweep.dump(1);
    const Exit e = run_program(dir, {"sweep", (dir / "sweep.json").string(), "--quiet"});
    CAPTURE(e.err);
    REQUIRE(e.code == 0);
    const auto rows = read_csv(dir / "out" / "summary.csv");
    REQUIRE(rows.size() == 3);
    const std::vector<std::string> &header = rows[0];
    const auto column = [&](const std::string &name) {
        const auto at = std::find(header.begin(), header.end(), name);
        REQUIRE_MESSAGE(at != header.end(), name);
        return static_cast<std::size_t>(at - header.begin());
    };
    CHECK(std::find(header.begin(), header.end(), "ftle_max") == header.end());
    for (std::size_t k = 0; k < 2; ++k)
        for (const std::string direction : {"forward", "backward"}) {
            CAPTURE(direction);
            const std::string cell = rows[k + 1].at(column("ftle_max_" + direction));
            REQUIRE_FALSE(cell.empty());
            const double expected = max_ftle(dir / "out" / ("member-00" + std::to_string(k)) / direction / "fields.nc");
            CHECK(std::stod(cell) == doctest::Approx(expected).epsilon(1e-5));
            CHECK_FALSE(rows[k + 1].at(column("ftle_mean_" + direction)).empty());
        }

    // The FTLE figure of the other kind of member is refused with the one to name.
    json named = sweep;
    named["figures"] = {"masked_fraction", "ftle_max"};
    CHECK(
        config_error(named).rfind("/figures/1: \"ftle_max\": the members run both directions (/base/time/directions)"
                                  ", each with its own FTLE field; name \"ftle_max_forward\" or \"ftle_max_backward\"",
                                  0) == 0);
    named["base"] = small_base(21, 2.0);
    named["figures"] = {"ftle_mean_backward"};
    CHECK(config_error(named).rfind("/figures/0: \"ftle_mean_backward\" is a figure of members run in both directions",
                                    0) == 0);
    fs::remove_all(dir);
}
