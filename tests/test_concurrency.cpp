// One writer per output folder (docs/robustness.md, "One writer per folder"): a second run or sweep into a folder that
// another holds is refused with exit 2 and one line naming the folder, and the folder ends with the files of exactly
// one run. The interleavings are forced, not hoped for: the first writer pauses at a named point (the test hook
// GEOBARRIER_TEST_PAUSE_AT, folder_lock.hpp) while the second is started, and goes on only when the test says so.
// Also: SIGTERM up to the last rename, what an earlier run left, what dead writers left.
#include <doctest/doctest.h>
#include <nlohmann/json.hpp>
#include <test_support.hpp>

#include <geobarrier/errors.hpp>
#include <geobarrier/experiment.hpp>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <set>
#include <thread>

namespace fs = std::filesystem;
using nlohmann::json;
extern char **environ;

namespace {

using geobarrier::test::read_text;

// A scratch folder of this test case, fresh.
fs::path scratch(const std::string &name) {
    const fs::path dir =
        fs::temp_directory_path() / ("geobarrier-concurrency-" + std::to_string(::getpid()) + "-" + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

// The bad-input battery's small experiment (11 x 9 Duffing), with a forcing amplitude that tells runs apart, and
// optionally the hyperbolic extractor (barriers.json and its pictures).
fs::path experiment(const fs::path &dir, const std::string &name, double amplitude, bool extractor) {
    json e = {{"system", {{"plugin", "duffing"}, {"params", {{"alpha", 1}, {"beta", 1}, {"delta", 0}}}}},
              {"forcing", {{"plugin", "cosine"}, {"params", {{"amplitude", amplitude}}}}},
              {"grid", {{"x", {-1.5, 1.5}}, {"y", {-1, 1}}, {"n", {11, 9}}}},
              {"time", {{"t0", 0}, {"t1", 2}}},
              {"products", {"ftle"}}};
    if (extractor) e["extractors"] = {{{"plugin", "hyperbolic"}}};
    const fs::path file = dir / (name + ".json");
    std::ofstream(file) << e.dump(1);
    return file;
}

struct Process {
    pid_t pid = -1;
    fs::path out, err;
};

// Starts `geobarrier ARGS...` with stdout and stderr to files; `pause_at` sets the test hook (pausing in `hooks`).
Process start(const fs::path &dir, const std::string &tag, std::vector<std::string> args,
              const std::string &pause_at = "", const fs::path &hooks = {}) {
    Process p{-1, dir / (tag + ".stdout"), dir / (tag + ".stderr")};
    const std::string program = geobarrier::test::geobarrier_program().string();
    args.insert(args.begin(), program);
    std::vector<char *> argv;
    for (auto &a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::vector<std::string> env_text;
    for (char **e = environ; *e; ++e) {
        const std::string v = *e;
        if (v.rfind("GEOBARRIER_TEST_PAUSE_", 0) != 0) env_text.push_back(v);
    }
    if (!pause_at.empty()) {
        env_text.push_back("GEOBARRIER_TEST_PAUSE_AT=" + pause_at);
        env_text.push_back("GEOBARRIER_TEST_PAUSE_DIR=" + hooks.string());
    }
    std::vector<char *> envp;
    for (auto &v : env_text) envp.push_back(v.data());
    envp.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, p.out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, p.err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    REQUIRE(posix_spawn(&p.pid, program.c_str(), &actions, nullptr, argv.data(), envp.data()) == 0);
    posix_spawn_file_actions_destroy(&actions);
    return p;
}

// The exit code (128 + signal for a signal death); a hang guard of 300 s, not a timing assertion.
int wait_for(const Process &p) {
    int status = 0;
    for (int i = 0; i < 60000; ++i) {
        if (::waitpid(p.pid, &status, WNOHANG) == p.pid)
            return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ::kill(p.pid, SIGKILL);
    ::waitpid(p.pid, &status, 0);
    FAIL("the program did not end within 300 s");
    return -1;
}

// Waits until a paused writer has reached `point` (its hook file exists), calling `still_running` between polls
// (it fails the test when the writer ended first). Bounded at 300 s: a guard against a hang, not a timing.
template <class StillRunning>
void wait_for_hook(const fs::path &hooks, const std::string &point, StillRunning still_running) {
    for (int i = 0; i < 60000; ++i) {
        if (fs::exists(hooks / (point + ".reached"))) return;
        still_running();
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    FAIL("the first writer never reached " << point);
}

// The same for a writer that is another process: fails if it ended first.
void wait_until_paused(const Process &p, const fs::path &hooks, const std::string &point) {
    wait_for_hook(hooks, point, [&] {
        int status = 0;
        REQUIRE_MESSAGE(::waitpid(p.pid, &status, WNOHANG) == 0, read_text(p.err));
    });
}

void release(const fs::path &hooks, const std::string &point) { std::ofstream(hooks / (point + ".go")) << "go\n"; }

// Every entry of a folder, hidden ones included, with the bytes of the files.
std::map<std::string, std::string> contents(const fs::path &folder) {
    std::map<std::string, std::string> out;
    for (const auto &e : fs::directory_iterator(folder))
        out[e.path().filename().string()] = e.is_regular_file() ? read_text(e.path()) : std::string("<folder>");
    return out;
}

// A folder holds the result of exactly the run `reference` (a folder of that experiment, run alone): the same names,
// the same bytes for every file but the manifest, and a manifest of that experiment listing exactly those files.
void check_one_run(const fs::path &folder, const fs::path &reference) {
    const auto got = contents(folder), want = contents(reference);
    std::set<std::string> got_names, want_names;
    for (const auto &[name, bytes] : got) got_names.insert(name);
    for (const auto &[name, bytes] : want) want_names.insert(name);
    CHECK(got_names == want_names);
    for (const auto &[name, bytes] : want)
        if (name != "manifest.json" && name.find(".png") == std::string::npos && got.count(name))
            CHECK_MESSAGE(got.at(name) == bytes, name);
    const json m = json::parse(got.at("manifest.json")), r = json::parse(want.at("manifest.json"));
    CHECK(m.at("experiment") == r.at("experiment"));
    CHECK(m.at("files") == r.at("files"));
}

// The one line of a refused writer.
void check_refused(const Process &p, int code, const fs::path &folder, const std::string &holder) {
    CHECK(code == 2);
    const std::string err = read_text(p.err);
    CHECK(std::count(err.begin(), err.end(), '\n') == 1);
    CHECK(err.rfind("geobarrier: error: " + folder.string() + ": another geobarrier " + holder + " (pid ", 0) == 0);
    CHECK(err.find("is writing into this output folder") != std::string::npos);
    CHECK(read_text(p.out).empty());
}

std::vector<std::string> run_args(const fs::path &exp, const fs::path &out) {
    return {"run", exp.string(), "--out", out.string(), "--quiet", "--threads", "1"};
}

// Runs `r` into `folder` in a thread paused once it holds the folder, then checks that a second run of this process
// into the same folder is refused (OutputBusyError) and that the first one completes; returns the first run's error.
std::string second_thread_refused(const geobarrier::ResolvedExperiment &r, const fs::path &folder,
                                  const fs::path &hooks) {
    geobarrier::RunOptions options;
    options.output_dir = folder;
    options.threads = 1;
    options.quiet = true;
    ::setenv("GEOBARRIER_TEST_PAUSE_AT", "locked", 1);
    ::setenv("GEOBARRIER_TEST_PAUSE_DIR", hooks.c_str(), 1);
    std::string first_error;
    std::thread first([&] {
        try {
            geobarrier::run_experiment(r, options);
        } catch (const std::exception &e) {
            first_error = e.what();
        }
    });
    wait_for_hook(hooks, "locked", [] {});
    CHECK_THROWS_AS(geobarrier::run_experiment(r, options), geobarrier::OutputBusyError);
    release(hooks, "locked");
    first.join();
    ::unsetenv("GEOBARRIER_TEST_PAUSE_AT");
    ::unsetenv("GEOBARRIER_TEST_PAUSE_DIR");
    fs::remove(hooks / "locked.reached");
    fs::remove(hooks / "locked.go");
    return first_error;
}

} // namespace

TEST_CASE("a second run into a folder another run holds is refused, at every stage; the folder ends with one run") {
    for (const std::string point : {"locked", "staged", "publishing"}) {
        CAPTURE(point);
        const fs::path dir = scratch("second-" + point), hooks = dir / "hooks", out = dir / "out";
        fs::create_directories(hooks);
        const fs::path a = experiment(dir, "a", 0.08, false), b = experiment(dir, "b", 0.3, true);
        // References, each run alone; and an earlier finished run of b in the shared folder (with barriers.json).
        REQUIRE(wait_for(start(dir, "ref-a", run_args(a, dir / "ref-a"))) == 0);
        REQUIRE(wait_for(start(dir, "ref-b", run_args(b, dir / "ref-b"))) == 0);
        REQUIRE(wait_for(start(dir, "earlier", run_args(b, out))) == 0);
        REQUIRE(fs::exists(out / "barriers.json"));

        const Process first = start(dir, "first", run_args(a, out), point, hooks);
        wait_until_paused(first, hooks, point);
        const Process second = start(dir, "second", run_args(b, out));
        check_refused(second, wait_for(second), out, "run");
        const Process sweep_like = start(dir, "third", run_args(a, out)); // the same experiment: refused as well
        check_refused(sweep_like, wait_for(sweep_like), out, "run");
        release(hooks, point);
        CHECK(wait_for(first) == 0);
        check_one_run(out, dir / "ref-a"); // a's files only: b's barriers.json and pictures are gone
        CHECK(!fs::exists(out / "barriers.json"));
        fs::remove_all(dir);
    }
}

TEST_CASE("SIGTERM: before the moves the folder is as it was; during them the result is completed, never exit 0") {
    const fs::path dir = scratch("sigterm"), out = dir / "out";
    const fs::path a = experiment(dir, "a", 0.08, false), b = experiment(dir, "b", 0.3, true);
    REQUIRE(wait_for(start(dir, "ref-a", run_args(a, dir / "ref-a"))) == 0);
    REQUIRE(wait_for(start(dir, "ref-b", run_args(b, dir / "ref-b"))) == 0);
    REQUIRE(wait_for(start(dir, "earlier", run_args(b, out))) == 0);
    const auto before = contents(out);

    SUBCASE("staged: every file written, nothing moved") {
        const fs::path hooks = dir / "hooks-staged";
        fs::create_directories(hooks);
        const Process p = start(dir, "term-staged", run_args(a, out), "staged", hooks);
        wait_until_paused(p, hooks, "staged");
        REQUIRE(::kill(p.pid, SIGTERM) == 0);
        release(hooks, "staged");
        CHECK(wait_for(p) == 143);
        const std::string err = read_text(p.err);
        CHECK(err.find("interrupted by SIGTERM before moving the finished files into place") != std::string::npos);
        CHECK(err.find("which is as it was before the run") != std::string::npos);
        CHECK(contents(out) == before); // byte for byte, no staging folder, no lock file
    }
    SUBCASE("publishing: the earlier run's files gone, this run's moved but its manifest") {
        const fs::path hooks = dir / "hooks-publishing";
        fs::create_directories(hooks);
        const Process p = start(dir, "term-publishing", run_args(a, out), "publishing", hooks);
        wait_until_paused(p, hooks, "publishing");
        CHECK(!fs::exists(out / "manifest.json")); // a folder without a manifest is no finished run
        REQUIRE(::kill(p.pid, SIGTERM) == 0);
        release(hooks, "publishing");
        CHECK(wait_for(p) == 143);
        const std::string err = read_text(p.err);
        CHECK(err.find("interrupted by SIGTERM while moving the finished files into place") != std::string::npos);
        CHECK(err.find("holds this run's complete result") != std::string::npos);
        check_one_run(out, dir / "ref-a");
    }
    fs::remove_all(dir);
}

TEST_CASE("what dead writers left is removed under the lock; what an earlier run left is removed if not replaced") {
    const fs::path dir = scratch("leftovers"), out = dir / "out";
    const fs::path a = experiment(dir, "a", 0.08, false), b = experiment(dir, "b", 0.3, true);
    REQUIRE(wait_for(start(dir, "ref-a", run_args(a, dir / "ref-a"))) == 0);
    REQUIRE(wait_for(start(dir, "ref-b", run_args(b, dir / "ref-b"))) == 0);

    SUBCASE("a SIGKILLed run's staging folder, temporary file and lock file") {
        fs::create_directories(out / ".geobarrier-partial-4194303-0-deadbeef");
        std::ofstream(out / ".geobarrier-partial-4194303-0-deadbeef" / "fields.nc") << "half";
        fs::create_directories(out / ".geobarrier-partial-4194304"); // the old naming, by pid only
        std::ofstream(out / ".fields.nc.tmp-4194303-7") << "half";
        std::ofstream(out / ".geobarrier-lock") << "geobarrier run (pid 4194303)\n"; // unlocked: its holder died
        std::ofstream(out / "notes.txt") << "the user's own file\n";
        REQUIRE(wait_for(start(dir, "run", run_args(a, out))) == 0);
        auto got = contents(out);
        CHECK(got.at("notes.txt") == "the user's own file\n"); // not a run's: kept
        fs::remove(out / "notes.txt");
        check_one_run(out, dir / "ref-a");
    }
    SUBCASE("a finished run of another experiment: its barriers.json and pictures go") {
        REQUIRE(wait_for(start(dir, "b", run_args(b, out))) == 0);
        REQUIRE(wait_for(start(dir, "a", run_args(a, out))) == 0);
        check_one_run(out, dir / "ref-a");
    }
    SUBCASE("a run killed while moving its files: its journal names them") {
        fs::create_directories(out);
        for (const char *name : {"barriers.json", "barriers.png", "strainlines.png", "fields.nc"})
            fs::copy_file(dir / "ref-b" / name, out / name);
        std::ofstream(out / ".geobarrier-publishing")
            << R"(["barriers.json", "barriers.png", "strainlines.png", "fields.nc", "ftle.png"])";
        REQUIRE(wait_for(start(dir, "a", run_args(a, out))) == 0);
        check_one_run(out, dir / "ref-a");
    }
    SUBCASE("a manifest naming paths outside the folder removes nothing there") {
        fs::create_directories(out);
        std::ofstream(dir / "precious.txt") << "keep\n";
        std::ofstream(out / "manifest.json") << R"({"files": ["../precious.txt", "/etc/hostname", ".", "..", ""]})";
        REQUIRE(wait_for(start(dir, "a", run_args(a, out))) == 0);
        CHECK(read_text(dir / "precious.txt") == "keep\n");
        check_one_run(out, dir / "ref-a");
    }
    fs::remove_all(dir);
}

TEST_CASE("one sweep per folder at a time; no run into a sweep's folder meanwhile") {
    const fs::path dir = scratch("sweep"), hooks = dir / "hooks", out = dir / "sweep-out";
    fs::create_directories(hooks);
    const fs::path a = experiment(dir, "a", 0.08, false);
    const json sweep = {
        {"base", "a.json"},
        {"parameters", json::array({{{"path", "/forcing/params/amplitude"}, {"values", {0.05, 0.1}}}})}};
    std::ofstream(dir / "sweep.json") << sweep.dump(1);
    const std::vector<std::string> sweep_args = {
        "sweep", (dir / "sweep.json").string(), "--out", out.string(), "--quiet", "--processes", "1", "--threads", "1"};
    const Process first = start(dir, "first", sweep_args, "sweep-locked", hooks);
    wait_until_paused(first, hooks, "sweep-locked");
    const Process second = start(dir, "second", sweep_args);
    check_refused(second, wait_for(second), out, "sweep");
    const Process run = start(dir, "run", run_args(a, out));
    check_refused(run, wait_for(run), out, "sweep");
    release(hooks, "sweep-locked");
    CHECK_MESSAGE(wait_for(first) == 0, read_text(first.err));
    CHECK(fs::exists(out / "summary.csv"));
    CHECK(!fs::exists(out / ".geobarrier-lock"));
    fs::remove_all(dir);
}

TEST_CASE("two threads of one process: the second run into the folder is refused (OutputBusyError)") {
    const fs::path dir = scratch("threads"), hooks = dir / "hooks", out = dir / "out";
    fs::create_directories(hooks);
    const fs::path a = experiment(dir, "a", 0.08, false);
    REQUIRE(wait_for(start(dir, "ref-a", run_args(a, dir / "ref-a"))) == 0);
    const geobarrier::ResolvedExperiment r = geobarrier::resolve_experiment(geobarrier::load_experiment(a));
    CHECK(second_thread_refused(r, out, hooks).empty());
    check_one_run(out, dir / "ref-a");
    fs::remove_all(dir);
}

TEST_CASE("a file system that cannot lock: the run warns and goes on, leaves others' staging, threads kept apart") {
    // No test machine has such a file system (NFS without its lock service): the hook GEOBARRIER_TEST_LOCK_FAILS makes
    // flock fail as it does there. Before the hook, this fallback (docs/robustness.md) had never run.
    const fs::path dir = scratch("no-flock"), hooks = dir / "hooks";
    fs::create_directories(hooks);
    const fs::path a = experiment(dir, "a", 0.08, false);
    REQUIRE(wait_for(start(dir, "ref-a", run_args(a, dir / "ref-a"))) == 0);
    for (const std::string failure : {"ENOLCK", "EOPNOTSUPP"}) {
        CAPTURE(failure);
        const fs::path out = dir / ("out-" + failure);
        // What looks like a dead writer's staging folder may be a live writer's on another machine: it stays.
        const fs::path staging = out / ".geobarrier-partial-999999-0-abcdef";
        fs::create_directories(staging);
        std::ofstream(staging / "fields.nc") << "another writer's";
        ::setenv("GEOBARRIER_TEST_LOCK_FAILS", failure.c_str(), 1);
        const Process p = start(dir, "run-" + failure, run_args(a, out));
        const int code = wait_for(p);
        const std::string err = read_text(p.err);
        CAPTURE(err);
        CHECK(code == 0);
        CHECK(err.find(out.string() + ": the file system cannot lock files (" +
                       (failure == "ENOLCK" ? "No locks available" : "Operation not supported") +
                       "); two geobarrier processes writing this folder at once are not kept apart") !=
              std::string::npos);
        CHECK(read_text(staging / "fields.nc") == "another writer's");
        fs::remove_all(staging);
        check_one_run(out, dir / "ref-a"); // and no lock file left

        // Within one process the folder is still held: a second thread's run into it is refused.
        const geobarrier::ResolvedExperiment r = geobarrier::resolve_experiment(geobarrier::load_experiment(a));
        CHECK(second_thread_refused(r, dir / ("threads-" + failure), hooks).empty());
        ::unsetenv("GEOBARRIER_TEST_LOCK_FAILS");
        check_one_run(dir / ("threads-" + failure), dir / "ref-a");
    }
    fs::remove_all(dir);
}

TEST_CASE("both directions: the folder and each direction's subfolder are held; an earlier run's files go") {
    const fs::path dir = scratch("both"), hooks = dir / "hooks", out = dir / "out";
    fs::create_directories(hooks);
    const fs::path a = experiment(dir, "a", 0.08, false);
    json both = json::parse(read_text(experiment(dir, "both", 0.08, true)));
    both["time"]["directions"] = "both";
    std::ofstream(dir / "both.json") << both.dump(1);
    REQUIRE(wait_for(start(dir, "earlier", run_args(a, out))) == 0);
    const Process first = start(dir, "first", run_args(dir / "both.json", out), "locked", hooks);
    wait_until_paused(first, hooks, "locked"); // inside the forward run
    const Process second = start(dir, "second", run_args(a, out));
    check_refused(second, wait_for(second), out, "run");
    const Process third = start(dir, "third", run_args(a, out / "forward"));
    check_refused(third, wait_for(third), out / "forward", "run");
    release(hooks, "locked");
    CHECK_MESSAGE(wait_for(first) == 0, read_text(first.err));
    std::set<std::string> names;
    for (const auto &e : fs::directory_iterator(out)) names.insert(e.path().filename().string());
    const json manifest = json::parse(read_text(out / "manifest.json"));
    std::set<std::string> listed;
    for (const json &f : manifest.at("files")) listed.insert(f.get<std::string>());
    CHECK(names == listed); // the earlier run's fields.nc and ftle.png are gone, no lock file, no staging folder
    fs::remove_all(dir);
}

TEST_CASE("both directions over an earlier one: its manifest and tangle.json go before a new direction is published") {
    // The directions are replaced one after the other, so the earlier run's top level cannot stay whole: before, its
    // manifest.json and tangle.json stayed beside the new forward/ (and the old tangle.json until the new one was
    // written), vouching for a mix. Forced: the new run pauses while publishing its forward direction.
    const fs::path dir = scratch("both-over-both"), hooks = dir / "hooks", out = dir / "out";
    fs::create_directories(hooks);
    for (const auto &[name, amplitude] : {std::pair<std::string, double>{"earlier", 0.08}, {"later", 0.1}}) {
        json both = json::parse(read_text(experiment(dir, name, amplitude, true)));
        both["time"]["directions"] = "both";
        std::ofstream(dir / (name + ".json")) << both.dump(1);
    }
    REQUIRE(wait_for(start(dir, "earlier", run_args(dir / "earlier.json", out))) == 0);
    REQUIRE(fs::exists(out / "tangle.json"));
    const Process later = start(dir, "later", run_args(dir / "later.json", out), "publishing", hooks);
    wait_until_paused(later, hooks, "publishing"); // forward/'s new files moved in, its manifest not yet
    CHECK_FALSE(fs::exists(out / "manifest.json"));
    CHECK_FALSE(fs::exists(out / "tangle.json"));
    CHECK_FALSE(fs::exists(out / "tangle.png"));
    CHECK(fs::exists(out / "backward" / "manifest.json")); // the earlier backward run, whole, until it is replaced
    release(hooks, "publishing");
    CHECK_MESSAGE(wait_for(later) == 0, read_text(later.err));
    std::set<std::string> names;
    for (const auto &e : fs::directory_iterator(out)) names.insert(e.path().filename().string());
    const json manifest = json::parse(read_text(out / "manifest.json"));
    std::set<std::string> listed;
    for (const json &f : manifest.at("files")) listed.insert(f.get<std::string>());
    CHECK(names == listed); // no journal, no lock file, no staging folder
    CHECK(manifest.at("experiment").at("forcing").at("params").at("amplitude") == 0.1);
    for (const std::string direction : {"forward", "backward"})
        CHECK(json::parse(read_text(out / direction / "manifest.json"))
                  .at("experiment")
                  .at("forcing")
                  .at("params")
                  .at("amplitude") == 0.1);
    fs::remove_all(dir);
}
