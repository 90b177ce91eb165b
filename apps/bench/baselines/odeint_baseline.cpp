// The naive C++ baseline of the bench: the FTLE of workload W as a user would write it with Boost.Odeint and no
// geobarrier. Every trajectory is integrated on its own with the adaptive Dormand-Prince 5(4) stepper at the paper's
// tolerances (rtol 1e-6, atol 1e-4), OpenMP threads over the trajectories; DF comes from centred differences over
// four auxiliary trajectories at +-d along x and y around each grid point (d = 1e-4 dx), as the paper does.
//   usage: odeint_baseline N aux OUTDIR [RTOL ATOL]
// Writes OUTDIR/odeint_aux_N<N>_ftle.bin (N*N doubles, row-major, rows along y) and prints one JSON line with the
// integration time, the right-hand-side evaluations over all trajectories and the thread count.
#include "workload_w.hpp"

#include <boost/numeric/odeint.hpp>
#include <omp.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

namespace {

using workload_w::State;

// End states of the four auxiliary trajectories around every grid point: neighbour q of point k at 4 * k + q,
// q = 0..3 for +dx, -dx, +dy, -dy.
std::vector<State> integrate_auxiliary_grid(std::size_t n, double rtol, double atol, long long &evaluations) {
    namespace odeint = boost::numeric::odeint;
    const std::size_t points = n * n;
    const double d = workload_w::auxiliary_offset(n);
    const double shift[4][2] = {{d, 0.0}, {-d, 0.0}, {0.0, d}, {0.0, -d}};
    std::vector<State> ends(4 * points);
    long long total = 0;
#pragma omp parallel for schedule(dynamic, 32) reduction(+ : total)
    for (long long job = 0; job < static_cast<long long>(4 * points); ++job) {
        const std::size_t k = static_cast<std::size_t>(job) / 4, q = static_cast<std::size_t>(job) % 4;
        State s = workload_w::grid_point(n, k / n, k % n);
        s[0] += shift[q][0];
        s[1] += shift[q][1];
        long long calls = 0;
        auto rhs = [&calls](const State &x, State &dxdt, double t) {
            ++calls;
            workload_w::velocity(x, dxdt, t);
        };
        auto stepper = odeint::make_controlled(atol, rtol, odeint::runge_kutta_dopri5<State>());
        odeint::integrate_adaptive(stepper, rhs, s, workload_w::t_start, workload_w::t_end, 0.01);
        ends[static_cast<std::size_t>(job)] = s;
        total += calls;
    }
    evaluations = total;
    return ends;
}

std::vector<double> ftle_from_auxiliary_grid(std::size_t n, const std::vector<State> &ends) {
    const double two_d = 2.0 * workload_w::auxiliary_offset(n);
    std::vector<double> ftle(n * n);
    for (std::size_t k = 0; k < ftle.size(); ++k) {
        const State &east = ends[4 * k], &west = ends[4 * k + 1], &north = ends[4 * k + 2], &south = ends[4 * k + 3];
        ftle[k] = workload_w::ftle((east[0] - west[0]) / two_d, (north[0] - south[0]) / two_d,
                                   (east[1] - west[1]) / two_d, (north[1] - south[1]) / two_d);
    }
    return ftle;
}

} // namespace

int main(int argc, char **argv) {
    if (argc != 4 && argc != 6) {
        std::fprintf(stderr, "usage: odeint_baseline N aux OUTDIR [RTOL ATOL]\n");
        return 2;
    }
    try {
        const std::size_t n = workload_w::parse_grid_size(argv[1]);
        if (std::string(argv[2]) != "aux") throw std::invalid_argument("the only gradient method is 'aux'");
        const std::string out = argv[3];
        const double rtol = argc == 6 ? std::strtod(argv[4], nullptr) : 1e-6;
        const double atol = argc == 6 ? std::strtod(argv[5], nullptr) : 1e-4;
        long long evaluations = 0;
        const auto start = std::chrono::steady_clock::now();
        const std::vector<State> ends = integrate_auxiliary_grid(n, rtol, atol, evaluations);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        workload_w::write_doubles(out + "/odeint_aux_N" + std::to_string(n) + "_ftle.bin",
                                  ftle_from_auxiliary_grid(n, ends));
        std::printf("{\"program\": \"odeint_baseline\", \"N\": %zu, \"rtol\": %g, \"atol\": %g, \"threads\": %d, "
                    "\"integrate_seconds\": %.4f, \"traj_rhs_evals\": %lld}\n",
                    n, rtol, atol, omp_get_max_threads(), seconds, evaluations);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "odeint_baseline: %s\n", e.what());
        return 2;
    }
    return 0;
}
