// The harness: one geobarrier run of a configuration as a whole process, best of repeated runs, its times from the
// manifest (whole process, flow-map stage, every stage) and its errors against an exact field; the peers (the exact
// reference, the naive Boost.Odeint baseline, SciPy); and the rows every section adds to bench.csv.
#pragma once

#include "fields.hpp"
#include "workloads.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace geobarrier::bench {

namespace fs = std::filesystem;
using nlohmann::json;

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

class Bench {
  public:
    fs::path out, peers, program, source;
    std::ofstream csv;
    std::vector<Row> rows;
    std::ostringstream md;

    // The exact FTLE of W on an n x n grid: rkf78 at 1e-12 on state + variational equations
    // (apps/bench/baselines/exact_reference.cpp), cached in the output folder (peers.cpp).
    std::vector<double> exact_w(std::size_t n, bool compute);
    // The exact FTLE of the double gyre: geobarrier itself with rkf78 at 1e-12 on the variational equations (the
    // recipe of the W reference; the plugin's Jacobian is checked by check-plugin), cached.
    std::vector<double> exact_gyre(std::size_t n);
    // One geobarrier run as a whole process, best of `repeat`; errors against `exact` when given.
    Row run(const std::string &section, const std::string &workload, const json &base, const Config &c,
            const std::vector<double> &exact, double baseline_wall = nan_value, int repeat = 1);
    // The naive Boost.Odeint baseline of W (dopri5 1e-6/1e-4 per trajectory, auxiliary grid, 2 threads).
    Row baseline(const std::string &section, std::size_t n, const std::vector<double> &exact);
    // The SciPy baseline; nothing when SciPy is not installed.
    std::optional<Row> scipy(const std::string &section, std::size_t n, const std::vector<double> &exact);

    void set_peers_source(const fs::path &p) { m_peers_source = p; }
    // The FTLE field of the last run() that wrote one (NaN where masked).
    const std::vector<double> &last_ftle() const { return m_last_ftle; }

    // Opens the output folder and bench.csv with its header (tables.cpp).
    void open(const fs::path &out_dir);
    // Keeps a row and writes it to bench.csv (tables.cpp).
    void add(const Row &row);
    // A markdown table of rows with errors (tables.cpp).
    void table(const std::vector<Row> &rs);

  private:
    fs::path m_peers_source;
    std::vector<double> m_last_ftle;
};

} // namespace geobarrier::bench
