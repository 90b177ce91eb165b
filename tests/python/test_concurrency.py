"""Two Python threads writing one output folder (docs/robustness.md, "One writer per folder"): before, both staged in
a folder named by the process id and one raised IoError leaving stray files. Now the second is refused with
geobarrier.IoError naming the folder while the first holds it, and the folder ends with the files of one run. The
interleaving is forced with the runner's test hook (GEOBARRIER_TEST_PAUSE_AT), not by timing."""

import hashlib
import json
import os
import threading
import time

import pytest

import geobarrier
from conftest import base_experiment


def digests(folder):
    """Every entry of the folder and its SHA-256, hidden entries included."""
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "<folder>"
            for p in sorted(folder.iterdir())}


def wait_for(path, thread):
    """Until the paused thread has reached its hook (a hang guard, not a timing assertion)."""
    for _ in range(60000):
        if path.exists():
            return
        assert thread.is_alive(), "the first run ended before it reached the hook"
        time.sleep(0.005)
    raise AssertionError("the first run never reached the hook")


@pytest.mark.parametrize("point", ["locked", "staged", "publishing"])
def test_second_thread_is_refused_and_the_folder_holds_one_run(tmp_path, monkeypatch, point):
    first_exp = base_experiment()
    second_exp = base_experiment(forcing={"plugin": "cosine", "params": {"amplitude": 0.3}})
    geobarrier.run(first_exp, tmp_path / "reference", threads=1)
    out = tmp_path / "out"
    hooks = tmp_path / "hooks"
    hooks.mkdir()
    monkeypatch.setenv("GEOBARRIER_TEST_PAUSE_AT", point)
    monkeypatch.setenv("GEOBARRIER_TEST_PAUSE_DIR", str(hooks))
    errors = []

    def first():
        try:
            geobarrier.run(first_exp, out, threads=1)
        except Exception as e:  # noqa: BLE001 (reported below)
            errors.append(e)

    thread = threading.Thread(target=first)
    thread.start()
    try:
        wait_for(hooks / f"{point}.reached", thread)
        with pytest.raises(geobarrier.IoError) as refused:
            geobarrier.run(second_exp, out, threads=1)
        message = str(refused.value)
        assert message.startswith(f"{out}: another geobarrier run (pid {os.getpid()})")
        assert "is writing into this output folder" in message and "\n" not in message
    finally:
        (hooks / f"{point}.go").write_text("go\n")
        thread.join()
    assert errors == []
    got, want = digests(out), digests(tmp_path / "reference")
    assert got.keys() == want.keys()  # no staging folder, no temporary file, no lock file
    assert got["fields.nc"] == want["fields.nc"]
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["experiment"] == json.loads((tmp_path / "reference" / "manifest.json").read_text())["experiment"]


def test_threads_into_one_folder_without_the_hook(tmp_path):
    # Eight threads at once, 25 rounds: each run is whole or refused, and the folder is always one run's.
    experiments = [base_experiment(forcing={"plugin": "cosine", "params": {"amplitude": 0.05 + 0.05 * k}})
                   for k in range(8)]
    references = {}
    for k, e in enumerate(experiments):
        geobarrier.run(e, tmp_path / f"ref-{k}", threads=1)
        references[k] = digests(tmp_path / f"ref-{k}")["fields.nc"]
    out = tmp_path / "out"
    for _ in range(25):
        outcome = {}

        def writer(k):
            try:
                geobarrier.run(experiments[k], out, threads=1)
                outcome[k] = "done"
            except geobarrier.IoError as e:
                assert "is writing into this output folder" in str(e)
                outcome[k] = "refused"

        threads = [threading.Thread(target=writer, args=(k,)) for k in range(len(experiments))]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert len(outcome) == len(experiments) and "done" in outcome.values()
        manifest = json.loads((out / "manifest.json").read_text())
        winner = next(k for k, e in enumerate(experiments)
                      if e["forcing"]["params"]["amplitude"] == manifest["experiment"]["forcing"]["params"]["amplitude"])
        assert outcome[winner] == "done"
        got = digests(out)
        assert sorted(got) == sorted(digests(tmp_path / f"ref-{winner}"))
        assert got["fields.nc"] == references[winner]
