// The plugin registry (plugin.hpp): the folders plugins are found in, the libraries mapped on demand (found by file
// name, a built-in's name refused from another folder unless named by path), and finding a plugin by kind and name
// with a "did you mean".
#include "plugins/library_check.hpp"
#include "plugins/plugin_internal.hpp"
#include <geobarrier/errors.hpp>
#include <geobarrier/plugin.hpp>

#include <boost/dll/runtime_symbol_info.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdlib>
#include <mutex>
#include <regex>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace geobarrier {

fs::path PluginRegistry::builtin_folder() {
    // This library lives in <prefix>/lib, plugins in <prefix>/lib/geobarrier/plugins, in the build tree and in an
    // install alike. Found from the library, not the program, so that a host program anywhere (python3, the tests
    // in build/tests) finds the same plugins as the geobarrier program in <prefix>/bin.
    const fs::path library = boost::dll::this_line_location().string(); // as the loader found it: "lib/x/../.."
    return (library.parent_path() / "geobarrier" / "plugins").lexically_normal();
}

std::vector<fs::path> PluginRegistry::default_folders(const std::vector<fs::path> &extra) {
    std::vector<fs::path> folders = extra;
    if (const char *env = std::getenv("GEOBARRIER_PLUGIN_PATH"))
        for (const auto &p : detail::split_list(env, ':')) folders.emplace_back(p);
    folders.push_back(builtin_folder());
    return folders;
}

namespace {

// PluginRegistry::find is const but may add a plugin loaded from a path; this lock makes concurrent calls safe (a
// library embedded in Python may resolve experiments from several threads). One lock for every registry: find is
// cheap next to what follows it.
std::mutex &registry_mutex() {
    static std::mutex m;
    return m;
}

bool looks_like_shared_library(const fs::path &p) {
    const std::string name = p.filename().string();
    return p.extension() == ".so" || name.find(".so.") != std::string::npos || p.extension() == ".dylib" ||
           p.extension() == ".dll";
}

// The libraries of a folder, sorted; none when it is not a folder.
std::vector<fs::path> library_files(const fs::path &folder) {
    std::vector<fs::path> files;
    std::error_code ec;
    if (!fs::is_directory(folder, ec)) return files;
    for (const auto &e : fs::directory_iterator(folder, ec))
        if (e.is_regular_file() && looks_like_shared_library(e.path())) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    return files;
}

// The files of `folder` named after plugin `name`, in the order they are tried (plugin.hpp, PluginRegistry).
std::vector<fs::path> files_named_after(const fs::path &folder, const std::string &name) {
    static const std::regex name_rule("[a-z0-9][a-z0-9-]*");
    std::vector<fs::path> out;
    if (!std::regex_match(name, name_rule)) return out;
    for (const std::string &file : {"geobarrier-" + name + ".so", "lib" + name + ".so", name + ".so"}) {
        std::error_code ec;
        if (fs::is_regular_file(folder / file, ec)) out.push_back(folder / file);
    }
    return out;
}

// The plugin name a library's file name stands for: geobarrier-NAME.so, libNAME.so, NAME.so.
std::string name_of_file(const fs::path &file) {
    std::string stem = file.stem().string();
    for (const std::string prefix : {"geobarrier-", "lib"})
        if (stem.rfind(prefix, 0) == 0 && stem.size() > prefix.size()) return stem.substr(prefix.size());
    return stem;
}

bool same_folder(const fs::path &a, const fs::path &b) {
    std::error_code ec;
    return fs::equivalent(a, b, ec) && !ec;
}

} // namespace

PluginRegistry::PluginRegistry(const std::vector<fs::path> &folders, PluginLoading loading)
    : m_folders(folders), m_loading(loading) {
    for (const fs::path &folder : folders) {
        std::error_code ec;
        if (!fs::is_directory(folder, ec)) {
            m_warnings.push_back(folder.string() + ": plugin folder does not exist");
            continue;
        }
        for (const auto &f : library_files(folder)) {
            if (loading == PluginLoading::all) {
                add_library(f, false, "every library of the folder is listed");
                continue;
            }
            // On demand, every library is still checked (plain reads, no code run): a damaged one is refused as
            // when it is mapped, since whoever put it there meant it to be loaded.
            const LibraryFileCheck checked = check_library_file(f);
            if (checked.problem == LibraryFileProblem::damaged)
                throw LibraryFileError(f.string() + ": not a loadable shared library (" + checked.reason + ")");
        }
    }
}

void PluginRegistry::add_library(const fs::path &file, bool strict, const std::string &reason) const {
    m_libraries.push_back(LoadedLibrary{file, {}, reason});
    std::vector<PluginHandle> found;
    try {
        found = load_plugin_library(file);
    } catch (const LibraryFileError &) {
        throw; // a damaged library is refused, not skipped: whoever put it there meant it to be loaded
    } catch (const PluginError &e) {
        if (strict) throw;
        m_warnings.push_back(e.what());
        return;
    }
    for (auto &h : found) {
        m_libraries.back().plugins.push_back(std::string(to_string(h.info.kind)) + " '" + h.info.name + "'");
        const auto same = std::find_if(m_plugins.begin(), m_plugins.end(), [&](const PluginHandle &o) {
            return o.info.kind == h.info.kind && o.info.name == h.info.name;
        });
        if (same != m_plugins.end()) {
            if (same->info.file != h.info.file)
                m_warnings.push_back(h.info.file.string() + ": " + to_string(h.info.kind) + " '" + h.info.name +
                                     "' is shadowed by " + same->info.file.string());
            continue;
        }
        m_plugins.push_back(std::move(h));
    }
}

