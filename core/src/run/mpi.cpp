// MPI sessions, the work queue and byte transfers (see mpi.hpp). Without MPI at build time, the single-process
// versions of the same functions.
#include "run/mpi.hpp"
#include <geobarrier/cancel.hpp>
#include <geobarrier/errors.hpp>

#include <chrono>
#include <cstdlib>
#include <exception>
#include <limits>

#ifdef GEOBARRIER_HAVE_MPI
// The C API only: the deprecated C++ bindings would need their own library (libmpi_cxx).
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>
#endif

namespace geobarrier::mpi {

namespace {

bool g_active = false;
bool g_thread_multiple = false;
bool g_share_tiles = false;
int g_rank = 0, g_size = 1;

constexpr std::uint64_t no_more = std::numeric_limits<std::uint64_t>::max();

#ifdef GEOBARRIER_HAVE_MPI
constexpr int tag_request = 7101, tag_reply = 7102, tag_bytes = 7103;
constexpr std::size_t max_piece = std::size_t(1) << 30; // bytes per message, well inside an int count

// Whether a launcher started this process as one rank of a job (Open MPI's mpirun, PMIx launchers such as srun
// --mpi=pmix, MPICH's hydra).
bool launched_by_mpirun() {
    for (const char *name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"})
        if (std::getenv(name)) return true;
    return false;
}

// Waits for a request by polling: an idle rank sleeps between tests instead of spinning on a core another rank or
// thread could use, and a SIGINT/SIGTERM stops the wait.
void wait_polling(MPI_Request &request, MPI_Status *status = MPI_STATUS_IGNORE) {
    int done = 0;
    for (unsigned polls = 0;; ++polls) {
        MPI_Test(&request, &done, status);
        if (done) return;
        if (const int signal = cancel_requested()) throw Cancelled(signal, "while waiting for the other MPI ranks");
        if (polls > 64) std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
}
#endif

} // namespace

bool built_with_mpi() {
#ifdef GEOBARRIER_HAVE_MPI
    return true;
#else
    return false;
#endif
}

Session::Session([[maybe_unused]] int &argc, [[maybe_unused]] char **&argv) {
#ifdef GEOBARRIER_HAVE_MPI
    if (!launched_by_mpirun()) return;
    int provided = MPI_THREAD_SINGLE;
    if (MPI_Init_thread(&argc, &argv, MPI_THREAD_MULTIPLE, &provided) != MPI_SUCCESS) return;
    g_thread_multiple = provided >= MPI_THREAD_MULTIPLE;
    MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
    MPI_Comm_size(MPI_COMM_WORLD, &g_size);
    g_active = true;
#endif
}

Session::~Session() {
#ifdef GEOBARRIER_HAVE_MPI
    if (g_active) MPI_Finalize();
    g_active = false;
#endif
}

bool active() { return g_active; }
int rank() { return g_active ? g_rank : 0; }
int size() { return g_active ? g_size : 1; }

void end_before_exit([[maybe_unused]] int code, [[maybe_unused]] bool every_rank) {
#ifdef GEOBARRIER_HAVE_MPI
    if (!g_active) return;
    if (g_size > 1 && !every_rank) MPI_Abort(MPI_COMM_WORLD, code);
    MPI_Finalize();
    g_active = false;
#endif
}

void share_tiles(bool on) { g_share_tiles = on; }
bool sharing_tiles() { return g_share_tiles && size() > 1; }

WorkQueue::WorkQueue(std::size_t count) : m_count(count) {
    // Dynamic balancing needs rank 0's serving thread, hence MPI_THREAD_MULTIPLE; without it each rank takes every
    // size-th index (interleaved, which still spreads costly regions of the grid over the ranks).
    m_dynamic = size() > 1 && g_thread_multiple;
    if (m_dynamic && rank() == 0) m_server = std::thread([this] { serve(); });
}

WorkQueue::~WorkQueue() {
    if (!m_server.joinable()) return;
    // Leaving by an exception: the other ranks will be stopped by MPI_Abort; do not wait for their requests.
    if (std::uncaught_exceptions() > 0) m_stop = true;
    m_server.join();
}

std::optional<std::size_t> WorkQueue::next() {
    if (size() == 1 || (rank() == 0 && m_dynamic)) {
        const std::size_t k = m_next.fetch_add(1);
        if (k < m_count) return k;
        return std::nullopt;
    }
    if (!m_dynamic) {
        const std::size_t k = static_cast<std::size_t>(rank()) + m_static_next * static_cast<std::size_t>(size());
        ++m_static_next;
        if (k < m_count) return k;
        return std::nullopt;
    }
#ifdef GEOBARRIER_HAVE_MPI
    std::uint64_t request = 0, reply = no_more;
    MPI_Request r;
    MPI_Isend(&request, 1, MPI_UINT64_T, 0, tag_request, MPI_COMM_WORLD, &r);
    wait_polling(r);
    MPI_Irecv(&reply, 1, MPI_UINT64_T, 0, tag_reply, MPI_COMM_WORLD, &r);
    wait_polling(r);
    if (reply != no_more) return static_cast<std::size_t>(reply);
#endif
    return std::nullopt;
}

void WorkQueue::serve() {
#ifdef GEOBARRIER_HAVE_MPI
    // Answers each rank's requests until every other rank has been told there is no more.
    int finished = 0;
    while (finished < size() - 1) {
        std::uint64_t request = 0;
        MPI_Request r;
        MPI_Status status;
        MPI_Irecv(&request, 1, MPI_UINT64_T, MPI_ANY_SOURCE, tag_request, MPI_COMM_WORLD, &r);
        int done = 0;
        while (!done) {
            MPI_Test(&r, &done, &status);
            if (done) break;
            if (m_stop) {
                MPI_Cancel(&r);
                MPI_Wait(&r, MPI_STATUS_IGNORE);
                return;
            }
            std::this_thread::sleep_for(std::chrono::microseconds(100));
        }
        const std::size_t k = m_next.fetch_add(1);
        const std::uint64_t reply = k < m_count ? static_cast<std::uint64_t>(k) : no_more;
        if (reply == no_more) ++finished;
        MPI_Send(&reply, 1, MPI_UINT64_T, status.MPI_SOURCE, tag_reply, MPI_COMM_WORLD);
    }
#endif
}

void send_bytes([[maybe_unused]] int to, [[maybe_unused]] const void *data, [[maybe_unused]] std::size_t bytes) {
#ifdef GEOBARRIER_HAVE_MPI
    const char *p = static_cast<const char *>(data);
    do {
        const std::size_t piece = std::min(bytes, max_piece);
        MPI_Request r;
        MPI_Isend(p, static_cast<int>(piece), MPI_BYTE, to, tag_bytes, MPI_COMM_WORLD, &r);
        wait_polling(r);
        p += piece;
        bytes -= piece;
    } while (bytes > 0);
#else
    throw Error("send_bytes: this build has no MPI");
#endif
}

void receive_bytes([[maybe_unused]] int from, [[maybe_unused]] void *data, [[maybe_unused]] std::size_t bytes) {
#ifdef GEOBARRIER_HAVE_MPI
    char *p = static_cast<char *>(data);
    do {
        const std::size_t piece = std::min(bytes, max_piece);
        MPI_Request r;
        MPI_Irecv(p, static_cast<int>(piece), MPI_BYTE, from, tag_bytes, MPI_COMM_WORLD, &r);
        wait_polling(r);
        p += piece;
        bytes -= piece;
    } while (bytes > 0);
#else
    throw Error("receive_bytes: this build has no MPI");
#endif
}

} // namespace geobarrier::mpi
