// Tests of the Cauchy–Green eigen-decomposition (paper eq. `cg`) on deformation gradients with
// closed-form answers, including the cases that break the naive formulas: lambda1/lambda2 = 1e-48, entries of 1e200.
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/errors.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

using namespace geobarrier;

namespace {

double rel_err(double got, double want) { return std::abs(got - want) / std::abs(want); }

// C = DF^T DF applied to v, in long double so the residual check measures the decomposition, not this product.
void apply_c(double f11, double f12, double f21, double f22, double vx, double vy, long double &ox, long double &oy) {
    const long double a = static_cast<long double>(f11) * vx + static_cast<long double>(f12) * vy; // DF v
    const long double b = static_cast<long double>(f21) * vx + static_cast<long double>(f22) * vy;
    ox = f11 * a + f21 * b; // DF^T (DF v)
    oy = f12 * a + f22 * b;
}

void check_frame(const CauchyGreenPoint &p) {
    // xi2 = Omega xi1 with Omega = [[0, -1], [1, 0]] (paper sec. 2), exactly, and both unit.
    CHECK(p.xi2_x == -p.xi1_y);
    CHECK(p.xi2_y == p.xi1_x);
    CHECK(std::abs(std::hypot(p.xi1_x, p.xi1_y) - 1.0) < 4e-16);
    CHECK(p.lambda1 <= p.lambda2);
}

} // namespace

TEST_CASE("saddle gradient diag(e^{aT}, e^{-aT}): lambda2 = e^{2aT}, lambda1 = e^{-2aT}, ftle = a") {
    // Relative 1e-14 is ~45 ulp: exp, one square and the scaled eigenvalue each add one rounding.
    for (double a : {0.1, 0.7, 2.0}) {
        for (double T : {1.0, 10.0, 50.0}) { // aT = 100: lambda1/lambda2 = e^{-400}, far below rounding of lambda2
            CAPTURE(a);
            CAPTURE(T);
            const CauchyGreenPoint p = cauchy_green_at(std::exp(a * T), 0.0, 0.0, std::exp(-a * T), T);
            CHECK(rel_err(p.lambda2, std::exp(2 * a * T)) < 1e-14);
            CHECK(rel_err(p.lambda1, std::exp(-2 * a * T)) < 1e-14);
            CHECK(rel_err(p.ftle, a) < 1e-14);
            CHECK_FALSE(p.degenerate);
            CHECK(std::abs(std::abs(p.xi2_x) - 1.0) < 1e-14);
            CHECK(std::abs(p.xi2_y) < 1e-14);
            check_frame(p);
            // Backward time: the same DF inverted gives the same FTLE with xi2 along y.
            const CauchyGreenPoint q = cauchy_green_at(std::exp(-a * T), 0.0, 0.0, std::exp(a * T), T);
            CHECK(rel_err(q.ftle, a) < 1e-14);
            CHECK(std::abs(q.xi2_x) < 1e-14);
            CHECK(std::abs(std::abs(q.xi2_y) - 1.0) < 1e-14);
        }
    }
}

TEST_CASE("a rotation gives C = I: degenerate, ftle 0, finite eigenvectors") {
    for (double theta : {0.0, 0.3, 1.0, 2.5, -1.2, 3.14159}) {
        CAPTURE(theta);
        const double c = std::cos(theta), s = std::sin(theta);
        const CauchyGreenPoint p = cauchy_green_at(c, -s, s, c, 7.0);
        CHECK(p.degenerate);
        CHECK(std::abs(p.lambda1 - 1.0) < 1e-15);
        CHECK(std::abs(p.lambda2 - 1.0) < 1e-15);
        CHECK(std::abs(p.ftle) < 1e-16);
        CHECK(p.xi1_x == 1.0);
        CHECK(p.xi1_y == 0.0);
        CHECK(p.xi2_x == 0.0);
        CHECK(p.xi2_y == 1.0);
        check_frame(p);
    }
}

TEST_CASE("shear [[1, s], [0, 1]] has closed-form eigenvalues and eigenvectors") {
    // C = [[1, s], [s, 1 + s^2]]: lambda2 = (2 + s^2 + s sqrt(s^2 + 4)) / 2 (no cancellation for s > 0),
    // lambda1 = 1 / lambda2 (det DF = 1), xi2 parallel to (s, lambda2 - 1).
    for (double s : {1e-3, 0.5, 3.0, 1e3, 1e7}) {
        CAPTURE(s);
        const double l2 = 0.5 * (2.0 + s * s + s * std::sqrt(s * s + 4.0));
        const CauchyGreenPoint p = cauchy_green_at(1.0, s, 0.0, 1.0, 2.0);
        CHECK(rel_err(p.lambda2, l2) < 1e-14);
        CHECK(rel_err(p.lambda1, 1.0 / l2) < 1e-14);
        CHECK(rel_err(p.ftle, std::log(l2) / 4.0) < 1e-14);
        CHECK_FALSE(p.degenerate);
        const double ex = s, ey = l2 - 1.0, en = std::hypot(ex, ey);
        CHECK(std::abs(p.xi2_x * ey / en - p.xi2_y * ex / en) < 1e-14); // parallel: cross product ~ 0
        check_frame(p);
    }
}

