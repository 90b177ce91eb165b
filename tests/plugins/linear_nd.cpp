// Known-answer linear systems of dimension 3 to 6 for the n-dimensional engine (tests/test_ndim.cpp):
// x' = A x with A = Q D Q^T, D = diag(a_0 .. a_{n-1}), a = rate * (1, -1, 1/2, -1/2, 1/3, -1/3) (saddles of
// decreasing strength), and Q the rotation by `angle` in the plane of components 0 and 2, so that A is not diagonal
// and the variational equations couple every block. Analytically DF(T) = Q diag(e^{a_i T}) Q^T and the Cauchy-Green
// tensor C = Q diag(e^{2 a_i T}) Q^T, with eigenvalues e^{2 a_i T}.
#include <geobarrier/sdk.hpp>

#include <cmath>

namespace {

using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

template <unsigned D> struct LinearND {
    static constexpr const char *names[] = {"", "", "", "linear-3d", "linear-4d", "linear-5d", "linear-6d"};
    static constexpr const char *name = names[D];
    static constexpr const char *version = "0.0.1";
    static constexpr const char *doc = "x' = Q D Q^T x, D = diag(rate (1, -1, 1/2, -1/2, ...)) (test)";
    static constexpr unsigned dimension = D;
    static constexpr bool uses_forcing = false;
    static constexpr gb_param_spec params[] = {
        real_param("rate", 0.5, -HUGE_VAL, HUGE_VAL, "1/time", "rate of the strongest saddle"),
        real_param("angle", 0.3, -HUGE_VAL, HUGE_VAL, "rad", "rotation of the eigenbasis in the (0, 2) plane"),
    };
    explicit LinearND(const Params &p) : m_c(std::cos(p.real("angle"))), m_s(std::sin(p.real("angle"))) {
        for (unsigned i = 0; i < D; ++i) m_a[i] = rate_of(p.real("rate"), i);
    }
    static double rate_of(double rate, unsigned i) { return (i % 2 == 0 ? rate : -rate) / (1 + i / 2); }

    template <class Real> void field(double, const Real *x, double, Real *dxdt) const {
        // y = Q^T x, y_i *= a_i, dxdt = Q y; Q rotates components 0 and 2.
        Real y[D];
        for (unsigned i = 0; i < D; ++i) y[i] = x[i];
        y[0] = m_c * x[0] + m_s * x[2];
        y[2] = -m_s * x[0] + m_c * x[2];
        for (unsigned i = 0; i < D; ++i) y[i] = m_a[i] * y[i];
        for (unsigned i = 0; i < D; ++i) dxdt[i] = y[i];
        dxdt[0] = m_c * y[0] - m_s * y[2];
        dxdt[2] = m_s * y[0] + m_c * y[2];
    }

    double m_c, m_s, m_a[D];
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<LinearND<3>>(), geobarrier::sdk::system<LinearND<4>>(),
                   geobarrier::sdk::system<LinearND<5>>(), geobarrier::sdk::system<LinearND<6>>())
