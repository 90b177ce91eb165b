// A forcing that builds up: f(t) = r((t - start) / duration) f_base(t), r rising smoothly from 0 to 1. The paper's
// motivating transient case (its introduction: "most realistic forms of forcing will take time to build up").
// A composite forcing (ABI 1.1): the experiment names the base forcing under "base" and the core evaluates it.
#include <geobarrier/sdk.hpp>

#include <cmath>
#include <string>

namespace {

using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;
using geobarrier::sdk::string_param;
using geobarrier::sdk::Terms;

enum class Shape { smooth, quintic, cubic };

Shape parse_shape(const std::string &s) {
    if (s == "quintic") return Shape::quintic;
    if (s == "cubic") return Shape::cubic;
    return Shape::smooth; // the schema admits only these three
}

// r(s) on [0, 1]: 0 before, 1 after, r(1 - s) = 1 - r(s).
//   smooth:  1 / (1 + exp(1/s - 1/(1 - s))), every derivative 0 at both ends (C-infinity);
//   quintic: 10 s^3 - 15 s^4 + 6 s^5, first and second derivatives 0 at the ends (C2);
//   cubic:   3 s^2 - 2 s^3, first derivative 0 at the ends (C1).
double ramp(Shape shape, double s) {
    if (!(s > 0.0)) return 0.0; // NaN stays NaN through the product with the base below
    if (s >= 1.0) return 1.0;
    switch (shape) {
    case Shape::quintic:
        return s * s * s * (10.0 + s * (-15.0 + 6.0 * s));
    case Shape::cubic:
        return s * s * (3.0 - 2.0 * s);
    case Shape::smooth:
        break;
    }
    return 1.0 / (1.0 + std::exp(1.0 / s - 1.0 / (1.0 - s)));
}

struct Ramp {
    static constexpr const char *name = "ramp";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc =
        "base forcing switched on smoothly: f(t) = r((t - start) / duration) f_base(t), r from 0 to 1";
    static constexpr unsigned min_terms = 1, max_terms = 1;
    static constexpr gb_param_spec params[] = {
        real_param("start", 0.0, -HUGE_VAL, HUGE_VAL, "time", "time at which the ramp leaves 0"),
        real_param("duration", 10.0, 1e-12, HUGE_VAL, "time", "time the ramp takes to reach 1"),
        string_param("shape", "smooth", "smooth|quintic|cubic",
                     "smooth: C-infinity 1/(1+exp(1/s-1/(1-s))); quintic: C2 10s^3-15s^4+6s^5; cubic: C1 3s^2-2s^3"),
    };

    explicit Ramp(const Params &p)
        : m_start(p.real("start")), m_duration(p.real("duration")), m_shape(parse_shape(p.string("shape"))) {}

    void combine(const Terms &terms, double *f) const {
        for (std::size_t k = 0; k < terms.n; ++k) {
            const double s = (terms.t[k] - m_start) / m_duration;
            f[k] = std::isnan(s) ? s : ramp(m_shape, s) * terms.value(0, k);
        }
    }

    double m_start, m_duration;
    Shape m_shape;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::forcing<Ramp>())
