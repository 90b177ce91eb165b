// The uniform grid of initial conditions G0 and the mask that marks points
// whose values must not be used.
#ifndef GEOBARRIER_GRID_HPP
#define GEOBARRIER_GRID_HPP

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace geobarrier {

// nx * ny points over [x_min, x_max] x [y_min, y_max], both ends included.
// Fields on the grid are row-major with the row index = y: value(i, j) is at
// i * nx + j, at the point (x(j), y(i)).
struct Grid {
    double x_min = 0.0, x_max = 1.0, y_min = 0.0, y_max = 1.0;
    std::size_t nx = 2, ny = 2;

    std::size_t size() const { return nx * ny; }
    double dx() const { return (x_max - x_min) / static_cast<double>(nx - 1); }
    double dy() const { return (y_max - y_min) / static_cast<double>(ny - 1); }
    double x(std::size_t j) const { return x_min + dx() * static_cast<double>(j); }
    double y(std::size_t i) const { return y_min + dy() * static_cast<double>(i); }

    // The column j whose x(j) is nearest to x: (x - x_min) / dx rounded half away from zero (std::lround), clamped to
    // [0, nx - 1], so that a point outside the grid gets the column on the grid's nearer edge (the reads of a field
    // at a point off the grid, a little outside after rounding, stay in bounds); 0 for NaN.
    std::size_t nearest_column(double x) const { return nearest_index((x - x_min) / dx(), nx); }
    // The same for the row i whose y(i) is nearest to y, in [0, ny - 1].
    std::size_t nearest_row(double y) const { return nearest_index((y - y_min) / dy(), ny); }
    // The index i * nx + j of the grid point nearest to (x, y) so, for fields in the grid's row-major order.
    std::size_t nearest_point(double x, double y) const { return nearest_row(y) * nx + nearest_column(x); }

  private:
    // u (in grid spacings from the first point) rounded and clamped to [0, n - 1]. Clamped before rounding: std::lround
    // of a value beyond long's range, or of NaN, is unspecified (a sanitizer build gave column 0 for x = 1e300).
    static std::size_t nearest_index(double u, std::size_t n) {
        if (!(u > 0.0)) return 0;
        if (u >= static_cast<double>(n - 1)) return n - 1;
        return static_cast<std::size_t>(std::lround(u));
    }
};

// How the Cauchy–Green tensor of an n-dimensional system is seen on a two-dimensional slice of its phase space
// (docs/experiment-format.md, "Grids as slices", says when each is the right one). Each is handed to the planar
// pipeline as a 2 x 2 gradient G whose G^T G has the eigenvalues below (cauchy_green.hpp, slice_gradient).
enum class SliceTensor {
    full,       // C = DF^T DF of the whole n x n DF: FTLE from its largest eigenvalue; eigenvectors not in the slice
    restricted, // P^T C P (P: the slice's two unit vectors): stretching of perturbations within the slice, measured in
                // the whole phase space; eigenvectors in the slice
    projected   // B^T B, B the 2 x 2 block of DF on the slice's axes: the derivative of the map from the slice to its
                // projection; the planar Cauchy–Green tensor when the slice is invariant (uncoupled components)
};

// A grid over two components of an n-dimensional state (the slice's axes), the other components fixed.
struct Slice {
    std::array<unsigned, 2> axes{0, 1}; // state components along the grid's x and y
    std::vector<double> state;          // every component's initial value (the axes' entries are ignored)
    SliceTensor tensor = SliceTensor::full;
};

// Why a grid point is masked; a point's mask is the OR of these bits, 0 = valid.
// Written to fields.nc as the `mask` variable with CF flag_masks/flag_meanings.
enum MaskBits : std::uint8_t {
    mask_left_bounds = 1,   // the trajectory left the experiment's `bounds` box
    mask_non_finite = 2,    // the trajectory blew up or the plugin returned NaN/Inf
    mask_step_limit = 4,    // the integrator hit its step limit or step-size floor
    mask_invalid_state = 8, // the plugin declared the state outside its domain
    mask_degenerate = 16,   // lambda1 == lambda2 (to rounding): eigenvectors undefined
    mask_unstable = 32,     // checked fixed steps: the step's error estimate failed even at the smallest sub-step
};

// Bits that make every value at a point unusable (all but mask_degenerate).
constexpr std::uint8_t mask_trajectory_bits =
    mask_left_bounds | mask_non_finite | mask_step_limit | mask_invalid_state | mask_unstable;

} // namespace geobarrier

#endif // GEOBARRIER_GRID_HPP
