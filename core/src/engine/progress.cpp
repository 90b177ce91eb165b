// Progress bar drawing: "\r<label> [#####.....]  42%  3.1 s, 4.2 s left".
#include "engine/progress.hpp"

#include <unistd.h>

#include <cstdio>

namespace geobarrier::detail {

ProgressBar::ProgressBar(std::string label, bool enabled)
    : m_label(std::move(label)), m_enabled(enabled && isatty(fileno(stderr)) != 0),
      m_start(std::chrono::steady_clock::now()), m_last(m_start) {}

ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::update(std::size_t done, std::size_t total) {
    if (!m_enabled) return;
    std::lock_guard<std::mutex> lock(m_mutex);
    const auto now = std::chrono::steady_clock::now();
    if (done < total && now - m_last < std::chrono::milliseconds(100)) return;
    m_last = now;
    draw(done, total);
}

void ProgressBar::draw(std::size_t done, std::size_t total) {
    const double fraction = total ? static_cast<double>(done) / static_cast<double>(total) : 1.0;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
    constexpr int width = 30;
    const int filled = static_cast<int>(fraction * width + 0.5);
    char bar[width + 1];
    for (int i = 0; i < width; ++i) bar[i] = i < filled ? '#' : '.';
    bar[width] = '\0';
    if (fraction > 0.0 && fraction < 1.0)
        std::fprintf(stderr, "\r%-18s [%s] %3.0f%%  %.1f s, %.1f s left ", m_label.c_str(), bar, 100 * fraction,
                     elapsed, elapsed * (1 - fraction) / fraction);
    else
        std::fprintf(stderr, "\r%-18s [%s] %3.0f%%  %.1f s             ", m_label.c_str(), bar, 100 * fraction,
                     elapsed);
    std::fflush(stderr);
    m_drawn = true;
}

void ProgressBar::finish() {
    if (!m_enabled) return;
    std::lock_guard<std::mutex> lock(m_mutex);
    if (m_drawn) {
        std::fputc('\n', stderr);
        m_drawn = false;
    }
    m_enabled = false;
}

} // namespace geobarrier::detail
