// A shell command run from a test (the geobarrier program, end to end): its exit status and what it wrote to stdout
// (with "2>&1" in the command, stderr too). test_cli, test_check_plugin and test_convergence_layouts run the program
// through it.
#ifndef GEOBARRIER_TEST_PROGRAM_OUTPUT_HPP
#define GEOBARRIER_TEST_PROGRAM_OUTPUT_HPP

#include <doctest/doctest.h>

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace geobarrier::test {

struct CommandResult {
    int status; // the exit status; -1 when killed by a signal
    std::string output;
};

inline CommandResult run_command(const std::string &command) {
    FILE *pipe = ::popen(command.c_str(), "r");
    REQUIRE(pipe != nullptr);
    std::string output;
    std::array<char, 4096> buffer;
    while (std::fgets(buffer.data(), buffer.size(), pipe)) output += buffer.data();
    const int raw = ::pclose(pipe);
    return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, output};
}

} // namespace geobarrier::test

#endif // GEOBARRIER_TEST_PROGRAM_OUTPUT_HPP
