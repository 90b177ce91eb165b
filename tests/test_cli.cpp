// The command-line program end to end: subcommands, exit codes, one-line
// errors, plugin search folders, and a run that writes its files.
#include <doctest/doctest.h>
#include <nlohmann/json.hpp>
#include <program_output.hpp>
#include <test_support.hpp>

#include <array>
#include <cstdio>
#include <fstream>

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

using Result = geobarrier::test::CommandResult; // output: stdout and stderr together by default

// Runs the program with a shell, returns its exit status and output (by default stdout and stderr together;
// `streams` "2>/dev/null" keeps stdout alone, "2>&1 >/dev/null" stderr alone).
Result run(const std::string &args, const std::string &env = "", const std::string &streams = "2>&1") {
    const std::string command =
        env + " " + geobarrier::test::geobarrier_program().string() + " " + args + " " + streams;
    return geobarrier::test::run_command(command);
}

bool contains(const std::string &text, const std::string &part) { return text.find(part) != std::string::npos; }

fs::path scratch() {
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-cli-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    return dir;
}

fs::path write_experiment(const fs::path &dir, const std::string &name, const json &j) {
    const fs::path file = dir / name;
    std::ofstream(file) << j.dump(2);
    return file;
}

json tiny_experiment() {
    return json::parse(R"({
      "system":  {"plugin": "duffing"},
      "forcing": {"plugin": "cosine", "params": {"amplitude": 0.08}},
      "grid":    {"x": [-1.5, 1.5], "y": [-1, 1], "n": [16, 11]},
      "time":    {"t0": 0, "t1": 3},
      "products": ["ftle"],
      "output": {"dir": "should-be-overridden", "plots": true}
    })");
}

} // namespace

TEST_CASE("--version and --help work") {
    const Result v = run("--version");
    CHECK(v.status == 0);
    CHECK(contains(v.output, "geobarrier"));
    CHECK(run("--help").status == 0);
    CHECK(run("run --help").status == 0);
}

TEST_CASE("command-line typos exit 2 with one line and a did-you-mean") {
    struct Case {
        const char *args, *expected;
    };
    for (const Case &c :
         {Case{"rnu exp.json", "'rnu' is not a geobarrier command; did you mean 'run'?"},
          Case{"valdiate exp.json", "did you mean 'validate'?"},
          Case{"no-such-command", "'no-such-command' is not a geobarrier command"},
          Case{"run exp.json --quite", "unknown option '--quite' for geobarrier run; did you mean "
                                       "'--quiet'?"},
          Case{"run exp.json --bogus", "unknown option '--bogus' for geobarrier run"},
          Case{"plugins --jsno", "did you mean '--json'?"}, Case{"--verison", "did you mean '--version'?"},
          Case{"check-plugin duffing --t-min -5 --tmax 5", "did you mean '--t-max'?"},
          Case{"run exp.json --threads 0", "--threads"}, Case{"", "subcommand"},
          // Every command's name misspelt, in another case, or cut short.
          Case{"swep s.json", "'swep' is not a geobarrier command; did you mean 'sweep'? (commands: "
                              "run, validate, sweep, plugins, check-plugin)"},
          Case{"check-plugins duffing", "did you mean 'check-plugin'?"}, Case{"plugin", "did you mean 'plugins'?"},
          Case{"RUN exp.json", "did you mean 'run'?"},
          // Every command's options misspelt, and an option of another command.
          Case{"sweep s.json --proceses 2", "unknown option '--proceses' for geobarrier sweep; did "
                                            "you mean '--processes'?"},
          Case{"plugins --json --plugin-pth x", "did you mean '--plugin-path'?"},
          Case{"check-plugin --al", "did you mean '--all'?"},
          Case{"validate exp.json --quiet", "unknown option '--quiet' for geobarrier validate"},
          // Values and arguments missing or too many.
          Case{"run exp.json --out", "--out"}, Case{"run", "file is required"},
          Case{"run exp.json extra.json", "extra.json"}}) {
        const Result r = run(c.args);
        CHECK_MESSAGE(r.status == 2, c.args);
        CHECK_MESSAGE(contains(r.output, "geobarrier: error: "), c.args, r.output);
        CHECK_MESSAGE(contains(r.output, c.expected), c.args, r.output);
        CHECK_MESSAGE(std::count(r.output.begin(), r.output.end(), '\n') == 1, c.args, r.output);
        CHECK_MESSAGE(run(c.args, "", "2>/dev/null").output.empty(), c.args); // nothing on stdout
    }
}

