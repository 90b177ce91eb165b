// The experiment runner: computes the stages the requested products and
// extractors need (and no others), then writes fields.nc, pictures,
// barriers.json and, last, manifest.json into the output folder.
#include "progress.hpp"

#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/output.hpp>

#include <omp.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <map>

namespace fs = std::filesystem;
using nlohmann::json;

namespace geobarrier {

namespace {

class StageTimer {
  public:
    StageTimer(json &stages, std::string name) : m_stages(stages), m_name(std::move(name)) {
        spdlog::info("{} ...", m_name);
    }
    ~StageTimer() {
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
        m_stages.push_back({{"stage", m_name}, {"wall_seconds", s}});
        spdlog::info("{} done in {:.2f} s", m_name, s);
    }

  private:
    json &m_stages;
    std::string m_name;
    std::chrono::steady_clock::time_point m_start = std::chrono::steady_clock::now();
};

json plugin_summary(const PluginInfo &info) {
    return {{"kind", to_string(info.kind)}, {"name", info.name}, {"version", info.version},
            {"file", info.file.string()}, {"abi", std::to_string(info.abi_major) + "." + std::to_string(info.abi_minor)}};
}

struct FieldDoc {
    const char *long_name;
    const char *units;
};

// Long names and units of every variable fields.nc can hold.
FieldDoc field_doc(const std::string &name) {
    static const std::map<std::string, FieldDoc> docs = {
        {"ftle", {"finite-time Lyapunov exponent log(lambda2)/(2|t1-t0|)", "1/time"}},
        {"lambda1", {"smaller Cauchy-Green eigenvalue", "1"}},
        {"lambda2", {"larger Cauchy-Green eigenvalue", "1"}},
        {"xi1_x", {"x component of the Cauchy-Green eigenvector xi1 (strain direction)", "1"}},
        {"xi1_y", {"y component of the Cauchy-Green eigenvector xi1 (strain direction)", "1"}},
        {"xi2_x", {"x component of the Cauchy-Green eigenvector xi2 = Omega xi1", "1"}},
        {"xi2_y", {"y component of the Cauchy-Green eigenvector xi2 = Omega xi1", "1"}},
        {"flow_x", {"x component of the flow map F(x0) at t1", "state"}},
        {"flow_y", {"y component of the flow map F(x0) at t1", "state"}},
    };
    const auto it = docs.find(name);
    return it == docs.end() ? FieldDoc{"", "1"} : it->second;
}

}  // namespace

RunSummary run_experiment(const ResolvedExperiment &r, const RunOptions &options) {
    const Experiment &e = r.experiment;
    const auto run_start = std::chrono::steady_clock::now();
    if (options.threads > 0) omp_set_num_threads(options.threads);

    RunSummary summary;
    summary.output_dir = options.output_dir ? *options.output_dir : e.output_dir;
    const fs::path out = summary.output_dir;
    {
        std::error_code ec;
        fs::create_directories(out, ec);
        if (ec || !fs::is_directory(out))
            throw IoError(out.string() + ": cannot create the output folder (" + ec.message() + ")");
    }

    json manifest;
    manifest["tool"] = {{"name", "geobarrier"},
                        {"version", GEOBARRIER_VERSION},
                        {"plugin_abi", std::to_string(GB_ABI_VERSION_MAJOR) + "." + std::to_string(GB_ABI_VERSION_MINOR)}};
    manifest["experiment_file"] = e.file.empty() ? "" : fs::absolute(e.file).string();
    manifest["experiment"] = e.source;
    manifest["resolved"] = r.resolved;
    json plugins = json::array({plugin_summary(r.system.info()), plugin_summary(r.forcing.info())});
    for (const Extractor &x : r.extractors) plugins.push_back(plugin_summary(x.info()));
    manifest["plugins"] = plugins;
    manifest["threads"] = options.threads > 0 ? options.threads : omp_get_max_threads();
    json stages = json::array();
    json warnings = json::array();
    for (const auto &w : r.registry.warnings()) warnings.push_back(w);

    // Stage 1: the flow map, with the gradient only when something needs it.
    const GradientMethod gradient = r.need_cauchy_green ? r.gradient : GradientMethod::none;
    GridFlowMap flow;
    {
        StageTimer timer(stages, "flow map");
        detail::ProgressBar bar("flow map", !options.quiet);
        const Dynamics dynamics{&r.system, &r.forcing};
        flow = compute_grid_flow_map(dynamics, e.grid, e.t0, e.t1, e.integrator, gradient, e.aux_offset,
                                     r.need_positions, e.bounds,
                                     [&bar](std::size_t done, std::size_t total) { bar.update(done, total); });
        bar.finish();
    }
    manifest["integrator_stats"] = flow.stats.to_json();
    manifest["gradient_method"] = to_string(gradient);
    const std::uint64_t masked = flow.stats.masked;
    if (masked == e.grid.size())
        throw NumericalError("every one of the " + std::to_string(masked) +
                             " grid points was masked (left the bounds, blew up or hit the step limit): " +
                             flow.stats.to_json().dump() + "; check the grid, the time interval and the system");
    if (masked > 0) {
        const std::string w = std::to_string(masked) + " of " + std::to_string(e.grid.size()) +
                              " trajectories masked (see integrator_stats and the mask variable in fields.nc)";
        spdlog::warn("{}", w);
        warnings.push_back(w);
    }

    // Stage 2: Cauchy–Green eigenvalues, eigenvectors and FTLE.
    CauchyGreenField cg;
    std::map<std::string, const std::vector<double> *> fields;
    if (r.need_cauchy_green) {
        StageTimer timer(stages, "cauchy-green");
        cg = cauchy_green_field(e.grid, flow.dF, flow.mask, std::abs(e.t1 - e.t0));
        fields = {{"ftle", &cg.ftle},   {"lambda1", &cg.lambda1}, {"lambda2", &cg.lambda2}, {"xi1_x", &cg.xi1_x},
                  {"xi1_y", &cg.xi1_y}, {"xi2_x", &cg.xi2_x},     {"xi2_y", &cg.xi2_y}};
        manifest["degenerate_points"] = cg.degenerate_count;
        flow.dF.clear();
        flow.dF.shrink_to_fit();
    }
    if (r.need_positions) {
        fields["flow_x"] = &flow.flow_x;
        fields["flow_y"] = &flow.flow_y;
    }
    const std::vector<std::uint8_t> &mask = r.need_cauchy_green ? cg.mask : flow.mask;

    // Stage 3: barrier extractors. They may advect points with the experiment's
    // system and integrator (the gradient by the experiment's method).
    json barriers = json::array();
    ExtractServices services;
    services.advect = [&](std::size_t n, const double *xy, double t_from, double t_to, double *xy_out, double *dF_out,
                          std::uint8_t *mask_out) {
        const Dynamics dynamics{&r.system, &r.forcing};
        // The auxiliary offset is relative to the grid spacing, as on the grid.
        const double dx = e.aux_offset * e.grid.dx(), dy = e.aux_offset * e.grid.dy();
        const bool variational = dF_out && r.system.has_jacobian() && r.gradient != GradientMethod::auxiliary_grid;
        const std::size_t per_point = (dF_out && !variational) ? 5 : 1;
        std::vector<double> x0(per_point * n), y0(per_point * n);
        const double ox[5] = {0, dx, -dx, 0, 0}, oy[5] = {0, 0, 0, dy, -dy};
        for (std::size_t k = 0; k < n; ++k)
            for (std::size_t q = 0; q < per_point; ++q) {
                x0[per_point * k + q] = xy[2 * k] + ox[q];
                y0[per_point * k + q] = xy[2 * k + 1] + oy[q];
            }
        const AdvectResult a = advect_points(dynamics, x0, y0, t_from, t_to, e.integrator, variational, e.bounds);
        for (std::size_t k = 0; k < n; ++k) {
            std::uint8_t m = 0;
            for (std::size_t q = 0; q < per_point; ++q) m |= a.mask[per_point * k + q];
            mask_out[k] = m;
            const std::size_t c = per_point * k;
            xy_out[2 * k] = m ? std::nan("") : a.x[c];
            xy_out[2 * k + 1] = m ? std::nan("") : a.y[c];
            if (!dF_out) continue;
            double *g = dF_out + 4 * k;
            if (m) {
                std::fill(g, g + 4, std::nan(""));
            } else if (variational) {
                std::copy(a.dF.begin() + 4 * k, a.dF.begin() + 4 * k + 4, g);
            } else {
                g[0] = (a.x[c + 1] - a.x[c + 2]) / (2 * dx);
                g[1] = (a.x[c + 3] - a.x[c + 4]) / (2 * dy);
                g[2] = (a.y[c + 1] - a.y[c + 2]) / (2 * dx);
                g[3] = (a.y[c + 3] - a.y[c + 4]) / (2 * dy);
            }
        }
    };
    for (const Extractor &x : r.extractors) {
        StageTimer timer(stages, "extractor " + x.info().name);
        std::vector<gb_field> inputs;
        for (const auto &name : x.required_fields()) inputs.push_back({name.c_str(), fields.at(name)->data()});
        const std::string out_text = out.string();
        const gb_extract_input input{e.grid.x_min, e.grid.x_max, e.grid.y_min, e.grid.y_max,
                                     e.grid.nx,    e.grid.ny,    e.t0,         e.t1,
                                     mask.data(),  static_cast<std::uint32_t>(inputs.size()),
                                     inputs.data(), out_text.c_str(), e.plots ? 1 : 0};
        for (const Barrier &b : x.extract(input, services)) {
            json points = json::array();
            for (std::size_t k = 0; k + 1 < b.xy.size(); k += 2) points.push_back({b.xy[k], b.xy[k + 1]});
            json item = {{"kind", b.kind}, {"closed", b.closed}, {"extractor", x.info().name}, {"points", points}};
            for (const auto &[name, value] : b.metrics) item[name] = value;
            barriers.push_back(item);
        }
    }

    // Stage 4: files. Each is written atomically; the manifest comes last, so a
    // folder with a manifest is a finished run.
    {
        StageTimer timer(stages, "output");
        std::vector<FieldVariable> variables;
        for (const auto &product : known_products()) {
            if (!e.wants(product.name)) continue;
            for (const char *name : product.variables) {
                const FieldDoc doc = field_doc(name);
                const bool vector_field = std::string(product.name) == "eigenvectors";
                variables.push_back(FieldVariable{name, doc.long_name, doc.units, fields.at(name),
                                                  static_cast<std::uint8_t>(vector_field ? (mask_trajectory_bits |
                                                                                            mask_degenerate)
                                                                                         : mask_trajectory_bits)});
            }
        }
        if (!variables.empty()) {
            json attributes = {{"title", e.description.empty() ? std::string("geobarrier fields") : e.description},
                               {"source", std::string("geobarrier ") + GEOBARRIER_VERSION},
                               {"system", r.system.info().name},
                               {"forcing", r.forcing.info().name},
                               {"t0", e.t0},
                               {"t1", e.t1},
                               {"gradient_method", to_string(gradient)},
                               {"experiment", r.resolved.dump()}};
            const fs::path file = out / "fields.nc";
            write_fields_netcdf(file, e.grid, variables, mask, attributes);
            summary.files.push_back(file);
        }
        if (e.plots && r.need_cauchy_green) {
            FieldPlot plot;
            plot.title = "FTLE, " + r.system.info().name + " + " + r.forcing.info().name + ", t = " +
                         fmt::format("{:g}", e.t0) + " to " + fmt::format("{:g}", e.t1);
            plot.colorbar_label = "FTLE";
            const fs::path file = out / "ftle.png";
            plot_field_png(file, e.grid, cg.ftle, mask, plot);
            summary.files.push_back(file);
        }
        if (!r.extractors.empty()) {
            const fs::path file = out / "barriers.json";
            write_text_file(file, json{{"barriers", barriers}}.dump(1) + "\n");
            summary.files.push_back(file);
        }
    }

    manifest["stages"] = stages;
    manifest["warnings"] = warnings;
    manifest["wall_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - run_start).count();
    json files = json::array();
    for (const auto &f : summary.files) files.push_back(f.filename().string());
    files.push_back("manifest.json");
    manifest["files"] = files;
    const fs::path manifest_file = out / "manifest.json";
    write_text_file(manifest_file, manifest.dump(2) + "\n");
    summary.files.push_back(manifest_file);
    summary.manifest = manifest;
    return summary;
}

}  // namespace geobarrier
