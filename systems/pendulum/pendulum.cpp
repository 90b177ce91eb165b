// The forced, damped pendulum x' = y, y' = -omega0^2 sin x - damping y + f(t): a mechanical oscillator with a
// separatrix (the saddles at x = +-pi), the classic test of forced-oscillator tools besides Duffing.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Batch;
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
    void rhs(const Batch &b, double *dxdt) const {
        const double *__restrict x = b.x;
        const double *__restrict y = b.x + b.ld;
        const double *__restrict f = b.f;
        double *__restrict dx = dxdt;
        double *__restrict dy = dxdt + b.ld;
        const double w2 = m_omega0_squared, c = m_damping;
        for (std::size_t k = 0; k < b.n; ++k) {
            dx[k] = y[k];
            dy[k] = -w2 * std::sin(x[k]) - c * y[k] + f[k];
        }
    }

    // jac = [[0, 1], [-omega0^2 cos x, -damping]].
    void jacobian(const Batch &b, double *jac) const {
        const double *__restrict x = b.x;
        double *__restrict j00 = jac;
        double *__restrict j01 = jac + b.ld;
        double *__restrict j10 = jac + 2 * b.ld;
        double *__restrict j11 = jac + 3 * b.ld;
        const double w2 = m_omega0_squared, c = m_damping;
        for (std::size_t k = 0; k < b.n; ++k) {
            j00[k] = 0.0;
            j01[k] = 1.0;
            j10[k] = -w2 * std::cos(x[k]);
            j11[k] = -c;
        }
    }

    // Liouville: det DF = exp(-damping (t1 - t0)).
    void divergence(const Batch &b, double *div) const {
        double *__restrict d = div;
        const double c = m_damping;
        for (std::size_t k = 0; k < b.n; ++k) d[k] = -c;
    }

    double m_omega0_squared, m_damping;
};

}  // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<Pendulum>())
