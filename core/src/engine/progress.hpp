// A one-line progress bar on stderr for long stages, shown only on a terminal.
#ifndef GEOBARRIER_SRC_PROGRESS_HPP
#define GEOBARRIER_SRC_PROGRESS_HPP

#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>

namespace geobarrier::detail {

class ProgressBar {
  public:
    // Draws nothing when `enabled` is false or stderr is not a terminal.
    ProgressBar(std::string label, bool enabled);
    ~ProgressBar();
    ProgressBar(const ProgressBar &) = delete;
    ProgressBar &operator=(const ProgressBar &) = delete;

    // Thread-safe; redraws at most ten times a second.
    void update(std::size_t done, std::size_t total);
    void finish();

  private:
    void draw(std::size_t done, std::size_t total);
    std::string m_label;
    bool m_enabled;
    bool m_drawn = false;
    std::mutex m_mutex;
    std::chrono::steady_clock::time_point m_start, m_last;
};

} // namespace geobarrier::detail

#endif // GEOBARRIER_SRC_PROGRESS_HPP
