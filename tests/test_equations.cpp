// The `equations` system (equations.hpp): the grammar and its messages, the generated source, the exact Jacobian
// (conformance checks against finite differences), the cache (keys, reuse, concurrent compiles, a missing compiler),
// and the paper's Duffing W written as equations against the built-in plugin.
#include <doctest/doctest.h>
#include <test_support.hpp>

#include "equations/equations.hpp"
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/conformance.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>

namespace fs = std::filesystem;
using nlohmann::json;
using namespace geobarrier;

namespace {

// Every test compiles into its own cache folder, named by GEOBARRIER_EQUATIONS_CACHE.
struct ScopedCache {
    fs::path folder;
    explicit ScopedCache(const std::string &name)
        : folder(fs::temp_directory_path() / ("geobarrier-equations-" + name + "-" + std::to_string(::getpid()))) {
        fs::remove_all(folder);
        ::setenv("GEOBARRIER_EQUATIONS_CACHE", folder.c_str(), 1);
    }
    ~ScopedCache() {
        ::unsetenv("GEOBARRIER_EQUATIONS_CACHE");
        fs::remove_all(folder);
    }
    std::size_t files(const std::string &extension) const {
        std::size_t n = 0;
        if (fs::exists(folder))
            for (const auto &e : fs::directory_iterator(folder)) n += e.path().extension() == extension;
        return n;
    }
};

json duffing_params(const std::string &acceleration = "x - x^3 + f") {
    return {{"state", {"x", "y"}}, {"rhs", {"y", acceleration}}};
}

// The message of the ConfigError that define() throws, or "" when it accepts the parameters.
std::string error_of(const json &params) {
    try {
        equations::define(params, "/system/params");
    } catch (const ConfigError &e) {
        return e.what();
    }
    return "";
}

bool contains(const std::string &text, const std::string &part) { return text.find(part) != std::string::npos; }

// Workload W of the bench (the paper's first example): Duffing, 0.08 cos t, T = 8 pi, on an n x n grid.
json workload_w(const json &system, std::size_t n) {
    return {{"system", system},
            {"forcing", {{"plugin", "cosine"}, {"params", {{"amplitude", 0.08}}}}},
            {"grid", {{"x", {-1.8, 1.8}}, {"y", {-1.2, 1.2}}, {"n", {n, n}}}},
            {"time", {{"t0", 0}, {"t1", 25.132741228718345}}},
            {"products", {"ftle"}}};
}

std::vector<double> ftle_of(const json &experiment) {
    const ResolvedExperiment r = resolve_experiment(parse_experiment(experiment));
    const Experiment &e = r.experiment;
    const FlowMap map = compute_grid_flow_map(
        with_grid_offset({Dynamics{&r.system, &r.forcing}, e.t0, e.t1, e.integrator, r.gradient, false, e.bounds},
                         e.grid, e.aux_offset),
        e.grid);
    return cauchy_green_field(e.grid, map.dF, map.mask, std::abs(e.t1 - e.t0), map.dF_exponent, map.log_det).ftle;
}

double max_difference(const std::vector<double> &a, const std::vector<double> &b) {
    REQUIRE(a.size() == b.size());
    double worst = 0.0;
    for (std::size_t k = 0; k < a.size(); ++k) {
        REQUIRE(std::isfinite(a[k]));
        REQUIRE(std::isfinite(b[k]));
        worst = std::max(worst, std::abs(a[k] - b[k]));
    }
    return worst;
}

} // namespace

