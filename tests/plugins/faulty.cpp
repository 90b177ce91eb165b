// Test plugins that each break one rule of the conformance checks, so test_conformance can show that every
// check catches what it is meant to catch (a checker that never fails proves nothing). Built into a subfolder
// of the test-plugin dir so that registries over that dir never see them.
#include <geobarrier/sdk.hpp>

#include <atomic>
#include <cmath>
#include <limits>

namespace {

using geobarrier::sdk::Batch;
using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

// A harmonic oscillator x' = y, y' = -k x + f, whose parts the faulty variants below spoil one at a time
// (faulty-nan: NaN only at x >= 2, i.e. on the default box's edge, which only the finite-values sweep visits;
// faulty-nan-jacobian: a finite field whose Jacobian is NaN at x >= 2, so that only DF goes bad).
template <class Fault> struct Oscillator {
    static constexpr unsigned dimension = 2;
    static constexpr gb_param_spec params[] = {real_param("k", 1.0, 0.0, 10.0, "1/time^2", "stiffness")};
    explicit Oscillator(const Params &p) : m_k(p.real("k")), m_instance(s_created++) {}

    void rhs(const Batch &b, double *dxdt) const {
        for (std::size_t k = 0; k < b.n; ++k) {
            const double x = b.x[k], y = b.x[b.ld + k];
            dxdt[k] = y;
            dxdt[b.ld + k] = -m_k * x + b.f[k];
            if (Fault::batch_dependent) dxdt[b.ld + k] += 1e-9 * static_cast<double>(b.n);
            if (Fault::nan_outside && x >= 2.0) dxdt[k] = std::numeric_limits<double>::quiet_NaN();
            if (Fault::instance_dependent) dxdt[k] += 1e-3 * static_cast<double>(m_instance);
        }
        if (Fault::writes_padding)
            for (std::size_t k = b.n; k < b.ld; ++k) dxdt[k] = 0.0;
    }
    void jacobian(const Batch &b, double *jac) const {
        for (std::size_t k = 0; k < b.n; ++k) {
            jac[k] = 0.0;
            jac[b.ld + k] = 1.0;
            jac[2 * b.ld + k] = Fault::wrong_jacobian ? -1.01 * m_k : -m_k;
            jac[3 * b.ld + k] = 0.0;
            if (Fault::nan_jacobian_outside && b.x[k] >= 2.0) jac[k] = std::numeric_limits<double>::quiet_NaN();
        }
    }
    void divergence(const Batch &b, double *div) const {
        for (std::size_t k = 0; k < b.n; ++k) div[k] = Fault::wrong_divergence ? 0.5 : 0.0;
    }

    double m_k;
    int m_instance;
    static inline std::atomic<int> s_created{0};
};

struct NoFault {
    static constexpr bool batch_dependent = false, nan_outside = false, instance_dependent = false,
                          writes_padding = false, wrong_jacobian = false, wrong_divergence = false,
                          nan_jacobian_outside = false;
};
#define GB_FAULT(type, field)                                                                                          \
    struct type : NoFault {                                                                                            \
        static constexpr bool field = true;                                                                            \
    };
GB_FAULT(BatchFault, batch_dependent)
GB_FAULT(NanFault, nan_outside)
GB_FAULT(InstanceFault, instance_dependent)
GB_FAULT(PaddingFault, writes_padding)
GB_FAULT(JacobianFault, wrong_jacobian)
GB_FAULT(DivergenceFault, wrong_divergence)
GB_FAULT(NanJacobianFault, nan_jacobian_outside)
#undef GB_FAULT

#define GB_FAULTY_SYSTEM(type, fault, plugin_name)                                                                     \
    struct type : Oscillator<fault> {                                                                                  \
        using Oscillator<fault>::Oscillator;                                                                           \
        static constexpr const char *name = plugin_name, *version = "0.0.1", *doc = "faulty test system";              \
    };
GB_FAULTY_SYSTEM(Good, NoFault, "faulty-none")
GB_FAULTY_SYSTEM(FaultyBatch, BatchFault, "faulty-batch")
GB_FAULTY_SYSTEM(FaultyNan, NanFault, "faulty-nan")
GB_FAULTY_SYSTEM(FaultyInstance, InstanceFault, "faulty-determinism")
GB_FAULTY_SYSTEM(FaultyPadding, PaddingFault, "faulty-padding")
GB_FAULTY_SYSTEM(FaultyJacobian, JacobianFault, "faulty-jacobian")
GB_FAULTY_SYSTEM(FaultyDivergence, DivergenceFault, "faulty-divergence")
GB_FAULTY_SYSTEM(FaultyNanJacobian, NanJacobianFault, "faulty-nan-jacobian")
#undef GB_FAULTY_SYSTEM

// A forcing whose values depend on the batch size and on the instance.
struct FaultyForcing {
    static constexpr const char *name = "faulty-forcing", *version = "0.0.1", *doc = "faulty test forcing";
    static constexpr gb_param_spec params[] = {real_param("amplitude", 1.0, 0.0, 10.0, "", "amplitude")};
    explicit FaultyForcing(const Params &p) : m_amplitude(p.real("amplitude")), m_instance(s_created++) {}
    void evaluate(std::size_t n, const double *t, double *f) const {
        for (std::size_t k = 0; k < n; ++k)
            f[k] = m_amplitude * std::sin(t[k]) + 1e-9 * static_cast<double>(n) + 1e-3 * m_instance;
    }
    double m_amplitude;
    int m_instance;
    static inline std::atomic<int> s_created{0};
};

// Extractors that report what no extractor may on check-plugin's synthetic shear vortex: a point off the grid, and a
// closed barrier that is a square, where every closed barrier of that flow is a circle about its centre.
template <bool OffGrid> struct FaultyExtractor {
    static constexpr const char *name = OffGrid ? "faulty-extractor-off-grid" : "faulty-extractor-square";
    static constexpr const char *version = "0.0.1", *doc = "faulty test extractor";
    static constexpr const char *required_fields[] = {"ftle", nullptr};
    explicit FaultyExtractor(const Params &) {}
    void extract(const geobarrier::sdk::Host &host, const gb_extract_input &in) const {
        if (OffGrid)
            host.add_barrier("hyperbolic", false, {0.0, 0.0, in.x_max + 10.0, 0.0}, {});
        else // corners and edge midpoints: radius 0.5 to 0.71
            host.add_barrier(
                "elliptic", true,
                {-0.5, -0.5, 0.0, -0.5, 0.5, -0.5, 0.5, 0.0, 0.5, 0.5, 0.0, 0.5, -0.5, 0.5, -0.5, 0.0, -0.5, -0.5}, {});
    }
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<Good>(), geobarrier::sdk::system<FaultyBatch>(),
                   geobarrier::sdk::system<FaultyNan>(), geobarrier::sdk::system<FaultyInstance>(),
                   geobarrier::sdk::system<FaultyPadding>(), geobarrier::sdk::system<FaultyJacobian>(),
                   geobarrier::sdk::system<FaultyDivergence>(), geobarrier::sdk::system<FaultyNanJacobian>(),
                   geobarrier::sdk::forcing<FaultyForcing>(), geobarrier::sdk::extractor<FaultyExtractor<true>>(),
                   geobarrier::sdk::extractor<FaultyExtractor<false>>())
