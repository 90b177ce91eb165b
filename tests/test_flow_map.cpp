// Tests of the flow map engine (lockstep batches, step-size control, masking, gradients of the flow map) against
// closed-form flows: the linear saddle, a rigid rotation, and invariants of the Duffing oscillator.
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/flow_map.hpp>

#include <test_support.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

using namespace geobarrier;
using geobarrier::test::make_forcing;
using geobarrier::test::make_system;

namespace {

const double pi = std::acos(-1.0);

IntegratorSettings settings_for(const std::string &method, double tol, std::size_t batch) {
    IntegratorSettings s;
    s.method = method;
    s.rtol = tol;
    s.atol = tol;
    s.batch = batch;
    return s;
}

// Classic RK4 applied to x' = a x multiplies by this per step of size h.
double rk4_factor(double z) { return 1.0 + z + z * z / 2.0 + z * z * z / 6.0 + z * z * z * z / 24.0; }

// A system of the faulty test plugins (tests/plugins/faulty.cpp), stiffness k = 1.
System faulty_system(const std::string &name) {
    const std::vector<PluginHandle> handles =
        load_plugin_library(geobarrier::test::test_plugin_dir() / "faulty" / "geobarrier-faulty.so");
    const auto it = std::find_if(handles.begin(), handles.end(), [&](const PluginHandle &h) {
        return h.info.kind == PluginKind::system && h.info.name == name;
    });
    REQUIRE(it != handles.end());
    return System(*it, validate_params(it->info, {{"k", 1.0}}, "/system/params"));
}

} // namespace

TEST_CASE("linear saddle: flow map = (x0 e^{aT}, y0 e^{-aT}) for every stepper, both time directions, any batch") {
    const double a = 0.8;
    const System saddle = make_system("linear-saddle", {{"a", a}});
    const Dynamics dyn{&saddle, nullptr};
    std::vector<double> x0, y0;
    test::sample_points(37, x0, y0); // 37: batches of 16 leave a partial last batch
    for (const std::string method : {"dopri5", "rkf78", "rk4"}) {
        for (double t1 : {6.0, -4.0}) {
            for (std::size_t batch : {1, 16}) {
                CAPTURE(method);
                CAPTURE(t1);
                CAPTURE(batch);
                const double t0 = 1.0, T = t1 - t0; // T = +5 forward, -5 backward
                const IntegratorSettings s = settings_for(method, 1e-10, batch);
                const FlowMap r = flow_map_at_points({dyn, t0, t1, s}, x0, y0);
                REQUIRE(r.flow_x.size() == x0.size());
                CHECK(r.stats.masked == 0);
                CHECK(r.stats.batches == (x0.size() + batch - 1) / batch);
                CHECK(r.stats.steps > 0);
                // Adaptive: every step's local error is below tol (atol + rtol |x|) and the flow carries it to t1
                // growing exactly like the solution, so the global error is at most N tol (1 + |x(t1)|) with N
                // steps per batch. N <= 200 is checked (batches are alike, so the mean stands for the max), which
                // makes 2e-8 (1 + |x|) a bound, not a guess.
                // RK4 with h = 0.01: the relative error of R(ah)^N against e^{aT} is about |T| a^5 h^4 / 120
                // = 1.4e-10, inside the same bound.
                if (method != "rk4") CHECK(r.stats.steps <= 200 * r.stats.batches);
                for (std::size_t k = 0; k < x0.size(); ++k) {
                    const double ex = x0[k] * std::exp(a * T), ey = y0[k] * std::exp(-a * T);
                    CHECK(std::abs(r.flow_x[k] - ex) <= 2e-8 * (1.0 + std::abs(ex)));
                    CHECK(std::abs(r.flow_y[k] - ey) <= 2e-8 * (1.0 + std::abs(ey)));
                }
                if (method == "rk4") {
                    // The fixed-step loop must take exactly 500 steps of 0.01 (the last landing on t1): then the
                    // result is x0 R(a h)^500 up to rounding (~1e-13 over 500 products).
                    CHECK(r.stats.steps == 500 * r.stats.batches);
                    const double h = std::copysign(0.01, T);
                    for (std::size_t k = 0; k < x0.size(); ++k) {
                        const double ex = x0[k] * std::pow(rk4_factor(a * h), 500.0);
                        const double ey = y0[k] * std::pow(rk4_factor(-a * h), 500.0);
                        CHECK(std::abs(r.flow_x[k] - ex) <= 1e-12 * std::abs(ex) + 1e-300);
                        CHECK(std::abs(r.flow_y[k] - ey) <= 1e-12 * std::abs(ey) + 1e-300);
                    }
                }
            }
        }
    }
}

