// The linear saddle x' = a x, y' = -a y: flow map diag(e^{aT}, e^{-aT}), so C = diag(e^{2aT}, e^{-2aT}) and
// FTLE = |a| exactly. A test system with known answers for the flow-map and Cauchy-Green code; ignores forcing.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

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

    // The vector field, one lane at a time; the SDK derives the batched rhs, the Jacobian diag(a, -a) (automatic
    // differentiation, exact here), its trace 0 and the fused step.
    template <class Real> void field(double, const Real *s, double, Real *dsdt) const {
        dsdt[0] = m_a * s[0];
        dsdt[1] = -m_a * s[1];
    }

    double m_a;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<LinearSaddle>())
