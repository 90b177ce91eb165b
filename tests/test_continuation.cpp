// Continuation across a sweep's parameter (core/src/run/continuation.hpp) against known answers: constructed barriers
// whose tracks, areas and events are known exactly; unforced Duffing swept over a parameter that cannot move its
// barriers; the damped, forced Duffing tangle appearing between 0.9 and 1.1 of Melnikov's threshold.
#include "sweep/continuation.hpp"

#include "sweep/sweep.hpp"
#include <geobarrier/experiment.hpp>

#include <test_support.hpp>

#include <doctest/doctest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using nlohmann::json;
using namespace geobarrier;

namespace {

const double pi = std::acos(-1.0);

json circle(double r, int n, bool outermost = false, double cx = 0.0, double cy = 0.0) {
    json p = json::array();
    for (int k = 0; k < n; ++k) p.push_back({cx + r * std::cos(2 * pi * k / n), cy + r * std::sin(2 * pi * k / n)});
    return {{"extractor", "elliptic"}, {"kind", "elliptic"},     {"closed", true},
            {"lambda", 1.0},           {"outermost", outermost}, {"points", p}};
}

json segment(double x0, double x1, double y) {
    json p = json::array();
    for (int k = 0; k <= 100; ++k) p.push_back({x0 + (x1 - x0) * k / 100.0, y});
    return {{"extractor", "hyperbolic"}, {"kind", "hyperbolic"}, {"closed", false}, {"repelling", true}, {"points", p}};
}

// Member p of a constructed series over the box [-1, 1]^2 on 101 x 101 points (h = 0.02), value 0.1 p, no barriers yet.
ContinuationMember constructed_member(int p, bool available = true) {
    ContinuationMember m;
    m.name = "member-00" + std::to_string(p);
    m.value = 0.1 * p;
    m.grid.x_min = m.grid.y_min = -1.0;
    m.grid.x_max = m.grid.y_max = 1.0;
    m.grid.nx = m.grid.ny = 101;
    m.available = available;
    return m;
}

// Lists member m's barriers as its own, each from run "" at its own index.
void index_barriers(ContinuationMember &m) {
    for (std::size_t b = 0; b < m.barriers.size(); ++b) m.runs.push_back(""), m.indices.push_back(b);
}

// The events of one kind.
std::vector<json> events_of(const json &series, const std::string &kind) {
    std::vector<json> found;
    for (const json &e : series["events"])
        if (e["event"] == kind) found.push_back(e);
    return found;
}

} // namespace

