// Test system for the elliptic extractor: a steady circular shear flow x' = -w(r) y, y' = w(r) x with angular
// velocity w(r) = omega + shear r^2. Its trajectories are circles, its flow map turns each circle rigidly by
// w(r) t, and the shear r w'(r) t between circles makes every circle around the origin a closed shearline (paper,
// section 2.1: "closed trajectories of a steady, circular shear flow"), with index +1 at the centre.
// With `contraction` c > 0 (x' = -w y - c x, y' = w x - c y; divergence -2c) every circle shrinks by e^(-c t)
// while turning: the angle gained depends on the initial radius only, so DF is e^(-c t) times the conservative
// one, the same eigenvectors and shearlines (the circles), but arclength scales by e^(-c t) and area by e^(-2 c t):
// a non-conservative flow whose barriers' length and area changes are known exactly.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Batch;
using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct CircularShear {
    static constexpr const char *name = "circular-shear";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc =
        "test: steady circular shear flow x' = -w(r) y, y' = w(r) x, w = omega + shear r^2";
    static constexpr unsigned dimension = 2;
    static constexpr bool uses_forcing = false;
    static constexpr gb_param_spec params[] = {
        real_param("omega", 1.0, -HUGE_VAL, HUGE_VAL, "rad/time", "angular velocity at the centre"),
        real_param("shear", 0.5, -HUGE_VAL, HUGE_VAL, "rad/(time state^2)", "w(r) = omega + shear r^2"),
        real_param("contraction", 0.0, -HUGE_VAL, HUGE_VAL, "1/time", "c: radial contraction rate (divergence -2c)"),
    };

    explicit CircularShear(const Params &p)
        : m_omega(p.real("omega")), m_shear(p.real("shear")), m_contraction(p.real("contraction")) {}

    void rhs(const Batch &b, double *dxdt) const {
        for (std::size_t k = 0; k < b.n; ++k) {
            const double x = b.x[k], y = b.x[b.ld + k];
            const double w = m_omega + m_shear * (x * x + y * y);
            dxdt[k] = -w * y - m_contraction * x;
            dxdt[b.ld + k] = w * x - m_contraction * y;
        }
    }

    // d/dx (-w y) = -2 s x y, d/dy (-w y) = -w - 2 s y^2, d/dx (w x) = w + 2 s x^2, d/dy (w x) = 2 s x y; minus c
    // on the diagonal.
    void jacobian(const Batch &b, double *jac) const {
        for (std::size_t k = 0; k < b.n; ++k) {
            const double x = b.x[k], y = b.x[b.ld + k];
            const double w = m_omega + m_shear * (x * x + y * y);
            jac[k] = -2.0 * m_shear * x * y - m_contraction;
            jac[b.ld + k] = -w - 2.0 * m_shear * y * y;
            jac[2 * b.ld + k] = w + 2.0 * m_shear * x * x;
            jac[3 * b.ld + k] = 2.0 * m_shear * x * y - m_contraction;
        }
    }

    void divergence(const Batch &b, double *div) const {
        for (std::size_t k = 0; k < b.n; ++k) div[k] = -2.0 * m_contraction;
    }

    double m_omega, m_shear, m_contraction;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<CircularShear>())
