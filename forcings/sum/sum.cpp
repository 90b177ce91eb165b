// The sum of forcings, f(t) = f_1(t) + ... + f_m(t): a composite forcing (ABI 1.1). The experiment lists the terms
// under "terms"; the core evaluates them and hands their values here, so plugins never call each other.
#include <geobarrier/sdk.hpp>

namespace {

using geobarrier::sdk::Params;
using geobarrier::sdk::Terms;

struct Sum {
    static constexpr const char *name = "sum";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "sum of forcings: f(t) = f_1(t) + ... + f_m(t), the terms listed in \"terms\"";
    static constexpr unsigned min_terms = 1, max_terms = 16;

    explicit Sum(const Params &) {}

    // Added in the order the terms are listed, so the result does not depend on the batch size.
    void combine(const Terms &terms, double *f) const {
        double *__restrict out = f;
        for (std::size_t k = 0; k < terms.n; ++k) out[k] = terms.value(0, k);
        for (std::size_t j = 1; j < terms.count; ++j) {
            const double *__restrict term = terms.values + j * terms.ld;
            for (std::size_t k = 0; k < terms.n; ++k) out[k] += term[k];
        }
    }
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::forcing<Sum>())
