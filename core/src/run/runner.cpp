// The experiment runner: computes the stages the requested products and
// extractors need (and no others), then writes fields.nc, pictures,
// barriers.json and, last, manifest.json into the output folder.
#include "engine/progress.hpp"
#include "output/folder_lock.hpp"
#include "output/provenance.hpp"

#include "engine/tiles.hpp"
#include "experiment/resources.hpp"
#include "run/convergence.hpp"
#include "run/mpi.hpp"
#include <geobarrier/cancel.hpp>
#include <geobarrier/cauchy_green.hpp>
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>
#include <geobarrier/extraction.hpp>
#include <geobarrier/frames.hpp>
#include <geobarrier/line_field.hpp>
#include <geobarrier/output.hpp>
#include <geobarrier/shear.hpp>
#include <geobarrier/tangle.hpp>
#include <geobarrier/threads.hpp>

#include <omp.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <set>

#include <unistd.h>

namespace fs = std::filesystem;
using nlohmann::json;

namespace geobarrier {

namespace {

class StageTimer {
  public:
    StageTimer(json &stages, std::string name) : m_stages(stages), m_name(std::move(name)) {
        spdlog::info("{} ...", m_name);
    }
    ~StageTimer() {
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
        m_stages.push_back({{"stage", m_name}, {"wall_seconds", s}});
        spdlog::info("{} done in {:.2f} s", m_name, s);
    }

  private:
    json &m_stages;
    std::string m_name;
    std::chrono::steady_clock::time_point m_start = std::chrono::steady_clock::now();
};

json plugin_summary(const PluginInfo &info) {
    return {{"kind", to_string(info.kind)},
            {"name", info.name},
            {"version", info.version},
            {"file", info.file.string()},
            {"abi", std::to_string(info.abi_major) + "." + std::to_string(info.abi_minor)}};
}

struct FieldDoc {
    const char *long_name;
    const char *units;
};

// Long names and units of every variable fields.nc can hold.
FieldDoc field_doc(const std::string &name) {
    static const std::map<std::string, FieldDoc> docs = {
        {"ftle", {"finite-time Lyapunov exponent log(lambda2)/(2|t1-t0|)", "1/time"}},
        {"lambda1", {"smaller Cauchy-Green eigenvalue", "1"}},
        {"lambda2", {"larger Cauchy-Green eigenvalue", "1"}},
        {"xi1_x", {"x component of the Cauchy-Green eigenvector xi1 (strain direction)", "1"}},
        {"xi1_y", {"y component of the Cauchy-Green eigenvector xi1 (strain direction)", "1"}},
        {"xi2_x", {"x component of the Cauchy-Green eigenvector xi2 = Omega xi1", "1"}},
        {"xi2_y", {"y component of the Cauchy-Green eigenvector xi2 = Omega xi1", "1"}},
        {"flow_x", {"x component of the flow map F(x0) at t1", "state"}},
        {"flow_y", {"y component of the flow map F(x0) at t1", "state"}},
        {"exit_time",
         {"time at which the trajectory left the bounds (fill value: it never did, the point is captured)", "time"}},
        {"strain_deviation", {"geodesic strain deviation d_g^xi1 (eq. gdev_str, general form)", "1/state"}},
        {"shear_deviation_plus", {"geodesic shear deviation d_g^eta+ (eq. dg_shr, general form)", "1/state"}},
        {"shear_deviation_minus", {"geodesic shear deviation d_g^eta- (eq. dg_shr, general form)", "1/state"}},
    };
    const auto it = docs.find(name);
    return it == docs.end() ? FieldDoc{"", "1"} : it->second;
}

// Where a run that writes no files (RunOptions::write_files = false) lets extractors and validation products put
// theirs: a fresh folder under the system's temporary folder, removed with the staging folder (never published).
fs::path private_scratch_folder() {
    static std::atomic<unsigned> counter{0};
    return fs::temp_directory_path() /
           ("geobarrier-in-memory-" + std::to_string(static_cast<long>(::getpid())) + "-" + std::to_string(counter++));
}

} // namespace

// An output folder claimed by one writer (docs/robustness.md, "One writer per folder"): created if missing (the folders
// made are remembered), then locked for as long as the claim lasts, refusing a second writer with OutputBusyError.
// Whatever dead writers left there (staging folders, temporary files) is removed under the lock. Unless kept, the
// claim removes the folders it created, when they are empty again, after releasing the lock.
class OutputClaim {
  public:
    explicit OutputClaim(fs::path out) : m_out(std::move(out)) {
        std::error_code ec;
        for (fs::path p = fs::absolute(m_out, ec); !p.empty() && !fs::exists(p, ec); p = p.parent_path()) {
            m_created.push_back(p);
            if (p == p.parent_path()) break;
        }
        // A failed writer that had created the folder removes it again: create it anew and retry.
        for (int attempt = 0; !m_lock; ++attempt) {
            fs::create_directories(m_out, ec);
            if (ec || !fs::is_directory(m_out))
                throw IoError(m_out.string() + ": cannot create the output folder (" + ec.message() + ")");
            // Fail now, not after the computation, when nothing can be written there (read-only, permissions).
            if (::access(m_out.c_str(), W_OK | X_OK) != 0)
                throw IoError(m_out.string() + ": cannot write into the output folder (" + std::strerror(errno) + ")");
            m_lock = detail::FolderLock::acquire(m_out, "run");
            if (!m_lock && attempt == 100)
                throw IoError(m_out.string() + ": cannot create the output folder (it kept being removed)");
        }
        detail::remove_stale_leftovers(m_out);
    }
    ~OutputClaim() {
        m_lock.reset(); // removes the lock file, so that a folder this run created is empty again
        if (m_kept) return;
        std::error_code ec;
        for (const fs::path &p : m_created) // innermost first
            if (!fs::is_directory(p, ec) || !fs::is_empty(p, ec) || !fs::remove(p, ec)) break;
    }
    OutputClaim(const OutputClaim &) = delete;
    OutputClaim &operator=(const OutputClaim &) = delete;

