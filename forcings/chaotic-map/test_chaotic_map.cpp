// Tests of the chaotic-map forcing: its samples against an independent iteration of the logistic map,
// the B-spline's values and C^2 joins at the knots, determinism, the guard against degenerate orbits, the time
// window, and the shared conformance checks. This file is compiled with -ffp-contract=off like the plugin, so the
// reference iteration below performs the same IEEE operations.
#include <doctest/doctest.h>

#include <geobarrier/conformance.hpp>
#include <geobarrier/errors.hpp>
#include <test_support.hpp>

#include <array>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

using namespace geobarrier;

namespace {

constexpr double default_seed = 0.3141592653589793;
constexpr double default_amplitude = 0.1;
constexpr long long default_span = 200000;
constexpr double golden_phi = 0.6180339887498949;
// f at three times for the default parameters, as hexadecimal floats (exact), from the reference build.
constexpr double golden_1000_25 = -0x1.53859b23e0f1ep-4;
constexpr double golden_m1000_75 = 0x1.b734389433b3dp-6;
constexpr double golden_150000_5 = 0x1.c60356e1889dfp-7;
// FNV-1a hash of f at t_k = -5000 + 0.7431 k, k = 0 .. 9999 (see fnv1a_bits).
constexpr std::uint64_t golden_hash = 0xd87f70d44a5565c1ull;

const PluginHandle &chaotic_map() {
    return test::registry().find(PluginKind::forcing, "chaotic-map", "/forcing/plugin");
}

// W(x, j) of the plugin's definition: the backward stream's first value and the re-injected values.
double weyl(double x, double j) {
    const double y = x + j * golden_phi;
    return 0.05 + 0.9 * (y - std::floor(y));
}

double logistic(double r, double z) { return (r * z) * (1.0 - z); }

// g_n for n = -span .. span (index n + span) by the documented definition, without the guard: the seeds used
// with it never need one, which this comparison also proves.
std::vector<double> plain_samples(double seed, double r, double amplitude, long long span) {
    std::vector<double> z(static_cast<std::size_t>(2 * span + 1));
    z[span] = seed;
    for (long long n = 1; n <= span; ++n) z[span + n] = logistic(r, z[span + n - 1]);
    z[span - 1] = weyl(seed, 1.0);
    for (long long m = 2; m <= span; ++m) z[span - m] = logistic(r, z[span - m + 1]);
    for (double &v : z) v = amplitude * (2.0 * v - 1.0);
    return z;
}

std::vector<double> evaluate(const Forcing &f, const std::vector<double> &t) {
    std::vector<double> out(t.size());
    f.evaluate(t.size(), t.data(), out.data());
    return out;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// FNV-1a over the values' bit patterns (little-endian byte order, whatever the machine's).
std::uint64_t fnv1a_bits(const std::vector<double> &values) {
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (double v : values) {
        std::uint64_t bits;
        std::memcpy(&bits, &v, sizeof bits);
        for (int byte = 0; byte < 8; ++byte) {
            h ^= (bits >> (8 * byte)) & 0xffu;
            h *= 0x100000001b3ull;
        }
    }
    return h;
}

// Weights w_i with sum_i w_i p(s_i) = p^(d)(z) for every cubic p through the four nodes s_i (Lagrange basis
// derivatives): finite differences that are exact for the spline's cubic pieces.
std::array<double, 4> cubic_weights(const std::array<double, 4> &s, double z, int d) {
    std::array<double, 4> w{};
    for (int i = 0; i < 4; ++i) {
        double other[3];
        double denominator = 1.0;
        for (int j = 0, m = 0; j < 4; ++j)
            if (j != i) {
                other[m++] = s[j];
                denominator *= s[i] - s[j];
            }
        const double a = z - other[0], b = z - other[1], c = z - other[2];
        const double numerator = d == 0 ? a * b * c : d == 1 ? a * b + a * c + b * c : d == 2 ? 2 * (a + b + c) : 6.0;
        w[i] = numerator / denominator;
    }
    return w;
}

} // namespace

TEST_CASE("chaotic-map: r outside the chaotic range and a fractional span are refused") {
    CHECK_THROWS_AS(test::make_forcing("chaotic-map", {{"r", 4.5}}), ConfigError);
    CHECK_THROWS_AS(test::make_forcing("chaotic-map", {{"span", 10.5}}), ConfigError);
}

TEST_CASE("chaotic-map: knot values are (g_{n-1} + 4 g_n + g_{n+1}) / 6 of an independent iteration") {
    // Every knot of the default window, both streams: the samples equal the map iterated in the test, and the
    // spline's value at a knot is the B-spline combination. The plugin's four-term sum with rounded weights
    // (1/6, 4/6, 1/6, 0) and the formula here differ by rounding only: a few ulp of max |g| = amplitude.
    const Forcing f = test::make_forcing("chaotic-map");
    const std::vector<double> g = plain_samples(default_seed, 4.0, default_amplitude, default_span);
    std::vector<double> t;
    for (long long n = 1 - default_span; n <= default_span - 1; ++n) t.push_back(static_cast<double>(n));
    const std::vector<double> values = evaluate(f, t);
    const double tol = 16 * DBL_EPSILON * default_amplitude;
    double worst = 0.0;
    long long worst_n = 0;
    for (std::size_t k = 0; k < t.size(); ++k) {
        const long long n = static_cast<long long>(t[k]);
        const std::size_t i = static_cast<std::size_t>(n + default_span);
        const double expected = (g[i - 1] + 4 * g[i] + g[i + 1]) / 6;
        const double diff = std::fabs(values[k] - expected);
        if (diff > worst) {
            worst = diff;
            worst_n = n;
        }
    }
    INFO("worst knot n = ", worst_n, ", difference ", worst, ", allowed ", tol);
    CHECK(worst <= tol);
}

TEST_CASE("chaotic-map: knots at start + n interval for another interval and start") {
    // interval 0.5 and start 3 are exact in binary, so t = start + n interval gives u = n exactly.
    const double interval = 0.5, start = 3.0, amplitude = 0.25;
    const Forcing f = test::make_forcing(
        "chaotic-map",
        {{"interval", interval}, {"start", start}, {"amplitude", amplitude}, {"span", 5000}, {"seed", 0.123}});
    const std::vector<double> g = plain_samples(0.123, 4.0, amplitude, 5000);
    for (long long n : {-4999LL, -1000LL, -1LL, 0LL, 1LL, 77LL, 4999LL}) {
        CAPTURE(n);
        const std::size_t i = static_cast<std::size_t>(n + 5000);
        CHECK(std::fabs(f(start + static_cast<double>(n) * interval) - (g[i - 1] + 4 * g[i] + g[i + 1]) / 6) <=
              16 * DBL_EPSILON * amplitude);
    }
}

TEST_CASE("chaotic-map: f, f' and f'' are continuous across knots, f''' jumps") {
    // On each side of a knot, f is one cubic: four values inside the piece determine it exactly, and its
    // value and derivatives at the knot follow from them (cubic_weights). Both sides must give the B-spline's
    // knot formulas f = (g- + 4 g + g+)/6, f' = (g+ - g-)/(2 dt), f'' = (g- - 2 g + g+)/dt^2; the third
    // derivatives must differ as the formulas say (showing the test could see a jump).
    // Tolerance: each value carries about 8 ulp of amplitude rounding; the reconstruction multiplies that by
    // sum |w_i| and divides by dt^d.
    const double interval = 0.5, amplitude = 0.1;
    const Forcing f = test::make_forcing("chaotic-map", {{"interval", interval}});
    const std::vector<double> g = plain_samples(default_seed, 4.0, amplitude, default_span);
    const std::array<double, 4> left = {-0.875, -0.625, -0.375, -0.125}, right = {0.125, 0.375, 0.625, 0.875};
    int third_derivative_jumps = 0;
    for (long long n : {-150000LL, -7LL, -1LL, 0LL, 1LL, 2LL, 1000LL, 150000LL}) {
        CAPTURE(n);
        const std::size_t i = static_cast<std::size_t>(n + default_span);
        const double gm2 = g[i - 2], gm = g[i - 1], g0 = g[i], gp = g[i + 1], gp2 = g[i + 2];
        const double exact[3] = {(gm + 4 * g0 + gp) / 6, (gp - gm) / (2 * interval),
                                 (gm - 2 * g0 + gp) / (interval * interval)};
        const double third_left = (-gm2 + 3 * gm - 3 * g0 + gp) / (interval * interval * interval);
        const double third_right = (-gm + 3 * g0 - 3 * gp + gp2) / (interval * interval * interval);
        double reconstructed[2][4];
        double weight_sum[4] = {0, 0, 0, 0};
        for (int side = 0; side < 2; ++side) {
            const auto &nodes = side == 0 ? left : right;
            std::vector<double> t;
            for (double s : nodes) t.push_back((static_cast<double>(n) + s) * interval);
            const std::vector<double> v = evaluate(f, t);
            for (int d = 0; d < 4; ++d) {
                const auto w = cubic_weights(nodes, 0.0, d);
                double sum = 0.0, abs_sum = 0.0;
                for (int j = 0; j < 4; ++j) {
                    sum += w[j] * v[j];
                    abs_sum += std::fabs(w[j]);
                }
                reconstructed[side][d] = sum / std::pow(interval, d);
                weight_sum[d] = std::max(weight_sum[d], abs_sum);
            }
        }
        for (int d = 0; d < 3; ++d) {
            CAPTURE(d);
            const double tol = 16 * DBL_EPSILON * amplitude * (weight_sum[d] + 8) / std::pow(interval, d);
            CHECK(std::fabs(reconstructed[0][d] - exact[d]) <= tol);
            CHECK(std::fabs(reconstructed[1][d] - exact[d]) <= tol);
            CHECK(std::fabs(reconstructed[0][d] - reconstructed[1][d]) <= 2 * tol);
        }
        const double tol3 = 16 * DBL_EPSILON * amplitude * (weight_sum[3] + 8) / std::pow(interval, 3);
        CHECK(std::fabs(reconstructed[0][3] - third_left) <= tol3);
        CHECK(std::fabs(reconstructed[1][3] - third_right) <= tol3);
        if (std::fabs(third_left - third_right) > 100 * tol3) ++third_derivative_jumps;
    }
    CHECK(third_derivative_jumps >= 6);
}

TEST_CASE("chaotic-map: first samples against a long double iteration (golden values)") {
    // Plugin (double) and reference (long double) iterate the same map from the same seed. Their difference
    // starts at the double's rounding (about 1e-16 per step) and is stretched by |f'(z)| = |r (1 - 2 z)| each
    // step, on average a factor 2 at r = 4 (Lyapunov exponent ln 2): after ~10 steps it is ~1e-13, after ~50
    // the two orbits have nothing in common. So the golden comparison covers the first knots only, with the
    // bound propagated step by step (e_{n+1} = |f'(z_n)| e_n + r e_n^2 + 4 ulp |z_{n+1}|).
    const Forcing f = test::make_forcing("chaotic-map");
    const long double r = 4.0L, amplitude = static_cast<long double>(default_amplitude);
    constexpr int steps = 11;
    long double z[steps];
    double bound[steps];
    z[0] = static_cast<long double>(default_seed);
    bound[0] = 0.0;
    for (int n = 1; n < steps; ++n) {
        z[n] = r * z[n - 1] * (1.0L - z[n - 1]);
        const double stretch = std::fabs(static_cast<double>(r * (1.0L - 2.0L * z[n - 1])));
        bound[n] = stretch * bound[n - 1] + 4.0 * bound[n - 1] * bound[n - 1] +
                   4 * DBL_EPSILON * static_cast<double>(z[n]) + 4 * LDBL_EPSILON;
    }
    for (int n = 1; n + 1 < steps; ++n) {
        CAPTURE(n);
        auto g = [&](int m) { return amplitude * (2.0L * z[m] - 1.0L); };
        const long double expected = (g(n - 1) + 4.0L * g(n) + g(n + 1)) / 6.0L;
        // A sample's error is 2 amplitude e_n plus its own rounding; the knot value averages three samples.
        auto sample_bound = [&](int m) {
            return 2 * default_amplitude * bound[m] + 2 * DBL_EPSILON * default_amplitude;
        };
        const double tol = (sample_bound(n - 1) + 4 * sample_bound(n) + sample_bound(n + 1)) / 6 +
                           16 * DBL_EPSILON * default_amplitude;
        const double diff = static_cast<double>(std::fabs(static_cast<long double>(f(n)) - expected));
        INFO("difference ", diff, ", bound ", tol);
        CHECK(diff <= tol);
        CHECK(tol < 1e-12);
    }
    // Bit-exact values on the reference build (x86-64, GCC, IEEE double). Any IEEE-754 machine must reproduce
    // them exactly; a mismatch means the plugin no longer computes in plain double arithmetic (fast-math, x87
    // excess precision, or FMA contraction: the map (r z)(1 - z) has nothing to contract, but W(x, j) and the
    // spline's sums do; a build with -mfma -ffp-contract=fast changes the last bit of about a third of the
    // values, which three values can miss and the hash of 10000 cannot).
    CHECK(same_bits(f(1000.25), golden_1000_25));
    CHECK(same_bits(f(-1000.75), golden_m1000_75));
    CHECK(same_bits(f(150000.5), golden_150000_5));
    std::vector<double> t(10000);
    for (std::size_t k = 0; k < t.size(); ++k) t[k] = -5000.0 + 0.7431 * static_cast<double>(k);
    CHECK(fnv1a_bits(evaluate(f, t)) == golden_hash);
}

TEST_CASE("chaotic-map: deterministic, and sensitive to the seed") {
    const std::vector<double> t = {-3000.5, -12.25, 0.0, 0.3, 7.75, 59.5, 1999.0};
    const std::vector<double> a = evaluate(test::make_forcing("chaotic-map"), t);
    const std::vector<double> b = evaluate(test::make_forcing("chaotic-map"), t);
    for (std::size_t k = 0; k < t.size(); ++k) CHECK(same_bits(a[k], b[k]));

    // A clearly different seed differs at once.
    const std::vector<double> c = evaluate(test::make_forcing("chaotic-map", {{"seed", 0.2}}), t);
    CHECK(std::fabs(c[2] - a[2]) > 1e-3);
    // The next double after the default seed: equal to rounding near t = 0, unrelated once chaos has
    // amplified the 5.6e-17 difference (by about 2 per step: O(1) after ~55 samples).
    const Forcing near = test::make_forcing("chaotic-map", {{"seed", std::nextafter(default_seed, 1.0)}});
    const Forcing base = test::make_forcing("chaotic-map");
    CHECK(std::fabs(near(1.0) - base(1.0)) < 1e-15);
    double largest_late_difference = 0.0;
    for (int n = 60; n < 100; ++n)
        largest_late_difference = std::max(largest_late_difference, std::fabs(near(n) - base(n)));
    CHECK(largest_late_difference > 0.02);
}

TEST_CASE("chaotic-map: f on a common window does not depend on span; interval and start only rescale time") {
    const Forcing full = test::make_forcing("chaotic-map");
    const Forcing short_span = test::make_forcing("chaotic-map", {{"span", 1000}});
    const Forcing half = test::make_forcing("chaotic-map", {{"interval", 0.5}});
    const Forcing shifted = test::make_forcing("chaotic-map", {{"start", 10.0}});
    for (int k = -7992; k <= 7992; k += 37) {
        const double t = k / 8.0; // dyadic: t / 0.5, 2 t and (t + 10) - 10 are exact
        CAPTURE(t);
        const double reference = full(t);
        CHECK(same_bits(short_span(t), reference));
        CHECK(same_bits(half(t / 2), reference));
        CHECK(same_bits(shifted(t + 10.0), reference));
    }
}

TEST_CASE("chaotic-map: bounded by the amplitude, with zero mean at r = 4") {
    for (double amplitude : {0.1, 2.5}) {
        const Forcing f = test::make_forcing("chaotic-map", {{"amplitude", amplitude}});
        std::vector<double> t;
        for (int k = -100000; k <= 100000; ++k) t.push_back(k * 1.9999 + 0.1234);
        double largest = 0.0;
        for (double v : evaluate(f, t)) largest = std::max(largest, std::fabs(v));
        CAPTURE(amplitude);
        // The B-spline weights are nonnegative and sum to 1, so |f| <= max |g_n| <= amplitude.
        CHECK(largest <= amplitude);
        CHECK(largest > 0.9 * amplitude);
    }
    // At r = 4, 2 z - 1 = cos(theta) with theta uniform and doubling each step: mean 0, variance 1/2, and
    // uncorrelated samples. The mean of the 400001 samples then has standard deviation
    // amplitude sqrt(0.5 / 400001) = 1.1e-4; the knot values average the samples with weights summing to 1.
    const std::vector<double> g = plain_samples(default_seed, 4.0, default_amplitude, default_span);
    double mean = 0.0;
    for (double v : g) mean += v;
    mean /= static_cast<double>(g.size());
    CHECK(std::fabs(mean) < 5 * default_amplitude * std::sqrt(0.5 / static_cast<double>(g.size())));
}

TEST_CASE("chaotic-map: degenerate orbits are re-injected, periodic windows refused") {
    // Seeds whose orbit would end on the fixed point 0 (via 1/2 -> 1 -> 0, or 1 -> 0) or stay on the fixed
    // point 3/4 of r = 4: the first degenerate iterate z_1 becomes W(seed, 2) and the map goes on from there.
    const double amplitude = default_amplitude;
    for (double seed : {0.0, 0.5, 0.75, 1.0}) {
        CAPTURE(seed);
        const Forcing f = test::make_forcing("chaotic-map", {{"seed", seed}, {"span", 100}});
        std::vector<double> z = {seed, weyl(seed, 2.0)};
        while (z.size() < 60) z.push_back(logistic(4.0, z.back()));
        auto g = [&](std::size_t n) { return amplitude * (2.0 * z[n] - 1.0); };
        for (std::size_t n = 1; n + 1 < z.size(); ++n) {
            CAPTURE(n);
            CHECK(std::fabs(f(static_cast<double>(n)) - (g(n - 1) + 4 * g(n) + g(n + 1)) / 6) <=
                  16 * DBL_EPSILON * amplitude);
        }
    }
    // r = 3.83 lies in the period-3 window: the orbit settles on a cycle again after every re-injection.
    try {
        test::make_forcing("chaotic-map", {{"r", 3.83}});
        FAIL("r = 3.83 was accepted");
    } catch (const PluginError &e) {
        const std::string what = e.what();
        CHECK(what.find("periodic window") != std::string::npos);
        CHECK(what.find("r = 3.83") != std::string::npos);
    }
    // r = 3.9 is chaotic (Lyapunov exponent about 0.5): no re-injection, the samples are the plain iteration.
    const Forcing f = test::make_forcing("chaotic-map", {{"r", 3.9}, {"span", 3000}});
    const std::vector<double> g = plain_samples(default_seed, 3.9, default_amplitude, 3000);
    for (long long n : {-2999LL, -5LL, 0LL, 5LL, 2999LL}) {
        const std::size_t i = static_cast<std::size_t>(n + 3000);
        CHECK(std::fabs(f(static_cast<double>(n)) - (g[i - 1] + 4 * g[i] + g[i + 1]) / 6) <=
              16 * DBL_EPSILON * default_amplitude);
    }
}

TEST_CASE("chaotic-map: times outside the window are errors naming the window") {
    const Forcing f = test::make_forcing("chaotic-map");
    // Window: [start + (1 - span) interval, start + (span - 1) interval] = [-199999, 199999].
    CHECK_NOTHROW(f(-199999.0));
    CHECK_NOTHROW(f(199999.0));
    for (double t : {std::nextafter(199999.0, HUGE_VAL), std::nextafter(-199999.0, -HUGE_VAL), 1e9, std::nan("")}) {
        CAPTURE(t);
        try {
            f(t);
            FAIL("no error");
        } catch (const PluginError &e) {
            CHECK(std::string(e.what()).find("outside the forcing's time window [-199999, 199999]") !=
                  std::string::npos);
        }
    }
    // One bad time sinks the whole batch (the caller must not use partial output).
    const std::vector<double> t = {0.0, 1.0, 3e5, 2.0};
    std::vector<double> out(t.size());
    CHECK_THROWS_AS(f.evaluate(t.size(), t.data(), out.data()), PluginError);
    // The window follows start, span and interval.
    const Forcing g = test::make_forcing("chaotic-map", {{"start", 100.0}, {"span", 11}, {"interval", 2.0}});
    CHECK_NOTHROW(g(80.0));
    CHECK_NOTHROW(g(120.0));
    CHECK_THROWS_AS(g(79.5), PluginError);
    CHECK_THROWS_AS(g(120.5), PluginError);
}

TEST_CASE("chaotic-map: one instance evaluated from several threads at once") {
    const Forcing f = test::make_forcing("chaotic-map");
    std::vector<double> t;
    for (int k = 0; k < 20000; ++k) t.push_back(-5000.0 + 0.5123 * k);
    const std::vector<double> serial = evaluate(f, t);
    std::vector<std::vector<double>> results(4);
    std::vector<std::thread> threads;
    for (auto &r : results) threads.emplace_back([&] { r = evaluate(f, t); });
    for (auto &th : threads) th.join();
    for (const auto &r : results) CHECK(r == serial);
}

TEST_CASE("chaotic-map: passes the conformance checks") {
    const nlohmann::json parameter_sets[] = {
        nlohmann::json::object(),
        {{"r", 3.9}, {"interval", 0.25}, {"amplitude", 0.2}, {"seed", 0.7}, {"span", 1000}},
    };
    for (const auto &params : parameter_sets) {
        ConformanceOptions options;
        options.params = params;
        options.t_min = -200.0;
        options.t_max = 200.0;
        const auto checks = check_plugin(chaotic_map(), options);
        INFO(params.dump(), "\n", format_checks(checks));
        CHECK(all_passed(checks));
    }
}
