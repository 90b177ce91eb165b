// Numerical extremes (docs/robustness.md): horizons long enough that lambda2 overflows a double, horizons so short
// that C = I, lambda1 many orders below lambda2, stiff systems and rosenbrock4, tolerances and grids at and past
// their limits, escaping trajectories, singular points of the line fields, and cancellation. Every bound is derived
// in the comment beside it.
#include "experiment/resources.hpp"

#include <geobarrier/cancel.hpp>
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/flow_map.hpp>
#include <geobarrier/tensor_lines.hpp>

#include <boost/numeric/odeint.hpp>
#include <doctest/doctest.h>
#include <netcdf.h>
#include <test_support.hpp>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <fstream>
#include <limits>
#include <random>
#include <thread>
#include <unistd.h>

using namespace geobarrier;
using geobarrier::test::make_forcing;
using geobarrier::test::make_system;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double ulp = std::numeric_limits<double>::epsilon() / 2; // unit roundoff 2^-53

IntegratorSettings settings(const std::string &method, double tol, std::size_t batch = 64) {
    IntegratorSettings s;
    s.method = method;
    s.rtol = tol;
    s.atol = tol;
    s.batch = batch;
    return s;
}

// Steps per batch, the N of the global error bounds below: each accepted step's local error is at most tol
// relative to the solution, and the variational equations carry it to t1 growing at most like the solution itself
// on the orbits used here (linear, or regular), so DF's relative error at t1 is at most N tol, log lambda2's at most
// 2 N tol, and the FTLE's at most N tol / |T|.
double steps_per_batch(const IntegratorStats &s) {
    return static_cast<double>(s.steps) / static_cast<double>(s.batches);
}

CauchyGreenPoint cg_of(const FlowMap &r, std::size_t k, double abs_T) {
    return cauchy_green_at(r.dF[4 * k], r.dF[4 * k + 1], r.dF[4 * k + 2], r.dF[4 * k + 3], abs_T, r.dF_exponent[k],
                           r.log_det[k]);
}

fs::path scratch(const std::string &name) {
    const fs::path d = fs::temp_directory_path() / ("geobarrier-extremes-" + std::to_string(::getpid())) / name;
    fs::remove_all(d);
    return d;
}

std::vector<double> read_nc(const fs::path &file, const char *variable) {
    int nc = -1, var = -1, dims[2] = {-1, -1};
    REQUIRE(nc_open(file.c_str(), NC_NOWRITE, &nc) == NC_NOERR);
    REQUIRE(nc_inq_varid(nc, variable, &var) == NC_NOERR);
    REQUIRE(nc_inq_vardimid(nc, var, dims) == NC_NOERR);
    std::size_t ny = 0, nx = 0;
    nc_inq_dimlen(nc, dims[0], &ny);
    nc_inq_dimlen(nc, dims[1], &nx);
    std::vector<double> v(nx * ny);
    REQUIRE(nc_get_var_double(nc, var, v.data()) == NC_NOERR);
    nc_close(nc);
    return v;
}

RunSummary run(const json &experiment, const fs::path &out) {
    json j = experiment;
    j["plugin_paths"] = {test::plugin_dir().string(), test::test_plugin_dir().string()};
    RunOptions options;
    options.output_dir = out;
    options.quiet = true;
    return run_experiment(resolve_experiment(parse_experiment(j)), options);
}

// An independent reference for the Duffing FTLE over long horizons: Boost.Odeint rkf78 at 1e-12 on the state and
// the variational equations, renormalising DF by its largest entry after every unit of time and summing the logs.
double reference_ftle(double x, double y, double T, double alpha, double delta, double eps) {
    using state = std::array<double, 6>;
    state s = {x, y, 1, 0, 0, 1};
    auto rhs = [&](const state &u, state &d, double t) {
        d[0] = u[1];
        d[1] = alpha * u[0] - u[0] * u[0] * u[0] - delta * u[1] + eps * std::cos(t);
        const double a = alpha - 3.0 * u[0] * u[0];
        d[2] = u[4];
        d[3] = u[5];
        d[4] = a * u[2] - delta * u[4];
        d[5] = a * u[3] - delta * u[5];
    };
    namespace odeint = boost::numeric::odeint;
    double log_scale = 0;
    for (int chunk = 0; chunk < static_cast<int>(T); ++chunk) {
        odeint::integrate_adaptive(odeint::make_controlled(1e-12, 1e-12, odeint::runge_kutta_fehlberg78<state>()), rhs,
                                   s, double(chunk), double(chunk + 1), 1e-3);
        const double m = std::max({std::abs(s[2]), std::abs(s[3]), std::abs(s[4]), std::abs(s[5])});
        for (int q = 2; q < 6; ++q) s[q] /= m;
        log_scale += std::log(m);
    }
    const double c11 = s[2] * s[2] + s[4] * s[4], c12 = s[2] * s[3] + s[4] * s[5], c22 = s[3] * s[3] + s[5] * s[5];
    const double l2 = 0.5 * (c11 + c22) + std::sqrt(0.25 * (c11 - c22) * (c11 - c22) + c12 * c12);
    return (std::log(l2) + 2 * log_scale) / (2 * T);
}

} // namespace

// ------------------------------------------------------------------------------------------------ long horizons

