// geobarrier-bench: the speed/accuracy trade of the flow-map engine on workload W (the paper's first example,
// apps/bench/baselines/README.md) and on the double gyre, measured as whole processes side by side with the naive
// Boost.Odeint baseline (and SciPy when it is installed), against exact fields. Sections: the headline
// configurations, threads, scaling in the number of grid points, memory on a large grid, the extraction stages, and
// (full mode) the sweep over tolerance, stepper, gradient method, offset, block size and the double gyre. Writes
// bench.csv, bench.md and the Pareto picture (error against time); timings live here, never in tests.
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/frames.hpp>
#include <geobarrier/output.hpp>

#include "peak_rate.hpp"

#include <CLI/CLI.hpp>
#include <netcdf.h>
#include <nlohmann/json.hpp>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using geobarrier::bench::peak_lane_fma_rate;
using nlohmann::json;

namespace {

constexpr double two_pi = 6.283185307179586;
constexpr double horizon = 4 * two_pi; // T = 8 pi
constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();
const char *const gnu_time = "/usr/bin/time";

struct ProcessResult {
    int status = -1;
    double wall_seconds = 0;
    double peak_mib = 0;     // the child's maximum resident set size
    double user_seconds = 0; // the child's user CPU time (all its threads): steadier than wall time on a shared machine
    std::string output;
};

// Runs argv as a child process (stdout+stderr captured to a file), timing it as a whole process. The peak resident
// memory comes from GNU time when installed: a forked child's own ru_maxrss would also count the bench's pages it
// inherited before exec.
ProcessResult run_process(std::vector<std::string> argv, const std::vector<std::string> &env = {}) {
    const std::string tag = std::to_string(::getpid());
    const fs::path log = fs::temp_directory_path() / ("geobarrier-bench-" + tag + ".log");
    const fs::path rss = fs::temp_directory_path() / ("geobarrier-bench-" + tag + ".rss");
    const bool timed = ::access(gnu_time, X_OK) == 0;
    if (timed) argv.insert(argv.begin(), {gnu_time, "-f", "%M", "-o", rss.string()});
    const auto start = std::chrono::steady_clock::now();
    const pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error("fork failed");
    if (pid == 0) {
        std::FILE *out = std::freopen(log.c_str(), "w", stdout);
        (void)out;
        ::dup2(::fileno(stdout), ::fileno(stderr));
        for (const auto &e : env) ::putenv(const_cast<char *>(e.c_str()));
        std::vector<char *> args;
        for (const auto &a : argv) args.push_back(const_cast<char *>(a.c_str()));
        args.push_back(nullptr);
        ::execvp(args[0], args.data());
        std::perror("exec");
        ::_exit(127);
    }
    int status = 0;
    struct rusage usage {};
    ::wait4(pid, &status, 0, &usage);
    ProcessResult r;
    r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.peak_mib = usage.ru_maxrss / 1024.0;
    r.user_seconds = usage.ru_utime.tv_sec + usage.ru_utime.tv_usec * 1e-6;
    if (timed) {
        std::ifstream in(rss);
        std::string line, last;
        while (std::getline(in, line))
            if (!line.empty()) last = line; // "Command exited with non-zero status" comes first on failure
        try {
            r.peak_mib = std::stod(last) / 1024.0;
        } catch (...) {
        }
        fs::remove(rss);
    }
    std::ifstream in(log);
    std::stringstream text;
    text << in.rdbuf();
    r.output = text.str();
    fs::remove(log);
    return r;
}

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

struct ErrorStats {
    double mean = nan_value, p99 = nan_value, max = nan_value, interior_max = nan_value;
    std::size_t missing = 0; // NaN or masked where the exact field is finite
};

// Errors against the exact FTLE; "interior" leaves out the outermost 2% of the box on each side.
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

// Workload W (apps/bench/baselines/README.md): the reference and the baselines integrate exactly this.
json workload_w(std::size_t n) {
    return {{"description", "workload W (apps/bench/baselines/README.md)"},
            {"system", {{"plugin", "duffing"}}},
            {"forcing", {{"plugin", "cosine"}, {"params", {{"amplitude", 0.08}}}}},
            {"grid", {{"x", {-1.8, 1.8}}, {"y", {-1.2, 1.2}}, {"n", {n, n}}}},
            {"time", {{"t0", 0}, {"t1", horizon}}},
            {"products", {"ftle"}},
            {"output", {{"plots", false}}}};
}

// The double gyre of experiments/double-gyre.json (Shadden, Lekien & Marsden 2005) on an n x n/2 grid.
json workload_gyre(std::size_t n) {
    return {{"description", "double gyre (experiments/double-gyre.json)"},
            {"system", {{"plugin", "double-gyre"}}},
            {"grid", {{"x", {0, 2}}, {"y", {0, 1}}, {"n", {n, n / 2}}}},
            {"time", {{"t0", 0}, {"t1", 15}}},
            {"products", {"ftle"}},
            {"output", {{"plots", false}}}};
}

struct Config {
    std::string name;
    json settings = json::object(); // merged into the workload (RFC 7386: integrator, cauchy_green, quality, grid...)
    int threads = 2;
};

json integrator(const std::string &method, double rtol, double atol) {
    return {{"integrator", {{"method", method}, {"rtol", rtol}, {"atol", atol}}}};
}
json with(json a, const json &b) {
    a.merge_patch(b);
    return a;
}
const json variational = {{"cauchy_green", {{"method", "variational"}}}};
json aux(double offset) { return {{"cauchy_green", {{"method", "auxiliary-grid"}, {"offset", offset}}}}; }

const char *const unchecked_config = "default, unchecked steps";

// The headline configurations: the defaults, the presets, and the paper's settings.
std::vector<Config> headline_configs() {
    return {
        {"default", json::object(), 2},
        {"quality draft", {{"quality", "draft"}}, 2},
        {"quality standard", {{"quality", "standard"}}, 2},
        {"quality publication", {{"quality", "publication"}}, 2},
        {"default, adaptive steps", {{"integrator", {{"adaptive", true}}}}, 2},
        // What the step check costs where every step passes (W): the default with the check off.
        {unchecked_config, {{"integrator", {{"step_tolerance", 0}}}}, 2},
        {"paper tolerances, aux 1e-4", with(integrator("dopri5", 1e-6, 1e-4), aux(1e-4)), 2},
        {"paper tolerances, variational", with(integrator("dopri5", 1e-6, 1e-4), variational), 2},
    };
}

// The full sweep: tolerance x stepper x gradient method, aux offsets, fixed-step rk4, block sizes.
std::vector<Config> sweep_configs() {
    std::vector<Config> configs;
    for (double tol : {1e-4, 1e-6, 1e-8, 1e-10}) {
        const std::string t = json(tol).dump();
        for (const char *method : {"dopri5", "rkf78"}) {
            configs.push_back({std::string(method) + " tol " + t + ", variational",
                               with(integrator(method, tol, tol), variational), 2});
            configs.push_back(
                {std::string(method) + " tol " + t + ", aux 1e-3", with(integrator(method, tol, tol), aux(1e-3)), 2});
        }
    }
    for (double offset : {1e-5, 1e-4, 1e-2, 1e-1})
        configs.push_back(
            {"dopri5 tol 1e-8, aux " + json(offset).dump(), with(integrator("dopri5", 1e-8, 1e-8), aux(offset)), 2});
    for (int steps : {200, 400, 800, 1600})
        configs.push_back({"rk4 " + std::to_string(steps) + " steps, variational",
                           with({{"integrator", {{"method", "rk4"}, {"step", horizon / steps}}}}, variational), 2});
    for (int batch : {1, 8, 16, 32, 64, 128, 256})
        configs.push_back({"default, batch " + std::to_string(batch), {{"integrator", {{"batch", batch}}}}, 2});
    return configs;
}

struct Row {
    std::string section, workload, name;
    std::size_t nx = 0, ny = 0;
    int threads = 2;
    double wall = nan_value, flow_map = nan_value, peak_mib = nan_value, ratio = nan_value;
    double rhs = nan_value, steps = nan_value;
    ErrorStats err;
    std::string note;
    json stages = json::array(); // the manifest's per-stage times
    // Every run's extractor stage over the same run's flow map (rows with an extractor): the spread the least-wall
    // run's single ratio hides on a shared machine.
    std::vector<double> extractor_ratios;
};

std::string fixed(double v, int digits) {
    if (!std::isfinite(v)) return "–";
    char b[64];
    std::snprintf(b, sizeof b, "%.*f", digits, v);
    return b;
}
std::string sci(double v) {
    if (!std::isfinite(v)) return "–";
    char b[64];
    std::snprintf(b, sizeof b, "%.1e", v);
    return b;
}
std::string csv_number(double v) {
    if (!std::isfinite(v)) return "";
    char b[64];
    std::snprintf(b, sizeof b, "%.6g", v);
    return b;
}
std::string first_line(const std::string &text) {
    std::istringstream in(text);
    std::string line, last;
    while (std::getline(in, line))
        if (line.find("error") != std::string::npos)
            return line;
        else if (!line.empty())
            last = line;
    return last;
}

class Bench {
  public:
    fs::path out, peers, program, source;
    std::ofstream csv;
    std::vector<Row> rows;
    std::ostringstream md;

