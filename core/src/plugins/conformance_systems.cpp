// The conformance checks of a system plugin (conformance.hpp): batch against one lane, untouched padding, the Jacobian
// against finite differences, the divergence against the trace, determinism, the forcing ignored when undeclared,
// finite values on the sample box, and the fused step against the core's stage-by-stage step.
#include "plugins/conformance_internal.hpp"
#include <geobarrier/errors.hpp>
#include <geobarrier/rk_tableaux.hpp>
#include <geobarrier/sdk.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace geobarrier::detail::conformance {

Box make_box(const ConformanceOptions &given, const PluginInfo &info) {
    const unsigned dim = info.dimension;
    // No box given: the system's documented domain, or [-2, 2] in every component.
    ConformanceOptions o = given;
    if (o.state_min.empty()) o.state_min = info.domain_min.empty() ? std::vector<double>{-2.0} : info.domain_min;
    if (o.state_max.empty()) o.state_max = info.domain_max.empty() ? std::vector<double>{2.0} : info.domain_max;
    auto expand = [dim](const std::vector<double> &v, const char *what) {
        if (v.size() == 1) return std::vector<double>(dim, v[0]);
        if (v.size() != dim)
            throw Error(std::string("conformance options: ") + what + " has " + std::to_string(v.size()) +
                        " values for a system of dimension " + std::to_string(dim) + " (give 1 or " +
                        std::to_string(dim) + ")");
        return v;
    };
    Box b{expand(o.state_min, "state_min"), expand(o.state_max, "state_max")};
    for (unsigned i = 0; i < dim; ++i)
        if (!(b.lo[i] < b.hi[i]) || !std::isfinite(b.lo[i]) || !std::isfinite(b.hi[i]))
            throw Error("conformance options: state box component " + std::to_string(i) + " [" + num(b.lo[i]) + ", " +
                        num(b.hi[i]) + "] is empty or not finite");
    return b;
}

