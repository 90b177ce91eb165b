// The pictures of a frames run (frames.hpp): the animation of the frames' FTLE fields with the barriers coloured by
// track (an animated PNG), and each track's figures against time.
#include <geobarrier/errors.hpp>
#include <geobarrier/frames.hpp>
#include <geobarrier/output.hpp>

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <deque>
#include <fstream>
#include <future>
#include <iterator>
#include <string>
#include <vector>

namespace geobarrier {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

using Bytes = std::vector<unsigned char>;

// CRC-32 of PNG chunks (ISO 3309, the polynomial 0xedb88320 reflected), over the chunk's type and data.
std::uint32_t crc32(const unsigned char *data, std::size_t n, std::uint32_t crc = 0xffffffffu) {
    static const std::array<std::uint32_t, 256> table = [] {
        std::array<std::uint32_t, 256> t{};
        for (std::uint32_t k = 0; k < 256; ++k) {
            std::uint32_t c = k;
            for (int bit = 0; bit < 8; ++bit) c = c & 1 ? 0xedb88320u ^ (c >> 1) : c >> 1;
            t[k] = c;
        }
        return t;
    }();
    for (std::size_t k = 0; k < n; ++k) crc = table[(crc ^ data[k]) & 0xff] ^ (crc >> 8);
    return crc;
}

void put32(Bytes &out, std::uint32_t v) {
    for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<unsigned char>(v >> shift));
}
void put16(Bytes &out, std::uint16_t v) {
    out.push_back(static_cast<unsigned char>(v >> 8));
    out.push_back(static_cast<unsigned char>(v));
}
std::uint32_t get32(const unsigned char *p) {
    return std::uint32_t(p[0]) << 24 | std::uint32_t(p[1]) << 16 | std::uint32_t(p[2]) << 8 | p[3];
}

void put_chunk(Bytes &out, const char *type, const Bytes &data) {
    put32(out, static_cast<std::uint32_t>(data.size()));
    const std::size_t start = out.size();
    out.insert(out.end(), type, type + 4);
    out.insert(out.end(), data.begin(), data.end());
    put32(out, crc32(out.data() + start, out.size() - start) ^ 0xffffffffu);
}

struct Chunk {
    std::string type;
    Bytes data;
};

constexpr unsigned char png_signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

std::vector<Chunk> read_chunks(const fs::path &file) {
    std::ifstream in(file, std::ios::binary);
    const Bytes bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (bytes.size() < 8 || !std::equal(png_signature, png_signature + 8, bytes.begin()))
        throw IoError(file.string() + ": not a PNG file");
    std::vector<Chunk> chunks;
    for (std::size_t at = 8; at + 12 <= bytes.size();) {
        const std::uint32_t length = get32(&bytes[at]);
        if (at + 12 + length > bytes.size()) throw IoError(file.string() + ": a PNG chunk runs past the end");
        chunks.push_back({std::string(bytes.begin() + at + 4, bytes.begin() + at + 8),
                          Bytes(bytes.begin() + at + 8, bytes.begin() + at + 8 + length)});
        at += 12 + length;
    }
    return chunks;
}

// fcTL: the whole picture, from (0, 0), shown for delay_ms, replacing the one before.
Bytes frame_control(std::uint32_t sequence, const Bytes &ihdr, unsigned delay_ms) {
    Bytes d;
    put32(d, sequence);
    d.insert(d.end(), ihdr.begin(), ihdr.begin() + 8); // width, height
    put32(d, 0);
    put32(d, 0);
    put16(d, static_cast<std::uint16_t>(delay_ms));
    put16(d, 1000);
    d.push_back(0); // dispose: none
    d.push_back(0); // blend: source
    return d;
}

} // namespace