    // The exact FTLE of W on an n x n grid: rkf78 at 1e-12 on state + variational equations
    // (apps/bench/baselines/exact_reference.cpp), cached in the output folder.
    std::vector<double> exact_w(std::size_t n, bool compute) {
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
            exact[k] =
                geobarrier::cauchy_green_at(dF[4 * k], dF[4 * k + 1], dF[4 * k + 2], dF[4 * k + 3], horizon).ftle;
        return exact;
    }

    // The exact FTLE of the double gyre: geobarrier itself with rkf78 at 1e-12 on the variational equations (the
    // recipe of the W reference; the plugin's Jacobian is checked by check-plugin), cached.
    std::vector<double> exact_gyre(std::size_t n) {
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

    // One geobarrier run as a whole process; errors against `exact` when given.
    Row run(const std::string &section, const std::string &workload, const json &base, const Config &c,
            const std::vector<double> &exact, double baseline_wall = nan_value, int repeat = 1) {
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
        std::cerr << "[" << section << "] " << workload << " " << row.nx << " x " << row.ny << ": " << c.name
                  << " ...\n";
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

    // The naive Boost.Odeint baseline of W (dopri5 1e-6/1e-4 per trajectory, auxiliary grid, 2 threads).
    Row baseline(const std::string &section, std::size_t n, const std::vector<double> &exact) {
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

    // The SciPy baseline (apps/bench/baselines/scipy_baseline.py: one stacked solve_ivp RK45 at the paper's
    // tolerances, auxiliary grid), run from a copy (the source tree may be read-only) with the reference folder as its
    // data.
    std::optional<Row> scipy(const std::string &section, std::size_t n, const std::vector<double> &exact) {
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
        const auto r = run_process({python, (dir / "scipy_baseline.py").string(), "--N", std::to_string(n), "--grid",
                                    "aux", "--mode", "vec", "--tag", tag},
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

    void set_peers_source(const fs::path &p) { m_peers_source = p; }
    // The FTLE field of the last run() that wrote one (NaN where masked).
    const std::vector<double> &last_ftle() const { return m_last_ftle; }

    void add(const Row &row) {
        rows.push_back(row);
        csv << '"' << row.section << "\",\"" << row.workload << "\",\"" << row.name << "\"," << row.nx << ',' << row.ny
            << ',' << row.threads << ',' << csv_number(row.wall) << ',' << csv_number(row.flow_map) << ','
            << csv_number(row.peak_mib) << ',' << csv_number(row.rhs) << ',' << csv_number(row.steps) << ','
            << csv_number(row.ratio) << ',' << csv_number(row.err.mean) << ',' << csv_number(row.err.p99) << ','
            << csv_number(row.err.max) << ',' << csv_number(row.err.interior_max) << ',' << row.err.missing << ",\""
            << row.note << "\"\n";
        csv.flush();
    }

    // A markdown table of rows with errors.
    void table(const std::vector<Row> &rs) {
        md << "| configuration | threads | wall (s) | flow map (s) | × baseline | peak RSS (MiB) | RHS evals | steps | "
              "mean err | p99 err | max err | interior max |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
        for (const Row &r : rs) {
            md << "| " << r.name << (r.note.empty() ? "" : " (" + r.note + ")") << " | " << r.threads << " | "
               << fixed(r.wall, 2) << " | " << fixed(r.flow_map, 2) << " | " << fixed(r.ratio, 1) << " | "
               << fixed(r.peak_mib, 0) << " | " << sci(r.rhs) << " | " << sci(r.steps) << " | " << sci(r.err.mean)
               << " | " << sci(r.err.p99) << " | " << sci(r.err.max) << " | " << sci(r.err.interior_max) << " |\n";
        }
        md << "\n";
    }

  private:
    fs::path m_peers_source;
    std::vector<double> m_last_ftle;
};

// The Pareto front (fastest for its error) of (time, error) points: sorted by time, error strictly decreasing.
std::vector<double> pareto_front(std::vector<std::pair<double, double>> points) {
    std::sort(points.begin(), points.end());
    std::vector<double> xy;
    double best = HUGE_VAL;
    for (const auto &[t, e] : points)
        if (e < best) {
            best = e;
            xy.push_back(t);
            xy.push_back(e);
        }
    return xy;
}

void pareto_picture(const fs::path &file, const std::vector<Row> &rows, std::size_t n) {
    geobarrier::XYPlot plot;
    plot.title = "Workload W, N = " + std::to_string(n) + ": FTLE error against time";
    plot.aspect = 0.8;
    plot.width_px = 1400;
    plot.x_label = "wall time of the whole process (s)";
    plot.y_label = "FTLE error";
    plot.log_x = plot.log_y = true;
    plot.legend = geobarrier::XYPlot::Legend::outside_right;
    using Series = geobarrier::PlotSeries;
    Series mean{{}, "mean error", "blue", 1.5, Series::Style::points};
    Series interior{{}, "interior max", "red", 1.5, Series::Style::points};
    // The default and the peers stand out, each as two markers: its mean error (lower) and interior max (upper).
    Series defaults{{}, "default", "#00a000", 1.5, Series::Style::points};
    Series odeint{{}, "Boost.Odeint", "#ff8000", 1.5, Series::Style::points};
    Series scipy{{}, "SciPy", "#a000c0", 1.5, Series::Style::points};
    defaults.marker_px = odeint.marker_px = scipy.marker_px = 10;
    std::vector<std::pair<double, double>> front_mean, front_interior;
    for (const Row &r : rows) {
        if (r.workload != "W" || r.nx != n || !std::isfinite(r.wall) || !std::isfinite(r.err.mean)) continue;
        if (r.section != "headline" && r.section != "sweep" && r.name.rfind("SciPy", 0) != 0) continue; // repeats
        Series *highlight = r.name.rfind("odeint", 0) == 0  ? &odeint
                            : r.name.rfind("SciPy", 0) == 0 ? &scipy
                            : r.name == "default"           ? &defaults
                                                            : nullptr;
        if (highlight) highlight->xy.insert(highlight->xy.end(), {r.wall, r.err.mean, r.wall, r.err.interior_max});
        if (highlight == &odeint || highlight == &scipy) continue;
        mean.xy.insert(mean.xy.end(), {r.wall, r.err.mean});
        interior.xy.insert(interior.xy.end(), {r.wall, r.err.interior_max});
        front_mean.emplace_back(r.wall, r.err.mean);
        front_interior.emplace_back(r.wall, r.err.interior_max);
    }
    Series fm{pareto_front(front_mean), "front, mean", "blue", 1.2, Series::Style::line, Series::Dash::dashed};
    Series fi{pareto_front(front_interior), "front, interior", "red", 1.2, Series::Style::line, Series::Dash::dashed};
    // The targets: mean error 1e-4, interior max 0.05.
    Series target_mean{{}, "target 1e-4", "blue", 1.0, Series::Style::line, Series::Dash::dotted};
    Series target_interior{{}, "target 0.05", "red", 1.0, Series::Style::line, Series::Dash::dotted};
    double t_min = HUGE_VAL, t_max = 0;
    for (const Row &r : rows)
        if (r.workload == "W" && r.nx == n && std::isfinite(r.wall) && std::isfinite(r.err.mean)) {
            t_min = std::min(t_min, r.wall);
            t_max = std::max(t_max, r.wall);
        }
    if (t_max <= 0) return;
    target_mean.xy = {t_min, 1e-4, t_max, 1e-4};
    target_interior.xy = {t_min, 0.05, t_max, 0.05};
    plot.series = {mean, interior, fm, fi, target_mean, target_interior, defaults, odeint};
    if (!scipy.xy.empty()) plot.series.push_back(scipy);
    geobarrier::plot_xy_png(file, plot);
}

// --- The accuracy suite (issue 13): the quality presets on every built-in system at its documented parameters and
// on stress settings, each against an exact field computed by geobarrier itself (rkf78, adaptive, rtol = atol =
// 1e-12, variational equations), cached in the output folder. ---

struct SuiteCase {
    std::string name;
    json experiment; // without grid size, integrator, quality; products ftle
};

json suite_experiment(const json &system, const json &forcing, std::array<double, 4> box, double t0, double t1,
                      const json &bounds = nullptr) {
    json e = {{"system", system},
              {"grid", {{"x", {box[0], box[1]}}, {"y", {box[2], box[3]}}, {"n", {101, 101}}}},
              {"time", {{"t0", t0}, {"t1", t1}}},
              {"products", {"ftle"}},
              {"output", {{"plots", false}}}};
    if (!forcing.is_null()) e["forcing"] = forcing;
    if (!bounds.is_null()) e["bounds"] = bounds;
    return e;
}

std::vector<SuiteCase> suite_cases() {
    const auto cosine = [](double amplitude, double omega) {
        return json{{"plugin", "cosine"}, {"params", {{"amplitude", amplitude}, {"omega", omega}}}};
    };
    const auto duffing = [](double delta) {
        return json{{"plugin", "duffing"}, {"params", {{"alpha", 1}, {"beta", 1}, {"delta", delta}}}};
    };
    const auto vdp = [](double mu) { return json{{"plugin", "van-der-pol"}, {"params", {{"mu", mu}}}}; };
    const json wide_bounds = {{"x", {-20, 20}}, {"y", {-40, 40}}};
    return {
        {"duffing: W (paper example 1, T = 8π)",
         suite_experiment(duffing(0), cosine(0.08, 1), {-1.8, 1.8, -1.2, 1.2}, 0, horizon)},
        {"duffing: damped attractor (δ = 0.15, A = 0.3, T = −8π, bounds)",
         suite_experiment(duffing(0.15), cosine(0.3, 1), {-1.8, 1.8, -1.2, 1.2}, 0, -horizon,
                          {{"x", {-20, 20}}, {"y", {-20, 20}}})},
        // Not the damped Duffing at A = 0.3 here: its attractor is chaotic, and over T = 100 no reference is exact.
        {"van der Pol μ = 1, long horizon (A = 0.3, ω = 1.2, T = 100)",
         suite_experiment(vdp(1), cosine(0.3, 1.2), {-3, 3, -4, 4}, 0, 100)},
        {"duffing: stiff damping (δ = 200, A = 0.3, T = 10)",
         suite_experiment(duffing(200), cosine(0.3, 1), {-1.8, 1.8, -1.2, 1.2}, 0, 10)},
        {"van der Pol μ = 1 (experiments/van-der-pol.json, T = −10, bounds)",
         suite_experiment(vdp(1), cosine(0.3, 1.2), {-3, 3, -4, 4}, 10, 0, wide_bounds)},
        {"van der Pol μ = 2 (A = 0.5, T = 10)", suite_experiment(vdp(2), cosine(0.5, 1), {-3, 3, -4, 4}, 0, 10)},
        {"van der Pol μ = 4 (A = 0.5, T = 10)", suite_experiment(vdp(4), cosine(0.5, 1), {-3, 3, -4, 4}, 0, 10)},
        {"van der Pol μ = 8 (A = 0.5, T = 10)", suite_experiment(vdp(8), cosine(0.5, 1), {-3, 3, -4, 4}, 0, 10)},
        {"pendulum (experiments/pendulum.json, T = 20)",
         suite_experiment({{"plugin", "pendulum"}, {"params", {{"omega0", 1}, {"damping", 0.1}}}}, cosine(0.3, 0.8),
                          {-4, 4, -3, 3}, 0, 20)},
        {"pendulum, strong forcing (A = 2.5, ω = 2, T = 20)",
         suite_experiment({{"plugin", "pendulum"}, {"params", {{"omega0", 1}, {"damping", 0.1}}}}, cosine(2.5, 2),
                          {-4, 4, -3, 3}, 0, 20)},
        {"double gyre (experiments/double-gyre.json, T = 15)",
         suite_experiment({{"plugin", "double-gyre"}}, nullptr, {0, 2, 0, 1}, 0, 15)},
        {"linear saddle (a = 1, T = 5)",
         suite_experiment({{"plugin", "linear-saddle"}, {"params", {{"a", 1}}}}, nullptr, {-1, 1, -1, 1}, 0, 5)},
        {"shear vortex (experiments/shear-vortex.json, T = 2π)",
         suite_experiment({{"plugin", "shear-vortex"}, {"params", {{"omega", 1}, {"shear", 1}}}}, nullptr,
                          {-1, 1, -1, 1}, 0, two_pi)},
        {"parallel shear jet (experiments/parallel-shear-jet.json, T = 10)",
         suite_experiment({{"plugin", "parallel-shear"}, {"params", {{"profile", "jet"}}}}, nullptr, {0, 4, -2, 2}, 0,
                          10)},
    };
}

// The accuracy each preset states (docs/experiment-format.md, "Quality presets"): mean and interior max FTLE error.
struct PresetTarget {
    const char *quality;
    double mean, interior_max;
};
constexpr PresetTarget preset_targets[] = {{"draft", 1e-3, 0.3}, {"standard", 1e-4, 0.05}, {"publication", 1e-6, 1e-3}};

// A file-name-safe tag for a suite case's cached exact field.
std::string suite_tag(std::size_t index, std::size_t n) {
    return "suite" + std::to_string(index) + "_N" + std::to_string(n);
}

// Systems of more than two state components: W's grid, horizon and forcing with the four-component coupled Duffing
// system (systems/coupled-duffing, k = 0.1) on its (x1, v1) slice, the other oscillator at rest at the origin, beside
// planar W, both with the defaults (the standard preset: checked fixed dop853 steps, fused) and the whole n x n
// Cauchy-Green tensor; per trajectory from the flow-map stage's time. Rows go to bench.csv (section "ndim").
std::string ndim_section(Bench &bench, std::size_t n, int repeat) {
    json slice = workload_w(n);
    slice["description"] = "workload W's grid on the (x1, v1) slice of coupled-duffing";
    slice["system"] = {{"plugin", "coupled-duffing"}, {"params", {{"k", 0.1}}}};
    slice["grid"] = {{"axes", {"x1", "v1"}},
                     {"x1", {-1.8, 1.8}},
                     {"v1", {-1.2, 1.2}},
                     {"n", {n, n}},
                     {"fixed", {{"x2", 0}, {"v2", 0}}}};
    std::vector<Row> rows;
    for (const auto &[workload, experiment] :
         {std::pair<std::string, json>{"W (planar duffing, 2 components)", workload_w(n)},
          std::pair<std::string, json>{"coupled-duffing slice (4 components)", slice}}) {
        Row r = bench.run("ndim", workload, experiment, {"default", json::object(), 2}, {}, nan_value, repeat);
        bench.add(r);
        rows.push_back(r);
    }
    std::ostringstream md;
    md << "## Systems of more than two components\n\nW's grid (N = " << n
       << "), horizon and forcing with the four-component `coupled-duffing` system (k = 0.1) on its (x1, v1) slice "
          "(x2 = v2 = 0), beside planar W, both with the defaults (checked fixed dop853 steps, the SDK's fused step, "
          "the whole Cauchy–Green tensor), 2 threads, best of "
       << repeat
       << ". The variational equations carry 4 + 16 + 1 components per trajectory against 2 + 4 + 1.\n\n"
          "| system | wall (s) | flow map (s) | core-µs per trajectory | steps per trajectory | × planar |\n"
          "|---|---|---|---|---|---|\n";
    const double trajectories = static_cast<double>(n) * static_cast<double>(n);
    for (const Row &r : rows) {
        const double per = 1e6 * r.flow_map * r.threads / trajectories;
        const double planar = 1e6 * rows[0].flow_map * rows[0].threads / trajectories;
        md << "| " << r.workload << " | " << fixed(r.wall, 2) << " | " << fixed(r.flow_map, 2) << " | " << fixed(per, 1)
           << " | " << fixed(r.steps / std::ceil(trajectories / 64.0), 0) << " | " << fixed(per / planar, 2) << " |\n";
        std::cout << "ndim: " << r.workload << ": " << fixed(per, 1) << " core-us per trajectory\n";
    }
    md << "\n";
    return md.str();
}

// Runs the suite at n x n points and returns its markdown section; rows go to bench.csv (section "suite").
std::string suite_section(Bench &bench, std::size_t n) {
    std::ostringstream md;
    md << "## Accuracy suite: every preset on every built-in system\n\n"
          "Each system at "
       << n << " × " << n << " grid points (the double gyre " << n << " × " << n / 2
       << "), 2 threads, against its exact field (geobarrier: rkf78 adaptive at rtol = atol = 1e-12, variational "
          "equations). *Masked*: points the preset masked where the exact field is finite. *Verdict*: `meets` "
          "= mean and interior max within the preset's stated accuracy (draft 1e-3 / 0.3, standard 1e-4 / 0.05, "
          "publication 1e-6 / 1e-3) with no more than 1% masked; `warned` = not met, but the run warned naming the "
          "integrator; `FAILS` = silently wrong. Warnings: the manifest's, shortened.\n\n"
          "| system | preset | exit | wall (s) | flow map (s) | steps / fixed grid | mean err | interior max | "
          "masked | verdict | warnings |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    std::size_t index = 0, fails = 0;
    for (const SuiteCase &c : suite_cases()) {
        json base = c.experiment;
        const bool gyre = base["system"]["plugin"] == "double-gyre";
        base["grid"]["n"] = {n, gyre ? n / 2 : n};
        const std::size_t nx = n, ny = gyre ? n / 2 : n;
        const fs::path ref_file = bench.out / (suite_tag(index++, n) + "_ftle.bin");
        if (!fs::exists(ref_file)) {
            const Row r = bench.run("suite-reference", c.name, base,
                                    {"exact", with(integrator("rkf78", 1e-12, 1e-12), variational), 2}, {});
            if (!std::isfinite(r.wall)) throw std::runtime_error(c.name + ": the exact field failed: " + r.note);
            write_doubles(ref_file, bench.last_ftle());
        }
        const std::vector<double> exact = read_doubles(ref_file, nx * ny);
        for (const PresetTarget &target : preset_targets) {
            Row r = bench.run("suite", c.name, base,
                              {std::string("quality ") + target.quality, {{"quality", target.quality}}, 2}, exact);
            const fs::path manifest_file = bench.out / "run" / "manifest.json";
            json manifest = json::object();
            if (std::isfinite(r.wall) && fs::exists(manifest_file))
                manifest = json::parse(std::ifstream(manifest_file));
            std::string warnings;
            bool names_integrator = false;
            for (const auto &w : manifest.value("warnings", json::array())) {
                const std::string text = w.get<std::string>();
                names_integrator = names_integrator || text.find("dop853") != std::string::npos;
                warnings += (warnings.empty() ? "" : "; ") + text.substr(0, 160) + (text.size() > 160 ? "…" : "");
            }
            const json stats = manifest.value("integrator_stats", json::object());
            const double steps = stats.value("steps", 0.0), planned = stats.value("planned_steps", 0.0);
            const double masked_share = static_cast<double>(r.err.missing) / static_cast<double>(nx * ny);
            const bool failed = !std::isfinite(r.wall);
            const bool meets = !failed && r.err.mean <= target.mean && r.err.interior_max <= target.interior_max &&
                               masked_share <= 0.01;
            const char *verdict = meets ? "meets" : (failed || names_integrator) ? "warned" : "FAILS";
            if (!meets && !failed && !names_integrator) ++fails;
            md << "| " << c.name << " | " << target.quality << " | " << (failed ? "≠ 0" : "0") << " | "
               << fixed(r.wall, 2) << " | " << fixed(r.flow_map, 2) << " | "
               << (planned > 0 ? fixed(steps / planned, 2) : "–") << " | " << sci(r.err.mean) << " | "
               << sci(r.err.interior_max) << " | " << r.err.missing << " (" << fixed(100 * masked_share, 1) << "%) | "
               << verdict << " | " << (failed ? r.note : warnings) << " |\n";
            r.note = verdict;
            bench.add(r);
        }
    }
    md << "\n"
       << (fails == 0 ? "Every row meets its preset's accuracy or warns naming the integrator."
                      : std::to_string(fails) + " rows are silently wrong (verdict FAILS).")
       << "\n\n";
    std::cout << "accuracy suite at N = " << n << ": " << fails << " silently wrong rows\n";
    return md.str();
}

std::string load_average() {
    std::ifstream in("/proc/loadavg");
    std::string a, b, c;
    in >> a >> b >> c;
    return a + " " + b + " " + c;
}

// --- Frames (docs/experiment-format.md, "Frames"): experiments/duffing-frames.json as one frames run against the same
// frames as separate runs, one process after the other. Needs no reference or baseline. ---

// The processor as the docs name it: "AMD EPYC family 25 model 17, 2 cores" (/proc/cpuinfo).
std::string cpu_name() {
    std::ifstream in("/proc/cpuinfo");
    std::map<std::string, std::string> first;
    int cores = 0;
    for (std::string line; std::getline(in, line);) {
        const std::size_t colon = line.find(':');
        if (colon == std::string::npos) continue;
        std::string key = line.substr(0, colon), value = colon + 2 <= line.size() ? line.substr(colon + 2) : "";
        key.erase(key.find_last_not_of(" \t") + 1);
        if (key == "processor") ++cores;
        first.emplace(key, value);
    }
    return first["model name"] + " family " + first["cpu family"] + " model " + first["model"] + ", " +
           std::to_string(cores) + " cores";
}

// Best wall and user CPU seconds of one side of the frames comparison.
struct FramesSide {
    double wall = HUGE_VAL, user = HUGE_VAL;
    void keep(double w, double u) { wall = std::min(wall, w), user = std::min(user, u); }
};

// The frames run (one `geobarrier run` of the frames experiment: the frames, their tracks and the animation) and the
// same frames as separate runs (one process per initial time, in turn), interleaved `repeat` times so that both sides
// see the same load, the fastest of each kept. Rows go to bench.csv (section "frames"); returns the markdown.
std::string frames_section(Bench &bench, int repeat) {
    const fs::path file = bench.source / "experiments" / "duffing-frames.json";
    const json experiment = json::parse(std::ifstream(file));
    const std::vector<double> t0s = geobarrier::frame_initial_times(experiment["time"]["t0"], "/time/t0");
    const fs::path scratch = bench.out / "frames";
    fs::remove_all(scratch);
    fs::create_directories(scratch);
    std::vector<fs::path> singles;
    for (std::size_t k = 0; k < t0s.size(); ++k) {
        json single = experiment;
        single["time"] = {{"t0", t0s[k]}, {"T", experiment["time"]["T"]}};
        singles.push_back(scratch / ("frame-" + std::to_string(k) + ".json"));
        std::ofstream(singles.back()) << single.dump(1) << "\n";
    }
    const auto run = [&](const fs::path &experiment_file, const fs::path &out) {
        ProcessResult r = run_process({bench.program.string(), "run", "-q", "--out", out.string(), experiment_file});
        if (r.status != 0)
            throw std::runtime_error("frames section: " + experiment_file.string() + ": " + first_line(r.output));
        return r;
    };
    FramesSide frames, separate;
    for (int attempt = 0; attempt < repeat; ++attempt) {
        std::cerr << "[frames] " << t0s.size() << " frames, attempt " << attempt + 1 << " of " << repeat << "\n";
        const ProcessResult f = run(file, scratch / "frames-run");
        frames.keep(f.wall_seconds, f.user_seconds);
        double wall = 0, user = 0;
        for (std::size_t k = 0; k < singles.size(); ++k) {
            const ProcessResult r = run(singles[k], scratch / ("separate-" + std::to_string(k)));
            wall += r.wall_seconds, user += r.user_seconds;
        }
        separate.keep(wall, user);
        std::cerr << "  frames run " << fixed(f.wall_seconds, 1) << " s, separate runs " << fixed(wall, 1) << " s\n";
    }
    const json manifest = json::parse(std::ifstream(scratch / "frames-run" / "manifest.json"));
    fs::remove_all(scratch);
    const std::size_t nx = experiment["grid"]["n"][0], ny = experiment["grid"]["n"][1];
    for (const auto &[name, side] : {std::pair<const char *, FramesSide>{"frames run", frames},
                                     std::pair<const char *, FramesSide>{"separate runs", separate}}) {
        Row row;
        row.section = "frames";
        row.workload = "W, " + std::to_string(t0s.size()) + " frames";
        row.name = name;
        row.nx = nx, row.ny = ny, row.threads = 0;
        row.wall = side.wall;
        row.ratio = side.wall / separate.wall;
        row.note = "user CPU " + fixed(side.user, 1) + " s";
        bench.add(row);
    }
    std::ostringstream md;
    md << "## Frames\n\n`experiments/duffing-frames.json`: W over one forcing period in " << t0s.size()
       << " frames (t0 from 0 to 2π, T = 8π, " << nx << " × " << ny
       << ", hyperbolic barriers, pictures). The frames run is one process (every frame's run, the tracks and the "
          "animation), "
       << manifest.value("frames_in_flight", 1)
       << " frames at a time; the separate runs are one process per t0, one after the other, all threads each. "
          "Interleaved, the fastest of "
       << repeat << " each, on " << cpu_name() << " (load average " << load_average()
       << " after).\n\n| | wall (s) | user CPU (s) | × separate runs |\n|---|---|---|---|\n"
       << "| frames run (with tracks and animation) | " << fixed(frames.wall, 1) << " | " << fixed(frames.user, 1)
       << " | " << fixed(frames.wall / separate.wall, 2) << " |\n| " << t0s.size() << " separate runs | "
       << fixed(separate.wall, 1) << " | " << fixed(separate.user, 1) << " | 1.00 |\n\n";
    return md.str();
}

} // namespace

// --- The equations system (docs/experiment-format.md, "Equations"): W with the oscillator written in the experiment,
// against the built-in duffing plugin. Needs no reference or baseline. ---

// W written as equations: "x - x^3 + f" as the paper writes it, or the built-in plugin's form with its parameters as
// named constants (runtime values, as in the plugin, so no term folds away at compile time).
json workload_w_equations(std::size_t n, bool with_constants) {
    json w = workload_w(n);
    json params = {{"state", {"x", "y"}}, {"rhs", {"y", "x - x^3 + f"}}};
    if (with_constants) {
        params["rhs"][1] = "alpha*x - beta*x^3 - delta*y + f";
        params["constants"] = {{"alpha", 1}, {"beta", 1}, {"delta", 0}};
    }
    w["system"] = {{"plugin", "equations"}, {"params", params}};
    return w;
}

// One system of the equations section, with its best times over the interleaved runs.
struct EquationsVariant {
    std::string label;
    json experiment;
    double flow_map = nan_value;            // best wall time of the flow-map stage
    double user = nan_value;                // best user CPU time of the whole run
    double max_ftle_difference = nan_value; // against the built-in plugin's field
};

struct EquationsTiming {
    std::size_t n = 0;
    int repeat = 0;
    double first_validate = nan_value, cached_validate = nan_value; // `validate`: compiling, then from the cache
    std::vector<EquationsVariant> variants;                         // the built-in plugin first
    std::string note;
};

// One `run` of an experiment for the equations section: the flow-map stage's wall time, the run's user CPU time and
// the FTLE field.
struct EquationsRun {
    double flow_map = nan_value, user = nan_value;
    std::vector<double> ftle;
};
EquationsRun run_for_equations(const Bench &bench, const json &experiment, const std::string &tag) {
    const fs::path file = bench.out / ("equations-" + tag + ".json"), dir = bench.out / ("equations-" + tag);
    std::ofstream(file) << experiment.dump(2);
    fs::remove_all(dir);
    const auto r =
        run_process({bench.program.string(), "run", file.string(), "--out", dir.string(), "--quiet", "--threads", "2"});
    if (r.status != 0) throw std::runtime_error("equations section, " + tag + ": " + first_line(r.output));
    EquationsRun out;
    out.user = r.user_seconds;
    const json manifest = json::parse(std::ifstream(dir / "manifest.json"));
    for (const auto &stage : manifest["stages"])
        if (stage["stage"] == "flow map") out.flow_map = stage["wall_seconds"].get<double>();
    const std::size_t n = experiment["grid"]["n"][0].get<std::size_t>();
    out.ftle = read_ftle_netcdf(dir / "fields.nc", n * n);
    return out;
}

// The first compile (a cold `validate` against one from the cache, in a fresh cache folder), then the built-in and
// the equations runs interleaved, `repeat` times each, best of each kept: load changes hit all alike.
EquationsTiming equations_section(const Bench &bench, std::size_t n, int repeat) {
    EquationsTiming timing;
    timing.n = n;
    timing.repeat = std::max(repeat, 1);
    timing.variants = {
        {"built-in duffing", workload_w(n)},
        {"equations \"x - x^3 + f\"", workload_w_equations(n, false)},
        {"equations \"alpha*x - beta*x^3 - delta*y + f\", constants 1, 1, 0", workload_w_equations(n, true)}};
    const fs::path cache = bench.out / "equations-cache";
    fs::remove_all(cache);
    ::setenv("GEOBARRIER_EQUATIONS_CACHE", cache.c_str(), 1);
    std::cerr << "[equations] W " << n << " x " << n << ": first compile, then built-in and equations runs ...\n";
    const fs::path file = bench.out / "equations-validate.json";
    std::ofstream(file) << timing.variants[1].experiment.dump(2);
    const auto cold = run_process({bench.program.string(), "validate", file.string()});
    const auto warm = run_process({bench.program.string(), "validate", file.string()});
    if (cold.status != 0 || warm.status != 0) {
        timing.note = "failed: " + first_line(cold.output + warm.output);
        ::unsetenv("GEOBARRIER_EQUATIONS_CACHE");
        return timing;
    }
    timing.first_validate = cold.wall_seconds;
    timing.cached_validate = warm.wall_seconds;
    const auto best = [](double a, double b) { return std::isnan(a) ? b : std::min(a, b); };
    for (int attempt = 0; attempt < timing.repeat; ++attempt) {
        std::vector<double> builtin_ftle;
        for (std::size_t v = 0; v < timing.variants.size(); ++v) {
            EquationsVariant &variant = timing.variants[v];
            const EquationsRun r = run_for_equations(bench, variant.experiment, std::to_string(v));
            variant.flow_map = best(variant.flow_map, r.flow_map);
            variant.user = best(variant.user, r.user);
            if (v == 0) builtin_ftle = r.ftle;
            double worst = 0.0;
            for (std::size_t k = 0; k < r.ftle.size(); ++k)
                worst = std::max(worst, std::abs(r.ftle[k] - builtin_ftle[k]));
            variant.max_ftle_difference = worst;
        }
    }
    ::unsetenv("GEOBARRIER_EQUATIONS_CACHE");
    for (const EquationsVariant &v : timing.variants)
        std::cerr << "  " << v.label << ": flow map " << fixed(v.flow_map, 2) << " s, user " << fixed(v.user, 2)
                  << " s\n";
    return timing;
}

void equations_markdown(std::ostream &md, const EquationsTiming &t) {
    md << "## Equations written in the experiment\n\nW at N = " << t.n
       << " with the oscillator written in the experiment (the `equations` system) against the built-in `duffing` "
          "plugin, the default integrator, 2 threads, best of "
       << t.repeat << " interleaved runs each.";
    if (!t.note.empty()) {
        md << " " << t.note << "\n\n";
        return;
    }
    const EquationsVariant &builtin = t.variants.front();
    md << "\n\n| system | flow map (s) | × built-in | user CPU of the run (s) | × built-in | max FTLE difference |\n"
          "|---|---|---|---|---|---|\n";
    for (const EquationsVariant &v : t.variants)
        md << "| " << v.label << " | " << fixed(v.flow_map, 2) << " | " << fixed(v.flow_map / builtin.flow_map, 3)
           << " | " << fixed(v.user, 2) << " | " << fixed(v.user / builtin.user, 3) << " | "
           << sci(v.max_ftle_difference) << " |\n";
    md << "\nFirst compile: `geobarrier validate` took " << fixed(t.first_validate, 2) << " s with an empty cache and "
       << fixed(t.cached_validate, 2) << " s from the cache, so the compile costs "
       << "about " << fixed(t.first_validate - t.cached_validate, 2) << " s, once. Without its constants the "
       << "equations' Jacobian entry d(y')/dy is the literal 0 and y' has no alpha, beta, delta products, which "
          "the built-in plugin computes at run time.\n\n";
}

namespace {

// The command line of the bench.
struct BenchOptions {
    std::size_t n = 1000, memory_n = 4000, scipy_n = 0, extraction_n = 1000, suite_n = 0;
    std::string out_dir = "out/bench", peers_dir, peers_source, program, machine, source = ".", program_avx2;
    std::set<std::string> sections;
    std::vector<std::string> tries;
    bool quick = false;
    int repeat = 0;

    bool wants(const char *section) const { return sections.count(section) > 0; }
    // Runs per configuration, the fastest kept: --repeat, else `fallback`.
    int best_of(int fallback) const { return repeat > 0 ? repeat : fallback; }
};

// Parses the command line into `o`; returns the exit code when the program should stop (--help, a bad option).
std::optional<int> parse_options(int argc, char **argv, BenchOptions &o) {
    CLI::App app{"geobarrier-bench: speed and accuracy of the flow-map engine on workload W"};
    std::string sections_text;
    app.add_option("--n", o.n, "grid points per direction of the headline runs")->check(CLI::Range(10, 20000));
    app.add_option("--out", o.out_dir,
                   "folder for bench.csv, bench.md, pareto.png, the cached exact fields and scratch");
    app.add_option("--peers", o.peers_dir, "folder with the built peers (reference, odeint_baseline)")->required();
    app.add_option("--peers-source", o.peers_source, "folder with the baselines' sources (scipy_baseline.py)");
    app.add_option("--program", o.program, "the geobarrier program")->required();
    app.add_option("--source", o.source, "the source tree (experiments/ for the extraction section)");
    app.add_option("--machine", o.machine, "one line describing the machine, for the report");
    app.add_option("--memory-n", o.memory_n, "grid points per direction of the memory run");
    app.add_option("--scipy-n", o.scipy_n, "grid of the SciPy comparison (default: --n; 300 with --quick)");
    app.add_option("--extraction-n", o.extraction_n, "grid points per direction of the extraction runs");
    app.add_option("--sections", sections_text,
                   "comma-separated: headline,threads,widths,scaling,memory,extraction,scipy,equations,suite,ndim,"
                   "frames,sweep,gyre (default: all but sweep and gyre with --quick, all without); suite, ndim, "
                   "frames or equations alone need no baseline");
    app.add_option("--repeat", o.repeat,
                   "runs per configuration, the fastest kept (default: 2 for threads and scaling, 1 elsewhere)");
    app.add_option("--try", o.tries,
                   "NAME=JSON: also run W with this patch merged into the experiment (RFC 7386, e.g. "
                   "'step 0.4={\"integrator\":{\"step\":0.4}}'), next to the headline; repeatable");
    app.add_option("--suite-n", o.suite_n, "grid points per direction of the accuracy suite (default 101)");
    app.add_option("--program-avx2", o.program_avx2,
                   "the geobarrier program of an AVX2-only build (-march=x86-64-v3) of the same source: section "
                   "'widths' times W's default with it beside the native build, and 'extraction' W's hyperbolic "
                   "extractor");
    app.add_flag("--quick", o.quick, "the short run for the docs (a few minutes): no sweep, no double gyre");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError &e) {
        return app.exit(e);
    }
    const std::string text =
        sections_text.empty()
            ? std::string(o.quick ? "headline,threads,widths,scaling,memory,extraction,scipy,equations,suite,ndim,"
                                    "frames"
                                  : "headline,threads,widths,scaling,memory,extraction,scipy,equations,suite,ndim,"
                                    "frames,sweep,gyre")
            : sections_text;
    std::istringstream in(text);
    for (std::string section; std::getline(in, section, ',');) o.sections.insert(section);
    if (o.scipy_n == 0) o.scipy_n = o.quick ? 300 : o.n;
    return std::nullopt;
}

// The rows of every section, for the report.
struct BenchResults {
    std::vector<double> exact; // W's exact FTLE at N
    Row base;                  // the naive Boost.Odeint baseline at N
    std::vector<Row> headline, scipy, threads, widths, scaling, extraction, sweep, gyre;
    std::optional<Row> default_row, unchecked_row, memory;
    std::string suite_md, ndim_md, frames_md;
    std::optional<EquationsTiming> equations;
};

// Headline: W at N, the baseline and the defaults, presets and paper settings, side by side; and the --try patches.
void headline_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    res.exact = bench.exact_w(o.n, true);
    res.base = bench.baseline("headline", o.n, res.exact);
    bench.add(res.base);
    res.headline = {res.base};
    if (o.wants("headline")) {
        for (const Config &c : headline_configs()) {
            // The default and its unchecked twin are compared with each other (the step check's cost, a few
            // percent): the fastest of 3 runs each, where one run's noise would swamp the difference.
            const bool pair = c.name == "default" || c.name == unchecked_config;
            Row r = bench.run("headline", "W", workload_w(o.n), c, res.exact, res.base.wall, o.best_of(pair ? 3 : 1));
            bench.add(r);
            res.headline.push_back(r);
            if (c.name == "default") res.default_row = r;
            if (c.name == unchecked_config) res.unchecked_row = r;
        }
    }
    for (const std::string &t : o.tries) {
        const std::size_t eq = t.find('=');
        if (eq == std::string::npos || eq == 0) throw std::runtime_error("--try " + t + ": expected NAME=JSON");
        json patch;
        try {
            patch = json::parse(t.substr(eq + 1));
        } catch (const json::parse_error &e) {
            throw std::runtime_error("--try " + t.substr(0, eq) + ": the patch is not JSON (" + e.what() + ")");
        }
        Row r = bench.run("headline", "W", workload_w(o.n), {t.substr(0, eq), patch, 2}, res.exact, res.base.wall,
                          o.best_of(1));
        bench.add(r);
        res.headline.push_back(r);
    }
}

// SciPy, when installed, with the baseline and the default at the same grid.
void scipy_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    const std::size_t n = o.scipy_n;
    const std::vector<double> exact_s = n == o.n ? res.exact : bench.exact_w(n, true);
    std::optional<Row> s = bench.scipy("scipy", n, exact_s);
    if (!s) {
        std::cerr << "SciPy is not installed (python3-scipy): no SciPy baseline\n";
        return;
    }
    Row b = n == o.n ? res.base : bench.baseline("scipy", n, exact_s);
    Row d = n == o.n && res.default_row
                ? *res.default_row
                : bench.run("scipy", "W", workload_w(n), {"default", json::object(), 2}, exact_s, b.wall);
    s->ratio = b.wall / s->wall;
    for (Row *r : {&b, &d, &*s}) {
        r->section = "scipy";
        bench.add(*r);
        res.scipy.push_back(*r);
    }
    if (n == o.n) res.headline.push_back(*s);
}

// Threads: the default on 1 and 2 threads, best of two runs each (ratios between runs are the point).
void threads_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    for (int t : {1, 2}) {
        Row r = bench.run("threads", "W", workload_w(o.n), {"default", json::object(), t}, res.exact, res.base.wall,
                          o.best_of(2));
        r.name = "default, " + std::to_string(t) + (t == 1 ? " thread" : " threads");
        bench.add(r);
        res.threads.push_back(r);
    }
}

// Vector widths: W's default on the native build and on an AVX2-only build of the same source.
void widths_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    const fs::path native = bench.program;
    for (const auto &[label, program_path] :
         {std::pair<std::string, fs::path>{"default, native build", native},
          std::pair<std::string, fs::path>{"default, AVX2-only build (-march=x86-64-v3)",
                                           fs::absolute(o.program_avx2)}}) {
        bench.program = program_path;
        Row r = bench.run("widths", "W", workload_w(o.n), {label, json::object(), 2}, res.exact, res.base.wall,
                          o.best_of(2));
        bench.add(r);
        res.widths.push_back(r);
    }
    bench.program = native;
}

// Scaling in the number of grid points: the default from N = 200 to 2000, best of two runs each (five below
// N = 1000: a run of a few tens of milliseconds on a shared machine needs more tries to show its cost), with errors
// where an exact field is cached or cheap enough to compute. The interior max error is set by a handful of points on
// razor-thin FTLE ridges, so which grid lands on them is luck: N = 700 and 1400 are always checked besides the
// headline's N (their exact fields are computed once, then cached).
void scaling_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    for (std::size_t s : {200, 400, 700, 1000, 1400, 2000}) {
        const std::vector<double> e = s == o.n ? res.exact : bench.exact_w(s, !o.quick || s == 700 || s == 1400);
        Row r = bench.run("scaling", "W", workload_w(s), {"default", json::object(), 2}, e, nan_value,
                          o.best_of(s < 1000 ? 5 : 2));
        bench.add(r);
        res.scaling.push_back(r);
    }
}

