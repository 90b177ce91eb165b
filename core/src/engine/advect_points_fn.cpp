// make_advect_points_fn (curves.hpp): curve advection over the core's own flow map. Here in the engine, not beside
// the curves in the extractor kit, because it calls flow_map_at_points: the kit that extractors compile in needs
// nothing of the engine (an extractor advects through gb_host.advect instead).
#include <geobarrier/curves.hpp>
#include <geobarrier/flow_map.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

namespace geobarrier {

AdvectPointsFn make_advect_points_fn(const Dynamics &dynamics, double t_from, double t_to,
                                     const IntegratorSettings &settings, const std::optional<Bounds> &bounds) {
    FlowMapRequest request{dynamics, t_from, t_to, settings};
    request.bounds = bounds;
    return [request](const std::vector<double> &xy_in, std::vector<double> &xy_out, std::vector<std::uint8_t> &mask) {
        const std::size_t n = xy_in.size() / 2;
        const FlowMap a = flow_map_at_points(request, n, [&](std::size_t k, double &x, double &y) {
            x = xy_in[2 * k];
            y = xy_in[2 * k + 1];
        });
        xy_out.resize(2 * n);
        for (std::size_t k = 0; k < n; ++k) {
            xy_out[2 * k] = a.flow_x[k];
            xy_out[2 * k + 1] = a.flow_y[k];
        }
        mask = a.mask;
    };
}

} // namespace geobarrier
