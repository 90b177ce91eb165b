// The bad-input battery: the geobarrier program is run on malformed, contradictory, hostile and impossible input,
// and each case must end with a non-zero exit code (2 for bad input, 1 for a failed computation), exactly one line
// on stderr that names the problem and where it is, nothing on stdout (--quiet), nothing in the output folder, and
// no signal, core dump or stack trace. The cases are listed in docs/robustness.md.
#include <doctest/doctest.h>
#include <nlohmann/json.hpp>
#include <test_support.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const fs::path bad_plugin_dir = geobarrier::test::test_plugin_dir() / "bad-input";

fs::path scratch() {
    static const fs::path dir = [] {
        const fs::path d = fs::temp_directory_path() / ("geobarrier-bad-input-" + std::to_string(::getpid()));
        fs::remove_all(d);
        fs::create_directories(d);
        return d;
    }();
    return dir;
}

std::string read_file(const fs::path &file) {
    std::ifstream in(file, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// A small, valid experiment that runs in well under a second; each case spoils one thing.
json base_experiment() {
    return json::parse(R"({
      "system":  {"plugin": "duffing", "params": {"alpha": 1, "beta": 1, "delta": 0}},
      "forcing": {"plugin": "cosine", "params": {"amplitude": 0.08}},
      "grid":    {"x": [-1.5, 1.5], "y": [-1, 1], "n": [11, 9]},
      "time":    {"t0": 0, "t1": 2},
      "products": ["ftle"]
    })");
}

struct Case {
    std::string name;
    std::function<std::string()> text; // the experiment file's contents
    int exit_code;                     // 1 or 2
    std::vector<std::string> message;  // each must appear in the one error line
    // Shell words run before the program in the same shell (e.g. "ulimit -f 2;"), and the output folder.
    std::string prefix = "";
    std::string out_dir = ""; // relative to the case's folder; default "out"
};

Case json_case(std::string name, std::function<void(json &)> spoil, int code, std::vector<std::string> message) {
    return Case{std::move(name),
                [spoil] {
                    json j = base_experiment();
                    spoil(j);
                    return j.dump(2);
                },
                code, std::move(message)};
}

Case text_case(std::string name, std::string text, int code, std::vector<std::string> message) {
    return Case{std::move(name), [text] { return text; }, code, std::move(message)};
}

struct Outcome {
    bool exited = false;
    int code = -1;
    int signal = 0;
    std::string out, err;
};

// Runs `geobarrier run exp.json --out OUT --quiet` in `dir` through sh, which execs the program so that the wait
// status is the program's own.
Outcome run_case(const fs::path &dir, const std::string &prefix, const std::string &out_dir) {
    const std::string command = "cd '" + dir.string() + "' && exec >stdout.txt 2>stderr.txt && " + prefix + " exec '" +
                                geobarrier::test::geobarrier_program().string() + "' run exp.json --out '" + out_dir +
                                "' --quiet --threads 2";
    const int raw = std::system(command.c_str());
    Outcome o;
    o.exited = WIFEXITED(raw);
    o.code = o.exited ? WEXITSTATUS(raw) : -1;
    o.signal = WIFSIGNALED(raw) ? WTERMSIG(raw) : 0;
    o.out = read_file(dir / "stdout.txt");
    o.err = read_file(dir / "stderr.txt");
    return o;
}

bool nothing_in(const fs::path &folder) { return !fs::exists(folder) || fs::is_empty(folder); }

bool has_core_file(const fs::path &dir) {
    for (const auto &e : fs::directory_iterator(dir)) {
        const std::string n = e.path().filename().string();
        if (n == "core" || n.rfind("core.", 0) == 0) return true;
    }
    return false;
}

// The checks every case must pass.
void check_outcome(const Case &c, const fs::path &dir, const Outcome &o, const fs::path &out) {
    CAPTURE(c.name);
    CAPTURE(o.err);
    CHECK_MESSAGE(o.exited, "killed by signal " << o.signal);
    CHECK(o.code == c.exit_code);
    CHECK(o.out.empty());
    CHECK(std::count(o.err.begin(), o.err.end(), '\n') == 1);
    CHECK(o.err.rfind("geobarrier: error: ", 0) == 0);
    for (const auto &part : c.message) CHECK_MESSAGE(o.err.find(part) != std::string::npos, "missing: " << part);
    for (const char *noise : {"terminate called", "Aborted", "Segmentation", "what():", "core dumped"})
        CHECK(o.err.find(noise) == std::string::npos);
    CHECK_MESSAGE(nothing_in(out), "the output folder " << out << " is not empty");
    CHECK_FALSE(has_core_file(dir));
}

// The equations system (docs/experiment-format.md, "Equations"), with its cache inside the output folder: the checks
// that nothing is written there also see that nothing was compiled.
Case equations_case(std::string name, json params, std::vector<std::string> message) {
    Case c = json_case(
        std::move(name),
        [params](json &j) {
            j["system"] = {{"plugin", "equations"}, {"params", params}};
        },
        2, std::move(message));
    c.prefix = "GEOBARRIER_EQUATIONS_CACHE=out/equations-cache";
    return c;
}

// base_experiment()'s Duffing with y' written as `acceleration`.
json duffing_equations(const std::string &acceleration) {
    return {{"state", {"x", "y"}}, {"rhs", {"y", acceleration}}, {"constants", {{"d", 0.1}}}};
}

std::vector<Case> equations_battery() {
    std::vector<Case> cases;
    auto add = [&](Case c) { cases.push_back(std::move(c)); };
    add(equations_case("equations: unknown name, with a hint", duffing_equations("x - x^3 - dd*y + f"),
                       {"/system/params/rhs/1, column 11: unknown name 'dd'; did you mean 'd'?"}));
    add(equations_case("equations: an unclosed parenthesis", duffing_equations("(x - x^3 + f"),
                       {"/system/params/rhs/1, column 13", "expected ')' to close the '(' at column 1"}));
    add(equations_case("equations: a parenthesis too many", duffing_equations("x - x^3) + f"),
                       {"/system/params/rhs/1, column 8", "unbalanced ')'"}));
    add(equations_case("equations: code injection after a closing parenthesis",
                       duffing_equations("x); system(\"touch pwned\""),
                       {"rhs/1, column 3", "unexpected character ';'"}));
    add(equations_case("equations: a preprocessor line", duffing_equations("#include <cstdlib>"),
                       {"rhs/1, column 1", "unexpected character '#'"}));
    add(equations_case("equations: a newline and a macro", duffing_equations("x\n#define y system"),
                       {"rhs/1, column 2", "control character 0x0A"}));
    add(equations_case("equations: a state name that is code", {{"state", {"x", "y); abort("}}, {"rhs", {"y", "x"}}},
                       {"/system/params/state/1", "cannot be a name"}));
    add(equations_case("equations: a very long expression", duffing_equations(std::string(3000, 'x')),
                       {"/system/params/rhs/1", "characters long; at most 1000"}));
    std::string product = "x";
    while (product.size() < 990) product += "*x";
    add(equations_case("equations: derivatives too large to compile", duffing_equations(product),
                       {"/system/params/rhs/1", "too large to compile"}));
    add(equations_case("equations: deeply nested",
                       duffing_equations(std::string(200, '(') + "x" + std::string(200, ')')),
                       {"rhs/1, column 33", "nested deeper than 32 levels"}));
    add(equations_case("equations: non-ASCII (a Unicode minus sign)", duffing_equations("x \xe2\x88\x92 x^3"),
                       {"rhs/1, column 3", "non-ASCII character (byte 0xE2)"}));
    add(equations_case("equations: a function that is not in the list", duffing_equations("system(x)"),
                       {"rhs/1, column 1", "'system' is not a function"}));
    add(equations_case("equations: three state components", {{"state", {"x", "y", "z"}}, {"rhs", {"y", "x", "z"}}},
                       {"/system/params/state", "give 2 state names"}));
    add(equations_case("equations: a constant given as text",
                       {{"state", {"x", "y"}}, {"rhs", {"y", "-d*x"}}, {"constants", {{"d", "0.1"}}}},
                       {"/system/params/constants/d", "is not a number"}));
    return cases;
}

// The file itself: not JSON, not an object, not there.
std::vector<Case> file_battery() {
    std::vector<Case> cases;
    auto add = [&](Case c) { cases.push_back(std::move(c)); };
    add(text_case("malformed JSON (a missing comma)", "{\n  \"system\": {\"plugin\": \"duffing\"}\n  \"grid\": {}\n}\n",
                  2, {"exp.json:3:", "not valid JSON"}));
    add(text_case("truncated JSON", "{\"system\": {\"plugin\": \"duff", 2, {"exp.json:1:", "not valid JSON"}));
    add(text_case("an empty file", "", 2, {"exp.json:1:1", "not valid JSON"}));
    add(text_case("binary garbage",
                  std::string("\x7f"
                              "ELF\x02\x01\x01\0\0\xff\xfe",
                              12),
                  2, {"exp.json:1:", "not valid JSON"}));
    add(text_case("a NaN literal", R"({"time": {"t0": NaN}})", 2, {"exp.json:1:", "not valid JSON"}));
    add(text_case("an array, not an object", "[1, 2, 3]", 2, {"exp.json: /:", "expected an object"}));
    add(text_case("100000 nested arrays", std::string(100000, '[') + std::string(100000, ']'), 2,
                  {"exp.json", "nested deeper than 64 levels"}));
    {
        Case c = text_case("the experiment file is missing", "{}", 1, {"exp.json", "cannot open"});
        c.prefix = "rm exp.json;";
        add(c);
    }
    {
        Case c = text_case("the experiment file is a folder", "{}", 1, {"exp.json", "is a folder"});
        c.prefix = "rm exp.json && mkdir exp.json;";
        add(c);
    }
    return cases;
}

// Structure and types: missing keys, wrong types, unknown keys and products.
std::vector<Case> structure_battery() {
    std::vector<Case> cases;
    auto add = [&](Case c) { cases.push_back(std::move(c)); };
    add(json_case("missing system", [](json &j) { j.erase("system"); }, 2, {"missing required key \"system\""}));
    add(json_case("missing grid", [](json &j) { j.erase("grid"); }, 2, {"missing required key \"grid\""}));
    add(json_case("missing time/t1", [](json &j) { j["time"].erase("t1"); }, 2, {"/time", "\"t1\""}));
    add(json_case("wrong type: grid/n holds a string",
                  [](json &j) {
                      j["grid"]["n"] = {11, "nine"};
                  },
                  2, {"/grid/n", "two integers"}));
    add(json_case("wrong type: t0 is a string", [](json &j) { j["time"]["t0"] = "zero"; }, 2,
                  {"/time/t0", "expected a number"}));
    add(json_case("wrong type: products is a string", [](json &j) { j["products"] = "ftle"; }, 2, {"/products"}));
    add(json_case("wrong type: plugin parameter", [](json &j) { j["system"]["params"]["alpha"] = "one"; }, 2,
                  {"/system/params/alpha"}));
    add(json_case("unknown top-level key, with a hint", [](json &j) { j["integrater"] = json::object(); }, 2,
                  {"/integrater", "did you mean \"integrator\""}));
    add(json_case("unknown integrator key, with a hint",
                  [](json &j) {
                      j["integrator"] = {{"rtoll", 1e-6}};
                  },
                  2, {"/integrator/rtoll", "did you mean \"rtol\""}));
    add(json_case("unknown plugin parameter, with a hint", [](json &j) { j["system"]["params"]["alpah"] = 1; }, 2,
                  {"/system/params", "alpah", "alpha"}));
    add(json_case("unknown product, with a hint", [](json &j) { j["products"] = {"ftel"}; }, 2,
                  {"/products/0", "did you mean \"ftle\""}));
    add(json_case("nothing to compute", [](json &j) { j["products"] = json::array(); }, 2, {"/products"}));
    return cases;
}

// Values outside their rules: non-finite numbers, empty boxes and grids, tolerances, steps, offsets.
std::vector<Case> values_battery() {
    std::vector<Case> cases;
    auto add = [&](Case c) { cases.push_back(std::move(c)); };
    add(json_case("parameter outside the schema's range",
                  [](json &j) {
                      j["system"] = {{"plugin", "pendulum"}, {"params", {{"omega0", -1.0}}}};
                  },
                  2, {"/system/params/omega0", "-1"}));
    // JSON has no NaN or Infinity; a number beyond the double range is the way to write one.
    const std::string base_text = base_experiment().dump(2);
    auto replaced = [&](const std::string &from, const std::string &to) {
        std::string t = base_text;
        t.replace(t.find(from), from.size(), to);
        return t;
    };
    add(text_case("infinite number (t1 = 1e999)", replaced("\"t1\": 2", "\"t1\": 1e999"), 2,
                  {"exp.json:", "1e999", "beyond the range of a double"}));
    add(text_case("infinite plugin parameter (alpha = -1e999)", replaced("\"alpha\": 1", "\"alpha\": -1e999"), 2,
                  {"exp.json:", "-1e999", "beyond the range of a double"}));
    add(text_case("infinite grid bound (x = [-1.5, 1e400])", replaced("1.5\n", "1e400\n"), 2, {"exp.json:", "1e400"}));
    add(json_case("t0 = t1", [](json &j) { j["time"]["t1"] = 0; }, 2, {"/time/t1", "nonzero length"}));
    add(json_case("empty box: x[0] > x[1]",
                  [](json &j) {
                      j["grid"]["x"] = {1.5, -1.5};
                  },
                  2, {"/grid/x", "min < max"}));
    add(json_case("empty box: y[0] = y[1]", [](json &j) { j["grid"]["y"] = {1, 1}; }, 2, {"/grid/y", "min < max"}));
    add(json_case("grid of 2 points in x",
                  [](json &j) {
                      j["grid"]["n"] = {2, 9};
                  },
                  2, {"/grid/n/0", "between 3 and 100000"}));
    add(json_case("negative grid size", [](json &j) { j["grid"]["n"] = {11, -9}; }, 2, {"/grid/n/1"}));
    add(json_case("fractional grid size", [](json &j) { j["grid"]["n"] = {10.5, 9}; }, 2, {"/grid/n"}));
    add(json_case("grid larger than the machine's memory",
                  [](json &j) {
                      j["grid"]["n"] = {100000, 100000};
                  },
                  2, {"/grid/n", "100000 x 100000", "needs about", "available"}));
    add(json_case("rtol = 0", [](json &j) { j["integrator"] = {{"rtol", 0}}; }, 2, {"/integrator/rtol"}));
    add(json_case("rtol = 1", [](json &j) { j["integrator"] = {{"rtol", 1}}; }, 2, {"/integrator/rtol", "below 1"}));
    add(json_case("negative rtol", [](json &j) { j["integrator"] = {{"rtol", -1e-6}}; }, 2, {"/integrator/rtol"}));
    add(json_case("atol = 0", [](json &j) { j["integrator"] = {{"atol", 0}}; }, 2, {"/integrator/atol"}));
    add(json_case("negative step", [](json &j) { j["integrator"] = {{"step", -0.1}}; }, 2, {"/integrator/step"}));
    add(json_case("max_steps = 0",
                  [](json &j) {
                      j["integrator"] = {{"max_steps", 0}};
                  },
                  2, {"/integrator/max_steps"}));
    add(json_case("batch = 0", [](json &j) { j["integrator"] = {{"batch", 0}}; }, 2, {"/integrator/batch"}));
    add(json_case("rk4 without a step",
                  [](json &j) {
                      j["integrator"] = {{"method", "rk4"}};
                  },
                  2, {"/integrator", "step"}));
    add(json_case("unknown integrator method, with a hint",
                  [](json &j) {
                      j["integrator"] = {{"method", "rosenbrok4"}};
                  },
                  2, {"/integrator/method", "did you mean \"rosenbrock4\""}));
    add(json_case("auxiliary offset above 0.5",
                  [](json &j) {
                      j["cauchy_green"] = {{"offset", 0.7}};
                  },
                  2, {"/cauchy_green/offset"}));
    add(json_case("empty output folder name", [](json &j) { j["output"] = {{"dir", ""}}; }, 2, {"/output/dir"}));
    add(json_case("plugin_paths holds a number", [](json &j) { j["plugin_paths"] = {3}; }, 2, {"/plugin_paths/0"}));
    return cases;
}

// A folder holding one plugin library cut in half (a copy interrupted, a full disk): the loader would map its missing
// half and die of SIGBUS on the first touch; it is refused before it is mapped (core/src/plugins/library_check.hpp).
fs::path truncated_library_folder() {
    static const fs::path folder = [] {
        const fs::path f = scratch() / "truncated-plugins";
        fs::create_directories(f);
        const std::string whole = read_file(geobarrier::test::plugin_dir() / "geobarrier-duffing.so");
        std::ofstream(f / "geobarrier-duffing.so", std::ios::binary) << whole.substr(0, whole.size() / 2);
        return f;
    }();
    return folder;
}

// Plugins: unknown, of another ABI, not a library, cut short, failing, declaring too much, without the Jacobian a
// setting needs.
std::vector<Case> plugin_battery() {
    const std::string nan_lib = (bad_plugin_dir / "geobarrier-bad-input.so").string();
    const std::string throwing_entry = (bad_plugin_dir / "entry-throws" / "geobarrier-entry-throws.so").string();
    const std::string wrong_abi = (geobarrier::test::test_plugin_dir() / "geobarrier-wrong-abi.so").string();
    const std::string not_a_library = (geobarrier::test::test_plugin_dir() / "not-a-plugin.so").string();
    std::vector<Case> cases;
    auto add = [&](Case c) { cases.push_back(std::move(c)); };
    add(json_case("unknown plugin, listing the known ones", [](json &j) { j["system"]["plugin"] = "dufing"; }, 2,
                  {"/system/plugin", "dufing", "duffing"}));
    add(json_case("a plugin of another ABI major version",
                  [wrong_abi](json &j) {
                      j["forcing"] = {{"plugin", wrong_abi}};
                  },
                  2, {"/forcing/plugin", "geobarrier-wrong-abi.so", "ABI 2.", "ABI 1."}));
    add(json_case("a file that is not a shared library",
                  [not_a_library](json &j) {
                      j["system"] = {{"plugin", not_a_library}};
                  },
                  2, {"/system/plugin", "not-a-plugin.so", "not a loadable shared library"}));
    const std::string truncated = (truncated_library_folder() / "geobarrier-duffing.so").string();
    add(json_case("a truncated library in a plugin folder",
                  [](json &j) { j["plugin_paths"] = {truncated_library_folder().string()}; }, 2,
                  {truncated, "not a loadable shared library (truncated: its loadable segment"}));
    add(json_case("a truncated library named by path",
                  [truncated](json &j) {
                      j["system"] = {{"plugin", truncated}};
                  },
                  2, {"/system/plugin", truncated, "truncated"}));
    const std::string huge =
        (geobarrier::test::test_plugin_dir() / "declared-limits" / "geobarrier-declared-dimension.so").string();
    add(json_case("a plugin declaring dimension 2^32 - 1",
                  [huge](json &j) {
                      j["system"] = {{"plugin", huge}};
                  },
                  2, {"/system/plugin", huge, "declares dimension 4294967295; a plugin may declare at most 64"}));
    add(json_case("a plugin whose entry function throws",
                  [throwing_entry](json &j) {
                      j["system"] = {{"plugin", throwing_entry}};
                  },
                  2, {"/system/plugin", "geobarrier-entry-throws.so", "deliberate failure in the plugin entry"}));
    add(json_case("a plugin whose factory throws",
                  [nan_lib](json &j) {
                      j["system"] = {{"plugin", "throwing-factory"}};
                      j["plugin_paths"] = {fs::path(nan_lib).parent_path().string()};
                  },
                  1, {"throwing-factory", "deliberate failure in the factory"}));
    add(json_case("a plugin whose right-hand side throws",
                  [nan_lib](json &j) {
                      j["system"] = {{"plugin", "throwing-system"}};
                      j["plugin_paths"] = {fs::path(nan_lib).parent_path().string()};
                  },
                  1, {"throwing-system", "deliberate failure in rhs"}));
    add(json_case("a system that returns NaN everywhere",
                  [nan_lib](json &j) {
                      j["system"] = {{"plugin", "nan-system"}};
                      j["plugin_paths"] = {fs::path(nan_lib).parent_path().string()};
                      j["cauchy_green"] = {{"method", "auxiliary-grid"}};
                  },
                  1, {"every one of the 99 grid points was masked", "non-finite"}));
    add(json_case("a forcing that returns NaN everywhere",
                  [nan_lib](json &j) {
                      j["system"] = {{"plugin", "forced-oscillator"}};
                      j["forcing"] = {{"plugin", "nan-forcing"}};
                      j["plugin_paths"] = {fs::path(nan_lib).parent_path().string()};
                  },
                  1, {"every one of the 99 grid points was masked", "non-finite"}));
    add(json_case("rosenbrock4 for a system without a Jacobian",
                  [nan_lib](json &j) {
                      j["system"] = {{"plugin", "forced-oscillator"}};
                      j["plugin_paths"] = {fs::path(nan_lib).parent_path().string()};
                      j["integrator"] = {{"method", "rosenbrock4"}};
                  },
                  2, {"/integrator/method", "rosenbrock4", "Jacobian"}));
    add(json_case("variational gradient for a system without a Jacobian",
                  [nan_lib](json &j) {
                      j["system"] = {{"plugin", "forced-oscillator"}};
                      j["plugin_paths"] = {fs::path(nan_lib).parent_path().string()};
                      j["cauchy_green"] = {{"method", "variational"}};
                  },
                  2, {"/cauchy_green/method", "Jacobian"}));
    return cases;
}

// Computations that cannot give an answer (exit 1).
std::vector<Case> computation_battery() {
    std::vector<Case> cases;
    auto add = [&](Case c) { cases.push_back(std::move(c)); };
    add(json_case("bounds that exclude the whole grid",
                  [](json &j) {
                      j["bounds"] = {{"x", {5, 6}}, {"y", {5, 6}}};
                  },
                  2, {"/bounds", "holds no point of the grid"}));
    add(json_case("every trajectory blows up (beta < 0, huge forcing)",
                  [](json &j) {
                      j["system"]["params"] = {{"alpha", 1}, {"beta", -1}, {"delta", 0}};
                      j["forcing"]["params"] = {{"amplitude", 1e6}};
                      j["time"]["t1"] = 20;
                  },
                  1, {"every one of the 99 grid points was masked", "blew up"}));
    add(json_case("a stiff system for an explicit stepper (step limit)",
                  [](json &j) {
                      j["system"]["params"] = {{"alpha", 1}, {"beta", 1}, {"delta", 1000}};
                      j["grid"]["n"] = {3, 3};
                      j["time"]["t1"] = 4000;
                      j["integrator"] = {{"method", "dopri5"}, {"batch", 9}};
                  },
                  1, {"every one of the 9 grid points was masked", "dopri5 reached its step limit", "rosenbrock4"}));
    return cases;
}

// Where the output goes: a folder that cannot be created or written, a full disk.
std::vector<Case> output_battery() {
    std::vector<Case> cases;
    auto add = [&](Case c) { cases.push_back(std::move(c)); };
    {
        Case c =
            json_case("an output folder below a regular file", [](json &) {}, 1, {"cannot create the output folder"});
        c.prefix = "touch blocker;";
        c.out_dir = "blocker/out";
        add(c);
    }
    {
        Case c = json_case("an output folder on a read-only file system (/proc)", [](json &) {}, 1,
                           {"/proc/geobarrier-out", "output folder"});
        c.out_dir = "/proc/geobarrier-out";
        add(c);
    }
    {
        // A full disk, simulated with a file-size limit (RLIMIT_FSIZE, 2 x 512 bytes in sh): writes past it fail
        // with EFBIG once the program ignores SIGXFSZ, as it does.
        Case c = json_case("a full disk (file-size limit of 1 KiB)",
                           [](json &j) {
                               j["grid"]["n"] = {101, 81};
                           },
                           1, {"fields.nc", "files are limited to 1.0 KiB (ulimit -f)"});
        c.prefix = "ulimit -f 2;";
        add(c);
    }
    return cases;
}

// Systems of more than two state components: grids over slices (docs/experiment-format.md, grids as slices).
std::vector<Case> slice_battery() {
    const std::string nan_lib = (bad_plugin_dir / "geobarrier-bad-input.so").string();
    std::vector<Case> cases;
    auto add = [&](Case c) { cases.push_back(std::move(c)); };
    const auto coupled = [](json &j) {
        j["system"] = {{"plugin", "coupled-duffing"}};
        j["grid"] = {{"axes", {"x1", "v1"}},
                     {"x1", {-1.5, 1.5}},
                     {"v1", {-1, 1}},
                     {"n", {11, 9}},
                     {"fixed", {{"x2", 0}, {"v2", 0}}}};
    };
    add(json_case("slice: an axis names an unknown component, with a hint",
                  [coupled](json &j) {
                      coupled(j);
                      j["grid"]["axes"] = {"x1", "v3"};
                      j["grid"].erase("v1");
                      j["grid"]["v3"] = {-1, 1};
                  },
                  2, {"/grid/axes/1", "\"v3\" is not a state component", "x1 v1 x2 v2"}));
    add(json_case("slice: a fixed component that is a grid axis",
                  [coupled](json &j) {
                      coupled(j);
                      j["grid"]["fixed"]["x1"] = 0.5;
                  },
                  2, {"/grid/fixed/x1", "axis of the grid"}));
    add(json_case("slice: a component neither on an axis nor fixed",
                  [coupled](json &j) {
                      coupled(j);
                      j["grid"]["fixed"].erase("v2");
                  },
                  2, {"/grid/fixed", "\"v2\"", "on an axis or fixed"}));
    add(json_case("slice: a fixed component the system does not have",
                  [coupled](json &j) {
                      coupled(j);
                      j["grid"]["fixed"]["y9"] = 0;
                  },
                  2, {"/grid/fixed/y9", "not a state component"}));
    add(json_case("a four-dimensional system on a planar grid (no axes)",
                  [](json &j) {
                      j["system"] = {{"plugin", "coupled-duffing"}};
                  },
                  2, {"/grid", "4 state components", "\"axes\""}));
    add(json_case("slice: the full tensor has no eigenvectors on the slice",
                  [coupled](json &j) {
                      coupled(j);
                      j["products"] = {"ftle", "eigenvectors"};
                  },
                  2, {"/cauchy_green/slice_tensor", "\"eigenvectors\"", "\"restricted\""}));
    add(json_case("slice: an extractor with the restricted tensor",
                  [coupled](json &j) {
                      coupled(j);
                      j["cauchy_green"] = {{"slice_tensor", "restricted"}};
                      j["extractors"] = {{{"plugin", "hyperbolic"}}};
                  },
                  2, {"/extractors/0", "two-dimensional flow map", "\"projected\""}));
    add(json_case("a system of dimension 7, over the engine's limit",
                  [nan_lib](json &j) {
                      j["system"] = {{"plugin", "seven-dimensional"}};
                      j["plugin_paths"] = {fs::path(nan_lib).parent_path().string()};
                  },
                  2, {"/system/plugin", "dimension 7", "2 to 6"}));
    return cases;
}

std::vector<Case> battery() {
    std::vector<Case> cases;
    for (auto section : {file_battery, structure_battery, values_battery, plugin_battery, slice_battery,
                         computation_battery, output_battery, equations_battery})
        for (Case &c : section()) cases.push_back(std::move(c));
    return cases;
}

} // namespace

