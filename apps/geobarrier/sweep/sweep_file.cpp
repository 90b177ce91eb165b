// Parameter sweeps (sweep.hpp): reading and checking the sweep file, and the members it makes. Running them is
// sweep.cpp's job (the members' processes in sweep_members.cpp, the summary in sweep_summary.cpp).
#include "sweep/sweep.hpp"
#include "sweep/sweep_internal.hpp"
#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>

#include "experiment/json_reader.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using nlohmann::json;

namespace geobarrier {

namespace detail::sweeps {

std::string read_text(const fs::path &file, const std::string &what) {
    std::error_code ec;
    if (fs::is_directory(file, ec)) throw IoError(file.string() + ": is a folder, not " + what);
    std::ifstream in(file, std::ios::binary);
    if (!in) throw IoError(file.string() + ": cannot open " + what);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) throw IoError(file.string() + ": cannot read " + what);
    return text;
}

std::string value_text(const json &v) { return v.is_string() ? v.get<std::string>() : v.dump(); }

// "amplitude = 0.08, omega = 1"
std::string describe_member(const Sweep &s, const SweepMember &m) {
    std::string text;
    for (std::size_t p = 0; p < s.parameters.size(); ++p)
        text += (p ? ", " : "") + s.parameters[p].name + " = " + value_text(s.parameters[p].values[m.choice[p]]);
    return text;
}

bool is_figure_pointer(const std::string &figure) { return !figure.empty() && figure[0] == '/'; }

} // namespace detail::sweeps

namespace {

using detail::ObjectReader;
using detail::short_dump;
using detail::type_name;
using detail::sweeps::describe_member;
using detail::sweeps::is_figure_pointer;
using detail::sweeps::read_text;

constexpr std::size_t max_members = 100000;

// Where a swept pointer meets an array of the base, it must name an element of it, and it cannot go through a value
// that is neither object nor array. Keys absent from an object are created (a plugin's "params" left out, a parameter
// at its default); a misspelt key is caught when the members are checked as experiments, with a hint.
void check_pointer_in_base(const json &base, const std::string &pointer, const std::string &at) {
    const json::json_pointer ptr(pointer);
    const json *node = &base;
    std::string walked;
    std::vector<std::string> tokens;
    for (json::json_pointer p = ptr; !p.empty(); p.pop_back()) tokens.insert(tokens.begin(), p.back());
    for (std::size_t k = 0; k < tokens.size(); ++k) {
        const std::string &token = tokens[k];
        if (node->is_object()) {
            if (!node->contains(token)) return;
            node = &node->at(token);
        } else if (node->is_array()) {
            const bool digits = !token.empty() && std::all_of(token.begin(), token.end(), ::isdigit);
            if (!digits || token.size() > 9 || std::stoul(token) >= node->size())
                throw ConfigError(at, "\"" + pointer + "\": \"" + walked + "\" is an array of " +
                                          std::to_string(node->size()) + " elements; \"" + token +
                                          "\" is not the index of one");
            node = &node->at(std::stoul(token));
        } else {
            throw ConfigError(at, "\"" + pointer + "\": \"" + walked + "\" is " + type_name(*node) +
                                      ", not an object or array to set \"" + token + "\" in");
        }
        walked += "/" + token;
    }
}

// n values from `from` to `to`, both included, evenly spaced; integers where the base holds an integer there and
// every value is one.
std::vector<json> range_values(double from, double to, std::size_t count, bool integer) {
    std::vector<json> values;
    bool all_integral = integer;
    std::vector<double> numbers;
    for (std::size_t k = 0; k < count; ++k) {
        const double v =
            k + 1 == count ? to : from + (to - from) * static_cast<double>(k) / static_cast<double>(count - 1);
        numbers.push_back(v);
        all_integral = all_integral && std::nearbyint(v) == v && std::abs(v) < 9e15;
    }
    for (const double v : numbers) values.push_back(all_integral ? json(static_cast<long long>(v)) : json(v));
    return values;
}

// A base experiment run in both directions: its members' fields.nc lie in forward/ and backward/, so their FTLE
// figures are per direction (ftle_mean_forward, ...).
bool runs_both_directions(const json &base) {
    return base.contains("time") && base["time"].is_object() && base["time"].value("directions", json()) == "both";
}

// The figures the base experiment can give when the sweep names none.
std::vector<std::string> default_figures(const json &base) {
    std::vector<std::string> figures;
    if (base.contains("extractors") && base["extractors"].is_array())
        for (const json &x : base["extractors"])
            if (x.is_object() && x.value("plugin", json()).is_string() && x["plugin"] == "elliptic") {
                figures.push_back("outermost_elliptic_area");
                figures.push_back("elliptic_barriers");
                break;
            }
    if (base.contains("products") && base["products"].is_array())
        for (const json &p : base["products"])
            if (p == "ftle") {
                if (runs_both_directions(base)) {
                    figures.insert(figures.end(), {"ftle_mean_forward", "ftle_max_forward", "ftle_mean_backward",
                                                   "ftle_max_backward"});
                } else {
                    figures.push_back("ftle_mean");
                    figures.push_back("ftle_max");
                }
            }
    // An open system's safe basin: its share of the grid, member by member (an erosion curve over the forcing).
    if (base.contains("bounds") && base["bounds"].is_object() && base["bounds"].value("exits", "stop") == "stop")
        figures.push_back("captured_fraction");
    figures.push_back("masked_fraction");
    return figures;
}

} // namespace