// Extraction costs: the paper's hyperbolic and elliptic experiments with the grid overridden.
void extraction_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    for (const char *name : {"duffing-damped-attractor", "duffing-kam"}) {
        const fs::path file = bench.source / "experiments" / (std::string(name) + ".json");
        json base_experiment = json::parse(std::ifstream(file));
        base_experiment["grid"]["n"] = {o.extraction_n, o.extraction_n};
        base_experiment["output"]["plots"] = false;
        // As written (the experiments' adaptive dopri5 at 1e-8), and with the default integrator, where the flow
        // map is faster and the extraction stands out.
        json with_defaults = base_experiment;
        with_defaults.erase("integrator");
        using Labelled = std::pair<const char *, const json &>;
        for (const auto &[label, experiment] :
             {Labelled{"as written", base_experiment}, Labelled{"default integrator", with_defaults}}) {
            Row r = bench.run("extraction", name, experiment, {label, json::object(), 2}, {});
            bench.add(r);
            res.extraction.push_back(r);
        }
    }
    // The elliptic lambda-line fallback (docs/extractors.md, elliptic step 8): the double gyre's eta-lines keep no
    // barrier, so the fallback runs; the grid keeps the box's 2:1 aspect. The experiment has no integrator: as
    // written is the default integrator.
    const fs::path gyre_file = bench.source / "experiments" / "double-gyre-elliptic.json";
    json gyre = json::parse(std::ifstream(gyre_file));
    gyre["grid"]["n"] = {o.extraction_n, std::max<std::size_t>(o.extraction_n / 2, 2)};
    gyre["output"]["plots"] = false;
    Row r = bench.run("extraction", "double-gyre-elliptic", gyre, {"default integrator", json::object(), 2}, {});
    bench.add(r);
    res.extraction.push_back(r);
    // Workload W itself with each extractor at its defaults (the runner adds the fields an extractor needs): a
    // user's first run on the paper's first example. Best of nine: these stages take about a second each, one run's
    // ratio to its flow map moves by +-0.2 on a shared machine, and the hyperbolic one sits near 1 (the criterion of
    // issue 16), so its median needs more runs than five.
    const auto w_row = [&](const char *extractor, const std::string &label) {
        json w = workload_w(o.extraction_n);
        w["extractors"] = json::array({{{"plugin", extractor}}});
        Row wr = bench.run("extraction", std::string("W, ") + extractor, w, {label, json::object(), 2}, {}, nan_value,
                           o.best_of(9));
        bench.add(wr);
        res.extraction.push_back(wr);
    };
    for (const char *extractor : {"hyperbolic", "elliptic", "parabolic"}) w_row(extractor, "default integrator");
    // The hyperbolic extractor, the costliest on W, on the AVX2-only build as well: its tensor-line evaluation and
    // sampling take their own code path there (core/src/fields/cell_corners.hpp).
    if (!o.program_avx2.empty()) {
        const fs::path native = bench.program;
        bench.program = fs::absolute(o.program_avx2);
        w_row("hyperbolic", "default integrator, AVX2-only build (-march=x86-64-v3)");
        bench.program = native;
    }
}

