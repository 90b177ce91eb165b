// Workload W, the paper's first example, as the bench's baseline programs integrate it: the forced Duffing
// oscillator x' = y, y' = x - x^3 + 0.08 cos t over [0, 8 pi] (paper eq. `duffing`, alpha = beta = 1, delta = 0),
// started on an n x n grid over [-1.8, 1.8] x [-1.2, 1.2] with both ends included. Point k = i * n + j has column
// j along x and row i along y, the order of geobarrier's fields.nc. Deliberately independent of the geobarrier
// library: these programs stand for what a user writes without it.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

namespace workload_w {

constexpr double forcing_amplitude = 0.08;
constexpr double t_start = 0.0;
constexpr double t_end = 8.0 * M_PI;
constexpr double x_min = -1.8, x_max = 1.8, y_min = -1.2, y_max = 1.2;
// The auxiliary grid's offset relative to the grid spacing along x (Farazmand & Haller 2012), the same absolute
// offset along x and y.
constexpr double relative_offset = 1e-4;

using State = std::array<double, 2>;

inline double forcing(double t) { return forcing_amplitude * std::cos(t); }

// The vector field of W.
inline void velocity(const State &s, State &dsdt, double t) {
    dsdt[0] = s[1];
    dsdt[1] = s[0] - s[0] * s[0] * s[0] + forcing(t);
}

// Initial state of grid point (row, column) of an n x n grid.
inline State grid_point(std::size_t n, std::size_t row, std::size_t column) {
    const double fx = static_cast<double>(column) / static_cast<double>(n - 1);
    const double fy = static_cast<double>(row) / static_cast<double>(n - 1);
    return {x_min + (x_max - x_min) * fx, y_min + (y_max - y_min) * fy};
}

inline double auxiliary_offset(std::size_t n) { return relative_offset * (x_max - x_min) / static_cast<double>(n - 1); }

// FTLE = log(lambda_max(C)) / (2 |T|) with C = DF^T DF (paper eq. `cg`), from DF = [[a, b], [c, d]].
inline double ftle(double a, double b, double c, double d) {
    const double c11 = a * a + c * c, c12 = a * b + c * d, c22 = b * b + d * d;
    const double half_trace = 0.5 * (c11 + c22);
    const double half_gap = std::hypot(0.5 * (c11 - c22), c12);
    return std::log(half_trace + half_gap) / (2.0 * std::fabs(t_end - t_start));
}

// The grid size from the command line: at least 2 points per direction.
inline std::size_t parse_grid_size(const char *text) {
    const long n = std::strtol(text, nullptr, 10);
    if (n < 2 || n > 100000)
        throw std::invalid_argument(std::string("N must be an integer in [2, 100000], got ") + text);
    return static_cast<std::size_t>(n);
}

inline void write_doubles(const std::string &path, const std::vector<double> &values) {
    std::FILE *file = std::fopen(path.c_str(), "wb");
    if (!file) throw std::runtime_error("cannot write " + path);
    const std::size_t written = std::fwrite(values.data(), sizeof(double), values.size(), file);
    if (std::fclose(file) != 0 || written != values.size()) throw std::runtime_error("cannot write " + path);
}

} // namespace workload_w
