// Stage 3, one extractor on fields over an experiment's grid (extraction.hpp).
#include <geobarrier/extraction.hpp>
#include <geobarrier/flow_map.hpp>

#include <cmath>

namespace geobarrier {

using nlohmann::json;

ExtractServices advection_services(const ResolvedExperiment &r) {
    ExtractServices services;
    services.advect = [&r](std::size_t n, const double *xy, double t_from, double t_to, double *xy_out, double *dF_out,
                           std::uint8_t *mask_out) {
        const Experiment &e = r.experiment;
        const Dynamics dynamics = r.dynamics();
        const GradientMethod method = !dF_out ? GradientMethod::none
                                      : r.system.has_jacobian() && r.gradient != GradientMethod::auxiliary_grid
                                          ? GradientMethod::variational
                                          : GradientMethod::auxiliary_grid;
        const FlowMapRequest request = with_grid_offset(
            {dynamics, t_from, t_to, e.integrator, method, true, masking(e.bounds)}, e.grid, e.aux_offset);
        const FlowMap a = flow_map_at_points(
            request, n, [xy](std::size_t k, double &x, double &y) { x = xy[2 * k], y = xy[2 * k + 1]; });
        for (std::size_t k = 0; k < n; ++k) {
            const std::uint8_t m = a.mask[k];
            mask_out[k] = m;
            xy_out[2 * k] = m ? std::nan("") : a.flow_x[k];
            xy_out[2 * k + 1] = m ? std::nan("") : a.flow_y[k];
            if (!dF_out) continue;
            double *g = dF_out + 4 * k;
            for (int q = 0; q < 4; ++q)
                // DF = 2^exponent dF (renormalised beyond the double range: entries become +-Inf there).
                g[q] = m                       ? std::nan("")
                       : a.dF_exponent.empty() ? a.dF[4 * k + q]
                                               : std::ldexp(a.dF[4 * k + q], a.dF_exponent[k]);
        }
    };
    return services;
}

void run_extractor(const ResolvedExperiment &r, const Extractor &x, const std::vector<gb_field> &inputs,
                   const std::uint8_t *mask, const std::string &out_dir, bool plots, const ExtractServices &services,
                   FoundBarriers &found) {
    const Experiment &e = r.experiment;
    // The system's state names and units (ABI 1.2), "" when undeclared, for the axes of the extractor's pictures.
    const PluginInfo &sys = r.system.info();
    const std::size_t cx = r.plane_component(0), cy = r.plane_component(1); // a slice's axes
    const std::string names[2] = {sys.state_names.empty() ? "" : sys.state_names[cx],
                                  sys.state_names.empty() ? "" : sys.state_names[cy]};
    const std::string units[2] = {sys.state_units.empty() ? "" : sys.state_units[cx],
                                  sys.state_units.empty() ? "" : sys.state_units[cy]};
    const char *const name_ptrs[2] = {names[0].c_str(), names[1].c_str()};
    const char *const unit_ptrs[2] = {units[0].c_str(), units[1].c_str()};
    const gb_extract_input input{e.grid.x_min,  e.grid.x_max,
                                 e.grid.y_min,  e.grid.y_max,
                                 e.grid.nx,     e.grid.ny,
                                 e.t0,          e.t1,
                                 mask,          static_cast<std::uint32_t>(inputs.size()),
                                 inputs.data(), out_dir.c_str(),
                                 plots ? 1 : 0, name_ptrs,
                                 unit_ptrs};
    for (const Barrier &b : x.extract(input, services)) {
        json points = json::array();
        for (std::size_t k = 0; k + 1 < b.xy.size(); k += 2) points.push_back({b.xy[k], b.xy[k + 1]});
        json item = {{"kind", b.kind}, {"closed", b.closed}, {"extractor", x.info().name}, {"points", points}};
        for (const auto &[name, value] : b.metrics) item[name] = value;
        for (const auto &[name, value] : b.attributes) item[name] = json::parse(value);
        if (item.value("candidate", false)) {
            found.candidates.push_back(item);
            continue;
        }
        found.items.push_back(item);
        found.barriers.push_back(b);
    }
}

} // namespace geobarrier
