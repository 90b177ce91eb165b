// The conformance check of an extractor plugin (conformance.hpp): a run on the exact fields of a flow with a known
// answer, the shear vortex, whose every closed barrier is a circle about the centre.
#include "engine/tiles.hpp"
#include "plugins/conformance_internal.hpp"
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/grid.hpp>
#include <geobarrier/line_field.hpp>
#include <geobarrier/shear.hpp>

#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <unistd.h>

namespace geobarrier::detail::conformance {

namespace {

// A synthetic flow with a known answer for extractors: the shear vortex x' = -w y, y' = w x, w = omega + shear r^2
// (systems/shear-vortex), whose flow map rotates each circle r = const rigidly by w(r) T. Its fields are exact: DF =
// R(theta) + R'(theta) x grad(theta)^T with theta = w(r) T, grad(theta) = 2 shear T x. Every circle about the centre is
// invariant, and a closed shearline (<e_theta, C e_theta> = 1), so every closed barrier an extractor reports must be
// such a circle; every barrier must lie on the grid, with finite metrics, the same on every run.
struct SyntheticVortex {
    double omega = 1.0, shear = 0.5;
    double t0 = 0.0, t1 = 4.0;
    Grid grid{-1.5, 1.5, -1.5, 1.5, 81, 81};

    double angle(double x, double y, double duration) const { return (omega + shear * (x * x + y * y)) * duration; }
    // The flow map from t_from to t_to at (x, y), and its gradient F11 F12 F21 F22 when dF is not null.
    void flow(double x, double y, double t_from, double t_to, double *xy, double *dF) const {
        const double duration = t_to - t_from, theta = angle(x, y, duration);
        const double c = std::cos(theta), s = std::sin(theta);
        xy[0] = c * x - s * y;
        xy[1] = s * x + c * y;
        if (!dF) return;
        const double gx = 2.0 * shear * duration * x, gy = 2.0 * shear * duration * y; // grad(theta)
        const double rx = -s * x - c * y, ry = c * x - s * y;                          // R'(theta) x
        dF[0] = c + rx * gx;
        dF[1] = -s + rx * gy;
        dF[2] = s + ry * gx;
        dF[3] = c + ry * gy;
    }
};

} // namespace

ConformanceCheck check_extractor_behaviour(const Extractor &extractor) {
    const std::string name = "synthetic_field";
    const SyntheticVortex v;
    const Grid &grid = v.grid;
    std::vector<double> dF(4 * grid.size()), flow_x(grid.size()), flow_y(grid.size());
    const std::vector<std::uint8_t> valid(grid.size(), 0);
    for (std::size_t i = 0; i < grid.ny; ++i)
        for (std::size_t j = 0; j < grid.nx; ++j) {
            const std::size_t k = i * grid.nx + j;
            double xy[2];
            v.flow(grid.x(j), grid.y(i), v.t0, v.t1, xy, &dF[4 * k]);
            flow_x[k] = xy[0];
            flow_y[k] = xy[1];
        }
    CauchyGreenField cg = cauchy_green_field(grid, dF, valid, std::fabs(v.t1 - v.t0));
    std::map<std::string, const std::vector<double> *> fields;
    for (const std::string &variable : cauchy_green_variables()) fields[variable] = &cauchy_green_member(cg, variable);
    fields["flow_x"] = &flow_x;
    fields["flow_y"] = &flow_y;
    const std::vector<double> no_exit(grid.size(), std::numeric_limits<double>::quiet_NaN()); // no bounds: abi.h
    fields["exit_time"] = &no_exit;
    std::vector<double> strain_deviation;
    ShearFields shear;
    std::vector<gb_field> inputs;
    for (const std::string &field : extractor.required_fields()) {
        if (field == "strain_deviation" && strain_deviation.empty()) {
            strain_deviation = strain_deviation_field(cg);
            fields[field] = &strain_deviation;
        } else if (field.rfind("shear_deviation", 0) == 0 && shear.deviation_plus.empty()) {
            shear = shear_fields(cg);
            fields["shear_deviation_plus"] = &shear.deviation_plus;
            fields["shear_deviation_minus"] = &shear.deviation_minus;
        }
        const auto found = fields.find(field);
        if (found == fields.end())
            return skip(name, "not checked: it requires field '" + field + "', which the synthetic flow lacks");
        inputs.push_back({field.c_str(), found->second->data()});
    }
    const char *const names[2] = {"x", "y"}, *const units[2] = {"length", "length"};
    const gb_extract_input input{
        grid.x_min,    grid.x_max, grid.y_min, grid.y_max,     grid.nx,
        grid.ny,       v.t0,       v.t1,       cg.mask.data(), static_cast<std::uint32_t>(inputs.size()),
        inputs.data(), nullptr,    0,          names,          units};
    // The extractor's own files, if any, go to a folder of its own that is removed afterwards.
    const std::filesystem::path folder =
        std::filesystem::temp_directory_path() /
        ("geobarrier-check-" + extractor.info().name + "-" + std::to_string(::getpid()));
    std::filesystem::create_directories(folder);
    struct RemoveFolder {
        std::filesystem::path path;
        ~RemoveFolder() {
            std::error_code ec;
            std::filesystem::remove_all(path, ec);
        }
    } remove_folder{folder};
    const std::string folder_text = folder.string();
    gb_extract_input in = input;
    in.output_dir = folder_text.c_str();
    ExtractServices services;
    services.advect = [&v](std::size_t n, const double *xy, double t_from, double t_to, double *xy_out, double *dF_out,
                           std::uint8_t *mask_out) {
        for (std::size_t k = 0; k < n; ++k) {
            v.flow(xy[2 * k], xy[2 * k + 1], t_from, t_to, xy_out + 2 * k, dF_out ? dF_out + 4 * k : nullptr);
            mask_out[k] = 0;
        }
    };
    const std::vector<Barrier> first = extractor.extract(in, services), again = extractor.extract(in, services);
    const double slack = grid.dx(); // a curve may end a grid cell outside, where it was interpolated
    std::size_t closed = 0;
    double worst_spread = 0.0;
    for (std::size_t b = 0; b < first.size(); ++b) {
        const Barrier &barrier = first[b];
        const std::string who = "barrier " + std::to_string(b) + " (" + barrier.kind + ")";
        if (barrier.kind != "hyperbolic" && barrier.kind != "elliptic" && barrier.kind != "parabolic")
            return fail(name, who + ": unknown kind");
        if (barrier.xy.size() < 4) return fail(name, who + ": fewer than 2 points");
        for (std::size_t p = 0; p + 1 < barrier.xy.size(); p += 2) {
            const double x = barrier.xy[p], y = barrier.xy[p + 1];
            if (!(x >= grid.x_min - slack && x <= grid.x_max + slack && y >= grid.y_min - slack &&
                  y <= grid.y_max + slack))
                return fail(name, who + ": point (" + num(x) + ", " + num(y) + ") is not on the grid");
        }
        for (const auto &metric : barrier.metrics)
            if (!std::isfinite(metric.second))
                return fail(name, who + ": metric '" + metric.first + "' = " + num(metric.second));
        if (!barrier.closed) continue;
        // The known answer: a closed barrier of the shear vortex is a circle about its centre.
        double r_min = HUGE_VAL, r_max = 0.0;
        for (std::size_t p = 0; p + 1 < barrier.xy.size(); p += 2) {
            const double r = std::hypot(barrier.xy[p], barrier.xy[p + 1]);
            r_min = std::min(r_min, r);
            r_max = std::max(r_max, r);
        }
        const double spread = (r_max - r_min) / (0.5 * (r_max + r_min));
        if (!(spread <= 0.02))
            return fail(name, who +
                                  ": closed, but not a circle about the centre as every closed barrier of this flow "
                                  "is: radius from " +
                                  num(r_min) + " to " + num(r_max));
        worst_spread = std::max(worst_spread, spread);
        ++closed;
    }
    if (first.size() != again.size())
        return fail(name, std::to_string(first.size()) + " barriers, then " + std::to_string(again.size()) +
                              " from the same input");
    for (std::size_t b = 0; b < first.size(); ++b)
        if (first[b].xy != again[b].xy || first[b].kind != again[b].kind)
            return fail(name, "barrier " + std::to_string(b) + " differs between two runs on the same input");
    return pass(name, "on the shear vortex (" + std::to_string(grid.nx) + " x " + std::to_string(grid.ny) +
                          " grid, exact fields and advection): " + std::to_string(first.size()) +
                          " barrier(s) on the grid with finite metrics, the same on a second run" +
                          (closed ? "; " + std::to_string(closed) +
                                        " closed, each a circle about the centre as the known answer says (radius "
                                        "spread " +
                                        short_num(worst_spread) + ")"
                                  : ""));
}

} // namespace geobarrier::detail::conformance
