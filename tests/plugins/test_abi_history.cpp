// The compatibility promise of docs/plugins.md, tested: plugins built against the ABI headers of earlier releases
// (1.0, 1.1 and 1.2, kept verbatim in abi-history/ as taken from the repository's history) load into this core and
// give the right answers as a system, a forcing and an extractor; the core reads only what each release declared;
// an extractor of 1.3 that links the core's C++ library still loads and runs; and a plugin of another major version
// is refused with a message naming both versions.
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <geobarrier/errors.hpp>
#include <test_support.hpp>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

using namespace geobarrier;

namespace {

struct Historic {
    const char *file;
    std::uint32_t minor;
};
const Historic historic[] = {
    {GEOBARRIER_ABI_1_0_PLUGIN, 0}, {GEOBARRIER_ABI_1_1_PLUGIN, 1}, {GEOBARRIER_ABI_1_2_PLUGIN, 2}};

const PluginHandle &find(const std::vector<PluginHandle> &handles, PluginKind kind) {
    for (const PluginHandle &h : handles)
        if (h.info.kind == kind) return h;
    FAIL("no plugin of kind ", to_string(kind));
    throw;
}

// What both ABI-history extractors are handed: a 3 x 2 grid over [-1, 2] x [-3, 4], t from 0 to 2, and one field
// "ftle" whose masked point (100) an extractor must leave out (the others sum to 7.75). Not copyable: `input` points
// into the members.
struct SmallExtractInput {
    std::vector<double> ftle = {0.5, 1.0, 2.0, 100.0, 0.25, 4.0};
    std::vector<std::uint8_t> mask = {0, 0, 0, 1, 0, 0};
    gb_field fields[1] = {{"ftle", nullptr}};
    const char *names[2] = {"x", "y"}, *units[2] = {"", ""};
    std::string output_dir;
    gb_extract_input input{};

    explicit SmallExtractInput(std::string out_dir) : output_dir(std::move(out_dir)) {
        fields[0].data = ftle.data();
        input.x_min = -1.0;
        input.x_max = 2.0;
        input.y_min = -3.0;
        input.y_max = 4.0;
        input.nx = 3;
        input.ny = 2;
        input.t0 = 0.0;
        input.t1 = 2.0;
        input.mask = mask.data();
        input.field_count = 1;
        input.fields = fields;
        input.output_dir = output_dir.c_str();
        input.state_names = names;
        input.state_units = units;
    }
    SmallExtractInput(const SmallExtractInput &) = delete;
    SmallExtractInput &operator=(const SmallExtractInput &) = delete;
};

// The host's advection for x' = x, y' = 0: x(t) = x0 e^{t - t0}, nothing masked.
ExtractServices exponential_advection() {
    ExtractServices services;
    services.advect = [](std::size_t n, const double *xy, double t_from, double t_to, double *xy_out, double *,
                         std::uint8_t *mask_out) {
        for (std::size_t k = 0; k < n; ++k) {
            xy_out[2 * k] = xy[2 * k] * std::exp(t_to - t_from);
            xy_out[2 * k + 1] = xy[2 * k + 1];
            mask_out[k] = 0;
        }
    };
    return services;
}

} // namespace