TEST_CASE("linear saddle: variational DF = diag(e^{aT}, e^{-aT})") {
    const double a = 1.3;
    const System saddle = make_system("linear-saddle", {{"a", a}});
    const Dynamics dyn{&saddle, nullptr};
    std::vector<double> x0, y0;
    test::sample_points(20, x0, y0);
    for (const std::string method : {"dopri5", "rkf78", "rk4"}) {
        for (double T : {3.0, -3.0}) {
            CAPTURE(method);
            CAPTURE(T);
            const FlowMap r = flow_map_at_points(
                {dyn, 0.0, T, settings_for(method, 1e-10, 8), GradientMethod::variational, true}, x0, y0);
            REQUIRE(r.dF.size() == 4 * x0.size());
            // Same bound as for the positions: N tol per unit of |DF| (N <= 200 steps for the adaptive methods).
            if (method != "rk4") CHECK(r.stats.steps <= 200 * r.stats.batches);
            for (std::size_t k = 0; k < x0.size(); ++k) {
                CHECK(std::abs(r.dF[4 * k] - std::exp(a * T)) <= 2e-8 * std::exp(a * std::abs(T)));
                CHECK(r.dF[4 * k + 1] == 0.0); // the off-diagonal stays exactly zero: J is diagonal
                CHECK(r.dF[4 * k + 2] == 0.0);
                CHECK(std::abs(r.dF[4 * k + 3] - std::exp(-a * T)) <= 2e-8 * std::exp(a * std::abs(T)));
                CHECK(std::abs(r.flow_x[k] - x0[k] * std::exp(a * T)) <= 2e-8 * (1.0 + std::exp(a * std::abs(T))));
            }
        }
    }
}

TEST_CASE("linear saddle on a grid: both gradient methods give DF = diag(e^{aT}, e^{-aT}) and FTLE = a") {
    const double a = 0.9, T = 4.0;
    const System saddle = make_system("linear-saddle", {{"a", a}});
    const Dynamics dyn{&saddle, nullptr};
    const Grid grid{-1.0, 1.0, -0.5, 0.7, 13, 7}; // x range, y range, nx, ny
    for (GradientMethod gm : {GradientMethod::variational, GradientMethod::auxiliary_grid}) {
        for (double t1 : {T, -T}) {
            for (bool positions : {false, true}) {
                CAPTURE(to_string(gm));
                CAPTURE(t1);
                CAPTURE(positions);
                const FlowMap fm = compute_grid_flow_map(
                    with_grid_offset({dyn, 0.0, t1, settings_for("dopri5", 1e-10, 16), gm, positions}, grid, 1e-4),
                    grid);
                REQUIRE(fm.dF.size() == 4 * grid.size());
                CHECK(fm.flow_x.size() == (positions ? grid.size() : 0));
                const double e = std::exp(a * t1), big = std::exp(a * T);
                // The discrete flow of a linear system is linear in x0, so centred differences of lockstep lanes
                // (identical steps) reproduce it exactly but for rounding: eps |F| / (2 d) with d = 1e-4 dx ~ 1.7e-5
                // gives ~1e-11 |F|. Integration error as above: <= 1e-8 |DF|.
                for (std::size_t p = 0; p < grid.size(); ++p) {
                    CHECK(std::abs(fm.dF[4 * p] - e) <= 1e-8 * big);
                    CHECK(std::abs(fm.dF[4 * p + 1]) <= 1e-8 * big);
                    CHECK(std::abs(fm.dF[4 * p + 2]) <= 1e-8 * big);
                    CHECK(std::abs(fm.dF[4 * p + 3] - 1.0 / e) <= 1e-8 * big);
                    if (positions) {
                        const double x = grid.x(p % grid.nx), y = grid.y(p / grid.nx);
                        CHECK(std::abs(fm.flow_x[p] - x * e) <= 1e-8 * (1.0 + big));
                        CHECK(std::abs(fm.flow_y[p] - y / e) <= 1e-8 * (1.0 + big));
                    }
                }
                const CauchyGreenField cg = cauchy_green_field(grid, fm.dF, fm.mask, T);
                CHECK(cg.degenerate_count == 0);
                for (std::size_t p = 0; p < grid.size(); ++p) {
                    // d ftle = d lambda2 / (2 T lambda2) <= 2e-8 / (2 T): FTLE = a to 1e-8.
                    CHECK(std::abs(cg.ftle[p] - a) <= 1e-8);
                    // Forward time stretches along x, backward time along y.
                    CHECK(std::abs(std::abs(t1 > 0 ? cg.xi2_x[p] : cg.xi2_y[p]) - 1.0) <= 1e-12);
                }
            }
        }
    }
    // The auxiliary grid integrates 4 (5 with positions) lanes per grid point.
    const FlowMap aux = compute_grid_flow_map(
        with_grid_offset({dyn, 0.0, T, settings_for("dopri5", 1e-10, 16), GradientMethod::auxiliary_grid, true}, grid,
                         1e-4),
        grid);
    CHECK(aux.stats.trajectories == 5 * grid.size());
    const FlowMap none = compute_grid_flow_map({dyn, 0.0, T, settings_for("dopri5", 1e-10, 16)}, grid);
    CHECK(none.dF.empty());
    CHECK(none.flow_x.size() == grid.size());
    CHECK(none.stats.trajectories == grid.size());
}

