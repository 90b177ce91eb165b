#include "harness.hpp"

#include "process.hpp"
#include "tables.hpp"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <stdexcept>

namespace geobarrier::bench {

std::vector<double> Bench::exact_gyre(std::size_t n) {
    const std::size_t nx = n, ny = n / 2;
    const fs::path file = out / ("ref_gyre_" + std::to_string(nx) + "x" + std::to_string(ny) + "_ftle.bin");
    if (!fs::exists(file)) {
        std::cerr << "computing the exact field of the double gyre (rkf78 1e-12, variational) ...\n";
        const Row r = run("reference", "double gyre", workload_gyre(n),
                          {"exact", with(integrator("rkf78", 1e-12, 1e-12), variational), 2}, {});
        if (!std::isfinite(r.wall)) throw std::runtime_error("the double gyre's exact field failed: " + r.note);
        write_doubles(file, m_last_ftle);
    }
    return read_doubles(file, nx * ny);
}

Row Bench::run(const std::string &section, const std::string &workload, const json &base, const Config &c,
               const std::vector<double> &exact, double baseline_wall, int repeat) {
    Row row;
    row.section = section;
    row.workload = workload;
    row.name = c.name;
    row.threads = c.threads;
    const json experiment = with(base, c.settings);
    row.nx = experiment["grid"]["n"][0].get<std::size_t>();
    row.ny = experiment["grid"]["n"][1].get<std::size_t>();
    const fs::path file = out / "experiment.json";
    std::ofstream(file) << experiment.dump(2);
    const fs::path run_dir = out / "run";
    std::cerr << "[" << section << "] " << workload << " " << row.nx << " x " << row.ny << ": " << c.name << " ...\n";
    // Best of `repeat` runs: the machine is shared, and other work only ever adds time.
    for (int attempt = 0; attempt < std::max(repeat, 1); ++attempt) {
        fs::remove_all(run_dir);
        const auto r = run_process({program.string(), "run", file.string(), "--out", run_dir.string(), "--quiet",
                                    "--threads", std::to_string(c.threads)});
        if (r.status != 0) {
            row.note = "failed: " + first_line(r.output);
            std::cerr << "  " << row.note << "\n";
            return row;
        }
        const json manifest = json::parse(std::ifstream(run_dir / "manifest.json"));
        double flow_map = nan_value;
        for (const auto &s : manifest["stages"])
            if (s["stage"] == "flow map") flow_map = s["wall_seconds"].get<double>();
        for (const auto &s : manifest["stages"])
            if (s["stage"].get<std::string>().rfind("extractor", 0) == 0)
                row.extractor_ratios.push_back(s["wall_seconds"].get<double>() / flow_map);
        if (attempt > 0 && !(r.wall_seconds < row.wall)) {
            row.flow_map = std::min(row.flow_map, flow_map);
            continue;
        }
        row.wall = r.wall_seconds;
        row.flow_map = attempt > 0 ? std::min(row.flow_map, flow_map) : flow_map;
        row.peak_mib = r.peak_mib;
        row.ratio = baseline_wall / r.wall_seconds;
        row.rhs = manifest["integrator_stats"]["rhs_evaluations"].get<double>();
        row.steps = manifest["integrator_stats"]["steps"].get<double>();
        row.stages = manifest["stages"];
    }
    if (fs::exists(run_dir / "fields.nc") && experiment["products"] == json::array({"ftle"})) {
        m_last_ftle = read_ftle_netcdf(run_dir / "fields.nc", row.nx * row.ny);
        if (!exact.empty()) row.err = ftle_errors(m_last_ftle, exact, row.nx, row.ny);
    }
    std::cerr << "  " << fixed(row.wall, 2) << " s, " << fixed(row.peak_mib, 0) << " MiB, mean error "
              << sci(row.err.mean) << "\n";
    return row;
}

} // namespace geobarrier::bench
