// Field pictures: a scalar field on the grid G0 as a PNG colour map (PLplot, cairo driver) with axes, a colour bar
// and curves drawn over it, written atomically. PLplot keeps global state, so all drawing is serialised.
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
#include <string>

namespace geobarrier {

namespace {

struct Rgb {
    int r = 0, g = 0, b = 0;
};

const std::map<std::string, Rgb> &named_colors()
{
    static const std::map<std::string, Rgb> colors{
        {"black", {0, 0, 0}},          {"white", {255, 255, 255}},   {"red", {214, 39, 40}},
        {"blue", {31, 119, 180}},      {"grey", {128, 128, 128}},    {"gray", {128, 128, 128}},
        {"orange", {255, 127, 14}},    {"green", {44, 160, 44}},     {"magenta", {227, 24, 196}},
        {"cyan", {23, 190, 207}},      {"yellow", {255, 221, 0}},    {"purple", {148, 103, 189}},
        {"brown", {140, 86, 75}},      {"pink", {247, 129, 191}},
    };
    return colors;
}

int hex_digit(char c)
{
    if (c >= '0' && c <= '9')
        return c - '0';
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    return -1;
}

Rgb parse_color(const std::string &text)
{
    std::string name;
    for (char c : text)
        name += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const auto found = named_colors().find(name);
    if (found != named_colors().end())
        return found->second;
    if (name.size() == 7 && name[0] == '#') {
        std::array<int, 6> digits{};
        bool ok = true;
        for (std::size_t i = 0; i < 6; ++i)
            ok = ok && (digits[i] = hex_digit(name[i + 1])) >= 0;
        if (ok)
            return {digits[0] * 16 + digits[1], digits[2] * 16 + digits[3], digits[4] * 16 + digits[5]};
    }
    std::string known;
    for (const auto &entry : named_colors())
        known += (known.empty() ? "" : ", ") + entry.first;
    throw Error("plot_field_png: unknown colour '" + text + "'; use one of " + known + " or #rrggbb");
}

// PLplot reads '#' as the start of an escape sequence; labels are plain UTF-8 text, so '#' is doubled.
std::string plain_text(const std::string &text)
{
    std::string out;
    for (char c : text) {
        out += c;
        if (c == '#')
            out += '#';
    }
    return out;
}

// Viridis (perceptually uniform, readable in grey and by colour-blind readers) sampled at 8 evenly spaced points;
// PLplot interpolates linearly in RGB between them.
void set_viridis_cmap1()
{
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

// cmap0 slots used below; set explicitly so the picture never depends on PLplot's default palette.
enum Cmap0Slot : PLINT { slot_background = 0, slot_ink = 1, slot_masked = 2, slot_curve = 3, slot_count = 4 };

struct ColorRange {
    double low = 0.0, high = 1.0;
};

// Values beyond +-1e300 are treated like infinities: the width of the colour range must stay finite.
bool plottable(double v) { return std::abs(v) <= 1e300; }

// The colour scale spans the finite values at unmasked points only, so one NaN or a blown-up masked trajectory
// cannot wash out the picture. A constant field gets a small symmetric range around its value.
ColorRange color_range(const std::vector<double> &values, const std::vector<std::uint8_t> &mask)
{
    double low = std::numeric_limits<double>::infinity(), high = -low;
    for (std::size_t k = 0; k < values.size(); ++k) {
        if (mask[k] != 0 || !plottable(values[k]))
            continue;
        low = std::min(low, values[k]);
        high = std::max(high, values[k]);
    }
    if (!(low <= high))
        return {0.0, 1.0};
    if (high - low <= 1e-12 * std::max(std::abs(low), std::abs(high))) {
        const double half = std::abs(low) > 0.0 ? 1e-3 * std::abs(low) : 1e-3;
        return {low - half, high + half};
    }
    return {low, high};
}

// Tick marks at a "nice" step (1, 2, 2.5 or 5 times a power of ten), labelled with one number of decimals for
// the whole axis; very large or small magnitudes are written as m×10^e on each label.
struct Ticks {
    double step = 1.0;
    int decimals = 0;
    int exponent = 0; // 0: plain numbers
};

Ticks make_ticks(double low, double high, double target_count)
{
    Ticks ticks;
    const double raw = (high - low) / std::max(target_count, 1.0);
    const double power = std::pow(10.0, std::floor(std::log10(raw)));
    const double mantissa = raw / power;
    const double nice =
        mantissa < 1.5 ? 1.0 : mantissa < 2.25 ? 2.0 : mantissa < 3.5 ? 2.5 : mantissa < 7.5 ? 5.0 : 10.0;
    ticks.step = nice * power;
    // The exponent of the largest tick, so the top label reads 1.0×10^-4 rather than 10×10^-5.
    const double largest = std::max(std::abs(std::round(low / ticks.step)), std::abs(std::round(high / ticks.step))) *
                           ticks.step;
    if (largest >= 1e5 || (largest > 0.0 && largest < 1e-3))
        ticks.exponent = static_cast<int>(std::floor(std::log10(largest)));
    const int step_exponent = static_cast<int>(std::floor(std::log10(ticks.step) + 1e-9));
    ticks.decimals = std::max(0, ticks.exponent - step_exponent + (nice == 2.5 ? 1 : 0));
    return ticks;
}

std::string format_tick(double value, const Ticks &ticks)
{
    if (std::abs(value) < 1e-6 * ticks.step)
        value = 0.0; // no "-0.0" from rounding at the origin
    char buffer[64];
    if (ticks.exponent == 0 || value == 0.0) {
        std::snprintf(buffer, sizeof buffer, "%.*f", ticks.exponent == 0 ? ticks.decimals : 0, value);
    } else {
        // "×" in UTF-8 (the cairo driver draws Unicode text); #u...#d is PLplot's superscript escape.
        std::snprintf(buffer, sizeof buffer, "%.*f\u00d710#u%d#d", ticks.decimals,
                      value / std::pow(10.0, ticks.exponent), ticks.exponent);
    }
    return buffer;
}

// How many characters the widest tick label of an axis over [low, high] takes (escapes excluded).
double label_chars(double low, double high, const Ticks &ticks)
{
    double widest = 1.0;
    for (double v = std::ceil(low / ticks.step) * ticks.step; v <= high + 1e-9 * ticks.step; v += ticks.step) {
        std::string text = format_tick(v, ticks);
        const std::size_t times = text.find("\u00d710#u");
        double chars = static_cast<double>(text.size());
        if (times != std::string::npos) // "×10" plus a superscript at about 0.7 size; the escapes take no room
            chars = static_cast<double>(times) + 3.0 + 0.7 * static_cast<double>(text.size() - times - 8);
        widest = std::max(widest, chars);
    }
    return widest;
}

void write_label(const Ticks &ticks, PLFLT value, char *label, PLINT length)
{
    std::snprintf(label, static_cast<std::size_t>(length), "%s", format_tick(value, ticks).c_str());
}

// Everything is measured in pixels, derived from the width so that every size scales together. The cairo driver
// draws text at 72 dots per inch whatever plspage says, so character heights in mm are converted with that.
constexpr double dots_per_inch = 72.0;
constexpr double char_width = 0.62;      // glyph width / character height, sans-serif digits, generous
constexpr double label_scale = 1.1;      // axis and colour bar labels relative to tick labels
constexpr double title_scale = 1.25;

struct Layout {
    int width = 0, height = 0;
    double char_px = 0;                                // tick label character height
    double left = 0, right = 0, top = 0, bottom = 0;   // margins around the plot box
    double bar_gap = 0, bar_width = 0;                 // colour bar: distance from the box, width
    double y_label_disp = 0, bar_label_disp = 0;       // plmtex displacements, in label character heights
    Ticks x_ticks, y_ticks, bar_ticks;
    double box_width() const { return width - left - right; }
    double box_height() const { return height - top - bottom; }
};

Layout make_layout(int width_px, double x0, double x1, double y0, double y1, double v0, double v1,
                   const FieldPlot &plot)
{
    Layout layout;
    layout.width = width_px;
    const double ch = std::max(1.45 * width_px / 100.0, 11.0); // small pictures keep legible text
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

void check_arguments(const Grid &grid, const std::vector<double> &values, const std::vector<std::uint8_t> &mask,
                     const FieldPlot &plot)
{
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
    if (plot.width_px < 200 || plot.width_px > 10000)
        throw Error(where + "width_px = " + std::to_string(plot.width_px) + " is outside [200, 10000]");
    for (const PlotCurve &curve : plot.curves) {
        if (curve.xy.size() % 2 != 0)
            throw Error(where + "a curve has an odd number of coordinates (" + std::to_string(curve.xy.size()) + ")");
        if (!(curve.width > 0.0 && curve.width < 100.0))
            throw Error(where + "a curve's width " + std::to_string(curve.width) + " is outside (0, 100)");
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
    PlplotStream()
    {
        plgstrm(&m_previous);
        PLINT stream = 0;
        plmkstrm(&stream);
        if (stream < 0)
            throw Error("plot_field_png: PLplot has no free stream");
    }
    ~PlplotStream()
    {
        plend1();
        plsstrm(m_previous);
    }
    PlplotStream(const PlplotStream &) = delete;
    PlplotStream &operator=(const PlplotStream &) = delete;

  private:
    PLINT m_previous = 0;
};

// Draws one curve, split wherever a point is not finite (a curve may carry NaN as a gap).
void draw_curve(const PlotCurve &curve)
{
    const Rgb rgb = parse_color(curve.color);
    plscol0(slot_curve, rgb.r, rgb.g, rgb.b);
    plcol0(slot_curve);
    plwidth(curve.width);
    std::vector<PLFLT> xs, ys;
    const std::size_t n = curve.xy.size() / 2;
    bool all_finite = true;
    auto flush = [&] {
        if (xs.size() >= 2)
            plline(static_cast<PLINT>(xs.size()), xs.data(), ys.data());
        xs.clear();
        ys.clear();
    };
    for (std::size_t p = 0; p < n; ++p) {
        const double x = curve.xy[2 * p], y = curve.xy[2 * p + 1];
        if (!std::isfinite(x) || !std::isfinite(y)) {
            all_finite = false;
            flush();
            continue;
        }
        xs.push_back(x);
        ys.push_back(y);
    }
    // A closed curve is joined back to its start only when it has no gaps: a gap means the loop is not whole.
    if (curve.closed && all_finite && n >= 3) {
        xs.push_back(curve.xy[0]);
        ys.push_back(curve.xy[1]);
    }
    flush();
}

void draw(const std::filesystem::path &file, const Grid &grid, const std::vector<double> &values,
          const std::vector<std::uint8_t> &mask, const FieldPlot &plot, PlplotErrors &errors)
{
    // The image's cells are centred on the grid points, so the box reaches half a cell beyond the outer points.
    const double half_dx = 0.5 * grid.dx(), half_dy = 0.5 * grid.dy();
    const double x0 = grid.x_min - half_dx, x1 = grid.x_max + half_dx;
    const double y0 = grid.y_min - half_dy, y1 = grid.y_max + half_dy;
    const ColorRange range = color_range(values, mask);
    const Layout layout = make_layout(plot.width_px, x0, x1, y0, y1, range.low, range.high, plot);
    const double w = layout.width, h = layout.height;
    const double char_mm = layout.char_px * 25.4 / dots_per_inch;

    plsError(&errors.code, errors.message);
    plsdev("pngcairo");
    plsfnam(file.c_str());
    plspage(dots_per_inch, dots_per_inch, layout.width, layout.height, 0, 0);
    // The image as one raster rather than a polygon per cell: faster, and no hairline seams between cells.
    plsetopt("drvopt", "rasterize_image=1");
    plscolbg(255, 255, 255);
    plscmap0n(slot_count);
    plscol0(slot_background, 255, 255, 255);
    plscol0(slot_ink, 0, 0, 0);
    plscol0(slot_masked, 211, 211, 211);
    set_viridis_cmap1();
    plsfont(PL_FCI_SANS, PL_FCI_UPRIGHT, PL_FCI_MEDIUM);
    plinit();
    if (errors.code != 0)
        throw IoError("'" + file.string() + "': PLplot cannot start: " + errors.message);
    pladv(0);
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
    plimagefr(columns.data(), static_cast<PLINT>(grid.nx), static_cast<PLINT>(grid.ny), x0, x1, y0, y1, range.low,
              range.high, range.low, range.high, nullptr, nullptr);

    for (const PlotCurve &curve : plot.curves)
        draw_curve(curve);

    // Axes: PLplot's x and y tick labels both go through one label function; it is pointed at each axis's format
    // in turn (the colour bar's axis is drawn as a y axis).
    plwidth(1.0);
    plcol0(slot_ink);
    plschr(char_mm, 1.0);
    plsmaj(0.6 * char_mm, 1.0);
    plsmin(0.3 * char_mm, 1.0);
    struct AxisFormats {
        Ticks x, y;
    };
    const AxisFormats main_axes{layout.x_ticks, layout.y_ticks};
    plslabelfunc(
        [](PLINT axis, PLFLT value, char *label, PLINT length, PLPointer data) {
            const auto *formats = static_cast<const AxisFormats *>(data);
            write_label(axis == PL_X_AXIS ? formats->x : formats->y, value, label, length);
        },
        const_cast<AxisFormats *>(&main_axes));
    plbox("bcnsto", layout.x_ticks.step, 0, "bcnstvo", layout.y_ticks.step, 0);
    plschr(char_mm, label_scale);
    plmtex("b", 3.0, 0.5, 0.5, plain_text(plot.x_label).c_str());
    plmtex("l", layout.y_label_disp, 0.5, 0.5, plain_text(plot.y_label).c_str());
    if (!plot.title.empty()) {
        plschr(char_mm, title_scale);
        plmtex("t", 1.3, 0.5, 0.5, plain_text(plot.title).c_str());
    }

    // Colour bar to the right of the box, as tall as the box; its label is placed here rather than by
    // plcolorbar, which does not know how wide our custom tick labels are.
    plschr(char_mm, 1.0);
    const AxisFormats bar_axis{layout.bar_ticks, layout.bar_ticks};
    plslabelfunc(
        [](PLINT, PLFLT value, char *label, PLINT length, PLPointer data) {
            write_label(static_cast<const AxisFormats *>(data)->y, value, label, length);
        },
        const_cast<AxisFormats *>(&bar_axis));
    const char *axis_opts = "bcvtmo";
    const PLFLT bar_step = layout.bar_ticks.step;
    const PLINT sub_ticks = 0;
    const PLINT n_values = 2;
    const std::array<PLFLT, 2> bar_values{range.low, range.high};
    const PLFLT *bar_values_ptr = bar_values.data();
    const double box_w = layout.box_width();
    PLFLT bar_width = 0.0, bar_height = 0.0;
    plcolorbar(&bar_width, &bar_height, PL_COLORBAR_GRADIENT,
               PL_POSITION_RIGHT | PL_POSITION_OUTSIDE | PL_POSITION_VIEWPORT,
               layout.bar_gap / box_w, 0.0, layout.bar_width / box_w, 1.0, slot_background, slot_ink, 1, 0.0, 0.0,
               slot_ink, 1.0, 0, nullptr, nullptr, 1, &axis_opts, &bar_step, &sub_ticks, &n_values, &bar_values_ptr);
    plslabelfunc(nullptr, nullptr);
    if (!plot.colorbar_label.empty()) {
        plvpor(layout.left / w, 1.0 - layout.right / w, layout.bottom / h, 1.0 - layout.top / h);
        plschr(char_mm, label_scale);
        plmtex("r", layout.bar_label_disp, 0.5, 0.5, plain_text(plot.colorbar_label).c_str());
    }
    if (errors.code != 0)
        throw IoError("'" + file.string() + "': PLplot failed: " + errors.message);
}

// Asked for a device it does not have, PLplot prompts on stdin; check for the driver first instead.
void require_pngcairo()
{
    std::array<const char *, 128> menus{}, names{};
    const char **menu_ptr = menus.data(), **name_ptr = names.data();
    int count = static_cast<int>(names.size());
    plgDevs(&menu_ptr, &name_ptr, &count);
    for (int i = 0; i < count && i < static_cast<int>(names.size()); ++i)
        if (names[i] != nullptr && std::string(names[i]) == "pngcairo")
            return;
    throw IoError("plot_field_png: PLplot's pngcairo driver is not installed (Debian: plplot-driver-cairo)");
}

std::mutex &plplot_mutex()
{
    static std::mutex mutex;
    return mutex;
}

}  // namespace

// The curve colours plot_field_png accepts by name (besides "#rrggbb").
std::vector<std::string> plot_colors()
{
    std::vector<std::string> names;
    for (const auto &entry : named_colors())
        names.push_back(entry.first);
    return names;
}

void plot_field_png(const std::filesystem::path &file, const Grid &grid, const std::vector<double> &values,
                    const std::vector<std::uint8_t> &mask, const FieldPlot &plot)
{
    check_arguments(grid, values, mask, plot);
    write_file_atomically(file, [&](const std::filesystem::path &temp) {
        // PLplot exits the process when it cannot open its output file; open it here first so that failure is
        // an IoError instead.
        {
            std::ofstream probe(temp, std::ios::binary);
            if (!probe)
                throw IoError("'" + file.string() + "': cannot create '" + temp.string() + "'");
        }
        std::lock_guard<std::mutex> lock(plplot_mutex());
        require_pngcairo();
        PlplotErrors errors;
        {
            PlplotStream stream;
            draw(temp, grid, values, mask, plot, errors);
        }  // plend1 writes the PNG
        if (errors.code != 0)
            throw IoError("'" + file.string() + "': PLplot failed: " + errors.message);
    });
}

}  // namespace geobarrier