TEST_CASE("rigid rotation: C = I, so lambda1 = lambda2 = 1, FTLE 0, degenerate") {
    const double omega = 1.7, T = 3.0;
    const System rotation = make_system("rigid-rotation", {{"omega", omega}});
    const Dynamics dyn{&rotation, nullptr};
    const Grid grid{-1.0, 1.0, -1.0, 1.0, 9, 9}; // x range, y range, nx, ny
    REQUIRE(rotation.has_jacobian());
    for (GradientMethod gm : {GradientMethod::auxiliary_grid, GradientMethod::variational}) {
        CAPTURE(to_string(gm));
        const FlowMap fm = compute_grid_flow_map(
            with_grid_offset({dyn, 0.0, T, settings_for("dopri5", 1e-10, 16), gm, true}, grid, 1e-4), grid);
        const CauchyGreenField cg = cauchy_green_field(grid, fm.dF, fm.mask, T);
        for (std::size_t p = 0; p < grid.size(); ++p) {
            CHECK(std::abs(cg.lambda1[p] - 1.0) <= 1e-8);
            CHECK(std::abs(cg.lambda2[p] - 1.0) <= 1e-8);
            CHECK(std::abs(cg.ftle[p]) <= 1e-8 / T);
            CHECK(std::isfinite(cg.xi1_x[p]));
            CHECK(std::isfinite(cg.xi2_y[p]));
            const double x = grid.x(p % grid.nx), y = grid.y(p / grid.nx);
            CHECK(std::abs(fm.flow_x[p] - (x * std::cos(omega * T) - y * std::sin(omega * T))) <= 1e-8);
            CHECK(std::abs(fm.flow_y[p] - (x * std::sin(omega * T) + y * std::cos(omega * T))) <= 1e-8);
        }
        if (gm == GradientMethod::variational) {
            // Each RK step maps DF by a polynomial in h A with A = omega [[0, -1], [1, 0]]: a scaled rotation. So
            // the computed DF stays a scaled rotation to rounding, C is a multiple of I to rounding, and every
            // point is degenerate. (The auxiliary grid's rounding, eps / d ~ 1e-11, exceeds degenerate_gap = 1e-12,
            // so it is not expected to flag them.)
            CHECK(cg.degenerate_count == grid.size());
        }
    }
}

TEST_CASE("unforced undamped Duffing conserves H = y^2/2 - x^2/2 + x^4/4") {
    const System duffing = make_system("duffing", {{"alpha", 1.0}, {"beta", 1.0}, {"delta", 0.0}});
    const Forcing none = make_forcing("none");
    std::vector<double> x0, y0;
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j) {
            x0.push_back(-1.6 + 3.2 * j / 5.0);
            y0.push_back(-0.9 + 1.8 * i / 5.0);
        }
    // Near the separatrix H = 0 (homoclinic loops through the saddle at 0, reaching x = +-sqrt 2).
    for (double x : {std::sqrt(2.0) - 1e-3, -std::sqrt(2.0) + 1e-4, 1e-3, std::sqrt(2.0) + 1e-3}) {
        x0.push_back(x);
        y0.push_back(0.0);
    }
    x0.push_back(0.0);
    y0.push_back(1e-3);
    for (const std::string method : {"dopri5", "rkf78"}) {
        for (const Forcing *forcing : {&none, static_cast<const Forcing *>(nullptr)}) {
            CAPTURE(method);
            const Dynamics dyn{&duffing, forcing};
            const FlowMap r = flow_map_at_points({dyn, 0.0, 20.0, settings_for(method, 1e-10, 8)}, x0, y0);
            CHECK(r.stats.masked == 0);
            double worst = 0.0;
            for (std::size_t k = 0; k < x0.size(); ++k)
                worst = std::max(worst, std::abs(test::duffing_energy(r.flow_x[k], r.flow_y[k]) -
                                                 test::duffing_energy(x0[k], y0[k])));
            MESSAGE(method << ": max |dH| = " << worst);
            // Local errors <= 1e-10 (1 + |x|) in state give |dH| <= |grad H| 1e-10 per step, N ~ 10^2-10^3 steps.
            CHECK(worst < 1e-7);
        }
    }
}