const PluginHandle *PluginRegistry::find_loaded(PluginKind kind, const std::string &name, const fs::path *file) const {
    for (const PluginHandle &h : m_plugins)
        if (h.info.kind == kind && h.info.name == name && (!file || h.info.file == *file)) return &h;
    return nullptr;
}

// Only the libraries the lookup needs (plugin.hpp, PluginRegistry): the first one named after the plugin, else the
// folders' others one at a time. Null when no folder holds the plugin.
const PluginHandle *PluginRegistry::find_on_demand(PluginKind kind, const std::string &name,
                                                   const std::string &json_path) const {
    const auto was_loaded = [&](const fs::path &file) {
        return std::any_of(m_libraries.begin(), m_libraries.end(),
                           [&](const LoadedLibrary &l) { return l.file == file; });
    };
    const fs::path builtin = builtin_folder();
    const std::vector<fs::path> builtin_named = files_named_after(builtin, name);
    bool named_file_exists = false;
    for (const fs::path &folder : m_folders)
        for (const fs::path &file : files_named_after(folder, name)) {
            named_file_exists = true;
            // Refused before it is mapped: a folder's library named like a built-in plugin would replace it.
            if (!builtin_named.empty() && !same_folder(folder, builtin))
                throw ConfigError(json_path, file.string() + " is named like the built-in " + to_string(kind) + " '" +
                                                 name + "' (" + builtin_named.front().string() +
                                                 ") and would shadow it; to use it, name the library by path: "
                                                 "\"plugin\": \"" +
                                                 file.string() + "\"");
            if (!was_loaded(file)) {
                try {
                    add_library(file, true, "named after the " + std::string(to_string(kind)));
                } catch (const PluginError &e) {
                    throw ConfigError(json_path, e.what()); // the library named after the plugin is not one
                }
            }
            if (const PluginHandle *h = find_loaded(kind, name, &file)) return h;
        }
    if (const PluginHandle *h = find_loaded(kind, name)) return h; // a library mapped for an earlier lookup
    if (named_file_exists) return nullptr;
    // No file is named after the plugin: the folders' other libraries, one at a time; a warning for each that ran
    // and did not hold it.
    for (const fs::path &folder : m_folders)
        for (const fs::path &file : library_files(folder)) {
            if (was_loaded(file)) continue;
            add_library(file, false, "looked for " + std::string(to_string(kind)) + " '" + name + "'");
            if (const PluginHandle *h = find_loaded(kind, name, &file)) return h;
            m_warnings.push_back(file.string() + ": mapped (its code run) while looking for " + to_string(kind) + " '" +
                                 name + "', which it does not hold: no library in the plugin folders is " +
                                 "named after it; name its library geobarrier-" + name +
                                 ".so so that no other library is mapped");
        }
    return nullptr;
}

// What the folders hold of a kind: the loaded plugins' names, and on demand the names the other files stand for.
std::vector<std::string> PluginRegistry::names_by_file(PluginKind kind) const {
    std::vector<std::string> names;
    for (const PluginHandle &h : m_plugins)
        if (h.info.kind == kind) names.push_back(h.info.name);
    if (m_loading == PluginLoading::on_demand)
        for (const fs::path &folder : m_folders)
            for (const fs::path &file : library_files(folder)) {
                const bool mapped = std::any_of(m_libraries.begin(), m_libraries.end(),
                                                [&](const LoadedLibrary &l) { return l.file == file; });
                if (!mapped) names.push_back(name_of_file(file));
            }
    std::sort(names.begin(), names.end());
    names.erase(std::unique(names.begin(), names.end()), names.end());
    return names;
}

const PluginHandle &PluginRegistry::find(PluginKind kind, const std::string &name, const std::string &json_path) const {
    std::lock_guard<std::mutex> lock(registry_mutex());
    const bool is_path = name.find('/') != std::string::npos || fs::path(name).extension() == ".so";
    if (is_path) {
        const fs::path file = fs::absolute(name);
        std::vector<PluginHandle> found;
        try {
            found = load_plugin_library(file);
        } catch (const PluginError &e) {
            throw ConfigError(json_path, e.what());
        }
        m_libraries.push_back(LoadedLibrary{file, {}, "named by path"});
        for (const auto &h : found)
            m_libraries.back().plugins.push_back(std::string(to_string(h.info.kind)) + " '" + h.info.name + "'");
        for (auto &h : found)
            if (h.info.kind == kind) {
                m_plugins.push_back(std::move(h));
                return m_plugins.back();
            }
        throw ConfigError(json_path, file.string() + " holds no " + to_string(kind) + " plugin");
    }
    if (m_loading == PluginLoading::on_demand) {
        if (const PluginHandle *h = find_on_demand(kind, name, json_path)) return *h;
    } else if (const PluginHandle *h = find_loaded(kind, name)) {
        return *h;
    }
    const std::vector<std::string> names = names_by_file(kind);
    std::string msg = "no " + std::string(to_string(kind)) + " plugin named \"" + name + "\"";
    const std::string hint = did_you_mean(name, names);
    if (!hint.empty()) msg += "; did you mean \"" + hint + "\"?";
    if (names.empty()) {
        msg += "; no " + std::string(to_string(kind)) + " plugins were found in:";
        for (const auto &f : m_folders) msg += " " + f.string();
    } else {
        // On demand, the libraries not mapped are known by their file names only, of any kind.
        msg +=
            m_loading == PluginLoading::on_demand ? " (plugins and libraries in the plugin folders:" : " (available:";
        for (const auto &n : names) msg += " " + n;
        msg += ")";
    }
    throw ConfigError(json_path, msg);
}

} // namespace geobarrier
