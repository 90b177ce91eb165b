// Pictures (PLplot, cairo PNG driver), written atomically: what the three kinds of picture share (plot_internal.hpp
// says what; plot_field.cpp, plot_xy.cpp and plot_xyz.cpp draw them). All share one set of fonts, tick rules and
// colours. PLplot keeps global state, so all drawing is serialised.
#include "plot/plot_internal.hpp"

#include <png.h>

namespace geobarrier {

namespace plot_internal {

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

Rgb parse_color(const std::string &text, const char *where) {
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

std::string plain_text(const std::string &text) {
    std::string out;
    for (char c : text) {
        out += c;
        if (c == '#') out += '#';
    }
    return out;
}

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

bool plottable(double v) { return std::abs(v) <= 1e300; }

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

double label_chars(double low, double high, const Ticks &ticks) {
    double widest = 1.0;
    for (double v = std::ceil(low / ticks.step) * ticks.step; v <= high + 1e-9 * ticks.step; v += ticks.step)
        widest = std::max(widest, visible_chars(format_tick(v, ticks)));
    return widest;
}

void write_label(const Ticks &ticks, PLFLT value, char *label, PLINT length) {
    std::snprintf(label, static_cast<std::size_t>(length), "%s", format_tick(value, ticks).c_str());
}

double char_px_for(int width_px) { return std::max(1.45 * width_px / 100.0, 11.0); }

double px_to_mm(double px) { return px * 25.4 / dots_per_inch; }

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

void begin_page(const std::filesystem::path &file, int width, int height, PLINT cmap0_slots, PlplotErrors &errors) {
    plsError(&errors.code, errors.message);
    plsdev("memcairo");
    plspage(dots_per_inch, dots_per_inch, width, height, 0, 0);
    // memcairo draws over the page as it finds it (its begin-of-page paints nothing): white, the background.
    PageRaster &page = current_page();
    page.width = width;
    page.height = height;
    page.rgb.assign(3 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height), 255);
    plsmem(width, height, page.rgb.data());
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

void set_color(PLINT slot, const Rgb &rgb, double alpha) {
    if (alpha >= 1.0)
        plscol0(slot, rgb.r, rgb.g, rgb.b);
    else
        plscol0a(slot, rgb.r, rgb.g, rgb.b, alpha);
    plcol0(slot);
}

void label_both_axes(PLINT axis, PLFLT value, char *label, PLINT length, PLPointer data) {
    const auto *formats = static_cast<const AxisFormats *>(data);
    write_label(axis == PL_X_AXIS ? formats->x : formats->y, value, label, length);
}

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
              const TitlePlacement &title_place) {
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

namespace {

// The squared distance from point p to the segment a-b.
double squared_distance_to_segment(const std::array<double, 2> &p, const std::array<double, 2> &a,
                                   const std::array<double, 2> &b) {
    const double dx = b[0] - a[0], dy = b[1] - a[1], len2 = dx * dx + dy * dy;
    const double s = len2 > 0 ? std::clamp(((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2, 0.0, 1.0) : 0.0;
    const double ex = p[0] - a[0] - s * dx, ey = p[1] - a[1] - s * dy;
    return ex * ex + ey * ey;
}

// Douglas-Peucker on points first..last (both kept, in pixels): marks in `keep` the points the chords need so that
// every dropped point lies within `tolerance` pixels of its chord. An explicit stack, no recursion.
void mark_kept(const std::vector<std::array<double, 2>> &px, double tolerance, std::size_t first, std::size_t last,
               std::vector<bool> &keep) {
    std::vector<std::pair<std::size_t, std::size_t>> stack{{first, last}};
    keep[first] = keep[last] = true;
    const double tolerance2 = tolerance * tolerance;
    while (!stack.empty()) {
        const auto [a, b] = stack.back();
        stack.pop_back();
        double worst = tolerance2;
        std::size_t at = a;
        for (std::size_t p = a + 1; p < b; ++p) {
            const double d2 = squared_distance_to_segment(px[p], px[a], px[b]);
            if (d2 > worst) {
                worst = d2;
                at = p;
            }
        }
        if (at == a) continue; // every point between a and b is within the tolerance of the chord a-b
        keep[at] = true;
        stack.push_back({a, at});
        stack.push_back({at, b});
    }
}

} // namespace

void decimate_polyline(std::vector<double> &x, std::vector<double> &y, double px_x, double px_y, double tolerance_px) {
    if (x.size() < 3 || !(px_x > 0) || !(px_y > 0) || !(tolerance_px > 0)) return;
    std::vector<std::array<double, 2>> px(x.size());
    for (std::size_t p = 0; p < x.size(); ++p) px[p] = {x[p] / px_x, y[p] / px_y};
    // Blocks of at most `block` points with their ends kept bound Douglas-Peucker's quadratic worst case (a curve
    // that each split shortens by one point) at `block` times the points.
    constexpr std::size_t block = 1024;
    std::vector<bool> keep(x.size(), false);
    for (std::size_t first = 0; first + 1 < x.size(); first += block)
        mark_kept(px, tolerance_px, first, std::min(first + block, x.size() - 1), keep);
    std::size_t n = 0;
    for (std::size_t p = 0; p < x.size(); ++p)
        if (keep[p]) {
            x[n] = x[p];
            y[n] = y[p];
            ++n;
        }
    x.resize(n);
    y.resize(n);
}

void draw_polyline(const std::vector<double> &x, const std::vector<double> &y, bool closed, double px_x, double px_y) {
    std::vector<PLFLT> xs, ys;
    bool all_finite = true;
    auto flush = [&] {
        decimate_polyline(xs, ys, px_x, px_y, decimation_tolerance_px);
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

void split_xy(const std::vector<double> &xy, std::vector<double> &x, std::vector<double> &y) {
    const std::size_t n = xy.size() / 2;
    x.resize(n);
    y.resize(n);
    for (std::size_t p = 0; p < n; ++p) {
        x[p] = xy[2 * p];
        y[p] = xy[2 * p + 1];
    }
}

void require_memcairo() {
    std::array<const char *, 128> menus{}, names{};
    const char **menu_ptr = menus.data(), **name_ptr = names.data();
    int count = static_cast<int>(names.size());
    plgDevs(&menu_ptr, &name_ptr, &count);
    for (int i = 0; i < count && i < static_cast<int>(names.size()); ++i)
        if (names[i] != nullptr && std::string(names[i]) == "memcairo") return;
    throw IoError("plot: PLplot's memcairo driver is not installed (Debian: plplot-driver-cairo)");
}

std::mutex &plplot_mutex() {
    static std::mutex mutex;
    return mutex;
}

PageRaster &current_page() {
    static PageRaster page;
    return page;
}

void write_png(const std::filesystem::path &file, const PageRaster &page) {
    write_file_atomically(file, [&](const std::filesystem::path &temp) {
        png_image image{};
        image.version = PNG_IMAGE_VERSION;
        image.width = static_cast<png_uint_32>(page.width);
        image.height = static_cast<png_uint_32>(page.height);
        image.format = PNG_FORMAT_RGB;
        if (png_image_write_to_file(&image, temp.c_str(), 0, page.rgb.data(), 0, nullptr) == 0)
            throw IoError("'" + file.string() + "': cannot write '" + temp.string() + "': " + image.message);
    });
}

} // namespace plot_internal

// The curve colours the pictures accept by name (besides "#rrggbb").
std::vector<std::string> plot_colors() {
    std::vector<std::string> names;
    for (const auto &entry : plot_internal::named_colors()) names.push_back(entry.first);
    return names;
}

} // namespace geobarrier
