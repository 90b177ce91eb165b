// The peers: the exact reference of W (apps/bench/baselines/exact_reference.cpp), the naive Boost.Odeint baseline and
// SciPy (apps/bench/baselines), each launched as a whole process beside the runs.
#include "harness.hpp"
#include "process.hpp"
#include "tables.hpp"

#include <geobarrier/cauchy_green.hpp>

#include <unistd.h>

#include <iostream>
#include <stdexcept>

namespace geobarrier::bench {

std::vector<double> Bench::exact_w(std::size_t n, bool compute) {
    const fs::path dF_file = out / ("ref_N" + std::to_string(n) + "_DF.bin");
    if (!fs::exists(dF_file)) {
        if (!compute) return {};
        std::cerr << "computing the exact field of W (reference, rkf78 1e-12) at N = " << n << " ...\n";
        const auto r =
            run_process({(peers / "reference").string(), std::to_string(n), out.string()}, {"OMP_NUM_THREADS=2"});
        if (r.status != 0) throw std::runtime_error("reference failed: " + r.output);
    }
    const std::size_t count = n * n;
    const std::vector<double> dF = read_doubles(dF_file, 4 * count);
    std::vector<double> exact(count);
    for (std::size_t k = 0; k < count; ++k)
        exact[k] = geobarrier::cauchy_green_at(dF[4 * k], dF[4 * k + 1], dF[4 * k + 2], dF[4 * k + 3], horizon).ftle;
    return exact;
}

Row Bench::baseline(const std::string &section, std::size_t n, const std::vector<double> &exact) {
    Row row;
    row.section = section;
    row.workload = "W";
    row.name = "odeint_baseline (dopri5 1e-6/1e-4, aux 1e-4, per trajectory)";
    row.nx = row.ny = n;
    std::cerr << "[" << section << "] baseline: odeint_baseline " << n << " aux ...\n";
    const auto r = run_process({(peers / "odeint_baseline").string(), std::to_string(n), "aux", out.string()},
                               {"OMP_NUM_THREADS=2"});
    if (r.status != 0) throw std::runtime_error("odeint_baseline failed: " + r.output);
    row.wall = r.wall_seconds;
    row.peak_mib = r.peak_mib;
    row.ratio = 1.0;
    const auto ftle = read_doubles(out / ("odeint_aux_N" + std::to_string(n) + "_ftle.bin"), n * n);
    if (!exact.empty()) row.err = ftle_errors(ftle, exact, n, n);
    try {
        row.rhs = json::parse(r.output.substr(r.output.find('{')))["traj_rhs_evals"].get<double>();
    } catch (...) {
    }
    std::cerr << "  " << fixed(row.wall, 2) << " s\n";
    return row;
}

// The SciPy baseline (apps/bench/baselines/scipy_baseline.py: one stacked solve_ivp RK45 at the paper's tolerances,
// auxiliary grid), run from a copy (the source tree may be read-only) with the reference folder as its data.
std::optional<Row> Bench::scipy(const std::string &section, std::size_t n, const std::vector<double> &exact) {
    // Debian's interpreter (python3-scipy), which a python3 earlier on PATH (pyenv, a venv) may hide.
    const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
    if (run_process({python, "-c", "import scipy"}).status != 0) return std::nullopt;
    const fs::path dir = out / "scipy";
    fs::create_directories(dir);
    fs::copy_file(m_peers_source / "scipy_baseline.py", dir / "scipy_baseline.py",
                  fs::copy_options::overwrite_existing);
    Row row;
    row.section = section;
    row.workload = "W";
    row.name = "SciPy solve_ivp RK45 1e-6/1e-4, aux 1e-4, one stacked solve";
    row.nx = row.ny = n;
    row.threads = 1;
    const std::string tag = "bench" + std::to_string(::getpid());
    std::cerr << "[" << section << "] SciPy baseline at N = " << n << " ...\n";
    const auto r = run_process({python, (dir / "scipy_baseline.py").string(), "--N", std::to_string(n), "--grid", "aux",
                                "--mode", "vec", "--tag", tag},
                               {"PEERS_DATA=" + out.string(), "OMP_NUM_THREADS=1", "OPENBLAS_NUM_THREADS=1"});
    if (r.status != 0) {
        row.note = "failed: " + first_line(r.output);
        return row;
    }
    row.wall = r.wall_seconds;
    row.peak_mib = r.peak_mib;
    const fs::path result = dir / "results" / ("scipy_vec_aux_RK45_N" + std::to_string(n) + "_" + tag + ".jsonl");
    std::ifstream in(result);
    std::string line, last;
    while (std::getline(in, line))
        if (!line.empty()) last = line;
    try {
        const json rec = json::parse(last);
        row.rhs = rec["traj_rhs_evals"].get<double>();
        if (rec.contains("vs_true") && !exact.empty()) {
            const json &e = rec["vs_true"];
            row.err.mean = e["mean_abs_err"].get<double>();
            row.err.p99 = e["p99_abs_err"].get<double>();
            row.err.max = e["max_abs_err"].get<double>();
            row.err.interior_max = e["interior_max_abs_err"].get<double>();
            row.err.missing = e["n_nonfinite"].get<std::size_t>();
            row.note = "errors by scipy_baseline.py, interior margin 1 point";
        }
    } catch (...) {
        row.note = "no result record";
    }
    fs::remove(result);
    return row;
}

} // namespace geobarrier::bench
