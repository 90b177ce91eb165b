// The linear saddle x' = a x, y' = -a y: flow map diag(e^{aT}, e^{-aT}), so C = diag(e^{2aT}, e^{-2aT}) and
// FTLE = |a| exactly. A test system with known answers for the flow-map and Cauchy-Green code; ignores forcing.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Batch;
using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct LinearSaddle {
    static constexpr const char *name = "linear-saddle";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "linear saddle x' = a x, y' = -a y (test system; FTLE = |a|)";
    static constexpr unsigned dimension = 2;
    // A nondimensional test system.
    static constexpr const char *state_names[] = {"x", "y"}, *state_units[] = {"", ""};
    static constexpr bool uses_forcing = false;
    static constexpr gb_param_spec params[] = {
        real_param("a", 1.0, -HUGE_VAL, HUGE_VAL, "1/time", "rate: x grows as e^{a t}, y decays as e^{-a t}"),
    };

    explicit LinearSaddle(const Params &p) : m_a(p.real("a")) {}

    void rhs(const Batch &b, double *dxdt) const {
        const double *__restrict x = b.x;
        const double *__restrict y = b.x + b.ld;
        double *__restrict dx = dxdt;
        double *__restrict dy = dxdt + b.ld;
        const double a = m_a;
        for (std::size_t k = 0; k < b.n; ++k) {
            dx[k] = a * x[k];
            dy[k] = -a * y[k];
        }
    }

    // jac = [[a, 0], [0, -a]], the same for every state.
    void jacobian(const Batch &b, double *jac) const {
        double *__restrict j00 = jac;
        double *__restrict j01 = jac + b.ld;
        double *__restrict j10 = jac + 2 * b.ld;
        double *__restrict j11 = jac + 3 * b.ld;
        const double a = m_a;
        for (std::size_t k = 0; k < b.n; ++k) {
            j00[k] = a;
            j01[k] = 0.0;
            j10[k] = 0.0;
            j11[k] = -a;
        }
    }

    // Area-preserving: the trace a + (-a) is exactly 0.
    void divergence(const Batch &b, double *div) const {
        double *__restrict d = div;
        for (std::size_t k = 0; k < b.n; ++k) d[k] = 0.0;
    }

    double m_a;
};

}  // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<LinearSaddle>())