TEST_CASE("forced Duffing: variational and auxiliary-grid gradients agree") {
    // The paper's first example (eps = 0.08) over two forcing periods, on a coarse grid (dx = 0.26) so that the
    // auxiliary grid's own error is large enough to be checked against its prediction.
    const System duffing = make_system("duffing");
    const Forcing cosine = make_forcing("cosine", {{"amplitude", 0.08}, {"omega", 1.0}, {"phase", 0.0}});
    const Dynamics dyn{&duffing, &cosine};
    const Grid grid{-1.8, 1.8, -1.2, 1.2, 15, 11}; // x range, y range, nx, ny
    const double T = 4.0 * pi, offset = 1e-4;
    const IntegratorSettings s = settings_for("dopri5", 1e-11, 16);
    const FlowMap var = compute_grid_flow_map({dyn, 0.0, T, s, GradientMethod::variational, true}, grid);
    const FlowMap aux = compute_grid_flow_map(
        with_grid_offset({dyn, 0.0, T, s, GradientMethod::auxiliary_grid, true}, grid, offset), grid);
    const FlowMap aux2 = compute_grid_flow_map(
        with_grid_offset({dyn, 0.0, T, s, GradientMethod::auxiliary_grid}, grid, 2.0 * offset), grid);
    const CauchyGreenField cv = cauchy_green_field(grid, var.dF, var.mask, T);
    const CauchyGreenField ca = cauchy_green_field(grid, aux.dF, aux.mask, T);
    // Error budget of the auxiliary grid, d = 1e-4 dx = 2.6e-5:
    //   truncation  the centred difference errs by E(d) = d^2 D^3F / 6 + O(d^4), so Richardson's
    //               (A(2d) - A(d)) / 3 predicts it, entry by entry;
    //   rounding    eps |F| / d ~ 1.1e-16 * 2 / 2.6e-5 ~ 1e-11 (absolute);
    //   integration lockstep lanes share their steps, so their errors differ smoothly: relative N tol, like
    //               the variational DF's own error (~1e-9 of |DF| at tol 1e-11).
    // So |DF_var - DF_aux| <= 1.25 |A(2d) - A(d)| / 3 + 1e-8 |DF| per entry (1.25: room for the O(d^4) term;
    // 1e-8: the rounding and integration terms with margin). Measured: the difference is truncation, ~6.6e-5 of
    // |DF| at worst, and scales as d^2 (6.6e-3 at 10 d, 6.6e-7 at d / 10).
    double worst_df = 0.0, worst_ftle = 0.0, worst_pos = 0.0;
    for (std::size_t p = 0; p < grid.size(); ++p) {
        CAPTURE(p);
        REQUIRE(var.mask[p] == 0);
        REQUIRE(aux.mask[p] == 0);
        double norm = 0.0, diff = 0.0;
        for (int q = 0; q < 4; ++q) norm = std::max(norm, std::abs(var.dF[4 * p + q]));
        for (int q = 0; q < 4; ++q) {
            const double d = std::abs(var.dF[4 * p + q] - aux.dF[4 * p + q]);
            const double predicted = std::abs(aux2.dF[4 * p + q] - aux.dF[4 * p + q]) / 3.0;
            CHECK(d <= 1.25 * predicted + 1e-8 * norm);
            diff = std::max(diff, d);
        }
        worst_df = std::max(worst_df, diff / norm);
        worst_ftle = std::max(worst_ftle, std::abs(cv.ftle[p] - ca.ftle[p]));
        worst_pos = std::max(
            worst_pos, std::max(std::abs(var.flow_x[p] - aux.flow_x[p]), std::abs(var.flow_y[p] - aux.flow_y[p])));
    }
    MESSAGE("max |DF_var - DF_aux| / max|DF| = " << worst_df << ", max |ftle diff| = " << worst_ftle
                                                 << ", max position diff = " << worst_pos);
    // The overall agreement at the default offset: 1e-4 of |DF| (measured 6.6e-5), hence |d ftle| <= 1e-4 / T.
    CHECK(worst_df < 1e-4);
    CHECK(worst_ftle < 1e-4 / T);
    // Positions: two runs at tol 1e-11 with different step sequences; their errors N tol |DF| ~ 300 * 1e-11 * 230.
    CHECK(worst_pos < 1e-6);
}

TEST_CASE("bounds: trajectories leaving the box are masked, the others are exact") {
    const double a = 1.0, T = 2.0; // x(T) = 7.389 x0: leaves |x| <= 3 iff |x0| > 0.406
    const System saddle = make_system("linear-saddle", {{"a", a}});
    const Dynamics dyn{&saddle, nullptr};
    std::vector<double> x0, y0;
    for (int k = 0; k <= 20; ++k) {
        x0.push_back(-1.0 + 0.1 * k);
        y0.push_back(0.5);
    }
    const Bounds box{-3.0, 3.0, -3.0, 3.0};
    for (std::size_t batch : {1, 8, 64}) {
        CAPTURE(batch);
        const FlowMap r = flow_map_at_points(
            {dyn, 0.0, T, settings_for("dopri5", 1e-10, batch), GradientMethod::none, false, box}, x0, y0);
        std::uint64_t expected = 0;
        for (std::size_t k = 0; k < x0.size(); ++k) {
            CAPTURE(x0[k]);
            if (std::abs(x0[k]) > 0.45) {
                ++expected;
                CHECK(r.mask[k] == mask_left_bounds);
                CHECK(std::isnan(r.flow_x[k]));
                CHECK(std::isnan(r.flow_y[k]));
            } else {
                CHECK(r.mask[k] == 0);
                CHECK(std::abs(r.flow_x[k] - x0[k] * std::exp(a * T)) <= 1e-8 * (1.0 + std::exp(a * T)));
                CHECK(std::abs(r.flow_y[k] - y0[k] * std::exp(-a * T)) <= 1e-8);
            }
        }
        CHECK(r.stats.masked_left_bounds == expected);
        CHECK(r.stats.masked == expected);
    }
    // On a grid, a point is masked when any of its auxiliary neighbours is.
    const Grid grid{-1.0, 1.0, 0.0, 0.5, 21, 2}; // x range, y range, nx, ny
    const FlowMap fm = compute_grid_flow_map(
        with_grid_offset({dyn, 0.0, T, settings_for("dopri5", 1e-10, 16), GradientMethod::auxiliary_grid, false, box},
                         grid, 1e-4),
        grid);
    for (std::size_t p = 0; p < grid.size(); ++p) {
        const double x = grid.x(p % grid.nx);
        CHECK(fm.mask[p] == (std::abs(x) > 0.45 ? mask_left_bounds : 0));
        CHECK(std::isnan(fm.dF[4 * p]) == (fm.mask[p] != 0));
    }
}

