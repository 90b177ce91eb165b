// Fields on disk and their errors: the exact references' raw doubles, a run's FTLE from its NetCDF file, and the
// error statistics of a field against the exact one.
#pragma once

#include <cstddef>
#include <filesystem>
#include <limits>
#include <vector>

namespace geobarrier::bench {

inline constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

std::vector<double> read_doubles(const std::filesystem::path &file, std::size_t count);
void write_doubles(const std::filesystem::path &file, const std::vector<double> &v);
// The "ftle" variable of a run's fields.nc, NaN where it holds the fill value (masked points).
std::vector<double> read_ftle_netcdf(const std::filesystem::path &file, std::size_t count);

struct ErrorStats {
    double mean = nan_value, p99 = nan_value, max = nan_value, interior_max = nan_value;
    std::size_t missing = 0; // NaN or masked where the exact field is finite
};

// Errors against the exact FTLE; "interior" leaves out the outermost 2% of the box on each side.
ErrorStats ftle_errors(const std::vector<double> &ftle, const std::vector<double> &exact, std::size_t nx,
                       std::size_t ny);

} // namespace geobarrier::bench
