// The forced, damped pendulum x' = y, y' = -omega0^2 sin x - damping y + f(t): a mechanical oscillator with a
// separatrix (the saddles at x = +-pi), the classic test of forced-oscillator tools besides Duffing.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct Pendulum {
    static constexpr const char *name = "pendulum";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "forced, damped pendulum: x' = y, y' = -omega0^2 sin x - damping y + f(t)";
    static constexpr unsigned dimension = 2;
    // Angle x and angular velocity y.
    static constexpr const char *state_names[] = {"x", "y"}, *state_units[] = {"rad", "rad/time"};
    static constexpr gb_param_spec params[] = {
        real_param("omega0", 1.0, 0.0, HUGE_VAL, "rad/time", "small-oscillation angular frequency sqrt(g / L)"),
        real_param("damping", 0.0, -HUGE_VAL, HUGE_VAL, "1/time", "linear damping: y' contains -damping y"),
    };

    explicit Pendulum(const Params &p)
        : m_omega0_squared(p.real("omega0") * p.real("omega0")), m_damping(p.real("damping")) {}

    // Component i of lane k is at [i * ld + k]; the loops run over lanes.
    // The vector field, one lane at a time; the SDK derives the batched rhs, the exact Jacobian
    // [[0, 1], [-omega0^2 cos x, -damping]] (automatic differentiation), its trace and the fused step.
    template <class Real> void field(double, const Real *s, double f, Real *dsdt) const {
        using std::sin;
        dsdt[0] = s[1];
        dsdt[1] = -m_omega0_squared * sin(s[0]) - m_damping * s[1] + f;
    }

    double m_omega0_squared, m_damping;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<Pendulum>())
