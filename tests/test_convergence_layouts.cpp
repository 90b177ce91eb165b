// "convergence" (run/convergence.hpp) in the runs made of several runs, through the program: with "directions": "both"
// each direction checks its own barriers (<dir>/forward, <dir>/backward), with frames each frame (<dir>/frames/NNN),
// and `geobarrier run` ends with "convergence: K of N barriers persist ...", K and N the top manifest's counts, the sum
// of its runs'. Known answers: the unforced pendulum is reversible ((x, y, t) -> (x, -y, -t)), so its backward
// barriers are its forward ones mirrored and persist alike; the unforced Duffing oscillator is autonomous, so every
// frame holds the same barriers, on the saddle's separatrix, which persist.
#include <doctest/doctest.h>
#include <nlohmann/json.hpp>
#include <program_output.hpp>
#include <test_support.hpp>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const double pi = std::acos(-1.0);

fs::path scratch(const std::string &name) {
    const fs::path dir =
        fs::temp_directory_path() / ("geobarrier-test-convergence-layouts-" + name + "-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

json read_json(const fs::path &file) { return json::parse(geobarrier::test::read_text(file)); }

// `geobarrier run` on j into dir/out (2 threads, as the machine has); its exit status and stdout.
using Program = geobarrier::test::CommandResult;
Program run_program(const json &j, const fs::path &dir) {
    std::ofstream(dir / "experiment.json") << j.dump(2);
    const std::string command = geobarrier::test::geobarrier_program().string() + " run " +
                                (dir / "experiment.json").string() + " --threads 2 --out " + (dir / "out").string() +
                                " 2>/dev/null";
    return geobarrier::test::run_command(command);
}

// The program's last line says the top manifest's counts.
void check_summary_line(const Program &p, const json &convergence) {
    CAPTURE(p.output);
    REQUIRE(p.status == 0);
    std::smatch m;
    REQUIRE(std::regex_search(p.output, m, std::regex("convergence: (\\d+) of (\\d+) barriers persist under every")));
    CHECK(std::stoul(m[1]) == convergence.at("converged").get<std::size_t>());
    CHECK(std::stoul(m[2]) == convergence.at("barriers").get<std::size_t>());
}

// One run's folder (a direction or a frame): barriers.json and the manifest hold the same "convergence" object, each
// share is in [0, 1], a barrier is converged exactly when every share reaches the threshold, and exactly the others
// are listed in not_converged and named in a warning. Returns the object.
json check_run(const fs::path &dir) {
    CAPTURE(dir.string());
    const json barriers = read_json(dir / "barriers.json"), manifest = read_json(dir / "manifest.json");
    REQUIRE(barriers.contains("convergence"));
    const json &c = barriers["convergence"];
    CHECK(c == manifest.at("convergence"));
    const json &items = barriers.at("barriers");
    CHECK(c["barriers"] == items.size());
    const double threshold = c["threshold"].get<double>();
    json not_converged = json::array();
    for (std::size_t b = 0; b < items.size(); ++b) {
        REQUIRE(items[b]["persistence"].size() == c["runs"].size());
        bool persists = true;
        for (const json &p : items[b]["persistence"]) {
            const double share = p["share"].get<double>();
            CHECK(share >= 0.0);
            CHECK(share <= 1.0);
            persists = persists && share >= threshold;
        }
        CHECK(items[b]["converged"] == persists);
        if (!persists) not_converged.push_back(b);
        const std::string named = "barrier " + std::to_string(b) + " (";
        const auto warned = std::any_of(manifest["warnings"].begin(), manifest["warnings"].end(), [&](const json &w) {
            return w.get<std::string>().rfind(named, 0) == 0 &&
                   w.get<std::string>().find("does not persist") != std::string::npos;
        });
        CHECK(warned == !persists);
    }
    CHECK(c["not_converged"] == not_converged);
    CHECK(c["converged"] == items.size() - not_converged.size());
    return c;
}

// The top manifest's "convergence": per run its counts, and their sums.
void check_total(const json &total, const std::vector<std::pair<std::string, json>> &runs) {
    REQUIRE(total["runs"].size() == runs.size());
    std::size_t barriers = 0, converged = 0;
    for (std::size_t k = 0; k < runs.size(); ++k) {
        const json &run = total["runs"][k];
        CHECK(run["run"] == runs[k].first);
        CHECK(run["barriers"] == runs[k].second["barriers"]);
        CHECK(run["converged"] == runs[k].second["converged"]);
        CHECK(run["not_converged"] == runs[k].second["not_converged"]);
        barriers += runs[k].second["barriers"].get<std::size_t>();
        converged += runs[k].second["converged"].get<std::size_t>();
    }
    CHECK(total["barriers"] == barriers);
    CHECK(total["converged"] == converged);
}

std::vector<double> first_shares(const fs::path &dir) {
    std::vector<double> shares;
    const json doc = read_json(dir / "barriers.json"); // kept: a range-for over a temporary's member reads freed memory
    for (const json &b : doc["barriers"]) shares.push_back(b["persistence"][0]["share"].get<double>());
    std::sort(shares.begin(), shares.end());
    return shares;
}

json experiment(const std::string &system, const json &params, const json &box, const json &n, const json &time) {
    return {{"system", {{"plugin", system}, {"params", params}}},
            {"forcing", {{"plugin", "none"}}},
            {"grid", {{"x", box[0]}, {"y", box[1]}, {"n", n}}},
            {"time", time},
            {"extractors", {{{"plugin", "hyperbolic"}, {"params", json::object()}}}},
            {"convergence", {{"horizon", 0.9}}},
            {"output", {{"plots", false}}}};
}

} // namespace

TEST_CASE("convergence with both directions: each direction marks its own barriers, the pendulum's alike, and the "
          "program's last line counts both") {
    // Measured (121 x 91, T = 8 pi, horizon x0.7): forward two barriers, 9.96 and 8.63 long, shares 1.00 and 0.88,
    // so one converged and one not; backward their mirror images with the same shares. (At x0.9 both read 1.00: that
    // run joins a separatrix branch from a saddle to the box's edge to the barrier it continues, 8.48 long against
    // 7.43 before: docs/extractors.md, step 6.)
    const fs::path dir = scratch("both");
    json j = experiment("pendulum", {{"omega0", 1}, {"damping", 0}}, {{-4, 4}, {-3, 3}}, {121, 91},
                        {{"t0", 0}, {"t1", 8 * pi}, {"directions", "both"}});
    j["convergence"]["horizon"] = 0.7;
    const Program p = run_program(j, dir);
    const json forward = check_run(dir / "out" / "forward"), backward = check_run(dir / "out" / "backward");
    const json total = read_json(dir / "out" / "manifest.json").at("convergence");
    check_total(total, {{"forward", forward}, {"backward", backward}});
    check_summary_line(p, total);
    // Both flags occur, so that the checks above see a converged barrier and one that is not.
    CHECK(total["converged"].get<std::size_t>() >= 1);
    CHECK(total["converged"].get<std::size_t>() < total["barriers"].get<std::size_t>());
    // Reversibility: the same shares in both directions (the backward horizon's change is T x0.7 backward).
    const std::vector<double> f = first_shares(dir / "out" / "forward"), b = first_shares(dir / "out" / "backward");
    REQUIRE(f.size() == b.size());
    for (std::size_t k = 0; k < f.size(); ++k) CHECK(b[k] == doctest::Approx(f[k]).epsilon(0.01));
    CHECK(backward["runs"][0]["change"].get<std::string>().find("T = -") != std::string::npos);
    fs::remove_all(dir);
}

TEST_CASE("convergence with frames: each frame marks its own barriers, the unforced Duffing oscillator's separatrix "
          "persists in every frame, and the program's last line counts all frames") {
    // Measured (121 x 81, T = 8 pi, horizon x0.9): one barrier per frame, share 1.00 in each.
    const fs::path dir = scratch("frames");
    const json j = experiment("duffing", {{"alpha", 1}, {"beta", 1}, {"delta", 0}}, {{-1.8, 1.8}, {-1.2, 1.2}},
                              {121, 81}, {{"t0", {0, 0.5}}, {"T", 8 * pi}});
    const Program p = run_program(j, dir);
    std::vector<std::pair<std::string, json>> frames;
    for (const char *frame : {"frames/000", "frames/001"}) {
        frames.emplace_back(frame, check_run(dir / "out" / frame));
        const json barriers = read_json(dir / "out" / frame / "barriers.json")["barriers"];
        REQUIRE(!barriers.empty());
        for (const json &b : barriers) CHECK(b["persistence"][0]["share"].get<double>() >= 0.9);
    }
    const json total = read_json(dir / "out" / "manifest.json").at("convergence");
    check_total(total, frames);
    check_summary_line(p, total);
    CHECK(total["converged"] == total["barriers"]);
    // Autonomous: the frames' barriers, and their shares, are the same.
    const std::vector<double> a = first_shares(dir / "out" / "frames/000"),
                              b = first_shares(dir / "out" / "frames/001");
    REQUIRE(a.size() == b.size());
    for (std::size_t k = 0; k < a.size(); ++k) CHECK(b[k] == doctest::Approx(a[k]).epsilon(0.01));
    fs::remove_all(dir);
}

TEST_CASE("convergence in a single run: the program's last line says the manifest's counts") {
    const fs::path dir = scratch("single");
    const json j = experiment("duffing", {{"alpha", 1}, {"beta", 1}, {"delta", 0}}, {{-1.8, 1.8}, {-1.2, 1.2}},
                              {121, 81}, {{"t0", 0}, {"t1", 8 * pi}});
    const Program p = run_program(j, dir);
    const json c = check_run(dir / "out");
    check_summary_line(p, c);
    fs::remove_all(dir);
}
