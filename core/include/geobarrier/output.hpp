// Writing results: every file is written atomically (to a temporary name in
// the same folder, then renamed), so an interrupted run never leaves a
// half-written file that looks whole.
#ifndef GEOBARRIER_OUTPUT_HPP
#define GEOBARRIER_OUTPUT_HPP

#include <geobarrier/grid.hpp>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace geobarrier {

// Calls write(temp) with a fresh temporary path beside `target`, then renames
// temp to target. If write throws, the temporary file is removed and the
// exception propagates; `target` is untouched. Throws IoError on rename failure.
void write_file_atomically(const std::filesystem::path &target,
                           const std::function<void(const std::filesystem::path &temp)> &write);
void write_text_file(const std::filesystem::path &target, const std::string &text);

// One variable of fields.nc: shape (ny, nx), row index = y.
struct FieldVariable {
    std::string name;
    std::string long_name;
    std::string units; // "1" when dimensionless
    const std::vector<double> *values = nullptr;
    // Points whose mask has any of these bits get the _FillValue.
    std::uint8_t masked_by = mask_trajectory_bits;
};

// Writes a NetCDF-4 file with coordinate variables x (nx) and y (ny), the
// given variables of shape (ny, nx) with _FillValue where masked, and a `mask`
// variable (ubyte, CF flag_masks/flag_meanings saying why). Global attributes
// come from a flat JSON object of strings and numbers.
void write_fields_netcdf(const std::filesystem::path &file, const Grid &grid,
                         const std::vector<FieldVariable> &variables, const std::vector<std::uint8_t> &mask,
                         const nlohmann::json &global_attributes);

// A polyline drawn over a field picture.
struct PlotCurve {
    std::vector<double> xy; // x0, y0, x1, y1, ...
    std::string color = "red"; // a name from plot_colors() or "#rrggbb"
    double width = 1.5;
    bool closed = false;
};

// The colour names PlotCurve accepts (besides "#rrggbb").
std::vector<std::string> plot_colors();

struct FieldPlot {
    std::string title;
    std::string x_label = "x";
    std::string y_label = "y";
    std::string colorbar_label;
    std::vector<PlotCurve> curves;
    int width_px = 1200; // picture size; the height follows the box's aspect
};

// Draws a field as a colour map with axes, labels and a colour bar (PLplot,
// cairo PNG driver). Masked points are drawn in light grey.
void plot_field_png(const std::filesystem::path &file, const Grid &grid, const std::vector<double> &values,
                    const std::vector<std::uint8_t> &mask, const FieldPlot &plot);

}  // namespace geobarrier

#endif  // GEOBARRIER_OUTPUT_HPP
