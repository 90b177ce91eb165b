// Pictures of an extractor, drawn by the core through the C ABI (GB_EXTENSION_PLOT, ABI 1.4): the FieldPlot and
// XYPlot of <geobarrier/output.hpp> handed over as the plain structs of abi.h, so that the extractor needs nothing of
// the core's C++ library. Header-only, for plugins built with <geobarrier/sdk.hpp>; call from extract()'s thread.
#ifndef GEOBARRIER_SDK_PLOT_HPP
#define GEOBARRIER_SDK_PLOT_HPP

#include <geobarrier/abi.h>
#include <geobarrier/grid.hpp>
#include <geobarrier/output.hpp>
#include <geobarrier/sdk.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace geobarrier::sdk {

// The core's picture service, or null when the core that loaded this plugin is older than 1.4 (or was built without
// it).
inline const gb_plot_service *plot_service() {
    const gb_host_info *host = detail::loaded_by;
    if (!host || host->abi_minor < 4 || !host->get_extension) return nullptr;
    const auto *service = static_cast<const gb_plot_service *>(host->get_extension(GB_EXTENSION_PLOT));
    if (!service || service->struct_size < sizeof(gb_plot_service)) return nullptr;
    return service;
}

namespace detail {
// Without the service: one note, so that a run on an older core says where its pictures went.
inline bool no_plot_service(const Host &host, const std::filesystem::path &file) {
    host.info("no picture " + file.filename().string() +
              ": the geobarrier core that loaded this extractor draws no pictures for plugins (plugin ABI 1.4)");
    return false;
}
inline void check_plot_status(gb_status status, const char *text) {
    if (status != GB_OK) throw std::runtime_error(std::string("picture: ") + text);
}
} // namespace detail

// Draws `values` on `grid` as a colour map with plot's curves (plot_field_png of output.hpp), through the core.
// Returns false, having drawn nothing and logged a note, when the core offers no pictures; throws when the core
// refuses the picture (its reason in the message).
inline bool draw_field_png(const Host &host, const std::filesystem::path &file, const Grid &grid,
                           const std::vector<double> &values, const std::vector<std::uint8_t> &mask,
                           const FieldPlot &plot) {
    const gb_plot_service *service = plot_service();
    if (!service) return detail::no_plot_service(host, file);
    if (values.size() != grid.size() || (!mask.empty() && mask.size() != grid.size()))
        throw std::invalid_argument("draw_field_png: " + std::to_string(values.size()) + " values and " +
                                    std::to_string(mask.size()) + " mask entries for a grid of " +
                                    std::to_string(grid.size()) + " points");
    std::vector<gb_plot_curve> curves;
    for (const PlotCurve &c : plot.curves)
        curves.push_back(gb_plot_curve{c.xy.data(), c.xy.size() / 2, c.color.c_str(), c.width, c.closed ? 1 : 0,
                                       c.points_only ? 1 : 0, c.marker_px});
    gb_plot_field p{};
    p.struct_size = sizeof(gb_plot_field);
    p.x_min = grid.x_min;
    p.x_max = grid.x_max;
    p.y_min = grid.y_min;
    p.y_max = grid.y_max;
    p.nx = grid.nx;
    p.ny = grid.ny;
    p.values = values.data();
    p.mask = mask.empty() ? nullptr : mask.data();
    p.title = plot.title.c_str();
    p.x_label = plot.x_label.c_str();
    p.y_label = plot.y_label.c_str();
    p.colorbar_label = plot.colorbar_label.c_str();
    p.curve_count = static_cast<std::uint32_t>(curves.size());
    p.curves = curves.data();
    p.width_px = plot.width_px;
    char text[512] = "";
    gb_message msg{text, sizeof text};
    detail::check_plot_status(service->field_png(file.string().c_str(), &p, &msg), text);
    return true;
}

// Draws an x-y picture (plot_xy_png of output.hpp) through the core; returns and throws as draw_field_png.
inline bool draw_xy_png(const Host &host, const std::filesystem::path &file, const XYPlot &plot) {
    const gb_plot_service *service = plot_service();
    if (!service) return detail::no_plot_service(host, file);
    std::vector<gb_plot_series> series;
    for (const PlotSeries &s : plot.series)
        series.push_back(gb_plot_series{s.xy.data(), s.xy.size() / 2, s.label.c_str(), s.color.c_str(), s.width,
                                        static_cast<std::int32_t>(s.style), static_cast<std::int32_t>(s.dash),
                                        s.marker_px, s.closed ? 1 : 0});
    gb_plot_xy p{};
    p.struct_size = sizeof(gb_plot_xy);
    p.title = plot.title.c_str();
    p.x_label = plot.x_label.c_str();
    p.y_label = plot.y_label.c_str();
    p.series_count = static_cast<std::uint32_t>(series.size());
    p.series = series.data();
    p.log_x = plot.log_x ? 1 : 0;
    p.log_y = plot.log_y ? 1 : 0;
    p.equal_aspect = plot.equal_aspect ? 1 : 0;
    p.aspect = plot.aspect;
    p.has_x_range = plot.x_range ? 1 : 0;
    p.has_y_range = plot.y_range ? 1 : 0;
    if (plot.x_range) {
        p.x_range[0] = plot.x_range->first;
        p.x_range[1] = plot.x_range->second;
    }
    if (plot.y_range) {
        p.y_range[0] = plot.y_range->first;
        p.y_range[1] = plot.y_range->second;
    }
    p.legend = static_cast<std::int32_t>(plot.legend);
    p.width_px = plot.width_px;
    char text[512] = "";
    gb_message msg{text, sizeof text};
    detail::check_plot_status(service->xy_png(file.string().c_str(), &p, &msg), text);
    return true;
}

} // namespace geobarrier::sdk

#endif // GEOBARRIER_SDK_PLOT_HPP
