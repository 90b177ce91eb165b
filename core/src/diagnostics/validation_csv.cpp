// The validation products' CSV tables (docs/experiment-format.md, "validation"): poincare.csv, tracers.csv,
// trajectories.csv, forcing.csv and stretching.csv, one row per point and time, doubles at full precision so that
// a table round-trips the numbers it holds.
#include <fmt/format.h>

#include <cmath>

#include "diagnostics/validation_internal.hpp"

namespace geobarrier::validation_detail {

// Non-finite values are written as empty fields.
std::string csv_number(double v) {
    if (!std::isfinite(v)) return "";
    return fmt::format("{:.17g}", v);
}

std::string poincare_csv(const Snapshots &iterates, const std::vector<std::string> &origin, double t_start,
                         double period, std::size_t iterations, std::size_t &rows) {
    std::string csv = "seed,origin,iteration,t,x,y\n";
    rows = 0;
    for (std::size_t s = 0; s < origin.size(); ++s)
        for (std::size_t k = 0; k <= iterations; ++k) {
            const double x = iterates.positions[k][2 * s], y = iterates.positions[k][2 * s + 1];
            if (!std::isfinite(x)) break; // masked from here on
            csv += fmt::format("{},{},{},{},{},{}\n", s, origin[s], k,
                               csv_number(t_start + static_cast<double>(k) * period), csv_number(x), csv_number(y));
            ++rows;
        }
    return csv;
}

std::string tracer_csv_rows(std::size_t cloud, const Snapshots &snaps, const std::vector<double> &times,
                            double release) {
    std::string csv;
    const std::size_t n = snaps.positions.empty() ? 0 : snaps.positions[0].size() / 2;
    for (std::size_t k = 0; k < times.size(); ++k) {
        if (k > 0 && same_time(times[k], release)) continue;
        for (std::size_t p = 0; p < n; ++p)
            if (std::isfinite(snaps.positions[k][2 * p]))
                csv += fmt::format("{},{},{},{},{}\n", cloud, p, csv_number(times[k]),
                                   csv_number(snaps.positions[k][2 * p]), csv_number(snaps.positions[k][2 * p + 1]));
    }
    return csv;
}

std::string trajectories_csv(const Snapshots &snaps, const std::vector<double> &times, const std::vector<int> &inside) {
    std::string csv = "trajectory,sample,t,x,y,inside\n";
    for (std::size_t s = 0; s < inside.size(); ++s)
        for (std::size_t k = 0; k < times.size(); ++k) {
            const double x = snaps.positions[k][2 * s], y = snaps.positions[k][2 * s + 1];
            if (!std::isfinite(x)) break;
            csv += fmt::format("{},{},{},{},{},{}\n", s, k, csv_number(times[k]), csv_number(x), csv_number(y),
                               inside[s] < 0 ? std::string() : std::to_string(inside[s]));
        }
    return csv;
}

std::string forcing_csv(const std::vector<double> &times, const std::vector<double> &f) {
    std::string csv = "t,f\n";
    for (std::size_t k = 0; k < times.size(); ++k) csv += csv_number(times[k]) + "," + csv_number(f[k]) + "\n";
    return csv;
}

double area_change(const Barrier &barrier, const StretchingHistory &h, const StretchingSample &s) {
    return barrier.closed && h.area0 > 0.0 ? (s.area - h.area0) / h.area0 : nan_value;
}

std::string stretching_csv_rows(std::size_t b, const Barrier &barrier, const StretchingHistory &h) {
    std::string csv;
    for (const StretchingSample &s : h.samples)
        csv += fmt::format("{},{},{},{},{},{},{},{},{},{}\n", b, barrier.kind, barrier.closed ? 1 : 0, csv_number(s.t),
                           csv_number(s.length), csv_number(s.delta_l), csv_number(s.area),
                           csv_number(area_change(barrier, h, s)), s.points, s.converged ? 1 : 0);
    return csv;
}

} // namespace geobarrier::validation_detail
