// Repeated runs on a shared machine: other work only ever adds time, so the least of a configuration's runs is the
// estimate of its own cost, and runs of the variants a section compares are interleaved (one of each, then again) so
// that a change of load hits them alike. Bench::run keeps the least-wall run of one configuration; the sections that
// interleave (frames, equations) keep their least times here; the median and the range describe per-run ratios.
#pragma once

#include "fields.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace geobarrier::bench {

// The least of the time kept so far and `t`; NaN (nothing kept yet) gives way to `t`.
inline double least(double kept, double t) { return std::isnan(kept) ? t : std::min(kept, t); }

// The least wall and user CPU seconds over repeated runs of one variant.
struct LeastTimes {
    double wall = nan_value, user = nan_value;
    void keep(double w, double u) { wall = least(wall, w), user = least(user, u); }
};

// The median of per-run values (the mean of the middle two for an even count); NaN for none.
inline double median(std::vector<double> values) {
    if (values.empty()) return nan_value;
    std::sort(values.begin(), values.end());
    const std::size_t n = values.size();
    return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

} // namespace geobarrier::bench