TEST_CASE("long horizon: linear saddle a = 1, T = 1000: FTLE = 1 to 1e-9 where lambda2 = e^2000 overflows") {
    const System saddle = make_system("linear-saddle", {{"a", 1.0}});
    const Dynamics dyn{&saddle, nullptr};
    // x0 = 0: the trajectory stays on the stable axis (x = x0 e^T would overflow), y decays to 0 harmlessly.
    const std::vector<double> x0 = {0.0, 0.0, 0.0}, y0 = {-1.0, 0.25, 0.9};
    const double T = 1000.0;
    for (const auto &[method, tol] : {std::pair<std::string, double>{"dopri5", 1e-11}, {"rkf78", 1e-10}}) {
        CAPTURE(method);
        const FlowMap r =
            flow_map_at_points({dyn, 0.0, T, settings(method, tol), GradientMethod::variational, true}, x0, y0);
        const double bound = steps_per_batch(r.stats) * tol / T;
        MESSAGE(method << " tol " << tol << ": " << steps_per_batch(r.stats) << " steps, FTLE error bound " << bound);
        REQUIRE(bound <= 1e-9);
        CHECK(r.stats.renormalised == 3);
        for (std::size_t k = 0; k < x0.size(); ++k) {
            CHECK(r.mask[k] == 0);
            CHECK(r.dF_exponent[k] > 1000); // DF11 = e^1000 ~ 2^1443 is carried scaled
            CHECK(r.log_det[k] == 0.0);     // tr Dv = a - a = 0 exactly
            const CauchyGreenPoint p = cg_of(r, k, T);
            CHECK(std::isfinite(p.ftle));
            CHECK(std::abs(p.ftle - 1.0) <= bound);
            CHECK(p.lambda2 == std::numeric_limits<double>::infinity()); // e^2000: beyond the double range
            CHECK(p.lambda1 == 0.0);                                     // e^-2000: below it
            CHECK(std::abs(std::abs(p.xi2_x) - 1.0) < 1e-15);            // the stretching direction is e_x
        }
    }
    // The same through the runner: the x = 0 column is right, the others are masked (x0 e^T blows up), and the
    // manifest records the method.
    const fs::path out = scratch("saddle-1000");
    const RunSummary s = run(json::parse(R"({
        "system": {"plugin": "linear-saddle", "params": {"a": 1}}, "grid": {"x": [-1, 1], "y": [-1, 1], "n": [3, 3]},
        "time": {"t0": 0, "t1": 1000}, "integrator": {"method": "rkf78", "rtol": 1e-10, "atol": 1e-10},
        "products": ["ftle", "eigenvalues"], "output": {"plots": false}})"),
                             out);
    CHECK(s.manifest["long_horizon"]["method"] == "renormalised variational equations");
    CHECK(s.manifest["gradient_method"] == "variational");
    CHECK(s.manifest["integrator_stats"]["renormalised"] == 3);
    CHECK(s.manifest["integrator_stats"]["masked_non_finite"] == 6);
    const std::vector<double> ftle = read_nc(out / "fields.nc", "ftle");
    for (std::size_t i = 0; i < 3; ++i) {
        CHECK(std::abs(ftle[i * 3 + 1] - 1.0) <= 1e-9);
        CHECK(ftle[i * 3] == NC_FILL_DOUBLE);
    }
    fs::remove_all(out);
}

TEST_CASE("long horizon: Duffing at its saddle equilibrium with alpha = 4, T = 200: lambda2 ~ e^770 overflows, the "
          "FTLE is the closed form mu+ + ln|P+| / T") {
    // At (0, 0) the state stays put (v = 0 exactly), so DF = exp(J T) with J = [[0, 1], [alpha, -delta]], whose
    // eigenvalues are mu+- = (-delta +- sqrt(delta^2 + 4 alpha)) / 2. exp(J T) = e^{mu+ T} P+ + e^{mu- T} P-, with
    // the spectral projector P+ = v w^T, v = (1, mu+), w = (alpha, mu+) / (alpha + mu+^2); so the largest singular
    // value is e^{mu+ T} |v| |w| (1 + O(e^{-(mu+ - mu-) T})) and FTLE = mu+ + ln(|v| |w|) / T to double precision.
    const double alpha = 4.0, T = 200.0, tol = 1e-11;
    for (const double delta : {0.0, 0.15}) {
        CAPTURE(delta);
        const System duffing = make_system("duffing", {{"alpha", alpha}, {"beta", 1.0}, {"delta", delta}});
        const FlowMap r = flow_map_at_points(
            {Dynamics{&duffing, nullptr}, 0.0, T, settings("dopri5", tol), GradientMethod::variational, true}, {0.0},
            {0.0});
        REQUIRE(r.mask[0] == 0);
        const double mu = (-delta + std::sqrt(delta * delta + 4 * alpha)) / 2;
        const double norm_p = std::hypot(1.0, mu) * std::hypot(alpha, mu) / (alpha + mu * mu);
        const double expected = mu + std::log(norm_p) / T;
        const CauchyGreenPoint p = cg_of(r, 0, T);
        const double bound = steps_per_batch(r.stats) * tol / T;
        MESSAGE("delta " << delta << ": FTLE " << p.ftle << ", closed form " << expected << ", bound " << bound);
        CHECK(2 * mu * T > std::log(1e308)); // lambda2 really overflows
        CHECK(p.lambda2 == std::numeric_limits<double>::infinity());
        CHECK(std::abs(p.ftle - expected) <= bound);
        // Liouville: log det DF = -delta T exactly up to the integration's rounding.
        CHECK(std::abs(r.log_det[0] + delta * T) <= 1e-12 * (1 + delta * T));
    }
}