// The double gyre: the default and the paper-like settings against its exact field.
void gyre_section(Bench &bench, const BenchOptions &o, BenchResults &res) {
    const std::vector<double> exact_g = bench.exact_gyre(o.n);
    for (const Config &c : std::vector<Config>{
             {"default", json::object(), 2},
             {"quality draft", {{"quality", "draft"}}, 2},
             {"dopri5 1e-6/1e-4, aux 1e-4", with(integrator("dopri5", 1e-6, 1e-4), aux(1e-4)), 2},
             {"dopri5 1e-6/1e-4, variational", with(integrator("dopri5", 1e-6, 1e-4), variational), 2},
             {"dopri5 1e-8/1e-10, variational", with(integrator("dopri5", 1e-8, 1e-10), variational), 2}}) {
        Row r = bench.run("gyre", "double gyre", workload_gyre(o.n), c, exact_g, nan_value, o.best_of(1));
        bench.add(r);
        res.gyre.push_back(r);
    }
}

// The report's opening: the run's conditions and the headline's verdicts (also on stdout).
void report_headline(std::ostream &md, const BenchOptions &o, const BenchResults &res, const std::string &load_before,
                     double bench_minutes) {
    const std::size_t n = o.n;
    md << "Workload W at N = " << n << " (" << n * n << " grid points), T = 8π";
    if (!o.machine.empty()) md << ", on " << o.machine;
    md << ". Load average " << load_before << " before the bench, " << load_average() << " after; the bench took "
       << fixed(bench_minutes, 1) << " min" << (o.quick ? " (--quick)" : "") << ".";
    if (std::stod(load_before) > static_cast<double>(::sysconf(_SC_NPROCESSORS_ONLN)))
        md << " **The machine was busy** (load above its core count): times are inflated and thread ratios "
              "understated; the ratios between rows of one table are what to compare.";
    md << "\n\n";
    const std::optional<Row> &memory_row = res.memory;
    if (res.default_row) {
        const Row &d = *res.default_row;
        const bool fast = d.ratio >= 30, accurate = d.err.mean <= 1e-4 && d.err.interior_max <= 0.05;
        md << "**Headline.** The default (no `integrator`, no `cauchy_green` keys) at N = " << n << ": "
           << fixed(d.wall, 2) << " s for the whole process, " << fixed(d.ratio, 1)
           << "× faster than the naive Boost.Odeint baseline (" << fixed(res.base.wall, 2)
           << " s, same run; target ≥ 30×: " << (fast ? "met" : "NOT met") << "); FTLE error mean " << sci(d.err.mean)
           << ", interior max " << sci(d.err.interior_max)
           << " (targets ≤ 1e-4 and ≤ 0.05: " << (accurate ? "met" : "NOT met") << ").";
        if (res.unchecked_row)
            md << " The step check (the default's error control) costs "
               << fixed(100.0 * (d.wall / res.unchecked_row->wall - 1.0), 1) << "% against the same steps unchecked (`"
               << unchecked_config << "`, " << fixed(res.unchecked_row->wall, 2) << " s; fastest of 3 runs each).";
        if (memory_row)
            md << " The " << o.memory_n << " × " << o.memory_n << " grid: peak resident memory "
               << fixed(memory_row->peak_mib, 0) << " MiB (target < 2048 MiB: "
               << (std::isfinite(memory_row->peak_mib) && memory_row->peak_mib < 2048 ? "met" : "NOT met") << "), "
               << fixed(memory_row->wall, 1) << " s.";
        md << "\n\n";
        std::cout << "default at N = " << n << ": " << fixed(d.wall, 2) << " s, " << fixed(d.ratio, 1)
                  << "x the baseline (" << fixed(res.base.wall, 2) << " s), FTLE error mean " << sci(d.err.mean)
                  << ", interior max " << sci(d.err.interior_max) << "\n";
    }
    if (memory_row)
        std::cout << o.memory_n << " x " << o.memory_n << " grid: peak " << fixed(memory_row->peak_mib, 0) << " MiB, "
                  << fixed(memory_row->wall, 1) << " s" << (memory_row->note.empty() ? "" : " " + memory_row->note)
                  << "\n";
}

