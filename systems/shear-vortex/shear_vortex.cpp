// A steady vortex with radial shear, x' = -w(r) y, y' = w(r) x with w(r) = omega + shear r^2: a test system with
// known answers for Cauchy-Green and elliptic-barrier code. Circles r = const are invariant and rotate rigidly by
// w(r) T, so F is known in closed form; in polar frames DF = [[1, 0], [gamma, 1]] with gamma = 2 shear r^2 T, so
// lambda1 lambda2 = 1, FTLE = asinh(|shear| r^2 |T|) / |T|, and every circle is a closed shearline
// (<e_theta, C e_theta> = 1). See docs/builtin-plugins.md. Ignores the forcing.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct ShearVortex {
    static constexpr const char *name = "shear-vortex";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc =
        "vortex with radial shear (test system): x' = -w y, y' = w x, w = omega + shear (x^2 + y^2)";
    static constexpr unsigned dimension = 2;
    // Positions, in the length unit of `shear`.
    static constexpr const char *state_names[] = {"x", "y"}, *state_units[] = {"length", "length"};
    static constexpr bool uses_forcing = false;
    static constexpr gb_param_spec params[] = {
        real_param("omega", 1.0, -HUGE_VAL, HUGE_VAL, "rad/time", "angular velocity at the centre"),
        real_param("shear", 1.0, -HUGE_VAL, HUGE_VAL, "rad/(time length^2)",
                   "growth of the angular velocity with r^2 (0: rigid rotation, no strain)"),
    };

    explicit ShearVortex(const Params &p) : m_omega(p.real("omega")), m_shear(p.real("shear")) {}

    // The vector field, one lane at a time; the SDK derives the batched rhs, the exact Jacobian
    // [[-p, -w - 2 shear y^2], [w + 2 shear x^2, p]] with p = 2 shear x y (automatic differentiation), its trace (0 up
    // to rounding: the flow is area-preserving) and the fused step.
    template <class Real> void field(double, const Real *s, double, Real *dsdt) const {
        const Real w = m_omega + m_shear * (s[0] * s[0] + s[1] * s[1]);
        dsdt[0] = -w * s[1];
        dsdt[1] = w * s[0];
    }

    double m_omega, m_shear;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<ShearVortex>())
