// Loading plugins: good ones are found and described, bad files are refused
// with one line naming the file and the reason, parameters are validated
// against schemas, and a plugin library outlives the registry that loaded it.
#include <geobarrier/errors.hpp>
#include <geobarrier/plugin.hpp>

#include <doctest/doctest.h>
#include <test_support.hpp>

#include <algorithm>
#include <functional>
#include <optional>

using namespace geobarrier;
using nlohmann::json;

namespace {
std::string error_of(const std::function<void()> &f) {
    try {
        f();
    } catch (const std::exception &e) {
        return e.what();
    }
    return "";
}
bool contains(const std::string &text, const std::string &part) { return text.find(part) != std::string::npos; }
} // namespace

TEST_CASE("the built-in plugins are found with their schemas") {
    const PluginRegistry registry({test::plugin_dir()});
    std::vector<std::string> names;
    for (const auto &h : registry.plugins()) names.push_back(std::string(to_string(h.info.kind)) + "/" + h.info.name);
    for (const char *expected :
         {"system/duffing", "system/linear-saddle", "forcing/none", "forcing/cosine", "forcing/chaotic-map"})
        CHECK_MESSAGE(std::find(names.begin(), names.end(), expected) != names.end(), expected);
    CHECK(registry.warnings().empty());

    const PluginHandle &duffing = registry.find(PluginKind::system, "duffing", "/system/plugin");
    CHECK(duffing.info.dimension == 2);
    CHECK(duffing.info.has_jacobian);
    CHECK(duffing.info.has_divergence);
    CHECK(duffing.info.uses_forcing);
    CHECK(duffing.info.abi_major == GB_ABI_VERSION_MAJOR);
    const json schema = plugin_info_to_json(duffing.info);
    REQUIRE(schema["params"].size() == 3);
    CHECK(schema["params"][0]["name"] == "alpha");
    CHECK(schema["params"][0]["default"] == 1.0);
}

TEST_CASE("a plugin built for another ABI major version is refused, naming the file and both versions") {
    const auto file = test::test_plugin_dir() / "geobarrier-wrong-abi.so";
    const std::string msg = error_of([&] { load_plugin_library(file); });
    CHECK(contains(msg, file.string()));
    CHECK(contains(msg, "ABI " + std::to_string(GB_ABI_VERSION_MAJOR + 1)));
    CHECK(contains(msg, "ABI " + std::to_string(GB_ABI_VERSION_MAJOR) + "."));
    CHECK(msg.find('\n') == std::string::npos);
}

TEST_CASE("state names and units (ABI 1.2) reach the loader; a plugin built for ABI 1.1 still loads") {
    const PluginHandle &duffing = test::registry().find(PluginKind::system, "duffing", "/system/plugin");
    CHECK(duffing.info.abi_minor == GB_ABI_VERSION_MINOR);
    CHECK(duffing.info.state_names == std::vector<std::string>{"x", "y"});
    CHECK(duffing.info.state_units == std::vector<std::string>{"", ""});
    CHECK(state_axis_label(duffing.info, 0) == "x [–]"); // the paper's scaled, nondimensional oscillator
    CHECK(time_axis_label(duffing.info) == "t [–]");
    const json schema = plugin_info_to_json(duffing.info);
    CHECK(schema["state"]["names"] == json{"x", "y"});

    const PluginHandle &pendulum = test::registry().find(PluginKind::system, "pendulum", "/system/plugin");
    CHECK(state_axis_label(pendulum.info, 0) == "x [rad]");
    CHECK(state_axis_label(pendulum.info, 1) == "y [rad/time]");
    CHECK(time_axis_label(pendulum.info) == "t [time]");

    // Its table ends where ABI 1.1's did, followed by poison pointers: reading the 1.2 fields would crash.
    const std::vector<PluginHandle> old = load_plugin_library(test::test_plugin_dir() / "geobarrier-abi-1-1.so");
    REQUIRE(old.size() == 1);
    CHECK(old[0].info.abi_minor == 1);
    CHECK(old[0].info.state_names.empty());
    CHECK(old[0].info.state_units.empty());
    CHECK(state_axis_label(old[0].info, 0) == "x");
    CHECK(state_axis_label(old[0].info, 1) == "y");
    CHECK(time_axis_label(old[0].info) == "t");
    CHECK(!plugin_info_to_json(old[0].info).contains("state"));
    const System rotation(old[0], validate_params(old[0].info, json::object(), "/system/params"));
    const double t = 0.0, x[2] = {1.0, 2.0}, f = 0.0;
    double dxdt[2] = {0.0, 0.0};
    std::int32_t status = -1;
    rotation.rhs(1, 1, &t, x, &f, dxdt, &status);
    CHECK(dxdt[0] == -2.0);
    CHECK(dxdt[1] == 1.0);
}

TEST_CASE("a library without the entry symbol is refused") {
    const auto file = test::test_plugin_dir() / "geobarrier-no-entry.so";
    const std::string msg = error_of([&] { load_plugin_library(file); });
    CHECK(contains(msg, file.string()));
    CHECK(contains(msg, "no 'geobarrier_plugin_entry' entry symbol"));
}

TEST_CASE("a file that is not a shared library is refused") {
    const auto file = test::test_plugin_dir() / "not-a-plugin.so";
    const std::string msg = error_of([&] { load_plugin_library(file); });
    CHECK(contains(msg, file.string()));
    CHECK(contains(msg, "not a loadable shared library"));
    CHECK(msg.find('\n') == std::string::npos);
    CHECK(contains(error_of([&] { load_plugin_library(test::test_plugin_dir() / "missing.so"); }), "no such file"));
}

