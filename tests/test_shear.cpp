// Shear fields (paper eqs. `shrvec`, `dg_shr`) and the index of CG singularities: the weights and shear vectors
// against their defining identities, the general deviation formula against the paper's area-preserving one, and
// singularity indices on line fields whose index is known.
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/line_field.hpp>
#include <geobarrier/shear.hpp>

#include <circular_shear.hpp>
#include <doctest/doctest.h>

#include <cmath>
#include <functional>
#include <random>

using namespace geobarrier;

namespace {

using test::circular_shear_cg;

// A field with prescribed xi1 direction angle(x, y) and anisotropy growing away from (x0, y0).
CauchyGreenField line_field_cg(const Grid &grid, double x0, double y0,
                               const std::function<double(double, double)> &angle) {
    CauchyGreenField cg;
    cg.grid = grid;
    const std::size_t n = grid.size();
    cg.mask.assign(n, 0);
    for (auto *v : {&cg.lambda1, &cg.lambda2, &cg.ftle, &cg.xi1_x, &cg.xi1_y, &cg.xi2_x, &cg.xi2_y}) v->assign(n, 0.0);
    for (std::size_t i = 0; i < grid.ny; ++i)
        for (std::size_t j = 0; j < grid.nx; ++j) {
            const std::size_t p = i * grid.nx + j;
            const double dx = grid.x(j) - x0, dy = grid.y(i) - y0, r = std::hypot(dx, dy);
            const double th = angle(dx, dy);
            cg.lambda1[p] = 1.0;
            cg.lambda2[p] = 1.0 + r;
            cg.xi1_x[p] = std::cos(th);
            cg.xi1_y[p] = std::sin(th);
            cg.xi2_x[p] = -std::sin(th);
            cg.xi2_y[p] = std::cos(th);
            if (r == 0.0) {
                cg.mask[p] = mask_degenerate;
                ++cg.degenerate_count;
            }
        }
    return cg;
}

} // namespace

TEST_CASE("shear weights: alpha^2 + beta^2 = 1, the isotropic and the overflowed limits") {
    for (double l2 : {1.0, 1.5, 10.0, 1e6, 1e300}) {
        const double l1 = 1.0 / l2;
        const ShearWeights w = shear_weights(l1, l2);
        CHECK(w.alpha * w.alpha + w.beta * w.beta == doctest::Approx(1.0).epsilon(1e-15));
        // Area-preserving: alpha = sqrt(l2 / (1 + l2)), beta = 1 / sqrt(1 + l2).
        CHECK(w.alpha == doctest::Approx(std::sqrt(l2 / (1.0 + l2))).epsilon(1e-14));
        CHECK(w.beta == doctest::Approx(1.0 / std::sqrt(1.0 + l2)).epsilon(1e-14));
    }
    const ShearWeights iso = shear_weights(2.0, 2.0);
    CHECK(iso.alpha == doctest::Approx(std::sqrt(0.5)));
    CHECK(iso.beta == doctest::Approx(std::sqrt(0.5)));
    const ShearWeights inf = shear_weights(0.0, HUGE_VAL);
    CHECK(inf.alpha == 1.0);
    CHECK(inf.beta == 0.0);
    CHECK(std::isnan(shear_weights(NAN, 1.0).alpha));
    CHECK(anisotropy(1.0, 1.0) == 0.0);
    CHECK(anisotropy(0.0, HUGE_VAL) == 1.0);
    CHECK(anisotropy(1.0, 3.0) == doctest::Approx(0.5));
}

TEST_CASE("eta+- are unit directions of no stretching: <eta, C eta> = sqrt(l1 l2) (eq. shrvec)") {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-3.0, 3.0);
    for (int k = 0; k < 200; ++k) {
        const double f11 = u(rng), f12 = u(rng), f21 = u(rng), f22 = u(rng);
        const CauchyGreenPoint p = cauchy_green_at(f11, f12, f21, f22, 1.0);
        if (p.degenerate) continue;
        const ShearWeights w = shear_weights(p.lambda1, p.lambda2);
        for (int sign : {+1, -1}) {
            const double ex = w.alpha * p.xi1_x + sign * w.beta * p.xi2_x;
            const double ey = w.alpha * p.xi1_y + sign * w.beta * p.xi2_y;
            CHECK(std::hypot(ex, ey) == doctest::Approx(1.0).epsilon(1e-14));
            const double gx = f11 * ex + f12 * ey, gy = f21 * ex + f22 * ey; // DF eta
            const double stretch = gx * gx + gy * gy;                        // <eta, C eta>
            CHECK(stretch == doctest::Approx(std::sqrt(p.lambda1 * p.lambda2)).epsilon(1e-12));
        }
    }
}

