"""The module and its OpenMP runtime: idle threads sleep as in the geobarrier program (apps/geobarrier/openmp_wait.cpp),
and a process forked after a parallel run runs the core with one thread (the second half of this file).

Why: with no policy set, libgomp keeps an idle thread spinning for a few ms after each of a run's ~47 parallel
regions before it sleeps; on a busy machine the spinning thread takes the core the master thread needs (the program's
extractor CPU on workload W fell from 0.47-0.51 to 0.34-0.36 of the flow map's). libgomp reads OMP_WAIT_POLICY once,
when it is loaded (its library constructor), so the variable must be in the environment when the native extension
(which links libgomp) is first imported: the program restarts itself for that, the module sets the variable just
before that import, and takes it out again after it, so that the programs a user starts from Python and the OpenMP
runtimes other libraries load later run with the user's environment.

When the user set OMP_WAIT_POLICY or GOMP_SPINCOUNT (either value) nothing changes. When the runtime was in the
process already (another library loaded it) it is too late: its setting stays, and a warning says how to choose.
"""

import os
import re
import threading
import warnings

# The OpenMP runtimes: GNU's (libgomp.so.1), LLVM's (libomp.so) and Intel's (libiomp5.so), also as wheels vendor them
# (libgomp-a34b3233.so.1.0.0), which are runtimes of their own.
_RUNTIME = re.compile(r"^lib(gomp|omp|iomp5)([-.].*)?\.so(\.|$)")


def _mapped_runtimes():
    """The OpenMP runtime files mapped into this process (set of paths), or None where /proc/self/maps is not there."""
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as f:
            fields = [line.split(None, 5) for line in f]  # address, perms, offset, device, inode, path
    except OSError:
        return None
    paths = {f[5].strip() for f in fields if len(f) == 6}
    return {p for p in paths if _RUNTIME.match(os.path.basename(p))}


def import_with_passive_wait(load):
    """Calls ``load()`` (the import of the native extension) with OMP_WAIT_POLICY=passive in the environment unless
    the user chose a policy, and returns what the OpenMP runtime got: "user" (the user's variables stand),
    "passive" (the runtime was loaded by this import and read it), "too late" (the runtime was loaded before: it
    spins; warned), or "unknown" (no /proc to tell; the variable was set)."""
    if "OMP_WAIT_POLICY" in os.environ or "GOMP_SPINCOUNT" in os.environ:
        load()
        return "user"
    before = _mapped_runtimes()
    os.environ["OMP_WAIT_POLICY"] = "passive"
    try:
        load()
    finally:
        after = _mapped_runtimes()
        # LLVM's and Intel's runtimes read the environment when the first parallel region starts, not when they are
        # loaded, so for them (or where /proc cannot tell) the variable stays; libgomp (GCC's, this build's) has read
        # it by now.
        loaded = None if after is None else after - (before or set())
        if loaded is not None and all(os.path.basename(p).startswith("libgomp") for p in loaded):
            del os.environ["OMP_WAIT_POLICY"]
    if before is None or after is None:
        return "unknown"
    if after - before:
        return "passive"
    if after:
        warnings.warn(
            f"geobarrier: the OpenMP runtime ({', '.join(sorted(after))}) was loaded before geobarrier (by another "
            "library imported earlier), so its idle threads keep spinning after each parallel region, which costs "
            "CPU time on a busy machine. Import geobarrier first or set OMP_WAIT_POLICY=passive before Python "
            "starts for the geobarrier program's setting; set OMP_WAIT_POLICY (passive or active) to silence this.",
            RuntimeWarning, stacklevel=3)
        return "too late"
    return "unknown"


# Forks. libgomp keeps, for each thread that ran a parallel region of more than one thread, a pool of worker threads
# for the next region. A fork copies the forking thread only, and in the child that thread's next parallel region of
# more than one thread waits for the pool's workers forever: multiprocessing's "fork" Pool (Linux's default start
# method) hung in its first run when the parent had run geobarrier before. In such a child the forking thread runs
# the core with one thread (a Pool's workers are the parallelism there); other threads of the child have no pool yet
# and keep theirs.
_parallel = threading.local()  # .used: this thread ran the core's parallel code
_stale_pool_thread = None  # in a child forked after its forking thread ran parallel code: that thread's ident


def parallel_threads(threads):
    """The thread count a call hands the core (0: OpenMP's default): ``threads``, or 1 in the thread whose pool a
    fork left behind, with a warning when the caller asked for more."""
    if _stale_pool_thread is not None and _stale_pool_thread == threading.get_ident():
        if threads not in (0, 1):
            warnings.warn(
                f"geobarrier: threads={threads} runs with 1 thread: this process was forked (os.fork, "
                "multiprocessing's \"fork\" start method) after this thread ran geobarrier's parallel code, and GNU "
                "OpenMP's worker threads do not survive a fork (more than one would wait for them forever). Use the "
                "\"spawn\" or \"forkserver\" start method for threads in the workers.", RuntimeWarning, stacklevel=3)
        return 1
    if threads != 1:
        _parallel.used = True
    return threads


def guard_forks(native):
    """Registers the fork handler that sets one thread in a child whose forking thread's OpenMP pool is stale."""
    def after_fork_in_child():
        global _stale_pool_thread
        if getattr(_parallel, "used", False):
            _stale_pool_thread = threading.get_ident()
            native.set_default_threads(1)  # the core's regions without a thread count of their own (cauchy_green)

    if hasattr(os, "register_at_fork"):
        os.register_at_fork(after_in_child=after_fork_in_child)