// The trade at N (the headline rows and the sweep), and SciPy.
void report_trade(Bench &bench, const BenchOptions &o, const BenchResults &res) {
    std::ostream &md = bench.md;
    md << "## The trade at N = " << o.n
       << "\n\nWall time of the whole process (start-up, plugin loading and NetCDF output included); flow map = "
          "the manifest's flow-map stage (trajectories, gradient and Cauchy–Green fields); × baseline = baseline "
          "wall time / this wall time. Errors against the exact field (rkf78 1e-12, variational); interior leaves "
          "out 2% of the box on each side.\n\n";
    md << "![FTLE error against wall time, log-log](images/performance-pareto.png)\n\n";
    bench.table(res.headline);
    if (!res.sweep.empty()) {
        md << "### The sweep: tolerance, stepper, gradient method, offset, fixed steps, block size\n\n";
        bench.table(res.sweep);
    }
    if (!res.scipy.empty()) {
        md << "## SciPy at N = " << o.scipy_n
           << "\n\nSciPy's `solve_ivp` (RK45 at the paper's tolerances, one stacked "
              "solve over all auxiliary trajectories, one thread), the Boost.Odeint "
              "baseline and the default on the same grid in the same run.\n\n";
        bench.table(res.scipy);
    }
}

void report_threads(Bench &bench, const BenchOptions &o, const std::vector<Row> &thread_rows) {
    if (thread_rows.size() != 2) return;
    const double speedup = thread_rows[0].wall / thread_rows[1].wall;
    const double engine = thread_rows[0].flow_map / thread_rows[1].flow_map;
    bench.md << "## Threads\n\nThe default at N = " << o.n
             << " on 1 and 2 threads (best of two runs each): " << fixed(speedup, 2) << "× for the whole process, "
             << fixed(engine, 2) << "× for the flow-map stage (target ≥ 1.8×).\n\n";
    bench.table(thread_rows);
    std::cout << "threads: 2 vs 1 at N = " << o.n << ": " << fixed(speedup, 2) << "x (flow map " << fixed(engine, 2)
              << "x)\n";
}

