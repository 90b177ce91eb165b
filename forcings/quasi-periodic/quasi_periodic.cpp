// Quasi-periodic forcing f(t) = a1 cos(omega1 t + phase1) + a2 cos(omega2 t + phase2): with an irrational frequency
// ratio (the default omega2 / omega1 = sqrt 2) it never repeats, the intermediate case between the periodic forcing
// and the aperiodic ones the paper is about (its introduction: period maps need recurrence).
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct QuasiPeriodic {
    static constexpr const char *name = "quasi-periodic";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc =
        "two incommensurate frequencies: f(t) = amplitude1 cos(omega1 t + phase1) + amplitude2 cos(omega2 t + phase2)";
    static constexpr gb_param_spec params[] = {
        real_param("amplitude1", 0.04, -HUGE_VAL, HUGE_VAL, "", "amplitude of the first cosine"),
        real_param("omega1", 1.0, -HUGE_VAL, HUGE_VAL, "rad/time", "angular frequency of the first cosine"),
        real_param("phase1", 0.0, -HUGE_VAL, HUGE_VAL, "rad", "phase of the first cosine at t = 0"),
        real_param("amplitude2", 0.04, -HUGE_VAL, HUGE_VAL, "", "amplitude of the second cosine"),
        real_param("omega2", 1.4142135623730951, -HUGE_VAL, HUGE_VAL, "rad/time",
                   "angular frequency of the second cosine (default sqrt 2: incommensurate with omega1 = 1)"),
        real_param("phase2", 0.0, -HUGE_VAL, HUGE_VAL, "rad", "phase of the second cosine at t = 0"),
    };

    explicit QuasiPeriodic(const Params &p)
        : m_a1(p.real("amplitude1")), m_w1(p.real("omega1")), m_p1(p.real("phase1")), m_a2(p.real("amplitude2")),
          m_w2(p.real("omega2")), m_p2(p.real("phase2")) {}

    void evaluate(std::size_t n, const double *t, double *f) const {
        const double *__restrict tt = t;
        double *__restrict out = f;
        for (std::size_t k = 0; k < n; ++k)
            out[k] = m_a1 * std::cos(m_w1 * tt[k] + m_p1) + m_a2 * std::cos(m_w2 * tt[k] + m_p2);
    }

    double m_a1, m_w1, m_p1, m_a2, m_w2, m_p2;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::forcing<QuasiPeriodic>())
