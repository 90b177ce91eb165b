// The exact FTLE field of workload W that the bench scores every run against: each grid point's trajectory and
// its deformation gradient DF from the variational equations DF' = Dv(x, t) DF, DF(t0) = I (no finite
// differences), integrated with Boost.Odeint's adaptive Runge-Kutta-Fehlberg 7(8) at abs = rel = 1e-12. At that
// tolerance the FTLE agrees with a tighter integration to round-off wherever the field is finite, so the errors the
// bench reports are those of the configurations it times.
//   usage: reference N OUTDIR [TOL]
// Writes OUTDIR/ref_N<N>_DF.bin (N*N x 4 doubles: DF11 DF12 DF21 DF22, rows of the grid along y) and
// OUTDIR/ref_N<N>_flowmap.bin (N*N x 2 doubles: the end states), and prints one JSON line.
#include "workload_w.hpp"

#include <boost/numeric/odeint.hpp>
#include <omp.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

namespace {

// State and deformation gradient together: x, y, then DF row by row.
using Extended = std::array<double, 6>;

// W's vector field and its variational equations; Dv = [[0, 1], [1 - 3 x^2, 0]].
void extended_velocity(const Extended &s, Extended &dsdt, double t) {
    const workload_w::State point{s[0], s[1]};
    workload_w::State v;
    workload_w::velocity(point, v, t);
    const double dv21 = 1.0 - 3.0 * s[0] * s[0];
    dsdt[0] = v[0];
    dsdt[1] = v[1];
    dsdt[2] = s[4]; // (Dv DF)_11 = DF_21
    dsdt[3] = s[5]; // (Dv DF)_12 = DF_22
    dsdt[4] = dv21 * s[2];
    dsdt[5] = dv21 * s[3];
}

} // namespace

int main(int argc, char **argv) {
    if (argc != 3 && argc != 4) {
        std::fprintf(stderr, "usage: reference N OUTDIR [TOL]\n");
        return 2;
    }
    try {
        namespace odeint = boost::numeric::odeint;
        const std::size_t n = workload_w::parse_grid_size(argv[1]);
        const std::string out = argv[2];
        const double tol = argc == 4 ? std::strtod(argv[3], nullptr) : 1e-12;
        const std::size_t points = n * n;
        std::vector<double> gradients(4 * points), ends(2 * points);
        long long total = 0;
        const auto start = std::chrono::steady_clock::now();
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : total)
        for (long long job = 0; job < static_cast<long long>(points); ++job) {
            const std::size_t k = static_cast<std::size_t>(job);
            const workload_w::State x0 = workload_w::grid_point(n, k / n, k % n);
            Extended s{x0[0], x0[1], 1.0, 0.0, 0.0, 1.0};
            long long calls = 0;
            auto rhs = [&calls](const Extended &x, Extended &dxdt, double t) {
                ++calls;
                extended_velocity(x, dxdt, t);
            };
            auto stepper = odeint::make_controlled(tol, tol, odeint::runge_kutta_fehlberg78<Extended>());
            odeint::integrate_adaptive(stepper, rhs, s, workload_w::t_start, workload_w::t_end, 1e-3);
            for (std::size_t c = 0; c < 4; ++c) gradients[4 * k + c] = s[2 + c];
            ends[2 * k] = s[0];
            ends[2 * k + 1] = s[1];
            total += calls;
        }
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        const std::string stem = out + "/ref_N" + std::to_string(n);
        workload_w::write_doubles(stem + "_DF.bin", gradients);
        workload_w::write_doubles(stem + "_flowmap.bin", ends);
        std::printf("{\"program\": \"reference\", \"N\": %zu, \"tol\": %g, \"threads\": %d, \"seconds\": %.3f, "
                    "\"rhs_evals\": %lld}\n",
                    n, tol, omp_get_max_threads(), seconds, total);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "reference: %s\n", e.what());
        return 2;
    }
    return 0;
}