TEST_CASE("general d_g^eta equals the paper's eq. dg_shr when lambda1 = 1/lambda2, up to its <grad l2, xi1> term") {
    // Area-preserving inputs, all derivatives expressed through grad lambda2 (g1 = <grad l2, xi1>,
    // g2 = <grad l2, xi2>): grad l1 = -grad l2 / l2^2 and grad alpha = grad l2 / (2 sqrt(l2) (1 + l2)^(3/2)).
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-2.0, 2.0), e(0.0, 8.0);
    for (int k = 0; k < 500; ++k) {
        const double l2 = std::pow(10.0, e(rng)) + 1e-3, l1 = 1.0 / l2;
        const double k1 = u(rng), k2 = u(rng), g2 = u(rng) * l2;
        const double s3 = std::pow(1.0 + l2, 1.5);
        const ShearWeights w = shear_weights(l1, l2);
        for (int sign : {+1, -1}) {
            auto general = [&](double g1) {
                const double grad_alpha_dot_eta = (w.alpha * g1 + sign * w.beta * g2) / (2.0 * std::sqrt(l2) * s3);
                return shear_deviation(sign, l1, l2, k1, k2, grad_alpha_dot_eta, -g2 / (l2 * l2));
            };
            // Along xi2 alone (g1 = 0) the two forms are the same expression.
            const double d0 = general(0.0), p0 = shear_deviation_area_preserving(sign, l2, k1, k2, 0.0, g2);
            CHECK(d0 == doctest::Approx(p0).epsilon(1e-10));
            // Otherwise they differ by at most |g1| / (2 l2 (1 + l2)^(3/2)) (the coefficients of g1 differ by that).
            const double g1 = u(rng) * l2;
            const double bound = std::abs(g1) / (2.0 * l2 * s3);
            CHECK(std::abs(general(g1) - shear_deviation_area_preserving(sign, l2, k1, k2, g1, g2)) <=
                  bound * (1.0 + 1e-9) + 1e-12 * (1.0 + d0));
        }
    }
}

TEST_CASE("d_g^eta on a grid: general and area-preserving forms agree on an area-preserving flow map") {
    // Circular shear flow (exact DF): lambda1 lambda2 = 1 to rounding. Between r = 0.3 and 0.9 the two forms must
    // agree to the analytic difference term |<grad l2, xi1>| / (2 l2 (1 + l2)^(3/2)) plus the discretisation
    // difference of the two routes to the derivatives (the general form differences alpha and lambda1, the
    // area-preserving one lambda2 only): second order in h, so it must shrink about fourfold when h halves.
    auto worst_excess = [](std::size_t n) {
        Grid g;
        g.x_min = g.y_min = -1.0;
        g.x_max = g.y_max = 1.0;
        g.nx = g.ny = n;
        const CauchyGreenField cg = circular_shear_cg(g, 1.0, 0.5, 8.0);
        const StrainDerivatives d = strain_derivatives(cg);
        const ShearFields general = shear_fields(cg, d, ShearDeviationForm::general);
        const ShearFields paper = shear_fields(cg, d, ShearDeviationForm::area_preserving);
        std::size_t compared = 0, nan_inside = 0;
        double worst = 0.0;
        for (std::size_t i = 0; i < g.ny; ++i)
            for (std::size_t j = 0; j < g.nx; ++j) {
                const std::size_t p = i * g.nx + j;
                const double r = std::hypot(g.x(j), g.y(i));
                if (r < 0.3 || r > 0.9) continue;
                if (!std::isfinite(general.deviation_plus[p]) || !std::isfinite(paper.deviation_plus[p]) ||
                    !std::isfinite(general.deviation_minus[p]) || !std::isfinite(paper.deviation_minus[p])) {
                    ++nan_inside;
                    continue;
                }
                const double l2 = cg.lambda2[p];
                const double g1 = d.dlambda2_dx[p] * cg.xi1_x[p] + d.dlambda2_dy[p] * cg.xi1_y[p];
                const double bound = std::abs(g1) / (2.0 * l2 * std::pow(1.0 + l2, 1.5));
                for (int sign : {+1, -1}) {
                    const double a = sign > 0 ? general.deviation_plus[p] : general.deviation_minus[p];
                    const double b = sign > 0 ? paper.deviation_plus[p] : paper.deviation_minus[p];
                    worst = std::max(worst, (std::abs(a - b) - bound) / b);
                }
                ++compared;
            }
        CHECK(compared > n * n / 4);
        CHECK(nan_inside == 0);
        return worst;
    };
    const double coarse = worst_excess(101), fine = worst_excess(201);
    MESSAGE("d_g general vs area-preserving, worst relative excess over the analytic difference: h = 0.02: "
            << coarse << ", h = 0.01: " << fine);
    CHECK(fine < 0.01);
    CHECK(coarse / fine > 3.0);
}