TEST_CASE("plugins built against the 1.0, 1.1 and 1.2 headers load and compute in this core") {
    for (const Historic &v : historic) {
        CAPTURE(v.file);
        const std::vector<PluginHandle> handles = load_plugin_library(v.file);
        REQUIRE(handles.size() == 3); // three descriptors: the array's stride is that of the old header
        for (const PluginHandle &h : handles) {
            CHECK(h.info.abi_major == 1);
            CHECK(h.info.abi_minor == v.minor);
        }

        // The system x' = a x, y' = -a y + f: values, Jacobian and divergence at two lanes.
        const PluginHandle &saddle = find(handles, PluginKind::system);
        CHECK(saddle.info.name == "history-saddle");
        REQUIRE(saddle.info.params.size() == 1);
        CHECK(saddle.info.params[0].name == "a");
        // What the core reads depends on the version the plugin declares: the domain from 1.1, names from 1.2.
        CHECK(saddle.info.domain_min == (v.minor >= 1 ? std::vector<double>{-3.0, -3.0} : std::vector<double>{}));
        CHECK(saddle.info.state_names ==
              (v.minor >= 2 ? std::vector<std::string>{"p", "q"} : std::vector<std::string>{}));
        const System system(saddle, validate_params(saddle.info, {{"a", 0.5}}, "/system/params"));
        CHECK_FALSE(system.has_advance());
        const double t[2] = {0.0, 1.0}, x[4] = {2.0, -4.0, /* y */ 1.0, 8.0}, f[2] = {0.25, -1.0};
        double dxdt[4], jac[8], div[2];
        std::int32_t status[2];
        system.rhs(2, 2, t, x, f, dxdt, status);
        CHECK(dxdt[0] == 1.0);
        CHECK(dxdt[1] == -2.0);
        CHECK(dxdt[2] == -0.25);
        CHECK(dxdt[3] == -5.0);
        system.jacobian(2, 2, t, x, f, jac, status);
        CHECK(jac[0] == 0.5);
        CHECK(jac[6] == -0.5);
        system.divergence(2, 2, t, x, f, div, status);
        CHECK(div[1] == 0.0);

        // The forcing f(t) = slope t.
        const PluginHandle &linear = find(handles, PluginKind::forcing);
        const Forcing forcing(linear, validate_params(linear.info, {{"slope", -2.0}}, "/forcing/params"));
        CHECK(forcing(1.5) == -3.0);

        // Both pass the conformance checks (the system's fused-step row says why it has none).
        for (const PluginHandle *h : {&saddle, &linear}) {
            const auto checks = check_plugin(*h);
            INFO(format_checks(checks));
            CHECK(all_passed(checks));
        }
        for (const ConformanceCheck &c : check_plugin(saddle))
            if (c.name == "advance_equals_stages") {
                CHECK(c.skipped);
                if (v.minor < 2) CHECK(c.detail.find("before the fused step") != std::string::npos);
            }

        // The extractor reads the current core's extract input and host (longer than its own) by their prefixes.
        const PluginHandle &probe = find(handles, PluginKind::extractor);
        REQUIRE(probe.info.required_fields == std::vector<std::string>{"ftle"});
        const Extractor extractor(probe, validate_params(probe.info, nlohmann::json::object(), "/extractors/0"));
        const SmallExtractInput small("."); // the masked 100 is left out: 7.75
        const std::vector<Barrier> barriers = extractor.extract(small.input, exponential_advection());
        REQUIRE(barriers.size() == 1);
        CHECK(barriers[0].kind == "hyperbolic");
        CHECK(barriers[0].xy == std::vector<double>{-1.0, -3.0, 2.0, 4.0});
        REQUIRE(barriers[0].metrics.size() == 2);
        CHECK(barriers[0].metrics[0].first == "ftle_sum");
        CHECK(barriers[0].metrics[0].second == 7.75);
        CHECK(barriers[0].metrics[1].second == std::exp(2.0));
    }
}