TEST_CASE("long horizon: Duffing over T = 200, damped and undamped, agrees with a renormalised reference") {
    const double T = 200.0, tol = 1e-10;
    struct Case {
        double delta, eps;
        bool regular; // every sample point's orbit is regular (no chaos), so FTLEs compare point by point
    };
    std::vector<double> xs, ys;
    for (int i = 0; i < 9; ++i)
        for (int j = 0; j < 3; ++j) {
            xs.push_back(-1.6 + 0.4 * i + 0.0123);
            ys.push_back(-0.4 + 0.4 * j + 0.0071);
        }
    for (const Case c : {Case{0.15, 0.0, true}, Case{0.15, 0.1, true}, Case{0.0, 0.0, true}, Case{0.0, 0.08, false},
                         Case{0.15, 0.3, false}}) {
        CAPTURE(c.delta);
        CAPTURE(c.eps);
        const System duffing = make_system("duffing", {{"alpha", 1.0}, {"beta", 1.0}, {"delta", c.delta}});
        const Forcing cosine = make_forcing("cosine", {{"amplitude", c.eps}, {"omega", 1.0}, {"phase", 0.0}});
        const FlowMap r = flow_map_at_points(
            {Dynamics{&duffing, &cosine}, 0.0, T, settings("dopri5", tol), GradientMethod::variational, true}, xs, ys);
        const double bound = steps_per_batch(r.stats) * tol / T;
        double worst = 0.0;
        std::size_t compared = 0;
        for (std::size_t k = 0; k < xs.size(); ++k) {
            CAPTURE(xs[k]);
            CAPTURE(ys[k]);
            REQUIRE(r.mask[k] == 0);
            const CauchyGreenPoint p = cg_of(r, k, T);
            CHECK(std::isfinite(p.ftle));
            CHECK(std::isfinite(p.lambda1));
            CHECK(std::isfinite(p.xi2_x));
            // Liouville: tr Dv = -delta, so lambda1 lambda2 = det(DF)^2 = e^{-2 delta T}, to rounding.
            CHECK(std::abs(p.lambda1 * p.lambda2 / std::exp(-2 * c.delta * T) - 1) < 1e-12);
            if (!c.regular) continue;
            // Undamped and unforced, orbits near the separatrix H = 0 pass the saddle arbitrarily slowly: their
            // FTLE is as sensitive as their phase, so only orbits with |H| >= 0.05 are compared.
            const double H = 0.5 * ys[k] * ys[k] - 0.5 * xs[k] * xs[k] + 0.25 * std::pow(xs[k], 4);
            if (c.delta == 0.0 && std::abs(H) < 0.05) continue;
            const double d = std::abs(p.ftle - reference_ftle(xs[k], ys[k], T, 1.0, c.delta, c.eps));
            worst = std::max(worst, d);
            ++compared;
            CHECK(d <= bound);
        }
        MESSAGE("delta " << c.delta << ", eps " << c.eps << ": " << compared << " points compared, worst |FTLE - ref| "
                         << worst << ", bound N tol / T = " << bound << ", renormalised " << r.stats.renormalised);
    }
}

// ------------------------------------------------------------------------------------------------ tiny horizons

TEST_CASE("tiny horizons: below rounding C = I exactly (degenerate, FTLE 0, no NaN); above it the FTLE tends to the "
          "largest strain rate") {
    const System duffing = make_system("duffing");
    const Dynamics dyn{&duffing, nullptr};
    for (const double T : {1e-300, 1e-20}) {
        CAPTURE(T);
        for (const std::string method : {"dopri5", "rkf78", "rk4", "rosenbrock4"}) {
            CAPTURE(method);
            IntegratorSettings s = settings(method, 1e-10);
            const FlowMap r =
                flow_map_at_points({dyn, 5.0, 5.0 + T, s, GradientMethod::variational, true}, {0.3, -1.2}, {0.2, 0.7});
            for (std::size_t k = 0; k < 2; ++k) {
                CHECK(r.mask[k] == 0); // a last step below the progress floor is taken, not masked
                const CauchyGreenPoint p = cg_of(r, k, T);
                CHECK(p.degenerate);
                CHECK(p.ftle == 0.0);
                CHECK(p.lambda1 == 1.0);
                CHECK(p.lambda2 == 1.0);
                CHECK((std::isfinite(p.xi1_x) && std::isfinite(p.xi1_y) && std::isfinite(p.xi2_x) &&
                       std::isfinite(p.xi2_y)));
            }
        }
    }
    // T = 1e-8: DF = I + T J + O(T^2), so FTLE = s + O(T) with s the largest eigenvalue of (J + J^T) / 2; at (0.3, 0.2)
    // J = [[0, 1], [1 - 3 x^2, 0]] and s = (2 - 3 x^2) / 2 = 0.865. DF's entries near 1 carry rounding ~1e-16, i.e.
    // ~1e-16 / T = 1e-8 relative in the FTLE; the O(T) term is ~|J|^2 T ~ 1e-8: 1e-6 bounds both with room.
    const double T = 1e-8;
    const FlowMap r = flow_map_at_points(
        {dyn, 5.0, 5.0 + T, settings("dopri5", 1e-10), GradientMethod::variational, true}, {0.3}, {0.2});
    const CauchyGreenPoint p = cg_of(r, 0, T);
    CHECK_FALSE(p.degenerate);
    CHECK(std::abs(p.ftle - 0.865) < 1e-6);

    // Through the runner on a grid: every point degenerate and counted, FTLE 0, eigenvectors written as fill.
    const fs::path out = scratch("tiny");
    const RunSummary s = run(json::parse(R"({
        "system": {"plugin": "duffing"}, "forcing": {"plugin": "cosine", "params": {"amplitude": 0.08}},
        "grid": {"x": [-1, 1], "y": [-1, 1], "n": [5, 4]}, "time": {"t0": 0, "t1": 1e-300},
        "products": ["ftle", "eigenvectors"], "output": {"plots": false}})"),
                             out);
    CHECK(s.manifest["degenerate_points"] == 20);
    for (const double v : read_nc(out / "fields.nc", "ftle")) CHECK(v == 0.0);
    for (const double v : read_nc(out / "fields.nc", "xi1_x")) CHECK(v == NC_FILL_DOUBLE);
    fs::remove_all(out);
}

