// Plugin SDK: turns a plain C++ class into the C tables of <geobarrier/abi.h>.
// A plugin includes only this header (and the ABI header it pulls in); it never
// links the core. Exceptions thrown by plugin code are caught here and become a
// GB_ERROR status with the exception's message: nothing throws across the ABI.
//
// A system plugin, in full: its vector field, one lane at a time.
//
//   struct Pendulum {
//       static constexpr const char *name = "pendulum", *version = "1.0.0",
//                                   *doc = "x' = y, y' = -sin x - c y + f(t)";
//       static constexpr unsigned dimension = 2;
//       static constexpr gb_param_spec params[] = {
//           geobarrier::sdk::real_param("damping", 0.0, 0.0, HUGE_VAL, "1/s", "linear damping")};
//       // (a plugin without parameters leaves `params` out)
//       explicit Pendulum(const geobarrier::sdk::Params &p) : c(p.real("damping")) {}
//       template <class Real> void field(double t, const Real *x, double f, Real *dxdt) const {
//           using std::sin;
//           dxdt[0] = x[1];
//           dxdt[1] = -sin(x[0]) - c * x[1] + f;
//       }
//       double c;
//   };
//   GEOBARRIER_PLUGINS(geobarrier::sdk::system<Pendulum>())
//
// From the one `field` the SDK derives everything the ABI asks of a system:
//   - the batched right-hand side (gb_system_vtable.rhs), a loop over lanes;
//   - the exact Jacobian dv_i/dx_j, by forward-mode automatic differentiation: a `field` that is a template over its
//     number type is also evaluated on dual numbers (<geobarrier/sdk_dual.hpp>; call math functions unqualified,
//     `using std::sin; sin(x)`, or as geobarrier::sdk::sin), and check-plugin compares it with finite differences.
//     Or give it by hand, one lane at a time (kept for generated code and for fields AD cannot see through):
//       void field_jacobian(double t, const double *x, double f, double *jac) const;  // jac[i * dimension + j]
//     A `field` taking plain `const double *` has no derived Jacobian: give field_jacobian then;
//   - the divergence, as the Jacobian's trace;
//   - a fused Runge-Kutta step (gb_system_vtable.advance): every stage of a lane, with the variational equations,
//     runs in registers, the lanes vectorised. Keep `field` short, branch-light and defined in the class.
// A member named field / field_jacobian with another signature, or not const, is a compile error saying what to
// write (never a silently slower plugin).
//
// Batched members written by hand stay possible, and take precedence over the derived ones (the adaptive steppers and
// the other engines call them; the fused step always uses the per-lane field):
//   void rhs(const geobarrier::sdk::Batch &b, double *dxdt) const;   // or (..., std::int32_t *lane_status) to mark
//                                                                    // lanes outside the model GB_LANE_INVALID
//   void jacobian(const Batch &, double *jac) const;                  // jac[(i*dimension+j)*ld+k]
//   void divergence(const Batch &, double *div) const;
// A system given only as rhs() has no fused step; check-plugin says so (advance_equals_stages, SKIP).
//
// A system may declare its documented domain (checked for finite values by check-plugin):
//   static constexpr double domain_min[] = {0.0, 0.0}, domain_max[] = {2.0, 1.0};
// and the names and units of its state components (ABI 1.2; pictures label their axes "name [unit]", "" for a
// nondimensional component):
//   static constexpr const char *state_names[] = {"theta", "omega"}, *state_units[] = {"rad", "rad/s"};
// and `static constexpr bool uses_forcing = false` when it ignores the forcing (checked).
//
// Forcings provide `void evaluate(std::size_t n, const double *t, double *f) const`.
// Composite forcings (ABI 1.1) combine other forcings, which the core evaluates for them:
// they declare `static constexpr unsigned min_terms = 1, max_terms = 1;` and provide
// `void combine(const geobarrier::sdk::Terms &terms, double *f) const` instead of evaluate.
// Extractors provide `static constexpr const char *required_fields[]` (NULL-terminated)
// and `void extract(const geobarrier::sdk::Host &, const gb_extract_input &) const`.
#ifndef GEOBARRIER_SDK_HPP
#define GEOBARRIER_SDK_HPP

#include <geobarrier/abi.h>
#include <geobarrier/rk_tableaux.hpp>
#include <geobarrier/sdk_dual.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

// The numerics revision the fused step is compiled with (abi.h, GB_ADVANCE_TABLEAU_REVISION). Overridable only so
// that a test can build a plugin with stale numerics and watch it decline.
#ifndef GEOBARRIER_SDK_TABLEAU_REVISION
#define GEOBARRIER_SDK_TABLEAU_REVISION GB_ADVANCE_TABLEAU_REVISION
#endif

