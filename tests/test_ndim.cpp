// Systems of more than two state components (flow_map.hpp, max_dimension): the engine's n x n variational equations
// against analytic flow maps (linear saddles of dimension 3 to 6, every engine path), energy conservation along
// Hamiltonian trajectories in four dimensions, the n x n Cauchy-Green tensor, and grids over slices: the uncoupled
// coupled-Duffing system (k = 0) on the (x1, v1) slice reproduces the planar Duffing FTLE.
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/flow_map.hpp>
#include <geobarrier/validation.hpp>

#include <test_support.hpp>

#include <Eigen/Dense>
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

using namespace geobarrier;
using geobarrier::test::make_forcing;
using geobarrier::test::make_system;
using nlohmann::json;

namespace {

// The linear-nd test plugins' rates and analytic DF(T) = Q diag(e^{a_i T}) Q^T (tests/plugins/linear_nd.cpp).
double rate_of(double rate, unsigned i) { return (i % 2 == 0 ? rate : -rate) / (1 + i / 2); }
Eigen::MatrixXd linear_nd_dF(unsigned n, double rate, double angle, double T) {
    Eigen::MatrixXd Q = Eigen::MatrixXd::Identity(n, n);
    Q(0, 0) = Q(2, 2) = std::cos(angle);
    Q(0, 2) = -std::sin(angle);
    Q(2, 0) = std::sin(angle);
    Eigen::VectorXd e(n);
    for (unsigned i = 0; i < n; ++i) e(i) = std::exp(rate_of(rate, i) * T);
    return Q * e.asDiagonal() * Q.transpose();
}

IntegratorSettings settings(const std::string &method, bool adaptive, double tol, double step = 0.05) {
    IntegratorSettings s;
    s.method = method;
    s.adaptive = adaptive;
    s.rtol = s.atol = tol;
    s.step = step;
    s.batch = 8;
    return s;
}

// Coupled Duffing energy (systems/coupled-duffing, alpha = beta = 1): sum_i (v^2/2 - x^2/2 + x^4/4) + k (x1-x2)^2/2.
double coupled_duffing_energy(const double *s, double k) {
    const auto one = [](double x, double v) { return 0.5 * v * v - 0.5 * x * x + 0.25 * x * x * x * x; };
    return one(s[0], s[1]) + one(s[2], s[3]) + 0.5 * k * (s[0] - s[2]) * (s[0] - s[2]);
}

} // namespace