void report_widths(std::ostream &md, std::size_t n, const std::vector<Row> &width_rows) {
    if (width_rows.size() != 2) return;
    // The machine's limit: the fused dop853 step with the variational equations of Duffing costs, per trajectory
    // and step, 58 multiply-adds per component for the stage states and the new state (the tableau's nonzero
    // a_ij and b_j) x 7 components, plus about 10 operations per stage for the field, the Jacobian and DF' =
    // Dv DF over 12 stages, plus 17 for the step check: about 543 vector-lane operations. The floor is that
    // many lane operations at the core's peak rate of lane multiply-adds, measured here for each width
    // (peak_rate.cpp): data sheets do not say how many 512-bit FMA units a given model, or a virtual machine's
    // share of it, has.
    const double ops = 58.0 * 7 + 10.0 * 12 + 17.0;
    const double lane_steps = static_cast<double>(n) * static_cast<double>(n) * 77.0;
    const double peak[2] = {peak_lane_fma_rate(8), peak_lane_fma_rate(4)};
    md << "## Vector widths and the machine's limit\n\nW's default at N = " << n
       << " on the native build and on an AVX2-only build (`-march=x86-64-v3 -ffp-contract=off`, "
          "`GEOBARRIER_NATIVE=OFF`) of the same source, same run, best of two. The fused dop853 step "
          "(Duffing, variational) costs about "
       << fixed(ops, 0)
       << " vector-lane operations (multiply-adds counted once) per trajectory-step. The floor is that many "
          "operations at the core's peak rate of lane multiply-adds, measured in the same run for each width "
          "(independent FMA chains on one core, best slice): "
       << sci(peak[0]) << " per second with 8-lane (AVX-512) vectors, " << sci(peak[1]) << " with 4-lane (AVX2) vectors"
       << (peak[0] > 0 && peak[0] < 1.5 * peak[1]
               ? " — no faster than AVX2 per core on this CPU (one 512-bit FMA unit, or a throttled clock), "
                 "so the AVX2 build loses nothing here"
               : "")
       << ". The share of the floor below is what the step achieves of it; the rest is what scheduling could "
          "still win (the 12 stages x 7 components of live values exceed the 32 vector registers, so stages "
          "spill to memory, and not every operation is a multiply-add). Beyond the floor, speed can only come "
          "from fewer operations per trajectory (fewer stages or steps for the same accuracy).\n\n| build | wall "
          "(s) | flow map (s) | × baseline | lane-steps per core-second | floor (peak / ops) | share of the floor "
          "|\n|---|---|---|---|---|---|---|\n";
    for (std::size_t i = 0; i < width_rows.size(); ++i) {
        const Row &r = width_rows[i];
        const double rate = lane_steps / (r.flow_map * r.threads), floor_rate = peak[i] / ops;
        md << "| " << r.name << " | " << fixed(r.wall, 2) << " | " << fixed(r.flow_map, 2) << " | " << fixed(r.ratio, 1)
           << " | " << sci(rate) << " | " << sci(floor_rate) << " | "
           << (floor_rate > 0 ? fixed(100 * rate / floor_rate, 0) + "%" : std::string("–")) << " |\n";
    }
    md << "\n";
}