TEST_CASE("continuation of constructed barriers: tracks, areas and every kind of event where they were built") {
    // Members p = 0..5 (constructed_member), member 1 failed (skipped):
    // torus A, radius 0.5 + 0.01 p (half a grid spacing per member), in all, the outermost of its island; torus B,
    // radius 0.2 inside it, while p <= 2; island E around (-0.7, -0.45), its outermost torus of radius 0.2 - 0.05 p
    // (2.5 grid spacings per member: each torus its own track, the island one track) while p <= 3; line C (y = 0.8)
    // whole while p <= 3, then in two pieces; line D (y = -0.8) only at p = 0; the tangle's crossings 0, -, 0, 4, 6, 6.
    // A polygon of n points on a circle of radius r encloses (n / 2) r^2 sin(2 pi / n).
    const int n = 400;
    std::vector<ContinuationMember> members(6);
    for (int p = 0; p < 6; ++p) {
        ContinuationMember &m = members[p] = constructed_member(p, p != 1);
        if (!m.available) continue;
        m.barriers.push_back(circle(0.5 + 0.01 * p, n, true));
        if (p <= 2) m.barriers.push_back(circle(0.2, n));
        if (p <= 3) m.barriers.push_back(circle(0.2 - 0.05 * p, n, true, -0.7, -0.45));
        if (p <= 3) {
            m.barriers.push_back(segment(-0.9, 0.9, 0.8));
        } else {
            m.barriers.push_back(segment(-0.9, -0.1, 0.8));
            m.barriers.push_back(segment(0.1, 0.9, 0.8));
        }
        if (p == 0) m.barriers.push_back(segment(-0.9, 0.9, -0.8));
        index_barriers(m);
        m.tangle_crossings = std::vector<double>{0, 0, 0, 4, 6, 6}[p];
    }
    const json series = continue_series(members);
    const json &tracks = series["tracks"];
    REQUIRE(tracks.size() == 7); // A, B, E at p = 0, C, D, E at p = 2, E at p = 3
    const json &a = tracks[0], &b = tracks[1], &c = tracks[3], &d = tracks[4];
    const auto area = [&](double r) { return n / 2.0 * r * r * std::sin(2 * pi / n); };
    CHECK(a["closed"] == true);
    CHECK(a["death"].is_null());
    REQUIRE(a["members"].size() == 5);
    for (const json &m : a["members"]) {
        const double r = 0.5 + 0.01 * m["member"].get<int>();
        CHECK(m["area"].get<double>() == doctest::Approx(area(r)).epsilon(1e-12));
        CHECK(m["stretching"].get<double>() == 1.0);
    }
    // Consecutive available members 0 and 2: radii 0.02 apart = one grid spacing, within the tolerance.
    CHECK(a["members"][1]["barriers"][0]["match_distance"].get<double>() == doctest::Approx(1.0).epsilon(1e-3));
    CHECK(b["members"].size() == 2);
    CHECK(b["death"] == 3);
    CHECK(c["death"].is_null());
    CHECK(c["members"].back()["barriers"].size() == 2);
    CHECK(c["members"].back()["length"].get<double>() == doctest::Approx(1.6));
    CHECK(d["death"] == 2); // the first available member without it
    // Torus B ends at member 3; E's tori at members 2, 3 and 4.
    const std::vector<json> breakups = events_of(series, "torus-breakup");
    REQUIRE(breakups.size() == 4);
    CHECK(breakups[0]["member"] == "member-002");
    CHECK(breakups[1]["member"] == "member-003");
    CHECK(breakups[2]["member"] == "member-003");
    CHECK(breakups[3]["member"] == "member-004");
    for (const json &e : {breakups[1], breakups[2]})
        if (e["track"] == b["id"]) {
            CHECK(e["last_value"].get<double>() == doctest::Approx(0.2));
            CHECK(e["last_area"].get<double>() == doctest::Approx(area(0.2)));
        }
    // Two islands: A's through every member; E's over members 0, 2, 3, gone at 4, its last torus of radius 0.1.
    const json &islands = series["islands"];
    REQUIRE(islands.size() == 2);
    CHECK(islands[0]["death"].is_null());
    CHECK(islands[0]["members"].size() == 5);
    REQUIRE(islands[1]["members"].size() == 3);
    CHECK(islands[1]["death"] == 4);
    CHECK(islands[1]["members"][1]["area"].get<double>() == doctest::Approx(area(0.1)));
    CHECK(islands[1]["members"][2]["centre"][0].get<double>() == doctest::Approx(-0.7));
    REQUIRE(events_of(series, "island-breakup").size() == 1);
    CHECK(events_of(series, "island-breakup")[0]["member"] == "member-004");
    CHECK(events_of(series, "island-breakup")[0]["last_value"].get<double>() == doctest::Approx(0.3));
    REQUIRE(events_of(series, "track-end").size() == 1);
    CHECK(events_of(series, "track-end")[0]["member"] == "member-002");
    REQUIRE(events_of(series, "track-split").size() == 1);
    CHECK(events_of(series, "track-split")[0]["member"] == "member-004");
    CHECK(events_of(series, "track-split")[0]["pieces"] == 2);
    REQUIRE(events_of(series, "tangle-onset").size() == 1);
    CHECK(events_of(series, "tangle-onset")[0]["member"] == "member-003");
    CHECK(events_of(series, "tangle-onset")[0]["last_member"] == "member-002");
    CHECK(series["events"].size() == 8);
}