TEST_CASE("equations: syntax and name errors name the JSON path, the column and what was expected") {
    json p = duffing_params("x - x^3 - dd*y + f");
    p["constants"] = {{"d", 0.1}};
    CHECK(error_of(p) == "/system/params/rhs/1, column 11: unknown name 'dd'; did you mean 'd'?");
    CHECK(contains(error_of(duffing_params("(x + 1")),
                   "/system/params/rhs/1, column 7: expected ')' to close the '(' at column 1"));
    CHECK(contains(error_of(duffing_params("x + 1)")), "rhs/1, column 6: unbalanced ')'"));
    CHECK(contains(error_of(duffing_params("x +")), "column 4: the expression ends early"));
    CHECK(contains(error_of(duffing_params("2 x")), "column 3: expected an operator (+ - * / ^) or the end"));
    CHECK(contains(error_of(duffing_params("x * * y")), "column 5: expected a number, a name or '(', found '*'"));
    CHECK(contains(error_of(duffing_params("sine(x)")), "column 1: 'sine' is not a function; did you mean 'sin'?"));
    CHECK(contains(error_of(duffing_params("sin + x")), "'sin' is a function: write sin(...)"));
    CHECK(contains(error_of(duffing_params("atan2(x)")), "atan2 takes 2 arguments, found 1"));
    CHECK(contains(error_of(duffing_params("sin(x, y)")), "sin takes 1 argument, found 2"));
    CHECK(contains(error_of(duffing_params("")), "/system/params/rhs/1: the expression is empty"));
    CHECK(contains(error_of(duffing_params("1e999 * x")), "column 1: the number 1e999 is outside the range"));
    CHECK(contains(error_of(duffing_params("zeta")), "unknown name 'zeta' (the names here: x, y, t, f, pi)"));
    // Hostile text never gets past the tokenizer, whose alphabet has no quote, semicolon, brace or '#'.
    CHECK(contains(error_of(duffing_params("x); system(\"rm -rf ~\")")), "column 3: unexpected character ';'"));
    CHECK(contains(error_of(duffing_params("#include <cstdlib>")), "column 1: unexpected character '#'"));
    CHECK(contains(error_of(duffing_params("x\n#define y")), "column 2: unexpected control character 0x0A"));
    CHECK(contains(error_of(duffing_params("x \xe2\x88\x92 y")), "column 3: non-ASCII character (byte 0xE2)"));
    // Limits: length and nesting.
    std::string long_sum = "x";
    while (long_sum.size() <= 1000) long_sum += " + x";
    CHECK(contains(error_of(duffing_params(long_sum)), "characters long; at most 1000 are allowed"));
    CHECK(contains(error_of(duffing_params(std::string(40, '(') + "x" + std::string(40, ')'))),
                   "nested deeper than 32 levels"));
    CHECK(contains(error_of(duffing_params(std::string(40, '-') + "x")), "nested deeper than 32 levels"));
    std::string product = "x";
    while (product.size() < 990) product += "*x";
    CHECK(contains(error_of(duffing_params(product)), "too large to compile"));
}

TEST_CASE("equations: names and structure are checked before anything is generated") {
    json p = duffing_params();
    p["state"] = {"x", "y", "z"};
    CHECK(contains(error_of(p), "/system/params/state: give 2 state names"));
    p["state"] = {"t", "y"};
    CHECK(contains(error_of(p), "/system/params/state/0: \"t\" cannot be a name: 't' is reserved for the time"));
    p["state"] = {"x", "y; system(1)"};
    CHECK(contains(error_of(p), "/system/params/state/1:"));
    CHECK(contains(error_of(p), "a name holds only ASCII letters, digits and '_'"));
    p["state"] = {"x", "x"};
    CHECK(contains(error_of(p), "/system/params/state/1: the name 'x' is declared twice"));
    p = duffing_params();
    p["constants"] = {{"d", "0.1"}};
    CHECK(contains(error_of(p), "/system/params/constants/d: \"0.1\" is not a number"));
    p["constants"] = {{"y", 0.1}};
    CHECK(contains(error_of(p), "/system/params/constants/y: the name 'y' is declared twice"));
    p["constants"] = {{"sin", 0.1}};
    CHECK(contains(error_of(p), "'sin' is reserved for a function"));
    p = duffing_params();
    p["rhs"] = {"y"};
    CHECK(contains(error_of(p), "/system/params/rhs: give one expression per state component (2), found 1"));
    p["rhs"] = {"y", 3};
    CHECK(contains(error_of(p), "/system/params/rhs/1: 3 is not a string"));
    p = duffing_params();
    p["constant"] = {{"d", 0.1}};
    CHECK(contains(error_of(p),
                   "/system/params/constant: unknown parameter of system 'equations'; did you mean \"constants\"?"));
    p = duffing_params();
    p.erase("rhs");
    CHECK(contains(error_of(p), "/system/params: missing \"rhs\""));
}