namespace geobarrier::sdk {

// a * b + c, one fused instruction where the CPU has FMA (the build never fuses on its own): for a system's per-lane
// field, whose floating-point instructions bound the fused step's speed (rk_tableaux.hpp).
using geobarrier::detail::mul_add;

// ------------------------------------------------------------ parameters

constexpr gb_param_spec real_param(const char *name, double default_value, double min_value, double max_value,
                                   const char *unit, const char *doc) {
    return gb_param_spec{name, GB_PARAM_REAL, default_value, min_value, max_value, "", nullptr, unit, doc};
}
constexpr gb_param_spec integer_param(const char *name, double default_value, double min_value, double max_value,
                                      const char *doc) {
    return gb_param_spec{name, GB_PARAM_INTEGER, default_value, min_value, max_value, "", nullptr, "", doc};
}
constexpr gb_param_spec bool_param(const char *name, bool default_value, const char *doc) {
    return gb_param_spec{name, GB_PARAM_BOOL, default_value ? 1.0 : 0.0, 0.0, 1.0, "", nullptr, "", doc};
}
// `choices` is a '|'-separated list of allowed values, or nullptr for any string.
constexpr gb_param_spec string_param(const char *name, const char *default_value, const char *choices,
                                     const char *doc) {
    return gb_param_spec{name, GB_PARAM_STRING, 0.0, 0.0, 0.0, default_value, choices, "", doc};
}

// A string parameter holding a file path: the core resolves a relative path against the folder of the
// experiment file that names it (the unit "path" marks it).
constexpr gb_param_spec path_param(const char *name, const char *default_value, const char *doc) {
    return gb_param_spec{name, GB_PARAM_STRING, 0.0, 0.0, 0.0, default_value, nullptr, "path", doc};
}

// Read access by name to the validated values the core passes to a factory.
class Params {
  public:
    Params(const gb_param_spec *specs, std::uint32_t spec_count, const gb_param_values *values)
        : m_specs(specs), m_count(spec_count), m_values(values) {}

    double real(const char *name) const { return m_values->values[index(name)]; }
    long long integer(const char *name) const { return static_cast<long long>(m_values->values[index(name)]); }
    bool flag(const char *name) const { return m_values->values[index(name)] != 0.0; }
    std::string string(const char *name) const {
        const char *s = m_values->strings ? m_values->strings[index(name)] : nullptr;
        return s ? std::string(s) : std::string();
    }

  private:
    std::uint32_t index(const char *name) const {
        for (std::uint32_t i = 0; i < m_count && i < m_values->count; ++i)
            if (std::strcmp(m_specs[i].name, name) == 0) return i;
        throw std::invalid_argument(std::string("plugin asked for undeclared parameter '") + name + "'");
    }
    const gb_param_spec *m_specs;
    std::uint32_t m_count;
    const gb_param_values *m_values;
};

// One batch of lanes: component i of lane k is x[i * ld + k]; lane k has time t[k]
// and forcing value f[k].
struct Batch {
    std::size_t n;
    std::size_t ld;
    const double *t;
    const double *x;
    const double *f;
};

// The values of a composite forcing's terms at n times: term j at time t[k] is value(j, k) = values[j * ld + k].
struct Terms {
    std::size_t n;
    std::size_t count;
    std::size_t ld;
    const double *t;
    const double *values;
    double value(std::size_t j, std::size_t k) const { return values[j * ld + k]; }
};

namespace detail {
// The gb_host_info of the core that loaded this library (GB_PLUGIN_ENTRY_WITH_HOST_SYMBOL, ABI 1.3), or null when
// the core is older than 1.3. One per plugin library: plugins are built with hidden visibility.
inline const gb_host_info *loaded_by = nullptr;
} // namespace detail

// The plugin ABI version of the core that loaded this plugin, which is the version of every struct the core fills
// (requests, inputs, the host): from its gb_host_info; a core older than 1.3 sends none, so then 2 for a plugin that
// links the core library (the loader checks the core's C++ series, whose first release spoke 1.2) and 0 otherwise.
inline std::uint32_t host_abi_minor() {
    if (detail::loaded_by) return detail::loaded_by->abi_minor;
#ifdef GEOBARRIER_VERSION
    return 2;
#else
    return 0;
#endif
}

// The code generation of this plugin (gb_build_info, the GB_EXTENSION_BUILD_INFO extension): the widest vectors and
// whether mul_add is one instruction. check-plugin compares it with the core's.
constexpr gb_build_info build_info() {
    return gb_build_info {
        sizeof(gb_build_info), GEOBARRIER_SDK_TABLEAU_REVISION,
#if defined(__AVX512F__)
            512,
#elif defined(__AVX__)
            256,
#else
            128,
#endif
#if defined(__FMA__) || defined(__aarch64__)
            1
#else
            0
#endif
    };
}

// What an extractor may ask of the core while it runs.
class Host {
  public:
    explicit Host(const gb_host *host) : m_host(host) {}
    void info(const std::string &line) const { m_host->log(m_host->context, 1, line.c_str()); }
    void warn(const std::string &line) const { m_host->log(m_host->context, 2, line.c_str()); }
    // Returns true when the user asked to stop.
    bool progress(double fraction) const { return m_host->progress(m_host->context, fraction) != 0; }
    void add_barrier(const char *kind, bool closed, const std::vector<double> &xy,
                     const std::vector<std::pair<std::string, double>> &metrics) const {
        std::vector<const char *> names;
        std::vector<double> values;
        for (const auto &m : metrics) {
            names.push_back(m.first.c_str());
            values.push_back(m.second);
        }
        const gb_status s = m_host->add_barrier(m_host->context, kind, closed ? 1 : 0, xy.size() / 2, xy.data(),
                                                static_cast<std::uint32_t>(names.size()), names.data(), values.data());
        if (s != GB_OK) throw std::runtime_error("the core refused a barrier");
    }
    // Text and boolean attributes of the barrier reported last (ABI 1.1): values are JSON literals, e.g.
    // {"family", "\"+\""}, {"outermost", "true"}. Needs a core of ABI 1.1 or newer (host_abi_minor()): throws
    // otherwise, as it cannot tell.
    void set_barrier_attributes(const std::vector<std::pair<std::string, std::string>> &attributes) const {
        if (host_abi_minor() < 1)
            throw std::runtime_error("barrier attributes need a geobarrier core of plugin ABI 1.3 or newer (or a "
                                     "plugin that links the core library)");
        std::vector<const char *> names, values;
        for (const auto &a : attributes) {
            names.push_back(a.first.c_str());
            values.push_back(a.second.c_str());
        }
        if (m_host->set_barrier_attributes(m_host->context, static_cast<std::uint32_t>(names.size()), names.data(),
                                           values.data()) != GB_OK)
            throw std::runtime_error("the core refused barrier attributes (no barrier yet, or a value is not JSON)");
    }
    // Advects points (x, y interleaved) with the experiment's system and integrator; mask 0 = valid.
    // With `gradient`, dF receives F11 F12 F21 F22 per point.
    void advect(const std::vector<double> &xy, double t_from, double t_to, std::vector<double> &xy_out,
                std::vector<std::uint8_t> &mask, std::vector<double> *gradient = nullptr) const {
        const std::size_t n = xy.size() / 2;
        xy_out.assign(2 * n, 0.0);
        mask.assign(n, 0);
        if (gradient) gradient->assign(4 * n, 0.0);
        char text[512];
        text[0] = '\0';
        gb_message msg{text, sizeof text};
        if (m_host->advect(m_host->context, n, xy.data(), t_from, t_to, xy_out.data(),
                           gradient ? gradient->data() : nullptr, mask.data(), &msg) != GB_OK)
            throw std::runtime_error(std::string("advection failed: ") + text);
    }

