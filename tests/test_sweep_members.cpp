// A sweep's members and what they leave (issue 37): a resumed sweep reuses a finished member only when every file
// its manifest lists is there with the size and SHA-256 the manifest records, and re-runs it otherwise, saying why;
// the members run in process groups of their own and end with the sweep process, SIGKILL included, so that nothing
// of a dead sweep keeps running or keeps its folder locked. The kill is placed with the test hook
// (GEOBARRIER_TEST_PAUSE_AT, folder_lock.hpp): the member is paused inside its run when the sweep is killed.
#include <doctest/doctest.h>
#include <nlohmann/json.hpp>
#include <test_support.hpp>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;
using nlohmann::json;
using namespace geobarrier;
extern char **environ;

namespace {

fs::path fresh_dir(const std::string &name) {
    const fs::path dir =
        fs::temp_directory_path() / ("geobarrier-sweep-members-" + std::to_string(::getpid()) + "-" + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

// A small undamped Duffing sweep over t1 into dir/out, one member at a time.
json small_sweep(const fs::path &dir, const std::vector<double> &t1) {
    const json base = json::parse(R"({"system": {"plugin": "duffing"}, "forcing": {"plugin": "cosine"},
        "grid": {"x": [-1, 1], "y": [-1, 1], "n": [21, 21]}, "time": {"t0": 0, "t1": 1},
        "bounds": {"x": [-3, 3], "y": [-3, 3]}, "products": ["ftle"], "output": {"plots": false}})");
    return {{"base", base},
            {"parameters", {{{"path", "/time/t1"}, {"values", t1}}}},
            {"figures", {"ftle_max"}},
            {"processes", 1},
            {"threads", 1},
            {"output", {{"dir", (dir / "out").string()}}}};
}

// Starts `geobarrier ARGS...` with stdout and stderr into dir; `pause_at` sets the test hook (pausing in `hooks`).
pid_t start_program(const fs::path &dir, std::vector<std::string> args, const std::string &pause_at = "",
                    const fs::path &hooks = {}) {
    const std::string program = test::geobarrier_program().string();
    args.insert(args.begin(), program);
    std::vector<std::string> env_text;
    for (char **e = environ; *e; ++e)
        if (std::string(*e).rfind("GEOBARRIER_TEST_PAUSE_", 0) != 0) env_text.emplace_back(*e);
    if (!pause_at.empty()) {
        env_text.push_back("GEOBARRIER_TEST_PAUSE_AT=" + pause_at);
        env_text.push_back("GEOBARRIER_TEST_PAUSE_DIR=" + hooks.string());
    }
    std::vector<char *> argv, envp;
    for (auto &a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    for (auto &e : env_text) envp.push_back(e.data());
    envp.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, (dir / "stdout.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, (dir / "stderr.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_t pid = -1;
    REQUIRE(posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), envp.data()) == 0);
    posix_spawn_file_actions_destroy(&actions);
    return pid;
}

// Waits for a process started here; its exit code (128 + signal when a signal ended it).
int wait_exit(pid_t pid) {
    int status = 0;
    REQUIRE(::waitpid(pid, &status, 0) == pid);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

struct Exit {
    int code = -1;
    std::string err;
};

Exit run_sweep_program(const fs::path &dir) {
    const pid_t pid = start_program(dir, {"sweep", (dir / "sweep.json").string()});
    Exit e;
    e.code = wait_exit(pid);
    e.err = test::read_text(dir / "stderr.txt");
    return e;
}

std::vector<std::vector<std::string>> read_csv(const fs::path &file) {
    std::vector<std::vector<std::string>> rows;
    std::ifstream in(file);
    for (std::string line; std::getline(in, line);) {
        std::vector<std::string> cells;
        std::stringstream s(line);
        for (std::string cell; std::getline(s, cell, ',');) cells.push_back(cell);
        rows.push_back(cells);
    }
    return rows;
}

// A process that is gone, or a zombie nobody reaps (its parent died; PID 1 of a container may not reap).
bool process_ended(pid_t pid) {
    if (::kill(pid, 0) != 0 && errno == ESRCH) return true;
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
    const std::size_t paren = text.rfind(')');
    if (paren == std::string::npos || paren + 2 >= text.size()) return !stat.is_open();
    return text[paren + 2] == 'Z' || text[paren + 2] == 'X';
}

// The parent of a live process, from /proc (0 when it cannot be read).
pid_t parent_of(pid_t pid) {
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
    const std::size_t paren = text.rfind(')');
    if (paren == std::string::npos) return 0;
    std::istringstream rest(text.substr(paren + 2));
    char state = 0;
    long parent = 0;
    rest >> state >> parent;
    return static_cast<pid_t>(parent);
}

} // namespace

TEST_CASE("A resumed sweep re-runs a member whose fields.nc was deleted, cut short or changed, saying why") {
    const fs::path dir = fresh_dir("resume");
    std::ofstream(dir / "sweep.json") << small_sweep(dir, {1.0, 2.0, 3.0, 4.0}).dump(1);
    const fs::path out = dir / "out";
    Exit first = run_sweep_program(dir);
    CAPTURE(first.err);
    REQUIRE(first.code == 0);

    // Every member's manifest records the size and SHA-256 of each file it wrote.
    const auto member = [&](int k) { return out / ("member-00" + std::to_string(k)); };
    std::vector<std::string> manifests;
    for (int k = 0; k < 4; ++k) {
        manifests.push_back(test::read_text(member(k) / "manifest.json"));
        const json files = json::parse(manifests.back())["provenance"]["output_files"];
        REQUIRE(files.is_array());
        REQUIRE(files.size() == 1);
        CHECK(files[0]["file"] == "fields.nc");
        CHECK(files[0]["bytes"].get<std::uintmax_t>() == fs::file_size(member(k) / "fields.nc"));
        CHECK(files[0]["sha256"].get<std::string>().size() == 64);
    }
    const std::uintmax_t size2 = fs::file_size(member(2) / "fields.nc");

    // member-001's fields.nc deleted, member-002's cut in half, one byte of member-003's changed (same size).
    fs::remove(member(1) / "fields.nc");
    fs::resize_file(member(2) / "fields.nc", size2 / 2);
    {
        std::fstream f(member(3) / "fields.nc", std::ios::in | std::ios::out | std::ios::binary);
        f.seekg(static_cast<std::streamoff>(fs::file_size(member(3) / "fields.nc") - 9));
        const char c = static_cast<char>(f.get());
        f.seekp(static_cast<std::streamoff>(fs::file_size(member(3) / "fields.nc") - 9));
        f.put(static_cast<char>(c ^ 0x5a));
    }

    const Exit resumed = run_sweep_program(dir);
    CAPTURE(resumed.err);
    CHECK(resumed.code == 0);
    CHECK(resumed.err.find("member-000 (t1 = 1.0): complete from an earlier run, skipped") != std::string::npos);
    CHECK(resumed.err.find("member-001 (t1 = 2.0): not reused: " + member(1).string() +
                           " holds a finished run of it, but its fields.nc is missing; running it again") !=
          std::string::npos);
    CHECK(resumed.err.find("member-002 (t1 = 3.0): not reused: " + member(2).string() +
                           " holds a finished run of it, but its fields.nc has " + std::to_string(size2 / 2) +
                           " bytes where the manifest records " + std::to_string(size2) +
                           " (cut short or changed); running it again") != std::string::npos);
    CHECK(resumed.err.find("member-003 (t1 = 4.0): not reused: " + member(3).string() +
                           " holds a finished run of it, but its fields.nc does not have the SHA-256 its manifest "
                           "records (changed since it was written); running it again") != std::string::npos);
    const auto rows = read_csv(out / "summary.csv");
    REQUIRE(rows.size() == 5);
    CHECK(rows[1][2] == "reused");
    for (int k = 2; k <= 4; ++k) {
        CHECK(rows[k][2] == "done");
        CHECK_FALSE(rows[k][3].empty()); // its ftle_max, read from the new fields.nc
    }
    CHECK(test::read_text(member(0) / "manifest.json") == manifests[0]); // not run again
    for (int k = 1; k < 4; ++k) {
        const json files = json::parse(test::read_text(member(k) / "manifest.json"))["provenance"]["output_files"];
        CHECK(files[0]["bytes"].get<std::uintmax_t>() == fs::file_size(member(k) / "fields.nc"));
    }

    // A third run finds every member whole and reuses all four.
    const Exit again = run_sweep_program(dir);
    CAPTURE(again.err);
    CHECK(again.code == 0);
    CHECK(again.err.find("not reused") == std::string::npos);
    const auto rows3 = read_csv(out / "summary.csv");
    REQUIRE(rows3.size() == 5);
    for (int k = 1; k <= 4; ++k) CHECK(rows3[k][2] == "reused");
    fs::remove_all(dir);
}

TEST_CASE("SIGKILL of a sweep process ends its running member, and the folder is free again") {
    const fs::path dir = fresh_dir("kill");
    const fs::path hooks = dir / "hooks";
    fs::create_directories(hooks);
    std::ofstream(dir / "sweep.json") << small_sweep(dir, {1.0, 2.0}).dump(1);
    // The member's run pauses once it holds its folder ("locked"); the sweep is killed while it waits there.
    const pid_t sweep = start_program(dir, {"sweep", (dir / "sweep.json").string()}, "locked", hooks);
    const fs::path reached = hooks / "locked.reached";
    int status = 0;
    for (int i = 0; i < 12000 && !fs::exists(reached); ++i) {
        if (::waitpid(sweep, &status, WNOHANG) == sweep) FAIL("the sweep ended before its member paused");
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    REQUIRE(fs::exists(reached));
    pid_t member = 0; // the hook's file appears with the pid in it
    std::istringstream(test::read_text(reached)) >> member;
    REQUIRE(member > 0);
    CHECK(member != sweep);
    CHECK(parent_of(member) == sweep);  // a forked member, paused inside its run
    CHECK(::getpgid(member) == member); // in a process group of its own (a compiler it starts joins it)

    REQUIRE(::kill(sweep, SIGKILL) == 0);
    CHECK(wait_exit(sweep) == 128 + SIGKILL);
    bool ended = false;
    for (int i = 0; i < 2000 && !ended; ++i) { // bounded: 10 s; it ends within milliseconds
        ended = process_ended(member);
        if (!ended) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    CHECK(ended);
    if (!ended) ::kill(member, SIGKILL); // leave nothing behind even when the check failed

    // The folder's lock died with the sweep and its member: the sweep runs again at once, cleans up and finishes.
    const Exit again = run_sweep_program(dir);
    CAPTURE(again.err);
    CHECK(again.code == 0);
    const auto rows = read_csv(dir / "out" / "summary.csv");
    REQUIRE(rows.size() == 3);
    CHECK(rows[1][2] == "done");
    CHECK(rows[2][2] == "done");
    for (const auto &entry : fs::directory_iterator(dir / "out"))
        CHECK(entry.path().filename().string().rfind(".geobarrier-", 0) != 0);
    for (const auto &entry : fs::directory_iterator(dir / "out" / "member-000"))
        CHECK(entry.path().filename().string().rfind(".geobarrier-", 0) != 0);
    fs::remove_all(dir);
}
