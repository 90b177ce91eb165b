// Must not compile: a `field_jacobian` with a wrong signature (a non-const state pointer). The build stops with a
// message saying what to write (ctest test_sdk_field_jacobian_wrong checks the message).
#include <geobarrier/sdk.hpp>

struct WrongJacobian {
    static constexpr const char *name = "wrong-jacobian", *version = "1.0.0", *doc = "x' = y, y' = -x";
    static constexpr unsigned dimension = 2;
    explicit WrongJacobian(const geobarrier::sdk::Params &) {}
    void field(double, const double *x, double, double *dxdt) const {
        dxdt[0] = x[1];
        dxdt[1] = -x[0];
    }
    void field_jacobian(double, double *x, double, double *jac) const { // x must be const double *
        jac[0] = 0.0 * x[0];
        jac[1] = 1.0;
        jac[2] = -1.0;
        jac[3] = 0.0;
    }
};
GEOBARRIER_PLUGINS(geobarrier::sdk::system<WrongJacobian>())