const std::vector<std::string> &sweep_figure_names() {
    static const std::vector<std::string> names = {
        "outermost_elliptic_area", "elliptic_barriers", "barriers",           "ftle_mean",         "ftle_max",
        "ftle_mean_forward",       "ftle_max_forward",  "ftle_mean_backward", "ftle_max_backward", "captured_fraction",
        "masked_fraction",         "wall_seconds"};
    return names;
}

bool is_sweep_json(const json &j) { return j.is_object() && j.contains("base"); }

bool is_sweep_file(const fs::path &file) {
    try {
        return is_sweep_json(parse_json_text(read_text(file, "a sweep file"), file.string()));
    } catch (const Error &) {
        return false;
    }
}

namespace {

// The sections of a sweep file, one reader each, in the order parse_sweep reads them.

// "base": the experiment itself, or the path of its file (relative to the sweep file's `folder`).
void read_base(const json &base, const fs::path &file, const fs::path &folder, Sweep &s) {
    if (base.is_string()) {
        fs::path path = base.get<std::string>();
        if (path.empty()) throw ConfigError("/base", "\"\" is empty; expected the path of an experiment file");
        if (path.is_relative()) path = (folder / path).lexically_normal();
        std::string text;
        try {
            text = read_text(path, "the base experiment file");
        } catch (const IoError &e) {
            throw ConfigError("/base", e.what());
        }
        s.base = parse_json_text(text, path.string());
        s.relative_to = path;
    } else if (base.is_object()) {
        s.base = base;
        s.relative_to = file;
    } else {
        throw ConfigError("/base", short_dump(base) + " is " + type_name(base) +
                                       "; expected an experiment (an object) or the path of an experiment file");
    }
    if (!s.base.is_object())
        throw ConfigError("/base", short_dump(s.base) + " is " + type_name(s.base) + "; expected an experiment object");
    if (is_sweep_json(s.base)) throw ConfigError("/base", "is a sweep itself; sweeps do not nest");
    // Frames (frames.hpp) write their fields and barriers into frames/NNN, where no figure looks: refused, not empty.
    const json *t0 = s.base.contains("time") && s.base["time"].is_object() && s.base["time"].contains("t0")
                         ? &s.base["time"]["t0"]
                         : nullptr;
    if (t0 && (t0->is_array() || t0->is_object()))
        throw ConfigError("/base/time/t0", "several initial times (frames) are not supported in a sweep; sweep a "
                                           "single t0, or run the frames of each member as its own experiment");
}

// One entry of "parameters" (at JSON path `at`): its path into the base experiment, name and values. `earlier` are
// the entries before it.
SweepParameter read_parameter(const json &entry, const std::string &at, const json &base,
                              const std::vector<SweepParameter> &earlier) {
    ObjectReader p(entry, at);
    SweepParameter parameter;
    parameter.path = p.string("path", std::nullopt);
    json::json_pointer pointer;
    try {
        pointer = json::json_pointer(parameter.path);
    } catch (const json::exception &) {
        throw ConfigError(p.child("path"),
                          "\"" + parameter.path + "\" is not a JSON pointer (e.g. \"/forcing/params/amplitude\")");
    }
    if (pointer.empty())
        throw ConfigError(p.child("path"), "\"\" is the whole experiment; name a value in it (e.g. "
                                           "\"/forcing/params/amplitude\")");
    if (parameter.path.rfind("/output", 0) == 0)
        throw ConfigError(p.child("path"), "\"" + parameter.path +
                                               "\": each member writes into its own folder "
                                               "of the sweep's output; sweep \"output\" in the sweep file instead");
    check_pointer_in_base(base, parameter.path, p.child("path"));
    for (const SweepParameter &other : earlier)
        if (other.path == parameter.path)
            throw ConfigError(p.child("path"), "\"" + parameter.path + "\" is swept twice");
    parameter.name = p.string("name", pointer.back());
    if (parameter.name.empty()) throw ConfigError(p.child("name"), "\"\" is empty; expected a column name");
    const bool has_values = p.has("values"), has_range = p.has("range");
    if (has_values == has_range)
        throw ConfigError(at, has_values ? "give either \"values\" or \"range\", not both"
                                         : "missing \"values\" (a list) or \"range\" ({\"from\", \"to\", \"count\"})");
    if (has_values) {
        const json &values = p.get("values");
        if (!values.is_array() || values.empty())
            throw ConfigError(p.child("values"), short_dump(values) + " must be a non-empty array of values");
        for (const json &v : values) parameter.values.push_back(v);
    } else {
        ObjectReader r(p.get("range"), p.child("range"));
        const double from = r.number("from"), to = r.number("to");
        r.get("count");
        const std::size_t count = r.count("count", 2, 2, max_members);
        r.finish();
        const bool integer = base.contains(pointer) && base.at(pointer).is_number_integer();
        parameter.values = range_values(from, to, count, integer);
    }
    p.finish();
    return parameter;
}

std::vector<SweepParameter> read_parameters(const json &params, const json &base) {
    if (!params.is_array() || params.empty())
        throw ConfigError("/parameters", short_dump(params) + " must be a non-empty array of {\"path\": \"/...\", "
                                                              "\"values\": [...]} or {\"path\": ..., \"range\": ...}");
    std::vector<SweepParameter> parameters;
    for (std::size_t i = 0; i < params.size(); ++i)
        parameters.push_back(read_parameter(params[i], "/parameters/" + std::to_string(i), base, parameters));
    return parameters;
}

// The members: every combination of the values ("grid"), or the k-th values together ("zip"), in the order of
// nested loops over the parameters as listed (the last one fastest).
std::vector<SweepMember> make_members(const Sweep &s) {
    std::size_t count = 1;
    if (s.combine == "zip") {
        count = s.parameters[0].values.size();
        for (std::size_t i = 1; i < s.parameters.size(); ++i)
            if (s.parameters[i].values.size() != count)
                throw ConfigError("/parameters/" + std::to_string(i),
                                  std::to_string(s.parameters[i].values.size()) + " values, but /parameters/0 has " +
                                      std::to_string(count) + "; \"combine\": \"zip\" pairs the k-th values");
    } else {
        for (const SweepParameter &p : s.parameters) {
            count *= p.values.size();
            if (count > max_members)
                throw ConfigError("/parameters", "more than " + std::to_string(max_members) + " members");
        }
    }
    const std::size_t digits = std::max<std::size_t>(3, std::to_string(count - 1).size());
    std::vector<SweepMember> members;
    for (std::size_t k = 0; k < count; ++k) {
        SweepMember m;
        m.choice.resize(s.parameters.size());
        std::size_t rest = k;
        for (std::size_t p = s.parameters.size(); p-- > 0;) {
            if (s.combine == "zip") {
                m.choice[p] = k;
            } else {
                m.choice[p] = rest % s.parameters[p].values.size();
                rest /= s.parameters[p].values.size();
            }
        }
        const std::string number = std::to_string(k);
        m.name = "member-" + std::string(digits - number.size(), '0') + number;
        m.experiment = s.base;
        for (std::size_t p = 0; p < s.parameters.size(); ++p)
            m.experiment[json::json_pointer(s.parameters[p].path)] = s.parameters[p].values[m.choice[p]];
        members.push_back(std::move(m));
    }
    return members;
}

// FTLE figures and the base's directions: a member run in both directions has no fields.nc of its own (an empty
// column before), one run in one direction no forward/ or backward/.
void check_direction_figures(const std::vector<std::string> &figures, const json &base) {
    const bool both = runs_both_directions(base);
    for (std::size_t i = 0; i < figures.size(); ++i) {
        const std::string &f = figures[i];
        const bool per_direction = f.rfind("ftle_", 0) == 0 && (f.find("_forward") != std::string::npos ||
                                                                f.find("_backward") != std::string::npos);
        if (both && (f == "ftle_mean" || f == "ftle_max"))
            throw ConfigError("/figures/" + std::to_string(i),
                              "\"" + f +
                                  "\": the members run both directions (/base/time/directions), each with its "
                                  "own FTLE field; name \"" +
                                  f + "_forward\" or \"" + f + "_backward\"");
        if (!both && per_direction)
            throw ConfigError("/figures/" + std::to_string(i),
                              "\"" + f +
                                  "\" is a figure of members run in both directions, and /base/time/directions "
                                  "is not \"both\"; name \"" +
                                  f.substr(0, f.rfind('_')) + "\"");
    }
}

std::vector<std::string> read_figures(const json &figures) {
    if (!figures.is_array()) throw ConfigError("/figures", short_dump(figures) + " must be an array of figure names");
    const auto &names = sweep_figure_names();
    std::vector<std::string> out;
    for (std::size_t i = 0; i < figures.size(); ++i) {
        const std::string at = "/figures/" + std::to_string(i);
        if (!figures[i].is_string()) throw ConfigError(at, short_dump(figures[i]) + " must be a figure name");
        const std::string name = figures[i].get<std::string>();
        if (is_figure_pointer(name)) {
            try {
                json::json_pointer{name};
            } catch (const json::exception &) {
                throw ConfigError(at, "\"" + name + "\" is not a JSON pointer into manifest.json");
            }
        } else if (std::find(names.begin(), names.end(), name) == names.end()) {
            std::string msg = "unknown figure \"" + name + "\"";
            const std::string hint = did_you_mean(name, names);
            if (!hint.empty()) msg += "; did you mean \"" + hint + "\"?";
            msg += " (known:";
            for (const auto &n : names) msg += " " + n;
            throw ConfigError(at, msg + ", or a JSON pointer into the member's manifest.json)");
        }
        out.push_back(name);
    }
    return out;
}

bool numeric(const SweepParameter &p) {
    return std::all_of(p.values.begin(), p.values.end(), [](const json &v) { return v.is_number(); });
}

// "plot": true/false, or {"figure", "parameter"}; by default the first figure against the first parameter when its
// values are numbers.
void read_plot(const ObjectReader &root, Sweep &s) {
    if (root.has("plot") && root.get("plot").is_boolean()) {
        if (root.boolean("plot", true)) {
            if (s.figures.empty()) throw ConfigError("/plot", "true, but there is no figure to draw");
            s.plot_figure = s.figures.front();
        }
        return;
    }
    if (!root.has("plot")) {
        if (!s.figures.empty() && numeric(s.parameters.front())) s.plot_figure = s.figures.front();
        return;
    }
    ObjectReader pl(root.get("plot"), "/plot");
    s.plot_figure = pl.string("figure", s.figures.empty() ? std::string() : s.figures.front(), s.figures);
    if (s.plot_figure.empty()) throw ConfigError("/plot/figure", "there is no figure to draw");
    if (pl.has("parameter")) {
        const std::string which = pl.string("parameter", std::nullopt);
        std::vector<std::string> choices;
        bool found = false;
        for (std::size_t i = 0; i < s.parameters.size() && !found; ++i) {
            if (s.parameters[i].path == which || s.parameters[i].name == which) {
                s.plot_parameter = i;
                found = true;
            }
            choices.push_back(s.parameters[i].name);
        }
        if (!found) {
            std::string msg = "\"" + which + "\" is not a swept parameter's path or name";
            const std::string hint = did_you_mean(which, choices);
            if (!hint.empty()) msg += "; did you mean \"" + hint + "\"?";
            throw ConfigError(pl.child("parameter"), msg);
        }
    }
    pl.finish();
    if (!numeric(s.parameters[s.plot_parameter]))
        throw ConfigError("/plot/parameter", "\"" + s.parameters[s.plot_parameter].path +
                                                 "\" has values that are not numbers; a picture needs an axis");
}

} // namespace

