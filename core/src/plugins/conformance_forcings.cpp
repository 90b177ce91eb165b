// The conformance checks of a forcing plugin (conformance.hpp): a composite forcing's terms, batch against one
// time, untouched padding, determinism and finite values on the sample times.
#include "plugins/conformance_internal.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace geobarrier::detail::conformance {

namespace {

// A composite forcing is checked through its combine() on smooth, distinct synthetic terms (two when it takes
// two): the core, not the plugin, evaluates real terms, so these checks need no other plugin.
std::size_t synthetic_term_count(const PluginInfo &info) {
    return std::min<std::size_t>(info.max_terms, std::max<std::size_t>(info.min_terms, 2));
}
double synthetic_term(std::size_t j, double t) {
    const double jj = static_cast<double>(j);
    return (1.0 + 0.5 * jj) * std::sin(0.7 * (jj + 1.0) * t + 0.3 * jj);
}

std::vector<double> evaluate(const Forcing &forcing, const std::vector<double> &t, std::size_t n) {
    std::vector<double> f(t.size(), output_sentinel);
    if (forcing.info().composite()) {
        // Rows of ld = n + 3 with NaN padding: a plugin must read term j of time k at j * ld + k only.
        const std::size_t count = synthetic_term_count(forcing.info()), ld = n + 3;
        std::vector<double> terms(count * ld, std::numeric_limits<double>::quiet_NaN());
        for (std::size_t j = 0; j < count; ++j)
            for (std::size_t k = 0; k < n; ++k) terms[j * ld + k] = synthetic_term(j, t[k]);
        forcing.combine(n, t.data(), count, ld, terms.data(), f.data());
    } else {
        forcing.evaluate(n, t.data(), f.data());
    }
    return f;
}

} // namespace

void check_forcing(const PluginHandle &handle, const ParamValues &values, const ConformanceOptions &o,
                   std::vector<ConformanceCheck> &out) {
    const Forcing a(handle, values), b(handle, values);
    Random rng(o.seed);
    const std::size_t n = o.lanes, ld = std::max(o.ld, o.lanes);
    std::vector<double> t(ld, std::numeric_limits<double>::quiet_NaN());
    for (std::size_t k = 0; k < n; ++k) t[k] = rng.uniform(o.t_min, o.t_max);
    if (a.info().composite())
        out.push_back(guarded("composite_terms", [&] {
            // Each term must matter somewhere: shifting term j by 1 at every time changes some value.
            const std::size_t count = synthetic_term_count(a.info()), row = n + 3;
            std::vector<double> terms(count * row, 0.0), base(ld, output_sentinel), shifted(ld, output_sentinel);
            for (std::size_t j = 0; j < count; ++j)
                for (std::size_t k = 0; k < n; ++k) terms[j * row + k] = synthetic_term(j, t[k]);
            a.combine(n, t.data(), count, row, terms.data(), base.data());
            for (std::size_t j = 0; j < count; ++j) {
                std::vector<double> moved = terms;
                for (std::size_t k = 0; k < n; ++k) moved[j * row + k] += 1.0;
                a.combine(n, t.data(), count, row, moved.data(), shifted.data());
                bool changed = false;
                for (std::size_t k = 0; k < n; ++k) changed = changed || !same_bits(base[k], shifted[k]);
                if (!changed)
                    return fail("composite_terms", "the value does not depend on term " + std::to_string(j) +
                                                       " at any of " + std::to_string(n) + " times");
            }
            return pass("composite_terms", "checked through combine() on " + std::to_string(count) +
                                               " synthetic term(s), each of which matters (declares " +
                                               std::to_string(a.info().min_terms) + " to " +
                                               std::to_string(a.info().max_terms) + ")");
        }));

    out.push_back(guarded("batch_equals_scalar", [&] {
        const std::vector<double> batch = evaluate(a, t, n);
        for (std::size_t k = 0; k < n; ++k) {
            const std::vector<double> single = evaluate(a, {t[k]}, 1);
            if (!close(batch[k], single[0], o.batch_rtol))
                return fail("batch_equals_scalar", "t = " + num(t[k]) + ": " + num(batch[k]) + " in a batch of " +
                                                       std::to_string(n) + ", " + num(single[0]) + " alone");
        }
        return pass("batch_equals_scalar",
                    std::to_string(n) + " values agree (relative tolerance " + short_num(o.batch_rtol) + ")");
    }));
    out.push_back(guarded("lanes_untouched", [&] {
        const std::vector<double> batch = evaluate(a, t, n);
        for (std::size_t k = n; k < ld; ++k)
            if (!same_bits(batch[k], output_sentinel))
                return fail("lanes_untouched",
                            "wrote f[" + std::to_string(k) + "] past the n = " + std::to_string(n) + " times");
        return pass("lanes_untouched", "only the n requested values are written");
    }));
    out.push_back(guarded("determinism", [&] {
        const std::vector<double> first = evaluate(a, t, n), again = evaluate(a, t, n), other = evaluate(b, t, n);
        for (std::size_t k = 0; k < n; ++k) {
            if (!same_bits(first[k], again[k]))
                return fail("determinism", "t = " + num(t[k]) + ": " + num(first[k]) + " then " + num(again[k]) +
                                               " from one instance");
            if (!same_bits(first[k], other[k]))
                return fail("determinism", "t = " + num(t[k]) + ": " + num(first[k]) + " and " + num(other[k]) +
                                               " from two instances with the same parameters");
        }
        return pass("determinism", "bit-identical across calls and across two instances");
    }));
    out.push_back(guarded("finite_on_sample_times", [&] {
        const std::size_t m = o.samples + 2;
        std::vector<double> times(m);
        for (std::size_t k = 0; k < m; ++k)
            times[k] = k + 1 == m ? o.t_max
                                  : o.t_min + (o.t_max - o.t_min) * static_cast<double>(k) / static_cast<double>(m - 1);
        const std::vector<double> f = evaluate(a, times, m);
        for (std::size_t k = 0; k < m; ++k)
            if (!std::isfinite(f[k])) return fail("finite_on_sample_times", "f(" + num(times[k]) + ") = " + num(f[k]));
        return pass("finite_on_sample_times",
                    std::to_string(m) + " times in [" + num(o.t_min) + ", " + num(o.t_max) + "]: all finite");
    }));
}

} // namespace geobarrier::detail::conformance