  private:
    const gb_host *m_host;
};

// The axis label of state component i (0 or 1) for an extractor's pictures: "name [unit]", "name [–]" when the
// unit is "" (nondimensional) and "x" / "y" when the system declares no names. Reads gb_extract_input's ABI 1.2
// fields only when the host has them (host_abi_minor()); else "x" / "y".
inline std::string axis_label(const gb_extract_input &in, unsigned i) {
    if (host_abi_minor() < 2) return i == 0 ? "x" : "y";
    const char *name = in.state_names && in.state_names[i] && *in.state_names[i] ? in.state_names[i] : nullptr;
    const char *unit = in.state_units && in.state_units[i] ? in.state_units[i] : "";
    if (!name) return i == 0 ? "x" : "y";
    return std::string(name) + " [" + (*unit ? unit : "–") + "]";
}

namespace detail {

inline void write_message(gb_message *msg, const char *text) noexcept {
    if (!msg || !msg->text || msg->capacity == 0) return;
    std::strncpy(msg->text, text, msg->capacity - 1);
    msg->text[msg->capacity - 1] = '\0';
}

// Runs `body`, turning any exception into GB_ERROR and a message.
template <class Body> gb_status guarded(gb_message *msg, Body &&body) noexcept {
    try {
        body();
        return GB_OK;
    } catch (const std::exception &e) {
        write_message(msg, e.what());
    } catch (...) {
        write_message(msg, "unknown exception in plugin");
    }
    return GB_ERROR;
}

template <class T, class = void> struct has_jacobian : std::false_type {};
template <class T>
struct has_jacobian<T, std::void_t<decltype(std::declval<const T &>().jacobian(
                           std::declval<const Batch &>(), static_cast<double *>(nullptr)))>> : std::true_type {};

template <class T, class = void> struct has_divergence : std::false_type {};
template <class T>
struct has_divergence<T, std::void_t<decltype(std::declval<const T &>().divergence(
                             std::declval<const Batch &>(), static_cast<double *>(nullptr)))>> : std::true_type {};

template <class T, class = void> struct has_rhs : std::false_type {};
template <class T>
struct has_rhs<T, std::void_t<decltype(std::declval<const T &>().rhs(
                      std::declval<const Batch &>(), static_cast<double *>(nullptr)))>> : std::true_type {};

// A plugin may set lane_status itself by declaring rhs(const Batch&, double*, int32_t*).
template <class T, class = void> struct has_lane_status_rhs : std::false_type {};
template <class T>
struct has_lane_status_rhs<
    T, std::void_t<decltype(std::declval<const T &>().rhs(std::declval<const Batch &>(), static_cast<double *>(nullptr),
                                                          static_cast<std::int32_t *>(nullptr)))>> : std::true_type {};

template <class T, class = void> struct uses_forcing : std::true_type {};
template <class T> struct uses_forcing<T, std::void_t<decltype(T::uses_forcing)>> {
    static constexpr bool value = T::uses_forcing;
};

// A system's documented domain: both domain_min and domain_max, `dimension` values each.
template <class T, class = void> struct has_domain : std::false_type {};
template <class T>
struct has_domain<T, std::void_t<decltype(T::domain_min), decltype(T::domain_max)>> : std::true_type {};

template <class T> constexpr const double *domain_min() {
    if constexpr (has_domain<T>::value) {
        static_assert(sizeof(T::domain_min) == T::dimension * sizeof(double), "domain_min needs dimension values");
        return T::domain_min;
    } else {
        return nullptr;
    }
}
template <class T> constexpr const double *domain_max() {
    if constexpr (has_domain<T>::value) {
        static_assert(sizeof(T::domain_max) == T::dimension * sizeof(double), "domain_max needs dimension values");
        return T::domain_max;
    } else {
        return nullptr;
    }
}

// A system's state names and units (ABI 1.2): both state_names and state_units, `dimension` entries each.
template <class T, class = void> struct has_state_names : std::false_type {};
template <class T>
struct has_state_names<T, std::void_t<decltype(T::state_names), decltype(T::state_units)>> : std::true_type {};

template <class T> constexpr const char *const *state_names() {
    if constexpr (has_state_names<T>::value) {
        static_assert(sizeof(T::state_names) == T::dimension * sizeof(const char *),
                      "state_names needs dimension entries");
        return T::state_names;
    } else {
        return nullptr;
    }
}
template <class T> constexpr const char *const *state_units() {
    if constexpr (has_state_names<T>::value) {
        static_assert(sizeof(T::state_units) == T::dimension * sizeof(const char *),
                      "state_units needs dimension entries");
        return T::state_units;
    } else {
        return nullptr;
    }
}

// A composite forcing provides combine(const Terms &, double *).
template <class T, class = void> struct has_combine : std::false_type {};
template <class T>
struct has_combine<T, std::void_t<decltype(std::declval<const T &>().combine(
                          std::declval<const Terms &>(), static_cast<double *>(nullptr)))>> : std::true_type {};

// A plugin without parameters simply declares no `params` member.
template <class T, class = void> struct has_params : std::false_type {};
template <class T> struct has_params<T, std::void_t<decltype(T::params)>> : std::true_type {};

template <class T> constexpr std::uint32_t param_count() {
    if constexpr (has_params<T>::value)
        return sizeof(T::params) / sizeof(T::params[0]);
    else
        return 0;
}
template <class T> constexpr const gb_param_spec *param_specs() {
    if constexpr (has_params<T>::value)
        return T::params;
    else
        return nullptr;
}

template <class T> void *create(const gb_param_values *values, gb_message *msg) noexcept {
    T *made = nullptr;
    guarded(msg, [&] { made = new T(Params(param_specs<T>(), param_count<T>(), values)); });
    return made;
}
template <class T> void destroy(void *self) noexcept { delete static_cast<T *>(self); }

inline void clear_lanes(std::int32_t *lane_status, std::uint64_t n) {
    for (std::uint64_t k = 0; k < n; ++k) lane_status[k] = GB_OK;
}

// The per-lane vector field of the fused step (see the header comment).
template <class T, class = void> struct has_field : std::false_type {};
template <class T>
struct has_field<T, std::void_t<decltype(std::declval<const T &>().field(0.0, static_cast<const double *>(nullptr), 0.0,
                                                                         static_cast<double *>(nullptr)))>>
    : std::true_type {};
template <class T, class = void> struct has_field_jacobian : std::false_type {};
template <class T>
struct has_field_jacobian<T, std::void_t<decltype(std::declval<const T &>().field_jacobian(
                                 0.0, static_cast<const double *>(nullptr), 0.0, static_cast<double *>(nullptr)))>>
    : std::true_type {};

// A `field` the SDK can differentiate: a template over the number type (or an overload) taking dual numbers.
template <class T, class = void> struct has_dual_field : std::false_type {};
template <class T>
struct has_dual_field<
    T, std::void_t<decltype(std::declval<const T &>().field(0.0, static_cast<const Dual<T::dimension> *>(nullptr), 0.0,
                                                            static_cast<Dual<T::dimension> *>(nullptr)))>>
    : std::true_type {};

// A Jacobian one lane at a time: given (field_jacobian) or derived (a differentiable field).
template <class T> constexpr bool has_lane_jacobian = has_field_jacobian<T>::value || has_dual_field<T>::value;

// Whether T declares a member of this name at all, whatever its signature: in a class deriving from T and from a
// probe that has the member too, naming it is ambiguous exactly when T has one. With the has_* traits above this
// tells "no field" (fine) from "a field the SDK cannot call" (a compile error saying what to write).
#define GEOBARRIER_SDK_MEMBER_PROBE(member)                                                                            \
    struct probe_##member {                                                                                            \
        int member;                                                                                                    \
    };                                                                                                                 \
    template <class T> struct probed_##member : T, probe_##member {};                                                  \
    template <class T, class = void> struct declares_##member : std::true_type {};                                     \
    template <class T>                                                                                                 \
    struct declares_##member<T, std::void_t<decltype(&probed_##member<T>::member)>> : std::false_type {};
GEOBARRIER_SDK_MEMBER_PROBE(field)
GEOBARRIER_SDK_MEMBER_PROBE(field_jacobian)
GEOBARRIER_SDK_MEMBER_PROBE(rhs)
GEOBARRIER_SDK_MEMBER_PROBE(jacobian)
GEOBARRIER_SDK_MEMBER_PROBE(divergence)
#undef GEOBARRIER_SDK_MEMBER_PROBE

// The Jacobian of one lane, jac[i * D + j] = dv_i/dx_j: the plugin's field_jacobian, or the field on dual numbers
// seeded with the identity (forward-mode automatic differentiation; exact up to rounding).
template <class T>
GEOBARRIER_ALWAYS_INLINE void lane_jacobian(const T &sys, double t, const double *x, double f, double *jac) {
    if constexpr (has_field_jacobian<T>::value) {
        sys.field_jacobian(t, x, f, jac);
    } else {
        constexpr unsigned D = T::dimension;
        Dual<D> s[D], v[D];
#pragma GCC unroll 16
        for (unsigned i = 0; i < D; ++i) {
            s[i] = Dual<D>(x[i]);
            s[i].d[i] = 1.0;
        }
        sys.field(t, static_cast<const Dual<D> *>(s), f, v);
#pragma GCC unroll 16
        for (unsigned i = 0; i < D; ++i)
#pragma GCC unroll 16
            for (unsigned j = 0; j < D; ++j) jac[i * D + j] = v[i].d[j];
    }
}

// The batched members derived from the per-lane ones: gather a lane, call, scatter. Lanes are independent, so the
// loops vectorise like the fused step's (ivdep: the outputs never alias the inputs).
template <class T> struct LaneLoops {
    static constexpr unsigned D = T::dimension;
    template <class PerLane> static void run(const Batch &b, double *out, unsigned rows, PerLane per_lane) {
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC ivdep
#endif
        for (std::size_t k = 0; k < b.n; ++k) {
            double s[D], r[D * D];
#pragma GCC unroll 16
            for (unsigned i = 0; i < D; ++i) s[i] = b.x[i * b.ld + k];
            per_lane(b.t[k], s, b.f ? b.f[k] : 0.0, r);
#pragma GCC unroll 16
            for (unsigned i = 0; i < rows; ++i) out[i * b.ld + k] = r[i];
        }
    }
    static void rhs(const T &sys, const Batch &b, double *dxdt) {
        run(b, dxdt, D, [&](double t, const double *s, double f, double *r) { sys.field(t, s, f, r); });
    }
    static void jacobian(const T &sys, const Batch &b, double *jac) {
        run(b, jac, D * D, [&](double t, const double *s, double f, double *r) { lane_jacobian(sys, t, s, f, r); });
    }
    // The trace, summed as the fused step sums it.
    static void divergence(const T &sys, const Batch &b, double *div) {
        run(b, div, 1, [&](double t, const double *s, double f, double *r) {
            double J[D * D];
            lane_jacobian(sys, t, s, f, J);
            double trace = J[0];
#pragma GCC unroll 16
            for (unsigned i = 1; i < D; ++i) trace += J[i * D + i];
            r[0] = trace;
        });
    }
};

// What a system class declares, checked once with messages that say what to write.
template <class T> struct SystemShape {
    static constexpr bool field = has_field<T>::value;
    static constexpr bool batch_rhs = has_rhs<T>::value || has_lane_status_rhs<T>::value;
    static_assert(!declares_field<T>::value || field,
                  "geobarrier::sdk: this system's `field` has the wrong signature or is not const. Write "
                  "`template <class Real> void field(double t, const Real *x, double f, Real *dxdt) const` (the SDK "
                  "then derives the Jacobian) or `void field(double t, const double *x, double f, double *dxdt) "
                  "const`");
    static_assert(!declares_field_jacobian<T>::value || has_field_jacobian<T>::value,
                  "geobarrier::sdk: this system's `field_jacobian` has the wrong signature or is not const. Write "
                  "`void field_jacobian(double t, const double *x, double f, double *jac) const` (jac[i * dimension "
                  "+ j] = dv_i/dx_j), or leave it out and make `field` a template so that the SDK derives it");
    static_assert(!declares_rhs<T>::value || batch_rhs,
                  "geobarrier::sdk: this system's `rhs` has the wrong signature or is not const. Write `void "
                  "rhs(const geobarrier::sdk::Batch &b, double *dxdt) const` (optionally with a third parameter "
                  "std::int32_t *lane_status), or leave it out: the SDK derives it from `field`");
    static_assert(!declares_jacobian<T>::value || has_jacobian<T>::value,
                  "geobarrier::sdk: this system's `jacobian` has the wrong signature or is not const. Write `void "
                  "jacobian(const geobarrier::sdk::Batch &b, double *jac) const`, or leave it out: the SDK derives "
                  "it from `field`");
    static_assert(!declares_divergence<T>::value || has_divergence<T>::value,
                  "geobarrier::sdk: this system's `divergence` has the wrong signature or is not const. Write `void "
                  "divergence(const geobarrier::sdk::Batch &b, double *div) const`, or leave it out: the SDK "
                  "derives it from the Jacobian");
    static_assert(field || batch_rhs,
                  "geobarrier::sdk: a system needs its vector field: `template <class Real> void field(double t, "
                  "const Real *x, double f, Real *dxdt) const` (or a batched rhs)");
    static_assert(!has_field_jacobian<T>::value || field,
                  "geobarrier::sdk: `field_jacobian` is given without `field`: give the per-lane field too");
    static constexpr bool jacobian = has_jacobian<T>::value || (field && has_lane_jacobian<T>);
    static constexpr bool divergence = has_divergence<T>::value || (field && has_lane_jacobian<T>);
    static constexpr bool derived_jacobian =
        !has_jacobian<T>::value && !has_field_jacobian<T>::value && field && has_dual_field<T>::value;
};

// One fused explicit Runge-Kutta step of tableau Tab for every lane of a request (gb_advance_request). Per lane the
// state (with the variational equations: x, DF row-major, log|det DF|) and the stage derivatives are small local
// arrays, so after inlining they live in registers, and the lane loop vectorises (GCC 12 -O3: 8 lanes with AVX-512,
// -fopt-info-vec; `omp simd` would not: its per-lane copies of the arrays defeat the vectoriser). The arithmetic is the
// core's stage-by-stage kernel's (flow_map.cpp: stage_state, new_state, the variational right-hand side), term for
// term, so both agree to rounding.
template <class T, class Tab, bool Variational> struct FusedStep {
    static constexpr unsigned D = T::dimension;
    static constexpr unsigned C = Variational ? D + D * D + 1 : D; // per-lane components
    static constexpr int S = Tab::stages;

    // True when the compiler knows v to be 0 after inlining (GCC and Clang; elsewhere never).
    GEOBARRIER_ALWAYS_INLINE static bool literal_zero(double v) {
#if defined(__GNUC__)
        return __builtin_constant_p(v) && v == 0.0;
#else
        (void)v;
        return false;
#endif
    }

    // d/dt of the lane's extended state: v, DF' = Dv DF, (log|det DF|)' = tr Dv (Liouville).
    GEOBARRIER_ALWAYS_INLINE static void derivative(const T &sys, double t, double f, const double *y, double *dy) {
        sys.field(t, y, f, dy);
        if constexpr (Variational) {
            double J[D * D];
            lane_jacobian(sys, t, y, f, J);
            const double *F = y + D;
#pragma GCC unroll 16
            for (unsigned i = 0; i < D; ++i)
#pragma GCC unroll 16
                for (unsigned j = 0; j < D; ++j) {
                    // Entries the plugin sets to a literal 0 (x' = y has two) drop out at compile time: 0 * F is
                    // not foldable in IEEE arithmetic, and those products were 8% of a Duffing dop853 step. Only
                    // the sign of an exact zero can differ from the core's stage-by-stage sum.
                    double s = 0.0;
                    bool started = false;
#pragma GCC unroll 16
                    for (unsigned l = 0; l < D; ++l) {
                        if (literal_zero(J[i * D + l])) continue;
                        s = started ? geobarrier::detail::mul_add(J[i * D + l], F[l * D + j], s)
                                    : J[i * D + l] * F[l * D + j];
                        started = true;
                    }
                    dy[D + i * D + j] = s;
                }
            double trace = J[0];
#pragma GCC unroll 16
            for (unsigned i = 1; i < D; ++i) trace += J[i * D + i];
            dy[D + D * D] = trace;
        }
    }

    // y = x + h sum_j row_j k_j, component by component (flow_map.cpp's stage_state and new_state).
    GEOBARRIER_ALWAYS_INLINE static void combine(const geobarrier::detail::RkRow &row, double h, const double *x,
                                                 const double (*k)[C], double *y) {
#pragma GCC unroll 16
        for (unsigned q = 0; q < C; ++q)
            y[q] = geobarrier::detail::row_step(row, h, x[q], [&](int j) { return k[j][q]; });
    }

    template <int I>
    GEOBARRIER_ALWAYS_INLINE static void stage(const T &sys, double t, double h, const double *forcing, const double *x,
                                               double (*k)[C]) {
        if constexpr (I == 0) {
            derivative(sys, t, forcing[0], x, k[0]);
        } else {
            double y[C];
            combine(Tab::a[I], h, x, k, y);
            derivative(sys, t + Tab::c[I] * h, forcing[I], y, k[I]);
        }
    }
    template <int... I>
    GEOBARRIER_ALWAYS_INLINE static void stages(std::integer_sequence<int, I...>, const T &sys, double t, double h,
                                                const double *forcing, const double *x, double (*k)[C]) {
        (stage<I>(sys, t, h, forcing, x, k), ...);
    }

    // Lanes are independent (x_out never aliases x): tell the vectoriser so. (Clang vectorises some of these loops on
    // its own; forcing it with `clang loop vectorize(assume_safety)` only brings warnings.) Every small loop above is
    // unrolled by pragma: with std::fma in the sums GCC's own unrolling heuristics leave some in place, and a lane
    // loop with inner loops does not vectorise.
    // Checked: also the lane's error estimate (gb_advance_request.lane_error, ABI 1.3) over the state components, by
    // the core's own function (rk_tableaux.hpp, lane_error_estimate), so that both paths take the same steps.
    template <bool Checked> static void run(const T &sys, const gb_advance_request &r) {
        const std::size_t n = r.n, ld = r.ld;
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC ivdep
#endif
        for (std::size_t lane = 0; lane < n; ++lane) {
            double x[C], k[S][C], out[C];
#pragma GCC unroll 16
            for (unsigned i = 0; i < D; ++i) x[i] = r.x[i * ld + lane];
            if constexpr (Variational) {
#pragma GCC unroll 16
                for (unsigned m = 0; m < D * D; ++m) x[D + m] = r.df[m * ld + lane];
                x[D + D * D] = r.log_det[lane];
            }
            stages(std::make_integer_sequence<int, S>{}, sys, r.t, r.h, r.forcing, x, k);
            combine(Tab::b, r.h, x, k, out);
#pragma GCC unroll 16
            for (unsigned i = 0; i < D; ++i) r.x_out[i * ld + lane] = out[i];
            if constexpr (Variational) {
#pragma GCC unroll 16
                for (unsigned m = 0; m < D * D; ++m) r.df_out[m * ld + lane] = out[D + m];
                r.log_det_out[lane] = out[D + D * D];
            }
            if constexpr (Checked)
                r.lane_error[lane] =
                    geobarrier::detail::lane_error_estimate<Tab, D>([&](int j, unsigned i) { return k[j][i]; });
        }
    }
};

template <class T, class Tab, bool Checked = false> void fused_step(const T &sys, const gb_advance_request &r) {
    if (r.variational) {
        if constexpr (has_lane_jacobian<T>) FusedStep<T, Tab, true>::template run<Checked>(sys, r);
    } else {
        FusedStep<T, Tab, false>::template run<Checked>(sys, r);
    }
}

template <class T> struct SystemThunks {
    using Shape = SystemShape<T>;
    static gb_status rhs(void *self, std::uint64_t n, std::uint64_t ld, const double *t, const double *x,
                         const double *f, double *dxdt, std::int32_t *lane_status, gb_message *msg) noexcept {
        return guarded(msg, [&] {
            const Batch b{n, ld, t, x, f};
            const T &sys = *static_cast<const T *>(self);
            clear_lanes(lane_status, n);
            if constexpr (has_lane_status_rhs<T>::value)
                sys.rhs(b, dxdt, lane_status);
            else if constexpr (has_rhs<T>::value)
                sys.rhs(b, dxdt);
            else if constexpr (Shape::field)
                LaneLoops<T>::rhs(sys, b, dxdt);
        });
    }
    static gb_status jacobian(void *self, std::uint64_t n, std::uint64_t ld, const double *t, const double *x,
                              const double *f, double *jac, std::int32_t *lane_status, gb_message *msg) noexcept {
        return guarded(msg, [&] {
            const T &sys = *static_cast<const T *>(self);
            clear_lanes(lane_status, n);
            if constexpr (has_jacobian<T>::value)
                sys.jacobian(Batch{n, ld, t, x, f}, jac);
            else if constexpr (Shape::jacobian)
                LaneLoops<T>::jacobian(sys, Batch{n, ld, t, x, f}, jac);
        });
    }
    static gb_status divergence(void *self, std::uint64_t n, std::uint64_t ld, const double *t, const double *x,
                                const double *f, double *div, std::int32_t *lane_status, gb_message *msg) noexcept {
        return guarded(msg, [&] {
            const T &sys = *static_cast<const T *>(self);
            clear_lanes(lane_status, n);
            if constexpr (has_divergence<T>::value)
                sys.divergence(Batch{n, ld, t, x, f}, div);
            else if constexpr (Shape::divergence)
                LaneLoops<T>::divergence(sys, Batch{n, ld, t, x, f}, div);
        });
    }
    static gb_status advance(void *self, const gb_advance_request *r, gb_message *msg) noexcept {
        if (r->method != GB_ADVANCE_RK4 && r->method != GB_ADVANCE_DOP853 && r->method != GB_ADVANCE_DOP853_CHECKED)
            return GB_UNSUPPORTED;
        // Numerics compiled in (tableaux and operation order) that differ from the core's: decline, and the core
        // takes its own path. The request names its revision from ABI 1.3 on; older cores use revision 1.
        const std::uint32_t core_revision = host_abi_minor() >= 3 ? r->tableau_revision : 1u;
        if (core_revision != GEOBARRIER_SDK_TABLEAU_REVISION) return GB_UNSUPPORTED;
        if (r->variational && !has_lane_jacobian<T>) return GB_UNSUPPORTED;
        return guarded(msg, [&] {
            if constexpr (has_field<T>::value) {
                clear_lanes(r->lane_status, r->n);
                const T &sys = *static_cast<const T *>(self);
                using geobarrier::detail::Dop853Tableau;
                if (r->method == GB_ADVANCE_RK4)
                    fused_step<T, geobarrier::detail::Rk4Tableau>(sys, *r);
                else if (r->method == GB_ADVANCE_DOP853)
                    fused_step<T, Dop853Tableau>(sys, *r);
                else
                    fused_step<T, Dop853Tableau, true>(sys, *r);
            }
        });
    }
    static constexpr std::uint32_t capabilities() {
        return (Shape::jacobian ? GB_SYSTEM_HAS_JACOBIAN : 0u) | (Shape::divergence ? GB_SYSTEM_HAS_DIVERGENCE : 0u) |
               (uses_forcing<T>::value ? GB_SYSTEM_USES_FORCING : 0u) |
               (Shape::derived_jacobian ? GB_SYSTEM_JACOBIAN_DERIVED : 0u);
    }
    static inline const gb_system_vtable table{T::dimension,
                                               capabilities(),
                                               &rhs,
                                               Shape::jacobian ? &jacobian : nullptr,
                                               Shape::divergence ? &divergence : nullptr,
                                               domain_min<T>(),
                                               domain_max<T>(),
                                               state_names<T>(),
                                               state_units<T>(),
                                               has_field<T>::value ? &advance : nullptr};
};

template <class T> struct ForcingThunks {
    static gb_status evaluate(void *self, std::uint64_t n, const double *t, double *f, gb_message *msg) noexcept {
        return guarded(msg, [&] {
            if constexpr (has_combine<T>::value)
                throw std::runtime_error(std::string("composite forcing '") + T::name +
                                         "' needs a geobarrier core with plugin ABI 1.1 or later");
            else
                static_cast<const T *>(self)->evaluate(static_cast<std::size_t>(n), t, f);
        });
    }
    static gb_status combine(void *self, std::uint64_t n, const double *t, std::uint32_t term_count, std::uint64_t ld,
                             const double *terms, double *f, gb_message *msg) noexcept {
        return guarded(msg, [&] {
            if constexpr (has_combine<T>::value)
                static_cast<const T *>(self)->combine(Terms{n, term_count, ld, t, terms}, f);
        });
    }
    static constexpr std::uint32_t min_terms() {
        if constexpr (has_combine<T>::value)
            return T::min_terms;
        else
            return 0;
    }
    static constexpr std::uint32_t max_terms() {
        if constexpr (has_combine<T>::value)
            return T::max_terms;
        else
            return 0;
    }
    static_assert(!has_combine<T>::value || (1 <= min_terms() && min_terms() <= max_terms()),
                  "a composite forcing needs 1 <= min_terms <= max_terms");
    static inline const gb_forcing_vtable table{&evaluate, min_terms(), max_terms(),
                                                has_combine<T>::value ? &combine : nullptr};
};

template <class T> struct ExtractorThunks {
    static gb_status extract(void *self, const gb_host *host, const gb_extract_input *input, gb_message *msg) noexcept {
        return guarded(msg, [&] { static_cast<const T *>(self)->extract(Host(host), *input); });
    }
    static inline const gb_extractor_vtable table{T::required_fields, &extract};
};

template <class T> gb_plugin_descriptor descriptor(gb_plugin_kind kind) {
    return gb_plugin_descriptor{
        kind,
        T::name,
        T::version,
        T::doc,
        param_count<T>(),
        param_specs<T>(),
        GB_THREAD_SAFE_CONCURRENT,
        &create<T>,
        &destroy<T>,
        nullptr,
        nullptr,
        nullptr,
#ifdef GEOBARRIER_VERSION
        GEOBARRIER_VERSION // this plugin links the core's C++ library
#else
        nullptr
#endif
    };
}

} // namespace detail