TEST_CASE("blow-up: lanes of x'' = x + x^3 from large states are masked non-finite, the others are exact") {
    // alpha = 1, beta = -1: y' = x + x^3 blows up in finite time (~ sqrt 2 / x0 from (x0, 0) with large x0).
    const System duffing = make_system("duffing", {{"alpha", 1.0}, {"beta", -1.0}, {"delta", 0.0}});
    const Dynamics dyn{&duffing, nullptr};
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const std::vector<double> x0 = {0.01, 10.0, -0.02, 5.0, 0.0, 1e3, 0.015, nan, 0.005};
    const std::vector<double> y0 = {0.0, 0.0, 0.01, 5.0, 0.02, -1e3, -0.01, 0.0, 0.0};
    const std::vector<bool> blows = {false, true, false, true, false, true, false, true, false};
    // The healthy lanes, integrated alone at a much tighter tolerance, as the reference.
    std::vector<double> hx, hy;
    for (std::size_t k = 0; k < x0.size(); ++k)
        if (!blows[k]) {
            hx.push_back(x0[k]);
            hy.push_back(y0[k]);
        }
    const FlowMap ref = flow_map_at_points({dyn, 0.0, 1.0, settings_for("rkf78", 1e-13, 1)}, hx, hy);
    for (const std::string method : {"dopri5", "rkf78", "rk4"}) {
        for (std::size_t batch : {1, 4, 16}) {
            CAPTURE(method);
            CAPTURE(batch);
            const FlowMap r = flow_map_at_points({dyn, 0.0, 1.0, settings_for(method, 1e-10, batch)}, x0, y0);
            std::size_t h = 0;
            for (std::size_t k = 0; k < x0.size(); ++k) {
                CAPTURE(k);
                if (blows[k]) {
                    CHECK(r.mask[k] == mask_non_finite);
                    CHECK(std::isnan(r.flow_x[k]));
                    CHECK(std::isnan(r.flow_y[k]));
                } else {
                    CHECK(r.mask[k] == 0);
                    // |x| <= 0.03 over T = 1: local error bound tol (1 + |x|) ~ 1e-10 per step, N <= ~100 steps;
                    // RK4 with h = 0.01 on this nearly linear flow: error ~ T h^4 |x| / 120 ~ 1e-12.
                    CHECK(std::abs(r.flow_x[k] - ref.flow_x[h]) <= 1e-8);
                    CHECK(std::abs(r.flow_y[k] - ref.flow_y[h]) <= 1e-8);
                    ++h;
                }
            }
            CHECK(r.stats.masked_non_finite == 4);
            CHECK(r.stats.masked == 4);
        }
    }
}

TEST_CASE("a plugin returning NaN: those lanes are masked non-finite, the others are exact") {
    // faulty-nan is x' = y, y' = -k x + f with x' = NaN wherever x >= 2 (a test plugin built for the conformance
    // checks). Lanes on circles of radius > 2 reach x = 2 and must be masked; the others are x0 cos t + y0 sin t.
    const System faulty = faulty_system("faulty-nan");
    const Dynamics dyn{&faulty, nullptr};
    const std::vector<double> x0 = {0.5, 0.0, -1.0, 2.5, 0.3, -2.2, 1.0, 0.0};
    const std::vector<double> y0 = {0.0, 3.0, 0.5, 0.0, -0.2, -1.5, 1.0, -1.9};
    const double T = 4.0; // long enough for every lane of radius > 2 to pass x = 2
    for (const std::string method : {"dopri5", "rkf78", "rk4"}) {
        for (std::size_t batch : {1, 8}) {
            CAPTURE(method);
            CAPTURE(batch);
            const FlowMap r = flow_map_at_points({dyn, 0.0, T, settings_for(method, 1e-10, batch)}, x0, y0);
            std::uint64_t expected = 0;
            for (std::size_t k = 0; k < x0.size(); ++k) {
                CAPTURE(k);
                if (std::hypot(x0[k], y0[k]) > 2.0) {
                    ++expected;
                    CHECK(r.mask[k] == mask_non_finite);
                    CHECK(std::isnan(r.flow_x[k]));
                } else {
                    CHECK(r.mask[k] == 0);
                    // As for the saddle: N tol (1 + |x|) with N <= 200, and RK4's h^4 error ~ T h^4 / 120 ~ 1e-10.
                    CHECK(std::abs(r.flow_x[k] - (x0[k] * std::cos(T) + y0[k] * std::sin(T))) <= 1e-8);
                    CHECK(std::abs(r.flow_y[k] - (y0[k] * std::cos(T) - x0[k] * std::sin(T))) <= 1e-8);
                }
            }
            CHECK(r.stats.masked_non_finite == expected);
        }
    }
}

