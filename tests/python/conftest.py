"""Shared set-up of the Python module's tests: where the build put the program and the test plugins (ctest passes
them in the environment, python/CMakeLists.txt), and small experiments that run in well under a second."""

import copy
import json
import os
import pathlib
import subprocess

SOURCE_DIR = pathlib.Path(os.environ.get("GEOBARRIER_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
PROGRAM = os.environ.get("GEOBARRIER_BIN", str(SOURCE_DIR / "build" / "bin" / "geobarrier"))
TEST_PLUGIN_DIR = pathlib.Path(os.environ.get("GEOBARRIER_TEST_PLUGIN_DIR",
                                              SOURCE_DIR / "build" / "lib" / "geobarrier" / "test-plugins"))

# The bad-input battery's base experiment (tests/test_bad_input.cpp): the paper's first example on an 11 x 9 grid.
BASE = {
    "system": {"plugin": "duffing", "params": {"alpha": 1, "beta": 1, "delta": 0}},
    "forcing": {"plugin": "cosine", "params": {"amplitude": 0.08}},
    "grid": {"x": [-1.5, 1.5], "y": [-1, 1], "n": [11, 9]},
    "time": {"t0": 0, "t1": 2},
    "products": ["ftle"],
}


def base_experiment(**changes):
    experiment = copy.deepcopy(BASE)
    experiment.update(copy.deepcopy(changes))
    return experiment


def write_json(path, experiment):
    path.write_text(json.dumps(experiment, indent=2))
    return path


def run_program(*args, cwd=None):
    """The geobarrier program, as a user would run it."""
    return subprocess.run([PROGRAM, *map(str, args)], cwd=cwd, capture_output=True, text=True, timeout=600)