    const fs::path &dir() const { return m_out; }
    void keep() { m_kept = true; }

  private:
    fs::path m_out;
    std::vector<fs::path> m_created;
    std::optional<detail::FolderLock> m_lock;
    bool m_kept = false;
};

namespace {

// Written into the output folder while a run moves its files into place, removed after its manifest: the names of
// the files of the run and of the earlier one, so that a run killed halfway leaves a record of what in the folder
// came from runs (the next run removes what it does not replace).
constexpr const char *publishing_journal = ".geobarrier-publishing";

// A name a manifest may list as a run's file in the output folder: one plain, visible path component.
bool plain_entry_name(const std::string &name) {
    return !name.empty() && name.find('/') == std::string::npos && name[0] != '.' && name != "manifest.json";
}

// The entries an earlier run put into `folder`, by its manifest ("files" and the extractors' files of its
// "provenance") and by the journal of a publication cut short; plain names only. An unreadable manifest lists nothing.
std::set<std::string> earlier_run_entries(const fs::path &folder) {
    std::set<std::string> names;
    const auto add = [&](const json &list) {
        if (!list.is_array()) return;
        for (const json &item : list)
            if (item.is_string() && plain_entry_name(item.get<std::string>())) names.insert(item.get<std::string>());
    };
    for (const fs::path &file : {folder / "manifest.json", folder / publishing_journal}) {
        std::error_code ec;
        if (!fs::is_regular_file(file, ec)) continue;
        std::ifstream in(file);
        const json j = json::parse(in, nullptr, false);
        if (j.is_array()) add(j);
        if (!j.is_object()) continue;
        add(j.value("files", json::array()));
        if (const auto p = j.find("provenance"); p != j.end() && p->is_object())
            add(p->value("extractor_files", json::array()));
    }
    return names;
}

void remove_entries(const fs::path &folder, const std::set<std::string> &names) {
    for (const std::string &name : names) {
        std::error_code ec;
        fs::remove_all(folder / name, ec);
        if (ec)
            throw IoError((folder / name).string() + ": cannot remove this file of an earlier run (" + ec.message() +
                          ")");
    }
}

// ".geobarrier-partial-<pid>-<counter>-<random>": unique per run, also among the threads of one process (Python).
std::string staging_name() {
    static std::atomic<unsigned long> counter{0};
    static thread_local std::mt19937_64 random{std::random_device{}()};
    return ".geobarrier-partial-" + std::to_string(static_cast<long>(::getpid())) + "-" +
           std::to_string(counter.fetch_add(1)) + "-" + fmt::format("{:08x}", static_cast<std::uint32_t>(random()));
}

} // namespace

// The output folder of a run. Everything is written into a hidden staging folder inside it and moved into place
// only when the whole run has succeeded, manifest.json last (each file was already written atomically, so a file
// under a final name is always whole). The folder is claimed (locked) from before the staging folder is made until
// the staging folder is gone. A failed or interrupted run leaves the output folder as it found it: no new file, an
// earlier finished run untouched, and the folders this run created removed again.
class OutputStaging {
  public:
    // `claim`: the output folder of a run that writes files; else a private folder of this run, made and removed here.
    OutputStaging(fs::path out, bool claim) : m_out(std::move(out)) {
        std::error_code ec;
        if (claim)
            m_claim.emplace(m_out);
        else
            fs::create_directories(m_out, ec);
        m_stage = m_out / staging_name();
        if (!fs::create_directory(m_stage, ec))
            throw IoError(m_stage.string() + ": cannot create the staging folder (" + ec.message() + ")");
    }
    ~OutputStaging() {
        std::error_code ec;
        if (!m_published) fs::remove_all(m_stage, ec);
        if (!m_claim) fs::remove(m_out, ec); // the private folder of a run that writes no files, empty again
        if (m_claim && m_published) m_claim->keep();
        m_claim.reset(); // unlocked only now
    }
    OutputStaging(const OutputStaging &) = delete;
    OutputStaging &operator=(const OutputStaging &) = delete;

    const fs::path &dir() const { return m_stage; }
    // A message about a staged file, naming it where it was to go.
    std::string final_names(std::string text) const {
        const std::string from = m_stage.string(), to = m_out.string();
        for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
            text.replace(at, from.size(), to);
        return text;
    }

