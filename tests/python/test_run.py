"""geobarrier.run from Python: the same fields as the program, bit for bit; results as xarray and as NumPy arrays;
the flow map alone; a sweep over the forcing amplitude against the exact flow map; progress; the GIL released."""

import json
import math
import os
import threading

import netCDF4
import numpy as np
import pytest
import xarray

import geobarrier
from conftest import SOURCE_DIR, base_experiment, run_program, write_json


def read_fields_nc(path):
    """fields.nc as a reader sees it: NaN where the file holds the fill value."""
    with netCDF4.Dataset(path) as nc:
        nc.set_auto_mask(False)
        out = {}
        for name, var in nc.variables.items():
            values = np.array(var[:])
            if name not in ("x", "y", "mask"):
                values[values == var.getncattr("_FillValue")] = np.nan
            out[name] = (values, {a: var.getncattr(a) for a in var.ncattrs() if a != "_FillValue"})
        return out, {a: nc.getncattr(a) for a in nc.ncattrs()}


def same_attributes(a, b):
    """Attribute dicts equal, array values (CF flag_masks) compared element by element."""
    return a.keys() == b.keys() and all(np.array_equal(np.asarray(a[k]), np.asarray(b[k])) for k in a)


def test_demo_shaped_run_from_a_file(tmp_path):
    # The README's one-liner on experiments/demo.json, with its grid made small: fields shaped (ny, nx) over the box.
    demo = json.loads((SOURCE_DIR / "experiments" / "demo.json").read_text())
    demo["grid"]["n"] = [31, 21]
    file = write_json(tmp_path / "demo.json", demo)
    r = geobarrier.run(file)
    assert isinstance(r.fields, xarray.Dataset)
    assert r.fields.ftle.shape == (21, 31)
    assert r.fields.ftle.dims == ("y", "x")
    assert r.fields.x.values[0] == -1.9 and r.fields.x.values[-1] == pytest.approx(1.9, abs=1e-15)
    assert r.fields.y.values[0] == -1.1 and r.fields.y.values[-1] == pytest.approx(1.1, abs=1e-15)
    # CF units: the model's own time scale is dimensionless "1", with the meaning in long_name.
    assert r.fields.ftle.attrs["units"] == "1" and "1/time in the model's own units" in r.fields.ftle.attrs["long_name"]
    assert r.fields.x.attrs["axis"] == "X" and r.fields.y.attrs["axis"] == "Y"
    assert set(r.fields.data_vars) == {"ftle", "lambda1", "lambda2", "xi1_x", "xi1_y", "xi2_x", "xi2_y", "mask"}
    assert r.fields.attrs["system"] == "duffing" and r.fields.attrs["forcing"] == "cosine"
    assert r.manifest["resolved"]["grid"]["n"] == [31, 21]
    # Nothing written unless asked: no output folder, no files.
    assert r.output_dir is None and r.files == []
    assert not (tmp_path / "out").exists()
    # The FTLE is log(lambda2) / (2 T) point by point.
    T = demo["time"]["t1"]
    np.testing.assert_allclose(r.fields.ftle.values, np.log(r.fields.lambda2.values) / (2 * T), rtol=1e-12)


