"""Ctrl-C during a run from Python: a Python process is sent SIGINT while the core computes; the run stops with
KeyboardInterrupt, the output folder is as it was (no file, no staging folder), Python's own SIGINT handling is back
afterwards and the next run works."""

import json
import os
import signal
import subprocess
import sys
import textwrap

import geobarrier
from conftest import BASE

CHILD = textwrap.dedent("""
    import json, os, signal, sys
    import geobarrier

    experiment, out = json.loads(sys.argv[1]), sys.argv[2]
    def started(stage, done, total):
        if not started.said:
            print("computing", flush=True)
            started.said = True
    started.said = False
    try:
        geobarrier.run(experiment, out=out, progress=started)
        print("finished")
    except KeyboardInterrupt as e:
        print("interrupted:", e)
    print("handler restored:", signal.getsignal(signal.SIGINT) is signal.default_int_handler)
    print("folder:", sorted(os.listdir(out)) if os.path.exists(out) else "absent")
    small = dict(experiment, grid={"x": [-1, 1], "y": [-1, 1], "n": [5, 5]}, time={"t0": 0, "t1": 1})
    print("next run:", geobarrier.run(small).fields.ftle.shape)
    try:
        os.kill(os.getpid(), signal.SIGINT)  # Python's handler again: KeyboardInterrupt right here
        print("no KeyboardInterrupt")
    except KeyboardInterrupt:
        print("python handles SIGINT again")
""")


# Large enough to take minutes: it is interrupted as soon as the flow map has started.
LONG = dict(BASE, grid={"x": [-1.5, 1.5], "y": [-1, 1], "n": [2000, 1500]}, time={"t0": 0, "t1": 200})


def interrupted_child(experiment, out):
    """Runs CHILD, sends it SIGINT once the core computes; returns its exit code, stdout and stderr."""
    child = subprocess.Popen([sys.executable, "-c", CHILD, json.dumps(experiment), str(out)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=os.environ.copy())
    try:
        assert child.stdout.readline().strip() == "computing"
        child.send_signal(signal.SIGINT)
        stdout, stderr = child.communicate(timeout=120)
    finally:
        child.kill()
    return child.returncode, stdout, stderr


def test_sigint_cancels_a_run_cleanly(tmp_path):
    code, stdout, stderr = interrupted_child(LONG, tmp_path / "out")
    assert code == 0, stderr
    lines = stdout.splitlines()
    assert lines[0].startswith("interrupted: interrupted by SIGINT"), stdout
    assert lines[1:] == ["handler restored: True", "folder: absent", "next run: (5, 5)",
                         "python handles SIGINT again"], stdout


def test_sigint_leaves_an_earlier_finished_run_untouched(tmp_path):
    out = tmp_path / "out"
    geobarrier.run(BASE, out=out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    code, stdout, stderr = interrupted_child(LONG, out)
    assert code == 0 and "interrupted: interrupted by SIGINT" in stdout, stderr
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
