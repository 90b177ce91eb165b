// Composite forcings in experiment files: "terms" and "base" are parsed, checked against the plugin's declared term
// count with JSON paths in every error, evaluated by the core through the Forcing wrapper, and echoed in the resolved
// experiment; and "path" parameters resolve against the experiment's folder.
#include <doctest/doctest.h>

#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <test_support.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

using namespace geobarrier;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

json experiment_with(const json &forcing) {
    json j = json::parse(R"({
      "system": {"plugin": "duffing"},
      "grid": {"x": [-1, 1], "y": [-1, 1], "n": [4, 4]},
      "time": {"t0": 0, "t1": 1},
      "products": ["ftle"]
    })");
    j["forcing"] = forcing;
    return j;
}

ResolvedExperiment resolve(const json &forcing) {
    return resolve_experiment(parse_experiment(experiment_with(forcing)));
}

// The message of the ConfigError that resolving (or parsing) this forcing throws.
std::string error_of(const json &forcing) {
    try {
        resolve(forcing);
    } catch (const ConfigError &e) {
        return e.what();
    }
    return "(no error)";
}

bool starts_with(const std::string &text, const std::string &prefix) { return text.rfind(prefix, 0) == 0; }

} // namespace

TEST_CASE("composite forcing: a sum of terms, evaluated by the core") {
    const ResolvedExperiment r = resolve(json::parse(R"({"plugin": "sum", "terms": [
        {"plugin": "cosine", "params": {"amplitude": 0.2}},
        {"plugin": "quasi-periodic"}]})"));
    CHECK(r.forcing.info().name == "sum");
    REQUIRE(r.forcing.terms().size() == 2);
    CHECK(r.forcing.terms()[0].info().name == "cosine");
    CHECK(r.forcing.terms()[1].info().name == "quasi-periodic");
    for (double t : {0.0, 1.5, -4.0}) {
        const double expected = 0.2 * std::cos(t) + (0.04 * std::cos(t) + 0.04 * std::cos(std::sqrt(2.0) * t));
        CHECK(std::fabs(r.forcing(t) - expected) <= 1e-15);
    }
    // The resolved experiment (for the manifest) echoes the tree with every default filled in.
    const json &echo = r.resolved["forcing"];
    CHECK(echo["plugin"] == "sum");
    REQUIRE(echo["terms"].size() == 2);
    CHECK(echo["terms"][0]["params"]["omega"] == 1.0);
    CHECK(echo["terms"][1]["params"]["omega2"] == std::sqrt(2.0));
}

TEST_CASE("composite forcing: a ramp of a sum, written with \"base\"") {
    const ResolvedExperiment r = resolve(json::parse(R"({"plugin": "ramp", "params": {"duration": 2, "shape": "cubic"},
        "base": {"plugin": "sum", "terms": [{"plugin": "cosine"}, {"plugin": "cosine", "params": {"omega": 3}}]}})"));
    const double t = 0.5, s = 0.25, ramp = s * s * (3 - 2 * s);
    CHECK(std::fabs(r.forcing(t) - ramp * (0.08 * std::cos(t) + 0.08 * std::cos(3 * t))) <= 1e-16);
    CHECK(r.resolved["forcing"]["base"]["plugin"] == "sum");
    CHECK(r.resolved["forcing"]["base"]["terms"][1]["params"]["omega"] == 3.0);
    CHECK_FALSE(r.resolved["forcing"].contains("terms"));
}

TEST_CASE("composite forcing: every mistake is an error at its JSON path") {
    CHECK(starts_with(error_of({{"plugin", "cosine"}, {"terms", {{{"plugin", "none"}}}}}),
                      "/forcing/terms: forcing 'cosine' is not a composite forcing and takes no \"terms\""));
    const std::string no_base = error_of({{"plugin", "ramp"}});
    CHECK(starts_with(no_base, "/forcing: forcing 'ramp' combines 1 other forcing(s), found 0"));
    CHECK(no_base.find("\"base\": {\"plugin\": ...}") != std::string::npos);
    CHECK(starts_with(error_of({{"plugin", "sum"}}), "/forcing: forcing 'sum' combines 1 to 16 other forcing(s)"));
    CHECK(starts_with(error_of({{"plugin", "ramp"}, {"terms", {{{"plugin", "none"}}, {{"plugin", "cosine"}}}}}),
                      "/forcing/terms/1: forcing 'ramp' combines 1 other forcing(s), found 2"));
    CHECK(starts_with(error_of({{"plugin", "sum"}, {"terms", json::array()}}),
                      "/forcing/terms: [] must be a non-empty array"));
    CHECK(starts_with(error_of({{"plugin", "sum"}, {"terms", {{"plugin", "none"}}}}), // an object, not a list
                      "/forcing/terms: {\"plugin\":\"none\"} must be a non-empty array"));
    CHECK(starts_with(error_of(json::parse(R"({"plugin": "sum", "terms": ["cosine"]})")),
                      "/forcing/terms/0: \"cosine\" is a string; expected an object"));
    CHECK(starts_with(error_of({{"plugin", "ramp"}, {"base", {{"plugin", "none"}}}, {"terms", {{{"plugin", "none"}}}}}),
                      "/forcing/base: give either \"base\" (one forcing) or \"terms\" (a list), not both"));
    CHECK(starts_with(error_of({{"plugin", "sum"}, {"terms", {{{"plugin", "none"}}, {{"plugin", "cosin"}}}}}),
                      "/forcing/terms/1/plugin:"));
    CHECK(starts_with(error_of({{"plugin", "ramp"}, {"base", {{"plugin", "cosine"}, {"params", {{"omega", "fast"}}}}}}),
                      "/forcing/base/params/omega:"));
    CHECK(starts_with(error_of({{"plugin", "ramp"}, {"base", {{"plugin", "cosine"}, {"bsae", 1}}}}),
                      "/forcing/base/bsae: unknown key"));
    // Nested composites, but not without end.
    json deep = {{"plugin", "none"}};
    for (int i = 0; i < 10; ++i) deep = {{"plugin", "ramp"}, {"base", deep}};
    CHECK(error_of(deep).find("composite forcings nested more than 8 deep") != std::string::npos);
    // Only forcings have terms.
    json j = experiment_with({{"plugin", "none"}});
    j["system"]["terms"] = json::array();
    CHECK_THROWS_WITH_AS(parse_experiment(j), doctest::Contains("/system/terms: unknown key"), ConfigError);
}

TEST_CASE("path parameters resolve against the experiment's folder, from any working directory") {
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-test-paths-" + std::to_string(::getpid()));
    fs::create_directories(dir / "series");
    std::ofstream(dir / "series" / "f.csv") << "t,f\n0,0\n1,1\n2,0\n";
    json j = experiment_with(json::parse(R"({"plugin": "data", "params": {"file": "series/f.csv"}})"));
    j["time"] = {{"t0", 0}, {"t1", 2}};
    std::ofstream(dir / "exp.json") << j.dump();
    const fs::path before = fs::current_path();
    fs::current_path(fs::temp_directory_path());
    const ResolvedExperiment r = resolve_experiment(load_experiment(dir / "exp.json"));
    fs::current_path(before);
    CHECK(r.forcing(1.0) == 1.0);
    CHECK(r.resolved["forcing"]["params"]["file"] == (dir / "series" / "f.csv").lexically_normal().string());
    fs::remove_all(dir);
}
