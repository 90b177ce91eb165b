// Part of the plugin SDK's machinery, included by <geobarrier/sdk.hpp> only: not part of the public face (a plugin
// never names geobarrier::sdk::detail). What the SDK reads from a plugin class: which members it declares (with which
// signatures), its parameters, domain and state names, and the guard that turns an exception into GB_ERROR and a
// message.
#ifndef GEOBARRIER_SDK_DETAIL_TRAITS_HPP
#define GEOBARRIER_SDK_DETAIL_TRAITS_HPP

#ifndef GEOBARRIER_SDK_HPP
#error "include <geobarrier/sdk.hpp>, not its detail headers"
#endif

namespace geobarrier::sdk::detail {

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

} // namespace geobarrier::sdk::detail

#endif // GEOBARRIER_SDK_DETAIL_TRAITS_HPP
