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
#include <optional>
#include <string>
#include <utility>
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

// The names and units a system declares for its two state components (PluginInfo::state_names, state_units);
// empty: x and y, nondimensional.
struct StateAxes {
    std::vector<std::string> names, units;
};

// Writes a NetCDF-4 file with coordinate variables x (nx) and y (ny), the
// given variables of shape (ny, nx) with _FillValue where masked, and a `mask`
// variable (ubyte, CF flag_masks/flag_meanings saying why). Global attributes
// come from a flat JSON object of strings and numbers. Units are written as
// UDUNITS-2 strings: the coordinates' from `axes`; a unit in the model's own
// nondimensional vocabulary (cf_units: "time", "length", "state") becomes "1"
// with the meaning appended to long_name.
void write_fields_netcdf(const std::filesystem::path &file, const Grid &grid,
                         const std::vector<FieldVariable> &variables, const std::vector<std::uint8_t> &mask,
                         const nlohmann::json &global_attributes, const StateAxes &axes = {});

// A unit as fields.nc writes it: `units` valid for UDUNITS-2 / CF, and what long_name should add ("" if nothing).
struct CfUnits {
    std::string units, meaning;
};
CfUnits cf_units(const std::string &unit);

// The long_name and units fields.nc gives a variable, and the coordinate x (component 0) or y (1): for programs that
// hand the fields over in memory with the file's attributes (the Python module).
struct NetcdfAttributes {
    std::string long_name, units;
};
NetcdfAttributes variable_attributes(const FieldVariable &variable);
NetcdfAttributes coordinate_attributes(std::size_t component, const StateAxes &axes);
// The mask variable's CF flag attributes (grid.hpp's MaskBits): one definition for fields.nc and the Python module.
struct MaskAttributes {
    std::vector<unsigned char> flag_masks;
    std::string flag_meanings, long_name;
};
MaskAttributes mask_attributes();

// A polyline drawn over a field picture.
struct PlotCurve {
    std::vector<double> xy;    // x0, y0, x1, y1, ...
    std::string color = "red"; // a name from plot_colors() or "#rrggbb"
    double width = 1.5;
    bool closed = false;
    // Markers only (filled discs of marker_px diameter, in pixels), no line: e.g. points above a threshold.
    bool points_only = false;
    double marker_px = 5.0;
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

// One data series of an x-y picture: points (x, y interleaved) drawn as a line, as markers (filled discs), or
// both. Non-finite points split a line into pieces (a gap), as in PlotCurve.
struct PlotSeries {
    enum class Style { line, points, line_points };
    enum class Dash { solid, dashed, dotted };
    std::vector<double> xy;
    std::string label;          // shown in the legend; empty = not listed
    std::string color = "blue"; // a name from plot_colors() or "#rrggbb"
    double width = 1.5;         // line width
    Style style = Style::line;
    Dash dash = Dash::solid;
    double marker_px = 5.0; // marker diameter in pixels
    bool closed = false;    // join the last point to the first (lines only)
};

// An x-y picture: axes with ticks and labels, a title, series and, when any series has a label, a legend.
struct XYPlot {
    enum class Legend { top_right, top_left, bottom_right, bottom_left, outside_right };
    std::string title;
    std::string x_label = "x";
    std::string y_label = "y";
    std::vector<PlotSeries> series;
    bool log_x = false, log_y = false; // logarithmic axes (non-positive values are left out)
    bool equal_aspect = false;         // one unit of x as long as one of y (clamped to 1:4 ... 4:1)
    double aspect = 0.6;               // box height / width when not equal_aspect
    std::optional<std::pair<double, double>> x_range, y_range; // default: the data's, padded by 3%
    Legend legend = Legend::top_right;
    int width_px = 1200;
};

// Draws an x-y picture (PLplot, cairo PNG driver) with the fonts, ticks and colours of plot_field_png, written
// atomically.
void plot_xy_png(const std::filesystem::path &file, const XYPlot &plot);

// A 3-D picture (e.g. curves in extended phase space (x, y, t), a tube swept by an advected closed curve).
// Coordinates are x, y, z interleaved; z is drawn upwards.
struct PlotSeries3D {
    std::vector<double> xyz;
    std::string label; // legend entry; empty = not listed
    std::string color = "blue";
    double width = 1.5;
    bool closed = false;
};
// A surface given as a structured mesh: `rows` x `cols` points, point (r, c) at xyz[3 * (r * cols + c)]; with
// `wrap_cols` column cols - 1 joins column 0 (a tube). Faces are shaded by their orientation to the viewer.
struct PlotSurface3D {
    std::vector<double> xyz;
    std::size_t rows = 0, cols = 0;
    bool wrap_cols = true;
    std::string color = "blue";
    double opacity = 0.85; // 0 (invisible) ... 1 (opaque)
};
struct XYZPlot {
    std::string title;
    std::string x_label = "x", y_label = "y", z_label = "t";
    std::vector<PlotSeries3D> series;
    std::vector<PlotSurface3D> surfaces;
    double altitude_deg = 25.0; // viewing elevation above the x-y plane
    double azimuth_deg = 35.0;  // rotation of the view around the z axis
    int width_px = 1200;
};
void plot_xyz_png(const std::filesystem::path &file, const XYZPlot &plot);

} // namespace geobarrier

#endif // GEOBARRIER_OUTPUT_HPP
