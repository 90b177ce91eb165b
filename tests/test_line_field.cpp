// Line fields and Cauchy–Green derivatives: curvatures and gradients on analytic fields (with random sign flips of
// the stored eigenvectors), and the general strain deviation against the paper's eq. `gdev_str` where
// lambda1 lambda2 = 1 (analytic field and the undamped Duffing oscillator's own Cauchy–Green field). The lane
// evaluation against the scalar one is test_lane_paths.
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/flow_map.hpp>
#include <geobarrier/line_field.hpp>

#include "line_fields.hpp"
#include "test_support.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>

using namespace geobarrier;
using geobarrier::test::box;
using geobarrier::test::circles;

TEST_CASE("the general strain deviation reduces to the paper's eq. gdev_str when lambda1 lambda2 = 1") {
    // Exact algebra: with lambda1 = 1/lambda2, grad lambda1 = -grad lambda2 / lambda2^2.
    for (double l2 : {1.5, 10.0, 1e4, 1e12})
        for (double k1 : {-3.0, 0.0, 0.7})
            for (double g2 : {-5.0, 0.0, 2.0, 1e3}) {
                const double general = strain_deviation(1.0 / l2, l2, k1, -g2 / (l2 * l2));
                const double paper = strain_deviation_area_preserving(l2, k1, g2);
                CHECK(general == doctest::Approx(paper).epsilon(1e-13));
            }
}

TEST_CASE("curvatures and gradients of an analytic field, orientation-free") {
    const Grid g = box(0.5, 1.5, 0.2, 1.2, 201, 201); // h = 0.005, away from the circles' centre
    std::vector<double> orientation;
    const CauchyGreenField cg = circles(g, 7, &orientation);
    const StrainDerivatives d = strain_derivatives(cg);
    const double h = g.dx();
    double worst_k1 = 0, worst_k2 = 0, worst_grad = 0, worst_dev = 0;
    for (std::size_t i = 0; i < g.ny; ++i)
        for (std::size_t j = 0; j < g.nx; ++j) {
            const std::size_t p = i * g.nx + j;
            REQUIRE(d.valid[p] == 1);
            const bool interior = i > 0 && j > 0 && i + 1 < g.ny && j + 1 < g.nx;
            if (!interior) continue; // one-sided at the edges: first order only
            const double x = g.x(j), y = g.y(i), r = std::hypot(x, y);
            worst_k1 = std::max(worst_k1, std::abs(d.kappa1[p] - orientation[p] / r) * r);
            worst_k2 = std::max(worst_k2, std::abs(d.kappa2[p]));
            const double l2 = cg.lambda2[p];
            worst_grad = std::max(
                {worst_grad, std::abs(d.dlambda2_dx[p] - l2) / l2, std::abs(d.dlambda2_dy[p] - 2 * l2) / (2 * l2)});
            // General vs paper form on the grid: the two differ only through the discrete gradients of lambda1
            // and lambda2, each with relative error a^2 h^2 / 6 (a <= 2) for exp(a y).
            const double g1 = d.dlambda1_dx[p] * cg.xi2_x[p] + d.dlambda1_dy[p] * cg.xi2_y[p];
            const double g2 = d.dlambda2_dx[p] * cg.xi2_x[p] + d.dlambda2_dy[p] * cg.xi2_y[p];
            const double general = strain_deviation(cg.lambda1[p], l2, d.kappa1[p], g1);
            const double paper = strain_deviation_area_preserving(l2, d.kappa1[p], g2);
            const double scale = (std::abs(g2) + 2 * l2 * std::abs(d.kappa1[p])) / (2 * l2 * l2 * l2);
            worst_dev = std::max(worst_dev, std::abs(general - paper) / scale);
        }
    // Centred differences of unit vectors along circles of radius >= 0.54: error O(h^2 / r^3) relative.
    MESSAGE("kappa1 relative error " << worst_k1 << ", |kappa2| " << worst_k2 << ", grad lambda2 " << worst_grad
                                     << ", general vs paper deviation " << worst_dev);
    CHECK(worst_k1 < 10 * h * h / (0.5 * 0.5));
    CHECK(worst_k2 < 10 * h * h);
    CHECK(worst_grad < 4 * h * h / 6 * 1.01);
    CHECK(worst_dev < 2 * 4 * h * h / 6 * 1.01);
    const std::vector<double> dev = strain_deviation_field(cg, d);
    CHECK(std::all_of(dev.begin(), dev.end(), [](double v) { return std::isfinite(v) && v >= 0; }));
}

