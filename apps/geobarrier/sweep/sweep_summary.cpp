// A sweep's summary (sweep.hpp): each finished member's figures (from its manifest, barriers.json and fields.nc),
// summary.csv, summary.md and the picture of a figure against a parameter, summary.png.
#include "sweep/sweep_internal.hpp"
#include <geobarrier/output.hpp>

#include <netcdf.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using nlohmann::json;

namespace geobarrier::detail::sweeps {

namespace {

// Mean and maximum of the FTLE over the unmasked points of a member's fields.nc.
std::pair<double, double> ftle_mean_max(const fs::path &file) {
    int ncid = -1;
    if (nc_open(file.c_str(), NC_NOWRITE, &ncid) != NC_NOERR) return {not_available, not_available};
    int ftle_id = -1, mask_id = -1;
    std::pair<double, double> result{not_available, not_available};
    if (nc_inq_varid(ncid, "ftle", &ftle_id) == NC_NOERR && nc_inq_varid(ncid, "mask", &mask_id) == NC_NOERR) {
        int dims[2];
        int ndims = 0;
        std::size_t n = 1;
        if (nc_inq_varndims(ncid, ftle_id, &ndims) == NC_NOERR && ndims == 2 &&
            nc_inq_vardimid(ncid, ftle_id, dims) == NC_NOERR) {
            for (int d : dims) {
                std::size_t len = 0;
                nc_inq_dimlen(ncid, d, &len);
                n *= len;
            }
            std::vector<double> ftle(n);
            std::vector<unsigned char> mask(n);
            if (nc_get_var_double(ncid, ftle_id, ftle.data()) == NC_NOERR &&
                nc_get_var_uchar(ncid, mask_id, mask.data()) == NC_NOERR) {
                double sum = 0.0, max = -std::numeric_limits<double>::infinity();
                std::size_t used = 0;
                for (std::size_t k = 0; k < n; ++k) {
                    if (mask[k] & mask_trajectory_bits || !std::isfinite(ftle[k])) continue;
                    sum += ftle[k];
                    max = std::max(max, ftle[k]);
                    ++used;
                }
                if (used > 0) result = {sum / static_cast<double>(used), max};
            }
        }
    }
    nc_close(ncid);
    return result;
}

std::string number_text(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string(); }

std::string csv_field(std::string text) {
    if (text.find_first_of(",\"\n") == std::string::npos) return text;
    for (std::size_t at = text.find('"'); at != std::string::npos; at = text.find('"', at + 2)) text.insert(at, "\"");
    return "\"" + text + "\"";
}

std::string markdown_cell(std::string text) {
    for (std::size_t at = text.find('|'); at != std::string::npos; at = text.find('|', at + 2)) text.insert(at, "\\");
    std::replace(text.begin(), text.end(), '\n', ' ');
    return text;
}

} // namespace

// The sweep's figures of one finished member, from its manifest, barriers.json and fields.nc.
std::vector<double> member_figures(const Sweep &s, const fs::path &folder, const json &manifest) {
    std::optional<json> barriers;
    std::optional<std::pair<double, double>> ftle;
    std::vector<double> values;
    for (const std::string &figure : s.figures) {
        double v = not_available;
        if (is_figure_pointer(figure)) {
            const json::json_pointer ptr(figure);
            if (manifest.contains(ptr) && manifest.at(ptr).is_number()) v = manifest.at(ptr).get<double>();
        } else if (figure == "wall_seconds") {
            v = manifest.value("wall_seconds", not_available);
        } else if (figure == "captured_fraction") {
            const json escape = manifest.value("escape", json::object());
            v = escape.value("captured_fraction", not_available);
        } else if (figure == "masked_fraction") {
            const json stats = manifest.value("integrator_stats", json::object());
            const double trajectories = stats.value("trajectories", 0.0);
            if (trajectories > 0) v = stats.value("masked", 0.0) / trajectories;
        } else if (figure == "ftle_mean" || figure == "ftle_max") {
            if (!ftle) ftle = ftle_mean_max(folder / "fields.nc");
            v = figure == "ftle_mean" ? ftle->first : ftle->second;
        } else if (figure.rfind("ftle_", 0) == 0) { // ftle_{mean,max}_{forward,backward}: that direction's run
            const std::string direction = figure.substr(figure.rfind('_') + 1);
            const auto value = ftle_mean_max(folder / direction / "fields.nc");
            v = figure.rfind("ftle_mean", 0) == 0 ? value.first : value.second;
        } else {
            if (!barriers) {
                try {
                    barriers = json::parse(read_text(folder / "barriers.json", "barriers.json")).at("barriers");
                } catch (const std::exception &) {
                    barriers = json();
                }
            }
            if (barriers->is_array()) {
                double count = 0, elliptic = 0, area = not_available;
                for (const json &b : *barriers) {
                    ++count;
                    if (b.value("kind", "") != "elliptic") continue;
                    ++elliptic;
                    if (b.value("outermost", false) && b.contains("enclosed_area") && b["enclosed_area"].is_number()) {
                        const double a = b["enclosed_area"].get<double>();
                        area = std::isnan(area) ? a : std::max(area, a);
                    }
                }
                v = figure == "barriers" ? count : figure == "elliptic_barriers" ? elliptic : area;
            }
        }
        values.push_back(v);
    }
    return values;
}

// summary.csv, summary.md and (with a plot figure) summary.png in `out`.
std::vector<fs::path> write_summary(const Sweep &s, const fs::path &out,
                                    const std::vector<SweepMemberResult> &results) {
    std::vector<std::string> header = {"member"};
    for (const SweepParameter &p : s.parameters) header.push_back(p.name);
    header.push_back("status");
    for (const std::string &f : s.figures) header.push_back(f);
    header.push_back("wall_seconds");
    header.push_back("message");
    std::vector<std::vector<std::string>> rows;
    for (std::size_t k = 0; k < s.members.size(); ++k) {
        const SweepMember &m = s.members[k];
        const SweepMemberResult &r = results[k];
        std::vector<std::string> row = {m.name};
        for (std::size_t p = 0; p < s.parameters.size(); ++p)
            row.push_back(value_text(s.parameters[p].values[m.choice[p]]));
        row.push_back(r.status);
        for (std::size_t f = 0; f < s.figures.size(); ++f)
            row.push_back(f < r.figures.size() ? number_text(r.figures[f]) : std::string());
        row.push_back(r.wall_seconds > 0 ? fmt::format("{:.2f}", r.wall_seconds) : std::string());
        row.push_back(r.message);
        rows.push_back(std::move(row));
    }
    std::string csv, md;
    for (std::size_t c = 0; c < header.size(); ++c) {
        csv += (c ? "," : "") + csv_field(header[c]);
        md += "| " + markdown_cell(header[c]) + " ";
    }
    csv += "\n";
    md += "|\n";
    for (std::size_t c = 0; c < header.size(); ++c) md += "|---";
    md += "|\n";
    for (const auto &row : rows) {
        for (std::size_t c = 0; c < row.size(); ++c) {
            csv += (c ? "," : "") + csv_field(row[c]);
            md += "| " + markdown_cell(row[c].empty() ? std::string("-") : row[c]) + " ";
        }
        csv += "\n";
        md += "|\n";
    }
    std::vector<fs::path> files = {out / "summary.csv", out / "summary.md"};
    write_text_file(files[0], csv);
    write_text_file(files[1], md);

    if (!s.plot_figure.empty()) {
        const std::size_t f =
            static_cast<std::size_t>(std::find(s.figures.begin(), s.figures.end(), s.plot_figure) - s.figures.begin());
        const std::size_t x = s.plot_parameter;
        // One series per combination of the other parameters' values, in member order.
        std::map<std::vector<std::size_t>, std::size_t> series_of;
        XYPlot plot;
        plot.title = s.plot_figure + " against " + s.parameters[x].name;
        plot.x_label = s.parameters[x].name + " (" + s.parameters[x].path + ")";
        plot.y_label = s.plot_figure;
        static const char *colors[] = {"blue", "red", "green", "black", "magenta", "cyan", "orange", "brown"};
        for (std::size_t k = 0; k < s.members.size(); ++k) {
            std::vector<std::size_t> others = s.members[k].choice;
            others[x] = 0;
            auto [it, inserted] = series_of.emplace(others, plot.series.size());
            if (inserted) {
                PlotSeries series;
                series.style = PlotSeries::Style::line_points;
                series.color = colors[plot.series.size() % (sizeof colors / sizeof *colors)];
                for (std::size_t p = 0; p < s.parameters.size(); ++p)
                    if (p != x)
                        series.label += (series.label.empty() ? "" : ", ") + s.parameters[p].name + " = " +
                                        value_text(s.parameters[p].values[others[p]]);
                plot.series.push_back(series);
            }
            const double value = f < results[k].figures.size() ? results[k].figures[f] : not_available;
            auto &xy = plot.series[it->second].xy;
            xy.push_back(s.parameters[x].values[s.members[k].choice[x]].get<double>());
            xy.push_back(value); // NaN (failed, or no such barrier) leaves a gap
        }
        bool any = false;
        for (const auto &series : plot.series)
            for (std::size_t k = 1; k < series.xy.size(); k += 2) any = any || std::isfinite(series.xy[k]);
        if (any) {
            files.push_back(out / "summary.png");
            plot_xy_png(files.back(), plot);
        } else {
            spdlog::warn("sweep: no member has a value of {}; summary.png not drawn", s.plot_figure);
        }
    }
    return files;
}

} // namespace geobarrier::detail::sweeps
