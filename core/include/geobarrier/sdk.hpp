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

} // namespace geobarrier::sdk

// The machinery behind the descriptors below (member detection, the derived batched members, the fused step, the C
// thunks), in <geobarrier/sdk/detail/>: not part of the public face.
#include <geobarrier/sdk/detail/fused_step.hpp>
#include <geobarrier/sdk/detail/lanes.hpp>
#include <geobarrier/sdk/detail/thunks.hpp>
#include <geobarrier/sdk/detail/traits.hpp>

namespace geobarrier::sdk {

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