TEST_CASE("equations: the source is generated from the parsed trees, with the exact Jacobian's zeros as literals") {
    json p = {{"state", {"position", "velocity"}},
              {"rhs", {"velocity", "position - position^3 - damping*velocity + 0.1*f"}},
              {"constants", {{"damping", 0.15}}}};
    const equations::Definition d = equations::define(p, "/system/params");
    for (const char *name : {"position", "velocity", "damping"}) CHECK_MESSAGE(!contains(d.source, name), name);
    CHECK(d.uses_forcing);
    CHECK(contains(d.source, "dsdt[0] = s[1];"));
    CHECK(
        contains(d.source, "dsdt[1] = gb_fma(0x1.999999999999ap-4, f, gb_fma(-k0, s[1], (s[0] - gb_ipow<3>(s[0]))));"));
    // d(x')/dx = 0 and d(x')/dy = 1 as literals; d(y')/dx = 1 - 3 x^2; d(y')/dy = -damping.
    CHECK(contains(d.source, "jac[0] = 0x0p+0;"));
    CHECK(contains(d.source, "jac[1] = 0x1p+0;"));
    CHECK(contains(d.source, "jac[2] = gb_fma(-0x1.8p+1, gb_ipow<2>(s[0]), 0x1p+0);"));
    CHECK(contains(d.source, "jac[3] = (-k0);"));
    CHECK(contains(d.source, "return (-k0);")); // the divergence: the trace
    // The same equations under other names and with other constant values are the same source (and cache entry).
    json renamed = {{"state", {"x", "v"}}, {"rhs", {"v", "x - x^3 - d*v + 0.1*f"}}, {"constants", {{"d", 0.5}}}};
    CHECK(equations::define(renamed, "/system/params").source == d.source);
    const equations::Definition unforced = equations::define(duffing_params("x - x^3"), "/system/params");
    CHECK_FALSE(unforced.uses_forcing);
    CHECK(contains(unforced.source, "uses_forcing = false"));
}

TEST_CASE("equations: compiled once into the cache, then loaded from it; constants need no new compile") {
    ScopedCache cache("reuse");
    json p = duffing_params("x - x^3 - d*y + f");
    p["constants"] = {{"d", 0.15}};
    const equations::Compiled first = equations::compile(p, "/system/params");
    CHECK(first.record["cached"] == false);
    CHECK(first.record["compile_seconds"].get<double>() > 0.0);
    const fs::path library = first.record["library"].get<std::string>();
    CHECK(library.parent_path() == cache.folder);
    CHECK(library.stem() == first.record["hash"].get<std::string>());
    CHECK(fs::exists(library));
    CHECK(cache.files(".cpp") == 1);
    CHECK(cache.files(".json") == 1);
    for (const auto &e : fs::directory_iterator(cache.folder))
        CHECK_MESSAGE(e.path().filename().string()[0] != '.', "a temporary file was left: " << e.path());
    CHECK(contains(first.record["compiler"].get<std::string>(), "(")); // path (identity)
    // The loaded plugin carries the experiment's names.
    const PluginInfo &info = first.handle.info;
    CHECK(info.name == "equations");
    CHECK(info.state_names == std::vector<std::string>{"x", "y"});
    REQUIRE(info.params.size() == 1);
    CHECK(info.params[0].name == "d");
    CHECK(info.params[0].default_value == 0.15);
    CHECK(first.values.value(0) == 0.15);

    p["constants"]["d"] = 0.3;
    const equations::Compiled second = equations::compile(p, "/system/params");
    CHECK(second.record["cached"] == true);
    CHECK(second.record["hash"] == first.record["hash"]);
    CHECK(second.values.value(0) == 0.3);
    // The value reaches the plugin: y' = x - x^3 - d y + f at x = 1, y = 2, f = 0.5 is 0.5 - 2 d.
    const System system(second.handle, second.values);
    const double t = 0.0, x[2] = {1.0, 2.0}, f = 0.5;
    double dxdt[2];
    std::int32_t status = 0;
    system.rhs(1, 1, &t, x, &f, dxdt, &status);
    CHECK(dxdt[0] == 2.0);
    CHECK(dxdt[1] == doctest::Approx(0.5 - 0.6).epsilon(1e-15));

    const equations::Compiled other = equations::compile(duffing_params("x - x^3 + 2*f"), "/system/params");
    CHECK(other.record["hash"] != first.record["hash"]);
    CHECK(cache.files(".so") == 2);
}

