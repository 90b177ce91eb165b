// An extractor of a third party on the extractor kit (geobarrier_add_plugin(... KIT)): it reports the grid's boundary
// as one closed barrier with its length from the kit's polyline_length (2 (width + height), exact in floating point
// for the test's box), the mean of the unmasked FTLE from the kit's grid_of and find_field, and draws the FTLE with
// the box through the core's picture service.
#include <geobarrier/curves.hpp>
#include <geobarrier/line_field.hpp>
#include <geobarrier/sdk.hpp>
#include <geobarrier/sdk_plot.hpp>

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <vector>

using namespace geobarrier;

struct KitBox {
    static constexpr const char *name = "kit-box";
    static constexpr const char *version = "1.0.0";
    static constexpr const char *doc = "the grid's boundary as a barrier, through the extractor kit";
    static constexpr const char *required_fields[] = {"ftle", nullptr};
    explicit KitBox(const sdk::Params &) {}

    void extract(const sdk::Host &host, const gb_extract_input &in) const {
        const Grid g = grid_of(in);
        const std::vector<double> box = {g.x_min, g.y_min, g.x_max, g.y_min, g.x_max, g.y_max, g.x_min, g.y_max};
        const double *ftle = find_field(in, "ftle");
        if (!ftle) throw std::runtime_error("no ftle field");
        double sum = 0.0, count = 0.0;
        for (std::size_t k = 0; k < g.size(); ++k)
            if (in.mask[k] == 0) {
                sum += ftle[k];
                count += 1.0;
            }
        host.add_barrier("hyperbolic", true, box, {{"length", polyline_length(box, true)}, {"mean_ftle", sum / count}});
        if (!in.plots) return;
        const std::vector<double> values(ftle, ftle + g.size());
        const std::vector<std::uint8_t> mask(in.mask, in.mask + g.size());
        FieldPlot plot;
        plot.title = "kit-box";
        plot.curves.push_back({box, "red", 2.0, true});
        sdk::draw_field_png(host, std::filesystem::path(in.output_dir) / "kit-box.png", g, values, mask, plot);
    }
};

GEOBARRIER_PLUGINS(geobarrier::sdk::extractor<KitBox>())
