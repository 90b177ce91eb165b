// Private to core/src/plot: what the three kinds of picture (plot_field.cpp, plot_xy.cpp, plot_xyz.cpp) share, defined
// in plot.cpp: colours, the palette, tick rules and labels, page set-up, the box with its axes and title, polylines
// and markers, argument checks, and write_picture, which serialises PLplot (global state), drawing into memory, and
// writes the PNG atomically outside the lock.
#pragma once

#include <geobarrier/errors.hpp>
#include <geobarrier/output.hpp>

#include <plplot.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <string>
#include <vector>

namespace geobarrier::plot_internal {

struct Rgb {
    int r = 0, g = 0, b = 0;
};

const std::map<std::string, Rgb> &named_colors();

int hex_digit(char c);

Rgb parse_color(const std::string &text, const char *where = "plot_field_png");

// PLplot reads '#' as the start of an escape sequence; labels are plain UTF-8 text, so '#' is doubled.

std::string plain_text(const std::string &text);

// Viridis (perceptually uniform, readable in grey and by colour-blind readers) sampled at 8 evenly spaced points;
// PLplot interpolates linearly in RGB between them.

void set_viridis_cmap1();

// cmap0 slots used below; set explicitly so the picture never depends on PLplot's default palette. x-y and 3-D
// pictures add one slot per series after slot_count (the legend refers to colours by slot).
enum Cmap0Slot : PLINT {
    slot_background = 0,
    slot_ink = 1,
    slot_masked = 2,
    slot_curve = 3,
    slot_count = 4,
    slot_grid = 4,    // x-y and 3-D only: grid lines
    slot_legend = 5,  // x-y only: the legend's frame
    slot_scratch = 6, // 3-D only: per-face colours
    slot_xy_count = 7
};

struct ColorRange {
    double low = 0.0, high = 1.0;
};

// Values beyond +-1e300 are treated like infinities: the width of the colour range must stay finite.

bool plottable(double v);

// The colour scale spans the finite values at unmasked points only, so one NaN or a blown-up masked trajectory
// cannot wash out the picture. A constant field gets a small symmetric range around its value.

ColorRange color_range(const std::vector<double> &values, const std::vector<std::uint8_t> &mask);

// Tick marks at a "nice" step (1, 2, 2.5 or 5 times a power of ten), labelled with one number of decimals for
// the whole axis; very large or small magnitudes are written as m×10^e on each label. A logarithmic axis works
// in log10 units: ticks at whole decades, labelled 0.01 ... 10000 or 10^e beyond.
struct Ticks {
    double step = 1.0;
    int decimals = 0;
    int exponent = 0; // 0: plain numbers
    bool log = false;
};

Ticks make_ticks(double low, double high, double target_count);

// low, high in log10 units.

Ticks make_log_ticks(double low, double high, double target_count);

std::string format_tick(double value, const Ticks &ticks);

// How many character widths a label takes on the page: UTF-8 continuation bytes and PLplot's #u/#d escapes take
// no room, superscripts about 0.7 of a character.

double visible_chars(const std::string &text);

// How many characters the widest tick label of an axis over [low, high] takes.

double label_chars(double low, double high, const Ticks &ticks);

void write_label(const Ticks &ticks, PLFLT value, char *label, PLINT length);

// Everything is measured in pixels, derived from the width so that every size scales together. The cairo driver
// draws text at 72 dots per inch whatever plspage says, so character heights in mm are converted with that.
constexpr double dots_per_inch = 72.0;

constexpr double char_width = 0.62;        // glyph width / character height, sans-serif digits, generous
constexpr double legend_char_width = 0.75; // the same in legend text as PLplot lays it out (measured, digits)
constexpr double label_scale = 1.1;        // axis and colour bar labels relative to tick labels
constexpr double title_scale = 1.25;

// The tick-label character height in pixels for a picture `width_px` wide: small pictures keep legible text.

double char_px_for(int width_px);

double px_to_mm(double px);

struct Layout {
    int width = 0, height = 0;
    double char_px = 0;                              // tick label character height
    double left = 0, right = 0, top = 0, bottom = 0; // margins around the plot box
    double bar_gap = 0, bar_width = 0;               // colour bar: distance from the box, width
    double y_label_disp = 0, bar_label_disp = 0;     // plmtex displacements, in label character heights
    Ticks x_ticks, y_ticks, bar_ticks;
    double box_width() const { return width - left - right; }
    double box_height() const { return height - top - bottom; }
};

void check_width(const char *where, int width_px);

void check_line_width(const char *where, double width);

void check_marker(const char *where, double marker_px);

// PLplot reports recoverable errors through plsError instead of printing them when these are registered.
struct PlplotErrors {
    PLINT code = 0;
    char message[1024] = {0};
};

// One PLplot stream, ended (and the previous stream restored) however drawing leaves the scope.
class PlplotStream {
  public:
    PlplotStream() {
        plgstrm(&m_previous);
        PLINT stream = 0;
        plmkstrm(&stream);
        if (stream < 0) throw Error("plot: PLplot has no free stream");
    }
    ~PlplotStream() {
        plend1();
        plsstrm(m_previous);
    }
    PlplotStream(const PlplotStream &) = delete;
    PlplotStream &operator=(const PlplotStream &) = delete;

