// A steady vortex with radial shear, x' = -w(r) y, y' = w(r) x with w(r) = omega + shear r^2: a test system with
// known answers for Cauchy-Green and elliptic-barrier code. Circles r = const are invariant and rotate rigidly by
// w(r) T, so F is known in closed form; in polar frames DF = [[1, 0], [gamma, 1]] with gamma = 2 shear r^2 T, so
// lambda1 lambda2 = 1, FTLE = asinh(|shear| r^2 |T|) / |T|, and every circle is a closed shearline
// (<e_theta, C e_theta> = 1). See docs/builtin-plugins.md. Ignores the forcing.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Batch;
using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct ShearVortex {
    static constexpr const char *name = "shear-vortex";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc =
        "vortex with radial shear (test system): x' = -w y, y' = w x, w = omega + shear (x^2 + y^2)";
    static constexpr unsigned dimension = 2;
    // Positions, in the length unit of `shear`.
    static constexpr const char *state_names[] = {"x", "y"}, *state_units[] = {"length", "length"};
    static constexpr bool uses_forcing = false;
    static constexpr gb_param_spec params[] = {
        real_param("omega", 1.0, -HUGE_VAL, HUGE_VAL, "rad/time", "angular velocity at the centre"),
        real_param("shear", 1.0, -HUGE_VAL, HUGE_VAL, "rad/(time length^2)",
                   "growth of the angular velocity with r^2 (0: rigid rotation, no strain)"),
    };

    explicit ShearVortex(const Params &p) : m_omega(p.real("omega")), m_shear(p.real("shear")) {}

    void rhs(const Batch &b, double *dxdt) const {
        const double *__restrict x = b.x;
        const double *__restrict y = b.x + b.ld;
        double *__restrict dx = dxdt;
        double *__restrict dy = dxdt + b.ld;
        const double omega = m_omega, shear = m_shear;
        for (std::size_t k = 0; k < b.n; ++k) {
            const double w = omega + shear * (x[k] * x[k] + y[k] * y[k]);
            dx[k] = -w * y[k];
            dy[k] = w * x[k];
        }
    }

    // With p = 2 shear x y: jac = [[-p, -w - 2 shear y^2], [w + 2 shear x^2, p]].
    void jacobian(const Batch &b, double *jac) const {
        const double *__restrict x = b.x;
        const double *__restrict y = b.x + b.ld;
        double *__restrict j00 = jac;
        double *__restrict j01 = jac + b.ld;
        double *__restrict j10 = jac + 2 * b.ld;
        double *__restrict j11 = jac + 3 * b.ld;
        const double omega = m_omega, shear = m_shear;
        for (std::size_t k = 0; k < b.n; ++k) {
            const double w = omega + shear * (x[k] * x[k] + y[k] * y[k]);
            const double p = 2.0 * shear * x[k] * y[k];
            j00[k] = -p;
            j01[k] = -w - 2.0 * shear * y[k] * y[k];
            j10[k] = w + 2.0 * shear * x[k] * x[k];
            j11[k] = p;
        }
    }

    // Area-preserving: the trace -p + p is exactly 0.
    void divergence(const Batch &b, double *div) const {
        double *__restrict d = div;
        for (std::size_t k = 0; k < b.n; ++k) d[k] = 0.0;
    }

    double m_omega, m_shear;
};

}  // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<ShearVortex>())
