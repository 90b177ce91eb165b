// geobarrier-bench: the speed/accuracy trade of the flow-map engine on workload W
// (the paper's first example, ../shared/peers/README.md), measured as whole
// processes side by side with the naive Boost.Odeint baseline, against the exact
// field. Writes bench.csv and a markdown table; timings live here, never in tests.
#include <geobarrier/cauchy_green.hpp>

#include <CLI/CLI.hpp>
#include <netcdf.h>
#include <nlohmann/json.hpp>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double two_pi = 6.283185307179586;
constexpr double horizon = 4 * two_pi; // T = 8 pi

struct ProcessResult {
    int status = -1;
    double wall_seconds = 0;
    double peak_mib = 0; // the child's maximum resident set size
    std::string output;
};

// Runs argv as a child process (stdout+stderr captured to a file), timing it as a whole process.
ProcessResult run_process(const std::vector<std::string> &argv, const std::vector<std::string> &env = {}) {
    const fs::path log = fs::temp_directory_path() / ("geobarrier-bench-" + std::to_string(::getpid()) + ".log");
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
        if (x == fill) x = std::nan("");
    return v;
}

struct ErrorStats {
    double mean = 0, p99 = 0, max = 0, interior_max = 0;
    std::size_t missing = 0; // NaN or masked where the reference is finite
};

// Errors against the exact FTLE; "interior" leaves out the outermost 2% of the box on each side.
ErrorStats ftle_errors(const std::vector<double> &ftle, const std::vector<double> &exact, std::size_t n) {
    ErrorStats s;
    std::vector<double> errors;
    errors.reserve(ftle.size());
    const std::size_t margin = std::max<std::size_t>(1, n / 50);
    for (std::size_t k = 0; k < ftle.size(); ++k) {
        if (!std::isfinite(exact[k])) continue;
        if (!std::isfinite(ftle[k])) {
            ++s.missing;
            continue;
        }
        const double e = std::abs(ftle[k] - exact[k]);
        errors.push_back(e);
        s.mean += e;
        s.max = std::max(s.max, e);
        const std::size_t i = k / n, j = k % n;
        if (i >= margin && j >= margin && i + margin < n && j + margin < n) s.interior_max = std::max(s.interior_max, e);
    }
    if (errors.empty()) return s;
    s.mean /= static_cast<double>(errors.size());
    const std::size_t at = static_cast<std::size_t>(0.99 * static_cast<double>(errors.size() - 1));
    std::nth_element(errors.begin(), errors.begin() + static_cast<std::ptrdiff_t>(at), errors.end());
    s.p99 = errors[at];
    return s;
}

json workload(std::size_t n) {
    return {{"description", "workload W (../shared/peers/README.md)"},
            {"system", {{"plugin", "duffing"}}},
            {"forcing", {{"plugin", "cosine"}, {"params", {{"amplitude", 0.08}}}}},
            {"grid", {{"x", {-1.8, 1.8}}, {"y", {-1.2, 1.2}}, {"n", {n, n}}}},
            {"time", {{"t0", 0}, {"t1", horizon}}},
            {"products", {"ftle"}},
            {"output", {{"plots", false}}}};
}

struct Config {
    std::string name;
    json settings; // merged into the workload (integrator, cauchy_green, quality...)
    int threads = 2;
};