TEST_CASE("warnings go to stderr; stdout holds only the result") {
    const fs::path tmp = scratch();
    json j = tiny_experiment();
    j["integrator"] = {{"method", "dopri5"}, {"rtol", 1e-16}, {"atol", 1e-8}};
    const fs::path file = write_experiment(tmp, "clamped.json", j);
    const Result out = run("validate " + file.string(), "", "2>/dev/null");
    const Result err = run("validate " + file.string(), "", "2>&1 >/dev/null");
    CHECK(out.status == 0);
    CHECK(contains(out.output, "valid"));
    CHECK_FALSE(contains(out.output, "warning"));
    CHECK(contains(err.output, "geobarrier: warning: " + file.string() + ": /integrator/rtol"));
    fs::remove_all(tmp);
}

TEST_CASE("parameter errors name the experiment file as structural errors do") {
    const fs::path tmp = scratch();
    json j = tiny_experiment();
    j["system"]["params"] = {{"alhpa", 1}};
    const fs::path typo = write_experiment(tmp, "typo.json", j);
    for (const std::string &args : {"validate " + typo.string(), "run " + typo.string() + " --quiet"}) {
        const Result r = run(args);
        CHECK(r.status == 2);
        CHECK_MESSAGE(contains(r.output, typo.string() + ": /system/params"), r.output);
    }
    j["system"]["params"] = {{"alpha", "one"}};
    const Result wrong_type = run("validate " + write_experiment(tmp, "type.json", j).string());
    CHECK(wrong_type.status == 2);
    CHECK_MESSAGE(contains(wrong_type.output, "type.json: /system/params/alpha"), wrong_type.output);
    fs::remove_all(tmp);
}

TEST_CASE("plugins finds the built-in plugins with no environment variable") {
    const Result r = run("plugins --json", "env -u GEOBARRIER_PLUGIN_PATH");
    REQUIRE(r.status == 0);
    const json j = json::parse(r.output);
    std::vector<std::string> names;
    for (const auto &p : j["plugins"]) names.push_back(p["name"]);
    for (const char *n : {"duffing", "cosine", "chaotic-map", "none", "linear-saddle"})
        CHECK_MESSAGE(std::find(names.begin(), names.end(), n) != names.end(), n);
    CHECK(std::find(names.begin(), names.end(), "rigid-rotation") == names.end());
    // JSON has no infinity: an unbounded side of a parameter's range is null, never a string.
    std::size_t unbounded = 0;
    for (const auto &p : j["plugins"])
        for (const auto &q : p["params"])
            for (const char *side : {"min", "max"})
                if (q.contains(side)) {
                    CHECK_MESSAGE((q[side].is_number() || q[side].is_null()), p["name"], q["name"], side);
                    unbounded += q[side].is_null();
                }
    CHECK(unbounded > 0);
    const Result text = run("plugins");
    CHECK(contains(text.output, "duffing"));
    CHECK(contains(text.output, "alpha"));
}

TEST_CASE("GEOBARRIER_PLUGIN_PATH and plugin_paths add folders") {
    const std::string dir = geobarrier::test::test_plugin_dir().string();
    CHECK(contains(run("plugins", "GEOBARRIER_PLUGIN_PATH=" + dir).output, "rigid-rotation"));

    const fs::path tmp = scratch();
    json j = tiny_experiment();
    j["system"] = {{"plugin", "rigid-rotation"}};
    j["forcing"] = {{"plugin", "none"}};
    const fs::path without = write_experiment(tmp, "rotation.json", j);
    const Result refused = run("validate " + without.string());
    CHECK(refused.status == 2);
    CHECK(contains(refused.output, "/system/plugin"));
    j["plugin_paths"] = {dir};
    const fs::path with = write_experiment(tmp, "rotation-with-path.json", j);
    const Result accepted = run("validate " + with.string());
    CHECK(accepted.status == 0);
    CHECK(contains(accepted.output, "valid"));
    fs::remove_all(tmp);
}