TEST_CASE("equations: the generated plugin passes check-plugin, every function's derivative included") {
    ScopedCache cache("conformance");
    // Every function of the grammar, on arguments inside its domain for every state (the checks take Runge-Kutta
    // steps from the box [-2, 2]^2, whose stages may leave it).
    json p = {{"state", {"x", "y"}},
              {"rhs",
               {"sin(x)*cos(y) + tan(0.3*tanh(x)) + asin(0.2*tanh(y)) - acos(0.1*tanh(x)) + atan(x*y) + a*sinh(0.5*x) "
                "- cosh(0.3*y) + tanh(x - y) + f*t",
                "exp(0.2*sin(x)) - log(3 + sin(y)) + sqrt(x^2 + 1) + cbrt(x + 5) + abs(y - 0.123) + atan2(y, x^2 + 1) "
                "+ (x^2 + 1)^a + (2 + sin(x))^cos(y) - (y^2 + 1)^-2*0.01 + x/(y^2 + 1) + 2^sin(x) + sign(x)"}},
              {"constants", {{"a", 0.7}}}};
    const equations::Compiled c = equations::compile(p, "/system/params");
    ConformanceOptions options;
    options.params = {{"a", 0.7}};
    const std::vector<ConformanceCheck> checks = check_plugin(c.handle, options);
    for (const ConformanceCheck &check : checks) CHECK_MESSAGE(check.passed, check.name << ": " << check.detail);
    CHECK(all_passed(checks));
}

TEST_CASE("equations: Duffing W written as equations gives the built-in plugin's FTLE to within 1e-8") {
    ScopedCache cache("duffing-w");
    const json builtin = {{"plugin", "duffing"}};
    const json written = {{"plugin", "equations"}, {"params", duffing_params()}};
    // The default integrator (fixed-step dop853 on the variational equations: the SDK's fused step) and the paper's
    // settings (adaptive dopri5 at 1e-6 / 1e-4 with an auxiliary grid).
    const json paper = {{"integrator", {{"method", "dopri5"}, {"rtol", 1e-6}, {"atol", 1e-4}}},
                        {"cauchy_green", {{"method", "auxiliary-grid"}, {"offset", 1e-4}}}};
    for (const json &settings : {json::object(), paper}) {
        CAPTURE(settings.dump());
        json a = workload_w(builtin, 81), b = workload_w(written, 81);
        a.merge_patch(settings);
        b.merge_patch(settings);
        const double difference = max_difference(ftle_of(a), ftle_of(b));
        MESSAGE("W, 81 x 81, " << std::string(settings.empty() ? "default integrator" : "paper settings")
                               << ": largest FTLE difference " << difference);
        CHECK(difference <= 1e-8);
    }
    // The damped oscillator of the paper's second case, with a named constant.
    json damped_builtin = workload_w({{"plugin", "duffing"}, {"params", {{"delta", 0.15}}}}, 61);
    json p = duffing_params("x - x^3 - delta*y + f");
    p["constants"] = {{"delta", 0.15}};
    json damped_written = workload_w({{"plugin", "equations"}, {"params", p}}, 61);
    for (json *j : {&damped_builtin, &damped_written}) (*j)["forcing"]["params"]["amplitude"] = 0.3;
    const double difference = max_difference(ftle_of(damped_builtin), ftle_of(damped_written));
    MESSAGE("damped Duffing, 61 x 61: largest FTLE difference " << difference);
    CHECK(difference <= 1e-8);
}