Sweep parse_sweep(const json &j, const fs::path &file) {
    Sweep s;
    s.file = file;
    ObjectReader root(j, "");
    const fs::path folder = file.empty() ? fs::current_path() : fs::absolute(file).parent_path();

    s.description = root.string("description", std::string());
    read_base(root.get("base"), file, folder, s);
    s.parameters = read_parameters(root.get("parameters"), s.base);
    s.combine = root.string("combine", s.combine, {"grid", "zip"});
    s.members = make_members(s);

    const std::string stem = file.empty() ? std::string("sweep") : file.stem().string();
    s.output_dir = "out/" + stem;
    if (root.has("output")) {
        ObjectReader o(root.get("output"), "/output");
        s.output_dir = o.string("dir", s.output_dir.string());
        if (s.output_dir.empty()) throw ConfigError("/output/dir", "\"\" is empty; expected a folder path");
        o.finish();
    }
    s.figures = root.has("figures") ? read_figures(root.get("figures")) : default_figures(s.base);
    check_direction_figures(s.figures, s.base);
    read_plot(root, s);
    s.processes = static_cast<int>(root.count("processes", 0, 1, 4096));
    s.threads = static_cast<int>(root.count("threads", 0, 1, max_threads));
    root.finish();
    return s;
}

Sweep load_sweep(const fs::path &file) {
    const json j = parse_json_text(read_text(file, "the sweep file"), file.string());
    try {
        return parse_sweep(j, file);
    } catch (const ConfigError &e) {
        throw ConfigError(file.string() + ": " + e.json_path(), std::string(e.what()).substr(e.json_path().size() + 2));
    }
}

void check_sweep_members(const Sweep &s) {
    const std::string prefix = s.file.empty() ? std::string() : s.file.string() + ": ";
    for (const SweepMember &m : s.members) {
        try {
            resolve_experiment(parse_experiment(m.experiment, s.relative_to));
        } catch (const ConfigError &e) {
            // Blame the swept value whose pointer holds the error's path, or the pointer itself when the error is
            // above it (a misspelt key on the way), else the base.
            const auto within = [](const std::string &path, const std::string &prefix) {
                return path.rfind(prefix, 0) == 0 && (path.size() == prefix.size() || path[prefix.size()] == '/');
            };
            std::string at = "/base";
            for (std::size_t p = 0; p < s.parameters.size(); ++p) {
                const std::string here = "/parameters/" + std::to_string(p);
                if (within(e.json_path(), s.parameters[p].path)) {
                    at = here + "/values/" + std::to_string(m.choice[p]);
                    break;
                }
                if (within(s.parameters[p].path, e.json_path())) {
                    at = here + "/path";
                    break;
                }
            }
            throw ConfigError(prefix + at, m.name + " (" + describe_member(s, m) + "): " + e.what());
        }
    }
}

} // namespace geobarrier