namespace {

// A batch of n lanes in rows of ld: times, states (component i of lane k at x[i*ld+k]) and forcing values.
struct Sample {
    std::size_t n = 0, ld = 0;
    unsigned dim = 0;
    std::vector<double> t, x, f;
};

// The fixed, nonzero forcing values handed to a system during the checks.
double forcing_value(std::size_t k) { return 0.05 * static_cast<double>(1 + k % 5) * (k % 2 ? -1.0 : 1.0); }

Sample random_sample(Random &rng, const Box &box, const ConformanceOptions &o, unsigned dim, std::size_t n,
                     std::size_t ld) {
    Sample s;
    s.n = n;
    s.ld = ld;
    s.dim = dim;
    // Padding lanes hold NaN: a plugin must not let them leak into the lanes it was asked for.
    const double nan = std::numeric_limits<double>::quiet_NaN();
    s.t.assign(ld, nan);
    s.f.assign(ld, nan);
    s.x.assign(static_cast<std::size_t>(dim) * ld, nan);
    for (std::size_t k = 0; k < n; ++k) {
        s.t[k] = rng.uniform(o.t_min, o.t_max);
        s.f[k] = forcing_value(k);
        for (unsigned i = 0; i < dim; ++i) s.x[i * ld + k] = rng.uniform(box.lo[i], box.hi[i]);
    }
    return s;
}

Sample one_lane(const Sample &s, std::size_t k) {
    Sample o;
    o.n = o.ld = 1;
    o.dim = s.dim;
    o.t = {s.t[k]};
    o.f = {s.f[k]};
    for (unsigned i = 0; i < s.dim; ++i) o.x.push_back(s.x[i * s.ld + k]);
    return o;
}

enum class Quantity { rhs, jacobian, divergence };

const char *to_string(Quantity q) {
    switch (q) {
    case Quantity::rhs:
        return "rhs";
    case Quantity::jacobian:
        return "jacobian";
    case Quantity::divergence:
        return "divergence";
    }
    return "?";
}

std::size_t rows(Quantity q, unsigned dim) {
    switch (q) {
    case Quantity::rhs:
        return dim;
    case Quantity::jacobian:
        return static_cast<std::size_t>(dim) * dim;
    case Quantity::divergence:
        return 1;
    }
    return 0;
}

struct Output {
    std::vector<double> values; // row r of lane k at values[r*ld+k]
    std::vector<std::int32_t> status;
};

Output evaluate(const System &system, Quantity q, const Sample &s) {
    Output o;
    o.values.assign(rows(q, s.dim) * s.ld, output_sentinel);
    o.status.assign(s.ld, status_sentinel);
    switch (q) {
    case Quantity::rhs:
        system.rhs(s.n, s.ld, s.t.data(), s.x.data(), s.f.data(), o.values.data(), o.status.data());
        break;
    case Quantity::jacobian:
        system.jacobian(s.n, s.ld, s.t.data(), s.x.data(), s.f.data(), o.values.data(), o.status.data());
        break;
    case Quantity::divergence:
        system.divergence(s.n, s.ld, s.t.data(), s.x.data(), s.f.data(), o.values.data(), o.status.data());
        break;
    }
    return o;
}

std::vector<Quantity> quantities(const System &system) {
    std::vector<Quantity> qs{Quantity::rhs};
    if (system.has_jacobian()) qs.push_back(Quantity::jacobian);
    if (system.has_divergence()) qs.push_back(Quantity::divergence);
    return qs;
}

std::string lane_state(const Sample &s, std::size_t k) {
    std::string out = "t = " + num(s.t[k]) + ", x = (";
    for (unsigned i = 0; i < s.dim; ++i) out += (i ? ", " : "") + num(s.x[i * s.ld + k]);
    return out + ")";
}

ConformanceCheck check_system_batch(const System &system, const Sample &s, double rtol) {
    const std::string name = "batch_equals_scalar";
    std::size_t compared = 0;
    for (Quantity q : quantities(system)) {
        const Output batch = evaluate(system, q, s);
        for (std::size_t k = 0; k < s.n; ++k) {
            const Output single = evaluate(system, q, one_lane(s, k));
            if (single.status[0] != batch.status[k])
                return fail(name, std::string(to_string(q)) + " lane " + std::to_string(k) + " status " +
                                      std::to_string(batch.status[k]) + " in the batch, " +
                                      std::to_string(single.status[0]) + " alone (" + lane_state(s, k) + ")");
            for (std::size_t r = 0; r < rows(q, s.dim); ++r) {
                const double a = batch.values[r * s.ld + k], b = single.values[r];
                ++compared;
                if (!close(a, b, rtol))
                    return fail(name, std::string(to_string(q)) + " row " + std::to_string(r) + " of lane " +
                                          std::to_string(k) + ": " + num(a) + " in a batch of " + std::to_string(s.n) +
                                          " (ld " + std::to_string(s.ld) + "), " + num(b) + " alone (" +
                                          lane_state(s, k) + ")");
            }
        }
    }
    return pass(name, std::to_string(compared) + " values agree (n = " + std::to_string(s.n) +
                          ", ld = " + std::to_string(s.ld) + ", relative tolerance " + short_num(rtol) + ")");
}

// Entries past the n lanes (the ld - n padding of each row, and of lane_status) belong to the caller.
ConformanceCheck check_system_lanes_untouched(const System &system, const Sample &s) {
    const std::string name = "lanes_untouched";
    for (Quantity q : quantities(system)) {
        const Output o = evaluate(system, q, s);
        for (std::size_t k = s.n; k < s.ld; ++k) {
            if (o.status[k] != status_sentinel)
                return fail(name, std::string(to_string(q)) + " wrote lane_status[" + std::to_string(k) +
                                      "] past the n = " + std::to_string(s.n) + " lanes");
            for (std::size_t r = 0; r < rows(q, s.dim); ++r)
                if (!same_bits(o.values[r * s.ld + k], output_sentinel))
                    return fail(name, std::string(to_string(q)) + " wrote row " + std::to_string(r) + ", lane " +
                                          std::to_string(k) + " past the n = " + std::to_string(s.n) +
                                          " lanes (ld = " + std::to_string(s.ld) + ")");
        }
        for (std::size_t k = 0; k < s.n; ++k)
            if (o.status[k] == status_sentinel)
                return fail(name, std::string(to_string(q)) + " left lane_status[" + std::to_string(k) + "] unset");
    }
    return pass(name, "only the n lanes of each row are written");
}

ConformanceCheck check_jacobian(const System &system, const Sample &s, const Box &box, const ConformanceOptions &o) {
    const std::string name = "jacobian_vs_finite_differences";
    if (!system.has_jacobian())
        return skip(name, "skipped: no Jacobian, so flow maps take finite differences on an auxiliary grid (with the "
                          "SDK: make `field` a template over its number type, Real, and it derives the Jacobian; or "
                          "give field_jacobian)");
    const unsigned dim = s.dim;
    const Output jac = evaluate(system, Quantity::jacobian, s);
    // fd[(i*dim+j)*ld+k] = (v_i(x + h e_j) - v_i(x - h e_j)) / (2h), with the step actually taken.
    std::vector<double> fd(static_cast<std::size_t>(dim) * dim * s.ld, 0.0);
    for (unsigned j = 0; j < dim; ++j) {
        const double h = o.fd_step * (box.hi[j] - box.lo[j]);
        Sample plus = s, minus = s;
        for (std::size_t k = 0; k < s.n; ++k) {
            plus.x[j * s.ld + k] += h;
            minus.x[j * s.ld + k] -= h;
        }
        const Output vp = evaluate(system, Quantity::rhs, plus), vm = evaluate(system, Quantity::rhs, minus);
        for (std::size_t k = 0; k < s.n; ++k) {
            const double step = plus.x[j * s.ld + k] - minus.x[j * s.ld + k];
            for (unsigned i = 0; i < dim; ++i)
                fd[(i * dim + j) * s.ld + k] = (vp.values[i * s.ld + k] - vm.values[i * s.ld + k]) / step;
        }
    }
    double worst = 0.0;
    std::string worst_detail;
    for (std::size_t k = 0; k < s.n; ++k) {
        double scale = 0.0;
        for (std::size_t e = 0; e < static_cast<std::size_t>(dim) * dim; ++e)
            scale = std::max({scale, std::fabs(jac.values[e * s.ld + k]), std::fabs(fd[e * s.ld + k])});
        for (std::size_t e = 0; e < static_cast<std::size_t>(dim) * dim; ++e) {
            const double a = jac.values[e * s.ld + k], b = fd[e * s.ld + k];
            const double diff = std::fabs(a - b);
            const double rel = diff == 0.0 ? 0.0 : diff / scale;
            if (std::isnan(rel) || rel > worst) {
                worst = std::isnan(rel) ? std::numeric_limits<double>::infinity() : rel;
                worst_detail = "entry (" + std::to_string(e / dim) + ", " + std::to_string(e % dim) + ") of lane " +
                               std::to_string(k) + ": analytic " + num(a) + ", finite difference " + num(b) + " (" +
                               lane_state(s, k) + ")";
            }
        }
    }
    const std::string summary = "largest difference " + short_num(worst) +
                                " relative to the lane's largest entry (allowed " + short_num(o.jacobian_rtol) +
                                ", step " + short_num(o.fd_step) + " of the box width)";
    // A Jacobian the SDK derived from the field by automatic differentiation is checked like a hand-written one.
    const std::string source = system.info().jacobian_derived ? "derived by automatic differentiation; " : "";
    if (worst > o.jacobian_rtol) return fail(name, source + summary + "; at " + worst_detail);
    return pass(name, source + summary);
}

ConformanceCheck check_divergence(const System &system, const Sample &s, const ConformanceOptions &o) {
    const std::string name = "divergence_equals_trace";
    if (!system.has_divergence()) return skip(name, "skipped: no divergence");
    if (!system.has_jacobian()) return skip(name, "skipped: a divergence but no Jacobian to compare with");
    const Output jac = evaluate(system, Quantity::jacobian, s), div = evaluate(system, Quantity::divergence, s);
    double worst = 0.0;
    for (std::size_t k = 0; k < s.n; ++k) {
        double trace = 0.0, size = 0.0;
        for (unsigned i = 0; i < s.dim; ++i) {
            const double jii = jac.values[(i * s.dim + i) * s.ld + k];
            trace += jii;
            size += std::fabs(jii);
        }
        const double d = div.values[k];
        const double diff = std::fabs(d - trace);
        if (!(diff <= o.divergence_rtol * size))
            return fail(name, "lane " + std::to_string(k) + ": divergence " + num(d) + ", trace of the Jacobian " +
                                  num(trace) + " (allowed " + short_num(o.divergence_rtol) + " x sum |J_ii| = " +
                                  short_num(o.divergence_rtol * size) + "; " + lane_state(s, k) + ")");
        if (size > 0.0) worst = std::max(worst, diff / size);
    }
    return pass(name, "largest |div - trace| / sum |J_ii| = " + short_num(worst) + " (allowed " +
                          short_num(o.divergence_rtol) + ")");
}

ConformanceCheck check_system_determinism(const System &a, const System &b, const Sample &s) {
    const std::string name = "determinism";
    for (Quantity q : quantities(a)) {
        const Output first = evaluate(a, q, s), again = evaluate(a, q, s), other = evaluate(b, q, s);
        for (std::size_t i = 0; i < first.values.size(); ++i) {
            if (!same_bits(first.values[i], again.values[i]))
                return fail(name, std::string(to_string(q)) + " differs between two calls on one instance: " +
                                      num(first.values[i]) + " then " + num(again.values[i]));
            if (!same_bits(first.values[i], other.values[i]))
                return fail(name, std::string(to_string(q)) + " differs between two instances with the same " +
                                      "parameters: " + num(first.values[i]) + " and " + num(other.values[i]));
        }
    }
    return pass(name, "bit-identical across calls and across two instances");
}

ConformanceCheck check_forcing_ignored(const System &system, const Sample &s) {
    const std::string name = "forcing_ignored";
    if (system.uses_forcing()) return skip(name, "skipped: the system declares that it uses the forcing");
    Sample unforced = s;
    for (std::size_t k = 0; k < s.n; ++k) unforced.f[k] = 0.0;
    for (Quantity q : quantities(system)) {
        const Output a = evaluate(system, q, s), b = evaluate(system, q, unforced);
        for (std::size_t i = 0; i < a.values.size(); ++i)
            if (!same_bits(a.values[i], b.values[i]))
                return fail(name, std::string(to_string(q)) + " depends on the forcing value although the system " +
                                      "does not declare GB_SYSTEM_USES_FORCING");
    }
    return pass(name, "outputs do not depend on f, as declared");
}

ConformanceCheck check_system_finite(const System &system, Random &rng, const Box &box, const ConformanceOptions &o) {
    const std::string name = "finite_on_sample_box";
    const unsigned dim = static_cast<unsigned>(box.lo.size());
    // The corners (for dimension <= 16) and the centre of the box, then random states.
    const std::size_t corners = dim <= 16 ? (std::size_t{1} << dim) : 0;
    const std::size_t n = corners + 1 + o.samples;
    Sample s = random_sample(rng, box, o, dim, n, n);
    for (std::size_t c = 0; c < corners; ++c)
        for (unsigned i = 0; i < dim; ++i) s.x[i * n + c] = (c >> i) & 1u ? box.hi[i] : box.lo[i];
    for (unsigned i = 0; i < dim; ++i) s.x[i * n + corners] = 0.5 * (box.lo[i] + box.hi[i]);
    for (Quantity q : quantities(system)) {
        const Output out = evaluate(system, q, s);
        std::size_t bad = 0, first = n;
        for (std::size_t k = 0; k < n; ++k) {
            bool ok = out.status[k] == GB_OK;
            for (std::size_t r = 0; r < rows(q, dim); ++r) ok = ok && std::isfinite(out.values[r * n + k]);
            if (!ok) {
                ++bad;
                first = std::min(first, k);
            }
        }
        if (bad > 0)
            return fail(name, std::string(to_string(q)) + ": " + std::to_string(bad) + " of " + std::to_string(n) +
                                  " states give a non-finite value or an invalid-lane status, first at " +
                                  lane_state(s, first));
    }
    std::string box_text;
    for (unsigned i = 0; i < dim; ++i) box_text += (i ? " x [" : "[") + num(box.lo[i]) + ", " + num(box.hi[i]) + "]";
    return pass(name, std::to_string(n) + " states in " + box_text + ", t in [" + num(o.t_min) + ", " + num(o.t_max) +
                          "]: all finite and valid");
}

// One step of tableau Tab over the sample's lanes (all at the time of lane 0, step h), with the variational
// equations when `variational`: through the fused step (ABI 1.2 advance) and stage by stage through rhs() and
// jacobian() in the flow-map engine's arithmetic order. Returns "" when every output agrees to within rtol of its
// row's largest magnitude, "declined" when the plugin does not offer the method, else what differs.
template <class Tab>
std::string compare_advance(const System &system, const Sample &s, std::int32_t method, bool variational, double h,
                            double rtol, std::size_t &compared) {
    const std::size_t n = s.n, ld = s.ld, D = s.dim, C = variational ? D + D * D + 1 : D;
    const double t = s.t[0];
    std::vector<double> x(C * ld, std::numeric_limits<double>::quiet_NaN());
    for (std::size_t k = 0; k < n; ++k) {
        for (std::size_t i = 0; i < D; ++i) x[i * ld + k] = s.x[i * ld + k];
        if (!variational) continue;
        // A DF that is not the identity, so that the product Dv DF is exercised in full.
        for (std::size_t m = 0; m < D * D; ++m)
            x[(D + m) * ld + k] = (m % (D + 1) == 0 ? 1.0 : 0.0) + forcing_value(k + 3 * m);
        x[(D + D * D) * ld + k] = 0.3;
    }
    std::vector<double> forcing(Tab::stages), times(ld, t), f(ld, 0.0), jac(D * D * ld, 0.0), y(C * ld, 0.0);
    for (int i = 0; i < Tab::stages; ++i) forcing[i] = forcing_value(static_cast<std::size_t>(i) + 1);
    std::vector<std::int32_t> status(ld, GB_OK);
    // The reference: stage by stage, as BatchContext::evaluate and stage_state / new_state in flow_map.cpp.
    std::vector<double> kst(static_cast<std::size_t>(Tab::stages) * C * ld, 0.0);
    // x + h sum_j row_j k_j as the core's kernel forms it (row_step: a chain of mul_add from x).
    auto combine = [&](const detail::RkRow &row, double *out) {
        for (std::size_t q = 0; q < C * ld; ++q)
            out[q] = detail::row_step(row, h, x[q], [&](int stage) { return kst[stage * C * ld + q]; });
    };
    for (int I = 0; I < Tab::stages; ++I) {
        combine(Tab::a[I], y.data());
        std::fill(times.begin(), times.end(), t + Tab::c[I] * h);
        std::fill(f.begin(), f.end(), forcing[I]);
        double *k = kst.data() + static_cast<std::size_t>(I) * C * ld;
        system.rhs(n, ld, times.data(), y.data(), f.data(), k, status.data());
        if (!variational) continue;
        system.jacobian(n, ld, times.data(), y.data(), f.data(), jac.data(), status.data());
        for (std::size_t lane = 0; lane < n; ++lane) {
            auto J = [&](std::size_t i, std::size_t j) { return jac[(i * D + j) * ld + lane]; };
            auto F = [&](std::size_t i, std::size_t j) { return y[(D + i * D + j) * ld + lane]; };
            for (std::size_t i = 0; i < D; ++i)
                for (std::size_t j = 0; j < D; ++j) {
                    double sum = J(i, 0) * F(0, j); // DF' = Dv DF as the core's kernel sums it (mul_add)
                    for (std::size_t l = 1; l < D; ++l) sum = detail::mul_add(J(i, l), F(l, j), sum);
                    k[(D + i * D + j) * ld + lane] = sum;
                }
            double trace = J(0, 0);
            for (std::size_t i = 1; i < D; ++i) trace += J(i, i);
            k[(D + D * D) * ld + lane] = trace;
        }
    }
    std::vector<double> expected(C * ld, 0.0), got(C * ld, output_sentinel);
    combine(Tab::b, expected.data());
    gb_advance_request r{};
    r.method = method;
    r.variational = variational ? 1 : 0;
    r.n = n;
    r.ld = ld;
    r.t = t;
    r.h = h;
    r.forcing = forcing.data();
    r.x = x.data();
    r.x_out = got.data();
    if (variational) {
        r.df = x.data() + D * ld;
        r.log_det = x.data() + (D + D * D) * ld;
        r.df_out = got.data() + D * ld;
        r.log_det_out = got.data() + (D + D * D) * ld;
    }
    r.lane_status = status.data();
    if (!system.advance(r)) return "declined";
    for (std::size_t c = 0; c < C; ++c) {
        double scale = 0.0;
        for (std::size_t k = 0; k < n; ++k) scale = std::max(scale, std::fabs(expected[c * ld + k]));
        for (std::size_t k = 0; k < n; ++k) {
            const double a = got[c * ld + k], b = expected[c * ld + k];
            ++compared;
            if (!(std::fabs(a - b) <= rtol * scale))
                return std::string(Tab::name) + (variational ? " (variational)" : "") + " component " +
                       std::to_string(c) + " of lane " + std::to_string(k) + ": " + num(a) + " from advance(), " +
                       num(b) + " stage by stage (" + lane_state(s, k) + ", h = " + num(h) + ")";
        }
    }
    return "";
}

// The fused step (ABI 1.2 advance), where the plugin has one, against the core's own stage-by-stage step.
ConformanceCheck check_advance(const System &system, const Sample &s) {
    const std::string name = "advance_equals_stages";
    constexpr double h = 0.1, rtol = 1e-13; // the same arithmetic: only reassociation by the compiler may differ
    std::size_t compared = 0;
    std::string declined;
    for (const bool variational : {false, true}) {
        if (variational && !system.has_jacobian()) continue;
        for (const std::int32_t method : {std::int32_t{GB_ADVANCE_RK4}, std::int32_t{GB_ADVANCE_DOP853}}) {
            const std::string what =
                method == GB_ADVANCE_RK4
                    ? compare_advance<detail::Rk4Tableau>(system, s, method, variational, h, rtol, compared)
                    : compare_advance<detail::Dop853Tableau>(system, s, method, variational, h, rtol, compared);
            if (what == "declined")
                declined += std::string(declined.empty() ? "" : ", ") + (method == GB_ADVANCE_RK4 ? "rk4" : "dop853") +
                            (variational ? " variational" : "");
            else if (!what.empty())
                return fail(name, what);
        }
    }
    const gb_build_info &build = system.info().build;
    if (!declined.empty() && build.struct_size && build.tableau_revision != GB_ADVANCE_TABLEAU_REVISION)
        declined += " (compiled with fused-step numerics revision " + std::to_string(build.tableau_revision) +
                    ", the core's is " + std::to_string(GB_ADVANCE_TABLEAU_REVISION) + ": rebuild the plugin)";
    return pass(name, std::to_string(compared) + " values of rk4 and dop853 steps agree (relative tolerance " +
                          short_num(rtol) + " of each component's largest value)" +
                          (declined.empty() ? ""
                                            : "; declined: " + declined +
                                                  (declined.find("variational") != std::string::npos
                                                       ? " (the variational equations need a per-lane Jacobian: give "
                                                         "field_jacobian, or make `field` a template so that the SDK "
                                                         "derives it)"
                                                       : "")));
}

} // namespace