TEST_CASE("linear n-D saddles: DF = Q diag(e^{a T}) Q^T and the Cauchy-Green eigenvalues e^{2 a T}, dimensions 3-6, "
          "every engine path") {
    const double rate = 0.5, angle = 0.3, t0 = 0.5, t1 = 4.5, T = t1 - t0;
    struct Path {
        const char *what;
        IntegratorSettings s;
        double tol; // relative error allowed on DF
    };
    std::vector<Path> paths = {
        {"lockstep dop853 fixed, fused (SDK step)", settings("dop853", false, 1e-10, 0.05), 1e-10},
        {"lockstep dop853 adaptive (stage by stage)", settings("dop853", true, 1e-11), 1e-8},
        {"lockstep rk4 fixed, fused", settings("rk4", false, 1e-10, 0.01), 1e-7},
        {"odeint dopri5", settings("dopri5", true, 1e-11), 1e-8},
        {"rosenbrock4", settings("rosenbrock4", true, 1e-10), 1e-6},
    };
    {
        Path unfused{"lockstep dop853 fixed, stage by stage", settings("dop853", false, 1e-10, 0.05), 1e-10};
        unfused.s.fused = false;
        paths.push_back(unfused);
        Path checked{"lockstep dop853 checked fixed steps, fused", settings("dop853", false, 1e-10, 0.05), 1e-10};
        checked.s.step_tolerance = 1e-6;
        paths.push_back(checked);
        Path checked_unfused = checked;
        checked_unfused.what = "lockstep dop853 checked fixed steps, stage by stage";
        checked_unfused.s.fused = false;
        paths.push_back(checked_unfused);
    }
    paths[3].s.engine = "odeint";
    for (unsigned n = 3; n <= 6; ++n) {
        const System sys = make_system("linear-" + std::to_string(n) + "d", {{"rate", rate}, {"angle", angle}});
        const Dynamics dyn{&sys, nullptr};
        const Eigen::MatrixXd expected = linear_nd_dF(n, rate, angle, T);
        // A few starting states; the flow is linear, so x(T) = DF x0.
        const std::size_t count = 11;
        const auto start = [n](std::size_t k, double *x) {
            for (unsigned i = 0; i < n; ++i) x[i] = std::sin(1.0 + k + 0.7 * i);
        };
        for (const Path &p : paths) {
            CAPTURE(n);
            CAPTURE(p.what);
            const FlowMap r = flow_map_of_states({dyn, t0, t1, p.s, GradientMethod::variational}, count, start);
            REQUIRE(r.dimension == n);
            CHECK(r.stats.masked == 0);
            // The SDK's fused step took every batch where the path says so (n-D fused steps), none elsewhere.
            const bool fused = std::string(p.what).find("fused") != std::string::npos;
            CHECK(r.stats.fused_batches == (fused ? r.stats.batches : 0));
            const std::size_t NN = std::size_t{n} * n;
            double worst_dF = 0.0, worst_x = 0.0;
            for (std::size_t k = 0; k < count; ++k) {
                std::vector<double> x0(n);
                start(k, x0.data());
                const double scale = std::ldexp(1.0, r.dF_exponent[k]);
                for (unsigned i = 0; i < n; ++i) {
                    double xi = 0.0;
                    for (unsigned j = 0; j < n; ++j) {
                        xi += expected(i, j) * x0[j];
                        const double got = scale * r.dF[NN * k + i * n + j];
                        worst_dF = std::max(worst_dF, std::abs(got - expected(i, j)) / expected.norm());
                    }
                    worst_x = std::max(worst_x, std::abs(r.state[n * k + i] - xi) / expected.norm());
                }
                // Liouville: log|det DF| = T tr A = T sum a_i.
                double trace = 0.0;
                for (unsigned i = 0; i < n; ++i) trace += rate_of(rate, i);
                CHECK(r.log_det[k] == doctest::Approx(trace * T).epsilon(p.tol * 10));
            }
            CHECK(worst_dF < p.tol);
            CHECK(worst_x < p.tol);
            // The n x n Cauchy-Green tensor of one point: eigenvalues e^{2 a_i T} ascending, FTLE = max a_i.
            const CauchyGreenND cg = cauchy_green_nd(&r.dF[0], n, T, r.dF_exponent[0], r.log_det[0]);
            std::vector<double> lambdas;
            for (unsigned i = 0; i < n; ++i) lambdas.push_back(std::exp(2.0 * rate_of(rate, i) * T));
            std::sort(lambdas.begin(), lambdas.end());
            for (unsigned i = 0; i < n; ++i) CHECK(cg.lambda[i] == doctest::Approx(lambdas[i]).epsilon(p.tol * 100));
            CHECK(cg.ftle == doctest::Approx(rate).epsilon(p.tol * 100));
        }
    }
}