// ------------------------------------------------------------------------------------ lambda1 far below lambda2

namespace {

// det [[a, b], [c, d]] to ~2^-64 relative: each product split exactly into a double and its rounding error by fma
// (a compensated product), the parts summed in long double.
long double reference_det(double a, double b, double c, double d) {
    const double p1 = a * d, e1 = std::fma(a, d, -p1), p2 = b * c, e2 = std::fma(b, c, -p2);
    return (static_cast<long double>(p1) - p2) + (static_cast<long double>(e1) - e2);
}

// lambda2 in long double (the dominant root has no cancellation), and lambda1 = det^2 / lambda2; the entries are
// first scaled by a power of 2 (exactly) so that no product over- or underflows.
void reference_eigenvalues(double a, double b, double c, double d, long double &l1, long double &l2) {
    const int k = std::ilogb(std::max({std::abs(a), std::abs(b), std::abs(c), std::abs(d)}));
    a = std::ldexp(a, -k);
    b = std::ldexp(b, -k);
    c = std::ldexp(c, -k);
    d = std::ldexp(d, -k);
    const long double A = a, B = b, C = c, D = d;
    const long double c11 = A * A + C * C, c12 = A * B + C * D, c22 = B * B + D * D;
    const long double h = (c11 - c22) / 2;
    l2 = std::ldexp((c11 + c22) / 2 + std::sqrt(h * h + c12 * c12), 2 * k);
    const long double det = std::ldexp(reference_det(a, b, c, d), 2 * k);
    l1 = det * det / l2;
}

} // namespace

TEST_CASE("lambda1 to a few ulps where lambda1 / lambda2 < 1e-20, against long double and compensated products") {
    // Bound: det(G) by Kahan's fma algorithm is within 1.5 ulp, doubled by the square (3 ulp); mu2 = (c11 + c22)/2 + r
    // is a sum of non-negative terms each within ~2 ulp (3 ulp in all), and m*m / mu2 adds two roundings: 8 ulp.
    // The scaling by powers of 2 is exact. lambda2 = mu2 scaled: 4 ulp.
    const double bound1 = 8 * ulp, bound2 = 4 * ulp;
    std::vector<std::array<double, 4>> matrices;
    // Cassini: [[F(n+1), F(n)], [F(n), F(n-1)]] has det (-1)^n exactly (while the entries are exact, n < 78) and
    // lambda1 / lambda2 ~ phi^{-4n}; scaled by powers of 2 (exact) up to 2^500, where lambda2 overflows and only
    // lambda1 remains representable.
    double f0 = 0, f1 = 1;
    for (int n = 1; n <= 78; ++n) {
        const double f2 = f0 + f1;
        f0 = f1;
        f1 = f2;
        if (n >= 20 && n % 6 == 0)
            for (const int e : {-300, 0, 40, 300, 500})
                matrices.push_back({std::ldexp(f1, e), std::ldexp(f0, e), std::ldexp(f0, e), std::ldexp(f1 - f0, e)});
    }
    // Random near-singular matrices R(theta) diag(s, s / 10^k) R(phi) with k = 11..150, entries rounded (the
    // reference computes with the rounded entries, which is what lambda1 must be accurate for).
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> angle(-3.1, 3.1), exponent(11, 150), scale(-100, 100);
    for (int i = 0; i < 2000; ++i) {
        const double t = angle(rng), u = angle(rng), s = std::pow(10.0, scale(rng)), k = exponent(rng);
        const double s2 = s * std::pow(10.0, -k);
        const double ct = std::cos(t), st = std::sin(t), cu = std::cos(u), su = std::sin(u);
        matrices.push_back({ct * s * cu - st * s2 * su, -ct * s * su - st * s2 * cu, st * s * cu + ct * s2 * su,
                            -st * s * su + ct * s2 * cu});
    }
    double worst1 = 0, worst2 = 0;
    std::size_t tested = 0;
    for (const auto &m : matrices) {
        long double l1, l2;
        reference_eigenvalues(m[0], m[1], m[2], m[3], l1, l2);
        if (!(l1 > 0) || !(l1 / l2 < 1e-20L)) continue;
        const CauchyGreenPoint p = cauchy_green_at(m[0], m[1], m[2], m[3], 1.0);
        CAPTURE(m[0]);
        CAPTURE(m[1]);
        CAPTURE(m[2]);
        CAPTURE(m[3]);
        if (l1 < std::numeric_limits<double>::min() || l1 > std::numeric_limits<double>::max()) continue;
        const double e1 = static_cast<double>(std::abs(p.lambda1 - l1) / l1);
        worst1 = std::max(worst1, e1);
        CHECK(e1 <= bound1);
        if (l2 < std::numeric_limits<double>::max()) {
            const double e2 = static_cast<double>(std::abs(p.lambda2 - l2) / l2);
            worst2 = std::max(worst2, e2);
            CHECK(e2 <= bound2);
        } else {
            CHECK(p.lambda2 == std::numeric_limits<double>::infinity());
        }
        CHECK(std::abs(p.ftle - static_cast<double>(std::log(l2) / 2)) <= 1e-15 * std::max(1.0, std::abs(p.ftle)));
        ++tested;
    }
    MESSAGE(tested << " matrices with lambda1 / lambda2 < 1e-20: worst relative error of lambda1 " << worst1 / ulp
                   << " ulp (bound 8), of lambda2 " << worst2 / ulp << " ulp (bound 4)");
    CHECK(tested > 1500);
}