TEST_CASE("only the libraries an experiment needs are mapped; validate lists them") {
    // Every library of a plugin folder was mapped (its constructors run) for every experiment, validate included
    // (issue 37). A folder holds rigid-rotation and a planted library whose constructor writes a marker file.
    const fs::path tmp = scratch() / "planted";
    fs::create_directories(tmp / "plugins");
    const fs::path rotation = tmp / "plugins" / "geobarrier-rigid-rotation.so";
    fs::copy_file(geobarrier::test::test_plugin_dir() / "geobarrier-rigid-rotation.so", rotation);
    fs::copy_file(geobarrier::test::test_plugin_dir() / "planted" / "geobarrier-planted.so",
                  tmp / "plugins" / "geobarrier-planted.so");
    const fs::path marker = tmp / "marker";
    const std::string env = "GEOBARRIER_TEST_MARKER=" + marker.string();
    json j = tiny_experiment();
    j["system"] = {{"plugin", "rigid-rotation"}};
    j["forcing"] = {{"plugin", "none"}};
    j["plugin_paths"] = {(tmp / "plugins").string()};
    const fs::path file = write_experiment(tmp, "rotation.json", j);

    const Result validated = run("validate " + file.string(), env, "2>/dev/null");
    CHECK(validated.status == 0);
    CHECK_MESSAGE(!fs::exists(marker), "validate ran the planted library's constructor");
    CHECK(contains(validated.output, "  loads " + rotation.string() + " (system 'rigid-rotation'"));
    CHECK(contains(validated.output,
                   "  loads " + (geobarrier::test::plugin_dir() / "geobarrier-none.so").string() + " (forcing 'none'"));
    CHECK_FALSE(contains(validated.output, "geobarrier-planted.so"));
    CHECK_FALSE(contains(validated.output, "geobarrier-duffing.so")); // a built-in the experiment does not use
    const Result ran = run("run " + file.string() + " --out " + (tmp / "out").string() + " --quiet", env);
    CHECK(ran.status == 0);
    CHECK_MESSAGE(!fs::exists(marker), "run ran the planted library's constructor");

    // check-plugin NAME maps what run and validate would (before, every library of the folders).
    const Result checked = run("check-plugin rigid-rotation --plugin-path " + (tmp / "plugins").string(), env);
    CHECK(checked.status == 0);
    CHECK(contains(checked.output, "PASS  system  rigid-rotation"));
    CHECK_MESSAGE(!fs::exists(marker), "check-plugin rigid-rotation ran the planted library's constructor");
    // A name no library is named after is refused, no library mapped (before: every one, with a warning each).
    const Result misspelt = run("check-plugin cosien", env, "2>&1 >/dev/null");
    CHECK(misspelt.status == 2);
    CHECK_MESSAGE(misspelt.output.rfind("geobarrier: error: cosien: no library in the plugin folders is named after "
                                        "'cosien' (looked for geobarrier-cosien.so, libcosien.so, cosien.so in ",
                                        0) == 0,
                  misspelt.output);
    CHECK(contains(misspelt.output, "; did you mean 'cosine'?; a library that declares several plugins is checked by "
                                    "its path: geobarrier check-plugin PATH\n"));
    CHECK(std::count(misspelt.output.begin(), misspelt.output.end(), '\n') == 1);
    const std::string test_plugins = geobarrier::test::test_plugin_dir().string();
    const Result several = run("check-plugin linear-3d --plugin-path " + test_plugins, env, "2>&1 >/dev/null");
    CHECK(several.status == 2);
    CHECK(contains(several.output, "named after 'linear-3d'"));
    CHECK(contains(several.output, " " + test_plugins));
    const Result by_path = run("check-plugin " + test_plugins + "/geobarrier-linear-nd.so", env);
    CHECK(contains(by_path.output, "  linear-3d  "));
    CHECK_MESSAGE(!fs::exists(marker), "check-plugin ran the planted library's constructor");

    // The check is a real one: listing every plugin maps every library (that is its job).
    CHECK(run("plugins --plugin-path " + (tmp / "plugins").string(), env).status == 0);
    CHECK(fs::exists(marker));
    fs::remove_all(tmp);
}