TEST_CASE("checked steps: a DF that turns NaN under a finite state is masked non-finite, not a failed step") {
    // faulty-nan-jacobian is the harmonic oscillator x' = y, y' = -k x with a finite field everywhere but a NaN
    // Jacobian entry at x >= 2: the state stays exact, DF goes NaN on the circles of radius > 2. The checked steps
    // screen the state through the error test and DF where it is renormalised (every few steps, and after the
    // last): such lanes end masked non-finite with no rejected step; the others have the rotation's exact DF.
    const System faulty = faulty_system("faulty-nan-jacobian");
    const Dynamics dyn{&faulty, nullptr};
    const std::vector<double> x0 = {0.5, 0.0, -1.0, 2.5, 0.3, -2.2, 1.0, 0.0};
    const std::vector<double> y0 = {0.0, 3.0, 0.5, 0.0, -0.2, -1.5, 1.0, -1.9};
    for (const double T : {4.0, 0.66}) { // 0.66: two steps, so only the check after the last step sees the NaN
        CAPTURE(T);
        const IntegratorSettings checked = quality_preset("standard");
        REQUIRE(checked.step_tolerance > 0.0);
        const FlowMap r = flow_map_at_points({dyn, 0.0, T, checked, GradientMethod::variational, true}, x0, y0);
        CHECK(r.stats.rejected_steps == 0);
        std::uint64_t expected = 0;
        for (std::size_t k = 0; k < x0.size(); ++k) {
            CAPTURE(k);
            // x(t) = x0 cos t + y0 sin t reaches 2 before T when the radius exceeds 2 and the phase allows.
            bool reaches = x0[k] >= 2.0;
            for (double t = 0.0; t <= T && !reaches; t += 1e-3)
                reaches = x0[k] * std::cos(t) + y0[k] * std::sin(t) >= 2.0;
            if (reaches) {
                ++expected;
                CHECK(r.mask[k] == mask_non_finite);
            } else {
                CHECK(r.mask[k] == 0);
                const double c = std::cos(T), s = std::sin(T);
                CHECK(std::abs(r.dF[4 * k + 0] - c) <= 1e-6);
                CHECK(std::abs(r.dF[4 * k + 1] - s) <= 1e-6);
                CHECK(std::abs(r.dF[4 * k + 2] + s) <= 1e-6);
                CHECK(std::abs(r.dF[4 * k + 3] - c) <= 1e-6);
            }
        }
        CHECK(expected > 0);
        CHECK(r.stats.masked_non_finite == expected);
    }
}
TEST_CASE("an exception inside the parallel batches reaches the caller") {
    const System saddle = make_system("linear-saddle");
    const Dynamics dyn{&saddle, nullptr};
    std::vector<double> x0, y0;
    test::sample_points(100, x0, y0);
    // The progress callback runs inside the OpenMP region, like the plugin calls; what it throws must come out
    // (the same path carries a PluginError from a failing plugin call).
    CHECK_THROWS_WITH_AS(
        flow_map_at_points({dyn, 0.0, 1.0, settings_for("dopri5", 1e-8, 4), GradientMethod::none, false, std::nullopt,
                            [](std::size_t done, std::size_t) {
                                if (done == 3) throw PluginError("plugin.so: stop at batch 3");
                            }},
                           x0, y0),
        "plugin.so: stop at batch 3", PluginError);
}

TEST_CASE("a lockstep batch gives the batch = 1 result to within the integration tolerance") {
    const System duffing = make_system("duffing");
    const Forcing cosine = make_forcing("cosine", {{"amplitude", 0.08}, {"omega", 1.0}, {"phase", 0.3}});
    const Dynamics dyn{&duffing, &cosine};
    std::vector<double> x0, y0;
    test::sample_points(64, x0, y0);
    const double T = 2.0 * pi;
    const FlowMap ref =
        flow_map_at_points({dyn, 0.0, T, settings_for("rkf78", 1e-13, 1), GradientMethod::variational, true}, x0, y0);
    for (const std::string method : {"dopri5", "rkf78"}) {
        const FlowMap one =
            flow_map_at_points({dyn, 0.0, T, settings_for(method, 1e-9, 1), GradientMethod::variational, true}, x0, y0);
        for (std::size_t batch : {4, 16, 64}) {
            CAPTURE(method);
            CAPTURE(batch);
            const FlowMap many = flow_map_at_points(
                {dyn, 0.0, T, settings_for(method, 1e-9, batch), GradientMethod::variational, true}, x0, y0);
            // A lane in a batch takes the steps chosen for the batch's worst lane, typically smaller than its own,
            // so it is typically more accurate than alone (measured: 3e-8 vs 7e-8). Both lie within their global
            // error of the reference, N tol |DF| with N ~ 10^2 steps and |DF| <= ~10 over one forcing period: 1e-6.
            // Deviation = the largest over positions and DF entries.
            const auto deviation = [&](const FlowMap &u, const FlowMap &v) {
                double w = 0.0;
                for (std::size_t k = 0; k < x0.size(); ++k) {
                    w = std::max({w, std::abs(u.flow_x[k] - v.flow_x[k]), std::abs(u.flow_y[k] - v.flow_y[k])});
                    for (int q = 0; q < 4; ++q) w = std::max(w, std::abs(u.dF[4 * k + q] - v.dF[4 * k + q]));
                }
                return w;
            };
            const double worst_one = deviation(one, ref), worst_many = deviation(many, ref);
            const double worst_diff = deviation(many, one);
            MESSAGE(method << " batch " << batch << ": error alone " << worst_one << ", in batch " << worst_many
                           << ", difference " << worst_diff);
            CHECK(worst_diff < 1e-6);
            CHECK(worst_many < 1e-6);
            CHECK(many.stats.steps <= one.stats.steps); // fewer, shared steps: the point of lockstep batches
        }
    }
}