// ------------------------------------------------------------------------------------------ stiff systems

TEST_CASE("stiff Duffing (delta = 1000): dopri5 hits its step limit with advice, rosenbrock4 solves it") {
    const System stiff = make_system("duffing", {{"alpha", 1.0}, {"beta", 1.0}, {"delta", 1000.0}});
    const Dynamics dyn{&stiff, nullptr};
    const std::vector<double> x0 = {0.5, -0.3, 1.5}, y0 = {0.2, 0.1, -2.0};
    const double T = 4000.0;
    // Explicit: stability caps the step near 3.3 / 1000, so T = 4000 needs ~1.2e6 steps > max_steps = 1e6.
    const FlowMap limited = flow_map_at_points({dyn, 0.0, T, IntegratorSettings{}}, x0, y0);
    CHECK(limited.stats.masked_step_limit == 3);
    const std::string advice = describe_masking(limited.stats, IntegratorSettings{}, true);
    CHECK(advice.find("dopri5 reached its step limit") != std::string::npos);
    CHECK(advice.find("rosenbrock4") != std::string::npos);
    Grid grid;
    grid.x_min = -1;
    grid.x_max = 1;
    grid.y_min = -1;
    grid.y_max = 1;
    grid.nx = grid.ny = 3;
    IntegratorSettings few = settings("rkf78", 1e-8, 9);
    few.max_steps = 10000;
    CHECK_THROWS_WITH_AS(compute_grid_flow_map({dyn, 0.0, T, few, GradientMethod::none, true}, grid),
                         doctest::Contains("rkf78 reached its step limit (max_steps = 10000"), NumericalError);

    // rosenbrock4 against dopri5 allowed 1e7 steps at 1e-11 (an independent, explicit reference). Both converge to
    // the stable foci (+-1, 0), where errors contract, so rosenbrock4's global error is at most the sum of its local
    // errors, N tol (1 + |x|) <= 2 N tol.
    IntegratorSettings reference = settings("dopri5", 1e-11);
    reference.max_steps = 10000000;
    const FlowMap ref = flow_map_at_points({dyn, 0.0, T, reference, GradientMethod::variational, true}, x0, y0);
    const IntegratorSettings implicit = settings("rosenbrock4", 1e-8);
    for (const bool variational : {false, true}) {
        CAPTURE(variational);
        const FlowMap r = flow_map_at_points(
            {dyn, 0.0, T, implicit, variational ? GradientMethod::variational : GradientMethod::none, true}, x0, y0);
        const double bound = 2 * steps_per_batch(r.stats) * 1e-8;
        MESSAGE("rosenbrock4: " << steps_per_batch(r.stats) << " steps per trajectory (dopri5 needed "
                                << steps_per_batch(ref.stats) << "), position bound " << bound);
        CHECK(r.stats.masked == 0);
        CHECK(r.stats.batches == 3); // one trajectory per batch (lanes_per_batch)
        for (std::size_t k = 0; k < 3; ++k) {
            CHECK(std::abs(r.flow_x[k] - ref.flow_x[k]) <= bound);
            CHECK(std::abs(r.flow_y[k] - ref.flow_y[k]) <= bound);
            if (!variational) continue;
            // log det DF = -delta T by Liouville, to the integration's relative accuracy.
            CHECK(std::abs(r.log_det[k] + 1000.0 * T) <= 1e-8 * 1000.0 * T);
            const CauchyGreenPoint p = cg_of(r, k, T), q = cg_of(ref, k, T);
            CHECK(std::abs(p.ftle - q.ftle) <= bound / T);
        }
    }
}

TEST_CASE("rosenbrock4 on non-stiff known answers: saddle, and forced Duffing with the variational equations") {
    // The Jacobian rows of the variational equations (second derivatives by differences of Dv) and d/dt (by a
    // difference in t) only make the Rosenbrock matrix inexact by ~1e-8; the error estimate still bounds each step.
    const double a = 0.8, T = 5.0, tol = 1e-9;
    const System saddle = make_system("linear-saddle", {{"a", a}});
    const FlowMap r = flow_map_at_points(
        {Dynamics{&saddle, nullptr}, 0.0, T, settings("rosenbrock4", tol), GradientMethod::variational, true},
        {0.3, -0.7}, {0.5, 0.2});
    const double n_tol = steps_per_batch(r.stats) * tol;
    for (std::size_t k = 0; k < 2; ++k) {
        CHECK(std::abs(r.dF[4 * k] - std::exp(a * T)) <= n_tol * std::exp(a * T));
        CHECK(std::abs(r.dF[4 * k + 3] - std::exp(-a * T)) <= n_tol + tol);
        CHECK(std::abs(cg_of(r, k, T).ftle - a) <= n_tol / T);
    }
    // Forced Duffing over one period: time-dependent (the d/dt column matters), against rkf78 at 1e-13.
    const System duffing = make_system("duffing");
    const Forcing cosine = make_forcing("cosine", {{"amplitude", 0.3}, {"omega", 1.2}, {"phase", 0.4}});
    const Dynamics dyn{&duffing, &cosine};
    const std::vector<double> x0 = {0.1, -0.9, 1.3}, y0 = {0.4, 0.0, -0.5};
    const double period = 2 * std::acos(-1.0) / 1.2;
    const FlowMap ref =
        flow_map_at_points({dyn, 0.0, period, settings("rkf78", 1e-13), GradientMethod::variational, true}, x0, y0);
    const FlowMap ros =
        flow_map_at_points({dyn, 0.0, period, settings("rosenbrock4", tol), GradientMethod::variational, true}, x0, y0);
    // |DF| stays below ~20 over one period here; N tol |DF| with N ~ 10^3 steps.
    const double bound = steps_per_batch(ros.stats) * tol * 20;
    for (std::size_t k = 0; k < 3; ++k) {
        CHECK(std::abs(ros.flow_x[k] - ref.flow_x[k]) <= bound);
        CHECK(std::abs(ros.flow_y[k] - ref.flow_y[k]) <= bound);
        for (int q = 0; q < 4; ++q) CHECK(std::abs(ros.dF[4 * k + q] - ref.dF[4 * k + q]) <= bound);
    }
}

