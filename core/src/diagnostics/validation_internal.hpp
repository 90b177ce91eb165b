// Private to the validation units (validation*.cpp): the rules the products share, their CSV tables and pictures,
// and the stage that runs them (validation.cpp: compute and summarise; validation_csv.cpp: tables;
// validation_plots.cpp: pictures; validation_compute.cpp: building blocks; validation_parse.cpp: the JSON object;
// validation_vtk.cpp: tube.vtp).
#ifndef GEOBARRIER_SRC_VALIDATION_INTERNAL_HPP
#define GEOBARRIER_SRC_VALIDATION_INTERNAL_HPP

#include <geobarrier/output.hpp>
#include <geobarrier/validation.hpp>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <limits>
#include <string>
#include <vector>

namespace geobarrier::validation_detail {

constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

// ---- shared rules (validation_compute.cpp)

// Times and coordinates in titles and legends: four significant digits read well (t = 3.142, not 3.14159).
std::string fmt_g(double v);
bool same_time(double a, double b);
std::vector<double> even_times(double a, double b, std::size_t n); // n >= 2 times from a to b, both included
// The advect_barriers times: the given ones, else `samples` evenly spaced times of [t0, t1].
std::vector<double> default_times(const AdvectBarriersSpec &spec, double t0, double t1);
// The closed elliptic barriers that bound the regular regions: those marked outermost, or all closed elliptic
// ones when the extractor marked none.
std::vector<const Barrier *> outermost_elliptic(const std::vector<Barrier> &barriers);

// ---- CSV tables (validation_csv.cpp); numbers at full precision, non-finite ones as empty fields

std::string csv_number(double v);
// poincare.csv: one row per seed and iterate until the seed is masked; `rows` counts them.
std::string poincare_csv(const Snapshots &iterates, const std::vector<std::string> &origin, double t_start,
                         double period, std::size_t iterations, std::size_t &rows);
// tracers.csv rows of one cloud: its positions at release and at each later time (release once).
std::string tracer_csv_rows(std::size_t cloud, const Snapshots &snaps, const std::vector<double> &times,
                            double release);
// trajectories.csv: one row per trajectory and sample until it is masked; `inside` -1 leaves the column empty.
std::string trajectories_csv(const Snapshots &snaps, const std::vector<double> &times, const std::vector<int> &inside);
std::string forcing_csv(const std::vector<double> &times, const std::vector<double> &f);
// The relative change of a closed barrier's area at sample s (NaN for open barriers).
double area_change(const Barrier &barrier, const StretchingHistory &h, const StretchingSample &s);
// stretching.csv rows of one barrier (index b).
std::string stretching_csv_rows(std::size_t b, const Barrier &barrier, const StretchingHistory &h);

// ---- the stage

// One validation run: the experiment's dynamics and barriers, the output folder, and what has been written.
struct Stage {
    const ValidationInput &in;
    const std::filesystem::path &out;
    ValidationOutput &result;
    const std::vector<Barrier> &barriers;

    // The products (validation.cpp): compute, write the table, summarise, draw.
    void poincare(const PoincareSpec &spec, nlohmann::json &summary);
    void section(const SectionSpec &spec, nlohmann::json &summary);
    void tracers(const std::vector<TracerCloudSpec> &clouds, nlohmann::json &summary);
    void trajectories(const TrajectoriesSpec &spec, nlohmann::json &summary);
    void forcing(const ForcingSpec &spec, nlohmann::json &summary);
    void advect_barriers(const AdvectBarriersSpec &spec, nlohmann::json &summary);

    void add_file(const std::filesystem::path &file) { result.files.push_back(file); }
    void warn(const std::string &w);
    void write_table(const std::string &name, const std::string &csv);
    // The found barriers a product works on ("all", "outermost", or given indices).
    std::vector<std::size_t> choose_barriers(const std::string &which, const std::vector<std::size_t> &indices,
                                             const std::string &json_path) const;

    // Pictures (validation_plots.cpp), drawn only when the experiment asks for plots.
    struct PoincarePicture {
        const PoincareSpec &spec;
        const Snapshots &iterates;
        std::size_t seeds;
        double t_start;
        const std::vector<std::size_t> &seeded_from; // the barriers seeds were spread along
    };
    void draw_poincare(const PoincarePicture &p);
    void draw_section(const SectionSpec &spec, const SectionCrossings &crossings);
    // The cloud at times[k] for every k >= 1 (times[0] is the release); returns the pictures' names.
    nlohmann::json draw_tracers(std::size_t cloud, const Snapshots &snaps, const std::vector<double> &times);
    struct TrajectoryPictures {
        double t_start, t_end;
        const std::vector<double> &starts; // x, y interleaved
        const std::vector<double> &times;
        const Snapshots &snaps;
        const std::vector<int> &inside;                // 1 inside, 0 outside, -1 unknown
        const std::vector<const Barrier *> &outermost; // the outermost elliptic barriers at t0
        bool classified;                               // the barriers were at the trajectories' start time
    };
    void draw_trajectories(const TrajectoryPictures &t);
    void draw_forcing(const std::vector<double> &times, const std::vector<double> &f);
    struct AdvectedPictures {
        const std::vector<std::size_t> &chosen;
        const std::vector<double> &times;
        const std::vector<StretchingHistory> &histories;
        const std::vector<BarrierTube> &tubes;
    };
    void draw_advected(const AdvectedPictures &a);

  private:
    std::string base_title() const;
    std::string state_label(std::size_t i) const;
    std::string time_label() const;
    void label_phase_plane(XYPlot &plot) const;
    void label_extended(XYZPlot &plot) const;
    XYPlot phase_plot(const std::string &title) const;
    void save(const XYPlot &plot, const std::string &name);
    void save(const XYZPlot &plot, const std::string &name);
    std::string trajectory_label(const TrajectoryPictures &t, std::size_t s) const;
    void draw_trajectory_phase(const TrajectoryPictures &t);
    void draw_trajectory_series(const TrajectoryPictures &t, int coordinate);
    void draw_trajectory_3d(const TrajectoryPictures &t);
    void draw_stretching(const AdvectedPictures &a);
    void draw_barriers_advected(const AdvectedPictures &a);
    void draw_tubes(const AdvectedPictures &a);
};

} // namespace geobarrier::validation_detail

#endif // GEOBARRIER_SRC_VALIDATION_INTERNAL_HPP