void report_scaling(std::ostream &md, const std::vector<Row> &scaling_rows) {
    if (scaling_rows.empty()) return;
    md << "## Scaling in the number of grid points\n\nThe default on 2 threads (best of five runs below N = 1000, of "
          "two from there). Time per point should not depend on N (linear within 15%); the flow-map stage leaves "
          "out the process start-up and the output, which weigh on small grids. The errors at N = 700 and 1400 "
          "check that the default's accuracy is no accident of the headline grid: the interior max comes from "
          "one or two points on razor-thin FTLE ridges.\n\n"
          "| N | points | wall (s) | flow map (s) | µs per point (wall) | µs per point "
          "(flow map) | flow map per point / N = 1000's | peak RSS (MiB) | mean err | interior max |\n"
          "|---|---|---|---|---|---|---|---|---|---|\n";
    double reference = nan_value;
    for (const Row &r : scaling_rows)
        if (r.nx == 1000) reference = r.flow_map / 1e6;
    double lo = HUGE_VAL, hi = 0;
    for (const Row &r : scaling_rows) {
        const double points = static_cast<double>(r.nx * r.ny), per = r.flow_map / points;
        md << "| " << r.nx << " | " << r.nx * r.ny << " | " << fixed(r.wall, 2) << " | " << fixed(r.flow_map, 2)
           << " | " << fixed(1e6 * r.wall / points, 3) << " | " << fixed(1e6 * per, 3) << " | "
           << fixed(per / reference, 2) << " | " << fixed(r.peak_mib, 0) << " | " << sci(r.err.mean) << " | "
           << sci(r.err.interior_max) << " |\n";
        if (std::isfinite(per)) {
            lo = std::min(lo, per);
            hi = std::max(hi, per);
        }
    }
    md << "\nFlow-map time per point varies by " << fixed(100 * (hi / lo - 1), 0)
       << "% between the fastest and the slowest N.\n\n";
    std::cout << "scaling 200..2000: flow-map time per point varies by " << fixed(100 * (hi / lo - 1), 0) << "%\n";
}