TEST_CASE("the n x n Cauchy-Green tensor: SVD eigenvalues agree with Eigen's SelfAdjointEigenSolver on C, and stay "
          "accurate where forming C loses the small ones") {
    // A random-ish 4 x 4 gradient: both ways agree.
    const unsigned n = 4;
    Eigen::MatrixXd G(n, n);
    for (unsigned i = 0; i < n; ++i)
        for (unsigned j = 0; j < n; ++j) G(i, j) = std::sin(1.3 * i + 0.7 * j + 0.1) + (i == j ? 1.5 : 0.0);
    std::vector<double> row_major(n * n);
    for (unsigned i = 0; i < n; ++i)
        for (unsigned j = 0; j < n; ++j) row_major[i * n + j] = G(i, j);
    const CauchyGreenND cg = cauchy_green_nd(row_major.data(), n, 2.0);
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(G.transpose() * G);
    for (unsigned i = 0; i < n; ++i) {
        CHECK(cg.lambda[i] == doctest::Approx(eig.eigenvalues()(i)).epsilon(1e-12));
        // Eigenvectors up to sign: |v . w| = 1.
        double dot = 0.0;
        for (unsigned j = 0; j < n; ++j) dot += cg.eigenvectors[i * n + j] * eig.eigenvectors()(j, i);
        CHECK(std::abs(dot) == doctest::Approx(1.0).epsilon(1e-10));
    }
    CHECK(cg.ftle == doctest::Approx(std::log(eig.eigenvalues()(n - 1)) / 4.0).epsilon(1e-12));
    // Extreme stretching: DF = diag(1e12, 1e-12, 3, 1/3) in a rotated basis; C's smallest eigenvalue 1e-24 is below
    // eps * 1e24 and lost in any eigen-solver of C, but Liouville's det DF = 1 gives it back.
    const Eigen::MatrixXd dF = linear_nd_dF(n, 0.0, 0.4, 1.0) *
                               Eigen::Vector4d(1e12, 1e-12, 3.0, 1.0 / 3.0).asDiagonal() *
                               linear_nd_dF(n, 0.0, 0.4, 1.0).transpose();
    for (unsigned i = 0; i < n; ++i)
        for (unsigned j = 0; j < n; ++j) row_major[i * n + j] = dF(i, j);
    const CauchyGreenND stiff = cauchy_green_nd(row_major.data(), n, 1.0, 0, 0.0);
    CHECK(stiff.lambda[0] == doctest::Approx(1e-24).epsilon(1e-6));
    CHECK(stiff.lambda[3] == doctest::Approx(1e24).epsilon(1e-12));
    CHECK(stiff.ftle == doctest::Approx(std::log(1e12)).epsilon(1e-14));
}

TEST_CASE("energy is conserved along Hamiltonian trajectories in four dimensions (coupled Duffing, spring pendulum)") {
    const Forcing none = make_forcing("none");
    IntegratorSettings s = settings("dop853", true, 1e-12);
    {
        const double k = 0.3;
        const System sys = make_system("coupled-duffing", {{"k", k}, {"delta", 0.0}});
        const Dynamics dyn{&sys, &none};
        const auto start = [](std::size_t p, double *x) {
            x[0] = -1.2 + 0.2 * p;
            x[1] = 0.3;
            x[2] = 0.8 - 0.1 * p;
            x[3] = -0.2;
        };
        const std::size_t count = 12;
        const FlowMap r = flow_map_of_states({dyn, 0.0, 40.0, s, GradientMethod::variational}, count, start);
        CHECK(r.stats.masked == 0);
        for (std::size_t p = 0; p < count; ++p) {
            double x0[4];
            start(p, x0);
            CAPTURE(p);
            CHECK(std::abs(coupled_duffing_energy(&r.state[4 * p], k) - coupled_duffing_energy(x0, k)) < 1e-9);
            // Hamiltonian: volume preserving, log|det DF| = 0.
            CHECK(std::abs(r.log_det[p]) < 1e-12);
        }
    }
    {
        const double g = 1.0, k = 4.0, L0 = 1.0;
        const System sys = make_system("spring-pendulum", {{"g", g}, {"k", k}, {"rest_length", L0}});
        const Dynamics dyn{&sys, &none};
        const auto energy = [&](const double *x) {
            return 0.5 * (x[1] * x[1] + x[0] * x[0] * x[3] * x[3]) - g * x[0] * std::cos(x[2]) +
                   0.5 * k * (x[0] - L0) * (x[0] - L0);
        };
        const auto start = [](std::size_t p, double *x) {
            x[0] = 1.1 + 0.05 * p;
            x[1] = 0.1;
            x[2] = 0.5 + 0.1 * p;
            x[3] = -0.3;
        };
        const std::size_t count = 9;
        const FlowMap r = flow_map_of_states({dyn, 0.0, 30.0, s}, count, start);
        CHECK(r.stats.masked == 0);
        for (std::size_t p = 0; p < count; ++p) {
            double x0[4];
            start(p, x0);
            CAPTURE(p);
            CHECK(std::abs(energy(&r.state[4 * p]) - energy(x0)) < 1e-9);
        }
    }
}

