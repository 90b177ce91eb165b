// The corners of grid cells for many lanes at once, for fields that hold two values per grid point interleaved (a
// line field's vectors, the hyperbolic extractor's d_g and log lambda1): the loads shared by LineField::evaluate_lanes
// on builds without AVX-512 and sample_interleaved_along on builds with AVX.
#ifndef GEOBARRIER_CELL_CORNERS_HPP
#define GEOBARRIER_CELL_CORNERS_HPP

#include <cstddef>

#if defined(__AVX__)
#include <immintrin.h>
#endif

namespace geobarrier::detail {

// A block of lanes' cells and their corners, for fields that hold two values (a, b) per grid point, interleaved. The
// caller locates each lane's cell (first: the index of a at its lower-left corner; u, w: the lane's local
// coordinates; inside: whether it lies in the box), then load() copies the corners so that the arithmetic can run
// vectorised over the block: corner[q][k] = values[first[k] + q] and corner[4 + q][k] = values[first[k] + row + q],
// q = 0 .. 3: a and b at the cell's left corner, then at its right one, in its lower row and then in its upper row
// (`row` values further on).
//
// Without AVX-512 (and with it, in the sampler's loop) the compiler does not gather the lanes' scattered corners: it
// assembled every corner value element by element. With AVX, each row's four values of four lanes are four contiguous
// loads, transposed in registers (W on an AVX2 build: the strainline stage took ~16% less time); the values are the
// same, so every result is the same bit for bit.
struct CornerBlock {
    // Lanes per block: the tensor-line integrator's lane count, so that one of its stages is one block.
    static constexpr std::size_t size = 32;
    alignas(64) double corner[8][size];
    alignas(64) double u[size], w[size];
    std::ptrdiff_t first[size];
    bool inside[size];

    // The corners of lanes 0 .. m - 1 (m <= size), whose first[] are filled in.
    void load(const double *values, std::ptrdiff_t row, std::size_t m) {
#if defined(__AVX__)
        for (std::size_t k = m; k < (m + 3) / 4 * 4; ++k) first[k] = 0; // lanes read four at a time
        for (std::size_t k = 0; k < m; k += 4)
            for (std::size_t r = 0; r < 2; ++r) {
                const double *at = values + (r ? row : 0);
                const __m256d l0 = _mm256_loadu_pd(at + first[k]), l1 = _mm256_loadu_pd(at + first[k + 1]),
                              l2 = _mm256_loadu_pd(at + first[k + 2]), l3 = _mm256_loadu_pd(at + first[k + 3]);
                // (l0[0] l1[0] l0[2] l1[2]), (l0[1] l1[1] l0[3] l1[3]), the same for lanes 2 and 3; then their halves.
                const __m256d even01 = _mm256_unpacklo_pd(l0, l1), odd01 = _mm256_unpackhi_pd(l0, l1);
                const __m256d even23 = _mm256_unpacklo_pd(l2, l3), odd23 = _mm256_unpackhi_pd(l2, l3);
                _mm256_store_pd(corner[4 * r] + k, _mm256_permute2f128_pd(even01, even23, 0x20));
                _mm256_store_pd(corner[4 * r + 1] + k, _mm256_permute2f128_pd(odd01, odd23, 0x20));
                _mm256_store_pd(corner[4 * r + 2] + k, _mm256_permute2f128_pd(even01, even23, 0x31));
                _mm256_store_pd(corner[4 * r + 3] + k, _mm256_permute2f128_pd(odd01, odd23, 0x31));
            }
#else
        for (std::size_t k = 0; k < m; ++k)
            for (std::size_t q = 0; q < 4; ++q) {
                corner[q][k] = values[first[k] + static_cast<std::ptrdiff_t>(q)];
                corner[4 + q][k] = values[first[k] + row + static_cast<std::ptrdiff_t>(q)];
            }
#endif
    }
};

} // namespace geobarrier::detail

#endif // GEOBARRIER_CELL_CORNERS_HPP