TEST_CASE("an extractor built against 1.3 that links the core's C++ library loads and runs in this core") {
    const std::vector<PluginHandle> handles = load_plugin_library(GEOBARRIER_ABI_1_3_EXTRACTOR);
    REQUIRE(handles.size() == 1);
    const PluginHandle &circle = handles[0];
    CHECK(circle.info.abi_minor == 3);
    CHECK(circle.info.core_version == GEOBARRIER_VERSION); // tied to the core's C++ series, which the loader checked
    const Extractor extractor(circle, validate_params(circle.info, {{"radius", 0.75}}, "/extractors/0"));

    const std::filesystem::path out = std::filesystem::temp_directory_path() / "geobarrier-abi-1-3-extractor";
    std::filesystem::remove_all(out);
    std::filesystem::create_directories(out);
    SmallExtractInput small(out.string()); // the masked 100 is left out: 7.75 / 5
    small.input.plots = 1;
    const std::vector<Barrier> barriers = extractor.extract(small.input, exponential_advection());
    REQUIRE(barriers.size() == 1);
    const Barrier &b = barriers[0];
    CHECK(b.kind == "elliptic");
    CHECK(b.closed);
    // The polygon of 64 points on the circle of radius 0.75 around the centre (0.5, 0.5), resampled to at most r/8
    // apart: ceil(length / (r / 8)) = ceil(50.26...) = 51 points, each on the circle or on a chord of it.
    const double length = 128.0 * 0.75 * std::sin(M_PI / 64.0);
    REQUIRE(b.xy.size() % 2 == 0);
    CHECK(b.xy.size() / 2 == 51);
    const double chord_depth = 0.75 * (1.0 - std::cos(M_PI / 64.0)); // the farthest a chord comes inside
    for (std::size_t k = 0; k < b.xy.size() / 2; ++k) {
        const double radius = std::hypot(b.xy[2 * k] - 0.5, b.xy[2 * k + 1] - 0.5);
        CHECK(radius <= 0.75 + 1e-12);
        CHECK(radius >= 0.75 - chord_depth - 1e-12);
    }
    REQUIRE(b.metrics.size() == 3);
    CHECK(b.metrics[0].first == "length");
    CHECK(b.metrics[0].second == doctest::Approx(length).epsilon(1e-14));
    CHECK(b.metrics[1].second == 7.75 / 5.0);
    CHECK(b.metrics[2].second == 0.5 * std::exp(2.0)); // the centre advected by the host
    REQUIRE(b.attributes.size() == 1);
    CHECK(b.attributes[0] == std::pair<std::string, std::string>{"family", "\"+\""});
    // Its picture, drawn by the core's plot_field_png it links: a PNG file.
    const std::string png = test::read_text(out / "history-circle.png");
    CHECK(png.substr(0, 8) == std::string("\x89PNG\r\n\x1a\n", 8));
    std::filesystem::remove_all(out);
}

TEST_CASE("the built-in extractors are on the C ABI alone: no core version, the current ABI") {
    for (const char *name : {"hyperbolic", "elliptic", "parabolic"}) {
        CAPTURE(name);
        const std::vector<PluginHandle> handles =
            load_plugin_library((test::plugin_dir() / ("geobarrier-" + std::string(name) + ".so")).string());
        REQUIRE(handles.size() == 1);
        CHECK(handles[0].info.core_version.empty()); // not tied to the core's C++ series any more
        CHECK(handles[0].info.abi_minor == GB_ABI_VERSION_MINOR);
    }
}

TEST_CASE("a fused step compiled with other numerics than the core's declines") {
    const std::vector<PluginHandle> handles = load_plugin_library(GEOBARRIER_STALE_NUMERICS_PLUGIN);
    REQUIRE(handles.size() == 1);
    CHECK(handles[0].info.build.tableau_revision == 0);
    const System system(handles[0], validate_params(handles[0].info, nlohmann::json::object(), "/system/params"));
    REQUIRE(system.has_advance());
    const double x[2] = {1.0, 0.0}, forcing[12] = {};
    double out[2] = {-1.0, -1.0};
    std::int32_t status = 0;
    gb_advance_request request{};
    request.method = GB_ADVANCE_RK4;
    request.n = request.ld = 1;
    request.h = 0.1;
    request.forcing = forcing;
    request.x = x;
    request.x_out = out;
    request.lane_status = &status;
    CHECK_FALSE(system.advance(request)); // declined: nothing written
    CHECK(out[0] == -1.0);
    for (const ConformanceCheck &c : check_plugin(handles[0]))
        if (c.name == "advance_equals_stages") {
            INFO(c.detail);
            CHECK(c.passed);
            CHECK(c.detail.find("declined: rk4, dop853") != std::string::npos);
            CHECK(c.detail.find("numerics revision 0, the core's is " + std::to_string(GB_ADVANCE_TABLEAU_REVISION)) !=
                  std::string::npos);
        }
}

TEST_CASE("a plugin of another ABI major version is refused, naming both versions") {
    const std::string file = (test::test_plugin_dir() / "geobarrier-wrong-abi.so").string();
    try {
        load_plugin_library(file);
        FAIL("the plugin was loaded");
    } catch (const PluginError &e) {
        const std::string what = e.what();
        INFO(what);
        CHECK(what.find("built for plugin ABI 2.") != std::string::npos);
        CHECK(what.find("this geobarrier speaks ABI " + std::to_string(GB_ABI_VERSION_MAJOR) + "." +
                        std::to_string(GB_ABI_VERSION_MINOR)) != std::string::npos);
    }
}