std::vector<Config> sweep(bool quick) {
    std::vector<Config> configs = {
        {"default", json::object(), 2},
        {"default, 1 thread", json::object(), 1},
        {"paper tolerances, aux 1e-4",
         {{"integrator", {{"method", "dopri5"}, {"rtol", 1e-6}, {"atol", 1e-4}}},
          {"cauchy_green", {{"method", "auxiliary-grid"}, {"offset", 1e-4}}}},
         2},
        {"paper tolerances, variational",
         {{"integrator", {{"method", "dopri5"}, {"rtol", 1e-6}, {"atol", 1e-4}}},
          {"cauchy_green", {{"method", "variational"}}}},
         2},
    };
    if (quick) return configs;
    for (double tol : {1e-4, 1e-6, 1e-8, 1e-10}) {
        for (const char *method : {"dopri5", "rkf78"}) {
            configs.push_back({std::string(method) + " variational tol " + json(tol).dump(),
                               {{"integrator", {{"method", method}, {"rtol", tol}, {"atol", tol}}},
                                {"cauchy_green", {{"method", "variational"}}}},
                               2});
            configs.push_back({std::string(method) + " aux 1e-3 tol " + json(tol).dump(),
                               {{"integrator", {{"method", method}, {"rtol", tol}, {"atol", tol}}},
                                {"cauchy_green", {{"method", "auxiliary-grid"}, {"offset", 1e-3}}}},
                               2});
        }
    }
    for (int steps : {400, 800, 1600})
        configs.push_back({"rk4 variational " + std::to_string(steps) + " steps",
                           {{"integrator", {{"method", "rk4"}, {"step", horizon / steps}}},
                            {"cauchy_green", {{"method", "variational"}}}},
                           2});
    for (int batch : {1, 8, 32, 64, 128})
        configs.push_back({"default, batch " + std::to_string(batch), {{"integrator", {{"batch", batch}}}}, 2});
    return configs;
}

std::string fixed(double v, int digits) {
    char b[64];
    std::snprintf(b, sizeof b, "%.*f", digits, v);
    return b;
}
std::string sci(double v) {
    char b[64];
    std::snprintf(b, sizeof b, "%.1e", v);
    return b;
}

}  // namespace

