#include "process.hpp"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

namespace geobarrier::bench {

namespace fs = std::filesystem;

namespace {
const char *const gnu_time = "/usr/bin/time";
} // namespace

ProcessResult run_process(std::vector<std::string> argv, const std::vector<std::string> &env) {
    const std::string tag = std::to_string(::getpid());
    const fs::path log = fs::temp_directory_path() / ("geobarrier-bench-" + tag + ".log");
    const fs::path rss = fs::temp_directory_path() / ("geobarrier-bench-" + tag + ".rss");
    const bool timed = ::access(gnu_time, X_OK) == 0;
    if (timed) argv.insert(argv.begin(), {gnu_time, "-f", "%M", "-o", rss.string()});
    const auto start = std::chrono::steady_clock::now();
    const pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error("fork failed");
    if (pid == 0) {
        std::FILE *out = std::freopen(log.c_str(), "w", stdout);
        (void)out;
        ::dup2(::fileno(stdout), ::fileno(stderr));
        for (const auto &e : env) ::putenv(const_cast<char *>(e.c_str()));
        std::vector<char *> args;
        for (const auto &a : argv) args.push_back(const_cast<char *>(a.c_str()));
        args.push_back(nullptr);
        ::execvp(args[0], args.data());
        std::perror("exec");
        ::_exit(127);
    }
    int status = 0;
    struct rusage usage {};
    ::wait4(pid, &status, 0, &usage);
    ProcessResult r;
    r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.peak_mib = usage.ru_maxrss / 1024.0;
    r.user_seconds = usage.ru_utime.tv_sec + usage.ru_utime.tv_usec * 1e-6;
    if (timed) {
        std::ifstream in(rss);
        std::string line, last;
        while (std::getline(in, line))
            if (!line.empty()) last = line; // "Command exited with non-zero status" comes first on failure
        try {
            r.peak_mib = std::stod(last) / 1024.0;
        } catch (...) {
        }
        fs::remove(rss);
    }
    std::ifstream in(log);
    std::stringstream text;
    text << in.rdbuf();
    r.output = text.str();
    fs::remove(log);
    return r;
}

std::string first_line(const std::string &text) {
    std::istringstream in(text);
    std::string line, last;
    while (std::getline(in, line))
        if (line.find("error") != std::string::npos)
            return line;
        else if (!line.empty())
            last = line;
    return last;
}

std::string load_average() {
    std::ifstream in("/proc/loadavg");
    std::string a, b, c;
    in >> a >> b >> c;
    return a + " " + b + " " + c;
}

std::string cpu_name() {
    std::ifstream in("/proc/cpuinfo");
    std::map<std::string, std::string> first;
    int cores = 0;
    for (std::string line; std::getline(in, line);) {
        const std::size_t colon = line.find(':');
        if (colon == std::string::npos) continue;
        std::string key = line.substr(0, colon), value = colon + 2 <= line.size() ? line.substr(colon + 2) : "";
        key.erase(key.find_last_not_of(" \t") + 1);
        if (key == "processor") ++cores;
        first.emplace(key, value);
    }
    return first["model name"] + " family " + first["cpu family"] + " model " + first["model"] + ", " +
           std::to_string(cores) + " cores";
}

} // namespace geobarrier::bench