TEST_CASE("bad-input battery: exit code, one line naming the problem and where, nothing written") {
    const std::vector<Case> cases = battery();
    std::size_t index = 0;
    for (const Case &c : cases) {
        const fs::path dir = scratch() / ("case-" + std::to_string(index++));
        fs::create_directories(dir);
        std::ofstream(dir / "exp.json", std::ios::binary) << c.text();
        const std::string out_dir = c.out_dir.empty() ? "out" : c.out_dir;
        const Outcome o = run_case(dir, c.prefix, out_dir);
        const fs::path out = fs::path(out_dir).is_absolute() ? fs::path(out_dir) : dir / out_dir;
        check_outcome(c, dir, o, out);
    }
    MESSAGE(cases.size() << " bad inputs tried through the program");
    CHECK(cases.size() >= 50);
}

TEST_CASE("a truncated library in a plugin folder: every command exits 2 naming it, none dies of a signal") {
    // Before the check, each of these died of SIGBUS (exit 135) with no message: dlopen mapped the missing half.
    const fs::path dir = scratch() / "truncated-commands";
    fs::create_directories(dir);
    const std::string folder = truncated_library_folder().string(),
                      library = (truncated_library_folder() / "geobarrier-duffing.so").string();
    json j = base_experiment();
    j["plugin_paths"] = {folder};
    std::ofstream(dir / "exp.json") << j.dump(2);
    const std::string program = geobarrier::test::geobarrier_program().string();
    for (const std::string &command : {program + " validate exp.json", program + " run exp.json --out out --quiet",
                                       program + " plugins --plugin-path '" + folder + "'",
                                       program + " plugins --json --plugin-path '" + folder + "'",
                                       program + " check-plugin --all --plugin-path '" + folder + "'",
                                       "GEOBARRIER_PLUGIN_PATH='" + folder + "' " + program + " plugins"}) {
        CAPTURE(command);
        const int raw = std::system(("cd '" + dir.string() + "' && " + command + " >stdout.txt 2>stderr.txt").c_str());
        const std::string err = read_file(dir / "stderr.txt");
        CAPTURE(err);
        CHECK(WIFEXITED(raw));
        CHECK(WEXITSTATUS(raw) == 2);
        CHECK(read_file(dir / "stdout.txt").empty());
        CHECK(std::count(err.begin(), err.end(), '\n') == 1);
        CHECK(err.rfind("geobarrier: error: " + library + ": not a loadable shared library (truncated: ", 0) == 0);
        CHECK_FALSE(fs::exists(dir / "out"));
    }
}