int main(int argc, char **argv) {
    CLI::App app{"geobarrier-bench: speed and accuracy of the flow-map engine on workload W"};
    std::size_t n = 1000;
    std::string out_dir = "out/bench", peers_dir, program, machine;
    bool quick = false;
    app.add_option("--n", n, "grid points per direction")->check(CLI::Range(10, 20000));
    app.add_option("--out", out_dir, "folder for bench.csv, bench.md and scratch files");
    app.add_option("--peers", peers_dir, "folder with the built peers (reference, odeint_baseline)")->required();
    app.add_option("--program", program, "the geobarrier program")->required();
    app.add_option("--machine", machine, "one line describing the machine, for the report");
    app.add_flag("--quick", quick, "only the headline configurations");
    CLI11_PARSE(app, argc, argv);

    const fs::path out = fs::absolute(out_dir);
    fs::create_directories(out);
    const std::size_t count = n * n;

    // The exact field: rkf78 at 1e-12 on state + variational equations (../shared/peers/reference.cpp), cached.
    const fs::path dF_file = out / ("ref_N" + std::to_string(n) + "_DF.bin");
    if (!fs::exists(dF_file)) {
        std::cerr << "computing the exact field (reference, rkf78 1e-12) at N = " << n << " ...\n";
        const auto r = run_process({(fs::path(peers_dir) / "reference").string(), std::to_string(n), out.string()},
                                   {"OMP_NUM_THREADS=2"});
        if (r.status != 0) throw std::runtime_error("reference failed: " + r.output);
    }
    const std::vector<double> dF = read_doubles(dF_file, 4 * count);
    std::vector<double> exact(count);
    for (std::size_t k = 0; k < count; ++k)
        exact[k] = geobarrier::cauchy_green_at(dF[4 * k], dF[4 * k + 1], dF[4 * k + 2], dF[4 * k + 3], horizon).ftle;

    std::ofstream csv(out / "bench.csv");
    csv << "name,threads,wall_seconds,peak_mib,rhs_evaluations,steps,ratio_to_baseline,mean_error,p99_error,"
           "max_error,interior_max_error,missing\n";
    std::vector<json> rows;

    // The naive Boost.Odeint baseline (auxiliary grid, 2 threads), as a whole process.
    std::cerr << "baseline: odeint_baseline " << n << " aux ...\n";
    const auto base = run_process({(fs::path(peers_dir) / "odeint_baseline").string(), std::to_string(n), "aux",
                                   out.string()},
                                  {"OMP_NUM_THREADS=2"});
    if (base.status != 0) throw std::runtime_error("odeint_baseline failed: " + base.output);
    const auto base_ftle = read_doubles(out / ("odeint_aux_N" + std::to_string(n) + "_ftle.bin"), count);
    const ErrorStats base_err = ftle_errors(base_ftle, exact, n);
    long long base_rhs = 0;
    try {
        base_rhs = json::parse(base.output.substr(base.output.find('{')))["traj_rhs_evals"].get<long long>();
    } catch (...) {
    }
    rows.push_back({{"name", "odeint_baseline (dopri5 1e-6/1e-4, aux 1e-4, per trajectory)"},
                    {"threads", 2},
                    {"wall", base.wall_seconds},
                    {"peak", base.peak_mib},
                    {"rhs", base_rhs},
                    {"steps", 0},
                    {"ratio", 1.0},
                    {"err", {base_err.mean, base_err.p99, base_err.max, base_err.interior_max, base_err.missing}}});

    for (const Config &c : sweep(quick)) {
        json experiment = workload(n);
        for (const auto &item : c.settings.items()) experiment[item.key()] = item.value();
        const fs::path file = out / "experiment.json";
        std::ofstream(file) << experiment.dump(2);
        const fs::path run_dir = out / "run";
        fs::remove_all(run_dir);
        std::cerr << c.name << " ...\n";
        const auto r = run_process({program, "run", file.string(), "--out", run_dir.string(), "--quiet", "--threads",
                                    std::to_string(c.threads)});
        if (r.status != 0) {
            std::cerr << "  failed: " << r.output << "\n";
            continue;
        }
        const json manifest = json::parse(std::ifstream(run_dir / "manifest.json"));
        const auto ftle = read_ftle_netcdf(run_dir / "fields.nc", count);
        const ErrorStats err = ftle_errors(ftle, exact, n);
        rows.push_back({{"name", c.name},
                        {"threads", c.threads},
                        {"wall", r.wall_seconds},
                        {"peak", r.peak_mib},
                        {"rhs", manifest["integrator_stats"]["rhs_evaluations"]},
                        {"steps", manifest["integrator_stats"]["steps"]},
                        {"ratio", base.wall_seconds / r.wall_seconds},
                        {"err", {err.mean, err.p99, err.max, err.interior_max, err.missing}}});
    }

    std::ostringstream md;
    md << "Workload W at N = " << n << " (" << count << " grid points), T = 8π";
    if (!machine.empty()) md << ", on " << machine;
    md << ". Wall time of the whole process; ratio = baseline wall time / this wall time. FTLE errors against the "
          "exact field (rkf78 1e-12, variational).\n\n";
    md << "| configuration | threads | wall (s) | × baseline | peak RSS (MiB) | RHS evals | mean err | p99 err | max err "
          "| interior max |\n|---|---|---|---|---|---|---|---|---|---|\n";
    for (const json &row : rows) {
        const auto &e = row["err"];
        csv << '"' << row["name"].get<std::string>() << "\"," << row["threads"] << ',' << row["wall"] << ','
            << row["peak"] << ',' << row["rhs"] << ',' << row["steps"] << ',' << row["ratio"] << ',' << e[0] << ','
            << e[1] << ',' << e[2] << ',' << e[3] << ',' << e[4] << '\n';
        md << "| " << row["name"].get<std::string>() << " | " << row["threads"] << " | "
           << fixed(row["wall"].get<double>(), 2) << " | " << fixed(row["ratio"].get<double>(), 1) << " | "
           << fixed(row["peak"].get<double>(), 0) << " | " << sci(row["rhs"].get<double>()) << " | "
           << sci(e[0].get<double>()) << " | " << sci(e[1].get<double>()) << " | " << sci(e[2].get<double>())
           << " | " << sci(e[3].get<double>()) << " |\n";
    }
    std::ofstream(out / "bench.md") << md.str();
    std::cout << md.str();
    return 0;
}