TEST_CASE("statistics are consistent with the steppers' stage counts") {
    const System saddle = make_system("linear-saddle", {{"a", 0.5}});
    const Dynamics dyn{&saddle, nullptr};
    std::vector<double> x0, y0;
    test::sample_points(10, x0, y0);
    // One batch of 10 lanes, so per-batch counts are the totals. Rhs calls per batch:
    //   dopri5: 1 initial + 6 per attempt (FSAL);  rkf78: 1 initial + 12 per attempt + 1 per accepted step;
    //   rk4: 4 per step.
    for (const std::string method : {"dopri5", "rkf78", "rk4"}) {
        CAPTURE(method);
        IntegratorSettings s = settings_for(method, 1e-9, 10);
        s.step = 0.5; // large first trial step: forces rejections for the adaptive methods
        const FlowMap r = flow_map_at_points({dyn, 0.0, 3.0, s}, x0, y0);
        const IntegratorStats &st = r.stats;
        CHECK(st.trajectories == 10);
        CHECK(st.batches == 1);
        CHECK(st.steps > 0);
        CHECK(st.rhs_evaluations >= st.steps);
        CHECK(st.wall_seconds >= 0.0);
        const std::string m = method;
        const std::uint64_t attempts = st.steps + st.rejected_steps;
        if (m == "dopri5") CHECK(st.rhs_evaluations == 10 * (1 + 6 * attempts));
        if (m == "rkf78") CHECK(st.rhs_evaluations == 10 * (1 + 12 * attempts + st.steps));
        if (m == "rk4") {
            CHECK(st.steps == 6);
            CHECK(st.rejected_steps == 0);
            CHECK(st.rhs_evaluations == 10 * 4 * 6);
        }
        const nlohmann::json j = st.to_json();
        for (const char *key :
             {"trajectories", "batches", "steps", "rejected_steps", "rhs_evaluations", "masked", "masked_left_bounds",
              "masked_non_finite", "masked_step_limit", "masked_invalid_state", "wall_seconds"})
            CHECK(j.contains(key));
        CHECK(j["steps"].get<std::uint64_t>() == st.steps);
    }
    IntegratorStats a, b;
    a.steps = 3;
    a.masked_non_finite = 1;
    a.wall_seconds = 0.5;
    b.steps = 4;
    b.masked_non_finite = 2;
    b.wall_seconds = 0.25;
    a.add(b);
    CHECK(a.steps == 7);
    CHECK(a.masked_non_finite == 3);
    CHECK(a.wall_seconds == 0.75);
}

TEST_CASE("step limit and progress: no hang, remaining lanes masked, progress reaches the total") {
    const System saddle = make_system("linear-saddle", {{"a", 0.5}});
    const Dynamics dyn{&saddle, nullptr};
    std::vector<double> x0, y0;
    test::sample_points(50, x0, y0);
    IntegratorSettings s = settings_for("dopri5", 1e-12, 8);
    s.max_steps = 5; // far too few for T = 10 at 1e-12
    std::atomic<std::size_t> calls{0}, last_total{0}, max_done{0};
    const FlowMap r = flow_map_at_points({dyn, 0.0, 10.0, s, GradientMethod::none, false, std::nullopt,
                                          [&](std::size_t done, std::size_t total) {
                                              ++calls;
                                              last_total = total;
                                              std::size_t m = max_done.load();
                                              while (done > m && !max_done.compare_exchange_weak(m, done)) {
                                              }
                                          }},
                                         x0, y0);
    CHECK(r.stats.masked_step_limit == 50);
    CHECK(std::all_of(r.mask.begin(), r.mask.end(), [](std::uint8_t m) { return m == mask_step_limit; }));
    CHECK(std::all_of(r.flow_x.begin(), r.flow_x.end(), [](double v) { return std::isnan(v); }));
    CHECK(calls == 7); // ceil(50 / 8) batches
    CHECK(last_total == 7);
    CHECK(max_done == 7);

    // t0 == t1: the identity, DF = I, no steps.
    const FlowMap id =
        flow_map_at_points({dyn, 2.0, 2.0, settings_for("dopri5", 1e-9, 8), GradientMethod::variational, true}, x0, y0);
    CHECK(id.stats.steps == 0);
    CHECK(id.flow_x == x0);
    CHECK(id.flow_y == y0);
    CHECK(id.dF[0] == 1.0);
    CHECK(id.dF[1] == 0.0);
    CHECK(id.dF[3] == 1.0);
}

TEST_CASE("the engine names a bad setting; the experiment layer maps it to its JSON path") {
    const System saddle = make_system("linear-saddle");
    const Dynamics dyn{&saddle, nullptr};
    const std::vector<double> x0 = {0.1}, y0 = {0.2};
    IntegratorSettings s;
    s.method = "euler-maruyama";
    try {
        flow_map_at_points({dyn, 0.0, 1.0, s}, x0, y0);
        FAIL("no error for an unknown method");
    } catch (const EngineSettingError &e) {
        CHECK(e.setting() == EngineSetting::method);
        CHECK(std::string(e.what()) == "method: " + e.message());
        // The same refusal through the experiment layer: the JSON path, then the engine's message.
        try {
            with_json_paths([&] { flow_map_at_points({dyn, 0.0, 1.0, s}, x0, y0); });
            FAIL("with_json_paths let the refusal through");
        } catch (const ConfigError &c) {
            CHECK(c.json_path() == "/integrator/method");
            CHECK(std::string(c.what()) == "/integrator/method: " + e.message());
        }
    }
    CHECK(parse_gradient_method("auxiliary-grid") == GradientMethod::auxiliary_grid);
    CHECK(parse_gradient_method("variational") == GradientMethod::variational);
    CHECK(parse_gradient_method("none") == GradientMethod::none);
    CHECK(std::string(to_string(GradientMethod::auxiliary_grid)) == "auxiliary-grid");
    try {
        parse_gradient_method("finite-differences");
        FAIL("no error for an unknown gradient method");
    } catch (const EngineSettingError &e) {
        CHECK(e.setting() == EngineSetting::gradient);
        CHECK(json_path_of(e.setting()) == "/cauchy_green/method");
    }
    IntegratorSettings bad;
    bad.step = 0.0;
    try {
        check_flow_map_settings({dyn, 0.0, 1.0, bad, GradientMethod::none});
        FAIL("no error for a zero step");
    } catch (const EngineSettingError &e) {
        CHECK(e.setting() == EngineSetting::step);
        CHECK(json_path_of(e.setting()) == "/integrator/step");
    }
    CHECK_THROWS_AS(flow_map_at_points({dyn, 0.0, 1.0, bad}, x0, y0), EngineSettingError);
    Grid grid;
    CHECK_THROWS_AS(compute_grid_flow_map({dyn, 0.0, 1.0, IntegratorSettings{}, GradientMethod::auxiliary_grid}, grid),
                    EngineSettingError);
    // Every setting has a path in the experiment file.
    for (int k = 0; k <= static_cast<int>(EngineSetting::grid); ++k)
        CHECK(json_path_of(static_cast<EngineSetting>(k)).rfind('/', 0) == 0);
}

