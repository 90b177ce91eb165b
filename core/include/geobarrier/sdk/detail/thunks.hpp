// Part of the plugin SDK's machinery, included by <geobarrier/sdk.hpp> only: not part of the public face (a plugin
// never names geobarrier::sdk::detail). The C functions of the ABI's tables for each plugin kind (systems, forcings,
// extractors), and the descriptor every plugin's entry lists.
#ifndef GEOBARRIER_SDK_DETAIL_THUNKS_HPP
#define GEOBARRIER_SDK_DETAIL_THUNKS_HPP

#ifndef GEOBARRIER_SDK_HPP
#error "include <geobarrier/sdk.hpp>, not its detail headers"
#endif

#include <geobarrier/sdk/detail/fused_step.hpp>
#include <geobarrier/sdk/detail/lanes.hpp>
#include <geobarrier/sdk/detail/traits.hpp>

namespace geobarrier::sdk::detail {

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

} // namespace geobarrier::sdk::detail

#endif // GEOBARRIER_SDK_DETAIL_THUNKS_HPP
