"""Idle OpenMP threads sleep in the Python module as in the geobarrier program (apps/geobarrier/openmp_wait.cpp).

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
