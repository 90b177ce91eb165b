// Frames and tracks (frames.hpp) against known answers: an autonomous system's frames are one frame and every track
// lasts through all of them; under a forcing of period P the frame at t0 + P is the frame at t0; bad "time" input is
// refused at its JSON path.
#include "sweep/sweep.hpp"
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/frames.hpp>

#include <test_support.hpp>

#include <doctest/doctest.h>

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using nlohmann::json;
using namespace geobarrier;

namespace {

const double pi = std::acos(-1.0);

// Duffing x'' = x - x^3 - delta x' + gamma cos t on a small grid, forward time, the hyperbolic extractor.
json duffing(double delta, double gamma) {
    json j = {{"system", {{"plugin", "duffing"}, {"params", {{"alpha", 1}, {"beta", 1}, {"delta", delta}}}}},
              {"grid", {{"x", {-1.6, 1.6}}, {"y", {-1.0, 1.0}}, {"n", {129, 81}}}},
              {"time", {{"t0", 0}, {"T", 6}}},
              {"bounds", {{"x", {-20, 20}}, {"y", {-20, 20}}}},
              {"products", {"ftle"}},
              {"extractors", {{{"plugin", "hyperbolic"}, {"params", json::object()}}}},
              {"output", {{"plots", false}}}};
    if (gamma != 0.0)
        j["forcing"] = {{"plugin", "cosine"}, {"params", {{"amplitude", gamma}, {"omega", 1}, {"phase", 0}}}};
    return j;
}

std::string error_path(const json &j) {
    try {
        parse_experiment(j);
    } catch (const ConfigError &e) {
        MESSAGE(std::string(e.what()));
        return e.json_path();
    }
    return "(accepted)";
}

json run_into(const json &j, const fs::path &out) {
    RunOptions options;
    options.output_dir = out;
    options.quiet = true;
    return run_experiment(resolve_experiment(parse_experiment(j)), options).manifest;
}

std::vector<double> points_of(const json &barrier) {
    std::vector<double> xy;
    for (const json &p : barrier["points"]) xy.insert(xy.end(), {p[0].get<double>(), p[1].get<double>()});
    return xy;
}

// The larger of the two directed mean distances between two barriers, capped at `cap`.
double curve_distance(const json &a, const json &b, double cap) {
    return std::max(mean_distance_to_polyline(points_of(a), points_of(b), b.value("closed", false), cap),
                    mean_distance_to_polyline(points_of(b), points_of(a), a.value("closed", false), cap));
}

json barriers_in(const fs::path &folder) { return json::parse(test::read_text(folder / "barriers.json"))["barriers"]; }

} // namespace

