// Cooperative cancellation: the signal handlers record the signal in one lock-free atomic, which long loops poll
// (see cancel.hpp for why the handler does nothing else).
#include <geobarrier/cancel.hpp>

#include <atomic>
#include <csignal>

#include <signal.h>

namespace geobarrier {

namespace {

std::atomic<int> g_signal{0};
static_assert(std::atomic<int>::is_always_lock_free, "the signal handler needs a lock-free atomic");

extern "C" void on_stop_signal(int signal) {
    // A second signal while the first is being honoured: the user insists, so stop now with the default action.
    // Temporary files may then remain (hidden ".name.tmp-*"), but no file under a final name is partial.
    if (g_signal.load(std::memory_order_relaxed) != 0) {
        std::signal(signal, SIG_DFL);
        std::raise(signal);
        return;
    }
    g_signal.store(signal, std::memory_order_relaxed);
}

} // namespace

Cancelled::Cancelled(int signal, const std::string &where)
    : Error("interrupted by " + signal_name(signal) + (where.empty() ? std::string() : " " + where)), m_signal(signal) {
}

void request_cancel(int signal) noexcept { g_signal.store(signal, std::memory_order_relaxed); }

int cancel_requested() noexcept { return g_signal.load(std::memory_order_relaxed); }

void clear_cancel() noexcept { g_signal.store(0, std::memory_order_relaxed); }

void throw_if_cancelled(const std::string &where) {
    if (const int s = cancel_requested()) throw Cancelled(s, where);
}

void install_signal_handlers() {
    struct sigaction action {};
    action.sa_handler = on_stop_signal;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESTART; // blocking calls (writes) resume; the loops notice the flag soon after
    sigaction(SIGINT, &action, nullptr);
    sigaction(SIGTERM, &action, nullptr);
    std::signal(SIGXFSZ, SIG_IGN);
}

std::string signal_name(int signal) {
    switch (signal) {
    case SIGINT:
        return "SIGINT";
    case SIGTERM:
        return "SIGTERM";
    default:
        return "signal " + std::to_string(signal);
    }
}

} // namespace geobarrier
