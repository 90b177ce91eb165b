// The forced, damped Duffing oscillator of the paper's section 3 (eqs. duffing-ex3, duffing-ex4,
// duffing_dissipative): x' = y, y' = alpha x - beta x^3 - delta y + f(t), with analytic Jacobian.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct Duffing {
    static constexpr const char *name = "duffing";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "Duffing oscillator: x' = y, y' = alpha x - beta x^3 - delta y + f(t)";
    static constexpr unsigned dimension = 2;
    // The paper's scaled, nondimensional oscillator: position x and velocity y carry no unit (nor does t).
    static constexpr const char *state_names[] = {"x", "y"}, *state_units[] = {"", ""};
    static constexpr gb_param_spec params[] = {
        real_param("alpha", 1.0, -HUGE_VAL, HUGE_VAL, "1/time^2",
                   "coefficient of x in y' (1: the paper's double-well)"),
        real_param("beta", 1.0, -HUGE_VAL, HUGE_VAL, "1/(x^2 time^2)", "cubic stiffness: y' contains -beta x^3"),
        real_param("delta", 0.0, -HUGE_VAL, HUGE_VAL, "1/time", "linear damping: y' contains -delta y (paper: 0.15)"),
    };

    explicit Duffing(const Params &p) : m_alpha(p.real("alpha")), m_beta(p.real("beta")), m_delta(p.real("delta")) {}

    // The vector field and its Jacobian [[0, 1], [alpha - 3 beta x^2, -delta]], one lane at a time: the SDK derives
    // the batched rhs, jacobian and divergence (the trace, -delta: area shrinks as exp(-delta t)) and compiles the
    // fused Runge-Kutta step from them. The Jacobian is given rather than derived for its two explicit multiply-adds.
    void field(double, const double *s, double f, double *dsdt) const {
        dsdt[0] = s[1];
        dsdt[1] = acceleration(s[0], s[1], f);
    }
    void field_jacobian(double, const double *s, double, double *jac) const {
        jac[0] = 0.0;
        jac[1] = 1.0;
        jac[2] = stiffness(s[0]);
        jac[3] = -m_delta;
    }

    // y' = x (alpha - beta x^2) - delta y + f and d(y')/dx = alpha - 3 beta x^2, with explicit multiply-adds: 5 and 2
    // instructions where the CPU has FMA (the fused dop853 step on W spends about a tenth of its time here).
    double acceleration(double x, double y, double f) const {
        using geobarrier::sdk::mul_add;
        return mul_add(-m_delta, y, mul_add(x, mul_add(-m_beta, x * x, m_alpha), f));
    }
    double stiffness(double x) const { return geobarrier::sdk::mul_add(-3.0 * m_beta, x * x, m_alpha); }

    double m_alpha, m_beta, m_delta;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<Duffing>())