TEST_CASE("frames: initial times as a list or {from, to, count} with one horizon T; bad input at its JSON path") {
    json j = duffing(0, 0);
    j["time"] = {{"t0", {{"from", 0}, {"to", 1}, {"count", 5}}}, {"T", -2}};
    Experiment e = parse_experiment(j);
    REQUIRE(e.frames.size() == 5);
    CHECK(e.frames[1] == 0.25);
    CHECK(e.frames[4] == 1.0);
    CHECK(e.t0 == 0.0);
    CHECK(e.t1 == -2.0); // backward time
    j["time"] = {{"t0", 3}, {"T", 2}};
    e = parse_experiment(j);
    CHECK(e.frames.empty());
    CHECK(e.t1 == 5.0);

    const auto with_time = [&](const json &time) {
        json k = j;
        k["time"] = time;
        return error_path(k);
    };
    CHECK(with_time({{"t0", json::array()}, {"T", 1}}) == "/time/t0");
    CHECK(with_time({{"t0", {0, 2, 1}}, {"T", 1}}) == "/time/t0/2");
    CHECK(with_time({{"t0", {0, 0}}, {"T", 1}}) == "/time/t0/1");
    CHECK(with_time({{"t0", {0, "1"}}, {"T", 1}}) == "/time/t0/1");
    CHECK(with_time({{"t0", std::vector<double>(max_frames + 1, 0.0)}, {"T", 1}}) == "/time/t0");
    CHECK(with_time({{"t0", {{"from", 0}, {"to", 1}, {"count", 1000000}}}, {"T", 1}}) == "/time/t0/count");
    CHECK(with_time({{"t0", {{"from", 0}, {"to", 1}, {"count", 1}}}, {"T", 1}}) == "/time/t0/count");
    CHECK(with_time({{"t0", {{"from", 1}, {"to", 0}, {"count", 3}}}, {"T", 1}}) == "/time/t0/to");
    CHECK(with_time({{"t0", {{"from", 0}, {"count", 3}}}, {"T", 1}}) == "/time/t0");
    CHECK(with_time({{"t0", {{"from", 0}, {"to", 1}, {"count", 3}, {"step", 1}}}, {"T", 1}}) == "/time/t0/step");
    CHECK(with_time({{"t0", {0, 1}}, {"t1", 1}}) == "/time/t1");
    CHECK(with_time({{"t0", {0, 1}}}) == "/time");
    CHECK(with_time({{"t0", 0}, {"t1", 1}, {"T", 1}}) == "/time/T");
    CHECK(with_time({{"t0", 0}, {"T", 0}}) == "/time/T");
    CHECK(with_time({{"t0", {0, 1}}, {"T", 1}, {"directions", "both"}}) == "/time/directions");
    json v = j;
    v["time"] = {{"t0", {0, 1}}, {"T", 1}};
    v["validation"] = {{"advect_barriers", true}};
    CHECK(error_path(v) == "/validation");

    // A sweep over a frames experiment: its figures would find nothing in the members' folders.
    json base = v;
    base.erase("validation");
    try {
        parse_sweep({{"base", base}, {"parameters", {{{"path", "/system/params/delta"}, {"values", {0.1, 0.2}}}}}});
        FAIL("a sweep over frames was accepted");
    } catch (const ConfigError &e) {
        CHECK(e.json_path() == "/base/time/t0");
    }

    // A run that keeps its results in memory (Python's run) is refused before anything is computed.
    json m = j;
    m["time"] = {{"t0", {0, 1}}, {"T", 1}};
    RunOptions in_memory;
    in_memory.write_files = false;
    in_memory.keep_results = true;
    try {
        run_experiment(resolve_experiment(parse_experiment(m)), in_memory);
        FAIL("a frames run kept in memory was accepted");
    } catch (const ConfigError &e) {
        CHECK(e.json_path() == "/time/t0");
    }
}

