// --- The equations system (docs/experiment-format.md, "Equations"): W with the oscillator written in the experiment,
// against the built-in duffing plugin. Needs no reference or baseline. ---
#include "../sections.hpp"

#include "../process.hpp"
#include "../repeat.hpp"
#include "../tables.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <stdexcept>

namespace geobarrier::bench {

namespace {

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
EquationsTiming equations_timing(const Bench &bench, std::size_t n, int repeat) {
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
    for (int attempt = 0; attempt < timing.repeat; ++attempt) {
        std::vector<double> builtin_ftle;
        for (std::size_t v = 0; v < timing.variants.size(); ++v) {
            EquationsVariant &variant = timing.variants[v];
            const EquationsRun r = run_for_equations(bench, variant.experiment, std::to_string(v));
            variant.flow_map = least(variant.flow_map, r.flow_map);
            variant.user = least(variant.user, r.user);
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

} // namespace

// The equations section's markdown: the timing above, then its table.
std::string equations_section(const Bench &bench, std::size_t n, int repeat) {
    std::ostringstream md;
    equations_markdown(md, equations_timing(bench, n, repeat));
    return md.str();
}

} // namespace geobarrier::bench
