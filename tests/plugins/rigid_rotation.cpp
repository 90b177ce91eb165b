// Test system: rigid rotation x' = -omega y, y' = omega x. Its flow map is a rotation, so C = I and FTLE = 0
// for every horizon; the core's Cauchy-Green tests use it.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Batch;
using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct RigidRotation {
    static constexpr const char *name = "rigid-rotation";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "rigid rotation x' = -omega y, y' = omega x (test system; C = I)";
    static constexpr unsigned dimension = 2;
    static constexpr bool uses_forcing = false;
    static constexpr gb_param_spec params[] = {
        real_param("omega", 1.0, -HUGE_VAL, HUGE_VAL, "rad/time", "angular velocity"),
    };

    explicit RigidRotation(const Params &p) : m_omega(p.real("omega")) {}

    void rhs(const Batch &b, double *dxdt) const {
        const double *__restrict x = b.x;
        const double *__restrict y = b.x + b.ld;
        double *__restrict dx = dxdt;
        double *__restrict dy = dxdt + b.ld;
        const double omega = m_omega;
        for (std::size_t k = 0; k < b.n; ++k) {
            dx[k] = -omega * y[k];
            dy[k] = omega * x[k];
        }
    }

    // The per-lane field without a per-lane Jacobian: the SDK's fused step then offers positions only and declines
    // variational steps, which the core must take stage by stage instead (test_lockstep).
    void field(double, const double *s, double, double *dsdt) const {
        dsdt[0] = -m_omega * s[1];
        dsdt[1] = m_omega * s[0];
    }

    // jac = [[0, -omega], [omega, 0]].
    void jacobian(const Batch &b, double *jac) const {
        double *__restrict j00 = jac;
        double *__restrict j01 = jac + b.ld;
        double *__restrict j10 = jac + 2 * b.ld;
        double *__restrict j11 = jac + 3 * b.ld;
        const double omega = m_omega;
        for (std::size_t k = 0; k < b.n; ++k) {
            j00[k] = 0.0;
            j01[k] = -omega;
            j10[k] = omega;
            j11[k] = 0.0;
        }
    }

    void divergence(const Batch &b, double *div) const {
        double *__restrict d = div;
        for (std::size_t k = 0; k < b.n; ++k) d[k] = 0.0;
    }

    double m_omega;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<RigidRotation>())