TEST_CASE("masked and degenerate points are never used by the derivatives") {
    const Grid g = box(0.5, 1.5, 0.2, 1.2, 41, 41);
    CauchyGreenField cg = circles(g, 3);
    const std::size_t bad = 20 * g.nx + 20;
    cg.mask[bad] = mask_non_finite;
    cg.lambda1[bad] = cg.lambda2[bad] = cg.xi1_x[bad] = cg.xi1_y[bad] = std::nan("");
    cg.mask[bad + 1] = mask_degenerate;
    const StrainDerivatives d = strain_derivatives(cg);
    CHECK(d.valid[bad] == 0);
    CHECK(std::isnan(d.kappa1[bad]));
    CHECK(d.valid[bad + 1] == 0);
    // Neighbours fall back to one-sided differences and stay finite.
    CHECK(d.valid[bad - 1] == 1);
    CHECK(std::isfinite(d.kappa1[bad - 1]));
    CHECK(std::isfinite(d.dlambda2_dx[bad - 1]));
    CHECK(d.valid[bad + g.nx] == 1);
}

TEST_CASE("LineField aligns corners before interpolating and reports unusable cells") {
    const Grid g = box(0.5, 1.5, 0.2, 1.2, 51, 51);
    CauchyGreenField cg = circles(g, 11);
    LineField f = LineField::from_cauchy_green(cg, 1, 0.0);
    double vx, vy;
    // At (1, 0.5) the tangent is (-0.5, 1)/|.|, up to sign; aligned with the reference.
    REQUIRE(f.evaluate(1.0, 0.5, 0.0, 1.0, vx, vy) == LineStatus::ok);
    const double r = std::hypot(1.0, 0.5);
    CHECK(vx == doctest::Approx(-0.5 / r).epsilon(1e-3));
    CHECK(vy == doctest::Approx(1.0 / r).epsilon(1e-3));
    REQUIRE(f.evaluate(1.0, 0.5, 0.0, -1.0, vx, vy) == LineStatus::ok);
    CHECK(vy == doctest::Approx(-1.0 / r).epsilon(1e-3));
    CHECK(std::hypot(vx, vy) == doctest::Approx(1.0));
    CHECK(f.evaluate(0.4, 0.5, 0, 1, vx, vy) == LineStatus::outside);
    CHECK(f.evaluate(1.5, 1.2, 0, 1, vx, vy) == LineStatus::ok); // the far corner belongs to the box

    // A masked point poisons its four cells; a singular one (small eigenvalue gap) too.
    cg.mask[25 * g.nx + 25] = mask_left_bounds;
    cg.lambda1[10 * g.nx + 10] = cg.lambda2[10 * g.nx + 10] * (1 - 1e-5);
    f = LineField::from_cauchy_green(cg, 1, 1e-3);
    CHECK(f.evaluate(g.x(25) - 0.5 * g.dx(), g.y(25) + 0.5 * g.dy(), 0, 1, vx, vy) == LineStatus::masked);
    CHECK(f.evaluate(g.x(10) + 0.5 * g.dx(), g.y(10) + 0.5 * g.dy(), 0, 1, vx, vy) == LineStatus::singular);
    CHECK(f.evaluate(g.x(12) + 0.5 * g.dx(), g.y(10) + 0.5 * g.dy(), 0, 1, vx, vy) == LineStatus::ok);
}

