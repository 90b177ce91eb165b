// An extractor as plugin ABI 1.3 made them: built against that release's header (abi_1_3.h, commit 7d54b49, kept
// verbatim) and linked to libgeobarrier for its C++ API (curves, the input's grid and fields, pictures), so that its
// descriptor names the core version it was built against (core_version) and the loader checks the C++ series. Since
// 1.4 the built-in extractors reach the core through the C ABI only; test_abi_history loads this one to show that an
// extractor of the older kind still loads and runs. Written by hand, without the SDK, with one known answer each:
//   extractor "history-circle": one closed barrier, the circle of radius r (parameter) around the grid's centre as a
//   polygon of 64 points, resampled by the core's resample_polyline to spacing r/8; metrics: the polygon's length
//   (polyline_length: 128 r sin(pi/64)), the mean of the "ftle" field over the unmasked grid points (grid_of and
//   find_field), and x of the advected centre (gb_host.advect); attribute "family" = "+" (ABI 1.1, allowed because
//   it links the core); with pictures, ftle.png through the core's plot_field_png.
#include GB_HISTORIC_ABI

#include <geobarrier/curves.hpp>
#include <geobarrier/line_field.hpp>
#include <geobarrier/output.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <stdexcept>
#include <vector>

namespace {

const double pi = 3.14159265358979323846;

struct Circle {
    double radius;
};

void set_message(gb_message *msg, const char *text) {
    if (msg && msg->text && msg->capacity > 0) std::snprintf(msg->text, msg->capacity, "%s", text);
}

void *create(const gb_param_values *values, gb_message *) { return new Circle{values->values[0]}; }
void destroy(void *self) { delete static_cast<Circle *>(self); }

gb_status extract(void *self, const gb_host *host, const gb_extract_input *in, gb_message *msg) {
    try {
        using namespace geobarrier;
        const double r = static_cast<const Circle *>(self)->radius;
        const Grid grid = grid_of(*in);
        const double *ftle = find_field(*in, "ftle");
        if (!ftle) throw std::runtime_error("no field ftle");
        double sum = 0.0;
        std::size_t count = 0;
        for (std::size_t k = 0; k < grid.size(); ++k)
            if (in->mask[k] == 0) {
                sum += ftle[k];
                ++count;
            }
        const double cx = 0.5 * (grid.x_min + grid.x_max), cy = 0.5 * (grid.y_min + grid.y_max);
        std::vector<double> polygon;
        for (int k = 0; k < 64; ++k) {
            polygon.push_back(cx + r * std::cos(2.0 * pi * k / 64.0));
            polygon.push_back(cy + r * std::sin(2.0 * pi * k / 64.0));
        }
        const double length = polyline_length(polygon, true);
        const std::vector<double> xy = resample_polyline(polygon, r / 8.0, true);
        const double centre[2] = {cx, cy};
        double moved[2];
        std::uint8_t moved_mask = 0;
        if (host->advect(host->context, 1, centre, in->t0, in->t1, moved, nullptr, &moved_mask, msg) != GB_OK)
            return GB_ERROR;
        const char *names[3] = {"length", "ftle_mean", "advected_x"};
        const double values[3] = {length, sum / static_cast<double>(count), moved[0]};
        if (host->add_barrier(host->context, "elliptic", 1, xy.size() / 2, xy.data(), 3, names, values) != GB_OK)
            throw std::runtime_error("the core refused the barrier");
        const char *attribute = "family", *value = "\"+\"";
        if (host->set_barrier_attributes(host->context, 1, &attribute, &value) != GB_OK)
            throw std::runtime_error("the core refused the attribute");
        if (in->plots) {
            const std::vector<double> field(ftle, ftle + grid.size());
            const std::vector<std::uint8_t> mask(in->mask, in->mask + grid.size());
            FieldPlot plot;
            plot.title = "history-circle";
            plot.curves.push_back({xy, "red", 1.5, true});
            plot_field_png(std::filesystem::path(in->output_dir) / "history-circle.png", grid, field, mask, plot);
        }
        return GB_OK;
    } catch (const std::exception &e) {
        set_message(msg, e.what());
        return GB_ERROR;
    }
}

const char *const required[] = {"ftle", nullptr};
const gb_extractor_vtable table = {required, &extract};
const gb_param_spec params[] = {{"radius", GB_PARAM_REAL, 0.5, 1e-3, 1e3, nullptr, nullptr, "", "the circle's radius"}};
const gb_plugin_descriptor descriptors[] = {
    {GB_KIND_EXTRACTOR, "history-circle", "1.3.0", "a circle through the core's C++ API (ABI 1.3 history)", 1, params,
     GB_THREAD_SAFE_CONCURRENT, &create, &destroy, nullptr, nullptr, &table, GEOBARRIER_VERSION}};
const gb_plugin_entry entry = {GB_ABI_VERSION_MAJOR, GB_ABI_VERSION_MINOR, 1, descriptors, nullptr};

} // namespace

extern "C" GB_PLUGIN_EXPORT const gb_plugin_entry *geobarrier_plugin_entry(void) { return &entry; }
