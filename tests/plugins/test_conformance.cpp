// Tests of the conformance checker itself: a correct plugin passes every check, and each deliberately faulty
// plugin (faulty.cpp) fails exactly the check meant to catch its fault. Schema and ABI problems are planted in a
// copy of a plugin's declarations, since the loader already refuses some of them.
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <geobarrier/errors.hpp>
#include <test_support.hpp>

#include <algorithm>
#include <set>
#include <string>
#include <vector>

using namespace geobarrier;

namespace {

const std::vector<PluginHandle> &faulty_plugins() {
    static const std::vector<PluginHandle> plugins = load_plugin_library(GEOBARRIER_FAULTY_PLUGIN);
    return plugins;
}

const PluginHandle &faulty(const std::string &name) {
    for (const auto &h : faulty_plugins())
        if (h.info.name == name) return h;
    throw std::runtime_error("no faulty plugin " + name);
}

std::set<std::string> failed(const std::vector<ConformanceCheck> &checks) {
    std::set<std::string> out;
    for (const auto &c : checks)
        if (!c.passed) out.insert(c.name);
    return out;
}

const ConformanceCheck &find_check(const std::vector<ConformanceCheck> &checks, const std::string &name) {
    for (const auto &c : checks)
        if (c.name == name) return c;
    throw std::runtime_error("no check " + name);
}

} // namespace

TEST_CASE("conformance: a correct system passes every check, in the documented order") {
    const auto checks = check_plugin(faulty("faulty-none"));
    INFO(format_checks(checks));
    CHECK(all_passed(checks));
    std::vector<std::string> names;
    for (const auto &c : checks) names.push_back(c.name);
    CHECK(names == std::vector<std::string>{"abi_version", "schema", "code_generation", "create", "batch_equals_scalar",
                                            "lanes_untouched", "jacobian_vs_finite_differences",
                                            "divergence_equals_trace", "determinism", "forcing_ignored",
                                            "finite_on_sample_box", "advance_equals_stages"});
    CHECK(find_check(checks, "forcing_ignored").skipped); // it declares that it uses the forcing
    // Given as a batched rhs only, it has no fused step: the row says so instead of vanishing.
    CHECK(find_check(checks, "advance_equals_stages").skipped);
    CHECK(find_check(checks, "advance_equals_stages").detail.find("no per-lane `field`") != std::string::npos);
    CHECK(find_check(checks, "code_generation").passed);
    CHECK(format_checks(checks).find("PASS  batch_equals_scalar") != std::string::npos);
}

TEST_CASE("conformance: each faulty system fails exactly the check for its fault") {
    const std::pair<const char *, const char *> cases[] = {
        {"faulty-batch", "batch_equals_scalar"},
        {"faulty-padding", "lanes_untouched"},
        {"faulty-jacobian", "jacobian_vs_finite_differences"},
        {"faulty-divergence", "divergence_equals_trace"},
        {"faulty-determinism", "determinism"},
        {"faulty-nan", "finite_on_sample_box"},
    };
    for (const auto &[plugin, check] : cases) {
        CAPTURE(plugin);
        const auto checks = check_plugin(faulty(plugin));
        INFO(format_checks(checks));
        CHECK(failed(checks) == std::set<std::string>{check});
        CHECK(format_checks(checks).find(std::string("FAIL  ") + check) != std::string::npos);
        CHECK(!find_check(checks, check).detail.empty());
    }
}

TEST_CASE("conformance: failure details name the offending values") {
    const auto jacobian = find_check(check_plugin(faulty("faulty-jacobian")), "jacobian_vs_finite_differences");
    // The planted error is 1% of the (1, 0) entry -k = -1: a relative difference of 0.01.
    CHECK(jacobian.detail.find("entry (1, 0)") != std::string::npos);
    CHECK(jacobian.detail.find("analytic -1.01") != std::string::npos);
    const auto nan = find_check(check_plugin(faulty("faulty-nan")), "finite_on_sample_box");
    CHECK(nan.detail.find("x = (2,") != std::string::npos);
    const auto divergence = find_check(check_plugin(faulty("faulty-divergence")), "divergence_equals_trace");
    CHECK(divergence.detail.find("divergence 0.5") != std::string::npos);
}

TEST_CASE("conformance: extractors run on a synthetic field with a known answer") {
    const auto off_grid = find_check(check_plugin(faulty("faulty-extractor-off-grid")), "synthetic_field");
    CHECK_FALSE(off_grid.passed);
    CHECK(off_grid.detail.find("is not on the grid") != std::string::npos);
    const auto square = find_check(check_plugin(faulty("faulty-extractor-square")), "synthetic_field");
    CHECK_FALSE(square.passed);
    CHECK(square.detail.find("not a circle about the centre") != std::string::npos);
    CHECK(format_checks({square}).rfind("FAIL  synthetic_field", 0) == 0);
}

TEST_CASE("conformance: forcings") {
    const auto good = check_plugin(test::registry().find(PluginKind::forcing, "cosine", "/forcing/plugin"));
    INFO(format_checks(good));
    CHECK(all_passed(good));
    std::vector<std::string> names;
    for (const auto &c : good) names.push_back(c.name);
    CHECK(names == std::vector<std::string>{"abi_version", "schema", "code_generation", "create", "batch_equals_scalar",
                                            "lanes_untouched", "determinism", "finite_on_sample_times"});
    // Its values depend on the batch size and on the instance.
    const auto bad = check_plugin(faulty("faulty-forcing"));
    CHECK(failed(bad) == std::set<std::string>{"batch_equals_scalar", "determinism"});
}

