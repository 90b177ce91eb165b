// Launching and timing: one child process as a whole (wall time, user CPU time, peak resident memory, its output),
// and the machine's state named in the report (load average, processor).
#pragma once

#include <string>
#include <vector>

namespace geobarrier::bench {

struct ProcessResult {
    int status = -1;
    double wall_seconds = 0;
    double peak_mib = 0;     // the child's maximum resident set size
    double user_seconds = 0; // the child's user CPU time (all its threads): steadier than wall time on a shared machine
    std::string output;
};

// Runs argv as a child process (stdout+stderr captured to a file), timing it as a whole process. The peak resident
// memory comes from GNU time when installed: a forked child's own ru_maxrss would also count the bench's pages it
// inherited before exec.
ProcessResult run_process(std::vector<std::string> argv, const std::vector<std::string> &env = {});

// The line of a failed run's output that says "error", else its last line.
std::string first_line(const std::string &text);

// /proc/loadavg's three averages, "1.02 0.98 0.87".
std::string load_average();

// The processor as the docs name it: "AMD EPYC family 25 model 17, 2 cores" (/proc/cpuinfo).
std::string cpu_name();

} // namespace geobarrier::bench