    // Moves every staged entry into the output folder, `last` (the manifest) last. First the earlier run's manifest
    // goes, then whatever else that run left and this one does not replace, so that the folder never pairs a manifest
    // with files of another run. Returns the final paths of `files`.
    std::vector<fs::path> publish(const std::vector<fs::path> &files, const fs::path &last) {
        std::error_code ec;
        std::vector<fs::path> entries;
        std::set<std::string> incoming;
        for (const auto &entry : fs::directory_iterator(m_stage)) {
            entries.push_back(entry.path());
            incoming.insert(entry.path().filename().string());
        }
        std::set<std::string> earlier = earlier_run_entries(m_out), stale;
        for (const std::string &name : earlier)
            if (!incoming.count(name)) stale.insert(name);
        json journal = json::array();
        for (const std::string &name : earlier) journal.push_back(name);
        for (const std::string &name : incoming)
            if (plain_entry_name(name) && !earlier.count(name)) journal.push_back(name);
        write_text_file(m_out / publishing_journal, journal.dump() + "\n");
        fs::remove(m_out / last.filename(), ec);
        remove_entries(m_out, stale);
        std::stable_partition(entries.begin(), entries.end(),
                              [&](const fs::path &p) { return p.filename() != last.filename(); });
        for (const fs::path &from : entries) {
            const fs::path to = m_out / from.filename();
            if (from.filename() == last.filename()) detail::test_pause("publishing");
            if (fs::is_directory(from) && fs::is_directory(to)) fs::remove_all(to);
            fs::rename(from, to, ec);
            if (ec) throw IoError(to.string() + ": cannot move the finished file into place (" + ec.message() + ")");
        }
        fs::remove(m_out / publishing_journal, ec);
        fs::remove(m_stage, ec);
        m_published = true;
        std::vector<fs::path> out;
        for (const fs::path &f : files) out.push_back(m_out / f.filename());
        return out;
    }

  private:
    fs::path m_out, m_stage;
    std::optional<OutputClaim> m_claim;
    bool m_published = false;
};

namespace {

// What the stages of one run add to its record: the manifest, the stages' wall times and the warnings.
struct RunRecord {
    json manifest;
    json stages = json::array();
    json warnings = json::array();

