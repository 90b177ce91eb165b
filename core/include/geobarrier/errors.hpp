// The core's small error hierarchy. Inside the core, failures are exceptions;
// the command-line program turns each into one line on stderr and an exit code.
#ifndef GEOBARRIER_ERRORS_HPP
#define GEOBARRIER_ERRORS_HPP

#include <stdexcept>
#include <string>

namespace geobarrier {

class Error : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

// Bad input in an experiment: names the JSON path, the value and the rule.
// what() reads "<path>: <message>", e.g. "/grid/n/0: 1 is below the minimum 2".
class ConfigError : public Error {
  public:
    ConfigError(std::string json_path, const std::string &message)
        : Error(json_path + ": " + message), m_path(std::move(json_path)) {}
    const std::string &json_path() const { return m_path; }

  private:
    std::string m_path;
};

// A plugin that cannot be loaded or that failed a call: "<file>: <reason>".
class PluginError : public Error {
  public:
    using Error::Error;
};

// A library file refused before it was mapped (truncated, unreadable, another machine's: plugins/library_check.hpp),
// wherever it was found: bad input, as an experiment's error is (the program exits with 2). A plugin folder scan, which
// skips the files that are not libraries with a warning, does not skip these: what() reads "<file>: <reason>".
class LibraryFileError : public PluginError {
  public:
    using PluginError::PluginError;
};

// A numerical stage that cannot give a trustworthy answer.
class NumericalError : public Error {
  public:
    using Error::Error;
};

// An input or output file that cannot be read or written.
class IoError : public Error {
  public:
    using Error::Error;
};

// An output folder another writer holds (a run or a sweep, of this process or another: docs/robustness.md, "One writer
// per folder"): "<folder>: another geobarrier run (pid N) is writing into this output folder; ...". Refused before
// anything is computed or written; the program exits with 2.
class OutputBusyError : public IoError {
  public:
    using IoError::IoError;
};

} // namespace geobarrier

#endif // GEOBARRIER_ERRORS_HPP
