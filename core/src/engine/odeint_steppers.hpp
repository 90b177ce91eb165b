// Boost.Odeint's steppers as the engine drives them (private; batch_integrator.hpp): the batch's right-hand side as
// an Odeint system, and rosenbrock4 (with the published tableau's d4) behind the explicit steppers' do_step call.
#pragma once

#include "batch_context.hpp"

#include <boost/numeric/odeint/stepper/rosenbrock4.hpp>
#include <boost/numeric/odeint/stepper/runge_kutta4.hpp>
#include <boost/numeric/odeint/stepper/runge_kutta_dopri5.hpp>
#include <boost/numeric/odeint/stepper/runge_kutta_fehlberg78.hpp>

#include <algorithm>
#include <utility>

namespace geobarrier::flow_map_engine {

// Internal linkage in each flow_map_dim<N>.cpp (batch_integrator.hpp).
namespace {

namespace odeint = boost::numeric::odeint;

template <unsigned N> struct Rhs {
    BatchContext<N> *ctx;
    void operator()(const State &x, State &dxdt, double t) const { ctx->evaluate(x.data(), dxdt.data(), t); }
};

using Dopri5 = odeint::runge_kutta_dopri5<State>;
using Rkf78 = odeint::runge_kutta_fehlberg78<State>;
using Rk4 = odeint::runge_kutta4<State>;

// The coefficients of Boost.Odeint's rosenbrock4 (Hairer & Wanner's ROS4 set, as in Numerical Recipes' StepperRoss),
// except d4: Boost 1.74 ships d4 = +0.0362 where the published tableau has -0.0362. d4 weighs the time derivative
// df/dt in the last stage, so the wrong sign leaves every non-autonomous system (any forcing) first-order accurate:
// on x' = cos t - x/2 the error at t = 1 halves with h (1.2e-3, 6.4e-4, 3.3e-4 for h = 0.1, 0.05, 0.025) instead of
// falling 16-fold (9.1e-9, 5.6e-10, 3.5e-11 with the sign fixed). Autonomous systems never see d4.
struct RosenbrockCoefficients {
    using value_type = double;
    using order_type = unsigned short;
    const double gamma = 0.25;
    const double d1 = 0.25, d2 = -0.1043, d3 = 0.1035, d4 = -0.3620000000000023e-01; // d4: see above
    const double c2 = 0.386, c3 = 0.21, c4 = 0.63;
    const double c21 = -0.5668800000000000e+01;
    const double a21 = 0.1544000000000000e+01;
    const double c31 = -0.2430093356833875e+01, c32 = -0.2063599157091915e+00;
    const double a31 = 0.9466785280815826e+00, a32 = 0.2557011698983284e+00;
    const double c41 = -0.1073529058151375e+00, c42 = -0.9594562251023355e+01, c43 = -0.2047028614809616e+02;
    const double a41 = 0.3314825187068521e+01, a42 = 0.2896124015972201e+01, a43 = 0.9986419139977817e+00;
    const double c51 = 0.7496443313967647e+01, c52 = -0.1024680431464352e+02, c53 = -0.3399990352819905e+02,
                 c54 = 0.1170890893206160e+02;
    const double a51 = 0.1221224509226641e+01, a52 = 0.6019134481288629e+01, a53 = 0.1253708332932087e+02,
                 a54 = -0.6878860361058950e+00;
    const double c61 = 0.8083246795921522e+01, c62 = -0.7981132988064893e+01, c63 = -0.3152159432874371e+02,
                 c64 = 0.1631930543123136e+02, c65 = -0.6058818238834054e+01;
    const double d21 = 0.1012623508344586e+02, d22 = -0.7487995877610167e+01, d23 = -0.3480091861555747e+02,
                 d24 = -0.7992771707568823e+01, d25 = 0.1025137723295662e+01;
    const double d31 = -0.6762803392801253e+00, d32 = 0.6087714651680015e+01, d33 = 0.1643084320892478e+02,
                 d34 = 0.2476722511418386e+02, d35 = -0.6594389125716872e+01;
    static const order_type stepper_order = 4;
    static const order_type error_order = 3;
};

// rosenbrock4 (Kaps-Rentrop, order 4, embedded order-3 error estimate) behind the same do_step call as the explicit
// steppers, so run_adaptive drives it with the same error norm, masking and step control. Odeint's stepper works on
// ublas vectors with a (right-hand side, Jacobian) pair; the copies in and out are a few dozen doubles.
class RosenbrockStepper {
  public:
    template <unsigned N>
    void do_step(Rhs<N> sys, const State &x, const State & /*dxdt*/, double t, State &x_out, double dt, State &xerr) {
        const std::size_t size = x.size();
        if (m_x.size() != size) {
            m_x.resize(size, false);
            m_out.resize(size, false);
            m_err.resize(size, false);
        }
        std::copy(x.begin(), x.end(), m_x.begin());
        BatchContext<N> *ctx = sys.ctx;
        auto rhs = [ctx](const Vector &u, Vector &dudt, double time) { ctx->evaluate(&u[0], &dudt[0], time); };
        auto jacobian = [ctx](const Vector &u, Matrix &J, double time, Vector &dfdt) {
            ctx->stiff_jacobian(&u[0], time, J, &dfdt[0]);
        };
        m_stepper.do_step(std::make_pair(rhs, jacobian), m_x, t, m_out, dt, m_err);
        std::copy(m_out.begin(), m_out.end(), x_out.begin());
        std::copy(m_err.begin(), m_err.end(), xerr.begin());
    }

  private:
    using Stepper = odeint::rosenbrock4<double, RosenbrockCoefficients>;
    using Vector = Stepper::state_type;
    using Matrix = Stepper::matrix_type;
    Stepper m_stepper;
    Vector m_x, m_out, m_err;
};

} // namespace

} // namespace geobarrier::flow_map_engine