    void warn(const std::string &text) {
        spdlog::warn("{}", text);
        warnings.push_back(text);
    }
};

// A stage's progress to RunOptions::progress ("flow map": done/total grid rows; other stages: 0/1 when they start).
void report(const RunOptions &options, const std::string &stage, std::size_t done, std::size_t total) {
    if (options.progress) options.progress(stage, done, total);
}

// The manifest's description of the run before anything is computed: the tool, the experiment as written and as
// resolved, every plugin, the threads.
json start_manifest(const ResolvedExperiment &r, const RunOptions &options) {
    const Experiment &e = r.experiment;
    json manifest;
    manifest["tool"] = {
        {"name", "geobarrier"},
        {"version", GEOBARRIER_VERSION},
        {"plugin_abi", std::to_string(GB_ABI_VERSION_MAJOR) + "." + std::to_string(GB_ABI_VERSION_MINOR)}};
    manifest["experiment_file"] = e.file.empty() ? "" : fs::absolute(e.file).string();
    manifest["experiment"] = e.source;
    manifest["resolved"] = r.resolved;
    json plugins = json::array({plugin_summary(r.system.info()), plugin_summary(r.forcing.info())});
    // A composite forcing's terms are plugins too (depth first, in the order listed).
    std::function<void(const Forcing &)> add_terms = [&](const Forcing &f) {
        for (const Forcing &term : f.terms()) {
            plugins.push_back(plugin_summary(term.info()));
            add_terms(term);
        }
    };
    add_terms(r.forcing);
    for (const Extractor &x : r.extractors) plugins.push_back(plugin_summary(x.info()));
    manifest["plugins"] = plugins;
    manifest["threads"] = options.threads > 0 ? options.threads : omp_get_max_threads();
    if (mpi::sharing_tiles()) manifest["mpi_ranks"] = mpi::size(); // threads is then per rank
    return manifest;
}

// The fields of the grid stages, and the names extractors and products read them by (pointers into the members).
struct GridStages {
    FlowMap flow;
    CauchyGreenField cg;
    std::vector<double> strain_deviation;
    ShearFields shear;
    std::vector<double> no_exit; // exit_time for extractors when nothing can exit (no bounds that stop): all NaN
    std::map<std::string, const std::vector<double> *> fields;
    const std::vector<std::uint8_t> *mask = nullptr; // the Cauchy–Green mask when computed, else the flow map's
    GradientMethod gradient = GradientMethod::none;
};

// Whether the experiment's products, or an extractor's required fields, ask for a field the name of which passes
// `matches`.
template <class Matches> bool field_wanted(const ResolvedExperiment &r, const std::string &product, Matches matches) {
    bool wanted = r.experiment.wants(product);
    for (const Extractor &x : r.extractors)
        for (const auto &name : x.required_fields()) wanted = wanted || matches(name);
    return wanted;
}

// The safe basin of an open system (bounds with ExitRule::stop): the grid points whose trajectories stay within the
// bounds over the whole horizon, as a count, a share of the grid and an area (the share of the grid's rectangle).
json describe_escape(const Grid &g, const FlowMap &flow) {
    std::uint64_t captured = 0, exited = 0;
    for (std::size_t k = 0; k < flow.exit_time.size(); ++k) {
        if (flow.mask[k] & mask_trajectory_bits) continue;
        (std::isnan(flow.exit_time[k]) ? captured : exited) += 1;
    }
    const double share = static_cast<double>(captured) / static_cast<double>(std::max<std::size_t>(g.size(), 1));
    return {{"exits", "stop"},
            {"exited", exited},
            {"captured", captured},
            {"captured_fraction", share},
            {"captured_area", share * (g.x_max - g.x_min) * (g.y_max - g.y_min)}};
}

// The barriers that bound the safe basin: each barrier's share of points within two grid spacings of the boundary
// between captured points (no exit over the horizon) and escaping ones, as "basin_boundary_share" in its item, and the
// indices of those with at least half their points there as the manifest's escape "bounding_barriers".
void mark_basin_boundary(const Grid &g, const FlowMap &flow, json &items, json &escape) {
    const auto state = [&](std::size_t i, std::size_t j) { // 0 masked, 1 captured, 2 escaped
        const std::size_t k = j * g.nx + i;
        return (flow.mask[k] & mask_trajectory_bits) ? 0 : std::isnan(flow.exit_time[k]) ? 1 : 2;
    };
    std::vector<std::uint8_t> boundary(g.size(), 0);
    for (std::size_t j = 0; j < g.ny; ++j)
        for (std::size_t i = 0; i < g.nx; ++i) {
            const int s = state(i, j);
            if (s == 0) continue;
            const bool edge = (i + 1 < g.nx && state(i + 1, j) == 3 - s) || (j + 1 < g.ny && state(i, j + 1) == 3 - s);
            if (edge) boundary[j * g.nx + i] = 1;
        }
    constexpr long reach = 2; // grid spacings
    json bounding = json::array();
    for (std::size_t b = 0; b < items.size(); ++b) {
        const json &points = items[b]["points"];
        std::size_t near = 0;
        for (const json &p : points) {
            const long i0 = std::lround((p[0].get<double>() - g.x_min) / g.dx());
            const long j0 = std::lround((p[1].get<double>() - g.y_min) / g.dy());
            bool found = false;
            for (long j = j0 - reach; j <= j0 + reach && !found; ++j)
                for (long i = i0 - reach; i <= i0 + reach && !found; ++i)
                    found = i >= 0 && j >= 0 && i < static_cast<long>(g.nx) && j < static_cast<long>(g.ny) &&
                            boundary[static_cast<std::size_t>(j) * g.nx + static_cast<std::size_t>(i)];
            near += found;
        }
        const double share = points.empty() ? 0.0 : static_cast<double>(near) / static_cast<double>(points.size());
        items[b]["basin_boundary_share"] = share;
        if (share >= 0.5) bounding.push_back(b);
    }
    escape["bounding_barriers"] = bounding;
}

// Stages 1 and 2: the flow map, with the gradient only when something needs it, and the Cauchy–Green eigenvalues,
// eigenvectors and FTLE, tile by tile (tiles.hpp): only the fields the products, extractors and pictures read are
// kept for the whole grid.
void compute_flow_and_cauchy_green(const ResolvedExperiment &r, const RunOptions &options, const FieldPlan &plan,
                                   RunRecord &record, GridStages &grid) {
    const Experiment &e = r.experiment;
    if (r.need_cauchy_green || r.need_positions) {   // validation products alone need no grid
        StageTimer timer(record.stages, "flow map"); // with the Cauchy–Green fields, tile by tile
        detail::ProgressBar bar("flow map", !options.quiet);
        const Dynamics dynamics = r.dynamics();
        GridFields computed = compute_grid_fields(dynamics, e.grid, e.t0, e.t1, e.integrator, e.bounds, plan,
                                                  [&](std::size_t done, std::size_t total) {
                                                      bar.update(done, total);
                                                      report(options, "flow map", done, total);
                                                  });
        bar.finish();
        grid.flow = std::move(computed.flow);
        grid.cg = std::move(computed.cg);
        record.manifest["tiles"] = {{"count", computed.tiles}, {"rows", computed.rows_per_tile}, {"kept", plan.keep}};
    }
    grid.gradient = plan.gradient;
    const IntegratorStats &stats = grid.flow.stats;
    record.manifest["integrator_stats"] = stats.to_json();
    record.manifest["gradient_method"] = to_string(plan.gradient);
    record.manifest["long_horizon"] = long_horizon_method(plan.gradient);
    if (stats.masked > 0)
        record.warn(describe_masking(stats, e.integrator, r.system.has_jacobian()) +
                    " (see integrator_stats and the mask variable in fields.nc)");
    if (const std::string w = describe_step_refinement(stats, e.integrator, r.system.has_jacobian()); !w.empty())
        record.warn(w);
    if (r.need_cauchy_green) {
        for (const auto &name : plan.keep) grid.fields[name] = &cauchy_green_member(grid.cg, name);
        record.manifest["degenerate_points"] = grid.cg.degenerate_count;
    }
    if (r.need_positions) {
        grid.fields["flow_x"] = &grid.flow.flow_x;
        grid.fields["flow_y"] = &grid.flow.flow_y;
    }
    if (!grid.flow.exit_time.empty()) {
        grid.fields["exit_time"] = &grid.flow.exit_time;
        record.manifest["escape"] = describe_escape(e.grid, grid.flow);
    } else if (std::any_of(r.extractors.begin(), r.extractors.end(), [](const Extractor &x) {
                   const auto &names = x.required_fields();
                   return std::find(names.begin(), names.end(), "exit_time") != names.end();
               })) {
        // An extractor reads exit_time in every run (abi.h): without bounds that stop trajectories nothing exits.
        // Not written to fields.nc (field_variables), which stays as it was.
        grid.no_exit.assign(e.grid.size(), std::numeric_limits<double>::quiet_NaN());
        grid.fields["exit_time"] = &grid.no_exit;
    }
    grid.mask = r.need_cauchy_green ? &grid.cg.mask : &grid.flow.mask;
}

// The fields derived from the Cauchy–Green fields, only when a product asks for them or an extractor needs them.
void compute_deviation_fields(const ResolvedExperiment &r, RunRecord &record, GridStages &grid) {
    if (!r.need_cauchy_green) return;
    // The geodesic strain deviation (paper eq. `gdev_str`, general form): it costs grid derivatives of lambda1,
    // lambda2 and xi1.
    if (field_wanted(r, "strain_deviation", [](const std::string &name) { return name == "strain_deviation"; })) {
        StageTimer timer(record.stages, "strain deviation");
        grid.strain_deviation = strain_deviation_field(grid.cg);
        grid.fields["strain_deviation"] = &grid.strain_deviation;
    }
    // The geodesic shear deviations (paper eq. `dg_shr`, general form); the elliptic extractor computes its own from
    // the eigen-fields.
    const auto is_shear = [](const std::string &name) { return name.rfind("shear_deviation", 0) == 0; };
    if (field_wanted(r, "shear_deviation_plus", is_shear) || r.experiment.wants("shear_deviation_minus")) {
        StageTimer timer(record.stages, "shear deviation");
        grid.shear = shear_fields(grid.cg);
        grid.fields["shear_deviation_plus"] = &grid.shear.deviation_plus;
        grid.fields["shear_deviation_minus"] = &grid.shear.deviation_minus;
    }
}

// Stage 3: the barrier extractors. They may advect points with the experiment's system and integrator.
FoundBarriers run_extractors(const ResolvedExperiment &r, const RunOptions &options, const GridStages &grid,
                             const fs::path &out, bool plots, RunRecord &record) {
    const ExtractServices services = advection_services(r);
    FoundBarriers found;
    for (const Extractor &x : r.extractors) {
        throw_if_cancelled("before extractor '" + x.info().name + "'");
        report(options, "extractor " + x.info().name, 0, 1);
        StageTimer timer(record.stages, "extractor " + x.info().name);
        std::vector<gb_field> inputs;
        for (const auto &name : x.required_fields()) inputs.push_back({name.c_str(), grid.fields.at(name)->data()});
        run_extractor(r, x, inputs, grid.mask->data(), out.string(), plots, services, found);
    }
    return found;
}

// The barriers of a changed run of "convergence" that changes only extractor keys: its extractors on this run's fields
// (no new flow map), writing into a private folder that is removed. Their stage times and warnings are not this run's.
json reextracted_barriers(const ResolvedExperiment &changed, const RunOptions &options, const GridStages &grid) {
    struct RemovedFolder {
        fs::path path = private_scratch_folder();
        ~RemovedFolder() {
            std::error_code ec;
            fs::remove_all(path, ec);
        }
    } folder;
    fs::create_directories(folder.path);
    RunRecord scratch;
    return run_extractors(changed, options, grid, folder.path, false, scratch).items;
}

// Whether this run's fields hold every field the changed run's extractors read.
bool fields_serve(const ResolvedExperiment &changed, const GridStages &grid) {
    for (const Extractor &x : changed.extractors)
        for (const auto &name : x.required_fields())
            if (!grid.fields.count(name)) return false;
    return true;
}

// Stage 3a: "convergence" (run/convergence.hpp). Each changed run in turn, in memory: re-extraction from this run's
// fields where only extractor keys change, else a whole run (a new flow map); nothing of them is written. Then this
// run's barriers (`items`) are marked with the share of each that every changed run reproduces. Returns the
// "convergence" object of barriers.json and the manifest (null without "convergence").
json check_convergence(const ResolvedExperiment &r, const RunOptions &options, const GridStages &grid, json &items,
                       RunRecord &record) {
    const Experiment &e = r.experiment;
    if (!e.convergence) return json();
    const std::vector<detail::ConvergenceChange> changes = detail::convergence_changes(r);
    StageTimer timer(record.stages, "convergence");
    std::vector<json> barriers;
    json runs = json::array();
    for (std::size_t k = 0; k < changes.size(); ++k) {
        const detail::ConvergenceChange &c = changes[k];
        throw_if_cancelled("before the changed run " + c.label);
        report(options, "convergence", k, changes.size());
        const auto start = std::chrono::steady_clock::now();
        const ResolvedExperiment changed = resolve_experiment(parse_experiment(c.source, e.file));
        const bool reextract = c.same_fields && fields_serve(changed, grid);
        spdlog::info("convergence: changed run {} of {}, {} ({})", k + 1, changes.size(), c.label,
                     reextract ? "this run's fields" : "a new flow map");
        if (reextract) {
            barriers.push_back(reextracted_barriers(changed, options, grid));
        } else {
            RunOptions o = options;
            o.output_dir.reset();
            o.write_files = false; // in memory: a private folder, removed
            o.keep_results = true; // the barriers
            barriers.push_back(run_experiment(changed, o).barriers);
        }
        runs.push_back(
            {{"change", c.label},
             {"json_path", c.json_path},
             {"flow_map", !reextract},
             {"barriers", barriers.back().size()},
             {"wall_seconds", std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()}});
    }
    report(options, "convergence", changes.size(), changes.size());
    std::vector<std::string> warnings;
    json summary =
        detail::mark_convergence(items, changes, barriers, std::move(runs), e.grid, *e.convergence, warnings);
    for (const std::string &w : warnings) record.warn(w);
    spdlog::info("convergence: {} of {} barriers persist under every change (threshold {:g})",
                 summary["converged"].get<std::size_t>(), items.size(), e.convergence->threshold);
    return summary;
}

// Stage 3b: the validation products (Poincaré iterates, tracers, trajectories, forcing, advected barriers), only
// those the experiment's "validation" object asks for; they write their own files, returned.
std::vector<fs::path> run_validation_products(const ResolvedExperiment &r, const RunOptions &options,
                                              const std::vector<Barrier> &barriers, const fs::path &out, bool plots,
                                              RunRecord &record) {
    const Experiment &e = r.experiment;
    if (e.validation.empty()) return {};
    throw_if_cancelled("before the validation products");
    report(options, "validation", 0, 1);
    StageTimer timer(record.stages, "validation");
    ValidationInput input;
    input.dynamics = r.dynamics();
    input.integrator = e.integrator;
    input.bounds = masking(e.bounds); // tracers and advected curves must know when they left
    input.t0 = e.t0;
    input.t1 = e.t1;
    input.barriers = &barriers;
    input.plots = plots;
    input.title = r.system.info().name + " + " + r.forcing.info().name;
    const ValidationOutput v = run_validation(e.validation, input, out);
    record.manifest["validation"] = v.summary;
    for (const auto &w : v.warnings) record.warnings.push_back(w);
    return v.files;
}

// The variables of fields.nc: those of the requested products, in the order of known_products().
std::vector<FieldVariable> field_variables(const Experiment &e, const GridStages &grid) {
    std::vector<FieldVariable> variables;
    for (const auto &product : known_products()) {
        if (!e.wants(product.name)) continue;
        // Eigenvectors and derivatives of them are undefined at degenerate points too.
        const std::string name_of_product = product.name;
        const bool vector_field = name_of_product == "eigenvectors" || name_of_product == "strain_deviation" ||
                                  name_of_product.rfind("shear_deviation", 0) == 0;
        const auto masked_by =
            static_cast<std::uint8_t>(vector_field ? (mask_trajectory_bits | mask_degenerate) : mask_trajectory_bits);
        for (const char *name : product.variables) {
            const FieldDoc doc = field_doc(name);
            variables.push_back(FieldVariable{name, doc.long_name, doc.units, grid.fields.at(name), masked_by});
        }
    }
    // Bounds that stop trajectories: when each left them, with the fields it qualifies.
    if (const auto exit = grid.fields.find("exit_time");
        !variables.empty() && !grid.flow.exit_time.empty() && exit != grid.fields.end()) {
        const FieldDoc doc = field_doc("exit_time");
        variables.push_back(FieldVariable{"exit_time", doc.long_name, doc.units, exit->second, mask_trajectory_bits});
    }
    return variables;
}

// The names and units of the grid's two axes: the system's first two components, or a slice's axes.
StateAxes plane_axes(const ResolvedExperiment &r) {
    StateAxes axes;
    const PluginInfo &sys = r.system.info();
    for (std::size_t i = 0; i < 2; ++i) {
        const std::size_t c = r.plane_component(i);
        if (c < sys.state_names.size()) axes.names.push_back(sys.state_names[c]);
        if (c < sys.state_units.size()) axes.units.push_back(sys.state_units[c]);
    }
    return axes;
}

// Stage 4: fields.nc, the FTLE picture and barriers.json, each written atomically into the staging folder `out`.
void write_result_files(const ResolvedExperiment &r, const RunOptions &options, const GridStages &grid,
                        const std::vector<FieldVariable> &variables, const json &barriers, const json &candidates,
                        const json &convergence, const fs::path &out, bool plots, RunSummary &summary) {
    const Experiment &e = r.experiment;
    if (!variables.empty()) {
        json attributes = {{"title", e.description.empty() ? std::string("geobarrier fields") : e.description},
                           {"source", std::string("geobarrier ") + GEOBARRIER_VERSION},
                           {"system", r.system.info().name},
                           {"forcing", r.forcing.info().name},
                           {"t0", e.t0},
                           {"t1", e.t1},
                           {"gradient_method", to_string(grid.gradient)},
                           {"experiment", r.resolved.dump()}};
        if (e.slice) { // the slice: its axes (the coordinates x and y), tensor and fixed components
            attributes["slice_axes"] = e.slice->axes[0] + " " + e.slice->axes[1];
            attributes["slice_tensor"] = r.resolved["cauchy_green"].value("slice_tensor", "full");
            for (const auto &[name, value] : e.slice->fixed) attributes["slice_fixed_" + name] = value;
        }
        if (options.keep_results) summary.field_attributes = attributes;
        if (options.write_files) {
            const fs::path file = out / "fields.nc";
            write_fields_netcdf(file, e.grid, variables, *grid.mask, attributes, plane_axes(r));
            summary.files.push_back(file);
        }
    }
    if (plots && r.need_cauchy_green) {
        FieldPlot plot;
        plot.title = "FTLE, " + r.system.info().name + " + " + r.forcing.info().name +
                     ", t = " + fmt::format("{:g}", e.t0) + " to " + fmt::format("{:g}", e.t1);
        plot.colorbar_label = "FTLE";
        plot.x_label = state_axis_label(r.system.info(), r.plane_component(0));
        plot.y_label = state_axis_label(r.system.info(), r.plane_component(1));
        const fs::path file = out / "ftle.png";
        plot_field_png(file, e.grid, grid.cg.ftle, *grid.mask, plot);
        summary.files.push_back(file);
    }
    if (options.write_files && !r.extractors.empty()) {
        const fs::path file = out / "barriers.json";
        json contents = {{"barriers", barriers}};
        if (!candidates.empty()) contents["candidates"] = candidates;
        if (!convergence.is_null()) contents["convergence"] = convergence;
        write_text_file(file, contents.dump(1) + "\n");
        summary.files.push_back(file);
    }
}

// RunOptions::keep_results: what fields.nc and barriers.json hold, in memory.
void keep_results(const Experiment &e, const StateAxes &state_axes, const GridStages &grid,
                  const std::vector<FieldVariable> &variables, const json &barriers, RunSummary &summary) {
    summary.grid = e.grid;
    summary.mask = *grid.mask;
    summary.barriers = barriers;
    for (const FieldVariable &v : variables) {
        const NetcdfAttributes a = variable_attributes(v);
        summary.fields.push_back({v.name, a.long_name, a.units, v.masked_by, *v.values});
    }
    for (std::size_t c = 0; c < 2; ++c) {
        const NetcdfAttributes a = coordinate_attributes(c, state_axes);
        std::vector<double> values(c == 0 ? e.grid.nx : e.grid.ny);
        for (std::size_t k = 0; k < values.size(); ++k) values[k] = c == 0 ? e.grid.x(k) : e.grid.y(k);
        summary.coordinates.push_back({c == 0 ? "x" : "y", a.long_name, a.units, 0, std::move(values)});
    }
}

// The run's last step: the manifest's closing entries; written (last of all files) and the staging folder published
// when the run writes files, else kept in the summary only.
RunSummary finish_run(RunRecord &record, const RunOptions &options, OutputStaging &staging,
                      std::chrono::steady_clock::time_point run_start, RunSummary summary) {
    json &manifest = record.manifest;
    manifest["stages"] = record.stages;
    manifest["warnings"] = record.warnings;
    manifest["wall_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - run_start).count();
    json files = json::array();
    for (const auto &f : summary.files) files.push_back(f.filename().string());
    if (options.write_files) files.push_back("manifest.json");
    manifest["files"] = files;
    if (!options.write_files) {
        summary.manifest = manifest;
        return summary; // the staging folder's destructor removes the private folder
    }
    const fs::path out = staging.dir(), manifest_file = out / "manifest.json";
    throw_if_cancelled("before writing manifest.json");
    try {
        write_text_file(manifest_file, manifest.dump(2) + "\n");
    } catch (const IoError &e) {
        throw IoError(staging.final_names(e.what()) + storage_hint(out));
    }
    summary.files.push_back(manifest_file);
    detail::test_pause("staged");
    // The last point at which a signal stops the run with the output folder as it was; once the moves have begun
    // they are finished (renames only), and the program reports a signal that came during them (main.cpp).
    throw_if_cancelled("before moving the finished files into place");
    summary.files = staging.publish(summary.files, manifest_file);
    summary.manifest = manifest;
    return summary;
}

RunSummary run_stages(const ResolvedExperiment &r, const RunOptions &options) {
    const Experiment &e = r.experiment;
    const auto run_start = std::chrono::steady_clock::now();
    const ScopedThreadCount thread_count(options.threads);
    const bool plots = e.plots && options.write_files;

    RunSummary summary;
    if (options.write_files) summary.output_dir = options.output_dir ? *options.output_dir : e.output_dir;
    OutputStaging staging(options.write_files ? summary.output_dir : private_scratch_folder(), options.write_files);
    const fs::path out = staging.dir(); // every file goes here first; published at the end
    detail::test_pause("locked");

    RunRecord record;
    record.manifest = start_manifest(r, options);
    for (const auto &w : r.registry.warnings()) record.warn(w); // stderr too (a library skipped, a plugin shadowed)
    for (const auto &w : e.warnings) record.warn(w);            // e.g. a clamped tolerance

    GridStages grid;
    compute_flow_and_cauchy_green(r, options, plan_fields(r), record, grid);
    compute_deviation_fields(r, record, grid);
    FoundBarriers found = run_extractors(r, options, grid, out, plots, record);
    const json convergence = check_convergence(r, options, grid, found.items, record);
    if (!convergence.is_null()) record.manifest["convergence"] = convergence;
    if (record.manifest.contains("escape"))
        mark_basin_boundary(e.grid, grid.flow, found.items, record.manifest["escape"]);
    const std::vector<fs::path> validation_files =
        run_validation_products(r, options, found.barriers, out, plots, record);
    summary.files.insert(summary.files.end(), validation_files.begin(), validation_files.end());

    // Each file is written atomically; the manifest comes last, so a folder with a manifest is a finished run.
    throw_if_cancelled("before writing the output files");
    const std::vector<FieldVariable> variables = field_variables(e, grid);
    try {
        StageTimer timer(record.stages, "output");
        write_result_files(r, options, grid, variables, found.items, found.candidates, convergence, out, plots,
                           summary);
    } catch (const IoError &error) {
        throw IoError(staging.final_names(error.what()) + storage_hint(out)); // a full disk shows up as "HDF error"
    }
    record.manifest["provenance"] = detail::run_provenance(r, record.manifest, summary.files, out);
    if (options.keep_results) {
        keep_results(e, plane_axes(r), grid, variables, found.items, summary);
        summary.candidates = found.candidates;
    }
    if (!options.write_files) summary.files.clear(); // the validation products' files went to the private folder
    return finish_run(record, options, staging, run_start, std::move(summary));
}

// Before several runs replace the subfolders of an earlier run of several runs (its "forward" and "backward"), one
// after the other: that run's manifest and its top-level files (tangle.json, its pictures) go first, so that the
// folder never holds an old manifest or an old tangle.json beside a new subfolder or a new manifest. Their names stay
// in the publishing journal until the new manifest is written, for the next run to remove if this one is killed. An
// earlier single run (no subfolder) is left whole until the new runs have succeeded, as a failed run leaves it.
void retire_earlier_runs(const fs::path &folder, const std::set<std::string> &earlier) {
    std::error_code ec;
    std::set<std::string> files;
    bool several = false;
    for (const std::string &name : earlier) {
        if (fs::is_directory(folder / name, ec))
            several = true;
        else
            files.insert(name);
    }
    if (!several) return;
    json journal = json::array();
    for (const std::string &name : earlier) journal.push_back(name);
    write_text_file(folder / publishing_journal, journal.dump() + "\n");
    fs::remove(folder / "manifest.json", ec);
    remove_entries(folder, files);
}

// Several runs into one folder, both directions (tangle.cpp) or frames (frames.cpp): claimed for the whole of the runs
// (each run claims its own subfolder as well); what an earlier run left there and the new manifest does not list is
// removed afterwards.
RunSummary run_claimed(const ResolvedExperiment &r, const RunOptions &options,
                       RunSummary (*runs)(const ResolvedExperiment &, const RunOptions &)) {
    if (!options.write_files || (mpi::sharing_tiles() && mpi::rank() != 0)) return runs(r, options);
    OutputClaim claim(options.output_dir ? *options.output_dir : r.experiment.output_dir);
    const std::set<std::string> earlier = earlier_run_entries(claim.dir());
    retire_earlier_runs(claim.dir(), earlier);
    RunSummary summary = runs(r, options);
    claim.keep();
    std::set<std::string> stale = earlier;
    for (const json &name : summary.manifest.value("files", json::array()))
        if (name.is_string()) stale.erase(name.get<std::string>());
    remove_entries(claim.dir(), stale);
    std::error_code ec;
    fs::remove(claim.dir() / publishing_journal, ec);
    return summary;
}

} // namespace

RunSummary run_experiment(const ResolvedExperiment &r, const RunOptions &options) {
    // Before a thread is started: OpenMP would try to start them all (libgomp aborts the process beyond its means).
    if (options.threads < 0 || options.threads > max_threads)
        throw ConfigError("threads", std::to_string(options.threads) + " worker threads asked for; give 1 to " +
                                         std::to_string(max_threads) + " (or 0: one per core)");
    // The engine names a bad setting by its own name; the experiment's JSON path goes with it here.
    // Every rank would have to join each changed run's flow map (run_as_tile_worker runs one experiment's).
    if (r.experiment.convergence && mpi::sharing_tiles())
        throw ConfigError("/convergence", "changed runs are not supported under mpirun; run the experiment without "
                                          "mpirun, or leave \"convergence\" out");
    return with_json_paths([&] {
        if (r.experiment.both_directions) return run_claimed(r, options, run_both_directions); // two runs, their tangle
        if (!r.experiment.frames.empty()) return run_claimed(r, options, run_frames); // a run per frame, their tracks
        // Under mpirun the ranks other than 0 only compute their share of the flow map's tiles (tiles.hpp).
        if (mpi::sharing_tiles() && mpi::rank() != 0) return run_as_tile_worker(r, options);
        return run_stages(r, options);
    });
}

} // namespace geobarrier
