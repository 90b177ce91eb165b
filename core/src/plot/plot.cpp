// Pictures (PLplot, cairo PNG driver), written atomically: a scalar field on the grid G0 as a colour map with a
// colour bar and curves over it, x-y pictures (lines, point clouds, time series, with a legend) and 3-D pictures
// (curves and shaded tubes in extended phase space). All share one set of fonts, tick rules and colours.
// PLplot keeps global state, so all drawing is serialised.
#include <geobarrier/errors.hpp>
#include <geobarrier/output.hpp>

#include <plplot.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <string>

namespace geobarrier {

namespace {

struct Rgb {
    int r = 0, g = 0, b = 0;
};

const std::map<std::string, Rgb> &named_colors() {
    static const std::map<std::string, Rgb> colors{
        {"black", {0, 0, 0}},       {"white", {255, 255, 255}}, {"red", {214, 39, 40}},
        {"blue", {31, 119, 180}},   {"grey", {128, 128, 128}},  {"gray", {128, 128, 128}},
        {"orange", {255, 127, 14}}, {"green", {44, 160, 44}},   {"magenta", {227, 24, 196}},
        {"cyan", {23, 190, 207}},   {"yellow", {255, 221, 0}},  {"purple", {148, 103, 189}},
        {"brown", {140, 86, 75}},   {"pink", {247, 129, 191}},
    };
    return colors;
}

int hex_digit(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    return -1;
}

Rgb parse_color(const std::string &text, const char *where = "plot_field_png") {
    std::string name;
    for (char c : text) name += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const auto found = named_colors().find(name);
    if (found != named_colors().end()) return found->second;
    if (name.size() == 7 && name[0] == '#') {
        std::array<int, 6> digits{};
        bool ok = true;
        for (std::size_t i = 0; i < 6; ++i) ok = ok && (digits[i] = hex_digit(name[i + 1])) >= 0;
        if (ok) return {digits[0] * 16 + digits[1], digits[2] * 16 + digits[3], digits[4] * 16 + digits[5]};
    }
    std::string known;
    for (const auto &entry : named_colors()) known += (known.empty() ? "" : ", ") + entry.first;
    throw Error(std::string(where) + ": unknown colour '" + text + "'; use one of " + known + " or #rrggbb");
}

// PLplot reads '#' as the start of an escape sequence; labels are plain UTF-8 text, so '#' is doubled.
std::string plain_text(const std::string &text) {
    std::string out;
    for (char c : text) {
        out += c;
        if (c == '#') out += '#';
    }
    return out;
}

// Viridis (perceptually uniform, readable in grey and by colour-blind readers) sampled at 8 evenly spaced points;
// PLplot interpolates linearly in RGB between them.
void set_viridis_cmap1() {
    static const std::array<PLFLT, 8> position{0.0, 1.0 / 7, 2.0 / 7, 3.0 / 7, 4.0 / 7, 5.0 / 7, 6.0 / 7, 1.0};
    static const std::array<PLFLT, 8> red{68, 70, 54, 39, 31, 74, 160, 253};
    static const std::array<PLFLT, 8> green{1, 50, 92, 127, 161, 193, 218, 231};
    static const std::array<PLFLT, 8> blue{84, 126, 141, 142, 135, 109, 57, 37};
    std::array<PLFLT, 8> r{}, g{}, b{};
    for (std::size_t i = 0; i < 8; ++i) {
        r[i] = red[i] / 255.0;
        g[i] = green[i] / 255.0;
        b[i] = blue[i] / 255.0;
    }
    plscmap1n(256);
    plscmap1l(1, 8, position.data(), r.data(), g.data(), b.data(), nullptr);
}

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
bool plottable(double v) { return std::abs(v) <= 1e300; }

// The colour scale spans the finite values at unmasked points only, so one NaN or a blown-up masked trajectory
// cannot wash out the picture. A constant field gets a small symmetric range around its value.
ColorRange color_range(const std::vector<double> &values, const std::vector<std::uint8_t> &mask) {
    double low = std::numeric_limits<double>::infinity(), high = -low;
    for (std::size_t k = 0; k < values.size(); ++k) {
        if (mask[k] != 0 || !plottable(values[k])) continue;
        low = std::min(low, values[k]);
        high = std::max(high, values[k]);
    }
    if (!(low <= high)) return {0.0, 1.0};
    if (high - low <= 1e-12 * std::max(std::abs(low), std::abs(high))) {
        const double half = std::abs(low) > 0.0 ? 1e-3 * std::abs(low) : 1e-3;
        return {low - half, high + half};
    }
    return {low, high};
}

// Tick marks at a "nice" step (1, 2, 2.5 or 5 times a power of ten), labelled with one number of decimals for
// the whole axis; very large or small magnitudes are written as m×10^e on each label. A logarithmic axis works
// in log10 units: ticks at whole decades, labelled 0.01 ... 10000 or 10^e beyond.
struct Ticks {
    double step = 1.0;
    int decimals = 0;
    int exponent = 0; // 0: plain numbers
    bool log = false;
};

Ticks make_ticks(double low, double high, double target_count) {
    Ticks ticks;
    const double raw = (high - low) / std::max(target_count, 1.0);
    const double power = std::pow(10.0, std::floor(std::log10(raw)));
    const double mantissa = raw / power;
    const double nice = mantissa < 1.5    ? 1.0
                        : mantissa < 2.25 ? 2.0
                        : mantissa < 3.5  ? 2.5
                        : mantissa < 7.5  ? 5.0
                                          : 10.0;
    ticks.step = nice * power;
    // The exponent of the largest tick, so the top label reads 1.0×10^-4 rather than 10×10^-5.
    const double largest =
        std::max(std::abs(std::round(low / ticks.step)), std::abs(std::round(high / ticks.step))) * ticks.step;
    if (largest >= 1e5 || (largest > 0.0 && largest < 1e-3))
        ticks.exponent = static_cast<int>(std::floor(std::log10(largest)));
    const int step_exponent = static_cast<int>(std::floor(std::log10(ticks.step) + 1e-9));
    ticks.decimals = std::max(0, ticks.exponent - step_exponent + (nice == 2.5 ? 1 : 0));
    return ticks;
}

// low, high in log10 units.
Ticks make_log_ticks(double low, double high, double target_count) {
    Ticks ticks;
    ticks.log = true;
    ticks.step = std::max(1.0, std::ceil((high - low) / std::max(target_count, 1.0)));
    return ticks;
}

std::string format_tick(double value, const Ticks &ticks) {
    char buffer[64];
    if (ticks.log) {
        const long decade = std::lround(value);
        if (decade >= -3 && decade <= 4)
            std::snprintf(buffer, sizeof buffer, "%.*f", static_cast<int>(std::max(0L, -decade)),
                          std::pow(10.0, static_cast<double>(decade)));
        else
            std::snprintf(buffer, sizeof buffer, "10#u%ld#d", decade);
        return buffer;
    }
    if (std::abs(value) < 1e-6 * ticks.step) value = 0.0; // no "-0.0" from rounding at the origin
    if (ticks.exponent == 0 || value == 0.0) {
        std::snprintf(buffer, sizeof buffer, "%.*f", ticks.exponent == 0 ? ticks.decimals : 0, value);
    } else {
        // "×" in UTF-8 (the cairo driver draws Unicode text); #u...#d is PLplot's superscript escape.
        std::snprintf(buffer, sizeof buffer, "%.*f\u00d710#u%d#d", ticks.decimals,
                      value / std::pow(10.0, ticks.exponent), ticks.exponent);
    }
    return buffer;
}

// How many character widths a label takes on the page: UTF-8 continuation bytes and PLplot's #u/#d escapes take
// no room, superscripts about 0.7 of a character.
double visible_chars(const std::string &text) {
    double chars = 0.0;
    bool superscript = false;
    for (std::size_t k = 0; k < text.size(); ++k) {
        const unsigned char c = static_cast<unsigned char>(text[k]);
        if (c == '#' && k + 1 < text.size() && (text[k + 1] == 'u' || text[k + 1] == 'd')) {
            superscript = text[k + 1] == 'u';
            ++k;
            continue;
        }
        if (c == '#' && k + 1 < text.size() && text[k + 1] == '#') ++k;
        if ((c & 0xC0) == 0x80) continue;
        chars += superscript ? 0.7 : 1.0;
    }
    return chars;
}

// How many characters the widest tick label of an axis over [low, high] takes.
double label_chars(double low, double high, const Ticks &ticks) {
    double widest = 1.0;
    for (double v = std::ceil(low / ticks.step) * ticks.step; v <= high + 1e-9 * ticks.step; v += ticks.step)
        widest = std::max(widest, visible_chars(format_tick(v, ticks)));
    return widest;
}

void write_label(const Ticks &ticks, PLFLT value, char *label, PLINT length) {
    std::snprintf(label, static_cast<std::size_t>(length), "%s", format_tick(value, ticks).c_str());
}

// Everything is measured in pixels, derived from the width so that every size scales together. The cairo driver
// draws text at 72 dots per inch whatever plspage says, so character heights in mm are converted with that.
constexpr double dots_per_inch = 72.0;
constexpr double char_width = 0.62;        // glyph width / character height, sans-serif digits, generous
constexpr double legend_char_width = 0.75; // the same in legend text as PLplot lays it out (measured, digits)
constexpr double label_scale = 1.1;        // axis and colour bar labels relative to tick labels
constexpr double title_scale = 1.25;

// The tick-label character height in pixels for a picture `width_px` wide: small pictures keep legible text.
double char_px_for(int width_px) { return std::max(1.45 * width_px / 100.0, 11.0); }
double px_to_mm(double px) { return px * 25.4 / dots_per_inch; }

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

Layout make_layout(int width_px, double x0, double x1, double y0, double y1, double v0, double v1,
                   const FieldPlot &plot) {
    Layout layout;
    layout.width = width_px;
    const double ch = char_px_for(width_px);
    layout.char_px = ch;
    layout.bar_gap = 2.0 * ch;
    layout.bar_width = 1.6 * ch;
    layout.top = plot.title.empty() ? 1.5 * ch : 4.0 * ch;
    layout.bottom = 5.4 * ch;
    // The box keeps the data's aspect ratio (one unit of x as long as one of y) unless that would make the
    // picture absurdly tall or flat; then it is clamped to 1:4 or 4:1.
    const double aspect = std::clamp((y1 - y0) / (x1 - x0), 0.25, 4.0);
    // The margins depend on the tick labels, which depend on the box's size: two rounds settle it.
    layout.left = 10.0 * ch;
    layout.right = 12.0 * ch;
    for (int round = 0; round < 2; ++round) {
        const double box_w = width_px - layout.left - layout.right;
        const double box_h = box_w * aspect;
        layout.x_ticks = make_ticks(x0, x1, std::clamp(box_w / (7.0 * ch), 3.0, 10.0));
        layout.y_ticks = make_ticks(y0, y1, std::clamp(box_h / (5.0 * ch), 2.0, 10.0));
        layout.bar_ticks = make_ticks(v0, v1, std::clamp(box_h / (5.0 * ch), 2.0, 10.0));
        const double y_labels = char_width * ch * label_chars(y0, y1, layout.y_ticks);
        const double bar_labels = char_width * ch * label_chars(v0, v1, layout.bar_ticks);
        // Tick labels sit about 0.7 character heights from the axis; the rotated label's baseline is one gap further.
        const double y_label_px = 0.7 * ch + y_labels + 1.0 * ch + label_scale * ch;
        layout.left = y_label_px + 1.0 * ch;
        layout.y_label_disp = y_label_px / (label_scale * ch);
        const double bar_label_px = layout.bar_gap + layout.bar_width + 0.7 * ch + bar_labels + 1.0 * ch +
                                    (plot.colorbar_label.empty() ? 0.0 : label_scale * ch);
        layout.right = bar_label_px + 1.5 * ch;
        layout.bar_label_disp = bar_label_px / (label_scale * ch);
    }
    layout.height = static_cast<int>(std::lround(layout.box_width() * aspect + layout.top + layout.bottom));
    return layout;
}

void check_width(const char *where, int width_px) {
    if (width_px < 200 || width_px > 10000)
        throw Error(std::string(where) + ": width_px = " + std::to_string(width_px) + " is outside [200, 10000]");
}

void check_line_width(const char *where, double width) {
    if (!(width > 0.0 && width < 100.0))
        throw Error(std::string(where) + ": a line width " + std::to_string(width) + " is outside (0, 100)");
}

void check_marker(const char *where, double marker_px) {
    if (!(marker_px > 0.0 && marker_px <= 100.0))
        throw Error(std::string(where) + ": a marker size " + std::to_string(marker_px) + " px is outside (0, 100]");
}

void check_arguments(const Grid &grid, const std::vector<double> &values, const std::vector<std::uint8_t> &mask,
                     const FieldPlot &plot) {
    const std::string where = "plot_field_png: ";
    if (grid.nx < 2 || grid.ny < 2)
        throw Error(where + "the grid needs at least 2 x 2 points, got " + std::to_string(grid.nx) + " x " +
                    std::to_string(grid.ny));
    if (!(std::isfinite(grid.x_min) && std::isfinite(grid.x_max) && grid.x_min < grid.x_max &&
          std::isfinite(grid.y_min) && std::isfinite(grid.y_max) && grid.y_min < grid.y_max))
        throw Error(where + "the grid's bounds must be finite with min < max");
    if (values.size() != grid.size() || mask.size() != grid.size())
        throw Error(where + std::to_string(values.size()) + " values and " + std::to_string(mask.size()) +
                    " mask entries for a grid of " + std::to_string(grid.size()) + " points");
    check_width("plot_field_png", plot.width_px);
    for (const PlotCurve &curve : plot.curves) {
        if (curve.xy.size() % 2 != 0)
            throw Error(where + "a curve has an odd number of coordinates (" + std::to_string(curve.xy.size()) + ")");
        check_line_width("plot_field_png", curve.width);
        if (curve.points_only) check_marker("plot_field_png", curve.marker_px);
        parse_color(curve.color);
    }
}

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

// Opens a page of width x height pixels on the PNG driver with the shared palette and font.
void begin_page(const std::filesystem::path &file, int width, int height, PLINT cmap0_slots, PlplotErrors &errors) {
    plsError(&errors.code, errors.message);
    plsdev("pngcairo");
    plsfnam(file.c_str());
    plspage(dots_per_inch, dots_per_inch, width, height, 0, 0);
    // Images as one raster rather than a polygon per cell: faster, and no hairline seams between cells.
    plsetopt("drvopt", "rasterize_image=1");
    plscolbg(255, 255, 255);
    plscmap0n(cmap0_slots);
    plscol0(slot_background, 255, 255, 255);
    plscol0(slot_ink, 0, 0, 0);
    plscol0(slot_masked, 211, 211, 211);
    set_viridis_cmap1();
    plsfont(PL_FCI_SANS, PL_FCI_UPRIGHT, PL_FCI_MEDIUM);
    plinit();
    if (errors.code != 0) throw IoError("'" + file.string() + "': PLplot cannot start: " + errors.message);
    pladv(0);
}

void set_color(PLINT slot, const Rgb &rgb, double alpha = 1.0) {
    if (alpha >= 1.0)
        plscol0(slot, rgb.r, rgb.g, rgb.b);
    else
        plscol0a(slot, rgb.r, rgb.g, rgb.b, alpha);
    plcol0(slot);
}

// The tick formats of the two axes, handed to PLplot's label callback (which gets one pointer).
struct AxisFormats {
    Ticks x, y;
};

void label_both_axes(PLINT axis, PLFLT value, char *label, PLINT length, PLPointer data) {
    const auto *formats = static_cast<const AxisFormats *>(data);
    write_label(axis == PL_X_AXIS ? formats->x : formats->y, value, label, length);
}

// The frame, ticks, tick labels, axis labels and title of a 2-D box, in the ink colour. `formats` must outlive
// the call. x_opt/y_opt are plbox options (custom labels "o" are added here).
// Where a title goes: centred over the box when it fits there, else centred on the page, and made smaller when it
// is wider than the page (position as a fraction of the box's width, from its left edge).
struct TitlePlacement {
    double position = 0.5;
    double scale = title_scale;
};

TitlePlacement place_title(const std::string &title, double ch, double left_px, double box_px, double page_px) {
    TitlePlacement place;
    const double width = visible_chars(title) * char_width * ch * title_scale;
    if (width <= box_px) return place;
    place.position = (0.5 * page_px - left_px) / box_px;
    if (width > page_px - 2.0 * ch) place.scale = title_scale * (page_px - 2.0 * ch) / width;
    return place;
}

void draw_box(const AxisFormats &formats, const std::string &x_opt, const std::string &y_opt, double char_mm,
              double y_label_disp, const std::string &x_label, const std::string &y_label, const std::string &title,
              const TitlePlacement &title_place = {}) {
    plwidth(1.0);
    plcol0(slot_ink);
    pllsty(1);
    plschr(char_mm, 1.0);
    plsmaj(0.6 * char_mm, 1.0);
    plsmin(0.3 * char_mm, 1.0);
    plslabelfunc(label_both_axes, const_cast<AxisFormats *>(&formats));
    plbox((x_opt + "o").c_str(), formats.x.step, 0, (y_opt + "o").c_str(), formats.y.step, 0);
    plschr(char_mm, label_scale);
    plmtex("b", 3.0, 0.5, 0.5, plain_text(x_label).c_str());
    plmtex("l", y_label_disp, 0.5, 0.5, plain_text(y_label).c_str());
    if (!title.empty()) {
        plschr(char_mm, title_place.scale);
        plmtex("t", 1.3 * title_scale / title_place.scale, title_place.position, 0.5, plain_text(title).c_str());
    }
    plslabelfunc(nullptr, nullptr);
}

// Splits a polyline (x, y arrays) at non-finite points and draws each piece; a closed curve is joined back to its
// start only when it has no gaps (a gap means the loop is not whole).
void draw_polyline(const std::vector<double> &x, const std::vector<double> &y, bool closed) {
    std::vector<PLFLT> xs, ys;
    bool all_finite = true;
    auto flush = [&] {
        if (xs.size() >= 2) plline(static_cast<PLINT>(xs.size()), xs.data(), ys.data());
        xs.clear();
        ys.clear();
    };
    for (std::size_t p = 0; p < x.size(); ++p) {
        if (!std::isfinite(x[p]) || !std::isfinite(y[p])) {
            all_finite = false;
            flush();
            continue;
        }
        xs.push_back(x[p]);
        ys.push_back(y[p]);
    }
    if (closed && all_finite && x.size() >= 3) {
        xs.push_back(x[0]);
        ys.push_back(y[0]);
    }
    flush();
}

// Filled discs of `diameter_px` at the finite points, in the current colour. `px_x`, `px_y`: world units per
// pixel on each axis, so the discs are round on the page whatever the axes' scales.
void draw_markers(const std::vector<double> &x, const std::vector<double> &y, double diameter_px, double px_x,
                  double px_y) {
    constexpr int sides = 16;
    std::array<double, sides> cosines{}, sines{};
    for (int k = 0; k < sides; ++k) {
        cosines[k] = std::cos(2.0 * M_PI * k / sides);
        sines[k] = std::sin(2.0 * M_PI * k / sides);
    }
    const double rx = 0.5 * diameter_px * px_x, ry = 0.5 * diameter_px * px_y;
    std::array<PLFLT, sides> xs{}, ys{};
    for (std::size_t p = 0; p < x.size(); ++p) {
        if (!std::isfinite(x[p]) || !std::isfinite(y[p])) continue;
        for (int k = 0; k < sides; ++k) {
            xs[k] = x[p] + rx * cosines[k];
            ys[k] = y[p] + ry * sines[k];
        }
        plfill(sides, xs.data(), ys.data());
    }
}

// Splits interleaved x, y into two arrays.
void split_xy(const std::vector<double> &xy, std::vector<double> &x, std::vector<double> &y) {
    const std::size_t n = xy.size() / 2;
    x.resize(n);
    y.resize(n);
    for (std::size_t p = 0; p < n; ++p) {
        x[p] = xy[2 * p];
        y[p] = xy[2 * p + 1];
    }
}

// ------------------------------------------------------------------------------------------------ field pictures

// Draws one curve over a field, split wherever a point is not finite (a curve may carry NaN as a gap).
void draw_curve(const PlotCurve &curve, double px_x, double px_y) {
    set_color(slot_curve, parse_color(curve.color));
    plwidth(curve.width);
    std::vector<double> x, y;
    split_xy(curve.xy, x, y);
    if (curve.points_only)
        draw_markers(x, y, curve.marker_px, px_x, px_y);
    else
        draw_polyline(x, y, curve.closed);
}

void draw_field(const std::filesystem::path &file, const Grid &grid, const std::vector<double> &values,
                const std::vector<std::uint8_t> &mask, const FieldPlot &plot, PlplotErrors &errors) {
    // The image's cells are centred on the grid points, so the box reaches half a cell beyond the outer points.
    const double half_dx = 0.5 * grid.dx(), half_dy = 0.5 * grid.dy();
    const double x0 = grid.x_min - half_dx, x1 = grid.x_max + half_dx;
    const double y0 = grid.y_min - half_dy, y1 = grid.y_max + half_dy;
    const ColorRange range = color_range(values, mask);
    const Layout layout = make_layout(plot.width_px, x0, x1, y0, y1, range.low, range.high, plot);
    const double w = layout.width, h = layout.height;
    const double char_mm = px_to_mm(layout.char_px);

    begin_page(file, layout.width, layout.height, slot_count, errors);
    plvpor(layout.left / w, 1.0 - layout.right / w, layout.bottom / h, 1.0 - layout.top / h);
    plwind(x0, x1, y0, y1);

    // Masked points show the grey underneath: they are given a value above zmax, which plimagefr skips.
    plcol0(slot_masked);
    const std::array<PLFLT, 4> box_x{x0, x1, x1, x0}, box_y{y0, y0, y1, y1};
    plfill(4, box_x.data(), box_y.data());
    const double skip = range.high + 1.0 + std::abs(range.high - range.low);
    std::vector<PLFLT> column_major(grid.size());
    std::vector<const PLFLT *> columns(grid.nx);
    for (std::size_t j = 0; j < grid.nx; ++j) {
        for (std::size_t i = 0; i < grid.ny; ++i) {
            const double v = values[i * grid.nx + j];
            column_major[j * grid.ny + i] = (mask[i * grid.nx + j] != 0 || !plottable(v)) ? skip : v;
        }
        columns[j] = column_major.data() + j * grid.ny;
    }
    // plimagefr without a transform spreads the nx values over nx - 1 steps of (xmax - xmin) / (nx - 1) and draws
    // value j on [xmin + j step, xmin + (j + 1) step]: with xmax one cell short of x1, cell j is centred on x(j).
    plimagefr(columns.data(), static_cast<PLINT>(grid.nx), static_cast<PLINT>(grid.ny), x0, x1 - grid.dx(), y0,
              y1 - grid.dy(), range.low, range.high, range.low, range.high, nullptr, nullptr);

    const double px_x = (x1 - x0) / layout.box_width(), px_y = (y1 - y0) / layout.box_height();
    for (const PlotCurve &curve : plot.curves) draw_curve(curve, px_x, px_y);

    // Axes: PLplot's x and y tick labels both go through one label function, pointed at each axis's format.
    const AxisFormats main_axes{layout.x_ticks, layout.y_ticks};
    draw_box(main_axes, "bcnst", "bcnstv", char_mm, layout.y_label_disp, plot.x_label, plot.y_label, plot.title,
             place_title(plot.title, layout.char_px, layout.left, layout.box_width(), layout.width));

    // Colour bar to the right of the box, as tall as the box; its label is placed here rather than by
    // plcolorbar, which does not know how wide our custom tick labels are. The colour bar's axis is a y axis.
    plschr(char_mm, 1.0);
    const AxisFormats bar_axis{layout.bar_ticks, layout.bar_ticks};
    plslabelfunc(label_both_axes, const_cast<AxisFormats *>(&bar_axis));
    const char *axis_opts = "bcvtmo";
    const PLFLT bar_step = layout.bar_ticks.step;
    const PLINT sub_ticks = 0;
    const PLINT n_values = 2;
    const std::array<PLFLT, 2> bar_values{range.low, range.high};
    const PLFLT *bar_values_ptr = bar_values.data();
    const double box_w = layout.box_width();
    PLFLT bar_width = 0.0, bar_height = 0.0;
    plcolorbar(&bar_width, &bar_height, PL_COLORBAR_GRADIENT,
               PL_POSITION_RIGHT | PL_POSITION_OUTSIDE | PL_POSITION_VIEWPORT, layout.bar_gap / box_w, 0.0,
               layout.bar_width / box_w, 1.0, slot_background, slot_ink, 1, 0.0, 0.0, slot_ink, 1.0, 0, nullptr,
               nullptr, 1, &axis_opts, &bar_step, &sub_ticks, &n_values, &bar_values_ptr);
    plslabelfunc(nullptr, nullptr);
    if (!plot.colorbar_label.empty()) {
        plvpor(layout.left / w, 1.0 - layout.right / w, layout.bottom / h, 1.0 - layout.top / h);
        plschr(char_mm, label_scale);
        plmtex("r", layout.bar_label_disp, 0.5, 0.5, plain_text(plot.colorbar_label).c_str());
    }
    if (errors.code != 0) throw IoError("'" + file.string() + "': PLplot failed: " + errors.message);
}

// ------------------------------------------------------------------------------------------------ x-y pictures

// A series in plotting units (log10 of the data on logarithmic axes; non-plottable values become NaN gaps).
struct PreparedSeries {
    std::vector<double> x, y;
};

PreparedSeries prepare_series(const PlotSeries &series, bool log_x, bool log_y) {
    PreparedSeries out;
    split_xy(series.xy, out.x, out.y);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    auto transform = [&](double &v, bool log) {
        if (!std::isfinite(v) || !plottable(v))
            v = nan;
        else if (log)
            v = v > 0.0 ? std::log10(v) : nan;
    };
    for (std::size_t p = 0; p < out.x.size(); ++p) {
        transform(out.x[p], log_x);
        transform(out.y[p], log_y);
        if (std::isnan(out.x[p]) || std::isnan(out.y[p])) out.x[p] = out.y[p] = nan;
    }
    return out;
}

// The plotted range of one axis: the requested one (in plotting units), or the data's padded by 3% each side;
// an empty or degenerate range is widened so the axis still has ticks.
std::pair<double, double> axis_range(const std::optional<std::pair<double, double>> &requested, bool log,
                                     const std::vector<PreparedSeries> &data, bool is_x) {
    if (requested)
        return log ? std::make_pair(std::log10(requested->first), std::log10(requested->second)) : *requested;
    double low = std::numeric_limits<double>::infinity(), high = -low;
    for (const PreparedSeries &s : data)
        for (double v : is_x ? s.x : s.y)
            if (std::isfinite(v)) {
                low = std::min(low, v);
                high = std::max(high, v);
            }
    if (!(low <= high)) return {0.0, 1.0};
    if (high - low <= 1e-12 * std::max(std::abs(low), std::abs(high))) {
        const double half = std::abs(low) > 0.0 ? 0.05 * std::abs(low) : 0.5;
        return {low - half, high + half};
    }
    const double pad = 0.03 * (high - low);
    return {low - pad, high + pad};
}

void check_xy(const XYPlot &plot) {
    const char *where = "plot_xy_png";
    check_width(where, plot.width_px);
    if (!(plot.aspect >= 0.1 && plot.aspect <= 10.0))
        throw Error(std::string(where) + ": aspect " + std::to_string(plot.aspect) + " is outside [0.1, 10]");
    for (const auto *range : {&plot.x_range, &plot.y_range}) {
        if (!*range) continue;
        const bool log = range == &plot.x_range ? plot.log_x : plot.log_y;
        if (!(std::isfinite((*range)->first) && std::isfinite((*range)->second) && (*range)->first < (*range)->second))
            throw Error(std::string(where) + ": an axis range must be finite with min < max");
        if (log && !((*range)->first > 0.0))
            throw Error(std::string(where) + ": a logarithmic axis needs a positive range");
    }
    for (const PlotSeries &s : plot.series) {
        if (s.xy.size() % 2 != 0)
            throw Error(std::string(where) + ": a series has an odd number of coordinates (" +
                        std::to_string(s.xy.size()) + ")");
        check_line_width(where, s.width);
        check_marker(where, s.marker_px);
        parse_color(s.color, where);
    }
}

PLINT dash_style(PlotSeries::Dash dash) {
    switch (dash) {
    case PlotSeries::Dash::dashed:
        return 3; // PLplot's long dashes
    case PlotSeries::Dash::dotted:
        return 2; // short dashes, the closest to dots that scales with the line
    default:
        return 1;
    }
}

// The legend of an x-y picture: the `listed` series (those with a label), where plot.legend says; `ch` is the
// character height in pixels, the data box box_w pixels wide and box_w * aspect tall.
void draw_xy_legend(const XYPlot &plot, const std::vector<std::size_t> &listed, double ch, double box_w,
                    double aspect) {
    const bool outside_legend = plot.legend == XYPlot::Legend::outside_right;
    const double char_mm = px_to_mm(ch);
    const PLINT n = static_cast<PLINT>(listed.size());
    std::vector<PLINT> opts(n), text_colors(n, slot_ink), line_colors(n), line_styles(n), symbol_colors(n),
        symbol_numbers(n, 1), box_colors(n, 0), box_patterns(n, 0);
    std::vector<PLFLT> line_widths(n), symbol_scales(n), box_scales(n, 0.0), box_line_widths(n, 0.0);
    std::vector<std::string> texts(n);
    std::vector<const char *> text_ptrs(n), symbol_ptrs(n);
    for (PLINT e = 0; e < n; ++e) {
        const PlotSeries &s = plot.series[listed[e]];
        opts[e] = (s.style != PlotSeries::Style::points ? PL_LEGEND_LINE : 0) |
                  (s.style != PlotSeries::Style::line ? PL_LEGEND_SYMBOL : 0);
        line_colors[e] = symbol_colors[e] = slot_xy_count + static_cast<PLINT>(listed[e]);
        line_styles[e] = dash_style(s.dash);
        line_widths[e] = s.width;
        // U+25CF (black circle) is about 0.6 character heights across in DejaVu Sans: scale it to the
        // markers' size, but keep it visible.
        symbol_scales[e] = std::max(s.marker_px, 0.5 * ch) / (0.6 * ch);
        symbol_ptrs[e] = "\u25cf";
        texts[e] = plain_text(s.label);
        text_ptrs[e] = texts[e].c_str();
    }
    PLINT position = PL_POSITION_INSIDE | PL_POSITION_VIEWPORT;
    switch (plot.legend) {
    case XYPlot::Legend::top_left:
        position |= PL_POSITION_TOP | PL_POSITION_LEFT;
        break;
    case XYPlot::Legend::bottom_left:
        position |= PL_POSITION_BOTTOM | PL_POSITION_LEFT;
        break;
    case XYPlot::Legend::bottom_right:
        position |= PL_POSITION_BOTTOM | PL_POSITION_RIGHT;
        break;
    case XYPlot::Legend::outside_right:
        position = PL_POSITION_OUTSIDE | PL_POSITION_VIEWPORT | PL_POSITION_RIGHT;
        break;
    default:
        position |= PL_POSITION_TOP | PL_POSITION_RIGHT;
    }
    set_color(slot_legend, {160, 160, 160});
    plschr(char_mm, 1.0);
    plwidth(1.0);
    PLFLT legend_width = 0.0, legend_height = 0.0;
    const double offset_x = (outside_legend ? 1.5 : 0.8) * ch / box_w;
    const double offset_y = (outside_legend ? 0.0 : 0.8) * ch / (box_w * aspect);
    pllegend(&legend_width, &legend_height, PL_LEGEND_BACKGROUND | PL_LEGEND_BOUNDING_BOX, position, offset_x, offset_y,
             3.0 * ch / box_w, slot_background, slot_legend, 1, 0, 0, n, opts.data(), 1.0, 1.0, 2.0, 0.0,
             text_colors.data(), text_ptrs.data(), box_colors.data(), box_patterns.data(), box_scales.data(),
             box_line_widths.data(), line_colors.data(), line_styles.data(), line_widths.data(), symbol_colors.data(),
             symbol_scales.data(), symbol_numbers.data(), symbol_ptrs.data());
}

void draw_xy(const std::filesystem::path &file, const XYPlot &plot, PlplotErrors &errors) {
    std::vector<PreparedSeries> data;
    for (const PlotSeries &s : plot.series) data.push_back(prepare_series(s, plot.log_x, plot.log_y));
    const auto [x0, x1] = axis_range(plot.x_range, plot.log_x, data, true);
    const auto [y0, y1] = axis_range(plot.y_range, plot.log_y, data, false);

    std::vector<std::size_t> listed; // series shown in the legend
    for (std::size_t k = 0; k < plot.series.size(); ++k)
        if (!plot.series[k].label.empty()) listed.push_back(k);
    const bool outside_legend = !listed.empty() && plot.legend == XYPlot::Legend::outside_right;

    // Layout, as for fields: margins from the tick labels, the box's aspect from the data or `aspect`.
    const double ch = char_px_for(plot.width_px);
    double widest_label = 0.0;
    for (std::size_t k : listed) widest_label = std::max(widest_label, visible_chars(plot.series[k].label));
    const double legend_px = (3.0 + 1.0 + 2.0) * ch + legend_char_width * ch * widest_label;
    const double top = plot.title.empty() ? 1.5 * ch : 4.0 * ch;
    const double bottom = 5.4 * ch;
    const double right = outside_legend ? legend_px + 2.5 * ch : 2.5 * ch;
    const double aspect = plot.equal_aspect ? std::clamp((y1 - y0) / (x1 - x0), 0.25, 4.0) : plot.aspect;
    double left = 10.0 * ch, y_label_disp = 0.0;
    Ticks x_ticks, y_ticks;
    for (int round = 0; round < 2; ++round) {
        const double box_w = plot.width_px - left - right;
        const double box_h = box_w * aspect;
        x_ticks = plot.log_x ? make_log_ticks(x0, x1, std::clamp(box_w / (7.0 * ch), 3.0, 10.0))
                             : make_ticks(x0, x1, std::clamp(box_w / (7.0 * ch), 3.0, 10.0));
        y_ticks = plot.log_y ? make_log_ticks(y0, y1, std::clamp(box_h / (5.0 * ch), 2.0, 10.0))
                             : make_ticks(y0, y1, std::clamp(box_h / (5.0 * ch), 2.0, 10.0));
        const double y_label_px =
            0.7 * ch + char_width * ch * label_chars(y0, y1, y_ticks) + 1.0 * ch + label_scale * ch;
        left = y_label_px + 1.0 * ch;
        y_label_disp = y_label_px / (label_scale * ch);
    }
    const double box_w = plot.width_px - left - right;
    const int height = static_cast<int>(std::lround(box_w * aspect + top + bottom));
    const double w = plot.width_px, h = height;
    const double char_mm = px_to_mm(ch);

    begin_page(file, plot.width_px, height, slot_xy_count + static_cast<PLINT>(plot.series.size()), errors);
    plvpor(left / w, 1.0 - right / w, bottom / h, 1.0 - top / h);
    plwind(x0, x1, y0, y1);

    // Light grid lines under the data at the major ticks (and decades on log axes).
    const AxisFormats formats{x_ticks, y_ticks};
    set_color(slot_grid, {225, 225, 225});
    plwidth(1.0);
    plbox((std::string("g") + (plot.log_x ? "l" : "")).c_str(), x_ticks.step, 0,
          (std::string("g") + (plot.log_y ? "l" : "")).c_str(), y_ticks.step, 0);

    const double px_x = (x1 - x0) / box_w, px_y = (y1 - y0) / (box_w * aspect);
    for (std::size_t k = 0; k < plot.series.size(); ++k) {
        const PlotSeries &s = plot.series[k];
        const PLINT slot = slot_xy_count + static_cast<PLINT>(k);
        set_color(slot, parse_color(s.color, "plot_xy_png"));
        if (s.style != PlotSeries::Style::points) {
            plwidth(s.width);
            pllsty(dash_style(s.dash));
            draw_polyline(data[k].x, data[k].y, s.closed);
            pllsty(1);
        }
        if (s.style != PlotSeries::Style::line) draw_markers(data[k].x, data[k].y, s.marker_px, px_x, px_y);
    }

    const std::string log_x = plot.log_x ? "l" : "", log_y = plot.log_y ? "l" : "";
    draw_box(formats, "bcnst" + log_x, "bcnstv" + log_y, char_mm, y_label_disp, plot.x_label, plot.y_label, plot.title,
             place_title(plot.title, ch, left, box_w, plot.width_px));

    if (!listed.empty()) draw_xy_legend(plot, listed, ch, box_w, aspect);
    if (errors.code != 0) throw IoError("'" + file.string() + "': PLplot failed: " + errors.message);
}

// ------------------------------------------------------------------------------------------------ 3-D pictures

void check_xyz(const XYZPlot &plot) {
    const char *where = "plot_xyz_png";
    check_width(where, plot.width_px);
    if (!(plot.altitude_deg >= 0.0 && plot.altitude_deg <= 90.0))
        throw Error(std::string(where) + ": altitude " + std::to_string(plot.altitude_deg) + " is outside [0, 90]");
    if (!std::isfinite(plot.azimuth_deg)) throw Error(std::string(where) + ": the azimuth must be finite");
    for (const PlotSeries3D &s : plot.series) {
        if (s.xyz.size() % 3 != 0)
            throw Error(std::string(where) + ": a series' coordinates are not triples (" +
                        std::to_string(s.xyz.size()) + " values)");
        check_line_width(where, s.width);
        parse_color(s.color, where);
    }
    for (const PlotSurface3D &s : plot.surfaces) {
        if (s.xyz.size() != 3 * s.rows * s.cols)
            throw Error(std::string(where) + ": a surface of " + std::to_string(s.rows) + " x " +
                        std::to_string(s.cols) + " points has " + std::to_string(s.xyz.size()) + " values");
        if (!(s.opacity >= 0.0 && s.opacity <= 1.0))
            throw Error(std::string(where) + ": opacity " + std::to_string(s.opacity) + " is outside [0, 1]");
        parse_color(s.color, where);
    }
}

// PLplot's world-to-viewer transform of plw3d (plot3d.c): the third row gives the depth, larger = nearer.
struct View3D {
    double xmid = 0, ymid = 0, zmid = 0, czx = 0, czy = 0, czz = 0;
    // Direction towards the viewer in the box's normalised coordinates, for shading.
    double depth(double x, double y, double z) const { return (x - xmid) * czx + (y - ymid) * czy + (z - zmid) * czz; }
};

// One thing to draw in the painter's algorithm: a quad face or a line segment.
struct Primitive {
    double depth = 0.0;
    bool face = false;
    std::array<double, 12> xyz{}; // a face: 4 corners; a segment: 2 ends
    Rgb rgb;
    double alpha = 1.0;
    double width = 1.0;
};

// The data's box: each coordinate's range over every series and surface, widened where empty or degenerate.
std::pair<std::array<double, 3>, std::array<double, 3>> data_box(const XYZPlot &plot) {
    std::array<double, 3> low{}, high{};
    low.fill(std::numeric_limits<double>::infinity());
    high.fill(-std::numeric_limits<double>::infinity());
    auto extend = [&](const std::vector<double> &xyz) {
        for (std::size_t p = 0; p + 2 < xyz.size(); p += 3)
            if (std::isfinite(xyz[p]) && std::isfinite(xyz[p + 1]) && std::isfinite(xyz[p + 2]))
                for (int c = 0; c < 3; ++c) {
                    low[c] = std::min(low[c], xyz[p + c]);
                    high[c] = std::max(high[c], xyz[p + c]);
                }
    };
    for (const auto &s : plot.series) extend(s.xyz);
    for (const auto &s : plot.surfaces) extend(s.xyz);
    for (int c = 0; c < 3; ++c) {
        if (!(low[c] <= high[c])) {
            low[c] = 0.0;
            high[c] = 1.0;
        } else if (high[c] - low[c] <= 1e-12 * std::max(std::abs(low[c]), std::abs(high[c]))) {
            const double half = std::abs(low[c]) > 0.0 ? 0.05 * std::abs(low[c]) : 0.5;
            low[c] -= half;
            high[c] += half;
        }
    }
    return {low, high};
}

// The quad faces of the surfaces, each shaded by how squarely it faces the viewer (normals in the box's normalised
// coordinates, `scale` per world unit; `toward` the viewer), from 55% to 100% of its colour.
void add_surface_faces(const XYZPlot &plot, const View3D &view, const std::array<double, 3> &scale,
                       const std::array<double, 3> &toward, std::vector<Primitive> &primitives) {
    for (const PlotSurface3D &s : plot.surfaces) {
        if (s.rows < 2 || s.cols < 2) continue;
        const Rgb base = parse_color(s.color, "plot_xyz_png");
        const std::size_t col_end = s.wrap_cols ? s.cols : s.cols - 1;
        for (std::size_t r = 0; r + 1 < s.rows; ++r)
            for (std::size_t c = 0; c < col_end; ++c) {
                const std::size_t c1 = (c + 1) % s.cols;
                const std::array<std::size_t, 4> corners{r * s.cols + c, r * s.cols + c1, (r + 1) * s.cols + c1,
                                                         (r + 1) * s.cols + c};
                Primitive p;
                p.face = true;
                bool finite = true;
                double depth = 0.0;
                for (int k = 0; k < 4; ++k)
                    for (int d = 0; d < 3; ++d) {
                        p.xyz[3 * k + d] = s.xyz[3 * corners[k] + d];
                        finite = finite && std::isfinite(p.xyz[3 * k + d]);
                    }
                if (!finite) continue;
                for (int k = 0; k < 4; ++k) depth += view.depth(p.xyz[3 * k], p.xyz[3 * k + 1], p.xyz[3 * k + 2]);
                p.depth = depth / 4.0;
                // Normal from the diagonals, in normalised box units.
                const double ax = (p.xyz[6] - p.xyz[0]) * scale[0], ay = (p.xyz[7] - p.xyz[1]) * scale[1],
                             az_ = (p.xyz[8] - p.xyz[2]) * scale[2];
                const double bx = (p.xyz[9] - p.xyz[3]) * scale[0], by = (p.xyz[10] - p.xyz[4]) * scale[1],
                             bz = (p.xyz[11] - p.xyz[5]) * scale[2];
                const double n0 = ay * bz - az_ * by, n1 = az_ * bx - ax * bz, n2 = ax * by - ay * bx;
                const double norm = std::sqrt(n0 * n0 + n1 * n1 + n2 * n2);
                const double facing =
                    norm > 0.0 ? std::abs(n0 * toward[0] + n1 * toward[1] + n2 * toward[2]) / norm : 0.0;
                const double shade = 0.55 + 0.45 * facing;
                p.rgb = {static_cast<int>(std::lround(base.r * shade)), static_cast<int>(std::lround(base.g * shade)),
                         static_cast<int>(std::lround(base.b * shade))};
                p.alpha = s.opacity;
                primitives.push_back(p);
            }
    }
}

// The line segments of the series.
void add_series_segments(const XYZPlot &plot, const View3D &view, std::vector<Primitive> &primitives) {
    for (const PlotSeries3D &s : plot.series) {
        const Rgb rgb = parse_color(s.color, "plot_xyz_png");
        const std::size_t n = s.xyz.size() / 3;
        const std::size_t segments = (s.closed && n >= 3) ? n : (n > 0 ? n - 1 : 0);
        for (std::size_t k = 0; k < segments; ++k) {
            const std::size_t a = k, b = (k + 1) % n;
            Primitive p;
            bool finite = true;
            for (int d = 0; d < 3; ++d) {
                p.xyz[d] = s.xyz[3 * a + d];
                p.xyz[3 + d] = s.xyz[3 * b + d];
                finite = finite && std::isfinite(p.xyz[d]) && std::isfinite(p.xyz[3 + d]);
            }
            if (!finite) continue;
            // Lines lying on a surface (a barrier drawn on its own tube) must not vanish under the faces they
            // share a depth with: they count as nearer by 2% of the box.
            p.depth =
                0.5 * (view.depth(p.xyz[0], p.xyz[1], p.xyz[2]) + view.depth(p.xyz[3], p.xyz[4], p.xyz[5])) + 0.02;
            p.rgb = rgb;
            p.width = s.width;
            primitives.push_back(p);
        }
    }
}

// The painter's algorithm: faces and segments drawn far to near.
void paint_far_to_near(std::vector<Primitive> &primitives) {
    std::stable_sort(primitives.begin(), primitives.end(),
                     [](const Primitive &a, const Primitive &b) { return a.depth < b.depth; });
    for (const Primitive &p : primitives) {
        set_color(slot_scratch, p.rgb, p.alpha);
        if (p.face) {
            std::array<PLFLT, 4> xs{p.xyz[0], p.xyz[3], p.xyz[6], p.xyz[9]},
                ys{p.xyz[1], p.xyz[4], p.xyz[7], p.xyz[10]}, zs{p.xyz[2], p.xyz[5], p.xyz[8], p.xyz[11]};
            plfill3(4, xs.data(), ys.data(), zs.data());
        } else {
            plwidth(p.width);
            std::array<PLFLT, 2> xs{p.xyz[0], p.xyz[3]}, ys{p.xyz[1], p.xyz[4]}, zs{p.xyz[2], p.xyz[5]};
            plline3(2, xs.data(), ys.data(), zs.data());
        }
    }
}

// Title and legend of a 3-D picture, in page coordinates (w x h pixels; `top` the title's margin).
void draw_xyz_title_and_legend(const XYZPlot &plot, const std::vector<std::size_t> &listed, double ch, double w,
                               double h, double top) {
    const double char_mm = px_to_mm(ch);
    plvpor(0.0, 1.0, 0.0, 1.0);
    plwind(0.0, 1.0, 0.0, 1.0);
    plcol0(slot_ink);
    if (!plot.title.empty()) {
        plschr(char_mm, title_scale);
        plptex(0.5, 1.0 - 2.2 * ch / h, 1.0, 0.0, 0.5, plain_text(plot.title).c_str());
    }
    if (listed.empty()) return;
    const PLINT n = static_cast<PLINT>(listed.size());
    std::vector<PLINT> opts(n, PL_LEGEND_LINE), text_colors(n, slot_ink), line_colors(n), line_styles(n, 1),
        zeros(n, 0);
    std::vector<PLFLT> line_widths(n), zero_scales(n, 0.0);
    std::vector<std::string> texts(n);
    std::vector<const char *> text_ptrs(n), no_symbols(n, "");
    for (PLINT e = 0; e < n; ++e) {
        const PlotSeries3D &s = plot.series[listed[e]];
        const PLINT slot = slot_xy_count + static_cast<PLINT>(listed[e]);
        plscol0(slot, parse_color(s.color).r, parse_color(s.color).g, parse_color(s.color).b);
        line_colors[e] = slot;
        line_widths[e] = s.width;
        texts[e] = plain_text(s.label);
        text_ptrs[e] = texts[e].c_str();
    }
    set_color(slot_legend, {160, 160, 160});
    plschr(char_mm, 1.0);
    plwidth(1.0);
    PLFLT legend_width = 0.0, legend_height = 0.0;
    pllegend(&legend_width, &legend_height, PL_LEGEND_BACKGROUND | PL_LEGEND_BOUNDING_BOX,
             PL_POSITION_INSIDE | PL_POSITION_VIEWPORT | PL_POSITION_TOP | PL_POSITION_RIGHT, 1.0 * ch / w, top / h,
             3.0 * ch / w, slot_background, slot_legend, 1, 0, 0, n, opts.data(), 1.0, 1.0, 2.0, 0.0,
             text_colors.data(), text_ptrs.data(), zeros.data(), zeros.data(), zero_scales.data(), zero_scales.data(),
             line_colors.data(), line_styles.data(), line_widths.data(), zeros.data(), zero_scales.data(), zeros.data(),
             no_symbols.data());
}

void draw_xyz(const std::filesystem::path &file, const XYZPlot &plot, PlplotErrors &errors) {
    const auto [low, high] = data_box(plot);
    const double ch = char_px_for(plot.width_px);
    const double char_mm = px_to_mm(ch);
    std::vector<std::size_t> listed;
    for (std::size_t k = 0; k < plot.series.size(); ++k)
        if (!plot.series[k].label.empty()) listed.push_back(k);
    // plw3d maps the data into a 1.15 x 1.15 x 1.1 box, whose projection (with its labels) fills a window of
    // [-1, 1] x [-0.45, 1.3] for the usual viewing angles, drawn with 1.32 times as many pixels per unit across as
    // up. A legend gets its own column on the right and the page is made less tall to match, so the box keeps its
    // proportions.
    double widest_label = 0.0;
    for (std::size_t k : listed) widest_label = std::max(widest_label, visible_chars(plot.series[k].label));
    const double legend_px =
        listed.empty() ? 0.0 : (3.0 + 1.0 + 2.0) * ch + legend_char_width * ch * widest_label + 2.0 * ch;
    const double top = plot.title.empty() ? 1.5 * ch : 4.0 * ch;
    // Text outside the viewport is clipped: the window reaches 0.12 units left of the box's projection, where the
    // rotated z label goes.
    const double left = 0.02 * plot.width_px;
    const double drawing_w = 0.98 * plot.width_px - left - legend_px, drawing_h = 0.625 * drawing_w;
    const int height = static_cast<int>(std::lround((drawing_h + top) / 0.98));
    begin_page(file, plot.width_px, height, slot_xy_count + static_cast<PLINT>(plot.series.size()), errors);
    const double w = plot.width_px, h = height;
    plvpor(left / w, (left + drawing_w) / w, 0.02, 1.0 - top / h);
    plwind(-1.12, 1.0, -0.45, 1.3);
    const double alt = plot.altitude_deg, az = plot.azimuth_deg;
    plw3d(1.15, 1.15, 1.1, low[0], high[0], low[1], high[1], low[2], high[2], alt, az);
    View3D view;
    view.xmid = 0.5 * (low[0] + high[0]);
    view.ymid = 0.5 * (low[1] + high[1]);
    view.zmid = 0.5 * (low[2] + high[2]);
    const double rad = M_PI / 180.0;
    const double cx = 1.15 / (high[0] - low[0]), cy = 1.15 / (high[1] - low[1]), cz = 1.1 / (high[2] - low[2]);
    view.czx = -cx * std::cos(alt * rad) * std::sin(az * rad);
    view.czy = -cy * std::cos(alt * rad) * std::cos(az * rad);
    view.czz = cz * std::sin(alt * rad);

    plwidth(1.0);
    plcol0(slot_ink);
    plschr(char_mm, 1.0);
    plsmaj(0.6 * char_mm, 1.0);
    plsmin(0.3 * char_mm, 1.0);
    // Nice steps, few enough that the slanted horizontal axes' labels do not run into each other; PLplot writes
    // 3-D tick labels with one significant decimal, so a step of 2.5 x 10^k becomes 5 x 10^k.
    auto step_3d = [](double lo, double hi, double count) {
        const double step = make_ticks(lo, hi, count).step;
        const double mantissa = step / std::pow(10.0, std::floor(std::log10(step)));
        return std::abs(mantissa - 2.5) < 1e-9 ? 2.0 * step : step;
    };
    const double x_step = step_3d(low[0], high[0], 4.0), y_step = step_3d(low[1], high[1], 4.0),
                 z_step = step_3d(low[2], high[2], 6.0);
    plbox3("bnstu", plain_text(plot.x_label).c_str(), x_step, 0, "bnstu", plain_text(plot.y_label).c_str(), y_step, 0,
           "bnstu", plain_text(plot.z_label).c_str(), z_step, 0);

    std::vector<Primitive> primitives;
    const std::array<double, 3> toward{-std::cos(alt * rad) * std::sin(az * rad),
                                       -std::cos(alt * rad) * std::cos(az * rad), std::sin(alt * rad)};
    add_surface_faces(plot, view, {cx, cy, cz}, toward, primitives);
    add_series_segments(plot, view, primitives);
    paint_far_to_near(primitives);
    draw_xyz_title_and_legend(plot, listed, ch, w, h, top);
    if (errors.code != 0) throw IoError("'" + file.string() + "': PLplot failed: " + errors.message);
}

// Asked for a device it does not have, PLplot prompts on stdin; check for the driver first instead.
void require_pngcairo() {
    std::array<const char *, 128> menus{}, names{};
    const char **menu_ptr = menus.data(), **name_ptr = names.data();
    int count = static_cast<int>(names.size());
    plgDevs(&menu_ptr, &name_ptr, &count);
    for (int i = 0; i < count && i < static_cast<int>(names.size()); ++i)
        if (names[i] != nullptr && std::string(names[i]) == "pngcairo") return;
    throw IoError("plot: PLplot's pngcairo driver is not installed (Debian: plplot-driver-cairo)");
}

std::mutex &plplot_mutex() {
    static std::mutex mutex;
    return mutex;
}

// Draws into a temporary file beside `file` with `draw(temp, errors)` and renames it into place.
template <class Draw> void write_picture(const std::filesystem::path &file, const Draw &draw) {
    write_file_atomically(file, [&](const std::filesystem::path &temp) {
        // PLplot exits the process when it cannot open its output file; open it here first so that failure is
        // an IoError instead.
        {
            std::ofstream probe(temp, std::ios::binary);
            if (!probe) throw IoError("'" + file.string() + "': cannot create '" + temp.string() + "'");
        }
        std::lock_guard<std::mutex> lock(plplot_mutex());
        require_pngcairo();
        PlplotErrors errors;
        {
            PlplotStream stream;
            draw(temp, errors);
        } // plend1 writes the PNG
        if (errors.code != 0) throw IoError("'" + file.string() + "': PLplot failed: " + errors.message);
    });
}

} // namespace

// The curve colours the pictures accept by name (besides "#rrggbb").
std::vector<std::string> plot_colors() {
    std::vector<std::string> names;
    for (const auto &entry : named_colors()) names.push_back(entry.first);
    return names;
}

void plot_field_png(const std::filesystem::path &file, const Grid &grid, const std::vector<double> &values,
                    const std::vector<std::uint8_t> &mask, const FieldPlot &plot) {
    check_arguments(grid, values, mask, plot);
    write_picture(file, [&](const std::filesystem::path &temp, PlplotErrors &errors) {
        draw_field(temp, grid, values, mask, plot, errors);
    });
}

void plot_xy_png(const std::filesystem::path &file, const XYPlot &plot) {
    check_xy(plot);
    write_picture(file, [&](const std::filesystem::path &temp, PlplotErrors &errors) { draw_xy(temp, plot, errors); });
}

void plot_xyz_png(const std::filesystem::path &file, const XYZPlot &plot) {
    check_xyz(plot);
    write_picture(file, [&](const std::filesystem::path &temp, PlplotErrors &errors) { draw_xyz(temp, plot, errors); });
}

} // namespace geobarrier
