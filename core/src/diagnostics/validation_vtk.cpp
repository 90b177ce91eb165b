// tube.vtp: advected barriers and their tubes through extended phase space (x, y, t) as a VTK XML PolyData file
// that ParaView opens: slices as polylines, tubes as quads, with the point arrays "time" and "barrier".
#include <geobarrier/output.hpp>
#include <geobarrier/validation.hpp>

#include <sstream>

namespace fs = std::filesystem;

namespace geobarrier {

void write_tubes_vtp(const fs::path &file, const std::vector<BarrierTube> &tubes) {
    // Points: every slice's own points, then every tube's mesh points.
    std::ostringstream points, point_time, point_barrier, line_conn, line_off, line_cell, poly_conn, poly_off,
        poly_cell;
    points.precision(17);
    point_time.precision(17);
    std::size_t n_points = 0, n_lines = 0, n_polys = 0, line_offset = 0, poly_offset = 0;
    for (std::size_t b = 0; b < tubes.size(); ++b) {
        const BarrierTube &tube = tubes[b];
        for (std::size_t r = 0; r < tube.slices.size() && r < tube.slice_times.size(); ++r) {
            const std::vector<double> &xy = tube.slices[r];
            const std::size_t n = xy.size() / 2;
            if (n < 2) continue;
            const std::size_t first = n_points;
            for (std::size_t p = 0; p < n; ++p) {
                points << xy[2 * p] << ' ' << xy[2 * p + 1] << ' ' << tube.slice_times[r] << '\n';
                point_time << tube.slice_times[r] << '\n';
                point_barrier << b << '\n';
                line_conn << first + p << ' ';
            }
            n_points += n;
            line_offset += n;
            if (tube.closed && n >= 3) {
                line_conn << first;
                ++line_offset;
            }
            line_conn << '\n';
            line_off << line_offset << '\n';
            line_cell << b << '\n';
            ++n_lines;
        }
        if (tube.rows < 2 || tube.columns < 2) continue;
        const std::size_t first = n_points;
        for (std::size_t q = 0; q < tube.rows * tube.columns; ++q) {
            points << tube.xyz[3 * q] << ' ' << tube.xyz[3 * q + 1] << ' ' << tube.xyz[3 * q + 2] << '\n';
            point_time << tube.xyz[3 * q + 2] << '\n';
            point_barrier << b << '\n';
        }
        n_points += tube.rows * tube.columns;
        const std::size_t col_end = tube.closed ? tube.columns : tube.columns - 1;
        for (std::size_t r = 0; r + 1 < tube.rows; ++r)
            for (std::size_t c = 0; c < col_end; ++c) {
                const std::size_t c1 = (c + 1) % tube.columns;
                poly_conn << first + r * tube.columns + c << ' ' << first + r * tube.columns + c1 << ' '
                          << first + (r + 1) * tube.columns + c1 << ' ' << first + (r + 1) * tube.columns + c << '\n';
                poly_offset += 4;
                poly_off << poly_offset << '\n';
                poly_cell << b << '\n';
                ++n_polys;
            }
    }
    std::ostringstream doc;
    doc << "<?xml version=\"1.0\"?>\n"
        << "<!-- geobarrier: barriers advected through extended phase space (x, y, t) -->\n"
        << "<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
        << "  <PolyData>\n"
        << "    <Piece NumberOfPoints=\"" << n_points << "\" NumberOfVerts=\"0\" NumberOfLines=\"" << n_lines
        << "\" NumberOfStrips=\"0\" NumberOfPolys=\"" << n_polys << "\">\n"
        << "      <PointData Scalars=\"time\">\n"
        << "        <DataArray type=\"Float64\" Name=\"time\" format=\"ascii\">\n"
        << point_time.str() << "        </DataArray>\n"
        << "        <DataArray type=\"Int32\" Name=\"barrier\" format=\"ascii\">\n"
        << point_barrier.str() << "        </DataArray>\n"
        << "      </PointData>\n"
        << "      <CellData Scalars=\"barrier\">\n"
        << "        <DataArray type=\"Int32\" Name=\"barrier\" format=\"ascii\">\n"
        << line_cell.str() << poly_cell.str() << "        </DataArray>\n"
        << "      </CellData>\n"
        << "      <Points>\n"
        << "        <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n"
        << points.str() << "        </DataArray>\n"
        << "      </Points>\n"
        << "      <Lines>\n"
        << "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n"
        << line_conn.str() << "        </DataArray>\n"
        << "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n"
        << line_off.str() << "        </DataArray>\n"
        << "      </Lines>\n"
        << "      <Polys>\n"
        << "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n"
        << poly_conn.str() << "        </DataArray>\n"
        << "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n"
        << poly_off.str() << "        </DataArray>\n"
        << "      </Polys>\n"
        << "    </Piece>\n"
        << "  </PolyData>\n"
        << "</VTKFile>\n";
    write_text_file(file, doc.str());
}

} // namespace geobarrier