TEST_CASE("equations: the manifest records the expressions, the hash and the compiler") {
    ScopedCache cache("manifest");
    json j = workload_w({{"plugin", "equations"}, {"params", duffing_params()}}, 11);
    j["output"] = {{"plots", false}};
    const fs::path out = cache.folder / "out";
    RunOptions options;
    options.output_dir = out;
    options.quiet = true;
    run_experiment(resolve_experiment(parse_experiment(j)), options);
    const json m = json::parse(std::ifstream(out / "manifest.json"));
    const json &system = m["resolved"]["system"];
    CHECK(system["plugin"] == "equations");
    CHECK(system["params"]["rhs"] == json({"y", "x - x^3 + f"}));
    CHECK(system["compiled"]["hash"].get<std::string>().size() == 32);
    CHECK(contains(system["compiled"]["compiler"].get<std::string>(), "/"));
    CHECK(system["compiled"].contains("flags"));
}

TEST_CASE("equations: two runs compiling the same equations at once both succeed, and publish one library") {
    ScopedCache cache("concurrent");
    fs::create_directories(cache.folder / "work");
    json j = workload_w({{"plugin", "equations"}, {"params", duffing_params("x - x^3 + 0.5*f")}}, 11);
    std::ofstream(cache.folder / "work" / "exp.json") << j.dump(2);
    const std::string program = test::geobarrier_program().string();
    const std::string command = "cd '" + (cache.folder / "work").string() + "' && (" + program +
                                " validate exp.json >out1.txt 2>&1; echo $? >status1.txt) & (cd '" +
                                (cache.folder / "work").string() + "' && " + program +
                                " validate exp.json >out2.txt 2>&1; echo $? >status2.txt) & wait";
    REQUIRE(std::system(command.c_str()) == 0);
    const auto read = [&](const char *name) {
        std::ifstream in(cache.folder / "work" / name);
        return std::string(std::istreambuf_iterator<char>(in), {});
    };
    CAPTURE(read("out1.txt"));
    CAPTURE(read("out2.txt"));
    CHECK(read("status1.txt") == "0\n");
    CHECK(read("status2.txt") == "0\n");
    CHECK(cache.files(".so") == 1);
    for (const auto &e : fs::directory_iterator(cache.folder))
        CHECK_MESSAGE(e.path().filename().string()[0] != '.', "a temporary file was left: " << e.path());
}

TEST_CASE("equations: no compiler, or a failing one, is a clear error and leaves nothing in the cache") {
    ScopedCache cache("no-compiler");
    ::setenv("GEOBARRIER_EQUATIONS_CXX", "/nonexistent/c++", 1);
    std::string message;
    try {
        equations::compile(duffing_params(), "/system/params");
    } catch (const Error &e) {
        message = e.what();
    }
    CHECK(contains(message, "no C++ compiler at /nonexistent/c++"));
    CHECK(contains(message, "install the Debian package"));
    CHECK(fs::is_empty(cache.folder));

    ::setenv("GEOBARRIER_EQUATIONS_CXX", "/bin/false", 1);
    message.clear();
    try {
        equations::compile(duffing_params(), "/system/params");
    } catch (const Error &e) {
        message = e.what();
    }
    ::unsetenv("GEOBARRIER_EQUATIONS_CXX");
    CHECK(message.rfind("cannot compile the equations system: the C++ compiler /bin/false failed", 0) == 0);
    CHECK(contains(message, "a fault of geobarrier, not of the experiment"));
    CHECK(cache.files(".so") == 0);
    CHECK(cache.files(".log") == 1); // kept for the report the message asks for
}