TEST_CASE("one request, one result: the entry points give the same numbers for the same points") {
    // The linear saddle x' = a x, y' = -a y: F = (x e^{aT}, y e^{-aT}), DF = diag(e^{aT}, e^{-aT}).
    const double a = 0.8, T = 2.5;
    const System saddle = make_system("linear-saddle", {{"a", a}});
    const Grid grid{-1.0, 1.0, -0.5, 0.5, 9, 5}; // x range, y range, nx, ny
    std::vector<double> x0, y0;
    for (std::size_t p = 0; p < grid.size(); ++p) {
        x0.push_back(grid.x(p % grid.nx));
        y0.push_back(grid.y(p / grid.nx));
    }
    const FlowMapRequest request{{&saddle, nullptr},          0.0, T, settings_for("dopri5", 1e-10, 8),
                                 GradientMethod::variational, true};
    const FlowMap on_grid = compute_grid_flow_map(request, grid);
    const FlowMap at_points = flow_map_at_points(request, x0, y0);
    const FlowMap of_states = flow_map_of_states(request, x0.size(), [&](std::size_t k, double *state) {
        state[0] = x0[k];
        state[1] = y0[k];
    });
    CHECK(on_grid.grid.nx == grid.nx);
    CHECK(on_grid.grid.ny == grid.ny);
    REQUIRE(of_states.dimension == 2);
    REQUIRE(of_states.state.size() == 2 * grid.size());
    CHECK(of_states.flow_x.empty()); // whole states, not plane positions
    for (std::size_t k = 0; k < grid.size(); ++k) {
        CHECK(std::abs(on_grid.flow_x[k] - x0[k] * std::exp(a * T)) <= 1e-8 * std::exp(a * T));
        CHECK(std::abs(on_grid.dF[4 * k] - std::exp(a * T)) <= 1e-8 * std::exp(a * T));
        // The same lanes in the same batches: the same numbers bit for bit, whatever the entry point.
        CHECK(at_points.flow_x[k] == on_grid.flow_x[k]);
        CHECK(at_points.flow_y[k] == on_grid.flow_y[k]);
        CHECK(of_states.state[2 * k] == on_grid.flow_x[k]);
        CHECK(of_states.state[2 * k + 1] == on_grid.flow_y[k]);
        for (std::size_t q = 0; q < 4; ++q) {
            CHECK(at_points.dF[4 * k + q] == on_grid.dF[4 * k + q]);
            CHECK(of_states.dF[4 * k + q] == on_grid.dF[4 * k + q]);
        }
        CHECK(of_states.log_det[k] == on_grid.log_det[k]);
    }
    // The auxiliary grid's offsets as a fraction of the grid spacing: the grid's neighbours at 1e-3 dx, 1e-3 dy.
    const FlowMapRequest aux =
        with_grid_offset({request.dynamics, 0.0, T, request.settings, GradientMethod::auxiliary_grid}, grid, 1e-3);
    CHECK(aux.offset_x == 1e-3 * grid.dx());
    CHECK(aux.offset_y == 1e-3 * grid.dy());
    const FlowMap aux_grid = compute_grid_flow_map(aux, grid);
    for (std::size_t k = 0; k < grid.size(); ++k)
        CHECK(std::abs(aux_grid.dF[4 * k + 3] - std::exp(-a * T)) <= 1e-8 * std::exp(a * T));
}

TEST_CASE("the entry points refuse what their points cannot have") {
    const System saddle = make_system("linear-saddle", {{"a", 1.0}});
    const FlowMapRequest request{{&saddle, nullptr}, 0.0, 1.0, settings_for("dopri5", 1e-8, 4)};
    CHECK_THROWS_WITH_AS(flow_map_at_points(request, std::vector<double>{0.1, 0.2}, std::vector<double>{0.3}),
                         "flow_map_at_points: 2 x coordinates but 1 y coordinates", Error);
    FlowMapRequest aux = request;
    aux.gradient = GradientMethod::auxiliary_grid;
    try {
        flow_map_of_states(aux, 1, [](std::size_t, double *state) { state[0] = state[1] = 0.1; });
        FAIL("no error for the auxiliary grid on whole states");
    } catch (const EngineSettingError &e) {
        CHECK(e.setting() == EngineSetting::gradient);
    }
    aux.offset_x = 1e-3; // offset_y still 0
    CHECK_THROWS_AS(flow_map_at_points(aux, std::vector<double>{0.1}, std::vector<double>{0.2}), EngineSettingError);
}