TEST_CASE("bad-input battery: a really full disk (a 64 KiB tmpfs in a user namespace), where unshare allows it") {
    if (std::system("unshare -r -m true >/dev/null 2>&1") != 0) {
        MESSAGE("skipped: unshare -r -m (an unprivileged user and mount namespace) is not available here");
        return;
    }
    const fs::path dir = scratch() / "tmpfs";
    fs::create_directories(dir / "out");
    json j = base_experiment();
    j["grid"]["n"] = {301, 201}; // fields.nc alone is larger than 64 KiB
    std::ofstream(dir / "exp.json") << j.dump(2);
    // The mount lives in the namespace, so the listing of the folder is taken there, before it goes away.
    const std::string command =
        "cd '" + dir.string() + "' && unshare -r -m sh -c 'mount -t tmpfs -o size=64k tmpfs out && " +
        geobarrier::test::geobarrier_program().string() +
        " run exp.json --out out --quiet >stdout.txt 2>stderr.txt; echo $? >status.txt; ls -A out >listing.txt'";
    REQUIRE(std::system(command.c_str()) == 0);
    const std::string status = read_file(dir / "status.txt"), err = read_file(dir / "stderr.txt");
    CAPTURE(err);
    CHECK(status == "1\n");
    CHECK(std::count(err.begin(), err.end(), '\n') == 1);
    CHECK(err.find("fields.nc") != std::string::npos);
    CHECK(err.find("its file system has") != std::string::npos); // HDF5 says only "HDF error": the hint says why
    CHECK(read_file(dir / "listing.txt").empty());
    CHECK(read_file(dir / "stdout.txt").empty());
}

