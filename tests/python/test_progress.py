"""Progress: run(progress=True) draws a text line per stage outside a notebook (a tqdm bar in one: test_notebooks.py);
ProgressBar drives one bar per stage and fills it when the stage completes; callbacks run in the caller's
contextvars context although the core calls them from its worker threads."""

import contextvars
import json

import numpy as np
import pytest

import geobarrier
from conftest import SOURCE_DIR
from test_results import attractor_experiment


class FakeBar:
    """Stands in for a tqdm class: records what ProgressBar does with it."""
    made = []

    def __init__(self, total, desc, **_):
        self.total, self.desc, self.n, self.closed = total, desc, 0, False
        FakeBar.made.append(self)

    def update(self, k):
        self.n += k

    def refresh(self):
        pass

    def close(self):
        self.closed = True


def test_progress_bar_one_bar_per_stage_filled_when_the_stage_completes():
    FakeBar.made = []
    bar = geobarrier.ProgressBar(FakeBar)
    r = geobarrier.run(attractor_experiment(), progress=bar, threads=2)
    assert r.barriers
    stages = [b.desc for b in FakeBar.made]
    assert stages[0] == "flow map" and any(s.startswith("extractor") for s in stages), stages
    flow = FakeBar.made[0]
    assert flow.total == 101 * 61 and flow.n == flow.total and flow.closed
    # run() closes the last stage when it returns: every bar full and closed.
    assert all(b.closed and b.n == b.total for b in FakeBar.made)


def test_progress_bar_left_short_when_the_run_stops():
    FakeBar.made = []
    bar = geobarrier.ProgressBar(FakeBar)

    def stop(stage, done, total):
        bar(stage, done, total)
        if done > 0:
            raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        geobarrier.run(dict(attractor_experiment(), extractors=[]), progress=stop, threads=2)
    bar.close()
    assert FakeBar.made[0].closed and 0 < FakeBar.made[0].n < FakeBar.made[0].total


def test_text_progress_outside_a_notebook(capsys):
    from geobarrier import _progress

    assert not _progress.in_notebook() and isinstance(_progress.default_progress(), geobarrier.ProgressLine)
    experiment = json.loads((SOURCE_DIR / "experiments" / "duffing-kam.json").read_text())
    experiment["grid"]["n"] = [61, 41]
    experiment["extractors"][0]["params"].update(launch_points=50, poincare_iterates=1)
    geobarrier.run(experiment, progress=True, threads=2)
    lines = capsys.readouterr().err.split("\n")
    # One line per stage, each ending at 100% (the extractor reports only its start).
    assert lines[0].startswith("\rflow map") and lines[0].rsplit("\r", 1)[1].split("]")[1].strip().startswith("100%")
    assert lines[1].startswith("\rextractor elliptic") and "100%" in lines[1].rsplit("\r", 1)[1]
    assert lines[2] == ""



def test_a_missing_or_failing_stderr_does_not_stop_the_run(monkeypatch):
    # Under pythonw and in some services sys.stderr is None: progress=True raised AttributeError from the core's
    # thread and the run was lost; a closed stream raised ValueError.
    import io
    experiment = dict(attractor_experiment(), extractors=[])
    reference = geobarrier.run(experiment, threads=2, xarray=False).fields.ftle
    closed = io.StringIO()
    closed.close()
    for stream in (None, closed):
        monkeypatch.setattr("sys.stderr", stream)
        r = geobarrier.run(experiment, progress=True, threads=2, xarray=False)
        assert np.array_equal(r.fields.ftle, reference, equal_nan=True)
    line = geobarrier.ProgressLine(closed)
    line("flow map", 1, 2)
    line.close(completed=True)
    assert line.stream is None  # it stopped drawing at the first failed write


CALLER = contextvars.ContextVar("caller", default="none")


def test_progress_callbacks_run_in_the_callers_context():
    # The core calls back from its worker threads; a notebook routes output by the caller's context.
    seen = set()
    CALLER.set("the cell")
    geobarrier.run(dict(attractor_experiment(), extractors=[]), progress=lambda *_: seen.add(CALLER.get()),
                   threads=2)
    assert seen == {"the cell"}


def test_the_bar_a_notebook_gets(monkeypatch):
    # tqdm's widget bar only with ipywidgets 7 or newer (Debian 12's 6.0 speaks the old widget protocol): faked
    # here, since no ipywidgets is installed for the tests.
    import sys
    import types

    tqdm = pytest.importorskip("tqdm", reason="needs python3-tqdm (scripts/install-deps)")
    from geobarrier import _progress

    for version, expected in (("8.1.1", "tqdm.notebook"), ("7.0.0", "tqdm.notebook"), ("6.0.0", "tqdm.std")):
        monkeypatch.setitem(sys.modules, "ipywidgets",
                            types.SimpleNamespace(__version__=version, __name__="ipywidgets"))
        assert _progress.notebook_tqdm().__module__ == expected, version
    monkeypatch.setitem(sys.modules, "ipywidgets", None)  # not installed: import fails
    assert _progress.notebook_tqdm() is tqdm.std.tqdm
    monkeypatch.setattr(_progress, "in_notebook", lambda: True)
    chosen = _progress.default_progress()
    assert isinstance(chosen, geobarrier.ProgressBar) and chosen.tqdm_class is tqdm.std.tqdm


def test_overlapping_progress_calls_take_turns():
    """Two worker threads' progress calls can overlap (the callback releases the GIL while it writes or sleeps);
    each must still run in the caller's context, one at a time, instead of raising "cannot enter context"."""
    import threading
    import time

    from geobarrier._progress import InContext

    marker = contextvars.ContextVar("marker", default="worker")
    marker.set("caller")
    seen, inside, overlap = [], [0], [False]

    def callback(stage, done, total):
        inside[0] += 1
        overlap[0] = overlap[0] or inside[0] > 1
        time.sleep(0.01)  # releases the GIL: the other thread's call arrives now
        seen.append(marker.get())
        inside[0] -= 1

    wrapped = InContext(callback)
    threads = [threading.Thread(target=lambda: [wrapped("flow map", k, 20) for k in range(20)]) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert seen == ["caller"] * 40
    assert not overlap[0]