TEST_CASE("frames of an autonomous system: every track lasts through all frames, its figures constant") {
    // Unforced Duffing: the flow map over [t0, t0 + T] does not depend on t0, so every frame holds the same barriers,
    // and each barrier (on the saddle's stable manifold, invariant) advected to the next frame's t0 lies on itself, up
    // to the finite-time barrier's distance from the manifold (T = 10; at T = 6 a joined barrier strays 0.9 grid
    // spacings from it).
    const fs::path dir =
        fs::temp_directory_path() / ("geobarrier-test-frames-autonomous-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    json j = duffing(0, 0);
    j["time"] = {{"t0", {0, 0.5, 1.0}}, {"T", 10}};
    const json manifest = run_into(j, dir);
    REQUIRE(manifest["frames"].size() == 3);
    const json tracks = json::parse(test::read_text(dir / "tracks.json"));
    const json first = barriers_in(dir / "frames" / "000");
    REQUIRE(first.size() >= 2);
    const double h = tracks["grid_spacing"].get<double>();
    for (const char *frame : {"001", "002"}) {
        const json other = barriers_in(dir / "frames" / frame);
        REQUIRE(other.size() == first.size());
        for (std::size_t b = 0; b < first.size(); ++b) CHECK(curve_distance(first[b], other[b], 10 * h) < h);
    }
    CHECK(tracks["track_count"] == first.size());
    CHECK(tracks["tracks_through_all_frames"] == first.size());
    for (const json &track : tracks["tracks"]) {
        CHECK(track["birth"] == 0);
        CHECK(track["death"].is_null());
        REQUIRE(track["frames"].size() == 3);
        REQUIRE(track["frames"][0]["barriers"].size() == 1);
        const json &b0 = track["frames"][0]["barriers"][0];
        for (std::size_t k = 1; k < 3; ++k) {
            REQUIRE(track["frames"][k]["barriers"].size() == 1);
            const json &bk = track["frames"][k]["barriers"][0];
            CHECK(bk["barrier"] == b0["barrier"]); // itself, not a neighbour
            CHECK(bk["length"].get<double>() == doctest::Approx(b0["length"].get<double>()).epsilon(1e-9));
            CHECK(bk["stretching"].get<double>() == doctest::Approx(b0["stretching"].get<double>()).epsilon(1e-9));
            MESSAGE("track " << track["id"] << " frame " << k << ": match distance " << bk["match_distance"]
                             << " grid spacings, length " << bk["length"]);
            CHECK(bk["match_distance"].get<double>() < 0.5);
        }
    }
    // A run of fewer frames into the same folder leaves none of the earlier run's extra frames.
    j["time"]["t0"] = {0, 0.5};
    CHECK(run_into(j, dir)["frames"].size() == 2);
    CHECK(fs::exists(dir / "frames" / "001" / "manifest.json"));
    CHECK_FALSE(fs::exists(dir / "frames" / "002"));
    fs::remove_all(dir);
}

TEST_CASE("frames of an autonomous system: nested closed barriers are tracked one to one, areas constant") {
    // Unforced Duffing's elliptic barriers, nested tori around each centre about a grid spacing apart: each torus
    // advected to the next frame must be matched to itself, not to a neighbour, and keep its enclosed area.
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-frames-tori-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    json j = duffing(0, 0);
    j["grid"]["n"] = {161, 101};
    j["time"] = {{"t0", {0, 0.5, 1.0}}, {"T", 8 * pi}};
    j["integrator"] = {{"method", "dopri5"}, {"rtol", 1e-8}, {"atol", 1e-10}};
    j["products"] = {"ftle", "shear_deviation_plus", "shear_deviation_minus"};
    j["extractors"] = {{{"plugin", "elliptic"}, {"params", {{"max_mean_deviation", 0.7}}}}};
    run_into(j, dir);
    const json tracks = json::parse(test::read_text(dir / "tracks.json"));
    const json first = barriers_in(dir / "frames" / "000");
    REQUIRE(first.size() >= 4);
    CHECK(tracks["track_count"] == first.size());
    CHECK(tracks["tracks_through_all_frames"] == first.size());
    for (const json &track : tracks["tracks"]) {
        REQUIRE(track["frames"].size() == 3);
        const json &b0 = track["frames"][0]["barriers"][0];
        CHECK(b0["area"].get<double>() > 0.0);
        for (std::size_t k = 1; k < 3; ++k) {
            REQUIRE(track["frames"][k]["barriers"].size() == 1);
            const json &bk = track["frames"][k]["barriers"][0];
            CHECK(bk["barrier"] == b0["barrier"]);
            CHECK(bk["area"].get<double>() == doctest::Approx(b0["area"].get<double>()).epsilon(1e-9));
            CHECK(bk["match_distance"].get<double>() < 1.0);
        }
    }
    fs::remove_all(dir);
}

TEST_CASE("frames of a rotating linear saddle: barriers along the known stable direction, a track along the manifold") {
    // x' = A(t) x, A(t) = R(w t) diag(a, -a) R(-w t). In the frame rotating with R(w t) the flow is autonomous,
    // y' = B y with B = [[a, w], [-w, -a]], eigenvalues +-mu, mu = sqrt(a^2 - w^2), stable direction v_s = (w, -(a +
    // mu)); at time t0 the stable manifold is the line through the origin along R(w t0) v_s. The FTLE field is
    // uniform, so every line parallel to it is a repelling barrier of the same stretching: each frame's barriers are
    // lines along R(w t0) v_s (finite-time error e^{-2 mu T} here), and a line at distance c from the manifold is
    // carried to distance c e^{mu dt} after dt, so the track of frame 0's barrier closest to the manifold stays within
    // d_k = d_{k-1} e^{mu dt} + 2 grid spacings (the match tolerance) of it.
    const double a = 1.0, w = 0.3, mu = std::sqrt(a * a - w * w), dt = 0.1;
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-frames-rotating-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    ::setenv("GEOBARRIER_EQUATIONS_CACHE", (dir / "cache").c_str(), 1);
    json j = {{"system",
               {{"plugin", "equations"},
                {"params",
                 {{"state", {"x", "y"}},
                  {"rhs", {"a*(cos(2*w*t)*x + sin(2*w*t)*y)", "a*(sin(2*w*t)*x - cos(2*w*t)*y)"}},
                  {"constants", {{"a", a}, {"w", w}}}}}}},
              {"grid", {{"x", {-1, 1}}, {"y", {-1, 1}}, {"n", {101, 101}}}},
              {"time", {{"t0", {0, dt, 2 * dt, 3 * dt}}, {"T", 5}}},
              {"integrator", {{"rtol", 1e-10}, {"atol", 1e-12}}},
              {"products", {"ftle"}},
              {"extractors", {{{"plugin", "hyperbolic"}, {"params", json::object()}}}},
              {"output", {{"plots", false}}}};
    run_into(j, dir / "out");
    const json tracks = json::parse(test::read_text(dir / "out" / "tracks.json"));
    const double h = tracks["grid_spacing"].get<double>();
    // The distance of a barrier (its mean point) from the manifold at t0, and the angle between them (degrees).
    const auto from_manifold = [&](const json &barrier, double t0, double &angle) {
        const double vx = w, vy = -(a + mu), c = std::cos(w * t0), s = std::sin(w * t0);
        const double dx = (c * vx - s * vy) / std::hypot(vx, vy), dy = (s * vx + c * vy) / std::hypot(vx, vy);
        const json &p = barrier["points"];
        const double bx = p.back()[0].get<double>() - p[0][0].get<double>(),
                     by = p.back()[1].get<double>() - p[0][1].get<double>();
        angle = std::asin(std::min(1.0, std::abs(bx * dy - by * dx) / std::hypot(bx, by))) * 180 / pi;
        double mx = 0, my = 0;
        for (const json &q : p) mx += q[0].get<double>() / p.size(), my += q[1].get<double>() / p.size();
        return std::abs(mx * dy - my * dx);
    };
    std::vector<json> frames;
    for (const char *k : {"000", "001", "002", "003"}) frames.push_back(barriers_in(dir / "out" / "frames" / k));
    std::size_t closest = 0;
    for (std::size_t k = 0; k < frames.size(); ++k) {
        REQUIRE(frames[k].size() >= 2);
        double best = HUGE_VAL;
        for (std::size_t b = 0; b < frames[k].size(); ++b) {
            double angle = 0.0;
            const double d = from_manifold(frames[k][b], k * dt, angle);
            CHECK(angle < 0.01);
            if (k == 0 && d < best) best = d, closest = b;
        }
    }
    const json *track = nullptr;
    for (const json &t : tracks["tracks"])
        for (const json &b : t["frames"][0]["barriers"])
            if (t["birth"] == 0 && b["barrier"] == closest) track = &t;
    REQUIRE(track != nullptr);
    REQUIRE((*track)["frames"].size() == 4);
    double angle = 0.0, bound = from_manifold(frames[0][closest], 0.0, angle);
    for (std::size_t k = 1; k < 4; ++k) {
        bound = bound * std::exp(mu * dt) + 2 * h;
        for (const json &b : (*track)["frames"][k]["barriers"]) {
            const double d = from_manifold(frames[k][b["barrier"].get<std::size_t>()], k * dt, angle);
            MESSAGE("frame " << k << ": the track's barrier " << d / h << " grid spacings from the manifold (bound "
                             << bound / h << ")");
            CHECK(d <= bound);
        }
    }
    ::unsetenv("GEOBARRIER_EQUATIONS_CACHE");
    fs::remove_all(dir);
}

namespace {

std::uint32_t be32(const std::string &s, std::size_t at) {
    std::uint32_t v = 0;
    for (std::size_t k = 0; k < 4; ++k) v = v << 8 | static_cast<unsigned char>(s[at + k]);
    return v;
}

// An animated PNG of `frames` frames, by the APNG specification: acTL's frame count, one fcTL per frame, sequence
// numbers 0, 1, 2, ... over fcTL and fdAT, and every chunk's CRC-32 (computed here bit by bit).
void check_animation(const fs::path &file, std::uint32_t frames) {
    const std::string png = test::read_text(file);
    REQUIRE(png.size() > 8);
    CHECK(png.substr(1, 3) == "PNG");
    std::uint32_t actl = 0, fctl = 0, sequence = 0;
    bool crcs = true;
    for (std::size_t at = 8; at + 12 <= png.size();) {
        const std::uint32_t length = be32(png, at);
        const std::string type = png.substr(at + 4, 4);
        std::uint32_t crc = 0xffffffffu;
        for (std::size_t k = at + 4; k < at + 8 + length; ++k) {
            crc ^= static_cast<unsigned char>(png[k]);
            for (int bit = 0; bit < 8; ++bit) crc = crc & 1 ? 0xedb88320u ^ (crc >> 1) : crc >> 1;
        }
        crcs = crcs && (crc ^ 0xffffffffu) == be32(png, at + 8 + length);
        if (type == "acTL") actl = be32(png, at + 8);
        if (type == "fcTL") ++fctl;
        if (type == "fcTL" || type == "fdAT") CHECK(be32(png, at + 8) == sequence++);
        at += 12 + length;
    }
    CHECK(crcs);
    CHECK(actl == frames);
    CHECK(fctl == frames);
    // ffmpeg's reader, when installed (not a dependency: Debian's ffmpeg pulls in about 80 packages): it decodes
    // every frame of the animation.
    if (std::system("command -v ffprobe >/dev/null 2>&1") != 0) {
        MESSAGE("ffprobe is not installed: the animation is checked by the APNG specification only");
        return;
    }
    const std::string command = "ffprobe -v error -count_frames -select_streams v:0 -show_entries "
                                "stream=codec_name,nb_read_frames -of csv=p=0 '" +
                                file.string() + "'";
    std::string answer;
    if (std::FILE *pipe = ::popen(command.c_str(), "r")) {
        char buffer[256];
        while (std::fgets(buffer, sizeof buffer, pipe) != nullptr) answer += buffer;
        CHECK(::pclose(pipe) == 0);
    }
    MESSAGE("ffprobe: " << answer);
    CHECK(answer == "apng," + std::to_string(frames) + "\n");
}

// The barriers a track holds in frame k, as one list of barriers.json items.
json track_barriers_in(const json &track, std::size_t k, const json &frame) {
    json out = json::array();
    for (const json &f : track["frames"])
        if (f["frame"] == k)
            for (const json &b : f["barriers"]) out.push_back(frame[b["barrier"].get<std::size_t>()]);
    return out;
}

} // namespace

TEST_CASE("frames of a periodic forcing: the frame at t0 + P is the frame at t0, and tracks return onto themselves") {
    // Damped, forced Duffing with period P = 2 pi: the flow maps from t0 and t0 + P are one map, so frame 4 (t0 = P)
    // holds frame 0's barriers; a track through all frames is one material curve carried over a whole period, which
    // lands on the curve it started from (the stable manifold of the saddle orbit at phase 0).
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-frames-periodic-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    json j = duffing(0.15, 0.3);
    j["time"] = {{"t0", {{"from", 0}, {"to", 2 * pi}, {"count", 5}}}, {"T", 10}};
    j["output"]["plots"] = true;
    run_into(j, dir);
    CHECK(fs::exists(dir / "tracks.png"));
    check_animation(dir / "animation.png", 5);
    const json tracks = json::parse(test::read_text(dir / "tracks.json"));
    const double h = tracks["grid_spacing"].get<double>();
    const json first = barriers_in(dir / "frames" / "000"), last = barriers_in(dir / "frames" / "004");
    REQUIRE(first.size() >= 1);
    REQUIRE(last.size() == first.size());
    for (const json &b : last) {
        double nearest = HUGE_VAL;
        for (const json &a : first) nearest = std::min(nearest, curve_distance(a, b, 10 * h));
        CHECK(nearest < h);
    }
    std::size_t through = 0;
    for (const json &track : tracks["tracks"]) {
        if (track["frames"].size() != 5) continue;
        ++through;
        const json from = track_barriers_in(track, 0, first), to = track_barriers_in(track, 4, last);
        REQUIRE(from.size() == to.size());
        for (std::size_t b = 0; b < from.size(); ++b) {
            const double d = curve_distance(from[b], to[b], 10 * h);
            MESSAGE("track " << track["id"] << ": frame 4's barrier " << d / h << " grid spacings from frame 0's");
            CHECK(d < h);
        }
    }
    CHECK(through >= 1);
    CHECK(tracks["tracks_through_all_frames"] == through);

    // Each frame is the run of a single t0: the same barriers as that run's.
    json single = duffing(0.15, 0.3);
    single["time"] = {{"t0", pi}, {"T", 10}};
    run_into(single, dir / "single");
    CHECK(barriers_in(dir / "single") == barriers_in(dir / "frames" / "002"));
    fs::remove_all(dir);
}

namespace {

// A closed orbit of unforced Duffing x'' = x - x^3 around the centre (1, 0), the level set H = -1/4 + e of
// H = y^2/2 - x^2/2 + x^4/4 (invariant, so every frame of an autonomous run holds it), as a barrier of 400 points
// found along rays from the centre by bisection.
json duffing_orbit(double e) {
    const auto H = [](double x, double y) { return 0.5 * y * y - 0.5 * x * x + 0.25 * x * x * x * x; };
    json points = json::array();
    for (int k = 0; k < 400; ++k) {
        const double angle = 2 * pi * k / 400, c = std::cos(angle), s = std::sin(angle);
        double lo = 0.0, hi = 0.9;
        for (int it = 0; it < 60; ++it) {
            const double mid = 0.5 * (lo + hi);
            (H(1 + mid * c, mid * s) < -0.25 + e ? lo : hi) = mid;
        }
        points.push_back({1 + lo * c, lo * s});
    }
    return {{"extractor", "elliptic"}, {"kind", "elliptic"}, {"closed", true}, {"points", points}};
}

} // namespace

TEST_CASE("tracks across a missed frame: a barrier dropped from a frame keeps its track within the gap limit") {
    // Three nested closed orbits of unforced Duffing, 4 to 5 grid spacings apart (farther than the match tolerance of
    // 2): frames that hold all of them are tracked one to one. Drop one from the middle frames, as an extractor that
    // misses a torus does: within max_gap frames its track skips them (one advection across the gap), beyond it the
    // track ends and a new one starts; an orbit that is not there before the gap does not take the track.
    json j = duffing(0, 0);
    const ResolvedExperiment r = resolve_experiment(parse_experiment(j));
    const json inner = duffing_orbit(0.04), middle = duffing_orbit(0.09), outer = duffing_orbit(0.16);
    const auto track_of = [](const json &tracks, std::size_t frame, std::size_t barrier) {
        for (const json &t : tracks["tracks"])
            for (const json &f : t["frames"])
                for (const json &b : f["barriers"])
                    if (f["frame"] == frame && b["barrier"] == barrier) return t;
        return json();
    };
    const std::vector<double> t0s = {0, 0.5, 1.0, 1.5};
    SUBCASE("one frame missed, max_gap 1: one track with frame 1 skipped") {
        const std::vector<json> frames = {json{inner, middle}, json{inner}, json{inner, middle}};
        const json tracks = track_barriers(r, {0, 0.5, 1.0}, frames);
        CHECK(tracks["max_gap_frames"] == 1);
        CHECK(tracks["track_count"] == 2);
        CHECK(tracks["tracks_through_all_frames"] == 1);
        const json t = track_of(tracks, 0, 1);
        REQUIRE(t["frames"].size() == 2);
        CHECK(t["frames"][1]["frame"] == 2);
        CHECK(t["frames"][1]["barriers"][0]["barrier"] == 1);
        CHECK(t["frames"][1]["barriers"][0]["match_distance"].get<double>() < 0.5);
        CHECK(t["skipped"] == json{1});
        CHECK(t["death"].is_null());
        CHECK(tracks["gaps"] == json{{{"from", 0}, {"to", 2}, {"matched_pairs", 1}}});
        CHECK(track_of(tracks, 0, 0)["skipped"] == json::array());
    }
    SUBCASE("max_gap 0: the track ends at the missed frame and a new one starts after it") {
        const std::vector<json> frames = {json{inner, middle}, json{inner}, json{inner, middle}};
        TrackSettings settings;
        settings.max_gap = 0;
        const json tracks = track_barriers(r, {0, 0.5, 1.0}, frames, settings);
        CHECK(tracks["track_count"] == 3);
        CHECK(track_of(tracks, 0, 1)["death"] == 1);
        CHECK(track_of(tracks, 2, 1)["birth"] == 2);
        CHECK(tracks["gaps"] == json::array());
    }
    SUBCASE("two frames missed: bridged with max_gap 2, not with max_gap 1") {
        const std::vector<json> frames = {json{inner, middle}, json{inner}, json{inner}, json{inner, middle}};
        CHECK(track_barriers(r, t0s, frames)["track_count"] == 3);
        TrackSettings settings;
        settings.max_gap = 2;
        const json tracks = track_barriers(r, t0s, frames, settings);
        CHECK(tracks["track_count"] == 2);
        CHECK(track_of(tracks, 0, 1)["skipped"] == json{1, 2});
        CHECK(tracks["gaps"] == json{{{"from", 0}, {"to", 3}, {"matched_pairs", 1}}});
    }
    SUBCASE("another orbit after the gap is not the missed one") {
        const std::vector<json> frames = {json{inner, middle}, json{inner}, json{inner, outer}};
        const json tracks = track_barriers(r, {0, 0.5, 1.0}, frames);
        CHECK(tracks["track_count"] == 3);
        CHECK(track_of(tracks, 0, 1)["death"] == 1);
        CHECK(track_of(tracks, 2, 1)["birth"] == 2);
    }
}
