// The time-periodic double gyre of Shadden, Lekien & Marsden (Physica D 212, 2005), the standard test flow of the
// LCS literature: stream function psi = A sin(pi g(x, t)) sin(pi y), g = a(t) x^2 + b(t) x, a = eps sin(omega t),
// b = 1 - 2 eps sin(omega t), on [0, 2] x [0, 1], whose boundary is invariant. Its time dependence is its own: it
// ignores the forcing.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Batch;
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

    void rhs(const Batch &b, double *dxdt) const {
        const double *__restrict t = b.t;
        const double *__restrict x = b.x;
        const double *__restrict y = b.x + b.ld;
        double *__restrict dx = dxdt;
        double *__restrict dy = dxdt + b.ld;
        const double pa = pi * m_amplitude;
        for (std::size_t k = 0; k < b.n; ++k) {
            const double s = m_epsilon * std::sin(m_omega * t[k]);
            const double a = s, bb = 1.0 - 2.0 * s;
            const double g = (a * x[k] + bb) * x[k], gx = 2.0 * a * x[k] + bb;
            const double sin_g = std::sin(pi * g), cos_g = std::cos(pi * g);
            const double sin_y = std::sin(pi * y[k]), cos_y = std::cos(pi * y[k]);
            dx[k] = -pa * sin_g * cos_y;
            dy[k] = pa * cos_g * sin_y * gx;
        }
    }

    // With p = pi^2 A cos(pi g) cos(pi y) g_x: jac = [[-p, pi^2 A sin(pi g) sin(pi y)],
    // [pi A sin(pi y) (2 a cos(pi g) - pi sin(pi g) g_x^2), p]].
    void jacobian(const Batch &b, double *jac) const {
        const double *__restrict t = b.t;
        const double *__restrict x = b.x;
        const double *__restrict y = b.x + b.ld;
        double *__restrict j00 = jac;
        double *__restrict j01 = jac + b.ld;
        double *__restrict j10 = jac + 2 * b.ld;
        double *__restrict j11 = jac + 3 * b.ld;
        const double pa = pi * m_amplitude, ppa = pi * pa;
        for (std::size_t k = 0; k < b.n; ++k) {
            const double s = m_epsilon * std::sin(m_omega * t[k]);
            const double a = s, bb = 1.0 - 2.0 * s;
            const double g = (a * x[k] + bb) * x[k], gx = 2.0 * a * x[k] + bb;
            const double sin_g = std::sin(pi * g), cos_g = std::cos(pi * g);
            const double sin_y = std::sin(pi * y[k]), cos_y = std::cos(pi * y[k]);
            const double p = ppa * cos_g * cos_y * gx;
            j00[k] = -p;
            j01[k] = ppa * sin_g * sin_y;
            j10[k] = pa * sin_y * (2.0 * a * cos_g - pi * sin_g * gx * gx);
            j11[k] = p;
        }
    }

    // Incompressible: u_x = -p and v_y = p cancel exactly, in floating point too.
    void divergence(const Batch &b, double *div) const {
        double *__restrict d = div;
        for (std::size_t k = 0; k < b.n; ++k) d[k] = 0.0;
    }

    double m_amplitude, m_epsilon, m_omega;
};

}  // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<DoubleGyre>())