@pytest.mark.parametrize("experiment", [
    base_experiment(grid={"x": [-1.5, 1.5], "y": [-1, 1], "n": [41, 31]}, time={"t0": 0, "t1": 6},
                    products=["ftle", "eigenvalues", "eigenvectors", "flow_map", "strain_deviation",
                              "shear_deviation_plus", "shear_deviation_minus"],
                    bounds={"x": [-1.6, 1.6], "y": [-1.2, 1.2]}),
    json.loads((SOURCE_DIR / "experiments" / "parallel-shear-jet.json").read_text()),
], ids=["duffing-every-product-with-exits", "jet-with-parabolic-barriers"])
def test_python_and_the_program_give_identical_fields_and_barriers(tmp_path, experiment):
    experiment = dict(experiment, output={"dir": "out", "plots": False})
    file = write_json(tmp_path / "exp.json", experiment)
    cli = run_program("run", file, "--out", tmp_path / "cli", "--quiet", "--threads", "2")
    assert cli.returncode == 0, cli.stderr
    expected, expected_attrs = read_fields_nc(tmp_path / "cli" / "fields.nc")

    r = geobarrier.run(experiment, threads=2)
    assert set(r.fields.variables) == set(expected)
    for name, (values, attrs) in expected.items():
        got = r.fields[name]
        assert got.dtype == values.dtype, name
        assert np.array_equal(got.values, values, equal_nan=True), name  # bit for bit, NaN where the file fills
        assert same_attributes(got.attrs, attrs), name
    assert same_attributes(r.fields.attrs, expected_attrs)
    if "bounds" in experiment:  # the case is meant to have trajectories that leave: their exit times agree too
        assert np.isfinite(r.fields["exit_time"].values).any()

    cli_barriers = json.loads((tmp_path / "cli" / "barriers.json").read_text())["barriers"] if (
        tmp_path / "cli" / "barriers.json").exists() else []
    assert len(r.barriers) == len(cli_barriers)
    for mine, theirs in zip(r.barriers, cli_barriers):
        assert mine.kind == theirs["kind"] and mine.closed == theirs["closed"]
        assert np.array_equal(mine.points, np.array(theirs["points"]).reshape(-1, 2))
    if "extractors" in experiment:
        assert r.barriers and r.barriers[0].kind == "parabolic"
        # The jet core y = 0 (experiments/parallel-shear-jet.json): a known answer, not only agreement.
        assert np.abs(r.barriers[0].points[:, 1]).max() < 1e-6


def test_writing_the_output_folder_from_python(tmp_path):
    r = geobarrier.run(base_experiment(), out=tmp_path / "out")
    assert r.output_dir == str(tmp_path / "out")
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert names == ["fields.nc", "ftle.png", "manifest.json"]
    assert json.loads((tmp_path / "out" / "manifest.json").read_text())["files"] == r.manifest["files"]
    on_disk, _ = read_fields_nc(tmp_path / "out" / "fields.nc")
    assert np.array_equal(on_disk["ftle"][0], r.fields.ftle.values, equal_nan=True)
    with pytest.raises(ValueError):
        geobarrier.run(base_experiment(), out=tmp_path / "other", write=False)


def test_numpy_results_without_xarray():
    experiment = base_experiment(products=["ftle", "eigenvalues"])
    as_xarray = geobarrier.run(experiment)
    plain = geobarrier.run(experiment, xarray=False)
    assert isinstance(plain.fields, geobarrier._fields.Fields)
    assert isinstance(plain.fields.ftle, np.ndarray) and plain.fields.ftle.shape == (9, 11)
    assert np.array_equal(plain.fields["lambda2"], as_xarray.fields.lambda2.values, equal_nan=True)
    assert np.array_equal(plain.fields.x, as_xarray.fields.x.values)
    assert plain.fields.variable_attrs["ftle"] == as_xarray.fields.ftle.attrs
    assert plain.fields.attrs == as_xarray.fields.attrs
    assert set(plain.fields) == {"ftle", "lambda1", "lambda2", "mask"}
    with pytest.raises(AttributeError, match="no field named 'xi1_x'"):
        plain.fields.xi1_x


# x'' = -x + A cos(w t) (duffing with alpha = -1, beta = 0): the flow map from t = 0 is exact,
# x(t) = (x0 - K) cos t + y0 sin t + K cos wt, y(t) = -(x0 - K) sin t + y0 cos t - K w sin wt, K = A / (1 - w^2).
def forced_harmonic(amplitude, omega=2.0, t1=5.0):
    return {
        "system": {"plugin": "duffing", "params": {"alpha": -1, "beta": 0, "delta": 0}},
        "forcing": {"plugin": "cosine", "params": {"amplitude": amplitude, "omega": omega, "phase": 0}},
        "grid": {"x": [-1, 1], "y": [-0.5, 0.5], "n": [9, 5]},
        "time": {"t0": 0, "t1": t1},
        "integrator": {"method": "dopri5", "rtol": 1e-11, "atol": 1e-12},
        "products": ["ftle"],
    }


