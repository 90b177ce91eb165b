// An extractor plugin: a crude FTLE ridge, the grid point of largest FTLE in every grid column joined into one
// curve, reported as a hyperbolic barrier candidate with its mean FTLE. It reads the FTLE field the core computed
// for it and writes nothing itself: the core puts its barrier in barriers.json.
#include <geobarrier/sdk.hpp>

#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using geobarrier::sdk::Host;
using geobarrier::sdk::Params;
using geobarrier::sdk::real_param;

struct FtleRidge {
    static constexpr const char *name = "ftle-ridge";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "crude FTLE ridge: the largest FTLE of each grid column, joined into a curve";
    // The fields this extractor needs, NULL-terminated: the core computes them even if no product asks for them.
    static constexpr const char *required_fields[] = {"ftle", nullptr};
    static constexpr gb_param_spec params[] = {
        real_param("min_ftle", 0.0, -HUGE_VAL, HUGE_VAL, "1/time", "skip columns whose largest FTLE is below this"),
    };

    explicit FtleRidge(const Params &p) : m_min_ftle(p.real("min_ftle")) {}

    // Fields are row-major, ny rows of nx, row index = y; masked points have mask[k] != 0.
    void extract(const Host &host, const gb_extract_input &in) const {
        const double *ftle = nullptr;
        for (std::uint32_t i = 0; i < in.field_count; ++i)
            if (std::strcmp(in.fields[i].name, "ftle") == 0) ftle = in.fields[i].data;
        if (!ftle) throw std::runtime_error("the core passed no ftle field");
        const double dx = (in.x_max - in.x_min) / (in.nx - 1), dy = (in.y_max - in.y_min) / (in.ny - 1);
        std::vector<double> xy;
        double sum = 0.0;
        for (std::size_t j = 0; j < in.nx; ++j) {
            std::size_t best = in.ny; // none yet
            for (std::size_t i = 0; i < in.ny; ++i) {
                const std::size_t k = i * in.nx + j;
                if (in.mask[k] == 0 && (best == in.ny || ftle[k] > ftle[best * in.nx + j])) best = i;
            }
            if (best == in.ny || ftle[best * in.nx + j] < m_min_ftle) continue;
            xy.push_back(in.x_min + dx * j);
            xy.push_back(in.y_min + dy * best);
            sum += ftle[best * in.nx + j];
        }
        const std::size_t points = xy.size() / 2;
        if (points < 2) {
            host.warn("fewer than 2 columns reach min_ftle: no ridge");
            return;
        }
        host.info("ridge through " + std::to_string(points) + " columns");
        host.add_barrier("hyperbolic", false, xy, {{"mean_ftle", sum / points}, {"points", double(points)}});
    }

    double m_min_ftle;
};

} // namespace

GEOBARRIER_PLUGINS(geobarrier::sdk::extractor<FtleRidge>())
