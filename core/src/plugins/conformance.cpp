// The plugin conformance checks of <geobarrier/conformance.hpp>: each check calls the plugin through the same
// System/Forcing wrappers the runner uses and reports what it found, with the offending values.
#include "engine/tiles.hpp"
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/conformance.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/line_field.hpp>
#include <geobarrier/rk_tableaux.hpp>
#include <geobarrier/sdk.hpp>
#include <geobarrier/shear.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <sstream>

#include <unistd.h>

namespace geobarrier {

namespace {

// splitmix64: the checks draw the same states on every platform (std:: distributions are implementation-defined).
class Random {
  public:
    explicit Random(std::uint64_t seed) : m_state(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (m_state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    double uniform(double lo, double hi) { return lo + (hi - lo) * (static_cast<double>(next() >> 11) * 0x1.0p-53); }

  private:
    std::uint64_t m_state;
};

// Written into outputs before a call, to see which entries a plugin wrote.
constexpr double output_sentinel = -1.2345678901234567e301;
constexpr std::int32_t status_sentinel = 0x5A5A5A5A;

std::string num(double v) {
    std::ostringstream s;
    s.precision(17);
    s << v;
    return s.str();
}
std::string short_num(double v) {
    std::ostringstream s;
    s.precision(3);
    s << v;
    return s.str();
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Equal, both NaN, or within rtol of the larger magnitude.
bool close(double a, double b, double rtol) {
    if (a == b || (std::isnan(a) && std::isnan(b))) return true;
    return std::fabs(a - b) <= rtol * std::max(std::fabs(a), std::fabs(b));
}

ConformanceCheck pass(const std::string &name, std::string detail) { return {name, true, std::move(detail), false}; }
ConformanceCheck fail(const std::string &name, std::string detail) { return {name, false, std::move(detail), false}; }
ConformanceCheck skip(const std::string &name, std::string detail) { return {name, true, std::move(detail), true}; }
ConformanceCheck warn(const std::string &name, std::string detail) {
    return {name, true, std::move(detail), false, true};
}

// Runs one check; an exception from the plugin (a failed call) is a failed check, not a crash of the checker.
ConformanceCheck guarded(const std::string &name, const std::function<ConformanceCheck()> &body) {
    try {
        return body();
    } catch (const std::exception &e) {
        return fail(name, e.what());
    }
}

// ------------------------------------------------------------ ABI and schema

ConformanceCheck check_abi(const PluginInfo &info) {
    const std::string versions = "plugin ABI " + std::to_string(info.abi_major) + "." + std::to_string(info.abi_minor) +
                                 ", core ABI " + std::to_string(GB_ABI_VERSION_MAJOR) + "." +
                                 std::to_string(GB_ABI_VERSION_MINOR);
    if (info.abi_major != GB_ABI_VERSION_MAJOR) return fail("abi_version", versions);
    return pass("abi_version", versions);
}

ConformanceCheck check_schema(const PluginInfo &info) {
    static const std::regex plugin_name_rule("[a-z0-9][a-z0-9-]*");
    static const std::regex param_name_rule("[a-z0-9_]+");
    std::vector<std::string> problems;
    if (!std::regex_match(info.name, plugin_name_rule))
        problems.push_back("plugin name '" + info.name + "' does not match [a-z0-9][a-z0-9-]*");
    if (info.version.empty()) problems.push_back("no version");
    if (info.doc.empty()) problems.push_back("no doc line");
    if (info.doc.find('\n') != std::string::npos) problems.push_back("doc is more than one line");
    if (info.thread_safety != GB_THREAD_SAFE_CONCURRENT && info.thread_safety != GB_THREAD_SAFE_PER_INSTANCE)
        problems.push_back("unknown thread_safety " + std::to_string(info.thread_safety));
    if (info.kind == PluginKind::system && info.dimension == 0) problems.push_back("dimension 0");
    // State names and units (ABI 1.2): when declared, one non-empty, distinct name per component (axis labels
    // "name [unit]"); a unit may be "" (nondimensional). The loader copied `dimension` entries, NULL ones as "".
    if (info.kind == PluginKind::system && !info.state_names.empty()) {
        if (info.state_names.size() != info.dimension || info.state_units.size() != info.dimension)
            problems.push_back(std::to_string(info.state_names.size()) + " state names and " +
                               std::to_string(info.state_units.size()) + " units for dimension " +
                               std::to_string(info.dimension));
        std::set<std::string> names;
        for (std::size_t i = 0; i < info.state_names.size(); ++i) {
            if (info.state_names[i].empty())
                problems.push_back("state component " + std::to_string(i) + " has no name");
            else if (!names.insert(info.state_names[i]).second)
                problems.push_back("state name '" + info.state_names[i] + "' used twice");
        }
    }
    std::set<std::string> seen;
    for (const ParamSpec &p : info.params) {
        const std::string who = "parameter '" + p.name + "'";
        if (!std::regex_match(p.name, param_name_rule)) problems.push_back(who + ": name does not match [a-z0-9_]+");
        if (!seen.insert(p.name).second) problems.push_back(who + ": declared twice");
        if (p.doc.empty()) problems.push_back(who + ": no doc line");
        if (p.doc.find('\n') != std::string::npos) problems.push_back(who + ": doc is more than one line");
        switch (p.type) {
        case ParamType::real:
        case ParamType::integer:
            if (std::isnan(p.min_value) || std::isnan(p.max_value) || std::isnan(p.default_value))
                problems.push_back(who + ": NaN in default or range");
            else if (!(p.min_value <= p.default_value && p.default_value <= p.max_value))
                problems.push_back(who + ": default " + num(p.default_value) + " outside its range [" +
                                   num(p.min_value) + ", " + num(p.max_value) + "]");
            if (!std::isfinite(p.default_value)) problems.push_back(who + ": default is not finite");
            if (p.type == ParamType::integer && std::isfinite(p.default_value) &&
                p.default_value != std::floor(p.default_value))
                problems.push_back(who + ": integer default " + num(p.default_value) + " is not an integer");
            break;
        case ParamType::boolean:
            if (p.default_value != 0.0 && p.default_value != 1.0)
                problems.push_back(who + ": bool default " + num(p.default_value) + " is not 0 or 1");
            break;
        case ParamType::string:
            if (!p.choices.empty() &&
                std::find(p.choices.begin(), p.choices.end(), p.default_string) == p.choices.end())
                problems.push_back(who + ": default \"" + p.default_string + "\" is not one of its choices");
            break;
        }
    }
    if (problems.empty()) {
        std::string state;
        if (info.kind == PluginKind::system) {
            if (info.state_names.empty()) {
                state = "; no state names declared (axes read x, y)";
            } else {
                state = "; state";
                for (std::size_t i = 0; i < info.state_names.size(); ++i)
                    state += (i ? ", " : " ") + state_axis_label(info, i);
            }
        }
        return pass("schema", std::to_string(info.params.size()) + " parameter(s), all well-formed" + state);
    }
    std::string detail;
    for (const auto &p : problems) detail += (detail.empty() ? "" : "; ") + p;
    return fail("schema", detail);
}

// How the plugin was compiled against how the core was (the GB_EXTENSION_BUILD_INFO extension, ABI 1.3): a plugin
// built for narrower vectors or without FMA runs its fused step slower than the built-ins (2.4x seen), so say so.
ConformanceCheck check_code_generation(const PluginInfo &info) {
    const std::string name = "code_generation";
    const gb_build_info core = sdk::build_info(), &own = info.build;
    const auto describe = [](const gb_build_info &b) {
        return std::to_string(b.vector_bits) + "-bit vectors, " + (b.fma ? "FMA" : "no FMA");
    };
    if (own.struct_size == 0)
        return skip(name, "the plugin does not say how it was compiled (built for ABI " +
                              std::to_string(info.abi_major) + "." + std::to_string(info.abi_minor) +
                              " or without the SDK)");
    if (own.vector_bits < core.vector_bits || (core.fma && !own.fma))
        return warn(name, "compiled for " + describe(own) + ", the core for " + describe(core) +
                              ": its fused step runs slower than the built-in plugins' (build it with "
                              "geobarrier_add_plugin without PORTABLE, or add -march=native)");
    return pass(name, "compiled for " + describe(own) + ", as the core (" + describe(core) + ")");
}

// ------------------------------------------------------------ systems

// The box of states, one bound per component.
struct Box {
    std::vector<double> lo, hi;
};

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

// ------------------------------------------------------------ forcings

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

// ------------------------------------------------------------ extractors

// A synthetic flow with a known answer for extractors: the shear vortex x' = -w y, y' = w x, w = omega + shear r^2
// (systems/shear-vortex), whose flow map rotates each circle r = const rigidly by w(r) T. Its fields are exact: DF =
// R(theta) + R'(theta) x grad(theta)^T with theta = w(r) T, grad(theta) = 2 shear T x. Every circle about the centre is
// invariant, and a closed shearline (<e_theta, C e_theta> = 1), so every closed barrier an extractor reports must be
// such a circle; every barrier must lie on the grid, with finite metrics, the same on every run.
struct SyntheticVortex {
    double omega = 1.0, shear = 0.5;
    double t0 = 0.0, t1 = 4.0;
    Grid grid{-1.5, 1.5, -1.5, 1.5, 81, 81};

    double angle(double x, double y, double duration) const { return (omega + shear * (x * x + y * y)) * duration; }
    // The flow map from t_from to t_to at (x, y), and its gradient F11 F12 F21 F22 when dF is not null.
    void flow(double x, double y, double t_from, double t_to, double *xy, double *dF) const {
        const double duration = t_to - t_from, theta = angle(x, y, duration);
        const double c = std::cos(theta), s = std::sin(theta);
        xy[0] = c * x - s * y;
        xy[1] = s * x + c * y;
        if (!dF) return;
        const double gx = 2.0 * shear * duration * x, gy = 2.0 * shear * duration * y; // grad(theta)
        const double rx = -s * x - c * y, ry = c * x - s * y;                          // R'(theta) x
        dF[0] = c + rx * gx;
        dF[1] = -s + rx * gy;
        dF[2] = s + ry * gx;
        dF[3] = c + ry * gy;
    }
};

ConformanceCheck check_extractor_behaviour(const Extractor &extractor) {
    const std::string name = "synthetic_field";
    const SyntheticVortex v;
    const Grid &grid = v.grid;
    std::vector<double> dF(4 * grid.size()), flow_x(grid.size()), flow_y(grid.size());
    const std::vector<std::uint8_t> valid(grid.size(), 0);
    for (std::size_t i = 0; i < grid.ny; ++i)
        for (std::size_t j = 0; j < grid.nx; ++j) {
            const std::size_t k = i * grid.nx + j;
            double xy[2];
            v.flow(grid.x(j), grid.y(i), v.t0, v.t1, xy, &dF[4 * k]);
            flow_x[k] = xy[0];
            flow_y[k] = xy[1];
        }
    CauchyGreenField cg = cauchy_green_field(grid, dF, valid, std::fabs(v.t1 - v.t0));
    std::map<std::string, const std::vector<double> *> fields;
    for (const std::string &variable : cauchy_green_variables()) fields[variable] = &cauchy_green_member(cg, variable);
    fields["flow_x"] = &flow_x;
    fields["flow_y"] = &flow_y;
    std::vector<double> strain_deviation;
    ShearFields shear;
    std::vector<gb_field> inputs;
    for (const std::string &field : extractor.required_fields()) {
        if (field == "strain_deviation" && strain_deviation.empty()) {
            strain_deviation = strain_deviation_field(cg);
            fields[field] = &strain_deviation;
        } else if (field.rfind("shear_deviation", 0) == 0 && shear.deviation_plus.empty()) {
            shear = shear_fields(cg);
            fields["shear_deviation_plus"] = &shear.deviation_plus;
            fields["shear_deviation_minus"] = &shear.deviation_minus;
        }
        const auto found = fields.find(field);
        if (found == fields.end())
            return skip(name, "not checked: it requires field '" + field + "', which the synthetic flow lacks");
        inputs.push_back({field.c_str(), found->second->data()});
    }
    const char *const names[2] = {"x", "y"}, *const units[2] = {"length", "length"};
    const gb_extract_input input{
        grid.x_min,    grid.x_max, grid.y_min, grid.y_max,     grid.nx,
        grid.ny,       v.t0,       v.t1,       cg.mask.data(), static_cast<std::uint32_t>(inputs.size()),
        inputs.data(), nullptr,    0,          names,          units};
    // The extractor's own files, if any, go to a folder of its own that is removed afterwards.
    const std::filesystem::path folder =
        std::filesystem::temp_directory_path() /
        ("geobarrier-check-" + extractor.info().name + "-" + std::to_string(::getpid()));
    std::filesystem::create_directories(folder);
    struct RemoveFolder {
        std::filesystem::path path;
        ~RemoveFolder() {
            std::error_code ec;
            std::filesystem::remove_all(path, ec);
        }
    } remove_folder{folder};
    const std::string folder_text = folder.string();
    gb_extract_input in = input;
    in.output_dir = folder_text.c_str();
    ExtractServices services;
    services.advect = [&v](std::size_t n, const double *xy, double t_from, double t_to, double *xy_out, double *dF_out,
                           std::uint8_t *mask_out) {
        for (std::size_t k = 0; k < n; ++k) {
            v.flow(xy[2 * k], xy[2 * k + 1], t_from, t_to, xy_out + 2 * k, dF_out ? dF_out + 4 * k : nullptr);
            mask_out[k] = 0;
        }
    };
    const std::vector<Barrier> first = extractor.extract(in, services), again = extractor.extract(in, services);
    const double slack = grid.dx(); // a curve may end a grid cell outside, where it was interpolated
    std::size_t closed = 0;
    double worst_spread = 0.0;
    for (std::size_t b = 0; b < first.size(); ++b) {
        const Barrier &barrier = first[b];
        const std::string who = "barrier " + std::to_string(b) + " (" + barrier.kind + ")";
        if (barrier.kind != "hyperbolic" && barrier.kind != "elliptic" && barrier.kind != "parabolic")
            return fail(name, who + ": unknown kind");
        if (barrier.xy.size() < 4) return fail(name, who + ": fewer than 2 points");
        for (std::size_t p = 0; p + 1 < barrier.xy.size(); p += 2) {
            const double x = barrier.xy[p], y = barrier.xy[p + 1];
            if (!(x >= grid.x_min - slack && x <= grid.x_max + slack && y >= grid.y_min - slack &&
                  y <= grid.y_max + slack))
                return fail(name, who + ": point (" + num(x) + ", " + num(y) + ") is not on the grid");
        }
        for (const auto &metric : barrier.metrics)
            if (!std::isfinite(metric.second))
                return fail(name, who + ": metric '" + metric.first + "' = " + num(metric.second));
        if (!barrier.closed) continue;
        // The known answer: a closed barrier of the shear vortex is a circle about its centre.
        double r_min = HUGE_VAL, r_max = 0.0;
        for (std::size_t p = 0; p + 1 < barrier.xy.size(); p += 2) {
            const double r = std::hypot(barrier.xy[p], barrier.xy[p + 1]);
            r_min = std::min(r_min, r);
            r_max = std::max(r_max, r);
        }
        const double spread = (r_max - r_min) / (0.5 * (r_max + r_min));
        if (!(spread <= 0.02))
            return fail(name, who +
                                  ": closed, but not a circle about the centre as every closed barrier of this flow "
                                  "is: radius from " +
                                  num(r_min) + " to " + num(r_max));
        worst_spread = std::max(worst_spread, spread);
        ++closed;
    }
    if (first.size() != again.size())
        return fail(name, std::to_string(first.size()) + " barriers, then " + std::to_string(again.size()) +
                              " from the same input");
    for (std::size_t b = 0; b < first.size(); ++b)
        if (first[b].xy != again[b].xy || first[b].kind != again[b].kind)
            return fail(name, "barrier " + std::to_string(b) + " differs between two runs on the same input");
    return pass(name, "on the shear vortex (" + std::to_string(grid.nx) + " x " + std::to_string(grid.ny) +
                          " grid, exact fields and advection): " + std::to_string(first.size()) +
                          " barrier(s) on the grid with finite metrics, the same on a second run" +
                          (closed ? "; " + std::to_string(closed) +
                                        " closed, each a circle about the centre as the known answer says (radius "
                                        "spread " +
                                        short_num(worst_spread) + ")"
                                  : ""));
}

} // namespace

std::vector<ConformanceCheck> check_plugin(const PluginHandle &handle, const ConformanceOptions &options) {
    if (!handle.descriptor) throw Error("check_plugin: the plugin handle holds no descriptor");
    if (options.lanes == 0) throw Error("conformance options: lanes must be at least 1");
    if (!(options.t_min <= options.t_max))
        throw Error("conformance options: t_min " + num(options.t_min) + " is after t_max " + num(options.t_max));
    const PluginInfo &info = handle.info;
    std::vector<ConformanceCheck> out;
    out.push_back(check_abi(info));
    out.push_back(check_schema(info));
    if (!out[0].passed) return out; // nothing else may be read from a plugin of another ABI
    out.push_back(check_code_generation(info));
    const Box box = info.kind == PluginKind::system ? make_box(options, info) : Box{};

    std::unique_ptr<ParamValues> values;
    out.push_back(guarded("create", [&] {
        values = std::make_unique<ParamValues>(validate_params(info, options.params, "/params"));
        switch (info.kind) {
        case PluginKind::system:
            (void)System(handle, *values);
            break;
        case PluginKind::forcing:
            (void)Forcing(handle, *values);
            break;
        case PluginKind::extractor:
            (void)Extractor(handle, *values);
            break;
        }
        return pass("create",
                    "an instance was created from " +
                        std::string(options.params.empty() ? "the default parameters" : "the given parameters"));
    }));
    if (!out.back().passed) {
        // A parameter no default can stand for (a string, e.g. the data forcing's file, whose default is empty)
        // needs a value from the user: without one the plugin is skipped with the reason, not failed.
        std::string required;
        for (const ParamSpec &p : info.params)
            if (p.type == ParamType::string && p.default_string.empty() && p.choices.empty())
                required += (required.empty() ? "\"" : ", \"") + p.name + "\"";
        if (options.params.empty() && !required.empty())
            out.back() = skip("create", "not checked: parameter " + required +
                                            " has no default, so no instance can be made from the defaults (" +
                                            out.back().detail + "); give a value with --params, e.g. --params '{\"" +
                                            info.name + "\": {...}}', to run the remaining checks");
        return out;
    }

    try {
        switch (info.kind) {
        case PluginKind::system:
            check_system(handle, *values, box, options, out);
            break;
        case PluginKind::forcing:
            check_forcing(handle, *values, options, out);
            break;
        case PluginKind::extractor:
            out.push_back(
                guarded("synthetic_field", [&] { return check_extractor_behaviour(Extractor(handle, *values)); }));
            break;
        }
    } catch (const std::exception &e) {
        out.push_back(fail("instances", std::string("creating the instances under test failed: ") + e.what()));
    }
    return out;
}

std::string count_checks(const std::vector<ConformanceCheck> &checks) {
    std::size_t passed = 0, skipped = 0, failed = 0, warnings = 0;
    for (const auto &c : checks) {
        if (c.skipped)
            ++skipped;
        else if (c.passed)
            ++passed;
        else
            ++failed;
        warnings += c.passed && c.warning;
    }
    return std::to_string(passed) + " passed, " + std::to_string(skipped) + " skipped, " + std::to_string(failed) +
           " failed" + (warnings ? ", " + std::to_string(warnings) + (warnings == 1 ? " warning" : " warnings") : "");
}

bool all_passed(const std::vector<ConformanceCheck> &checks) {
    return std::all_of(checks.begin(), checks.end(), [](const ConformanceCheck &c) { return c.passed; });
}

std::string format_checks(const std::vector<ConformanceCheck> &checks) {
    std::size_t width = 0;
    for (const auto &c : checks) width = std::max(width, c.name.size());
    std::string out;
    for (const auto &c : checks) {
        out += c.skipped ? "SKIP  " : !c.passed ? "FAIL  " : c.warning ? "WARN  " : "PASS  ";
        out += c.name + std::string(width - c.name.size() + 2, ' ') + c.detail + "\n";
    }
    return out;
}

} // namespace geobarrier
