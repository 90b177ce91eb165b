// SIGINT (Ctrl-C, a notebook's "interrupt kernel") while the core computes, for the module's calls that release the
// GIL (run in bindings.cpp, the array functions in arrays.cpp).
#ifndef GEOBARRIER_PYTHON_INTERRUPT_SCOPE_HPP
#define GEOBARRIER_PYTHON_INTERRUPT_SCOPE_HPP

#include <geobarrier/cancel.hpp>

#include <signal.h>

namespace geobarrier::python {

// The core's cancellation request, noticed by the flow-map engine and the runner between batches (cancel.hpp).
extern "C" inline void on_interrupt(int signal) { geobarrier::request_cancel(signal); }

// Python's own handler could only run once the call returns, so for the length of the call this one takes its
// place (when `enabled`: the main thread only); the previous one is restored afterwards.
class InterruptScope {
  public:
    explicit InterruptScope(bool enabled) : m_enabled(enabled) {
        if (!m_enabled) return;
        geobarrier::clear_cancel();
        struct sigaction action {};
        action.sa_handler = on_interrupt;
        sigemptyset(&action.sa_mask);
        action.sa_flags = SA_RESTART;
        sigaction(SIGINT, &action, &m_previous);
    }
    ~InterruptScope() {
        if (m_enabled) sigaction(SIGINT, &m_previous, nullptr);
    }
    InterruptScope(const InterruptScope &) = delete;
    InterruptScope &operator=(const InterruptScope &) = delete;

  private:
    bool m_enabled;
    struct sigaction m_previous {};
};

} // namespace geobarrier::python

#endif // GEOBARRIER_PYTHON_INTERRUPT_SCOPE_HPP
