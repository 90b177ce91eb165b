// Section "extraction": the paper's extraction experiments and W with each extractor. Reports every stage's time
// against the flow-map stage of the same run, and the extractor's ratio over all of a row's runs (median and range).
#include "../sections.hpp"

#include "../tables.hpp"

#include <algorithm>
#include <iostream>

namespace geobarrier::bench {

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

} // namespace geobarrier::bench