TEST_CASE("a disk full before fields.nc is created reads as a full disk; a failed sweep member says why, where unshare "
          "allows it") {
    // NetCDF answers every failure of HDF5's file creation with EACCES: a disk full at creation read "Permission
    // denied". A sweep member's message went only to its log, on the same full disk: its reason was empty.
    if (std::system("unshare -r -m true >/dev/null 2>&1") != 0) {
        MESSAGE("skipped: unshare -r -m (an unprivileged user and mount namespace) is not available here");
        return;
    }
    const fs::path dir = scratch() / "full-at-creation";
    fs::create_directories(dir / "out");
    std::ofstream(dir / "exp.json") << base_experiment().dump(2);
    const json sweep = {{"base", base_experiment()},
                        {"parameters", {{{"path", "/forcing/params/amplitude"}, {"values", {0.08}}}}},
                        {"processes", 1},
                        {"threads", 1}};
    std::ofstream(dir / "sweep.json") << sweep.dump(2);
    const std::string program = geobarrier::test::geobarrier_program().string();
    // A 64 KiB tmpfs filled up by a file of ours first; empty files and folders still fit (they take no blocks).
    const std::string command =
        "cd '" + dir.string() + "' && unshare -r -m sh -c 'mount -t tmpfs -o size=64k tmpfs out && " +
        "(head -c 70000 /dev/zero >out/filler 2>/dev/null; true) && " + program +
        " run exp.json --out out/run --quiet >run.stdout 2>run.stderr; echo $? >run.status; " + program +
        " sweep sweep.json --out out/sweep --quiet >sweep.stdout 2>sweep.stderr; echo $? >sweep.status'";
    REQUIRE(std::system(command.c_str()) == 0);
    const std::string err = read_file(dir / "run.stderr");
    CAPTURE(err);
    CHECK(read_file(dir / "run.status") == "1\n");
    CHECK(std::count(err.begin(), err.end(), '\n') == 1);
    CHECK(err.rfind("geobarrier: error: 'out/run/fields.nc': cannot create the NetCDF-4 file: No space left on device "
                    "(the file system is full)",
                    0) == 0);
    CHECK(err.find("Permission denied") == std::string::npos);

    const std::string sweep_err = read_file(dir / "sweep.stderr");
    CAPTURE(sweep_err);
    CHECK(read_file(dir / "sweep.status") == "1\n");
    // The member's own message, through its pipe to the sweep: its log is empty on the full disk.
    CHECK(sweep_err.find("failed, exit 1: 'out/sweep/member-000/fields.nc': cannot create the NetCDF-4 file: No "
                         "space left on device") != std::string::npos);
}

