// An independent reference for the paper's first example (forced undamped
// Duffing, x' = y, y' = x - x^3 + eps cos t): Boost.Odeint rkf78 at 1e-12 on
// the state plus the variational equations, one trajectory at a time, as
// apps/bench/baselines/exact_reference.cpp does. Shares no code with the engine.
#ifndef GEOBARRIER_TEST_REFERENCE_FTLE_HPP
#define GEOBARRIER_TEST_REFERENCE_FTLE_HPP

#include <geobarrier/experiment.hpp>

#include <boost/numeric/odeint.hpp>
#include <doctest/doctest.h>
#include <netcdf.h>
#include <test_support.hpp>

#include <array>
#include <cmath>
#include <random>

namespace geobarrier::test {

inline double reference_duffing_ftle(double x, double y, double t0, double t1, double eps) {
    using state = std::array<double, 6>;
    state s = {x, y, 1, 0, 0, 1};
    auto rhs = [eps](const state &u, state &d, double t) {
        d[0] = u[1];
        d[1] = u[0] - u[0] * u[0] * u[0] + eps * std::cos(t);
        const double a = 1.0 - 3.0 * u[0] * u[0];
        d[2] = u[4];
        d[3] = u[5];
        d[4] = a * u[2];
        d[5] = a * u[3];
    };
    namespace odeint = boost::numeric::odeint;
    odeint::integrate_adaptive(odeint::make_controlled(1e-12, 1e-12, odeint::runge_kutta_fehlberg78<state>()), rhs, s,
                               t0, t1, (t1 > t0 ? 1e-3 : -1e-3));
    const double c11 = s[2] * s[2] + s[4] * s[4], c12 = s[2] * s[3] + s[4] * s[5], c22 = s[3] * s[3] + s[5] * s[5];
    const double l2 = 0.5 * (c11 + c22) + std::sqrt(0.25 * (c11 - c22) * (c11 - c22) + c12 * c12);
    return std::log(l2) / (2 * std::abs(t1 - t0));
}

struct FtleError {
    double max = 0, mean = 0;
    std::size_t points = 0;
};

// Runs `experiment` (a Duffing + cosine experiment with product ftle) with
// `settings` merged in, and compares its FTLE with the reference at every grid
// point, or at `sample` random grid points when sample > 0.
inline FtleError ftle_error_against_reference(nlohmann::json experiment, const nlohmann::json &settings,
                                              std::size_t sample = 0) {
    for (const auto &item : settings.items()) experiment[item.key()] = item.value();
    experiment["plugin_paths"] = {plugin_dir().string()};
    experiment["products"] = {"ftle"};
    const ResolvedExperiment r = resolve_experiment(parse_experiment(experiment));
    const auto dir = std::filesystem::temp_directory_path() / ("geobarrier-reference-" + std::to_string(::getpid()));
    RunOptions options;
    options.output_dir = dir;
    options.quiet = true;
    run_experiment(r, options);
    const Grid &g = r.experiment.grid;
    std::vector<double> ftle(g.size());
    int nc = -1, var = -1;
    REQUIRE(nc_open((dir / "fields.nc").c_str(), NC_NOWRITE, &nc) == NC_NOERR);
    REQUIRE(nc_inq_varid(nc, "ftle", &var) == NC_NOERR);
    REQUIRE(nc_get_var_double(nc, var, ftle.data()) == NC_NOERR);
    nc_close(nc);
    std::filesystem::remove_all(dir);

    const double eps = experiment["forcing"]["params"]["amplitude"].get<double>();
    std::vector<std::size_t> points;
    if (sample == 0) {
        for (std::size_t k = 0; k < g.size(); ++k) points.push_back(k);
    } else {
        std::mt19937_64 rng(12345);
        std::uniform_int_distribution<std::size_t> pick(0, g.size() - 1);
        for (std::size_t n = 0; n < sample; ++n) points.push_back(pick(rng));
    }
    FtleError e;
    for (const std::size_t k : points) {
        const double ref = reference_duffing_ftle(g.x(k % g.nx), g.y(k / g.nx), r.experiment.t0, r.experiment.t1, eps);
        const double err = std::abs(ftle[k] - ref);
        e.max = std::max(e.max, err);
        e.mean += err;
    }
    e.points = points.size();
    e.mean /= static_cast<double>(points.size());
    MESSAGE("settings " << settings.dump() << ": FTLE error vs rkf78 1e-12 over " << e.points << " points: max "
                        << e.max << ", mean " << e.mean);
    return e;
}

} // namespace geobarrier::test

#endif // GEOBARRIER_TEST_REFERENCE_FTLE_HPP