// -------------------------------------------------------------------------------------------------- tolerances

TEST_CASE("tolerances: rtol below 1e-14 is clamped with a warning; rtol outside (0, 1) and atol <= 0 are errors") {
    json j = json::parse(R"({"system": {"plugin": "linear-saddle"}, "grid": {"x": [-1, 1], "y": [-1, 1], "n": [3, 3]},
                             "time": {"t0": 0, "t1": 1}, "products": ["ftle"], "integrator": {"rtol": 1e-16}})");
    const Experiment e = parse_experiment(j);
    CHECK(e.integrator.rtol == min_rtol);
    REQUIRE(e.warnings.size() == 1);
    CHECK(e.warnings[0].find("/integrator/rtol") != std::string::npos);
    CHECK(e.warnings[0].find("clamped to 1e-14") != std::string::npos);
    // ... and the warning reaches the manifest.
    const fs::path out = scratch("clamped");
    j["output"] = {{"plots", false}};
    const RunSummary s = run(j, out);
    bool found = false;
    for (const auto &w : s.manifest["warnings"])
        found = found || w.get<std::string>().find("clamped to 1e-14") != std::string::npos;
    CHECK(found);
    CHECK(s.manifest["resolved"]["integrator"]["rtol"] == 1e-14);
    fs::remove_all(out);
    for (const double bad : {0.0, 1.0, 2.0, -1e-8}) {
        j["integrator"] = {{"rtol", bad}};
        CAPTURE(bad);
        CHECK_THROWS_WITH_AS(parse_experiment(j), doctest::Contains("/integrator/rtol"), ConfigError);
    }
    j["integrator"] = {{"atol", 0.0}};
    CHECK_THROWS_WITH_AS(parse_experiment(j), doctest::Contains("/integrator/atol"), ConfigError);
    // The engine clamps on its own too: rtol 1e-300 integrates exactly as rtol 1e-14 (same steps, same result), where
    // unclamped it would shrink every step to the progress floor and mask everything.
    const System saddle = make_system("linear-saddle", {{"a", 0.5}});
    IntegratorSettings tiny = settings("dopri5", 1e-300), floor = settings("dopri5", 1e-14);
    tiny.atol = floor.atol = 1e-12;
    const FlowMap r1 = flow_map_at_points({Dynamics{&saddle, nullptr}, 0.0, 1.0, tiny}, {0.1}, {0.2});
    const FlowMap r2 = flow_map_at_points({Dynamics{&saddle, nullptr}, 0.0, 1.0, floor}, {0.1}, {0.2});
    CHECK(r1.mask[0] == 0);
    CHECK(r1.flow_x[0] == r2.flow_x[0]);
    CHECK(r1.stats.steps == r2.stats.steps);
    IntegratorSettings bad = floor;
    bad.rtol = 1.0;
    CHECK_THROWS_AS(flow_map_at_points({Dynamics{&saddle, nullptr}, 0.0, 1.0, bad}, {0.1}, {0.2}), EngineSettingError);
}

// ------------------------------------------------------------------------------------------------------- grids

TEST_CASE("grids: fewer than 3 points per direction is an error; a grid beyond the memory is refused up front") {
    json j = json::parse(R"({"system": {"plugin": "linear-saddle"}, "grid": {"x": [-1, 1], "y": [-1, 1], "n": [3, 2]},
                             "time": {"t0": 0, "t1": 1}, "products": ["ftle"]})");
    CHECK_THROWS_WITH_AS(parse_experiment(j), doctest::Contains("/grid/n/1"), ConfigError);
    j["grid"]["n"] = {3, 3};
    CHECK_NOTHROW(parse_experiment(j));

    const AvailableMemory m = available_memory();
    CHECK(m.known);
    CHECK(m.bytes > 0);
    MESSAGE("available memory: " << format_bytes(m.bytes) << " (" << m.source << ")");
    Grid huge;
    huge.nx = huge.ny = 100000;
    FieldPlan ftle_only;
    ftle_only.cauchy_green = true;
    ftle_only.gradient = GradientMethod::variational;
    ftle_only.keep = {"ftle"};
    const IntegratorSettings settings;
    const std::uint64_t need = estimate_run_memory(huge, settings, ftle_only);
    // Tiled (tiles.hpp): 1e10 points x (mask 1 + NetCDF buffer 8 + CG mask 1 + ftle 8 = 18 bytes), one tile's points x
    // (mask 1 + positions 16 + DF 32 + CG fields 56 + CG mask 1 + DF exponent 4 + log det 8 = 118 bytes), + 256 MiB.
    const double tile_points = static_cast<double>(tile_rows(huge, settings, ftle_only)) * 1e5;
    CHECK(tile_points >= 1e5);
    CHECK(tile_points <= 1e6);
    CHECK(need == static_cast<std::uint64_t>(18e10 + 118 * tile_points + 256.0 * 1024 * 1024));
    CHECK(format_bytes(need) == "168 GiB");
    // Every Cauchy-Green field kept and a picture: 7 fields and the picture's two buffers more per point.
    FieldPlan all = ftle_only;
    all.keep = cauchy_green_variables();
    all.plot = true;
    CHECK(estimate_run_memory(huge, settings, all) - need == static_cast<std::uint64_t>(1e10 * (6 * 8 + 2 * 8)));
    CHECK(format_bytes(512) == "512 bytes");
    CHECK(format_bytes(3u << 20) == "3.0 MiB");
    const AvailableMemory small{8ull << 30, "a test", true};
    CHECK_THROWS_WITH_AS(check_memory(need, small, huge),
                         "/grid/n: a 100000 x 100000 grid needs about 168 GiB of memory, but only 8.0 GiB is available "
                         "(a test); use fewer points, or split the box into several runs",
                         ConfigError);
    CHECK_NOTHROW(check_memory(1000, small, huge));
    CHECK_NOTHROW(check_memory(need, AvailableMemory{}, huge)); // unknown: nothing is refused
    j["grid"]["n"] = {100000, 100000};
    CHECK_THROWS_WITH_AS(resolve_experiment(parse_experiment(j)), doctest::Contains("needs about"), ConfigError);
}