TEST_CASE("tensor singularities: wedge, trisector, centre and a degenerate grid point have their index") {
    Grid g;
    g.x_min = -1.0;
    g.x_max = 1.0;
    g.y_min = -1.0;
    g.y_max = 1.0;
    g.nx = g.ny = 40; // (0.013, -0.027) is inside one cell, not on a grid line
    const double x0 = 0.013, y0 = -0.027;
    struct Case {
        const char *name;
        std::function<double(double, double)> angle;
        int twice_index;
    };
    const Case cases[] = {
        {"wedge", [](double dx, double dy) { return 0.5 * std::atan2(dy, dx); }, 1},
        {"trisector", [](double dx, double dy) { return -0.5 * std::atan2(dy, dx); }, -1},
        {"centre (circles)", [](double dx, double dy) { return std::atan2(dy, dx) + M_PI / 2; }, 2},
        {"saddle-like (x, -y)", [](double dx, double dy) { return -std::atan2(dy, dx); }, -2},
    };
    for (const Case &c : cases) {
        CAPTURE(c.name);
        // A singularity of index +-1 may show as two half-index ones in neighbouring cells when the field turns by
        // a right angle between two corners of its cell (the turn's sense is then undecided); the total counts.
        const auto s = tensor_singularities(line_field_cg(g, x0, y0, c.angle));
        REQUIRE(!s.empty());
        CHECK(s.size() <= static_cast<std::size_t>(std::abs(c.twice_index)));
        int total = 0;
        for (const auto &one : s) {
            total += one.twice_index;
            CHECK(std::hypot(one.x - x0, one.y - y0) <= 1.5 * g.dx());
            CHECK(one.anisotropy < 0.1); // lambda2 = 1 + r: resolved
        }
        CHECK(total == c.twice_index);
    }
    // The singular point on a grid point (degenerate there): the winding around its eight neighbours.
    Grid odd = g;
    odd.nx = odd.ny = 41;          // (0, 0) is grid point (20, 20), exactly: the spacing 1/16 is a power of two, so
    odd.x_min = odd.y_min = -1.25; // x_min + h j has no rounding even when the compiler contracts it to an FMA
    odd.x_max = odd.y_max = 1.25;  // (-march=native), which with h = 0.05 gave x(20) = 5.6e-17
    const auto s =
        tensor_singularities(line_field_cg(odd, 0.0, 0.0, [](double dx, double dy) { return std::atan2(dy, dx); }));
    REQUIRE(s.size() == 1);
    CHECK(s[0].twice_index == 2);
    CHECK(s[0].x == 0.0);
    CHECK(s[0].y == 0.0);
    // A smooth field without singularities has none.
    CHECK(tensor_singularities(line_field_cg(g, 5.0, 5.0, [](double dx, double) { return 0.3 * dx; })).empty());
}

TEST_CASE("the exact circular shear field has one index +1 singularity at its centre") {
    Grid g;
    g.x_min = g.y_min = -1.0;
    g.x_max = g.y_max = 1.0;
    g.nx = g.ny = 100; // the centre lies inside a cell
    // Its four corners sit on the diagonals, a right angle apart as seen from the centre, so the index +1 shows
    // as two wedges in neighbouring cells (see above).
    const auto s = tensor_singularities(circular_shear_cg(g, 1.0, 0.5, 8.0));
    REQUIRE(!s.empty());
    CHECK(s.size() <= 2);
    int total = 0;
    for (const auto &one : s) {
        total += one.twice_index;
        CHECK(std::hypot(one.x, one.y) < 1.5 * g.dx());
    }
    CHECK(total == 2);
}

