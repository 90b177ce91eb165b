// Trenches of a scalar grid field: curves along which the field is minimal across the curve. The parabolic
// extractor's "shearless" method traces them on the FTLE field, where they are the jet cores: parabolic LCSs are
// the shearless barriers of Farazmand, Blazevski & Haller (2014), material lines of locally weakest stretching,
// which show up as trenches of the FTLE / lambda2 field (a V-shaped one at a steady jet core, where C = I).
#ifndef GEOBARRIER_PARABOLIC_TRENCHES_HPP
#define GEOBARRIER_PARABOLIC_TRENCHES_HPP

#include <geobarrier/grid.hpp>

#include <cstdint>
#include <vector>

namespace geobarrier::parabolic {

struct TrenchSettings {
    // A trench point lies at least this far below the field at `probe_cells` grid spacings on both sides, across
    // the trench: the trench's depth. Seeds need it; a trace stops where the depth falls below half of it.
    double min_depth = 0.0;
    double probe_cells = 3.0;
    double max_length = 1.0; // longest trench, per direction from its seed
};

struct Trench {
    std::vector<double> xy; // x, y interleaved, about half a grid spacing apart
    bool closed = false;
    double length = 0.0;
    double mean_depth = 0.0; // depth averaged over the trench's points
};

// Traces the trenches of `field` (masked where mask & mask_bits != 0, or not finite), deepest seeds first. Seeds
// are interior grid points where the field's Hessian (centred differences) curves up most across a direction n
// (largest eigenvalue positive and larger than the other's magnitude), the point is the least of itself and its
// neighbours at +-h along n (h = the smaller grid spacing) and the depth reaches min_depth. From a seed the trench
// is followed both ways: a step of h/2 along the trench's tangent (perpendicular to n), then a correction to the
// least value along n within +-h (the least of 9 samples, refined by a parabola through it and the values h to
// either side), which does not need the field to be smooth at the trench (a jet core's FTLE has a kink there).
// A trace stops at the box or a masked cell, where no interior minimum is found, where the depth fades, on meeting
// another trench, or on closing. Seeds near a traced trench are skipped.
std::vector<Trench> trace_trenches(const Grid &grid, const std::vector<double> &field,
                                   const std::vector<std::uint8_t> &mask, std::uint8_t mask_bits,
                                   const TrenchSettings &settings);

} // namespace geobarrier::parabolic

#endif // GEOBARRIER_PARABOLIC_TRENCHES_HPP