// ------------------------------------------------------------------------------- escaping and blow-up on a grid

TEST_CASE("escaping and blowing-up trajectories on a grid are masked and counted; all masked is a clear error") {
    // x'' = x + x^3 + 5 cos t (beta = -1): trajectories from |x0| large enough blow up in finite time.
    const System duffing = make_system("duffing", {{"alpha", 1.0}, {"beta", -1.0}, {"delta", 0.0}});
    const Forcing cosine = make_forcing("cosine", {{"amplitude", 5.0}, {"omega", 1.0}, {"phase", 0.0}});
    const Dynamics dyn{&duffing, &cosine};
    Grid grid;
    grid.x_min = -3;
    grid.x_max = 3;
    grid.y_min = -3;
    grid.y_max = 3;
    grid.nx = grid.ny = 13;
    for (const GradientMethod g : {GradientMethod::variational, GradientMethod::auxiliary_grid}) {
        const std::string method_name = to_string(g);
        CAPTURE(method_name);
        const FlowMap fm = compute_grid_flow_map(
            with_grid_offset({dyn, 0.0, 1.5, settings("dopri5", 1e-9), g, true}, grid, 1e-3), grid);
        std::size_t masked = 0;
        for (std::size_t p = 0; p < grid.size(); ++p) {
            if (fm.mask[p] == 0) {
                CHECK(std::isfinite(fm.flow_x[p]));
                for (int q = 0; q < 4; ++q) CHECK(std::isfinite(fm.dF[4 * p + q]));
                continue;
            }
            ++masked;
            CHECK((fm.mask[p] & mask_non_finite) != 0);
            CHECK(std::isnan(fm.flow_x[p]));
        }
        MESSAGE(method_name << ": " << masked << " of " << grid.size() << " points masked");
        CHECK(masked > 0);
        CHECK(masked < grid.size());
        const CauchyGreenField cg = cauchy_green_field(grid, fm.dF, fm.mask, 1.5, fm.dF_exponent, fm.log_det);
        for (std::size_t p = 0; p < grid.size(); ++p)
            CHECK(std::isnan(cg.ftle[p]) == ((fm.mask[p] & mask_trajectory_bits) != 0));
    }
    // Over a longer horizon every trajectory escapes: a NumericalError naming the reason, not an empty result.
    const Forcing huge = make_forcing("cosine", {{"amplitude", 1e6}, {"omega", 1.0}, {"phase", 0.0}});
    CHECK_THROWS_WITH_AS(
        compute_grid_flow_map({Dynamics{&duffing, &huge}, 0.0, 20.0, IntegratorSettings{}, GradientMethod::variational},
                              grid),
        doctest::Contains("every one of the 169 grid points was masked"), NumericalError);
}

TEST_CASE("extractors see masked and degenerate points flagged in the mask") {
    // The probe extractor reports the point of largest FTLE among mask == 0 points; with beta < 0 and a strong
    // forcing, the largest FTLEs would be next to the escaping region, whose points are masked.
    const fs::path out = scratch("probe");
    const RunSummary s = run(json::parse(R"({
        "system": {"plugin": "duffing", "params": {"beta": -1}}, "forcing": {"plugin": "cosine", "params": {"amplitude": 5}},
        "grid": {"x": [-3, 3], "y": [-3, 3], "n": [13, 13]}, "time": {"t0": 0, "t1": 1.5},
        "products": ["ftle"], "extractors": [{"plugin": "probe"}], "output": {"plots": false}})"),
                             out);
    const std::uint64_t masked = s.manifest["integrator_stats"]["masked"];
    CHECK(masked > 0);
    const json barriers = json::parse(std::ifstream(out / "barriers.json"))["barriers"];
    REQUIRE(barriers.size() == 1);
    const double x = barriers[0]["points"][0][0], y = barriers[0]["points"][0][1];
    // The probe's point is a grid point that was not masked: its index in fields.nc's mask is 0.
    int nc = -1, var = -1;
    REQUIRE(nc_open((out / "fields.nc").c_str(), NC_NOWRITE, &nc) == NC_NOERR);
    REQUIRE(nc_inq_varid(nc, "mask", &var) == NC_NOERR);
    std::vector<unsigned char> mask(169);
    REQUIRE(nc_get_var_uchar(nc, var, mask.data()) == NC_NOERR);
    nc_close(nc);
    const long j = std::lround((x + 3) / 0.5), i = std::lround((y + 3) / 0.5);
    CHECK(mask[i * 13 + j] == 0);
    bool warned = false;
    for (const auto &w : s.manifest["warnings"])
        warned = warned || w.get<std::string>().find("blew up") != std::string::npos;
    CHECK(warned);
    fs::remove_all(out);
}