TEST_CASE("general and paper strain deviations agree on the undamped Duffing oscillator's own field") {
    // Area-preserving: det DF = 1, so lambda1 = 1/lambda2 up to the integrator's tolerance. Short horizon so that
    // the grid resolves the fields: the two forms then differ only by the difference between the discrete
    // gradients of lambda1 and of 1/lambda2.
    const System duffing = test::make_system("duffing", {{"delta", 0.0}});
    const Forcing cosine = test::make_forcing("cosine", {{"amplitude", 0.08}});
    const Grid g = box(-1.5, 1.5, -1.0, 1.0, 151, 101);
    IntegratorSettings s;
    s.rtol = 1e-10;
    s.atol = 1e-12;
    const double T = 2.0;
    const FlowMap fm = compute_grid_flow_map({Dynamics{&duffing, &cosine}, 0.0, T, s, GradientMethod::variational}, g);
    const CauchyGreenField cg = cauchy_green_field(g, fm.dF, fm.mask, T);
    const StrainDerivatives d = strain_derivatives(cg);
    // On the grid the two forms differ only in the discrete gradients: the centred difference of lambda1 = 1/f
    // (f = lambda2) along an axis is -(f+ - f-) / (2h f+ f-), where the paper's form has -(f+ - f-) / (2h f^2).
    // So, at interior points, |general - paper| <= sum over axes |D f xi2_axis| |f^2 / (f+ f-) - 1| / (2 f^3),
    // plus the (det DF^2 - 1) lambda1 kappa1 term of the integrator's tolerance.
    std::vector<double> rel;
    std::size_t checked = 0, within = 0;
    for (std::size_t i = 1; i + 1 < g.ny; ++i)
        for (std::size_t j = 1; j + 1 < g.nx; ++j) {
            const std::size_t p = i * g.nx + j;
            const std::size_t nb[4] = {p - 1, p + 1, p - g.nx, p + g.nx};
            bool ok = d.valid[p] == 1;
            for (std::size_t q : nb) ok = ok && cg.mask[q] == 0;
            if (!ok) continue;
            const double f = cg.lambda2[p];
            const double g1 = d.dlambda1_dx[p] * cg.xi2_x[p] + d.dlambda1_dy[p] * cg.xi2_y[p];
            const double g2 = d.dlambda2_dx[p] * cg.xi2_x[p] + d.dlambda2_dy[p] * cg.xi2_y[p];
            const double general = strain_deviation(cg.lambda1[p], f, d.kappa1[p], g1);
            const double paper = strain_deviation_area_preserving(f, d.kappa1[p], g2);
            const double ex = std::abs(f * f / (cg.lambda2[p + 1] * cg.lambda2[p - 1]) - 1);
            const double ey = std::abs(f * f / (cg.lambda2[p + g.nx] * cg.lambda2[p - g.nx]) - 1);
            const double bound =
                (std::abs(d.dlambda2_dx[p] * cg.xi2_x[p]) * ex + std::abs(d.dlambda2_dy[p] * cg.xi2_y[p]) * ey) /
                    (2 * f * f * f) +
                std::abs(cg.lambda1[p] * f - 1) * std::abs(d.kappa1[p]) / (f * f);
            const double scale = (std::abs(g2) + 2 * f * std::abs(d.kappa1[p])) / (2 * f * f * f);
            ++checked;
            if (std::abs(general - paper) <= 1.001 * bound + 1e-12 * scale) ++within;
            rel.push_back(std::abs(general - paper) / scale);
        }
    REQUIRE(checked > g.size() * 9 / 10);
    std::sort(rel.begin(), rel.end());
    MESSAGE("Duffing T = 2: " << checked << " interior points, |general - paper| / scale median " << rel[rel.size() / 2]
                              << ", 95th percentile " << rel[rel.size() * 95 / 100]);
    CHECK(within == checked);
}
