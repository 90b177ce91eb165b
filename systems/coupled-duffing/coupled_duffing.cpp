// Two Duffing oscillators with a linear spring between them: four state components (x1, v1, x2, v2),
//   x1' = v1,  v1' = alpha x1 - beta x1^3 - delta v1 + k (x2 - x1) + f(t)
//   x2' = v2,  v2' = alpha x2 - beta x2^3 - delta v2 + k (x1 - x2) + drive2 f(t)
// The first oscillator is the planar `duffing` plugin's, written with the same operations, so with k = 0 the (x1, v1)
// slice is the planar Duffing oscillator. Unforced and undamped (delta = 0, f = 0) the system is Hamiltonian, with
// energy H = sum_i (v_i^2 / 2 - alpha x_i^2 / 2 + beta x_i^4 / 4) + k (x1 - x2)^2 / 2.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct CoupledDuffing {
    static constexpr const char *name = "coupled-duffing";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc =
        "two Duffing oscillators coupled by a linear spring k (4 state components: x1, v1, x2, v2)";
    static constexpr unsigned dimension = 4;
    // Nondimensional like `duffing`: positions x_i and velocities v_i carry no unit.
    static constexpr const char *state_names[] = {"x1", "v1", "x2", "v2"}, *state_units[] = {"", "", "", ""};
    static constexpr gb_param_spec params[] = {
        real_param("alpha", 1.0, -HUGE_VAL, HUGE_VAL, "1/time^2", "coefficient of x_i in v_i' (1: double-well)"),
        real_param("beta", 1.0, -HUGE_VAL, HUGE_VAL, "1/(x^2 time^2)", "cubic stiffness: v_i' contains -beta x_i^3"),
        real_param("delta", 0.0, -HUGE_VAL, HUGE_VAL, "1/time", "linear damping: v_i' contains -delta v_i"),
        real_param("k", 0.1, -HUGE_VAL, HUGE_VAL, "1/time^2", "coupling spring: v1' contains k (x2 - x1)"),
        real_param("drive2", 0.0, -HUGE_VAL, HUGE_VAL, "", "weight of the forcing on the second oscillator"),
    };

    explicit CoupledDuffing(const Params &p)
        : m_alpha(p.real("alpha")), m_beta(p.real("beta")), m_delta(p.real("delta")), m_k(p.real("k")),
          m_drive2(p.real("drive2")) {}

    // One lane at a time; the SDK derives the 4 x 4 Jacobian by automatic differentiation, the batched members and
    // the fused step.
    template <class Real> void field(double, const Real *s, double f, Real *dsdt) const {
        using geobarrier::sdk::mul_add;
        dsdt[0] = s[1];
        dsdt[1] = mul_add(m_k, s[2] - s[0], acceleration(s[0], s[1], f));
        dsdt[2] = s[3];
        dsdt[3] = mul_add(m_k, s[0] - s[2], acceleration(s[2], s[3], m_drive2 * f));
    }

    // The planar duffing plugin's y' = x (alpha - beta x^2) - delta y + f, operation for operation.
    template <class Real> Real acceleration(const Real &x, const Real &y, double f) const {
        using geobarrier::sdk::mul_add;
        return mul_add(-m_delta, y, mul_add(x, mul_add(-m_beta, x * x, m_alpha), f));
    }

    double m_alpha, m_beta, m_delta, m_k, m_drive2;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<CoupledDuffing>())