TEST_CASE("random gradients: eigenpairs satisfy C xi = lambda xi and xi2 = Omega xi1") {
    std::mt19937_64 rng(42);
    std::uniform_real_distribution<double> u(-3.0, 3.0);
    for (int trial = 0; trial < 1000; ++trial) {
        const double f11 = u(rng), f12 = u(rng), f21 = u(rng), f22 = u(rng);
        const CauchyGreenPoint p = cauchy_green_at(f11, f12, f21, f22, 1.0);
        CAPTURE(trial);
        check_frame(p);
        if (p.degenerate) continue;
        long double cx, cy;
        // Residuals relative to lambda2 (the scale of C): a backward-stable decomposition gives ~ few ulp.
        apply_c(f11, f12, f21, f22, p.xi2_x, p.xi2_y, cx, cy);
        CHECK(static_cast<double>(std::hypot(cx - p.lambda2 * p.xi2_x, cy - p.lambda2 * p.xi2_y)) < 1e-14 * p.lambda2);
        apply_c(f11, f12, f21, f22, p.xi1_x, p.xi1_y, cx, cy);
        CHECK(static_cast<double>(std::hypot(cx - p.lambda1 * p.xi1_x, cy - p.lambda1 * p.xi1_y)) < 1e-14 * p.lambda2);
        const double det = f11 * f22 - f12 * f21;
        CHECK(rel_err(p.lambda1 * p.lambda2, det * det) < 1e-13); // lambda1 lambda2 = det C
    }
}

TEST_CASE("lambda1 of diag(1e12, 1e-12) R is accurate although lambda1 / lambda2 = 1e-48") {
    // DF = diag(1e12, 1e-12) R(theta): C = R^T diag(1e24, 1e-24) R, so lambda1 = 1e-24, lambda2 = 1e24 and
    // xi2 = R^T e1 = (cos, -sin). tr/2 - sqrt(...) would return 0 or noise of size 1e24 * 1e-16.
    for (double theta : {0.0, 0.4, 1.3, 2.0, -0.7}) {
        CAPTURE(theta);
        const double c = std::cos(theta), s = std::sin(theta);
        const CauchyGreenPoint p = cauchy_green_at(1e12 * c, -1e12 * s, 1e-12 * s, 1e-12 * c, 3.0);
        CHECK(rel_err(p.lambda1, 1e-24) < 1e-14);
        CHECK(rel_err(p.lambda2, 1e24) < 1e-14);
        CHECK(std::abs(std::abs(p.xi2_x * c - p.xi2_y * s) - 1.0) < 1e-14); // |<xi2, (c, -s)>| = 1
        check_frame(p);
    }
}

TEST_CASE("entries of 1e200: lambda2 overflows but the FTLE stays finite and exact") {
    const double T = 10.0;
    const CauchyGreenPoint p = cauchy_green_at(1e200, 0.0, 0.0, 1e-200, T);
    CHECK(std::isfinite(p.ftle));
    CHECK(rel_err(p.ftle, std::log(1e200) / T) < 1e-14);
    CHECK(std::abs(std::abs(p.xi2_x) - 1.0) < 1e-15);
    CHECK_FALSE(std::isnan(p.lambda1));
    CHECK_FALSE(std::isnan(p.lambda2));
    // A full matrix: FTLE(1e200 M) = FTLE(M) + log(1e200) / T.
    const CauchyGreenPoint small = cauchy_green_at(1.0, 2.0, 3.0, 1.0, T);
    const CauchyGreenPoint big = cauchy_green_at(1e200, 2e200, 3e200, 1e200, T);
    CHECK(std::isfinite(big.ftle));
    CHECK(rel_err(big.ftle, small.ftle + std::log(1e200) / T) < 1e-14);
    CHECK(std::abs(big.xi2_x - small.xi2_x) < 1e-15);
    CHECK(std::abs(big.xi2_y - small.xi2_y) < 1e-15);
}

TEST_CASE("zero duration gives ftle 0; a non-finite gradient gives NaN, never a fake value") {
    CHECK(cauchy_green_at(2.0, 0.0, 0.0, 0.5, 0.0).ftle == 0.0);
    const CauchyGreenPoint p = cauchy_green_at(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0, 1.0, 1.0);
    CHECK(std::isnan(p.ftle));
    CHECK(p.degenerate);
}

