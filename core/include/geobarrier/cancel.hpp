// Cooperative cancellation of a run. The program's SIGINT/SIGTERM handler only records the signal; the flow-map
// engine and the runner poll it and stop by throwing Cancelled, so every file is either written whole (temporary
// name, then rename) or not at all, and the program can say where it stopped.
#ifndef GEOBARRIER_CANCEL_HPP
#define GEOBARRIER_CANCEL_HPP

#include <geobarrier/errors.hpp>

#include <string>

namespace geobarrier {

// Thrown where a requested cancellation is noticed. what(): "interrupted by SIGINT <where>".
class Cancelled : public Error {
  public:
    Cancelled(int signal, const std::string &where);
    int signal() const { return m_signal; }

  private:
    int m_signal;
};

// Records a cancellation request (async-signal-safe: one lock-free atomic store).
void request_cancel(int signal) noexcept;
// The signal that asked to stop, or 0 when none did. Cheap enough to call once per integration step.
int cancel_requested() noexcept;
// Forgets a request (tests, and programs that run several experiments).
void clear_cancel() noexcept;
// Throws Cancelled when a cancellation was requested; `where` completes the message ("during the flow map").
void throw_if_cancelled(const std::string &where);

// For programs: SIGINT and SIGTERM call request_cancel (a second one terminates at once, with the default action),
// and SIGXFSZ is ignored so that a file-size limit makes the write fail with EFBIG, reported as an I/O error,
// instead of killing the process with a half-written temporary file.
void install_signal_handlers();

// "SIGINT", "SIGTERM", or "signal N".
std::string signal_name(int signal);

} // namespace geobarrier

#endif // GEOBARRIER_CANCEL_HPP