TEST_CASE("scanning a folder keeps the good plugins and records one warning per bad file") {
    const PluginRegistry registry({test::test_plugin_dir()});
    CHECK_NOTHROW(registry.find(PluginKind::system, "rigid-rotation", "/system/plugin"));
    CHECK(registry.warnings().size() == 3);
    for (const auto &w : registry.warnings()) CHECK(contains(w, test::test_plugin_dir().string()));
}

TEST_CASE("unknown plugin names are errors at the JSON path, with a hint") {
    const PluginRegistry registry({test::plugin_dir()});
    const std::string msg = error_of([&] { registry.find(PluginKind::system, "dufing", "/system/plugin"); });
    CHECK(contains(msg, "/system/plugin"));
    CHECK(contains(msg, "did you mean \"duffing\""));
    // A forcing name is not a system.
    CHECK(contains(error_of([&] { registry.find(PluginKind::system, "cosine", "/system/plugin"); }), "available:"));
    // A path loads that file.
    const auto path = (test::plugin_dir() / "geobarrier-duffing.so").string();
    CHECK(registry.find(PluginKind::system, path, "/system/plugin").info.name == "duffing");
}

TEST_CASE("parameters are validated against the schema") {
    const PluginHandle &duffing = test::registry().find(PluginKind::system, "duffing", "/system/plugin");
    const ParamValues defaults = validate_params(duffing.info, json::object(), "/system/params");
    CHECK(defaults.value(0) == 1.0);
    CHECK(params_to_json(duffing.info, defaults) == json{{"alpha", 1.0}, {"beta", 1.0}, {"delta", 0.0}});

    const std::string unknown = error_of([&] { validate_params(duffing.info, {{"detla", 0.1}}, "/system/params"); });
    CHECK(contains(unknown, "/system/params/detla"));
    CHECK(contains(unknown, "did you mean \"delta\""));
    const std::string wrong_type = error_of([&] {
        validate_params(duffing.info, {{"alpha", "one"}}, "/system/params");
    });
    CHECK(contains(wrong_type, "/system/params/alpha"));
    CHECK(contains(wrong_type, "not a number"));
    CHECK(contains(error_of([&] { validate_params(duffing.info, json::array(), "/system/params"); }),
                   "expected an object"));

    const PluginHandle &chaotic = test::registry().find(PluginKind::forcing, "chaotic-map", "/forcing/plugin");
    const auto seed = std::find_if(chaotic.info.params.begin(), chaotic.info.params.end(),
                                   [](const ParamSpec &p) { return p.name == "seed"; });
    REQUIRE(seed != chaotic.info.params.end());
    const std::string range = error_of([&] { validate_params(chaotic.info, {{"seed", 7.5}}, "/forcing/params"); });
    CHECK(contains(range, "/forcing/params/seed"));
    CHECK(contains(range, "outside the allowed range"));
}

TEST_CASE("a plugin object keeps its library loaded after the registry is gone") {
    std::optional<System> saddle;
    {
        const PluginRegistry registry({test::plugin_dir()});
        const PluginHandle &h = registry.find(PluginKind::system, "linear-saddle", "/system/plugin");
        saddle.emplace(h, validate_params(h.info, {{"a", 2.0}}, "/system/params"));
    }
    const double t = 0.0, x[2] = {3.0, 5.0}, f = 0.0;
    double dxdt[2] = {0, 0};
    std::int32_t status = -1;
    saddle->rhs(1, 1, &t, x, &f, dxdt, &status);
    CHECK(dxdt[0] == 6.0);
    CHECK(dxdt[1] == -10.0);
    CHECK(status == GB_OK);
}

TEST_CASE("a failing plugin call becomes a PluginError naming the plugin and its message") {
    // The chaotic-map forcing is defined on a finite window of samples.
    const Forcing forcing = test::make_forcing("chaotic-map");
    const std::string msg = error_of([&] { forcing(1e12); });
    CHECK(contains(msg, "chaotic-map"));
    CHECK(contains(msg, "evaluate"));
}

TEST_CASE("did_you_mean suggests only close names") {
    CHECK(did_you_mean("dopri", {"dopri5", "rkf78", "rk4"}) == "dopri5");
    CHECK(did_you_mean("GRID", {"grid", "time"}) == "grid");
    CHECK(did_you_mean("banana", {"grid", "time"}).empty());
}

TEST_CASE("declared limits are checked as the descriptor is read: a huge dimension, parameter count, a long name") {
    // Each test library gives arrays of two entries behind counts of 2^32 - 1: refused at once, nothing sized first.
    const auto folder = test::test_plugin_dir() / "declared-limits";
    struct Case {
        const char *file, *expected;
    };
    for (const Case &c :
         {Case{"geobarrier-declared-dimension.so",
               "system 'huge-dimension' declares dimension 4294967295; a plugin may declare at most 64"},
          Case{"geobarrier-declared-params.so",
               "plugin 'huge-param-count' declares 4294967295 parameters; a plugin may declare at most "
               "256"},
          Case{"geobarrier-declared-name.so", "a descriptor with a name longer than 64 characters"}}) {
        CAPTURE(c.file);
        std::string msg;
        try {
            load_plugin_library(folder / c.file);
        } catch (const PluginError &e) {
            msg = e.what();
        }
        CHECK(contains(msg, (folder / c.file).string() + ": "));
        CHECK_MESSAGE(contains(msg, c.expected), msg);
        CHECK(msg.find('\n') == std::string::npos);
    }
    // In a plugin folder they are skipped with a warning each, like any malformed descriptor; the others still load.
    const PluginRegistry registry({folder, test::plugin_dir()});
    CHECK(registry.warnings().size() == 3);
    CHECK_NOTHROW(registry.find(PluginKind::system, "duffing", "/system/plugin"));
}