TEST_CASE("continuation carries an island across a member where the extractor missed it, up to max_gap") {
    // Members p = 0..4 (constructed_member). Island F: outermost torus of radius 0.4 - 0.02 p around (0.1, 0) in
    // members 0, 1, 3, 4 (missed at 2, as the KAM sweep's left island at one amplitude); island G: radius 0.2 around
    // (-0.6, 0.5) in members 0, 1 only (missed at 2 and 3, back at 4).
    const int n = 200;
    std::vector<ContinuationMember> members(5);
    for (int p = 0; p < 5; ++p) {
        ContinuationMember &m = members[p] = constructed_member(p);
        if (p != 2) m.barriers.push_back(circle(0.4 - 0.02 * p, n, true, 0.1, 0.0));
        if (p <= 1 || p == 4) m.barriers.push_back(circle(0.2, n, true, -0.6, 0.5));
        index_barriers(m);
    }
    const json carried = continue_series(members); // max_gap 1 by default
    const json &islands = carried["islands"];
    REQUIRE(islands.size() == 3); // F throughout, G until its two-member gap, G again at member 4 (a new island)
    CHECK(islands[0]["death"].is_null());
    CHECK(islands[0]["members"].size() == 4);
    CHECK(islands[0]["skipped"] == json::array({2}));
    CHECK(islands[0]["members"][2]["area"].get<double>() ==
          doctest::Approx(n / 2.0 * 0.34 * 0.34 * std::sin(2 * pi / n)).epsilon(1e-12));
    CHECK(islands[1]["death"] == 2); // the first member of the gap it did not come back from
    CHECK(islands[1]["skipped"].empty());
    CHECK(islands[2]["birth"] == 4);
    REQUIRE(events_of(carried, "island-breakup").size() == 1);
    CHECK(events_of(carried, "island-breakup")[0]["member"] == "member-002");
    CHECK(events_of(carried, "island-breakup")[0]["island"] == 1);

    TrackSettings every_member;
    every_member.max_gap = 0;
    const json strict = continue_series(members, every_member);
    REQUIRE(strict["islands"].size() == 4); // F until 2, F again from 3, G until 2, G again at 4
    CHECK(strict["islands"][0]["death"] == 2);
    CHECK(events_of(strict, "island-breakup").size() == 2);

    TrackSettings two_members;
    two_members.max_gap = 2;
    const json bridged = continue_series(members, two_members);
    REQUIRE(bridged["islands"].size() == 2);
    CHECK(bridged["islands"][1]["skipped"] == json::array({2, 3}));
    CHECK(events_of(bridged, "island-breakup").empty());
}

