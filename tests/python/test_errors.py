"""Bad input from Python: the bad-input battery's cases (tests/test_bad_input.cpp) raise geobarrier.ConfigError
with the JSON path in .path and in the message, or another geobarrier.Error for a computation that cannot succeed;
the interpreter survives every one, and the output folder stays empty."""

import copy
import json
import re
import time

import pytest

import geobarrier
from geobarrier import _geobarrier as _native
from conftest import BASE, TEST_PLUGIN_DIR

BAD_INPUT = TEST_PLUGIN_DIR / "bad-input"
WRONG_ABI = str(TEST_PLUGIN_DIR / "geobarrier-wrong-abi.so")
NOT_A_LIBRARY = str(TEST_PLUGIN_DIR / "not-a-plugin.so")
THROWING_ENTRY = str(BAD_INPUT / "entry-throws" / "geobarrier-entry-throws.so")


def spoiled(**changes):
    def spoil(j):
        for path, value in changes.items():
            *parents, key = path.split("/")
            node = j
            for p in parents:
                node = node[p]
            if value is DELETE:
                del node[key]
            else:
                node[key] = value
        return j
    return spoil


DELETE = object()

# (case, spoil, JSON path, parts of the message): ConfigError, as `geobarrier run` exits 2 for these.
CONFIG_CASES = [
    ("missing system", spoiled(system=DELETE), "/", ['missing required key "system"']),
    ("missing time/t1", spoiled(**{"time/t1": DELETE}), "/time", ['"t1"']),
    ("grid/n holds a string", spoiled(**{"grid/n": [11, "nine"]}), "/grid/n", ["two integers"]),
    ("t0 is a string", spoiled(**{"time/t0": "zero"}), "/time/t0", ["expected a number"]),
    ("products is a string", spoiled(products="ftle"), "/products", []),
    ("wrong type of plugin parameter", spoiled(**{"system/params/alpha": "one"}), "/system/params/alpha", []),
    ("unknown top-level key", spoiled(integrater={}), "/integrater", ['did you mean "integrator"']),
    ("unknown integrator key", spoiled(integrator={"rtoll": 1e-6}), "/integrator/rtoll", ['did you mean "rtol"']),
    ("unknown product", spoiled(products=["ftel"]), "/products/0", ['did you mean "ftle"']),
    ("nothing to compute", spoiled(products=[]), "/products", []),
    ("parameter outside its range", spoiled(system={"plugin": "pendulum", "params": {"omega0": -1.0}}),
     "/system/params/omega0", ["-1"]),
    ("t0 = t1", spoiled(**{"time/t1": 0}), "/time/t1", ["nonzero length"]),
    ("bounds exclude the grid", spoiled(bounds={"x": [5, 6], "y": [5, 6]}), "/bounds", ["holds no point of the grid"]),
    ("empty box", spoiled(**{"grid/x": [1.5, -1.5]}), "/grid/x", ["min < max"]),
    ("grid of 2 points", spoiled(**{"grid/n": [2, 9]}), "/grid/n/0", ["between 3 and 100000"]),
    ("grid beyond the memory", spoiled(**{"grid/n": [100000, 100000]}), "/grid/n", ["needs about", "available"]),
    ("rtol = 1", spoiled(integrator={"rtol": 1}), "/integrator/rtol", ["below 1"]),
    ("rk4 without a step", spoiled(integrator={"method": "rk4"}), "/integrator", ["step"]),
    ("unknown method", spoiled(integrator={"method": "rosenbrok4"}), "/integrator/method",
     ['did you mean "rosenbrock4"']),
    ("offset above 0.5", spoiled(cauchy_green={"offset": 0.7}), "/cauchy_green/offset", []),
    ("empty output folder name", spoiled(output={"dir": ""}), "/output/dir", []),
    ("plugin_paths holds a number", spoiled(plugin_paths=[3]), "/plugin_paths/0", []),
    ("unknown plugin", spoiled(**{"system/plugin": "dufing"}), "/system/plugin", ["dufing", "duffing"]),
    ("another ABI major version", spoiled(forcing={"plugin": WRONG_ABI}), "/forcing/plugin",
     ["geobarrier-wrong-abi.so", "ABI 2."]),
    ("not a shared library", spoiled(system={"plugin": NOT_A_LIBRARY}), "/system/plugin",
     ["not a loadable shared library"]),
    ("the entry function throws", spoiled(system={"plugin": THROWING_ENTRY}), "/system/plugin",
     ["deliberate failure in the plugin entry"]),
    ("rosenbrock4 without a Jacobian",
     spoiled(system={"plugin": "forced-oscillator"}, plugin_paths=[str(BAD_INPUT)],
             integrator={"method": "rosenbrock4"}), "/integrator/method", ["Jacobian"]),
]

# (case, spoil, exception class, parts of the message): a computation that fails (`geobarrier run` exits 1).
FAILURE_CASES = [
    ("the factory throws", spoiled(system={"plugin": "throwing-factory"}, plugin_paths=[str(BAD_INPUT)]),
     geobarrier.PluginError, ["deliberate failure in the factory"]),
    ("the right-hand side throws", spoiled(system={"plugin": "throwing-system"}, plugin_paths=[str(BAD_INPUT)]),
     geobarrier.PluginError, ["deliberate failure in rhs"]),
    ("a system that returns NaN", spoiled(system={"plugin": "nan-system"}, plugin_paths=[str(BAD_INPUT)],
                                          cauchy_green={"method": "auxiliary-grid"}),
     geobarrier.NumericalError, ["every one of the 99 grid points was masked", "non-finite"]),
    ("an output folder below a regular file", None, geobarrier.IoError, ["cannot create the output folder"]),
]


