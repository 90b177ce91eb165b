// The unforced pendulum x'' = -sin x against its analytic separatrix y^2 / 2 - cos x = 1, i.e. y = +-2 |cos(x / 2)|:
// forward in time its repelling barriers are the separatrix, all of it in the box, including the two branches that
// run from a saddle (x = +-pi, y = 0) to the box's edge, about 1.19 long each. Those are pieces of strainlines that
// run along a heteroclinic orbit into the saddle and turn there onto the branch: remainders past the barrier on the
// heteroclinic orbit, far shorter than the strainline's segment, which the selection keeps and joins to that barrier
// as one curve, or judges with it where it cannot be joined (docs/extractors.md, steps 6 and 8;
// docs/extractor-measurements.md).
#include <geobarrier/experiment.hpp>

#include <test_support.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <fstream>
#include <string>
#include <unistd.h>
#include <vector>

using namespace geobarrier;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

const double pi = std::acos(-1.0);

// The separatrix in the box [-4, 4] x [-3, 3], cut at the saddles into its six branches (upper and lower, left of
// -pi, between the saddles, right of pi), each as n points (x, y interleaved).
std::vector<std::vector<double>> separatrix_branches(std::size_t n) {
    const double cuts[4] = {-4.0, -pi, pi, 4.0};
    std::vector<std::vector<double>> branches;
    for (int arc = 0; arc < 3; ++arc)
        for (const double sign : {1.0, -1.0}) {
            std::vector<double> xy;
            for (std::size_t k = 0; k < n; ++k) {
                const double x =
                    cuts[arc] + (cuts[arc + 1] - cuts[arc]) * static_cast<double>(k) / static_cast<double>(n - 1);
                xy.insert(xy.end(), {x, sign * 2.0 * std::abs(std::cos(0.5 * x))});
            }
            branches.push_back(std::move(xy));
        }
    return branches;
}

// The share of the points of `xy` within `tol` of a point of one of `others`.
double share_near(const std::vector<double> &xy, const std::vector<std::vector<double>> &others, double tol) {
    std::size_t near = 0;
    for (std::size_t k = 0; k < xy.size(); k += 2) {
        bool hit = false;
        for (const std::vector<double> &o : others)
            for (std::size_t j = 0; j < o.size() && !hit; j += 2)
                hit = std::hypot(xy[k] - o[j], xy[k + 1] - o[j + 1]) <= tol;
        near += hit ? 1 : 0;
    }
    return static_cast<double>(near) / static_cast<double>(xy.size() / 2);
}

std::vector<double> points_of(const json &barrier) {
    std::vector<double> xy;
    for (const json &p : barrier["points"]) xy.insert(xy.end(), {p[0].get<double>(), p[1].get<double>()});
    return xy;
}

} // namespace

TEST_CASE("unforced pendulum, forward time, 481 x 361: the barriers are the separatrix y^2 / 2 - cos x = 1, every "
          "branch of it in the box") {
    // The barrier suite's case pendulum-unforced-forward on its full grid (scripts/barrier_suite.py), with the
    // extractor's defaults; and at T + 10%, where the branches' ends at the saddles are taken by pieces that pass
    // straight through them, so that the branches are reported as curves of their own, judged with the barrier
    // they continue.
    double horizon = 8 * pi;
    SUBCASE("T = 8 pi") {}
    SUBCASE("T = 8.8 pi") { horizon = 8.8 * pi; }
    json j = {{"system", {{"plugin", "pendulum"}, {"params", {{"omega0", 1}, {"damping", 0}}}}},
              {"forcing", {{"plugin", "none"}}},
              {"grid", {{"x", {-4, 4}}, {"y", {-3, 3}}, {"n", {481, 361}}}},
              {"time", {{"t0", 0}, {"t1", horizon}}},
              {"extractors", {{{"plugin", "hyperbolic"}, {"params", json::object()}}}},
              {"output", {{"plots", false}}}};
    j["plugin_paths"] = {test::plugin_dir().string()};
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-pendulum-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    RunOptions options;
    options.output_dir = dir;
    options.quiet = true;
    run_experiment(resolve_experiment(parse_experiment(j)), options);
    const json barriers = json::parse(std::ifstream(dir / "barriers.json"))["barriers"];
    fs::remove_all(dir);
    std::vector<std::vector<double>> curves;
    std::size_t top = barriers.size();
    for (std::size_t b = 0; b < barriers.size(); ++b) {
        if (barriers[b].value("candidate", false)) continue;
        if (barriers[b].value("global_minimum", false)) top = curves.size();
        curves.push_back(points_of(barriers[b]));
    }
    REQUIRE(top < curves.size());
    // Within 2 grid spacings (8 / 480 = 0.0167) and a little: the suite's tolerance for this case.
    const double tol = 0.035;
    const std::vector<std::vector<double>> truth = separatrix_branches(2001);
    // Each barrier lies on the separatrix, the least-stretching one entirely.
    CHECK(share_near(curves[top], truth, tol) >= 0.99);
    for (const std::vector<double> &c : curves) CHECK(share_near(c, truth, tol) >= 0.95);
    // Each branch is covered, in at most two barriers (a barrier counts on a branch when it covers a tenth of it).
    for (const std::vector<double> &branch : truth) {
        MESSAGE("branch from (" << branch[0] << ", " << branch[1] << "): " << share_near(branch, curves, tol)
                                << " within " << tol << " of the barriers");
        CHECK(share_near(branch, curves, tol) >= 0.9);
        std::size_t pieces = 0;
        for (const std::vector<double> &c : curves) pieces += share_near(branch, {c}, tol) >= 0.1 ? 1 : 0;
        CHECK(pieces <= 2);
    }
}
