// The picture service the core offers extractors through the C ABI (GB_EXTENSION_PLOT, abi.h, ABI 1.4): the plain C
// structs an extractor fills, drawn by plot_field_png and plot_xy_png (output.hpp).
#ifndef GEOBARRIER_PLOT_SERVICE_HPP
#define GEOBARRIER_PLOT_SERVICE_HPP

#include <geobarrier/abi.h>

namespace geobarrier {

// Lives as long as the process (gb_host_info.get_extension hands it out).
const gb_plot_service *plot_service();

} // namespace geobarrier

#endif // GEOBARRIER_PLOT_SERVICE_HPP
