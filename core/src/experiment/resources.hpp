// Memory a run will need and memory the machine can give, checked before anything is computed: a grid too large is
// refused up front with both numbers, instead of being killed by the OOM killer halfway through.
#ifndef GEOBARRIER_RESOURCES_HPP
#define GEOBARRIER_RESOURCES_HPP

#include "engine/tiles.hpp"

#include <geobarrier/flow_map.hpp>
#include <geobarrier/grid.hpp>

#include <cstdint>
#include <filesystem>
#include <string>

namespace geobarrier {

struct AvailableMemory {
    std::uint64_t bytes = 0;
    std::string source; // where the number came from, for messages
    bool known = false; // false when nothing could be read (then nothing is refused)
};

// The smaller of MemAvailable in /proc/meminfo and, inside a memory-limited cgroup (v2 or v1), its limit minus its
// current usage: the OOM killer acts at whichever comes first.
AvailableMemory available_memory();

// What a run over `grid` holds at its peak, in bytes, computing the flow map and Cauchy–Green fields tile by tile
// (tiles.hpp): per grid point the masks, the fields the plan keeps (positions, Cauchy–Green variables), the NetCDF
// writer's buffer, the picture's and, with extractors or derived fields, their grid fields; per point of one tile its
// trajectories' results and Cauchy–Green fields; plus a fixed allowance for the program, plugins and threads. An
// estimate, meant to be on the high side.
std::uint64_t estimate_run_memory(const Grid &grid, const IntegratorSettings &settings, const FieldPlan &plan);

// Throws ConfigError at /grid/n, with the estimate and what is available, when `needed` exceeds `available`.
void check_memory(std::uint64_t needed, const AvailableMemory &available, const Grid &grid);

// What may explain a failed write into `folder`, for the error message: "; its file system has 52 KiB free" and, when
// the process has a file-size limit, "; files are limited to 1.0 KiB (ulimit -f)". Libraries such as HDF5 report a
// full disk only as a generic I/O error.
std::string storage_hint(const std::filesystem::path &folder);

// "1.5 GiB", "312 MiB", "4.0 KiB", "12 bytes".
std::string format_bytes(std::uint64_t bytes);

} // namespace geobarrier

#endif // GEOBARRIER_RESOURCES_HPP