// "median (least–most) over n runs" of per-run ratios; "–" for fewer than two runs (the previous column has it).
std::string ratio_spread(std::vector<double> ratios) {
    if (ratios.size() < 2) return "–";
    std::sort(ratios.begin(), ratios.end());
    const std::size_t n = ratios.size();
    const double median = n % 2 ? ratios[n / 2] : 0.5 * (ratios[n / 2 - 1] + ratios[n / 2]);
    return fixed(median, 2) + " (" + fixed(ratios.front(), 2) + "–" + fixed(ratios.back(), 2) + ") over " +
           std::to_string(n) + " runs";
}

void report_extraction(std::ostream &md, std::size_t extraction_n, const std::vector<Row> &extraction_rows) {
    if (extraction_rows.empty()) return;
    md << "## Extraction costs\n\nThe paper's hyperbolic (`experiments/duffing-damped-attractor.json`) and "
          "elliptic (`experiments/duffing-kam.json`) experiments with the grid overridden to "
       << extraction_n << " × " << extraction_n
       << " and pictures off, as written (adaptive dopri5 at rtol 1e-8) and with the default integrator, and "
          "`experiments/double-gyre-elliptic.json` at "
       << extraction_n << " × " << std::max<std::size_t>(extraction_n / 2, 2)
       << " (the default integrator; its eta-lines keep no barrier, so the extractor's time includes the "
          "lambda-line fallback, docs/extractors.md, elliptic step 8), and workload W at "
       << extraction_n << " × " << extraction_n
       << " with each extractor at its defaults (best of nine runs), and its hyperbolic extractor again on the "
          "AVX2-only build of \"Vector widths\"; stage times from the manifest of the least-wall run, next to the "
          "flow map of the same run. The last column gives, for the extractor, the median and the range of that "
          "ratio over all of the row's runs: on a shared machine one run's ratio moves by ±0.2.\n\n"
          "| experiment | integrator | wall (s) | stage | seconds | × flow map | extractor × flow map, every run "
          "|\n|---|---|---|---|---|---|---|\n";
    for (const Row &r : extraction_rows) {
        if (!r.note.empty()) {
            md << "| " << r.workload << " | " << r.name << " | – | " << r.note << " | – | – | – |\n";
            continue;
        }
        // The flow map of the same run as the stages (r.flow_map is the least over a row's repeats).
        double flow_map = r.flow_map;
        for (const auto &s : r.stages)
            if (s["stage"] == "flow map") flow_map = s["wall_seconds"].get<double>();
        for (const auto &s : r.stages) {
            const double t = s["wall_seconds"].get<double>();
            const bool extractor = s["stage"].get<std::string>().rfind("extractor", 0) == 0;
            md << "| " << r.workload << " | " << r.name << " | " << fixed(r.wall, 2) << " | "
               << s["stage"].get<std::string>() << " | " << fixed(t, 2) << " | " << fixed(t / flow_map, 2) << " | "
               << (extractor ? ratio_spread(r.extractor_ratios) : "") << " |\n";
            if (extractor)
                std::cout << r.workload << " (" << r.name << "): " << s["stage"].get<std::string>() << " "
                          << fixed(t, 2) << " s = " << fixed(t / flow_map, 2) << "x the flow map ("
                          << fixed(flow_map, 2) << " s)\n";
        }
    }
    md << "\n";
}

// The report after the headline: every section that ran, in the order of docs/performance.md.
void report_sections(Bench &bench, const BenchOptions &o, const BenchResults &res) {
    std::ostream &md = bench.md;
    report_trade(bench, o, res);
    report_threads(bench, o, res.threads);
    report_widths(md, o.n, res.widths);
    if (!res.suite_md.empty()) md << res.suite_md;
    if (!res.ndim_md.empty()) md << res.ndim_md;
    report_scaling(md, res.scaling);
    if (res.memory) {
        md << "## Memory\n\nW on a " << o.memory_n << " × " << o.memory_n
           << " grid (FTLE only, no picture), the defaults, 2 threads; flow map and Cauchy–Green fields computed in "
              "tiles of grid rows, only the FTLE kept for the whole grid. Peak resident memory by GNU time.\n\n";
        bench.table({*res.memory});
    }
    report_extraction(md, o.extraction_n, res.extraction);
    if (!res.frames_md.empty()) md << res.frames_md;
    if (!res.gyre.empty()) {
        md << "## The double gyre\n\n`experiments/double-gyre.json` (A = 0.1, ε = 0.25, ω = 2π/10, T = 15) on an "
           << o.n << " × " << o.n / 2
           << " grid, against its exact field (geobarrier, rkf78 at 1e-12 on the variational equations).\n\n";
        bench.table(res.gyre);
    }
    if (res.equations) equations_markdown(md, *res.equations);
}

// Opens the output folder and bench.csv with its header.
void open_bench(Bench &bench, const BenchOptions &o) {
    bench.out = fs::absolute(o.out_dir);
    bench.peers = fs::absolute(o.peers_dir);
    bench.program = fs::absolute(o.program);
    bench.source = fs::absolute(o.source);
    bench.set_peers_source(o.peers_source.empty() ? bench.source / "apps" / "bench" / "baselines"
                                                  : fs::path(o.peers_source));
    fs::create_directories(bench.out);
    bench.csv.open(bench.out / "bench.csv");
    bench.csv << "section,workload,name,nx,ny,threads,wall_seconds,flow_map_seconds,peak_mib,rhs_evaluations,steps,"
                 "ratio_to_baseline,mean_error,p99_error,max_error,interior_max_error,missing,note\n";
}

} // namespace

int main(int argc, char **argv) {
    BenchOptions o;
    if (const std::optional<int> code = parse_options(argc, argv, o)) return *code;
    Bench bench;
    open_bench(bench, o);
    const std::string load_before = load_average();
    const auto bench_start = std::chrono::steady_clock::now();
    BenchResults res;

    // The equations system against the built-in plugin; alone, it needs neither the reference nor the baseline.
    if (o.wants("equations")) {
        res.equations = equations_section(bench, o.n, o.best_of(2));
        if (o.sections.size() == 1) {
            equations_markdown(bench.md, *res.equations);
            std::ofstream(bench.out / "bench.md") << bench.md.str();
            std::cerr << "wrote " << (bench.out / "bench.md").string() << "\n";
            return 0;
        }
    }
    // The accuracy suite alone (--sections suite) needs no baseline and no peers' reference.
    if (o.wants("suite")) res.suite_md = suite_section(bench, o.suite_n > 0 ? o.suite_n : 101);
    if (o.sections == std::set<std::string>{"suite"}) {
        std::ofstream(bench.out / "bench.md") << res.suite_md;
        std::cerr << "wrote " << (bench.out / "bench.csv").string() << " and bench.md\n";
        return 0;
    }

    // Systems of more than two components (section "ndim"); alone, it needs no baseline either.
    if (o.wants("ndim")) res.ndim_md = ndim_section(bench, std::min<std::size_t>(o.n, 300), o.best_of(2));
    if (o.sections == std::set<std::string>{"ndim"}) {
        std::ofstream(bench.out / "bench.md") << res.ndim_md;
        std::cerr << "wrote " << (bench.out / "bench.csv").string() << " and bench.md\n";
        return 0;
    }

    // Frames against separate runs (section "frames"); alone, it needs no baseline either.
    if (o.wants("frames")) res.frames_md = frames_section(bench, o.best_of(o.quick ? 1 : 2));
    if (o.sections == std::set<std::string>{"frames"}) {
        std::ofstream(bench.out / "bench.md") << res.frames_md;
        std::cerr << "wrote " << (bench.out / "bench.csv").string() << " and bench.md\n";
        return 0;
    }

    headline_section(bench, o, res);
    if (o.wants("scipy")) scipy_section(bench, o, res);
    if (o.wants("threads")) threads_section(bench, o, res);
    if (o.wants("widths") && !o.program_avx2.empty()) widths_section(bench, o, res);
    if (o.wants("scaling")) scaling_section(bench, o, res);
    if (o.wants("memory")) { // a large grid of W (FTLE only, no picture) with the defaults
        res.memory = bench.run("memory", "W", workload_w(o.memory_n), {"default", json::object(), 2}, {});
        bench.add(*res.memory);
    }
    if (o.wants("extraction")) extraction_section(bench, o, res);
    if (o.wants("sweep")) { // the full sweep (tolerance, stepper, gradient method, offset, rk4 steps, block size)
        for (const Config &c : sweep_configs()) {
            Row r = bench.run("sweep", "W", workload_w(o.n), c, res.exact, res.base.wall, o.best_of(1));
            bench.add(r);
            res.sweep.push_back(r);
        }
    }
    if (o.wants("gyre")) gyre_section(bench, o, res);
    const double bench_minutes =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - bench_start).count() / 60;

    report_headline(bench.md, o, res, load_before, bench_minutes);
    report_sections(bench, o, res);
    const fs::path picture = bench.out / "pareto.png";
    try {
        pareto_picture(picture, bench.rows, o.n);
    } catch (const std::exception &e) {
        std::cerr << "no Pareto picture: " << e.what() << "\n";
    }
    std::ofstream(bench.out / "bench.md") << bench.md.str();
    std::cerr << "wrote " << (bench.out / "bench.csv").string() << ", bench.md and pareto.png\n";
    return 0;
}
