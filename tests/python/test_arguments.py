"""Arguments a user gets wrong, from Python: each raises at once, naming the argument (or the experiment's JSON path),
the value and what was expected, and writes nothing; values Python users pass as a matter of course (NumPy integers,
None for a default, a single folder, Python's spelling of a log level) work."""

import json
import math
import os

import numpy as np
import pytest

import geobarrier
from conftest import BASE, TEST_PLUGIN_DIR, base_experiment, write_json


@pytest.mark.parametrize("experiment, path, value", [
    (base_experiment(time={"t0": 0, "t1": math.nan}), "/time/t1", "nan"),
    (base_experiment(grid={"x": [np.float64("nan"), 1.5], "y": [-1, 1], "n": [11, 9]}), "/grid/x/0", "nan"),
    (base_experiment(grid={"x": np.array([-1.5, np.inf]), "y": [-1, 1], "n": [11, 9]}), "/grid/x/1", "inf"),
    (base_experiment(forcing={"plugin": "cosine", "params": {"amplitude": -math.inf}}), "/forcing/params/amplitude",
     "-inf"),
    # JSON Pointer (RFC 6901) escapes "/" as "~1" and "~" as "~0" in a key.
    (base_experiment(system={"plugin": "duffing", "params": {"a/b~c": math.nan}}), "/system/params/a~1b~0c", "nan"),
])
def test_nan_or_infinity_in_an_experiment_names_its_json_path(experiment, path, value):
    for call in (geobarrier.run, geobarrier.validate):
        with pytest.raises(geobarrier.ConfigError) as raised:
            call(experiment)
        assert raised.value.path == path
        assert str(raised.value).startswith(f"{path}: {value} is not a finite number")


def test_an_experiment_that_holds_itself_raises_config_error():
    experiment = base_experiment()
    experiment["time"]["again"] = experiment
    with pytest.raises(geobarrier.ConfigError, match="Circular reference") as raised:
        geobarrier.run(experiment)
    assert raised.value.path == "/"


def test_numpy_integers_and_none_are_thread_counts():
    one = geobarrier.run(BASE, threads=1, xarray=False).fields.ftle
    assert np.array_equal(geobarrier.run(BASE, threads=np.int64(1), xarray=False).fields.ftle, one, equal_nan=True)
    two = geobarrier.run(BASE, threads=2, xarray=False).fields.ftle
    assert np.array_equal(geobarrier.run(BASE, threads=np.int32(2), xarray=False).fields.ftle, two, equal_nan=True)
    # None as in flow_map() and barriers(): all cores, as 0 is.
    assert np.array_equal(geobarrier.run(BASE, threads=None, xarray=False).fields.ftle,
                          geobarrier.run(BASE, threads=0, xarray=False).fields.ftle, equal_nan=True)


@pytest.mark.parametrize("threads, kind", [(2.0, "float"), ("2", "str"), (True, "bool"), (np.bool_(True), "bool")])
def test_a_thread_count_of_another_type_raises_type_error(threads, kind):
    with pytest.raises(TypeError, match=f"threads: expected an int .*, got {kind}"):
        geobarrier.run(BASE, threads=threads)


@pytest.mark.parametrize("keyword, value, expected", [
    ("write", "no", "write: expected True or False or None, got str 'no'"),
    ("write", 0, "write: expected True or False or None, got int 0"),
    ("xarray", "no", "xarray: expected True or False, got str 'no'"),
    ("flow_map", "yes", "flow_map: expected True or False, got str 'yes'"),
    ("out", 5, r"out: expected a folder path \(str or os.PathLike\), got int"),
    ("out", b"folder", r"out: expected a folder path \(str or os.PathLike\), got bytes"),
])
def test_wrong_flags_and_folders_raise_type_error_and_write_nothing(tmp_path, monkeypatch, keyword, value, expected):
    # write="no" was truthy: it wrote the output folder (out/experiment in the working directory).
    monkeypatch.chdir(tmp_path)
    with pytest.raises(TypeError, match=expected):
        geobarrier.run(BASE, **{keyword: value})
    assert os.listdir(tmp_path) == []


def test_an_empty_output_folder_name_raises_value_error(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError, match='out: "" is no folder'):
        geobarrier.run(BASE, out="")
    assert os.listdir(tmp_path) == []


