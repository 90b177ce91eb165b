"""The example notebooks (examples/python/*.ipynb) run: each is executed by a real Jupyter kernel through nbclient
(Debian: python3-nbclient, python3-ipykernel), from examples/python as Jupyter would start it, and any cell error
fails the test. The paper's first example shows its progress bar (tqdm, Debian: python3-tqdm) in the executed
notebook's output; the committed notebooks hold no outputs. And an interrupted kernel ("interrupt kernel", SIGINT)
stops a run cleanly: KeyboardInterrupt in the cell, and the kernel runs the next cell.

The equations notebook compiles its oscillator once into the user's equations cache (docs/experiment-format.md),
as a user's first run would; later runs load it."""

import json
import os
import pathlib
import queue
import time

import pytest

import geobarrier
from conftest import SOURCE_DIR

nbformat = pytest.importorskip("nbformat", reason="needs python3-nbformat (scripts/install-deps)")
nbclient = pytest.importorskip("nbclient", reason="needs python3-nbclient and python3-ipykernel (scripts/install-deps)")
pytest.importorskip("ipykernel", reason="needs python3-ipykernel (scripts/install-deps)")

EXAMPLES = SOURCE_DIR / "examples" / "python"
NOTEBOOKS = sorted(p.name for p in EXAMPLES.glob("*.ipynb"))


@pytest.fixture(autouse=True)
def kernel_environment(monkeypatch):
    # The kernel imports geobarrier from the same place as this suite (PYTHONPATH, absolute: the kernel starts in
    # examples/python) and draws no window.
    package_parent = str(pathlib.Path(geobarrier.__file__).resolve().parents[1])
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([package_parent, os.environ.get("PYTHONPATH", "")]))
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    monkeypatch.setenv("PYDEVD_DISABLE_FILE_VALIDATION", "1")  # ipykernel's debugger warns about frozen modules


def execute(name):
    notebook = nbformat.read(EXAMPLES / name, as_version=4)
    client = nbclient.NotebookClient(notebook, timeout=120, kernel_name="python3",
                                     resources={"metadata": {"path": str(EXAMPLES)}})
    client.execute()  # raises CellExecutionError on the first cell that fails
    return notebook


def outputs(notebook, stream=None):
    for cell in notebook.cells:
        for output in cell.get("outputs", []):
            if stream is None or (output.get("output_type") == "stream" and output.get("name") == stream):
                yield output


def test_the_examples_are_there_and_clean():
    assert NOTEBOOKS == ["amplitude_sweep.ipynb", "own_oscillator_equations.ipynb", "paper_first_example.ipynb"]
    for name in NOTEBOOKS:
        notebook = nbformat.read(EXAMPLES / name, as_version=4)
        nbformat.validate(notebook)
        code = [c for c in notebook.cells if c.cell_type == "code"]
        assert code and all(c.outputs == [] and c.execution_count is None for c in code), name
        assert notebook.metadata.kernelspec.name == "python3"


@pytest.mark.parametrize("name", NOTEBOOKS)
def test_notebook_runs_without_errors(name):
    notebook = execute(name)
    code = [c for c in notebook.cells if c.cell_type == "code"]
    assert all(c.execution_count is not None for c in code)
    assert not [o for o in outputs(notebook) if o.get("output_type") == "error"]
    images = [o for o in outputs(notebook) if "image/png" in o.get("data", {})]
    assert images, f"{name} draws no picture"
    text = "".join(o.text for o in outputs(notebook, "stdout"))
    if name == "paper_first_example.ipynb":
        # The progress bar: tqdm's, one per stage, on the cell's stderr, ending full (without tqdm: the text line).
        progress = "".join(o.text for o in outputs(notebook, "stderr"))
        try:
            import tqdm  # noqa: F401
        except ImportError:
            assert "flow map            [" in progress and "100%" in progress, progress
        else:
            assert "flow map:   0%|" in progress and "flow map: 100%|██████████| 21201/21201" in progress, progress
            assert "extractor elliptic: 100%|██████████| 1/1" in progress, progress
        assert "10 barriers on 2 islands" in text, text
    elif name == "own_oscillator_equations.ipynb":
        assert "compiled plugin:" in text and "FTLE on 191 x 161 points" in text, text
    else:
        assert "elliptic_barriers" in json.dumps([o.get("data", {}) for o in outputs(notebook)])


def test_interrupting_the_kernel_stops_a_run_cleanly(tmp_path):
    from jupyter_client.manager import start_new_kernel

    manager, client = start_new_kernel(kernel_name="python3", cwd=str(tmp_path))
    try:
        client.execute_interactive("import geobarrier", timeout=60)
        # Minutes of work, with the notebook's progress bar: interrupted once the flow map has started.
        long_run = {"system": {"plugin": "duffing"}, "forcing": {"plugin": "cosine", "params": {"amplitude": 0.08}},
                    "grid": {"x": [-1.5, 1.5], "y": [-1, 1], "n": [2000, 1500]}, "time": {"t0": 0, "t1": 200},
                    "products": ["ftle"]}
        code = f"geobarrier.run({long_run!r}, out='out', progress=True)"
        msg_id = client.execute(code)
        stderr, started = "", time.monotonic()
        while "flow map:" not in stderr:
            assert time.monotonic() - started < 60, "the run never reported progress"
            try:
                message = client.get_iopub_msg(timeout=1)
            except queue.Empty:
                continue
            if message["parent_header"].get("msg_id") == msg_id and message["msg_type"] == "stream":
                stderr += message["content"]["text"]
        interrupted = time.monotonic()
        manager.interrupt_kernel()
        reply = client.get_shell_msg(timeout=60)
        assert time.monotonic() - interrupted < 30
        assert reply["parent_header"]["msg_id"] == msg_id
        assert reply["content"]["status"] == "error" and reply["content"]["ename"] == "KeyboardInterrupt", reply
        assert not (tmp_path / "out").exists()  # no file of the interrupted run
        # The kernel is alive and runs the next cell (ipykernel aborts requests that arrive right after an error,
        # as Jupyter's "stop on error" does: the cell is sent again then).
        seen = []
        small = "print(geobarrier.run(dict(" + repr(long_run) + ", grid={'x': [-1, 1], 'y': [-1, 1], 'n': [5, 5]}, " \
                "time={'t0': 0, 't1': 1})).fields.ftle.shape)"
        for _ in range(10):
            reply = client.execute_interactive(small, timeout=60,
                                               output_hook=lambda m: seen.append(m["content"].get("text", "")))
            if reply["content"]["status"] != "aborted":
                break
            time.sleep(0.5)
        assert reply["content"]["status"] == "ok" and "(5, 5)" in "".join(seen)
    finally:
        client.stop_channels()
        manager.shutdown_kernel(now=True)
