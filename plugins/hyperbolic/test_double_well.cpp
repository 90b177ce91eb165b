// Test system for the hyperbolic extractor: the unforced double well x' = y, y' = x + a x^2 - x^3, whose energy
// H = y^2/2 - x^2/2 - a x^3/3 + x^4/4 is conserved. The saddle at the origin has two homoclinic loops on H = 0; the
// quadratic term a makes them unequal (a = 0: the symmetric Duffing well). In forward time both loops are the
// saddle's stable manifold, the repelling barriers the extractor must report.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Batch;
using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct DoubleWell {
    static constexpr const char *name = "double-well";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "test: unforced double well x' = y, y' = x + a x^2 - x^3";
    static constexpr unsigned dimension = 2;
    static constexpr bool uses_forcing = false;
    static constexpr gb_param_spec params[] = {
        real_param("a", 0.0, -HUGE_VAL, HUGE_VAL, "1/(state time^2)", "quadratic force: unequal wells for a != 0"),
    };

    explicit DoubleWell(const Params &p) : m_a(p.real("a")) {}

    void rhs(const Batch &b, double *dxdt) const {
        for (std::size_t k = 0; k < b.n; ++k) {
            const double x = b.x[k];
            dxdt[k] = b.x[b.ld + k];
            dxdt[b.ld + k] = x * (1.0 + x * (m_a - x));
        }
    }

    // [[0, 1], [1 + 2 a x - 3 x^2, 0]]
    void jacobian(const Batch &b, double *jac) const {
        for (std::size_t k = 0; k < b.n; ++k) {
            const double x = b.x[k];
            jac[k] = 0.0;
            jac[b.ld + k] = 1.0;
            jac[2 * b.ld + k] = 1.0 + x * (2.0 * m_a - 3.0 * x);
            jac[3 * b.ld + k] = 0.0;
        }
    }

    void divergence(const Batch &b, double *div) const {
        for (std::size_t k = 0; k < b.n; ++k) div[k] = 0.0;
    }

    double m_a;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<DoubleWell>())