TEST_CASE("an interrupted earlier run and a failed later run leave a finished run untouched") {
    // A finished run, then a run into the same folder that fails while computing: the first run's files (and its
    // manifest) stay as they were, and nothing of the failed run appears.
    const fs::path dir = scratch() / "keep";
    fs::create_directories(dir);
    std::ofstream(dir / "exp.json") << base_experiment().dump(2);
    REQUIRE(run_case(dir, "", "out").code == 0);
    const std::string manifest = read_file(dir / "out" / "manifest.json"),
                      fields = read_file(dir / "out" / "fields.nc");
    REQUIRE_FALSE(manifest.empty());
    json j = base_experiment(); // every trajectory blows up: the run fails after it has started computing
    j["system"]["params"] = {{"alpha", 1}, {"beta", -1}, {"delta", 0}};
    j["forcing"]["params"] = {{"amplitude", 1e6}};
    j["time"]["t1"] = 20;
    std::ofstream(dir / "exp.json") << j.dump(2);
    const Outcome o = run_case(dir, "", "out");
    CHECK(o.code == 1);
    CHECK(read_file(dir / "out" / "manifest.json") == manifest);
    CHECK(read_file(dir / "out" / "fields.nc") == fields);
    std::size_t entries = 0;
    for (const auto &e : fs::directory_iterator(dir / "out")) {
        CHECK_MESSAGE(e.path().filename().string()[0] != '.', e.path()); // no staging folder left behind
        ++entries;
    }
    CHECK(entries == 3); // fields.nc, ftle.png, manifest.json
    fs::remove_all(scratch());
}
