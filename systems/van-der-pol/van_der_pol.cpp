// The forced Van der Pol oscillator x' = y, y' = mu (1 - x^2) y - x + f(t): self-excited, with an attracting limit
// cycle (amplitude 2 as mu -> 0) that backward-time FTLE ridges reveal as an attractor.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Batch;
using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct VanDerPol {
    static constexpr const char *name = "van-der-pol";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "forced Van der Pol oscillator: x' = y, y' = mu (1 - x^2) y - x + f(t)";
    static constexpr unsigned dimension = 2;
    // The nondimensional oscillator: position x and velocity y carry no unit (nor does t).
    static constexpr const char *state_names[] = {"x", "y"}, *state_units[] = {"", ""};
    static constexpr gb_param_spec params[] = {
        real_param("mu", 1.0, -HUGE_VAL, HUGE_VAL, "1/time",
                   "nonlinear damping: negative for |x| < 1 (energy in), positive outside (energy out)"),
    };

    explicit VanDerPol(const Params &p) : m_mu(p.real("mu")) {}

    void rhs(const Batch &b, double *dxdt) const {
        const double *__restrict x = b.x;
        const double *__restrict y = b.x + b.ld;
        const double *__restrict f = b.f;
        double *__restrict dx = dxdt;
        double *__restrict dy = dxdt + b.ld;
        const double mu = m_mu;
        for (std::size_t k = 0; k < b.n; ++k) {
            dx[k] = y[k];
            dy[k] = mu * (1.0 - x[k] * x[k]) * y[k] - x[k] + f[k];
        }
    }

    // jac = [[0, 1], [-2 mu x y - 1, mu (1 - x^2)]].
    void jacobian(const Batch &b, double *jac) const {
        const double *__restrict x = b.x;
        const double *__restrict y = b.x + b.ld;
        double *__restrict j00 = jac;
        double *__restrict j01 = jac + b.ld;
        double *__restrict j10 = jac + 2 * b.ld;
        double *__restrict j11 = jac + 3 * b.ld;
        const double mu = m_mu;
        for (std::size_t k = 0; k < b.n; ++k) {
            j00[k] = 0.0;
            j01[k] = 1.0;
            j10[k] = -2.0 * mu * x[k] * y[k] - 1.0;
            j11[k] = mu * (1.0 - x[k] * x[k]);
        }
    }

    // The trace mu (1 - x^2), written as in jacobian() so that both round the same way.
    void divergence(const Batch &b, double *div) const {
        const double *__restrict x = b.x;
        double *__restrict d = div;
        const double mu = m_mu;
        for (std::size_t k = 0; k < b.n; ++k) d[k] = mu * (1.0 - x[k] * x[k]);
    }

    double m_mu;
};

}  // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<VanDerPol>())