// Descriptors for GEOBARRIER_PLUGINS(...). The object's const methods must be
// safe to call from several threads at once (GB_THREAD_SAFE_CONCURRENT).
template <class T> gb_plugin_descriptor system() {
    gb_plugin_descriptor d = detail::descriptor<T>(GB_KIND_SYSTEM);
    d.system = &detail::SystemThunks<T>::table;
    return d;
}
template <class T> gb_plugin_descriptor forcing() {
    gb_plugin_descriptor d = detail::descriptor<T>(GB_KIND_FORCING);
    d.forcing = &detail::ForcingThunks<T>::table;
    return d;
}
template <class T> gb_plugin_descriptor extractor() {
    gb_plugin_descriptor d = detail::descriptor<T>(GB_KIND_EXTRACTOR);
    d.extractor = &detail::ExtractorThunks<T>::table;
    return d;
}

} // namespace geobarrier::sdk

namespace geobarrier::sdk::detail {
// The library's extensions by id (gb_plugin_entry.get_extension): its build info, for every descriptor.
inline const void *library_extension(std::uint32_t, const char *id) noexcept {
    static constexpr gb_build_info build = build_info();
    if (id && std::strcmp(id, GB_EXTENSION_BUILD_INFO) == 0) return &build;
    return nullptr;
}
} // namespace geobarrier::sdk::detail

