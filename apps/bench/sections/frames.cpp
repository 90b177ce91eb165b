// --- Frames (docs/experiment-format.md, "Frames"): experiments/duffing-frames.json as one frames run against the same
// frames as separate runs, one process after the other. Needs no reference or baseline. ---
#include "../sections.hpp"

#include "../process.hpp"
#include "../repeat.hpp"
#include "../tables.hpp"

#include <geobarrier/frames.hpp>
#include <iostream>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace geobarrier::bench {

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
    LeastTimes frames, separate;
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
    for (const auto &[name, side] : {std::pair<const char *, LeastTimes>{"frames run", frames},
                                     std::pair<const char *, LeastTimes>{"separate runs", separate}}) {
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

} // namespace geobarrier::bench
