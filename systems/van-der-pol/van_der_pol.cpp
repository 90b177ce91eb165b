// The forced Van der Pol oscillator x' = y, y' = mu (1 - x^2) y - x + f(t): self-excited, with an attracting limit
// cycle (amplitude 2 as mu -> 0) that backward-time FTLE ridges reveal as an attractor.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

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

    // The vector field, one lane at a time; the SDK derives the batched rhs, the exact Jacobian
    // [[0, 1], [-2 mu x y - 1, mu (1 - x^2)]] (automatic differentiation), its trace and the fused step.
    template <class Real> void field(double, const Real *s, double f, Real *dsdt) const {
        dsdt[0] = s[1];
        dsdt[1] = m_mu * (1.0 - s[0] * s[0]) * s[1] - s[0] + f;
    }

    double m_mu;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<VanDerPol>())
