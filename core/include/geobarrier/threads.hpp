// The OpenMP thread count of one computation, for programs that embed the library (the Python module, a sweep).
#ifndef GEOBARRIER_THREADS_HPP
#define GEOBARRIER_THREADS_HPP

namespace geobarrier {

// Sets the OpenMP thread count for the calling thread (threads > 0; 0 keeps the current one) and restores the previous
// count when it goes out of scope, so that the embedding program keeps its own setting.
class ScopedThreadCount {
  public:
    explicit ScopedThreadCount(int threads);
    ~ScopedThreadCount();
    ScopedThreadCount(const ScopedThreadCount &) = delete;
    ScopedThreadCount &operator=(const ScopedThreadCount &) = delete;

  private:
    int m_saved;
};

} // namespace geobarrier

#endif // GEOBARRIER_THREADS_HPP
