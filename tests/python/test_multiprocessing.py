"""geobarrier with multiprocessing. Systems and forcings pickle (as what makes them), so a "spawn" Pool's workers get
them. A process forked after geobarrier ran (multiprocessing's "fork" Pool, Linux's default start method) runs the core
in its forking thread with one thread: libgomp's worker threads stay behind in the parent, and a parallel region of
more than one thread in the child waited for them forever (python/geobarrier/_openmp.py). Each case runs in a fresh
interpreter (a fork of pytest's own process would copy its threads' state too) and under an alarm, so that a hang
fails the test instead of stopping the suite."""

import json
import multiprocessing
import os
import pickle
import subprocess
import sys

import numpy as np
import pytest

import geobarrier
from conftest import BASE

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork on this platform")

PRELUDE = """
import json, os, signal, sys, threading, warnings
import multiprocessing as mp
import numpy as np
import geobarrier
signal.alarm(120)  # a hang in a child shows as a pool timeout; this ends the parent whatever happens
BASE = json.loads(sys.argv[1])
def ftle(threads=None, amplitude=0.08):
    e = dict(BASE, forcing={"plugin": "cosine", "params": {"amplitude": amplitude}})
    return geobarrier.run(e, threads=threads, xarray=False).fields.ftle
"""


def script(code):
    """stdout of `code` after PRELUDE in a fresh interpreter; fails the test on a non-zero exit (an alarm too)."""
    experiment = dict(BASE, grid=dict(BASE["grid"], n=[61, 41]))
    done = subprocess.run([sys.executable, "-c", PRELUDE + code, json.dumps(experiment)], capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout, done.stderr


def test_a_fork_pool_after_a_run_in_the_parent_computes_what_the_parent_does():
    out, err = script("""
reference = {a: ftle(threads=1, amplitude=a) for a in (0.0, 0.04, 0.08)}
ftle(threads=2)  # the parent's pool of OpenMP worker threads
def child(a):
    return ftle(amplitude=a).tolist()  # the default: all cores, which libgomp could not give a fork child
with mp.get_context("fork").Pool(2) as pool:
    got = pool.map_async(child, list(reference)).get(timeout=90)
print("equal", all(np.array_equal(np.array(g), reference[a], equal_nan=True) for g, a in zip(got, reference)))
""")
    assert "equal True" in out
    assert "RuntimeWarning" not in err  # the default thread count is no request to warn about


def test_threads_asked_for_in_such_a_child_run_with_one_and_warn():
    out, err = script("""
reference = ftle(threads=1)
ftle(threads=2)
DF = geobarrier.flow_map(geobarrier.System("duffing"), np.array([[0.1, 0.2], [0.3, -0.4]] * 64), 0, 3,
                         derivative=True)[1]
reference_cg = geobarrier.cauchy_green(DF, 3).ftle
pid = os.fork()
if pid == 0:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        same = np.array_equal(ftle(threads=2), reference, equal_nan=True)
        # cauchy_green and ftle take no thread count: OpenMP's default, which the fork handler set to 1
        same_cg = np.array_equal(geobarrier.cauchy_green(DF, 3).ftle, reference_cg)
        same_cg = same_cg and np.array_equal(geobarrier.ftle(DF, 3), reference_cg)
    print("child", same, same_cg, [str(w.message)[:60] for w in caught], flush=True)
    # Another thread of the child has no pool yet: it keeps its threads.
    result = {}
    worker = threading.Thread(target=lambda: result.update(f=ftle(threads=2)))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        worker.start(); worker.join()
    print("thread", np.array_equal(result["f"], reference, equal_nan=True), len(caught), flush=True)
    os._exit(0)
_, status = os.waitpid(pid, 0)
print("status", status)
""")
    assert "child True True ['geobarrier: threads=2 runs with 1 thread: this process was f']" in out
    assert "thread True 0" in out
    assert "status 0" in out


def test_a_fork_before_any_parallel_run_keeps_its_threads():
    out, err = script("""
reference = ftle(threads=1)  # one thread: no pool in the parent
pid = os.fork()
if pid == 0:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        print("child", np.array_equal(ftle(threads=2), reference, equal_nan=True), len(caught), flush=True)
    os._exit(0)
_, status = os.waitpid(pid, 0)
print("status", status)
""")
    assert "child True 0" in out and "status 0" in out


def flow_in_a_worker(system, forcing, points):
    """A spawn worker's job (module level: pickled by name)."""
    import geobarrier
    return geobarrier.flow_map(system, points, 0, 3, forcing=forcing)


@pytest.mark.parametrize("make", [
    lambda: (geobarrier.System("duffing", alpha=1, beta=1, delta=0.1), geobarrier.Forcing("cosine", amplitude=0.2)),
    lambda: (geobarrier.System.from_equations(["x", "v"], ["v", "x - x^3 - d*v + f"], {"d": 0.15}),
             geobarrier.Forcing("sum", terms=[geobarrier.Forcing("cosine"), geobarrier.Forcing("cosine", omega=2)])),
    lambda: (geobarrier.System("duffing"),
             geobarrier.Forcing("ramp", base=geobarrier.Forcing("cosine", amplitude=0.3))),
])
def test_systems_and_forcings_pickle_as_what_makes_them(make):
    system, forcing = make()
    points = np.array([[0.1, 0.2], [-0.7, 0.3], [1.2, -0.1]])
    again_system, again_forcing = pickle.loads(pickle.dumps((system, forcing)))
    assert (again_system.name, again_system.params) == (system.name, system.params)
    assert (again_forcing.name, again_forcing.params) == (forcing.name, forcing.params)
    expected = geobarrier.flow_map(system, points, 0, 3, forcing=forcing)
    assert np.array_equal(geobarrier.flow_map(again_system, points, 0, 3, forcing=again_forcing), expected)


def test_a_spawn_pool_gets_systems_and_forcings():
    system = geobarrier.System("duffing", delta=0.1)
    forcings = [geobarrier.Forcing("cosine", amplitude=a) for a in (0.0, 0.1)]
    points = np.array([[0.1, 0.2], [-0.7, 0.3]])
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        got = pool.starmap_async(flow_in_a_worker, [(system, f, points) for f in forcings]).get(timeout=120)
    for forcing, states in zip(forcings, got):
        assert np.array_equal(states, geobarrier.flow_map(system, points, 0, 3, forcing=forcing))