TEST_CASE("continuation of unforced Duffing over a parameter that cannot move its barriers: one track per torus") {
    // x'' = x - x^3 with the cosine forcing at amplitude 0 swept over its frequency: the flow, and so every member's
    // barriers, are the same, so each nested torus (about a grid spacing from the next) continues as itself through
    // every member at distance 0 with its area, and nothing happens.
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-continuation-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    json base = {{"system", {{"plugin", "duffing"}, {"params", {{"alpha", 1}, {"beta", 1}, {"delta", 0}}}}},
                 {"forcing", {{"plugin", "cosine"}, {"params", {{"amplitude", 0}, {"omega", 1}, {"phase", 0}}}}},
                 {"grid", {{"x", {-1.6, 1.6}}, {"y", {-1.0, 1.0}}, {"n", {161, 101}}}},
                 {"time", {{"t0", 0}, {"t1", 8 * pi}}},
                 {"integrator", {{"method", "dopri5"}, {"rtol", 1e-8}, {"atol", 1e-10}}},
                 {"products", {"ftle", "shear_deviation_plus", "shear_deviation_minus"}},
                 {"extractors", {{{"plugin", "elliptic"}, {"params", {{"max_mean_deviation", 0.7}}}}}},
                 {"output", {{"plots", false}}}};
    const json sweep = {{"base", base},
                        {"parameters", {{{"path", "/forcing/params/omega"}, {"values", {0.5, 1.0, 1.5}}}}},
                        {"plot", {{"figure", "elliptic_barriers"}, {"parameter", "omega"}}}};
    SweepOptions options;
    options.output_dir = dir;
    options.quiet = true;
    const SweepResult result = run_sweep(parse_sweep(sweep), options);
    REQUIRE(result.failed == 0);
    const json continuation = json::parse(test::read_text(dir / "continuation.json"));
    CHECK(continuation["parameter"]["name"] == "omega");
    CHECK(continuation["island_max_gap_members"] == 2); // a sweep carries an island across two missed members
    CHECK(fs::exists(dir / "continuation.png"));
    REQUIRE(continuation["series"].size() == 1);
    const json &series = continuation["series"][0];
    const json first = json::parse(test::read_text(dir / "member-000" / "barriers.json"))["barriers"];
    REQUIRE(first.size() >= 4);
    REQUIRE(series["tracks"].size() == first.size());
    for (const json &track : series["tracks"]) {
        CHECK(track["closed"] == true);
        CHECK(track["death"].is_null());
        REQUIRE(track["members"].size() == 3);
        const json &b0 = track["members"][0]["barriers"][0];
        for (std::size_t k = 1; k < 3; ++k) {
            REQUIRE(track["members"][k]["barriers"].size() == 1);
            const json &bk = track["members"][k]["barriers"][0];
            CHECK(bk["barrier"] == b0["barrier"]); // itself, not the next torus
            CHECK(bk["area"].get<double>() == doctest::Approx(b0["area"].get<double>()).epsilon(1e-12));
            CHECK(bk["match_distance"].get<double>() < 1e-9);
        }
    }
    REQUIRE(series["islands"].size() == 2); // the islands around the centres (-1, 0) and (1, 0)
    for (const json &island : series["islands"]) {
        CHECK(island["death"].is_null());
        CHECK(island["members"].size() == 3);
        CHECK(std::abs(std::abs(island["members"][0]["centre"][0].get<double>()) - 1.0) < 0.1);
    }
    CHECK(series["events"].empty());
    CHECK(test::read_text(dir / "summary.md").find("No events.") != std::string::npos);
    fs::remove_all(dir);
}

TEST_CASE("continuation of forced, damped Duffing: tangle onset between 0.9 and 1.1 of Melnikov's threshold") {
    // experiments/sweep-duffing-tangency.json (the forcing at 0.8, 0.9, 1.1 and 1.2 gamma_c, delta = 0.1 and 0.2,
    // zipped) as tests/test_tangle.cpp runs it: crossings 0 below the threshold, some above, so each delta's series
    // has one tangle-onset, at 1.1 gamma_c, after 0.9 gamma_c.
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-onset-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    const fs::path file = test::source_dir() / "experiments" / "sweep-duffing-tangency.json";
    json sweep = json::parse(test::read_text(file));
    json base = json::parse(test::read_text(test::source_dir() / "experiments" / "duffing-tangle.json"));
    base["output"]["plots"] = false;
    base["time"].erase("grow_periods"); // the counts are the barriers' own
    sweep["base"] = base;
    SweepOptions options;
    options.output_dir = dir;
    options.quiet = true;
    const SweepResult result = run_sweep(parse_sweep(sweep, file), options);
    REQUIRE(result.failed == 0);
    const json continuation = json::parse(test::read_text(dir / "continuation.json"));
    CHECK(continuation["parameter"]["name"] == "amplitude");
    REQUIRE(continuation["series"].size() == 2);
    for (const json &series : continuation["series"]) {
        const double delta = series["fixed"]["delta"].get<double>();
        const double gamma_c = 4 * delta * std::cosh(pi / 2) / (3 * std::sqrt(2.0) * pi);
        CAPTURE(delta);
        const std::vector<json> onset = events_of(series, "tangle-onset");
        REQUIRE(onset.size() == 1);
        MESSAGE("delta " << delta << ": " << onset[0].dump());
        CHECK(onset[0]["value"].get<double>() / gamma_c == doctest::Approx(1.1).epsilon(1e-3));
        CHECK(onset[0]["last_value"].get<double>() / gamma_c == doctest::Approx(0.9).epsilon(1e-3));
    }
    CHECK(test::read_text(dir / "summary.md").find("tangle-onset") != std::string::npos);
    fs::remove_all(dir);
}