void check_system(const PluginHandle &handle, const ParamValues &values, const Box &box, const ConformanceOptions &o,
                  std::vector<ConformanceCheck> &out) {
    const System a(handle, values), b(handle, values);
    Random rng(o.seed);
    const Sample s = random_sample(rng, box, o, a.dimension(), o.lanes, std::max(o.ld, o.lanes));
    out.push_back(guarded("batch_equals_scalar", [&] { return check_system_batch(a, s, o.batch_rtol); }));
    out.push_back(guarded("lanes_untouched", [&] { return check_system_lanes_untouched(a, s); }));
    out.push_back(guarded("jacobian_vs_finite_differences", [&] { return check_jacobian(a, s, box, o); }));
    out.push_back(guarded("divergence_equals_trace", [&] { return check_divergence(a, s, o); }));
    out.push_back(guarded("determinism", [&] { return check_system_determinism(a, b, s); }));
    out.push_back(guarded("forcing_ignored", [&] { return check_forcing_ignored(a, s); }));
    out.push_back(guarded("finite_on_sample_box", [&] { return check_system_finite(a, rng, box, o); }));
    // A system without a fused step runs slower on the fixed-step methods: the row says so rather than vanishing.
    if (a.has_advance())
        out.push_back(guarded("advance_equals_stages", [&] { return check_advance(a, s); }));
    else
        out.push_back(skip("advance_equals_stages",
                           handle.info.abi_minor < 2
                               ? "no fused step: the plugin was built for ABI " +
                                     std::to_string(handle.info.abi_major) + "." +
                                     std::to_string(handle.info.abi_minor) + ", before the fused step (1.2)"
                               : "no fused step: the system gives no per-lane `field` (sdk.hpp); fixed-step flow maps "
                                 "take the slower stage-by-stage path"));
}

} // namespace geobarrier::detail::conformance
