// Must not compile: a per-lane `field` without const. The SDK could not call it and the plugin would silently lose
// its fused step and derived Jacobian; instead the build stops with a message saying what to write (ctest
// test_sdk_field_not_const checks the message).
#include <geobarrier/sdk.hpp>

struct NotConst {
    static constexpr const char *name = "not-const", *version = "1.0.0", *doc = "x' = y, y' = -x";
    static constexpr unsigned dimension = 2;
    explicit NotConst(const geobarrier::sdk::Params &) {}
    template <class Real> void field(double, const Real *x, double, Real *dxdt) { // missing const
        dxdt[0] = x[1];
        dxdt[1] = -x[0];
    }
};
GEOBARRIER_PLUGINS(geobarrier::sdk::system<NotConst>())