TEST_CASE("conformance: a system that ignores the forcing is checked for it") {
    const auto handles = load_plugin_library(GEOBARRIER_RIGID_ROTATION_PLUGIN);
    REQUIRE(handles.size() == 1);
    const auto checks = check_plugin(handles[0]);
    INFO(format_checks(checks));
    CHECK(all_passed(checks));
    CHECK_FALSE(find_check(checks, "forcing_ignored").skipped);
}

TEST_CASE("conformance: malformed schemas") {
    PluginHandle h = faulty("faulty-none");
    ParamSpec p = h.info.params[0];
    SUBCASE("default outside the range") {
        h.info.params[0].default_value = 11.0;
        const auto checks = check_plugin(h);
        CHECK(find_check(checks, "schema").detail.find("default 11 outside its range [0, 10]") != std::string::npos);
        // The same default is also refused when an instance is made from it.
        CHECK(failed(checks) == std::set<std::string>{"schema", "create"});
    }
    SUBCASE("names, docs, duplicates, strings, integers, booleans") {
        ParamSpec upper = p, duplicate = p, undocumented = p, text = p, integer = p, flag = p;
        upper.name = "Stiffness";
        undocumented.name = "damping";
        undocumented.doc = "";
        text.name = "mode";
        text.type = ParamType::string;
        text.default_string = "fast";
        text.choices = {"slow", "exact"};
        integer.name = "steps";
        integer.type = ParamType::integer;
        integer.default_value = 2.5;
        integer.min_value = 0;
        integer.max_value = 10;
        flag.name = "on";
        flag.type = ParamType::boolean;
        flag.default_value = 0.5;
        h.info.params = {p, upper, duplicate, undocumented, text, integer, flag};
        h.info.doc = "";
        const std::string detail = find_check(check_plugin(h), "schema").detail;
        CHECK(detail.find("parameter 'Stiffness': name does not match [a-z0-9_]+") != std::string::npos);
        CHECK(detail.find("parameter 'k': declared twice") != std::string::npos);
        CHECK(detail.find("parameter 'damping': no doc line") != std::string::npos);
        CHECK(detail.find("parameter 'mode': default \"fast\" is not one of its choices") != std::string::npos);
        CHECK(detail.find("parameter 'steps': integer default 2.5 is not an integer") != std::string::npos);
        CHECK(detail.find("parameter 'on': bool default 0.5 is not 0 or 1") != std::string::npos);
        CHECK(detail.find("no doc line") != std::string::npos);
    }
}

TEST_CASE("conformance: state names and units (ABI 1.2)") {
    PluginHandle h = faulty("faulty-none");
    SUBCASE("none declared: passes, and says the axes read x, y") {
        const ConformanceCheck schema = find_check(check_plugin(h), "schema");
        CHECK(schema.passed);
        CHECK(schema.detail.find("no state names declared") != std::string::npos);
    }
    SUBCASE("declared: the axis labels are listed") {
        h.info.state_names = {"theta", "omega"};
        h.info.state_units = {"rad", ""};
        const ConformanceCheck schema = find_check(check_plugin(h), "schema");
        CHECK(schema.passed);
        CHECK(schema.detail.find("state theta [rad], omega [–]") != std::string::npos);
    }
    SUBCASE("an empty name, a name used twice, a count that is not the dimension") {
        h.info.state_names = {"x", ""};
        h.info.state_units = {"", ""};
        CHECK(find_check(check_plugin(h), "schema").detail.find("state component 1 has no name") != std::string::npos);
        h.info.state_names = {"x", "x"};
        CHECK(find_check(check_plugin(h), "schema").detail.find("state name 'x' used twice") != std::string::npos);
        h.info.state_names = {"x"};
        h.info.state_units = {""};
        CHECK(find_check(check_plugin(h), "schema").detail.find("1 state names and 1 units for dimension 2") !=
              std::string::npos);
    }
}

TEST_CASE("conformance: another ABI major version stops the checks") {
    PluginHandle h = faulty("faulty-none");
    h.info.abi_major = GB_ABI_VERSION_MAJOR + 1;
    const auto checks = check_plugin(h);
    REQUIRE(checks.size() == 2);
    CHECK_FALSE(checks[0].passed);
    CHECK(checks[0].name == "abi_version");
    const std::string minor = std::to_string(GB_ABI_VERSION_MINOR);
    CHECK(checks[0].detail.find("plugin ABI 2." + minor + ", core ABI 1." + minor) != std::string::npos);
}

TEST_CASE("conformance: options") {
    SUBCASE("parameters are validated like an experiment's") {
        ConformanceOptions o;
        o.params = {{"k", 20.0}};
        const auto checks = check_plugin(faulty("faulty-none"), o);
        CHECK(failed(checks) == std::set<std::string>{"create"});
        CHECK(find_check(checks, "create").detail.find("/params/k") != std::string::npos);
    }
    SUBCASE("a box of the wrong dimension is a usage error") {
        ConformanceOptions o;
        o.state_min = {-1.0, -1.0, -1.0};
        CHECK_THROWS_AS(check_plugin(faulty("faulty-none"), o), Error);
    }
    SUBCASE("a smaller box keeps faulty-nan's NaN (at x >= 2) out of reach") {
        ConformanceOptions o;
        o.state_min = {-1.0, -3.0};
        o.state_max = {1.5, 3.0};
        CHECK(all_passed(check_plugin(faulty("faulty-nan"), o)));
    }
    SUBCASE("one lane, ld = n") {
        ConformanceOptions o;
        o.lanes = 1;
        o.ld = 1;
        CHECK(all_passed(check_plugin(faulty("faulty-none"), o)));
        // With no padding there is nothing faulty-padding could overwrite.
        CHECK(all_passed(check_plugin(faulty("faulty-padding"), o)));
    }
}
