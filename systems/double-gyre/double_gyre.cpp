// The time-periodic double gyre of Shadden, Lekien & Marsden (Physica D 212, 2005), the standard test flow of the
// LCS literature: stream function psi = A sin(pi g(x, t)) sin(pi y), g = a(t) x^2 + b(t) x, a = eps sin(omega t),
// b = 1 - 2 eps sin(omega t), on [0, 2] x [0, 1], whose boundary is invariant. Its time dependence is its own: it
// ignores the forcing.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

constexpr double pi = 3.141592653589793;

struct DoubleGyre {
    static constexpr const char *name = "double-gyre";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc =
        "double gyre (Shadden et al. 2005): u = -pi A sin(pi g) cos(pi y), v = pi A cos(pi g) sin(pi y) dg/dx";
    static constexpr unsigned dimension = 2;
    // Positions in the box [0, 2] x [0, 1], in the length unit of `amplitude`.
    static constexpr const char *state_names[] = {"x", "y"}, *state_units[] = {"length", "length"};
    static constexpr bool uses_forcing = false;
    // The flow is defined on the two gyres' box; outside it the formulas continue periodically.
    static constexpr double domain_min[] = {0.0, 0.0};
    static constexpr double domain_max[] = {2.0, 1.0};
    static constexpr gb_param_spec params[] = {
        real_param("amplitude", 0.1, -HUGE_VAL, HUGE_VAL, "length^2/time", "velocity amplitude A"),
        real_param("epsilon", 0.25, -HUGE_VAL, HUGE_VAL, "",
                   "how far the gyres' dividing line swings: it oscillates about x = 1 (0 = steady)"),
        real_param("omega", 0.6283185307179586, -HUGE_VAL, HUGE_VAL, "rad/time",
                   "angular frequency of the oscillation (default 2 pi / 10: period 10)"),
    };

    explicit DoubleGyre(const Params &p)
        : m_amplitude(p.real("amplitude")), m_epsilon(p.real("epsilon")), m_omega(p.real("omega")) {}

    // The vector field and its Jacobian, one lane at a time; the SDK derives the batched rhs, the divergence (the
    // trace -p + p, exactly 0: the flow is incompressible) and the fused step. The Jacobian is given rather than
    // derived: it reuses the field's sines and cosines.
    void field(double t, const double *s, double, double *dsdt) const {
        const Gyre g = at(t, s);
        dsdt[0] = -pi * m_amplitude * g.sin_g * g.cos_y;
        dsdt[1] = pi * m_amplitude * g.cos_g * g.sin_y * g.gx;
    }
    // With p = pi^2 A cos(pi g) cos(pi y) g_x: jac = [[-p, pi^2 A sin(pi g) sin(pi y)],
    // [pi A sin(pi y) (2 a cos(pi g) - pi sin(pi g) g_x^2), p]].
    void field_jacobian(double t, const double *s, double, double *jac) const {
        const Gyre g = at(t, s);
        const double pa = pi * m_amplitude, ppa = pi * pa;
        const double p = ppa * g.cos_g * g.cos_y * g.gx;
        jac[0] = -p;
        jac[1] = ppa * g.sin_g * g.sin_y;
        jac[2] = pa * g.sin_y * (2.0 * g.a * g.cos_g - pi * g.sin_g * g.gx * g.gx);
        jac[3] = p;
    }

    // g = a(t) x^2 + b(t) x, its slope g_x, and the sines and cosines of pi g and pi y at one state.
    struct Gyre {
        double a, gx, sin_g, cos_g, sin_y, cos_y;
    };
    Gyre at(double t, const double *s) const {
        const double e = m_epsilon * std::sin(m_omega * t);
        const double a = e, b = 1.0 - 2.0 * e;
        const double g = (a * s[0] + b) * s[0], gx = 2.0 * a * s[0] + b;
        return {a, gx, std::sin(pi * g), std::cos(pi * g), std::sin(pi * s[1]), std::cos(pi * s[1])};
    }

    double m_amplitude, m_epsilon, m_omega;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<DoubleGyre>())