// ------------------------------------------------------------------------- singular points of the line fields

TEST_CASE("singular points (lambda1 = lambda2): counted, and tensor lines stop or step over them, never NaN") {
    // DF = I + e [[x, y], [y, -x]] makes C = I + 2e [[x, y], [y, -x]] + O(e^2): lambda2 - lambda1 ~ 4 e r vanishes
    // only at the origin, a grid point, where C = I exactly; the xi lines wind around it (an index-1/2 singularity).
    Grid grid;
    grid.x_min = grid.y_min = -1;
    grid.x_max = grid.y_max = 1;
    grid.nx = grid.ny = 41;
    const double e = 0.05;
    std::vector<double> dF(4 * grid.size());
    for (std::size_t i = 0; i < grid.ny; ++i)
        for (std::size_t j = 0; j < grid.nx; ++j) {
            const double x = grid.x(j), y = grid.y(i);
            double *f = &dF[4 * (i * grid.nx + j)];
            f[0] = 1 + e * x;
            f[1] = e * y;
            f[2] = e * y;
            f[3] = 1 - e * x;
        }
    const CauchyGreenField cg = cauchy_green_field(grid, dF, std::vector<std::uint8_t>(grid.size(), 0), 1.0);
    CHECK(cg.degenerate_count == 1);
    CHECK(cg.mask[20 * 41 + 20] == mask_degenerate);
    for (const int which : {1, 2}) {
        const LineField field = LineField::from_cauchy_green(cg, which);
        std::size_t stopped_singular = 0, lines = 0;
        // Seeds on a ring around the singularity and on lines through it.
        for (int s = 0; s < 48; ++s) {
            const double angle = 2 * std::acos(-1.0) * s / 48, radius = s % 2 ? 0.3 : 0.07;
            const TwoWayLine line =
                integrate_tensor_line_both_ways(field, radius * std::cos(angle), radius * std::sin(angle));
            ++lines;
            for (const double v : line.xy) CHECK(std::isfinite(v));
            for (const double v : line.s) CHECK(std::isfinite(v));
            for (const StopReason r : {line.stop_backward, line.stop_forward}) {
                CHECK(r != StopReason::masked);
                stopped_singular += r == StopReason::singular;
            }
        }
        MESSAGE("xi" << which << ": " << lines << " lines, " << stopped_singular << " ends at the singular point");
        CHECK(stopped_singular > 0);
    }
    // Through the runner: a vortex whose centre is a rotation (C = I) has a degenerate point, counted in the manifest.
    const fs::path out = scratch("vortex");
    const RunSummary s = run(json::parse(R"({
        "system": {"plugin": "shear-vortex"}, "grid": {"x": [-1, 1], "y": [-1, 1], "n": [21, 21]},
        "time": {"t0": 0, "t1": 2}, "products": ["ftle", "eigenvectors"], "output": {"plots": false}})"),
                             out);
    CHECK(s.manifest["degenerate_points"].get<std::uint64_t>() >= 1);
    fs::remove_all(out);
}

// ------------------------------------------------------------------------------------------------ cancellation

TEST_CASE("cancellation: a requested stop ends the integration promptly with Cancelled, and a run writes nothing") {
    const System saddle = make_system("linear-saddle");
    clear_cancel();
    request_cancel(SIGINT);
    CHECK(cancel_requested() == SIGINT);
    CHECK_THROWS_WITH_AS(flow_map_at_points({Dynamics{&saddle, nullptr}, 0.0, 1.0, IntegratorSettings{}}, {0.1}, {0.2}),
                         "interrupted by SIGINT while integrating trajectories", Cancelled);
    clear_cancel();
    CHECK(cancel_requested() == 0);

    // A long run cancelled from another thread while it integrates: it stops with Cancelled (SIGTERM), and the
    // output folder it created is gone again.
    const fs::path base = scratch("cancelled");
    fs::create_directories(base);
    const fs::path out = base / "nested" / "out";
    const json j = json::parse(R"({
        "system": {"plugin": "duffing"}, "forcing": {"plugin": "cosine"},
        "grid": {"x": [-2, 2], "y": [-2, 2], "n": [400, 400]}, "time": {"t0": 0, "t1": 400},
        "products": ["ftle"]})");
    std::atomic<bool> finished{false};
    std::thread stopper([&] {
        // Wait until the run has created its staging folder, i.e. it is computing, then ask it to stop.
        for (int i = 0; i < 6000 && !finished; ++i) {
            if (fs::exists(out)) break;
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        request_cancel(SIGTERM);
    });
    try {
        run(j, out);
        FAIL("the run was not cancelled");
    } catch (const Cancelled &c) {
        CHECK(c.signal() == SIGTERM);
        CHECK(std::string(c.what()) == "interrupted by SIGTERM while integrating trajectories");
    }
    finished = true;
    stopper.join();
    clear_cancel();
    CHECK_FALSE(fs::exists(out));
    CHECK_FALSE(fs::exists(out.parent_path())); // "nested" was created by the run too
    CHECK(fs::exists(out.parent_path().parent_path()));
    fs::remove_all(fs::temp_directory_path() / ("geobarrier-extremes-" + std::to_string(::getpid())));
}