namespace {

json slice_experiment(const std::string &tensor) {
    return json::parse(R"({
      "system":  {"plugin": "coupled-duffing", "params": {"alpha": 1, "beta": 1, "delta": 0, "k": 0}},
      "forcing": {"plugin": "cosine", "params": {"amplitude": 0.08}},
      "grid":    {"axes": ["x1", "v1"], "x1": [-1.5, 1.5], "v1": [-1, 1], "n": [21, 15],
                  "fixed": {"x2": 0.4, "v2": -0.2}},
      "cauchy_green": {"method": "variational", "slice_tensor": ")" +
                       tensor + R"("},
      "time":    {"t0": 0, "t1": 12},
      "products": ["ftle", "eigenvalues"]
    })");
}

RunSummary run_in_memory(json j) {
    j["plugin_paths"] = {test::plugin_dir().string(), test::test_plugin_dir().string()};
    RunOptions options;
    options.quiet = true;
    options.write_files = false;
    options.keep_results = true;
    return run_experiment(resolve_experiment(parse_experiment(j)), options);
}

const std::vector<double> &field(const RunSummary &s, const std::string &name) {
    for (const FieldResult &f : s.fields)
        if (f.name == name) return f.values;
    FAIL("no field " << name);
    static const std::vector<double> none;
    return none;
}

} // namespace

TEST_CASE("a slice of the uncoupled system (k = 0) reproduces the planar Duffing FTLE to 1e-10") {
    json planar = slice_experiment("restricted");
    planar["system"] = {{"plugin", "duffing"}, {"params", {{"alpha", 1}, {"beta", 1}, {"delta", 0}}}};
    planar["grid"] = {{"x", {-1.5, 1.5}}, {"y", {-1, 1}}, {"n", {21, 15}}};
    planar["cauchy_green"].erase("slice_tensor");
    const RunSummary reference = run_in_memory(planar);
    const std::vector<double> &ftle0 = field(reference, "ftle");
    for (const char *tensor : {"restricted", "projected"}) {
        CAPTURE(tensor);
        const RunSummary slice = run_in_memory(slice_experiment(tensor));
        const std::vector<double> &ftle = field(slice, "ftle");
        REQUIRE(ftle.size() == ftle0.size());
        double worst = 0.0;
        for (std::size_t p = 0; p < ftle.size(); ++p) worst = std::max(worst, std::abs(ftle[p] - ftle0[p]));
        CHECK(worst < 1e-10);
        MESSAGE(std::string(tensor) << ": largest FTLE difference to the planar run " << worst);
        CHECK(slice.field_attributes.at("slice_axes") == "x1 v1");
        CHECK(slice.field_attributes.at("slice_fixed_x2") == 0.4);
    }
    // The whole 4 x 4 tensor stretches at least as much as its restriction to the slice (interlacing), and here
    // the second oscillator, uncoupled, adds its own stretching: full FTLE = max(FTLE on the slice, FTLE of the
    // second oscillator's state), never below the slice's.
    const RunSummary full = run_in_memory(slice_experiment("full"));
    const std::vector<double> &ftle_full = field(full, "ftle");
    std::size_t above = 0;
    for (std::size_t p = 0; p < ftle0.size(); ++p) {
        CHECK(ftle_full[p] >= ftle0[p] - 1e-12);
        above += ftle_full[p] > ftle0[p] + 1e-6;
    }
    CHECK(above > 0); // the second oscillator (at (0.4, -0.2), inside the double well's separatrix loop) stretches too
}

