// SIGINT and SIGTERM on a running geobarrier program: it stops promptly (between integration steps), says so in one
// line, exits with 128 + the signal (130, 143), and leaves no file of the run under a final name: the output folder
// it created is gone again.
#include <doctest/doctest.h>
#include <nlohmann/json.hpp>
#include <test_support.hpp>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <fstream>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;
extern char **environ;

namespace {

std::string read_file(const fs::path &file) {
    std::ifstream in(file);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// Starts the program on an experiment that would take minutes (a 500 x 500 Duffing grid over T = 300), waits until it
// is computing (its staging folder exists), sends `signal`, and waits for the exit (a hang guard of 120 s, not a
// timing assertion: the run would take far longer than that to finish by itself).
void interrupt_run(int signal, int expected_code, const char *name) {
    const fs::path dir = fs::temp_directory_path() / ("geobarrier-interrupt-" + std::to_string(::getpid()) + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    std::ofstream(dir / "exp.json") << R"({
        "system": {"plugin": "duffing"}, "forcing": {"plugin": "cosine"},
        "grid": {"x": [-2, 2], "y": [-2, 2], "n": [500, 500]}, "time": {"t0": 0, "t1": 300},
        "products": ["ftle", "eigenvalues", "eigenvectors"]})";
    const fs::path out = dir / "out";
    const std::string program = geobarrier::test::geobarrier_program().string(), exp = (dir / "exp.json").string(),
                      out_text = out.string();
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, (dir / "stdout.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, (dir / "stderr.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    std::vector<std::string> args = {program, "run", exp, "--out", out_text, "--quiet", "--threads", "2"};
    std::vector<char *> argv;
    for (auto &a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = -1;
    REQUIRE(posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), environ) == 0);
    posix_spawn_file_actions_destroy(&actions);

    const auto computing = [&] {
        if (!fs::exists(out)) return false;
        for (const auto &e : fs::directory_iterator(out))
            if (e.path().filename().string().rfind(".geobarrier-partial-", 0) == 0) return true;
        return false;
    };
    int status = 0;
    bool exited_early = false;
    for (int i = 0; i < 12000 && !computing(); ++i) {
        if (::waitpid(pid, &status, WNOHANG) == pid) {
            exited_early = true;
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    REQUIRE_MESSAGE(!exited_early, read_file(dir / "stderr.txt"));
    std::this_thread::sleep_for(std::chrono::milliseconds(300)); // well inside the flow map
    REQUIRE(::kill(pid, signal) == 0);
    bool done = false;
    for (int i = 0; i < 12000 && !done; ++i) {
        done = ::waitpid(pid, &status, WNOHANG) == pid;
        if (!done) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (!done) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, &status, 0);
        FAIL("the program did not stop within 120 s of " << name);
    }
    const std::string err = read_file(dir / "stderr.txt");
    CAPTURE(err);
    REQUIRE(WIFEXITED(status)); // it handled the signal: an exit, not a death by signal
    CHECK(WEXITSTATUS(status) == expected_code);
    CHECK(std::count(err.begin(), err.end(), '\n') == 1);
    CHECK(err.find(std::string("geobarrier: interrupted by ") + name + " while integrating trajectories") == 0);
    CHECK(err.find("no file of this run was put in the output folder") != std::string::npos);
    CHECK(read_file(dir / "stdout.txt").empty());
    CHECK_FALSE(fs::exists(out)); // created by the run, removed again: nothing under a final name, no partial file
    fs::remove_all(dir);
}

} // namespace

TEST_CASE("SIGINT stops a run: exit code 130, one line, nothing left behind") { interrupt_run(SIGINT, 130, "SIGINT"); }

TEST_CASE("SIGTERM stops a run: exit code 143, one line, nothing left behind") {
    interrupt_run(SIGTERM, 143, "SIGTERM");
}
