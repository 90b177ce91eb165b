// Memory checks before a run (see resources.hpp): /proc/meminfo and cgroup limits, and a per-point estimate of what
// the stages hold at their peak.
#include "experiment/resources.hpp"
#include <geobarrier/errors.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/resource.h>
#include <sys/statvfs.h>

namespace geobarrier {

namespace {

// A number of bytes from a one-line cgroup file; false for "max" (no limit) or an unreadable file.
bool read_cgroup_bytes(const char *path, std::uint64_t &bytes) {
    std::ifstream in(path);
    std::string word;
    if (!(in >> word) || word == "max") return false;
    try {
        bytes = std::stoull(word);
    } catch (...) {
        return false;
    }
    return true;
}

void consider(AvailableMemory &m, std::uint64_t bytes, const std::string &source) {
    if (!m.known || bytes < m.bytes) {
        m.bytes = bytes;
        m.source = source;
        m.known = true;
    }
}

} // namespace

AvailableMemory available_memory() {
    AvailableMemory m;
    {
        std::ifstream in("/proc/meminfo");
        std::string line;
        while (std::getline(in, line)) {
            std::istringstream fields(line);
            std::string key;
            std::uint64_t kib = 0;
            if (fields >> key >> kib && key == "MemAvailable:") {
                consider(m, kib * 1024, "MemAvailable in /proc/meminfo");
                break;
            }
        }
    }
    std::uint64_t limit = 0, used = 0;
    if (read_cgroup_bytes("/sys/fs/cgroup/memory.max", limit)) {
        if (!read_cgroup_bytes("/sys/fs/cgroup/memory.current", used)) used = 0;
        consider(m, limit > used ? limit - used : 0, "the cgroup limit /sys/fs/cgroup/memory.max less memory.current");
    } else if (read_cgroup_bytes("/sys/fs/cgroup/memory/memory.limit_in_bytes", limit) && limit < (1ull << 60)) {
        if (!read_cgroup_bytes("/sys/fs/cgroup/memory/memory.usage_in_bytes", used)) used = 0;
        consider(m, limit > used ? limit - used : 0,
                 "the cgroup limit memory.limit_in_bytes less memory.usage_in_bytes");
    }
    return m;
}

std::uint64_t estimate_run_memory(const Grid &grid, const IntegratorSettings &settings, const FieldPlan &plan) {
    // Bytes per grid point held for the whole run (see runner.cpp and tiles.cpp): the flow map's mask and, with
    // Cauchy-Green fields, theirs; the kept fields; the NetCDF writer's buffer of one variable.
    double per_point = 1 + 8;
    if (plan.positions) per_point += 2 * 8; // flow_x, flow_y
    if (plan.cauchy_green) per_point += 1 + 8 * static_cast<double>(plan.keep.size());
    if (plan.plot) per_point += 2 * 8;     // the picture's copy of the FTLE and PLplot's own
    if (plan.derived) per_point += 16 * 8; // deviation fields, gradients, line-field caches
    // Bytes per point of one tile, held while it is computed: mask, positions, DF, DF exponent and log|det DF|, and
    // its Cauchy-Green fields (all seven, and their mask).
    double per_tile_point = 1 + 2 * 8;
    if (plan.cauchy_green) {
        per_tile_point += 4 * 8 + 7 * 8 + 1;
        if (plan.gradient == GradientMethod::variational) per_tile_point += 4 + 8;
    }
    const double tile_points = static_cast<double>(tile_rows(grid, settings, plan)) * static_cast<double>(grid.nx);
    constexpr double fixed = 256.0 * 1024 * 1024; // program, libraries, plugins, thread stacks, pictures
    const double total =
        per_point * static_cast<double>(grid.nx) * static_cast<double>(grid.ny) + per_tile_point * tile_points + fixed;
    return total >= 1.8e19 ? UINT64_MAX : static_cast<std::uint64_t>(total);
}

void check_memory(std::uint64_t needed, const AvailableMemory &available, const Grid &grid) {
    if (!available.known || needed <= available.bytes) return;
    throw ConfigError("/grid/n", "a " + std::to_string(grid.nx) + " x " + std::to_string(grid.ny) +
                                     " grid needs about " + format_bytes(needed) + " of memory, but only " +
                                     format_bytes(available.bytes) + " is available (" + available.source +
                                     "); use fewer points, or split the box into several runs");
}

std::string storage_hint(const std::filesystem::path &folder) {
    std::string hint;
    struct statvfs fs_info {};
    if (::statvfs(folder.empty() ? "." : folder.c_str(), &fs_info) == 0)
        hint +=
            "; its file system has " +
            format_bytes(static_cast<std::uint64_t>(fs_info.f_bavail) * static_cast<std::uint64_t>(fs_info.f_frsize)) +
            " free";
    struct rlimit limit {};
    if (::getrlimit(RLIMIT_FSIZE, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY)
        hint += "; files are limited to " + format_bytes(static_cast<std::uint64_t>(limit.rlim_cur)) + " (ulimit -f)";
    return hint;
}

std::string format_bytes(std::uint64_t bytes) {
    const char *units[] = {"bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    double value = static_cast<double>(bytes);
    int unit = 0;
    while (value >= 1024.0 && unit < 6) {
        value /= 1024.0;
        ++unit;
    }
    char text[32];
    if (unit == 0)
        std::snprintf(text, sizeof text, "%llu bytes", static_cast<unsigned long long>(bytes));
    else
        std::snprintf(text, sizeof text, value < 10 ? "%.1f %s" : "%.0f %s", value, units[unit]);
    return text;
}

} // namespace geobarrier
