// Periodic forcing f(t) = amplitude cos(omega t + phase): the paper's eps cos(t) of section 3.1
// (eps = 0.08 undamped, 0.3 with damping in eq. duffing_dissipative).
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct Cosine {
    static constexpr const char *name = "cosine";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "periodic forcing f(t) = amplitude cos(omega t + phase)";
    static constexpr gb_param_spec params[] = {
        real_param("amplitude", 0.08, -HUGE_VAL, HUGE_VAL, "",
                   "forcing amplitude, the paper's eps (0.08 undamped, 0.3 damped)"),
        real_param("omega", 1.0, -HUGE_VAL, HUGE_VAL, "rad/time", "angular frequency (period 2 pi / omega)"),
        real_param("phase", 0.0, -HUGE_VAL, HUGE_VAL, "rad", "phase at t = 0"),
    };

    explicit Cosine(const Params &p)
        : m_amplitude(p.real("amplitude")), m_omega(p.real("omega")), m_phase(p.real("phase")) {}

    void evaluate(std::size_t n, const double *t, double *f) const {
        const double *__restrict tt = t;
        double *__restrict out = f;
        const double amplitude = m_amplitude, omega = m_omega, phase = m_phase;
        for (std::size_t k = 0; k < n; ++k) out[k] = amplitude * std::cos(omega * tt[k] + phase);
    }

    double m_amplitude, m_omega, m_phase;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::forcing<Cosine>())
