// --- The accuracy suite (issue 13): the quality presets on every built-in system at its documented parameters and
// on stress settings, each against an exact field computed by geobarrier itself (rkf78, adaptive, rtol = atol =
// 1e-12, variational equations), cached in the output folder. ---
#include "../sections.hpp"

#include "../tables.hpp"

#include <array>
#include <cmath>
#include <iostream>
#include <sstream>

namespace geobarrier::bench {

namespace {

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

} // namespace

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

} // namespace geobarrier::bench
