// The command-line program end to end: subcommands, exit codes, one-line
// errors, plugin search folders, and a run that writes its files.
#include <doctest/doctest.h>
#include <nlohmann/json.hpp>
#include <test_support.hpp>

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <fstream>

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

struct Result {
    int status;
    std::string output; // stdout and stderr together
};

// Runs the program with a shell, returns its exit status and output.
Result run(const std::string &args, const std::string &env = "") {
    const std::string command = env + " " + geobarrier::test::geobarrier_program().string() + " " + args + " 2>&1";
    FILE *pipe = ::popen(command.c_str(), "r");
    REQUIRE(pipe != nullptr);
    std::string output;
    std::array<char, 4096> buffer;
    while (std::fgets(buffer.data(), buffer.size(), pipe)) output += buffer.data();
    const int raw = ::pclose(pipe);
    return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, output};
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

}  // namespace

TEST_CASE("--version and --help work") {
    const Result v = run("--version");
    CHECK(v.status == 0);
    CHECK(contains(v.output, "geobarrier"));
    CHECK(run("--help").status == 0);
    CHECK(run("no-such-command").status != 0);
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
    // No temporary files are left behind.
    for (const auto &e : fs::directory_iterator(out)) CHECK_MESSAGE(e.path().filename().string()[0] != '.', e.path());
    fs::remove_all(tmp);
}
