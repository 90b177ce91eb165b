// A steady parallel shear flow x' = U p(y / L), y' = 0: a test system with known answers for parabolic barriers
// (paper section 2.1: "the parallel trajectories of a steady shear flow"). Every line y = const is invariant and
// slides rigidly, so F(x0, y0) = (x0 + U p(y0/L) T, y0), DF = [[1, s], [0, 1]] with s = (U/L) p'(y0/L) T, and
// lambda1 lambda2 = 1. Profiles: "jet" p = sech^2 (the Bickley jet), "layer" p = tanh (a shear layer). Ignores
// the forcing.
#include <geobarrier/sdk.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

namespace {

using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;
using geobarrier::sdk::string_param;

struct ParallelShear {
    static constexpr const char *name = "parallel-shear";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "steady parallel shear flow (test system): x' = U p(y/L), y' = 0 (U = velocity, "
                                       "L = width); p = sech^2 (jet) or tanh (layer)";
    static constexpr unsigned dimension = 2;
    // Positions along (x) and across (y) the flow, in the length unit of `width`.
    static constexpr const char *state_names[] = {"x", "y"}, *state_units[] = {"length", "length"};
    static constexpr bool uses_forcing = false;
    static constexpr gb_param_spec params[] = {
        string_param("profile", "jet", "jet|layer",
                     "jet: p = sech^2 (Bickley jet, core at y = 0); layer: p = tanh (shear layer centred on y = 0)"),
        real_param("velocity", 1.0, -HUGE_VAL, HUGE_VAL, "length/time", "velocity scale"),
        real_param("width", 1.0, 1e-12, HUGE_VAL, "length", "width scale"),
    };

    explicit ParallelShear(const Params &p)
        : m_jet(p.string("profile") == "jet"), m_u(p.real("velocity")), m_l(p.real("width")) {}

    // p(z) and p'(z).
    template <class Real> Real profile(const Real &z) const {
        using std::cosh, std::tanh;
        if (!m_jet) return tanh(z);
        const Real c = 1.0 / cosh(z);
        return c * c;
    }

    // The vector field, one lane at a time; the SDK derives the batched rhs, the exact Jacobian
    // [[0, U p'(y/L) / L], [0, 0]] (automatic differentiation), its trace 0 and the fused step.
    template <class Real> void field(double, const Real *s, double, Real *dsdt) const {
        dsdt[0] = m_u * profile(s[1] / m_l);
        dsdt[1] = Real(0.0);
    }

    bool m_jet;
    double m_u, m_l;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<ParallelShear>())
