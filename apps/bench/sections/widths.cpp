// Section "widths": W's default on the native build and on an AVX2-only build of the same source. Reports lane-steps
// per core-second against the floor set by the machine's measured peak multiply-add rate (peak_rate.cpp).
#include "../sections.hpp"

#include "../peak_rate.hpp"
#include "../tables.hpp"

namespace geobarrier::bench {

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
          "`GEOBARRIER_MARCH=x86-64-v3`) of the same source, same run, best of two. The fused dop853 step "
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

} // namespace geobarrier::bench