TEST_CASE("a plugin named by no file is searched with a warning per library mapped") {
    // linear-3d lives in geobarrier-linear-nd.so: no file is named after it, so the folders' libraries are mapped one
    // at a time until it is found, with a warning for each that did not hold it (abi-1-1, circular-shear, ...).
    const fs::path tmp = scratch() / "unnamed";
    fs::create_directories(tmp);
    json j = tiny_experiment();
    j["system"] = {{"plugin", "linear-3d"}};
    j["forcing"] = {{"plugin", "none"}};
    j["grid"] = json::parse(R"({"axes": ["x1", "x2"], "x1": [-1, 1], "x2": [-1, 1], "n": [8, 8], "fixed": {"x3": 0}})");
    j["plugin_paths"] = {geobarrier::test::test_plugin_dir().string()};
    const Result r = run("validate " + write_experiment(tmp, "linear.json", j).string());
    CHECK(r.status == 0);
    CHECK(contains(r.output, "while looking for system 'linear-3d'"));
    CHECK(contains(r.output, "name its library geobarrier-linear-3d.so"));
    CHECK(contains(r.output, "geobarrier-linear-nd.so (system 'linear-3d', system 'linear-4d'"));
    fs::remove_all(tmp);
}

TEST_CASE("a folder plugin named like a built-in one is refused unless named by path") {
    // A folder's duffing silently replaced the built-in one (issue 37). Refused before it is mapped; the explicit
    // form is the library's path in "plugin".
    const fs::path tmp = scratch() / "shadow";
    fs::create_directories(tmp / "plugins");
    const fs::path own = tmp / "plugins" / "geobarrier-duffing.so";
    fs::copy_file(geobarrier::test::plugin_dir() / "geobarrier-duffing.so", own);
    json j = tiny_experiment();
    j["plugin_paths"] = {(tmp / "plugins").string()};
    const Result refused = run("validate " + write_experiment(tmp, "shadow.json", j).string());
    CHECK(refused.status == 2);
    CHECK(contains(refused.output, "/system/plugin"));
    CHECK(contains(refused.output, own.string() + " is named like the built-in system 'duffing'"));
    CHECK(std::count(refused.output.begin(), refused.output.end(), '\n') == 1);
    j["system"]["plugin"] = own.string();
    const fs::path file = write_experiment(tmp, "explicit.json", j);
    const Result validated = run("validate " + file.string(), "", "2>/dev/null");
    CHECK(validated.status == 0);
    CHECK(contains(validated.output, "  loads " + own.string() + " (system 'duffing'; named by path)"));
    CHECK_FALSE(contains(validated.output, (geobarrier::test::plugin_dir() / "geobarrier-duffing.so").string()));
    const Result ran = run("run " + file.string() + " --out " + (tmp / "out").string() + " --quiet");
    CHECK(ran.status == 0);
    // A folder library with another file name is not mapped at all: the built-in duffing is used.
    fs::rename(own, tmp / "plugins" / "my-duffing.so");
    j["system"]["plugin"] = "duffing";
    const Result builtin = run("validate " + write_experiment(tmp, "other-name.json", j).string(), "", "2>&1");
    CHECK(builtin.status == 0);
    CHECK(contains(builtin.output, (geobarrier::test::plugin_dir() / "geobarrier-duffing.so").string()));
    CHECK_FALSE(contains(builtin.output, "my-duffing.so"));
    fs::remove_all(tmp);
}