TEST_CASE("event sections: crossings of a hyperplane located to the integrator's tolerance (known crossing times)") {
    // linear-4d with angle 0: x_i(t) = x_i(0) e^{a_i t}, a = (0.5, -0.5, 0.25, -0.25).
    const System sys = make_system("linear-4d", {{"rate", 0.5}, {"angle", 0.0}});
    const Dynamics dyn{&sys, nullptr};
    IntegratorSettings s = settings("dop853", true, 1e-12);
    std::vector<double> seeds;
    for (int p = 0; p < 5; ++p) seeds.insert(seeds.end(), {0.1 * (p + 1), 1.0, 0.2, 1.0});
    const double t0 = 0.3;
    // x0 = 1 upward: t* = t0 + ln(1 / x0(0)) / 0.5 (between 0 and 4.6 after t0; sampled every 0.7).
    const SectionCrossings up =
        section_crossings(dyn, s, std::nullopt, seeds, t0, t0 + 6.0, {1, 0, 0, 0}, 1.0, +1, 100, 0.7);
    REQUIRE(up.times.size() == 5); // the fifth seed starts at 0.5 ... each crosses once
    for (std::size_t c = 0; c < up.times.size(); ++c) {
        const std::size_t p = up.seeds[c];
        const double exact = t0 + std::log(1.0 / (0.1 * (p + 1))) / 0.5;
        CAPTURE(p);
        CHECK(std::abs(up.times[c] - exact) < 1e-10);
        CHECK(std::abs(up.states[4 * c] - 1.0) < 1e-11);
        CHECK(std::abs(up.states[4 * c + 1] - std::exp(-0.5 * (exact - t0))) < 1e-11);
    }
    // The same plane downward: x0 only grows, so no crossing; x1 = 0.5 downward at t0 + 2 ln 2 for every seed.
    CHECK(section_crossings(dyn, s, std::nullopt, seeds, t0, t0 + 6.0, {1, 0, 0, 0}, 1.0, -1, 100, 0.7).times.empty());
    const SectionCrossings down =
        section_crossings(dyn, s, std::nullopt, seeds, t0, t0 + 6.0, {0, 2, 0, 0}, 1.0, -1, 3, 0.7);
    REQUIRE(down.times.size() == 3); // max_crossings
    for (double t : down.times) CHECK(std::abs(t - (t0 + 2.0 * std::log(2.0))) < 1e-10);
}

TEST_CASE("period-map iterates on a slice carry the whole state from period to period") {
    const System sys = make_system("coupled-duffing", {{"k", 0.3}});
    const Forcing cosine = make_forcing("cosine", {{"amplitude", 0.08}});
    Slice slice;
    slice.axes = {0, 1};
    slice.state = {0.0, 0.0, 0.4, -0.2};
    const Dynamics on_slice{&sys, &cosine, &slice};
    const Dynamics whole{&sys, &cosine, nullptr};
    const IntegratorSettings s = settings("dop853", true, 1e-11);
    const double period = 2.0 * std::acos(-1.0);
    const std::vector<double> seeds = {0.3, 0.1, -0.5, 0.2};
    const Snapshots it = poincare_iterates(on_slice, s, std::nullopt, seeds, 0.0, period, 2);
    // Two periods at once from the whole initial states.
    const FlowMap direct = flow_map_of_states({whole, 0.0, 2.0 * period, s}, 2, [&](std::size_t p, double *x) {
        std::copy(slice.state.begin(), slice.state.end(), x);
        x[0] = seeds[2 * p];
        x[1] = seeds[2 * p + 1];
    });
    for (std::size_t p = 0; p < 2; ++p) {
        CHECK(std::abs(it.positions[2][2 * p] - direct.state[4 * p]) < 1e-8);
        CHECK(std::abs(it.positions[2][2 * p + 1] - direct.state[4 * p + 1]) < 1e-8);
    }
}
