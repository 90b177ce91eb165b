// The forced spring (elastic) pendulum: a mass on a spring of stiffness k and rest length L0 (rest_length), swinging in
// a plane under gravity g, with the spring's length forced by f(t). State (r, vr, theta, omega): the spring's length,
// its rate, the angle from the downward vertical and the angular velocity,
//   r' = vr,          vr' = r omega^2 + g cos(theta) - k (r - L0) - damping vr + f(t)
//   theta' = omega,   omega' = -(g sin(theta) + 2 vr omega) / r - damping omega
// (per unit mass). Unforced and undamped its energy E = (vr^2 + r^2 omega^2) / 2 - g r cos(theta) + k (r - L0)^2 / 2
// is conserved. The model needs r > 0 (its domain).
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct SpringPendulum {
    static constexpr const char *name = "spring-pendulum";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc =
        "forced spring pendulum (4 state components: r, vr, theta, omega); the forcing drives the spring";
    static constexpr unsigned dimension = 4;
    static constexpr const char *state_names[] = {"r", "vr", "theta", "omega"},
                                *state_units[] = {"length", "length/time", "rad", "rad/time"};
    // Where the model is meant to be used: the spring neither collapses nor runs away.
    static constexpr double domain_min[] = {0.25, -3.0, -3.2, -3.0};
    static constexpr double domain_max[] = {3.0, 3.0, 3.2, 3.0};
    static constexpr gb_param_spec params[] = {
        real_param("g", 1.0, 0.0, HUGE_VAL, "length/time^2", "gravity"),
        real_param("k", 4.0, 0.0, HUGE_VAL, "1/time^2", "spring stiffness per unit mass"),
        real_param("rest_length", 1.0, 0.0, HUGE_VAL, "length", "rest length L0 of the spring"),
        real_param("damping", 0.0, -HUGE_VAL, HUGE_VAL, "1/time", "linear damping of vr and omega"),
    };

    explicit SpringPendulum(const Params &p)
        : m_g(p.real("g")), m_k(p.real("k")), m_rest(p.real("rest_length")), m_damping(p.real("damping")) {}

    // One lane at a time; the SDK derives the Jacobian (automatic differentiation) and the fused step.
    template <class Real> void field(double, const Real *s, double f, Real *dsdt) const {
        using std::cos;
        using std::sin;
        const Real &r = s[0], &vr = s[1], &theta = s[2], &omega = s[3];
        dsdt[0] = vr;
        dsdt[1] = r * omega * omega + m_g * cos(theta) - m_k * (r - m_rest) - m_damping * vr + f;
        dsdt[2] = omega;
        dsdt[3] = -(m_g * sin(theta) + 2.0 * vr * omega) / r - m_damping * omega;
    }

    double m_g, m_k, m_rest, m_damping;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<SpringPendulum>())
