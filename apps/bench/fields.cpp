#include "fields.hpp"

#include <netcdf.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string>

namespace geobarrier::bench {

namespace fs = std::filesystem;

std::vector<double> read_doubles(const fs::path &file, std::size_t count) {
    std::ifstream in(file, std::ios::binary);
    std::vector<double> v(count);
    if (!in.read(reinterpret_cast<char *>(v.data()), static_cast<std::streamsize>(count * sizeof(double))))
        throw std::runtime_error(file.string() + ": cannot read " + std::to_string(count) + " doubles");
    return v;
}

void write_doubles(const fs::path &file, const std::vector<double> &v) {
    std::ofstream(file, std::ios::binary)
        .write(reinterpret_cast<const char *>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(double)));
}

std::vector<double> read_ftle_netcdf(const fs::path &file, std::size_t count) {
    int nc = -1, var = -1;
    if (nc_open(file.c_str(), NC_NOWRITE, &nc) != NC_NOERR || nc_inq_varid(nc, "ftle", &var) != NC_NOERR)
        throw std::runtime_error(file.string() + ": no ftle variable");
    std::vector<double> v(count);
    nc_get_var_double(nc, var, v.data());
    double fill = NC_FILL_DOUBLE;
    nc_get_att_double(nc, var, "_FillValue", &fill);
    nc_close(nc);
    for (double &x : v)
        if (x == fill) x = nan_value;
    return v;
}

ErrorStats ftle_errors(const std::vector<double> &ftle, const std::vector<double> &exact, std::size_t nx,
                       std::size_t ny) {
    ErrorStats s;
    std::vector<double> errors;
    errors.reserve(ftle.size());
    const std::size_t mx = std::max<std::size_t>(1, nx / 50), my = std::max<std::size_t>(1, ny / 50);
    double sum = 0, max = 0, interior = 0;
    for (std::size_t k = 0; k < ftle.size(); ++k) {
        if (!std::isfinite(exact[k])) continue;
        if (!std::isfinite(ftle[k])) {
            ++s.missing;
            continue;
        }
        const double e = std::abs(ftle[k] - exact[k]);
        errors.push_back(e);
        sum += e;
        max = std::max(max, e);
        const std::size_t i = k / nx, j = k % nx;
        if (i >= my && j >= mx && i + my < ny && j + mx < nx) interior = std::max(interior, e);
    }
    if (errors.empty()) return s;
    s.mean = sum / static_cast<double>(errors.size());
    s.max = max;
    s.interior_max = interior;
    const std::size_t at = static_cast<std::size_t>(0.99 * static_cast<double>(errors.size() - 1));
    std::nth_element(errors.begin(), errors.begin() + static_cast<std::ptrdiff_t>(at), errors.end());
    s.p99 = errors[at];
    return s;
}

} // namespace geobarrier::bench
