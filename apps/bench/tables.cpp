// Writing rows: bench.csv (every row as it comes) and the Markdown tables of rows with errors.
#include "tables.hpp"

#include "harness.hpp"
#include "repeat.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace geobarrier::bench {

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

std::string ratio_spread(std::vector<double> ratios) {
    if (ratios.size() < 2) return "–";
    std::sort(ratios.begin(), ratios.end());
    const std::size_t n = ratios.size();
    return fixed(median(ratios), 2) + " (" + fixed(ratios.front(), 2) + "–" + fixed(ratios.back(), 2) + ") over " +
           std::to_string(n) + " runs";
}

void Bench::open(const fs::path &out_dir) {
    out = out_dir;
    fs::create_directories(out);
    csv.open(out / "bench.csv");
    csv << "section,workload,name,nx,ny,threads,wall_seconds,flow_map_seconds,peak_mib,rhs_evaluations,steps,"
           "ratio_to_baseline,mean_error,p99_error,max_error,interior_max_error,missing,note\n";
}

void Bench::add(const Row &row) {
    rows.push_back(row);
    csv << '"' << row.section << "\",\"" << row.workload << "\",\"" << row.name << "\"," << row.nx << ',' << row.ny
        << ',' << row.threads << ',' << csv_number(row.wall) << ',' << csv_number(row.flow_map) << ','
        << csv_number(row.peak_mib) << ',' << csv_number(row.rhs) << ',' << csv_number(row.steps) << ','
        << csv_number(row.ratio) << ',' << csv_number(row.err.mean) << ',' << csv_number(row.err.p99) << ','
        << csv_number(row.err.max) << ',' << csv_number(row.err.interior_max) << ',' << row.err.missing << ",\""
        << row.note << "\"\n";
    csv.flush();
}

void Bench::table(const std::vector<Row> &rs) {
    md << "| configuration | threads | wall (s) | flow map (s) | × baseline | peak RSS (MiB) | RHS evals | steps | "
          "mean err | p99 err | max err | interior max |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const Row &r : rs) {
        md << "| " << r.name << (r.note.empty() ? "" : " (" + r.note + ")") << " | " << r.threads << " | "
           << fixed(r.wall, 2) << " | " << fixed(r.flow_map, 2) << " | " << fixed(r.ratio, 1) << " | "
           << fixed(r.peak_mib, 0) << " | " << sci(r.rhs) << " | " << sci(r.steps) << " | " << sci(r.err.mean) << " | "
           << sci(r.err.p99) << " | " << sci(r.err.max) << " | " << sci(r.err.interior_max) << " |\n";
    }
    md << "\n";
}

} // namespace geobarrier::bench