void write_animated_png(const fs::path &file, const std::vector<fs::path> &frames, unsigned delay_ms) {
    if (frames.empty()) throw IoError(file.string() + ": an animation needs at least one frame");
    Bytes out(png_signature, png_signature + 8);
    std::uint32_t sequence = 0;
    Bytes ihdr;
    for (std::size_t k = 0; k < frames.size(); ++k) {
        const std::vector<Chunk> chunks = read_chunks(frames[k]);
        if (chunks.empty() || chunks.front().type != "IHDR" || chunks.front().data.size() != 13)
            throw IoError(frames[k].string() + ": a PNG file without its header");
        if (k == 0) {
            ihdr = chunks.front().data;
            put_chunk(out, "IHDR", ihdr);
            Bytes actl;
            put32(actl, static_cast<std::uint32_t>(frames.size()));
            put32(actl, 0); // played over and over
            put_chunk(out, "acTL", actl);
        } else if (chunks.front().data != ihdr) { // every frame as the first: size, depth, colour type
            throw IoError(frames[k].string() + ": not the size and kind of the animation's first frame");
        }
        // Each frame's fcTL right before its first IDAT or fdAT, after the first frame's ancillary chunks: ffmpeg's
        // reader refuses any other chunk between them (the APNG specification only asks that fcTL precede them).
        bool control = false;
        for (const Chunk &c : chunks) {
            if (c.type == "IDAT" && !control) {
                put_chunk(out, "fcTL", frame_control(sequence++, ihdr, delay_ms));
                control = true;
            }
            if (c.type == "IDAT" && k == 0) {
                put_chunk(out, "IDAT", c.data);
            } else if (c.type == "IDAT") {
                Bytes fdat;
                put32(fdat, sequence++);
                fdat.insert(fdat.end(), c.data.begin(), c.data.end());
                put_chunk(out, "fdAT", fdat);
            } else if (k == 0 && c.type != "IHDR" && c.type != "IEND" && c.type != "PLTE") {
                put_chunk(out, c.type.c_str(), c.data); // the first frame's ancillary chunks (gamma, text)
            } else if (c.type == "PLTE") {
                throw IoError(frames[k].string() + ": a palette PNG (the animation takes true-colour frames)");
            }
        }
        if (!control) throw IoError(frames[k].string() + ": a PNG file without image data");
    }
    put_chunk(out, "IEND", {});
    write_file_atomically(file, [&](const fs::path &temp) {
        std::ofstream o(temp, std::ios::binary);
        o.write(reinterpret_cast<const char *>(out.data()), static_cast<std::streamsize>(out.size()));
        if (!o.flush()) throw IoError(temp.string() + ": cannot write the animation");
    });
}

namespace {

// A colour per track, distinct for neighbours (Okabe-Ito's colour-blind safe palette, then repeated).
std::string track_color(std::size_t id) {
    static const char *palette[] = {"#e69f00", "#56b4e9", "#009e73", "#f0e442", "#0072b2",
                                    "#d55e00", "#cc79a7", "#ffffff", "#000000"};
    return palette[id % (sizeof palette / sizeof *palette)];
}

} // namespace

void plot_frames_animation(const fs::path &file, const fs::path &scratch, const Grid &grid,
                           const std::vector<FrameField> &fields, const std::vector<json> &barriers, const json &tracks,
                           const std::string &title) {
    // The track of each barrier of each frame.
    std::vector<std::vector<std::size_t>> track_of(barriers.size());
    for (std::size_t k = 0; k < barriers.size(); ++k) track_of[k].assign(barriers[k].size(), 0);
    for (const json &t : tracks.at("tracks"))
        for (const json &f : t.at("frames"))
            for (const json &b : f.at("barriers"))
                track_of[f.at("frame").get<std::size_t>()][b.at("barrier").get<std::size_t>()] = t.at("id");
    std::vector<fs::path> pictures;
    // Two pictures at a time: PLplot draws one while the other's PNG is compressed (plot_field_png draws under
    // PLplot's lock and compresses after it). A future's destructor waits, so none outlives a throw.
    std::deque<std::future<void>> drawing;
    for (std::size_t k = 0; k < fields.size(); ++k) {
        if (drawing.size() >= 2) {
            drawing.front().get();
            drawing.pop_front();
        }
        FieldPlot plot;
        plot.title = fmt::format("{}: frame {} of {}, t0 = {:.4g}", title, k + 1, fields.size(), fields[k].t0);
        plot.colorbar_label = "FTLE";
        plot.width_px = 900;
        for (std::size_t b = 0; b < barriers[k].size(); ++b) {
            PlotCurve c;
            c.color = track_color(track_of[k][b]);
            c.width = 2.0;
            c.closed = barriers[k][b].value("closed", false);
            for (const json &p : barriers[k][b].at("points")) c.xy.insert(c.xy.end(), {p[0], p[1]});
            plot.curves.push_back(std::move(c));
        }
        pictures.push_back(scratch / fmt::format("frame-{:03d}.png", k));
        drawing.push_back(
            std::async(std::launch::async, [&field = fields[k], &grid, file = pictures.back(), plot = std::move(plot)] {
                plot_field_png(file, grid, field.ftle, field.mask, plot);
            }));
    }
    for (; !drawing.empty(); drawing.pop_front()) drawing.front().get();
    write_animated_png(file, pictures, 400);
    std::error_code ec;
    for (const fs::path &p : pictures) fs::remove(p, ec);
}

void plot_track_figures(const fs::path &file, const json &tracks) {
    XYPlot plot;
    plot.title = "tracks: each track's length against its frames' initial time";
    plot.x_label = "t0";
    plot.y_label = "length (sum of the track's barriers)";
    plot.legend = XYPlot::Legend::outside_right;
    for (const json &t : tracks.at("tracks")) {
        PlotSeries s;
        s.color = track_color(t.at("id"));
        s.style = PlotSeries::Style::line_points;
        if (t.at("id").get<std::size_t>() < 12) s.label = fmt::format("track {}", t.at("id").get<std::size_t>());
        for (const json &f : t.at("frames")) s.xy.insert(s.xy.end(), {f.at("t0"), f.at("length")});
        plot.series.push_back(std::move(s));
    }
    plot_xy_png(file, plot);
}

} // namespace geobarrier
