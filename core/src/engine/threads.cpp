// ScopedThreadCount (threads.hpp).
#include <geobarrier/threads.hpp>

#include <omp.h>

namespace geobarrier {

ScopedThreadCount::ScopedThreadCount(int threads) : m_saved(omp_get_max_threads()) {
    if (threads > 0) omp_set_num_threads(threads);
}

ScopedThreadCount::~ScopedThreadCount() { omp_set_num_threads(m_saved); }

} // namespace geobarrier