TEST_CASE(
    "equations: `geobarrier plugins` documents the system, and `check-plugin equations` checks what it compiles") {
    ScopedCache cache("cli");
    fs::create_directories(cache.folder);
    const std::string program = test::geobarrier_program().string(), out = (cache.folder / "out.txt").string();
    const auto output = [&](const std::string &arguments) {
        const int status = std::system((program + " " + arguments + " >" + out + " 2>&1").c_str());
        std::ifstream in(out);
        return std::make_pair(WEXITSTATUS(status), std::string(std::istreambuf_iterator<char>(in), {}));
    };
    const auto [listed, text] = output("plugins");
    CHECK(listed == 0);
    CHECK(contains(text, "equations (built in) - a vector field written in the experiment"));
    CHECK(contains(text, "rhs (array of expressions)"));
    const auto [listed_json, listing] = output("plugins --json");
    CHECK(listed_json == 0);
    CHECK(json::parse(listing)["built_in"][0]["name"] == "equations");
    const auto [checked, table] = output(
        "check-plugin equations --params '{\"state\": [\"x\", \"v\"], \"rhs\": [\"v\", \"-w*sin(x) - c*v + f\"], "
        "\"constants\": {\"w\": 1.5, \"c\": 0.1}}'");
    CAPTURE(table);
    CHECK(checked == 0);
    CHECK(contains(table, "PASS  jacobian_vs_finite_differences"));
    CHECK(contains(table, "PASS  advance_equals_stages"));
    CHECK(contains(table, "PASS  system  equations"));
    const auto [refused, message] = output("check-plugin equations --params '{\"state\": [\"x\", \"v\"], \"rhs\": "
                                           "[\"v\", \"-w*sin(x\"], \"constants\": {\"w\": 1}}'");
    CHECK(refused == 2);
    CHECK(contains(message, "--params/rhs/1, column 9: expected ')' to close the '(' at column 7"));
}

TEST_CASE("equations: a cache folder removed while compiling is called that, not a fault of geobarrier") {
    // A "compiler" that removes the cache folder it was asked to write into (as another program cleaning ~/.cache
    // would, mid-compile), then fails as a real compiler does when its output folder is gone, or succeeds having
    // written nothing. Before, the first read "a fault of geobarrier ... please report it with <folder>/<key>.log",
    // a log that went with the folder.
    ScopedCache cache("removed");
    const fs::path scripts = fs::temp_directory_path() / ("geobarrier-removing-cxx-" + std::to_string(::getpid()));
    fs::create_directories(scripts);
    for (const int exit_code : {1, 0}) {
        CAPTURE(exit_code);
        const fs::path script = scripts / ("cxx-" + std::to_string(exit_code));
        std::ofstream(script) << "#!/bin/sh\nrm -rf \"$GEOBARRIER_EQUATIONS_CACHE\"\nexit " << exit_code << "\n";
        fs::permissions(script, fs::perms::owner_all);
        ::setenv("GEOBARRIER_EQUATIONS_CXX", script.c_str(), 1);
        std::string message;
        try {
            equations::compile(duffing_params(), "/system/params");
        } catch (const IoError &e) {
            message = e.what();
        } catch (const Error &e) {
            message = std::string("not an IoError: ") + e.what();
        }
        ::unsetenv("GEOBARRIER_EQUATIONS_CXX");
        CAPTURE(message);
        CHECK(message.rfind("cannot compile the equations system: the equations cache folder " + cache.folder.string() +
                                " was removed while the compiler was writing into it",
                            0) == 0);
        CHECK_FALSE(contains(message, "fault of geobarrier"));
        CHECK_FALSE(contains(message, ".log"));
        CHECK_FALSE(fs::exists(cache.folder));
    }
    fs::remove_all(scripts);
}

