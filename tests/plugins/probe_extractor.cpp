// A test-only extractor that exercises the extractor ABI end to end: it reads
// the FTLE field, reports the grid point of largest FTLE and its image under
// the flow map (through the host's advect service) as a two-point "barrier",
// with the gradient's determinant as a metric.
#include <geobarrier/sdk.hpp>

#include <cmath>
#include <cstring>

namespace {

struct ProbeExtractor {
    static constexpr const char *name = "probe";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "test: reports the point of largest FTLE and its image at t1";
    static constexpr const char *required_fields[] = {"ftle", nullptr};
    static constexpr gb_param_spec params[] = {
        geobarrier::sdk::bool_param("closed", false, "report the barrier as closed")};

    explicit ProbeExtractor(const geobarrier::sdk::Params &p) : m_closed(p.flag("closed")) {}

    void extract(const geobarrier::sdk::Host &host, const gb_extract_input &in) const {
        const double *ftle = nullptr;
        for (std::uint32_t i = 0; i < in.field_count; ++i)
            if (std::strcmp(in.fields[i].name, "ftle") == 0) ftle = in.fields[i].data;
        if (!ftle) throw std::runtime_error("no ftle field");
        std::size_t best = 0; // the first unmasked point (the core never hands over an all-masked grid)
        while (best + 1 < in.nx * in.ny && in.mask[best] != 0) ++best;
        for (std::size_t k = 0; k < in.nx * in.ny; ++k)
            if (in.mask[k] == 0 && ftle[k] > ftle[best]) best = k;
        const double dx = (in.x_max - in.x_min) / (in.nx - 1), dy = (in.y_max - in.y_min) / (in.ny - 1);
        const std::vector<double> p = {in.x_min + dx * (best % in.nx), in.y_min + dy * (best / in.nx)};
        std::vector<double> image, gradient;
        std::vector<std::uint8_t> mask;
        host.advect(p, in.t0, in.t1, image, mask, &gradient);
        host.info("largest FTLE " + std::to_string(ftle[best]));
        const double det = gradient[0] * gradient[3] - gradient[1] * gradient[2];
        host.add_barrier("hyperbolic", m_closed, {p[0], p[1], image[0], image[1]},
                         {{"ftle", ftle[best]}, {"det_gradient", det}, {"plots", in.plots}});
    }
    bool m_closed;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::extractor<ProbeExtractor>())