TEST_CASE("cauchy_green_field: masked points are NaN, degenerate points flagged and counted") {
    Grid grid;
    grid.nx = 3;
    grid.ny = 2;
    const double e = std::exp(1.0), nan = std::numeric_limits<double>::quiet_NaN();
    // Points: saddle, identity (degenerate), masked, saddle, NaN gradient (unmasked), rotation (degenerate).
    std::vector<double> dF = {e, 0, 0, 1 / e, 1,   0, 0, 1, nan, nan, nan, nan,
                              e, 0, 0, 1 / e, nan, 0, 0, 1, 0,   -1,  1,   0};
    std::vector<std::uint8_t> mask = {0, 0, mask_left_bounds, 0, 0, 0};
    const CauchyGreenField f = cauchy_green_field(grid, dF, mask, 0.5);
    CHECK(f.degenerate_count == 2);
    CHECK(f.mask[0] == 0);
    CHECK(f.mask[1] == mask_degenerate);
    CHECK(f.mask[2] == mask_left_bounds);
    CHECK(f.mask[4] == mask_non_finite);
    CHECK(f.mask[5] == mask_degenerate);
    CHECK(rel_err(f.ftle[0], 2.0) < 1e-14); // log(e^2) / (2 * 0.5)
    CHECK(rel_err(f.ftle[3], 2.0) < 1e-14);
    CHECK(f.ftle[1] == 0.0);
    CHECK(f.xi2_y[1] == 1.0);
    for (const auto *v : {&f.lambda1, &f.lambda2, &f.ftle, &f.xi1_x, &f.xi1_y, &f.xi2_x, &f.xi2_y}) {
        CHECK(std::isnan((*v)[2]));
        CHECK(std::isnan((*v)[4]));
        CHECK(std::isfinite((*v)[5]));
    }
    CHECK_THROWS_AS(cauchy_green_field(grid, std::vector<double>(4), mask, 1.0), Error);
}

TEST_CASE("cauchy_green_into: only the fields asked for, at an offset, equal to the whole computation") {
    // Random gradients (some masked, one NaN, one identity) computed whole and then as the tail of a larger field
    // that keeps only ftle and lambda2 (the memory tiles' FTLE-only case: no lambda1, no eigenvectors).
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-3.0, 3.0);
    const std::size_t count = 200, first = 50;
    std::vector<double> dF(4 * count);
    for (double &v : dF) v = u(rng);
    std::vector<std::uint8_t> mask(count, 0);
    for (std::size_t p = 0; p < count; p += 17) mask[p] = mask_left_bounds;
    dF[4 * 5] = std::numeric_limits<double>::quiet_NaN();
    for (int q = 0; q < 4; ++q) dF[4 * 6 + q] = (q == 0 || q == 3) ? 1.0 : 0.0;
    Grid grid;
    grid.nx = count;
    grid.ny = 1;
    const CauchyGreenField whole = cauchy_green_field(grid, dF, mask, 2.0);

    CauchyGreenField part;
    part.mask.assign(first + count, 0);
    part.ftle.assign(first + count, -1.0);
    part.lambda2.assign(first + count, -1.0);
    const std::uint64_t degenerate =
        cauchy_green_into(part, first, count, dF.data(), mask.data(), nullptr, nullptr, 2.0);
    CHECK(degenerate == whole.degenerate_count);
    CHECK(part.lambda1.empty());
    CHECK(part.xi1_x.empty());
    for (std::size_t p = 0; p < first; ++p) CHECK(part.ftle[p] == -1.0); // points before `first` untouched
    for (std::size_t p = 0; p < count; ++p) {
        CAPTURE(p);
        CHECK(part.mask[first + p] == whole.mask[p]);
        if (std::isnan(whole.ftle[p])) {
            CHECK(std::isnan(part.ftle[first + p]));
            CHECK(std::isnan(part.lambda2[first + p]));
        } else {
            CHECK(part.ftle[first + p] == whole.ftle[p]);
            CHECK(part.lambda2[first + p] == whole.lambda2[p]);
        }
    }
    CHECK(std::isnan(part.ftle[first + 5]));
    CHECK(part.mask[first + 5] == mask_non_finite);
    CHECK(part.mask[first + 6] == mask_degenerate);
    CHECK_THROWS_AS(cauchy_green_into(part, first + 1, count, dF.data(), mask.data(), nullptr, nullptr, 2.0), Error);
    part.xi2_x.assign(3, 0.0); // neither empty nor the grid's size
    CHECK_THROWS_AS(cauchy_green_into(part, 0, count, dF.data(), mask.data(), nullptr, nullptr, 2.0), Error);
}
