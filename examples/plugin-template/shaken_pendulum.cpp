// A system plugin: a damped pendulum whose pivot is shaken sideways with acceleration f(t) (per unit length),
//   x' = y,   y' = -omega0^2 sin x - damping y - f(t) cos x.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Batch;
using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct ShakenPendulum {
    static constexpr const char *name = "shaken-pendulum";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "pendulum on a shaken pivot: y' = -omega0^2 sin x - damping y - f(t) cos x";
    static constexpr unsigned dimension = 2;
    // Optional (ABI 1.2): names and units of the state components, for axis labels "theta [rad]".
    static constexpr const char *state_names[] = {"theta", "omega"}, *state_units[] = {"rad", "rad/time"};
    static constexpr gb_param_spec params[] = {
        real_param("omega0", 1.0, 0.0, HUGE_VAL, "rad/time", "small-oscillation angular frequency sqrt(g / L)"),
        real_param("damping", 0.1, 0.0, HUGE_VAL, "1/time", "linear damping"),
    };

    explicit ShakenPendulum(const Params &p) : m_w2(p.real("omega0") * p.real("omega0")), m_c(p.real("damping")) {}

    // A batch of lanes: component i of lane k is b.x[i * b.ld + k]; lane k has time b.t[k] and forcing b.f[k].
    void rhs(const Batch &b, double *dxdt) const {
        for (std::size_t k = 0; k < b.n; ++k) {
            const double x = b.x[k], y = b.x[b.ld + k];
            dxdt[k] = y;
            dxdt[b.ld + k] = -m_w2 * std::sin(x) - m_c * y - b.f[k] * std::cos(x);
        }
    }

    // Optional: the Jacobian (row-major 2 x 2 blocks of lanes) lets geobarrier use the variational equations.
    void jacobian(const Batch &b, double *jac) const {
        for (std::size_t k = 0; k < b.n; ++k) {
            const double x = b.x[k];
            jac[0 * b.ld + k] = 0.0;
            jac[1 * b.ld + k] = 1.0;
            jac[2 * b.ld + k] = -m_w2 * std::cos(x) + b.f[k] * std::sin(x);
            jac[3 * b.ld + k] = -m_c;
        }
    }

    // Optional: the divergence, the trace of the Jacobian.
    void divergence(const Batch &b, double *div) const {
        for (std::size_t k = 0; k < b.n; ++k) div[k] = -m_c;
    }

    double m_w2, m_c;
};

}  // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<ShakenPendulum>())