TEST_CASE("validate reports bad input on one line with the JSON path, exit code 2") {
    const fs::path tmp = scratch();
    json j = tiny_experiment();
    j["grid"]["n"] = {16, "eleven"};
    const Result r = run("validate " + write_experiment(tmp, "bad.json", j).string());
    CHECK(r.status == 2);
    CHECK(contains(r.output, "/grid/n"));
    CHECK(std::count(r.output.begin(), r.output.end(), '\n') == 1);
    const Result missing = run("validate " + (tmp / "missing.json").string());
    CHECK(missing.status != 0);
    CHECK(contains(missing.output, "missing.json"));
    fs::remove_all(tmp);
}

TEST_CASE("run writes the outputs to --out, which overrides output.dir") {
    const fs::path tmp = scratch();
    const fs::path file = write_experiment(tmp, "tiny.json", tiny_experiment());
    const fs::path out = tmp / "out";
    const Result r = run("run " + file.string() + " --out " + out.string() + " --threads 2 --quiet");
    CHECK(r.status == 0);
    for (const char *f : {"fields.nc", "ftle.png", "manifest.json"}) CHECK_MESSAGE(fs::exists(out / f), f);
    CHECK_FALSE(fs::exists(tmp / "should-be-overridden"));
    const json m = json::parse(std::ifstream(out / "manifest.json"));
    CHECK(m["threads"] == 2);
    // Provenance: when, where, which build, which plugin files byte for byte (as sha256sum hashes them), and that
    // Duffing's fused step integrated every batch of the default preset's fixed dop853 steps.
    const json &p = m["provenance"];
    CHECK(p["created"].get<std::string>().size() == 20); // 2026-01-31T12:00:00Z
    CHECK(p["created"].get<std::string>().back() == 'Z');
    CHECK_FALSE(p["host"]["cpu"].get<std::string>().empty());
    CHECK(p["host"]["instruction_sets"]["compiled_for"].is_array());
    CHECK_FALSE(p["build"]["commit"].get<std::string>().empty());
    CHECK(contains(p["build"]["flags"].get<std::string>(), "-O"));
    REQUIRE(p["plugin_files"].size() == 2);
    for (const json &f : p["plugin_files"]) {
        FILE *pipe = ::popen(("sha256sum " + f["file"].get<std::string>()).c_str(), "r");
        REQUIRE(pipe != nullptr);
        std::array<char, 65> digest{};
        REQUIRE(std::fgets(digest.data(), digest.size(), pipe) != nullptr);
        ::pclose(pipe);
        CHECK(f["sha256"] == std::string(digest.data()));
    }
    CHECK(p["fused_step"]["plugin_has_one"] == true);
    CHECK(p["fused_step"]["ran"] == true);
    CHECK(p["fused_step"]["batches"] == m["integrator_stats"]["batches"]);
    CHECK(p["extractor_files"] == json::array());
    // No temporary files are left behind.
    for (const auto &e : fs::directory_iterator(out)) CHECK_MESSAGE(e.path().filename().string()[0] != '.', e.path());
    fs::remove_all(tmp);
}

TEST_CASE("the manifest's provenance lists the files the extractors wrote themselves") {
    const fs::path tmp = scratch();
    json j = tiny_experiment();
    j["grid"]["n"] = {41, 31};
    j["time"]["t1"] = 6;
    j["extractors"] = {{{"plugin", "hyperbolic"}}};
    const fs::path out = tmp / "out";
    const Result r =
        run("run " + write_experiment(tmp, "extract.json", j).string() + " --out " + out.string() + " --quiet");
    REQUIRE(r.status == 0);
    const json m = json::parse(std::ifstream(out / "manifest.json"));
    const json listed = m["provenance"]["extractor_files"];
    CHECK(listed == json{"barriers.png", "strainlines.png"}); // the hyperbolic extractor's pictures
    for (const auto &name : listed) CHECK_MESSAGE(fs::exists(out / name.get<std::string>()), name);
    for (const auto &name : m["files"]) CHECK(std::find(listed.begin(), listed.end(), name) == listed.end());
    fs::remove_all(tmp);
}
