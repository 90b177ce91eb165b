// Tests of the sum forcing: the core evaluates the terms and the plugin adds them in order; term-count limits;
// the shared conformance checks (through combine() on synthetic terms).
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <geobarrier/errors.hpp>
#include <test_support.hpp>

#include <cmath>
#include <vector>

using namespace geobarrier;

namespace {
const PluginHandle &sum() { return test::registry().find(PluginKind::forcing, "sum", "/forcing/plugin"); }
Forcing make_sum(std::vector<Forcing> terms) {
    return Forcing(sum(), validate_params(sum().info, nlohmann::json::object(), "/forcing/params"), std::move(terms));
}
} // namespace

TEST_CASE("sum: f = f_1 + f_2 + f_3 exactly (added in order)") {
    const Forcing a = test::make_forcing("cosine", {{"amplitude", 0.3}, {"omega", 2.0}});
    const Forcing b = test::make_forcing("quasi-periodic");
    const Forcing c = test::make_forcing("cosine", {{"amplitude", -0.1}, {"phase", 0.5}});
    const Forcing s = make_sum({a, b, c});
    CHECK(s.terms().size() == 3);
    const std::vector<double> t = {-3.0, 0.0, 0.5, 12.0, 40.0};
    std::vector<double> out(t.size());
    s.evaluate(t.size(), t.data(), out.data());
    for (std::size_t k = 0; k < t.size(); ++k) {
        CAPTURE(t[k]);
        CHECK(out[k] == (a(t[k]) + b(t[k])) + c(t[k]));
        CHECK(s(t[k]) == out[k]);
    }
    // One term: the identity.
    const Forcing one = make_sum({a});
    CHECK(one(1.7) == a(1.7));
    // A batch larger than the wrapper's stack buffer takes the heap path and gives the same values.
    std::vector<double> many(100), values(100);
    for (std::size_t k = 0; k < many.size(); ++k) many[k] = 0.37 * static_cast<double>(k);
    s.evaluate(many.size(), many.data(), values.data());
    for (std::size_t k = 0; k < many.size(); ++k) CHECK(values[k] == s(many[k]));
}

TEST_CASE("sum: term counts outside 1..16 and a sum without terms are errors") {
    const Forcing a = test::make_forcing("cosine");
    CHECK_THROWS_AS(make_sum({}), PluginError);
    CHECK_THROWS_AS(make_sum(std::vector<Forcing>(17, a)), PluginError);
    CHECK_NOTHROW(make_sum(std::vector<Forcing>(16, a)));
    // Created without terms (as the conformance checks do), evaluate() refuses: only the core evaluates terms.
    const Forcing bare(sum(), validate_params(sum().info, nlohmann::json::object(), "/forcing/params"));
    CHECK_THROWS_WITH_AS(bare(0.0), doctest::Contains("without its terms"), PluginError);
    // A plain forcing takes no terms.
    const PluginHandle &cosine = test::registry().find(PluginKind::forcing, "cosine", "/forcing/plugin");
    CHECK_THROWS_WITH_AS(Forcing(cosine, validate_params(cosine.info, {}, "/forcing/params"), {a}),
                         doctest::Contains("not a composite forcing"), PluginError);
}

TEST_CASE("sum: passes the conformance checks") {
    const auto checks = check_plugin(sum());
    INFO(format_checks(checks));
    CHECK(all_passed(checks));
    bool composite_checked = false;
    for (const auto &c : checks) composite_checked = composite_checked || c.name == "composite_terms";
    CHECK(composite_checked);
}