TEST_CASE("equations: a killed compile's temporary files are removed once they are an hour old") {
    ScopedCache cache("stale");
    fs::create_directories(cache.folder);
    const fs::path stale = cache.folder / ".0123-99-0.cpp", recent = cache.folder / ".0123-99-1.cpp";
    std::ofstream(stale) << "x";
    std::ofstream(recent) << "x";
    fs::last_write_time(stale, fs::file_time_type::clock::now() - std::chrono::hours(2));
    ::setenv("GEOBARRIER_EQUATIONS_CXX", "/nonexistent/c++", 1); // the sweep runs before the compiler is started
    CHECK_THROWS_AS(equations::compile(duffing_params(), "/system/params"), Error);
    ::unsetenv("GEOBARRIER_EQUATIONS_CXX");
    CHECK_FALSE(fs::exists(stale));
    CHECK(fs::exists(recent)); // perhaps a compile running now
}

TEST_CASE("equations: a cache folder others could write is refused, naming it and why") {
    ScopedCache cache("private");
    const json p = duffing_params();
    CHECK(equations::compile(p, "/system/params").record["cached"] == false);
    // Created private: only its owner may put a library there.
    CHECK((fs::status(cache.folder).permissions() & (fs::perms::group_write | fs::perms::others_write)) ==
          fs::perms::none);

    const auto refusal = [&](fs::perms mode) {
        fs::permissions(cache.folder, mode);
        std::string message;
        try {
            equations::compile(p, "/system/params");
        } catch (const IoError &e) {
            message = e.what();
        }
        fs::permissions(cache.folder, fs::perms::owner_all);
        return message;
    };
    const std::string world = refusal(fs::perms::all);
    CHECK(contains(world,
                   "the equations cache folder " + cache.folder.string() + " is writable by every user (mode 0777)"));
    CHECK(contains(world, "another user could put a library there that geobarrier would load"));
    CHECK(contains(world, "chmod go-w"));
    CHECK(world.find('\n') == std::string::npos);
    const std::string group = refusal(fs::perms::owner_all | fs::perms::group_all);
    CHECK(contains(group, "is writable by its group (mode 0770)"));
}

TEST_CASE("equations: a truncated library in the cache is refused before it is mapped, and built afresh") {
    // Compiled by another process (this one must not have it mapped: cutting a file short under a live mapping is a
    // SIGBUS of its own), then cut in half as a copy interrupted or a power cut before the write reached the disk.
    ScopedCache cache("truncated");
    fs::create_directories(cache.folder / "work");
    json j = {{"system", {{"plugin", "equations"}, {"params", duffing_params()}}},
              {"forcing", {{"plugin", "cosine"}}},
              {"grid", {{"x", {-1, 1}}, {"y", {-1, 1}}, {"n", {5, 5}}}},
              {"time", {{"t0", 0}, {"t1", 1}}},
              {"products", {"ftle"}}};
    std::ofstream(cache.folder / "work" / "exp.json") << j.dump(2);
    const std::string validate = "cd '" + (cache.folder / "work").string() + "' && " +
                                 test::geobarrier_program().string() + " validate exp.json >/dev/null 2>&1";
    REQUIRE(std::system(validate.c_str()) == 0);
    REQUIRE(cache.files(".so") == 1);
    fs::path library;
    for (const auto &e : fs::directory_iterator(cache.folder))
        if (e.path().extension() == ".so") library = e.path();
    const auto whole = fs::file_size(library);
    fs::resize_file(library, whole / 2);

    const int status = std::system(validate.c_str()); // died of SIGBUS before the check
    CHECK(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 0);
    CHECK(fs::file_size(library) == whole);
    fs::resize_file(library, whole / 3);
    const equations::Compiled again = equations::compile(duffing_params(), "/system/params");
    CHECK(again.record["cached"] == false);
    // Rebuilt whole, not left cut: this process's build of the same source may differ from the program's by a few
    // bytes (16 in the sanitizer build), so not byte for byte, but far from the third it was cut to.
    CHECK(fs::file_size(library) + 4096 >= whole);
}

TEST_CASE("equations: more constants than a plugin may declare are refused before anything is compiled") {
    json p = duffing_params();
    for (std::uint32_t k = 0; k <= max_declared_params; ++k) p["constants"]["c" + std::to_string(k)] = 1.0;
    CHECK(contains(error_of(p), "/system/params/constants: 257 constants; at most 256"));
}