TEST_CASE("area preservation: |ln det DF| from lambda1 lambda2, zero for a conservative flow, delta T for damping") {
    Grid g;
    g.x_min = g.y_min = -1.0;
    g.x_max = g.y_max = 1.0;
    g.nx = g.ny = 41;
    // Circular shear (divergence-free, exact DF): ln det DF = 0 to rounding.
    const CauchyGreenField cg = circular_shear_cg(g, 1.0, 0.5, 8.0);
    const AreaPreservation a = area_preservation(cg);
    CHECK(a.points == g.size());
    CHECK(a.max < 1e-12);
    // A uniformly damped map (x' = -delta/2 x, y' = -delta/2 y over T: det DF = exp(-delta T)) with a masked point
    // holding garbage, which must not count.
    CauchyGreenField damped = cg;
    const double delta_t = 0.15 * 8.0 * M_PI;
    for (std::size_t p = 0; p < g.size(); ++p) damped.lambda1[p] = std::exp(-2.0 * delta_t) / damped.lambda2[p];
    damped.mask[7] = mask_non_finite;
    damped.lambda1[7] = 1e300;
    const AreaPreservation d = area_preservation(damped);
    CHECK(d.points == g.size() - 1);
    CHECK(d.median == doctest::Approx(delta_t).epsilon(1e-12));
    CHECK(d.q99 == doctest::Approx(delta_t).epsilon(1e-12));
    CHECK(d.max == doctest::Approx(delta_t).epsilon(1e-12));
}

TEST_CASE("lambda-lines: <e, C e> = lambda^2, undefined outside [l1, l2], and shearlines when lambda = 1 = l1 l2") {
    for (double l2 : {1.5, 10.0, 1e4, 1e12}) {
        CAPTURE(l2);
        // Conservative: lambda1 = 1/lambda2, lambda = 1 gives the weights of eq. `shrvec`.
        const ShearWeights a = lambda_line_weights(1.0, 1.0 / l2, l2), b = shear_weights(1.0 / l2, l2);
        CHECK(a.alpha == doctest::Approx(b.alpha).epsilon(1e-12));
        CHECK(a.beta == doctest::Approx(b.beta).epsilon(1e-12));
        // Any lambda in [sqrt(l1), sqrt(l2)] of a compressible map: the stretching of eta_lambda is lambda.
        const double l1 = 0.3 / l2;
        for (double lambda : {std::sqrt(l1), 0.7, 1.0, std::sqrt(l2)}) {
            if (lambda * lambda < l1 || lambda * lambda > l2) continue;
            const ShearWeights w = lambda_line_weights(lambda, l1, l2);
            CHECK(w.alpha * w.alpha + w.beta * w.beta == doctest::Approx(1.0).epsilon(1e-12));
            CHECK(w.alpha * w.alpha * l1 + w.beta * w.beta * l2 == doctest::Approx(lambda * lambda).epsilon(1e-10));
        }
        CHECK(std::isnan(lambda_line_weights(0.5 * std::sqrt(l1), l1, l2).alpha)); // every direction stretches more
        CHECK(std::isnan(lambda_line_weights(2.0 * std::sqrt(l2), l1, l2).alpha)); // ... or less
    }
    CHECK(std::isnan(lambda_line_weights(1.0, 1.0, 1.0).alpha)); // isotropic: no lambda-line direction
    const ShearWeights inf = lambda_line_weights(1.0, 0.0, HUGE_VAL);
    CHECK(inf.alpha == 1.0);
    CHECK(inf.beta == 0.0);
    // On a grid: the fields equal shear_fields()' eta+- wherever lambda1 lambda2 = 1 (circular shear, exact DF).
    Grid g;
    g.x_min = g.y_min = -1.0;
    g.x_max = g.y_max = 1.0;
    g.nx = g.ny = 41;
    const CauchyGreenField cg = circular_shear_cg(g, 1.0, 0.5, 8.0);
    const ShearFields shear = shear_fields(cg), lines = lambda_line_fields(cg, 1.0);
    std::size_t compared = 0;
    for (std::size_t p = 0; p < g.size(); ++p) {
        if (!std::isfinite(shear.eta_plus_x[p]) || cg.lambda2[p] < 1.0 + 1e-6) continue;
        CHECK(lines.eta_plus_x[p] == doctest::Approx(shear.eta_plus_x[p]).epsilon(1e-9));
        CHECK(lines.eta_minus_y[p] == doctest::Approx(shear.eta_minus_y[p]).epsilon(1e-9));
        CHECK(std::isnan(lines.deviation_plus[p]));
        ++compared;
    }
    CHECK(compared > g.size() / 2);
}