def test_flow_map_of_a_missing_or_unreadable_file_raises_io_error_as_without(tmp_path):
    for flow_map in (False, True):
        with pytest.raises(geobarrier.IoError, match="cannot open the experiment file"):
            geobarrier.run(tmp_path / "none.json", flow_map=flow_map)
        with pytest.raises(geobarrier.IoError, match="is a folder, not an experiment file"):
            geobarrier.run(tmp_path, flow_map=flow_map)
    # And the file itself, read: the flow map alone.
    r = geobarrier.run(write_json(tmp_path / "exp.json", base_experiment(extractors=[{"plugin": "hyperbolic"}])),
                       flow_map=True, xarray=False)
    assert set(r.fields.keys()) == {"flow_x", "flow_y", "mask"} and len(r.barriers) == 0


def test_plugins_takes_one_folder_as_a_folder():
    folder = TEST_PLUGIN_DIR / "bad-input"
    listed = geobarrier.plugins([folder])
    ours = [p["name"] for p in listed if os.path.dirname(p["file"]) == str(folder)]
    assert ours  # the folder's own plugins are there
    # A str was a list of one-letter folders ("/" among them, whose libraries were listed).
    for one in (str(folder), folder):
        assert [p["name"] for p in geobarrier.plugins(one) if os.path.dirname(p["file"]) == str(folder)] == ours
    with pytest.raises(TypeError, match="plugin_paths: expected a list of folder paths"):
        geobarrier.plugins(None)


def test_log_levels_in_any_case_and_a_clear_type_error():
    try:
        geobarrier.set_log_level("ERROR")  # Python's logging spells them so
        geobarrier.set_log_level("Warning")
        with pytest.raises(TypeError, match=r'level: expected a str \("debug", .*got int'):
            geobarrier.set_log_level(20)
        with pytest.raises(geobarrier.ConfigError, match='"loud" is not a log level'):
            geobarrier.set_log_level("loud")
    finally:
        geobarrier.set_log_level("warning")


def test_a_result_or_a_path_where_fields_belong_says_what_to_pass(tmp_path):
    pytest.importorskip("matplotlib")
    r = geobarrier.run(base_experiment(products=["ftle", "eigenvalues", "eigenvectors"]), tmp_path / "run")
    for call in (lambda f: geobarrier.barriers(f, "elliptic"), geobarrier.plot):
        with pytest.raises(TypeError, match=r"got Result \(a run's Result: pass result.fields\)"):
            call(r)
        with pytest.raises(TypeError, match=r"got str \(a path: open fields.nc with xarray.open_dataset\(path\)"):
            call(str(tmp_path / "run" / "fields.nc"))
        with pytest.raises(TypeError, match="fields: expected an xarray.Dataset .* got NoneType$"):
            call(None)


def test_a_missing_field_names_the_fields_there():
    fields = geobarrier.run(BASE, xarray=False).fields
    with pytest.raises(KeyError, match=r"no field named 'lambda1' \(fields: ftle, mask\)"):
        fields["lambda1"]
    with pytest.raises(AttributeError, match=r"no field named 'lambda1' \(fields: ftle, mask\)"):
        fields.lambda1
    assert json.loads(fields.attrs["experiment"])["grid"]["n"] == [11, 9]


def test_a_missing_figure_names_the_barriers_figures():
    barrier = geobarrier.Barrier({"kind": "hyperbolic", "extractor": "hyperbolic", "closed": False,
                                  "points": [[0, 0], [1, 0], [1, 1]], "rank": 1.0, "length": 2.0})
    assert barrier["rank"] == 1 and isinstance(barrier["rank"], int) and barrier["length"] == 2.0
    with pytest.raises(KeyError, match=r"no figure 'nosuch' \(this barrier's: rank, length\)"):
        barrier["nosuch"]


def test_flow_map_of_an_experiment_in_both_directions_says_why_not(tmp_path):
    # The core said that the experiment had no extractors (flow_map=True drops them), which it had.
    experiment = base_experiment(time={"t0": 0, "t1": 2, "directions": "both"}, extractors=[{"plugin": "hyperbolic"}])
    path = write_json(tmp_path / "both.json", experiment)
    for given, file in ((experiment, ""), (path, str(path))):
        with pytest.raises(geobarrier.ConfigError, match='flow_map=True computes the flow map of one direction, and '
                                                         '"both" asks for two') as raised:
            geobarrier.run(given, flow_map=True)
        assert (raised.value.path, raised.value.file) == ("/time/directions", file)
    one = dict(experiment, time={"t0": 0, "t1": 2, "directions": "one"})
    assert set(geobarrier.run(one, flow_map=True, xarray=False).fields.keys()) == {"flow_x", "flow_y", "mask"}