// Defines the library's exported entry points, listing its plugins: the plain one, and the one through which a core
// of ABI 1.3 or newer also tells the plugin its version (gb_host_info).
#define GEOBARRIER_PLUGINS(...)                                                                                        \
    extern "C" GB_PLUGIN_EXPORT const gb_plugin_entry *geobarrier_plugin_entry(void) {                                 \
        static const gb_plugin_descriptor geobarrier_descriptors[] = {__VA_ARGS__};                                    \
        static const gb_plugin_entry geobarrier_entry = {                                                              \
            GB_ABI_VERSION_MAJOR, GB_ABI_VERSION_MINOR,                                                                \
            static_cast<std::uint32_t>(sizeof(geobarrier_descriptors) / sizeof(geobarrier_descriptors[0])),            \
            geobarrier_descriptors, &geobarrier::sdk::detail::library_extension};                                      \
        return &geobarrier_entry;                                                                                      \
    }                                                                                                                  \
    extern "C" GB_PLUGIN_EXPORT const gb_plugin_entry *geobarrier_plugin_entry_with_host(const gb_host_info *host) {   \
        if (host && host->struct_size >= sizeof(std::uint32_t) * 3) geobarrier::sdk::detail::loaded_by = host;         \
        return geobarrier_plugin_entry();                                                                              \
    }

#endif // GEOBARRIER_SDK_HPP
