// MPI for runs beyond one machine (docs/cluster.md). Started only when the program was launched by mpirun (the
// launcher's environment says so): the same binary run directly behaves as a single process and never touches MPI.
// Under mpirun, `geobarrier run` shares the flow map's tiles among the ranks (tiles.hpp) and `geobarrier sweep`
// shares its members. Without MPI at build time (GEOBARRIER_MPI off, or no MPI found) every rank query says "one
// process" and the work queue hands out every index locally.
#ifndef GEOBARRIER_MPI_HPP
#define GEOBARRIER_MPI_HPP

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace geobarrier::mpi {

// Whether this build has MPI.
bool built_with_mpi();

// Initializes MPI when launched by mpirun (asking for MPI_THREAD_MULTIPLE: rank 0 serves the work queue from a
// thread); does nothing otherwise. Finalizes when destroyed.
class Session {
  public:
    Session(int &argc, char **&argv);
    ~Session();
    Session(const Session &) = delete;
    Session &operator=(const Session &) = delete;
};

bool active(); // MPI is initialized (and not finalized)
int rank();    // 0 when not active
int size();    // 1 when not active

// Before the program leaves with `code` after a failure. When more than one rank runs: if every rank fails alike
// (`every_rank` true: bad input, which each rank reads the same), they finalize together; otherwise MPI_Abort ends the
// whole job with `code` so that no rank waits forever for the failed one. One rank: finalizes.
void end_before_exit(int code, bool every_rank);

// Whether `geobarrier run` shares its flow map's tiles among the ranks: switched on by the program for `run` (a
// sweep's members run whole, one per rank); true only with more than one rank.
void share_tiles(bool on);
bool sharing_tiles();

// The indices 0 .. count-1, handed to the ranks as each asks for the next (dynamic balancing: a rank whose tiles
// cost more takes fewer). Rank 0 serves the others from a thread and takes its own without messages. Every rank must
// call next() until it returns nothing. With one rank it is a counter.
class WorkQueue {
  public:
    explicit WorkQueue(std::size_t count);
    ~WorkQueue();
    WorkQueue(const WorkQueue &) = delete;
    WorkQueue &operator=(const WorkQueue &) = delete;
    std::optional<std::size_t> next();

  private:
    void serve();
    std::size_t m_count;
    std::atomic<std::size_t> m_next{0};
    std::atomic<bool> m_stop{false};
    std::size_t m_static_next = 0; // without a serving thread: this rank's share, rank + k * size
    bool m_dynamic = false;
    std::thread m_server;
};

// Point-to-point transfers of raw bytes between two ranks, in pieces below MPI's int counts. Waiting polls (with
// short sleeps, so an idle rank leaves its core to others) and throws Cancelled when SIGINT/SIGTERM arrives.
void send_bytes(int to, const void *data, std::size_t bytes);
void receive_bytes(int from, void *data, std::size_t bytes);

template <class T> void send_vector(int to, const std::vector<T> &v) {
    const std::uint64_t n = v.size();
    send_bytes(to, &n, sizeof n);
    send_bytes(to, v.data(), n * sizeof(T));
}
template <class T> std::vector<T> receive_vector(int from) {
    std::uint64_t n = 0;
    receive_bytes(from, &n, sizeof n);
    std::vector<T> v(static_cast<std::size_t>(n));
    receive_bytes(from, v.data(), v.size() * sizeof(T));
    return v;
}

} // namespace geobarrier::mpi

#endif // GEOBARRIER_MPI_HPP