@pytest.mark.parametrize("case, spoil, path, parts", CONFIG_CASES, ids=[c[0] for c in CONFIG_CASES])
def test_bad_input_raises_config_error_with_the_json_path(tmp_path, case, spoil, path, parts):
    experiment = spoil(copy.deepcopy(BASE))
    for call in (lambda: geobarrier.validate(experiment), lambda: geobarrier.run(experiment, out=tmp_path / "out")):
        with pytest.raises(geobarrier.ConfigError) as raised:
            call()
        e = raised.value
        assert e.path == path
        assert str(e).startswith(path + ": ")
        for part in parts:
            assert part in str(e)
        assert isinstance(e, ValueError) and isinstance(e, geobarrier.Error)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("case, spoil, error, parts", FAILURE_CASES, ids=[c[0] for c in FAILURE_CASES])
def test_failed_computations_raise_a_geobarrier_error(tmp_path, case, spoil, error, parts):
    out = tmp_path / "out"
    experiment = copy.deepcopy(BASE)
    if spoil is None:  # the output folder case
        (tmp_path / "blocker").write_text("")
        out = tmp_path / "blocker" / "out"
    else:
        experiment = spoil(experiment)
    with pytest.raises(error) as raised:
        geobarrier.run(experiment, out=out)
    assert not isinstance(raised.value, geobarrier.ConfigError)
    for part in parts:
        assert part in str(raised.value)
    assert not out.exists() or not any(out.iterdir())


def test_malformed_files_name_the_line_and_column(tmp_path):
    cases = {
        "a missing comma": ('{\n  "system": {"plugin": "duffing"}\n  "grid": {}\n}\n', "exp.json:3:"),
        "an empty file": ("", "exp.json:1:1"),
        "a NaN literal": ('{"time": {"t0": NaN}}', "exp.json:1:"),
        "binary garbage": ("\x7fELF\x02\x01", "exp.json:1:"),
    }
    for name, (text, where) in cases.items():
        (tmp_path / "exp.json").write_text(text)
        for call in (geobarrier.validate, geobarrier.run):
            with pytest.raises(geobarrier.ConfigError) as raised:
                call(tmp_path / "exp.json")
            assert where in raised.value.path and "not valid JSON" in str(raised.value), name
    (tmp_path / "array.json").write_text("[1, 2, 3]")
    with pytest.raises(geobarrier.ConfigError, match="expected an object") as raised:
        geobarrier.run(tmp_path / "array.json")
    assert raised.value.path == "/" and raised.value.file.endswith("array.json")


def test_bad_arguments_from_python():
    with pytest.raises(geobarrier.ConfigError) as raised:  # JSON has no NaN: caught before the core sees it
        geobarrier.run(dict(BASE, time={"t0": 0, "t1": float("nan")}))
    assert raised.value.path == "/time/t1"
    with pytest.raises(TypeError):
        geobarrier.run(42)
    with pytest.raises(TypeError):
        geobarrier.run(dict(BASE, description=object()))
    with pytest.raises(ValueError):
        geobarrier.run(BASE, threads=-1)
    # The command line's cap: 100000 threads aborted the interpreter inside OpenMP (libgomp) or crashed it.
    started = time.monotonic()
    for threads in (1025, 100000):
        with pytest.raises(ValueError, match="threads must be at most 1024"):
            geobarrier.run(BASE, threads=threads)
    with pytest.raises(geobarrier.ConfigError, match="100000 worker threads asked for; give 1 to 1024"):
        _native.run(json.dumps(BASE), "", None, False, 100000, None, False)  # the binding refuses it on its own
    assert time.monotonic() - started < 1
    with pytest.raises(geobarrier.IoError, match="cannot open"):
        geobarrier.run("/nonexistent/exp.json")
    with pytest.raises(geobarrier.ConfigError):
        geobarrier.set_log_level("loud")


def test_validate_summarises_a_good_experiment():
    summary = geobarrier.validate(BASE)
    assert summary["system"] == "duffing" and summary["forcing"] == "cosine"
    assert summary["grid"] == [11, 9] and summary["products"] == ["ftle"]
    assert summary["resolved"]["system"]["params"] == {"alpha": 1.0, "beta": 1.0, "delta": 0.0}


def test_a_truncated_library_in_a_plugin_folder_raises_plugin_error(tmp_path):
    # dlopen would map its missing half and kill the interpreter with SIGBUS; it is refused before it is mapped.
    whole = (TEST_PLUGIN_DIR / "geobarrier-rigid-rotation.so").read_bytes()
    library = tmp_path / "geobarrier-rigid-rotation.so"
    library.write_bytes(whole[:len(whole) // 2])
    expected = re.escape(f"{library}: not a loadable shared library (truncated: ")
    for call in (lambda: geobarrier.plugins([tmp_path]),
                 lambda: geobarrier.validate(dict(BASE, plugin_paths=[str(tmp_path)])),
                 lambda: geobarrier.run(dict(BASE, plugin_paths=[str(tmp_path)]))):
        with pytest.raises(geobarrier.PluginError, match=expected):
            call()
