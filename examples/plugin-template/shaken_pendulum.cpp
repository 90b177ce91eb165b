// A system plugin: a damped pendulum whose pivot is shaken sideways with acceleration f(t) (per unit length),
//   x' = y,   y' = -omega0^2 sin x - damping y - f(t) cos x.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

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

    // The vector field at one state s (one lane): dsdt[i] = component i of v at time t with forcing value f. A template
    // over the number type: the SDK also evaluates it on dual numbers and so derives the exact Jacobian, for the
    // variational equations. It derives the batched evaluation and a fused Runge-Kutta step from it, too.
    template <class Real> void field(double, const Real *s, double f, Real *dsdt) const {
        using std::cos, std::sin; // unqualified calls below: the dual-number overloads are found too
        dsdt[0] = s[1];
        dsdt[1] = -m_w2 * sin(s[0]) - m_c * s[1] - f * cos(s[0]);
    }

    double m_w2, m_c;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<ShakenPendulum>())