def exact_forced_harmonic(x0, y0, amplitude, omega=2.0, t=5.0):
    k = amplitude / (1 - omega ** 2)
    return ((x0 - k) * math.cos(t) + y0 * math.sin(t) + k * math.cos(omega * t),
            -(x0 - k) * math.sin(t) + y0 * math.cos(t) - k * omega * math.sin(omega * t))


def test_a_sweep_over_the_forcing_amplitude_follows_the_exact_flow_map():
    amplitudes = np.linspace(0.0, 0.4, 5)  # NumPy values go straight into the experiment dict
    for amplitude in amplitudes:
        r = geobarrier.run(forced_harmonic(amplitude), flow_map=True)
        assert set(r.fields.data_vars) == {"flow_x", "flow_y", "mask"}  # the flow map alone
        assert r.manifest["experiment"]["forcing"]["params"]["amplitude"] == amplitude
        x0, y0 = np.meshgrid(r.fields.x.values, r.fields.y.values)
        fx, fy = exact_forced_harmonic(x0, y0, amplitude)
        np.testing.assert_allclose(r.fields.flow_x.values, fx, rtol=0, atol=1e-8)
        np.testing.assert_allclose(r.fields.flow_y.values, fy, rtol=0, atol=1e-8)
    # The flow map of a linear system is a rotation plus a shift: C = I, FTLE = 0 whatever the amplitude.
    ftle = geobarrier.run(forced_harmonic(amplitudes[-1])).fields.ftle.values
    assert np.abs(ftle).max() < 1e-9


def test_progress_is_reported_when_asked(capsys):
    calls = []
    geobarrier.run(base_experiment(grid={"x": [-1.5, 1.5], "y": [-1, 1], "n": [61, 41]}),
                   progress=lambda stage, done, total: calls.append((stage, done, total)))
    assert calls and all(stage == "flow map" for stage, _, _ in calls)
    assert calls[-1][1] == calls[-1][2] > 0  # the finished stage is always reported
    assert all(a[1] <= b[1] for a, b in zip(calls, calls[1:]))

    geobarrier.run(base_experiment(), progress=True)
    err = capsys.readouterr().err
    assert "flow map" in err and "100%" in err and err.endswith("\n")
    assert capsys.readouterr().err == ""  # and nothing when not asked
    geobarrier.run(base_experiment())
    assert capsys.readouterr().err == ""


def test_an_exception_in_the_progress_callback_stops_the_run():
    def fail(stage, done, total):
        raise ZeroDivisionError("from the callback")

    with pytest.raises(ZeroDivisionError, match="from the callback"):
        geobarrier.run(base_experiment(), progress=fail)
    geobarrier.run(base_experiment())  # the next run is unaffected


def test_the_gil_is_released_while_the_core_computes():
    # While a run computes in a thread, this thread keeps running Python: it could not if the run held the GIL.
    computing, finished = threading.Event(), threading.Event()
    results = []

    def work():
        try:
            results.append(geobarrier.run(
                base_experiment(grid={"x": [-1.5, 1.5], "y": [-1, 1], "n": [201, 151]}, time={"t0": 0, "t1": 20}),
                threads=1, progress=lambda *_: computing.set()))
        finally:
            finished.set()

    thread = threading.Thread(target=work)
    thread.start()
    assert computing.wait(timeout=300)
    ticks_while_computing = 0
    while not finished.is_set():
        ticks_while_computing += 1
    thread.join()
    assert results and results[0].fields.ftle.shape == (151, 201)
    assert ticks_while_computing > 1000


