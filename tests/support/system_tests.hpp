// What the tests beside each system share: its right-hand side at one state, and tight integrator settings for
// comparisons against closed forms.
#pragma once

#include <geobarrier/flow_map.hpp>
#include <geobarrier/plugin.hpp>

#include <doctest/doctest.h>

#include <array>
#include <cstddef>
#include <cstdint>

namespace geobarrier::test {

// The system's velocity at one state x (one lane, t = 0) under the forcing value f; the plugin must report GB_OK.
template <std::size_t N> std::array<double, N> rhs_at(const System &s, const std::array<double, N> &x, double f) {
    std::array<double, N> dxdt{};
    const double t = 0.0;
    std::int32_t status = -1;
    s.rhs(1, 1, &t, x.data(), &f, dxdt.data(), &status);
    CHECK(status == GB_OK);
    return dxdt;
}

// Tolerances far below the checks' (which compare with closed forms at 1e-9 or so): the integrator's error is
// not what is tested.
inline IntegratorSettings tight_integrator() {
    IntegratorSettings s;
    s.rtol = 1e-12;
    s.atol = 1e-15;
    return s;
}

} // namespace geobarrier::test
