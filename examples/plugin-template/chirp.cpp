// A forcing plugin: a linear chirp, a cosine whose frequency sweeps up with time (aperiodic),
//   f(t) = amplitude cos(omega t + rate t^2 / 2).
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct Chirp {
    static constexpr const char *name = "chirp";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "linear chirp f(t) = amplitude cos(omega t + rate t^2 / 2)";
    static constexpr gb_param_spec params[] = {
        real_param("amplitude", 0.1, -HUGE_VAL, HUGE_VAL, "", "amplitude"),
        real_param("omega", 0.5, -HUGE_VAL, HUGE_VAL, "rad/time", "angular frequency at t = 0"),
        real_param("rate", 0.05, -HUGE_VAL, HUGE_VAL, "rad/time^2", "growth of the angular frequency per unit time"),
    };

    explicit Chirp(const Params &p) : m_a(p.real("amplitude")), m_w(p.real("omega")), m_r(p.real("rate")) {}

    // n times t[k]; write f[k].
    void evaluate(std::size_t n, const double *t, double *f) const {
        for (std::size_t k = 0; k < n; ++k) f[k] = m_a * std::cos((m_w + 0.5 * m_r * t[k]) * t[k]);
    }

    double m_a, m_w, m_r;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::forcing<Chirp>())