def test_concurrent_runs_from_threads_agree_with_one_run():
    experiment = base_experiment(products=["ftle", "flow_map"])
    alone = geobarrier.run(experiment, threads=1)
    results = [None] * 4

    def work(i):
        results[i] = geobarrier.run(experiment, threads=1)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        assert np.array_equal(r.fields.ftle.values, alone.fields.ftle.values, equal_nan=True)


def test_threads_setting_is_the_runs_own():
    # OpenMP's default: OMP_NUM_THREADS, else the processors this process may use.
    default = int(os.environ.get("OMP_NUM_THREADS", "0")) or len(os.sched_getaffinity(0))
    r = geobarrier.run(base_experiment(), threads=default + 1)
    assert r.manifest["threads"] == default + 1
    r = geobarrier.run(base_experiment())  # not left at default + 1 by the run before
    assert r.manifest["threads"] == default


def test_both_directions_give_a_result_per_direction_and_the_tangle(tmp_path):
    # Unforced Duffing x'' = x - x^3: the origin is a saddle whose stable (forward, repelling barriers) and unstable
    # (backward, attracting barriers) manifolds, the homoclinic loops, cross there at the angle between its
    # eigenvectors (1, 1) and (1, -1): 90 degrees. In memory, the results are those the command line writes.
    experiment = base_experiment(grid={"x": [-1.5, 1.5], "y": [-1, 1], "n": [151, 101]},
                                 time={"t0": 0, "t1": 8, "directions": "both"}, extractors=[{"plugin": "hyperbolic"}])
    del experiment["forcing"]
    r = geobarrier.run(experiment, xarray=False)
    assert isinstance(r, geobarrier.BothDirections)
    assert r.output_dir is None and r.files == []
    assert r.forward.manifest["resolved"]["time"]["t1"] == 8 and r.backward.manifest["resolved"]["time"]["t1"] == -8
    assert len(r.forward.barriers) >= 1 and len(r.backward.barriers) >= 1
    # As a Result: both directions' barriers, the repelling ones first, and the forward run's fields.
    assert [b.attributes.get("attracting", False) for b in r.barriers] == \
        [False] * len(r.forward.barriers) + [True] * len(r.backward.barriers)
    assert all(b.repelling for b in r.forward.barriers) and all(b.attracting for b in r.backward.barriers)
    assert r.fields is r.forward.fields
    # Backward time's FTLE is its own field, not the forward one again.
    assert not np.allclose(r.forward.fields.ftle, r.backward.fields.ftle)
    at_saddle = [c for c in r.crossings if math.hypot(*c["point"]) < 0.04]
    assert at_saddle and at_saddle[0]["angle_degrees"] == pytest.approx(90.0, rel=0.05)
    assert r.manifest["crossings"] == r.tangle["counts"]
    # The picture: the backward run's FTLE, every barrier of both directions, and the crossings as one line of dots.
    import matplotlib
    matplotlib.use("Agg")
    ax = r.plot(direction="backward", colorbar=False)
    assert np.allclose(np.ma.filled(ax.collections[0].get_array(), np.nan).ravel(), r.backward.fields.ftle.ravel(),
                       equal_nan=True)
    assert len(ax.get_lines()) == len(r.barriers) + 1
    assert np.array_equal(ax.get_lines()[-1].get_xydata(), [c["point"] for c in r.crossings])

    written = geobarrier.run(experiment, tmp_path / "out")
    assert {p.name for p in (tmp_path / "out").iterdir()} >= {"forward", "backward", "tangle.json", "manifest.json"}
    tangle = json.loads((tmp_path / "out" / "tangle.json").read_text())
    assert r.tangle["crossings"] == tangle["crossings"] == written.crossings
    for name in ("forward", "backward"):
        on_disk = json.loads((tmp_path / "out" / name / "barriers.json").read_text())["barriers"]
        assert [b.points.tolist() for b in getattr(r, name).barriers] == [b["points"] for b in on_disk]
