// Test plugins that misbehave at run time, for the bad-input battery (test_bad_input): a system and a forcing that
// return NaN everywhere, a system whose right-hand side throws, and one whose factory throws. Built into a subfolder
// of the test-plugin dir so that registries over that dir never see them; experiments name them by path.
#include <geobarrier/sdk.hpp>

#include <limits>
#include <stdexcept>

namespace {

using geobarrier::sdk::Batch;
using geobarrier::sdk::Params;

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

struct NanSystem {
    static constexpr const char *name = "nan-system", *version = "0.0.1", *doc = "x' = y' = NaN everywhere (test)";
    static constexpr unsigned dimension = 2;
    static constexpr bool uses_forcing = false;
    explicit NanSystem(const Params &) {}
    void rhs(const Batch &b, double *dxdt) const {
        for (std::size_t k = 0; k < b.n; ++k) dxdt[k] = dxdt[b.ld + k] = nan_value;
    }
};

// A harmless oscillator x' = y, y' = -x + f driven by whatever forcing it is given (to carry nan-forcing).
struct Oscillator {
    static constexpr const char *name = "forced-oscillator", *version = "0.0.1", *doc = "x' = y, y' = -x + f (test)";
    static constexpr unsigned dimension = 2;
    explicit Oscillator(const Params &) {}
    void rhs(const Batch &b, double *dxdt) const {
        for (std::size_t k = 0; k < b.n; ++k) {
            dxdt[k] = b.x[b.ld + k];
            dxdt[b.ld + k] = -b.x[k] + b.f[k];
        }
    }
};

struct NanForcing {
    static constexpr const char *name = "nan-forcing", *version = "0.0.1", *doc = "f(t) = NaN (test)";
    explicit NanForcing(const Params &) {}
    void evaluate(std::size_t n, const double *, double *f) const {
        for (std::size_t k = 0; k < n; ++k) f[k] = nan_value;
    }
};

struct ThrowingSystem {
    static constexpr const char *name = "throwing-system", *version = "0.0.1",
                                *doc = "its right-hand side throws (test)";
    static constexpr unsigned dimension = 2;
    static constexpr bool uses_forcing = false;
    explicit ThrowingSystem(const Params &) {}
    void rhs(const Batch &, double *) const { throw std::runtime_error("deliberate failure in rhs"); }
};

struct ThrowingFactory {
    static constexpr const char *name = "throwing-factory", *version = "0.0.1", *doc = "its constructor throws (test)";
    static constexpr unsigned dimension = 2;
    static constexpr bool uses_forcing = false;
    explicit ThrowingFactory(const Params &) { throw std::runtime_error("deliberate failure in the factory"); }
    void rhs(const Batch &, double *) const {}
};

// Seven state components, one more than the engine integrates (flow_map.hpp, max_dimension): x_i' = 0.
struct SevenDimensional {
    static constexpr const char *name = "seven-dimensional", *version = "0.0.1",
                                *doc = "x' = 0 in 7 dimensions, beyond the engine's limit (test)";
    static constexpr unsigned dimension = 7;
    static constexpr bool uses_forcing = false;
    static constexpr const char *state_names[] = {"a", "b", "c", "d", "e", "f", "g"},
                                *state_units[] = {"", "", "", "", "", "", ""};
    explicit SevenDimensional(const Params &) {}
    template <class Real> void field(double, const Real *, double, Real *dxdt) const {
        for (unsigned i = 0; i < dimension; ++i) dxdt[i] = Real(0.0);
    }
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::system<SevenDimensional>(), geobarrier::sdk::system<NanSystem>(),
                   geobarrier::sdk::system<Oscillator>(), geobarrier::sdk::forcing<NanForcing>(),
                   geobarrier::sdk::system<ThrowingSystem>(), geobarrier::sdk::system<ThrowingFactory>())
