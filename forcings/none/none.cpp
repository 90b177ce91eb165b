// The zero forcing f(t) = 0: the unforced system (the paper's eps = 0 case, where Duffing is integrable).
#include <geobarrier/sdk.hpp>

namespace {

struct NoForcing {
    static constexpr const char *name = "none";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "no forcing: f(t) = 0";

    explicit NoForcing(const geobarrier::sdk::Params &) {}

    void evaluate(std::size_t n, const double *t, double *f) const {
        (void)t;
        double *__restrict out = f;
        for (std::size_t k = 0; k < n; ++k) out[k] = 0.0;
    }
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::forcing<NoForcing>())