  private:
    PLINT m_previous = 0;
};

// Opens a page of width x height pixels in memory (current_page, PLplot's memcairo driver) with the shared palette
// and font; `file` names the picture in messages.

void begin_page(const std::filesystem::path &file, int width, int height, PLINT cmap0_slots, PlplotErrors &errors);

void set_color(PLINT slot, const Rgb &rgb, double alpha = 1.0);

// The tick formats of the two axes, handed to PLplot's label callback (which gets one pointer).
struct AxisFormats {
    Ticks x, y;
};

void label_both_axes(PLINT axis, PLFLT value, char *label, PLINT length, PLPointer data);

// The frame, ticks, tick labels, axis labels and title of a 2-D box, in the ink colour. `formats` must outlive
// the call. x_opt/y_opt are plbox options (custom labels "o" are added here).
// Where a title goes: centred over the box when it fits there, else centred on the page, and made smaller when it
// is wider than the page (position as a fraction of the box's width, from its left edge).
struct TitlePlacement {
    double position = 0.5;
    double scale = title_scale;
};

TitlePlacement place_title(const std::string &title, double ch, double left_px, double box_px, double page_px);

void draw_box(const AxisFormats &formats, const std::string &x_opt, const std::string &y_opt, double char_mm,
              double y_label_disp, const std::string &x_label, const std::string &y_label, const std::string &title,
              const TitlePlacement &title_place = {});

// A polyline's points thinned (Douglas-Peucker) to those that keep every dropped point within `tolerance_px` pixels
// of the line drawn; `px_x`, `px_y`: world units per pixel on each axis. The kept points are original points, so
// the thinned line also stays within `tolerance_px` of the original (each chord is covered by the projection of the
// stretch of the original it replaces). Curves reach the pictures with far more points than pixels (W's strainlines:
// 1.9 million), and cairo's stroking costs by the segment: the serial part of a run that a frames run overlaps.
void decimate_polyline(std::vector<double> &x, std::vector<double> &y, double px_x, double px_y, double tolerance_px);

// A quarter of a pixel: an antialiased line of the thinned points covers the same pixels to the eye.
constexpr double decimation_tolerance_px = 0.25;

// Splits a polyline (x, y arrays) at non-finite points and draws each piece, thinned to the picture's pixels
// (decimate_polyline, `px_x` and `px_y` world units per pixel); a closed curve is joined back to its start only
// when it has no gaps (a gap means the loop is not whole).

void draw_polyline(const std::vector<double> &x, const std::vector<double> &y, bool closed, double px_x, double px_y);

// Filled discs of `diameter_px` at the finite points, in the current colour. `px_x`, `px_y`: world units per
// pixel on each axis, so the discs are round on the page whatever the axes' scales.

void draw_markers(const std::vector<double> &x, const std::vector<double> &y, double diameter_px, double px_x,
                  double px_y);

// Splits interleaved x, y into two arrays.

void split_xy(const std::vector<double> &xy, std::vector<double> &x, std::vector<double> &y);

// Asked for a device it does not have, PLplot prompts on stdin; check for the driver first instead.

void require_memcairo();

std::mutex &plplot_mutex();

// A picture's pixels, 8-bit RGB row by row from the top.
struct PageRaster {
    int width = 0, height = 0;
    std::vector<unsigned char> rgb;
};

// The page PLplot's memcairo driver draws into: begin_page sizes it (white), plend1 fills it. One page at a time,
// under plplot_mutex, as PLplot draws.
PageRaster &current_page();

// Writes `page` as an 8-bit RGB PNG, atomically (libpng's defaults: zlib level 6, adaptive filters).
void write_png(const std::filesystem::path &file, const PageRaster &page);

// Draws with `draw(file, errors)` (`file`: for messages) under the PLplot lock into memory, then compresses and
// writes the PNG after releasing it: PLplot's global state allows one picture at a time, but the compression (a
// fifth of a picture's cost) needs none of it, so two frames' pictures compress while a third draws.
template <class Draw> void write_picture(const std::filesystem::path &file, const Draw &draw) {
    PageRaster page;
    {
        std::lock_guard<std::mutex> lock(plplot_mutex());
        require_memcairo();
        PlplotErrors errors;
        {
            PlplotStream stream;
            draw(file, errors);
        } // plend1 copies the page into current_page()
        page = std::move(current_page());
        current_page() = PageRaster{};
        if (errors.code != 0) throw IoError("'" + file.string() + "': PLplot failed: " + errors.message);
    }
    write_png(file, page);
}

} // namespace geobarrier::plot_internal
