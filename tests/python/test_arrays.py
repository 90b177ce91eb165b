"""The array functions (docs/python.md, "Arrays"): flow_map on known answers (the linear saddle, a linear 4-D
system), bit for bit the program's fields on the paper's first example, Cauchy–Green and FTLE from given gradients,
systems and forcings as objects, and a bad-input battery: every bad argument raises with its name, none crashes."""

import math
import subprocess
import sys
import textwrap
import threading

import numpy as np
import pytest

import geobarrier
from conftest import TEST_PLUGIN_DIR, base_experiment, run_program, write_json
from test_run import read_fields_nc

T = 8 * math.pi


def duffing():
    return geobarrier.System("duffing", alpha=1, beta=1, delta=0), geobarrier.Forcing("cosine", amplitude=0.08)


def grid_points(x, y):
    """The grid's points in the program's order: row by row (y outer, x inner)."""
    xx, yy = np.meshgrid(x, y)
    return np.column_stack([xx.ravel(), yy.ravel()])


# --- known answers ---

@pytest.mark.parametrize("t1", [2.0, -1.5])
def test_linear_saddle_final_states_and_gradient_are_exact(t1):
    saddle = geobarrier.System("linear-saddle", a=1.0)
    rng = np.random.default_rng(1)
    points = rng.uniform(-1, 1, size=(100, 2))
    states, DF = geobarrier.flow_map(saddle, points, 0.0, t1, derivative=True)
    assert states.shape == (100, 2) and states.dtype == np.float64 and DF.shape == (100, 2, 2)
    exact = points * [math.exp(t1), math.exp(-t1)]
    np.testing.assert_allclose(states, exact, rtol=1e-9, atol=0)
    np.testing.assert_allclose(DF, np.broadcast_to(np.diag([math.exp(t1), math.exp(-t1)]), DF.shape), rtol=1e-9,
                               atol=1e-12)
    np.testing.assert_allclose(geobarrier.ftle(DF, t1), 1.0, rtol=1e-9)
    # Without the derivative: the same states (the positions alone, to the integrator's tolerance).
    np.testing.assert_allclose(geobarrier.flow_map(saddle, points, 0.0, t1), exact, rtol=1e-9)


def test_one_state_gives_results_without_the_points_axis():
    saddle = geobarrier.System("linear-saddle", a=0.5)
    state, DF = geobarrier.flow_map(saddle, [1.0, 1.0], 0, 2, derivative=True)
    assert state.shape == (2,) and DF.shape == (2, 2)
    np.testing.assert_allclose(state, [math.e, 1 / math.e], rtol=1e-9)
    assert isinstance(geobarrier.ftle(DF, 2), float)


def test_a_four_dimensional_linear_system_has_its_analytic_gradient():
    system = geobarrier.System("linear-4d", rate=0.5, angle=0.3, plugin_paths=[TEST_PLUGIN_DIR])
    assert system.dimension == 4
    t1 = 3.0
    c, s = math.cos(0.3), math.sin(0.3)
    Q = np.array([[c, 0, -s, 0], [0, 1, 0, 0], [s, 0, c, 0], [0, 0, 0, 1]])
    rates = np.array([0.5, -0.5, 0.25, -0.25])
    exact_DF = Q @ np.diag(np.exp(rates * t1)) @ Q.T
    points = np.random.default_rng(2).uniform(-1, 1, size=(70, 4))
    states, DF = geobarrier.flow_map(system, points, 0, t1, derivative=True)
    assert states.shape == (70, 4) and DF.shape == (70, 4, 4)
    np.testing.assert_allclose(states, points @ exact_DF.T, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(DF, np.broadcast_to(exact_DF, DF.shape), rtol=1e-8, atol=1e-12)
    cg = geobarrier.cauchy_green(DF, t1)
    np.testing.assert_allclose(cg.eigenvalues, np.broadcast_to(np.sort(np.exp(2 * rates * t1)), (70, 4)), rtol=1e-8)
    np.testing.assert_allclose(cg.ftle, 0.5, rtol=1e-8)
    np.testing.assert_allclose(geobarrier.ftle(cg.C, t1, of="C"), 0.5, rtol=1e-8)


# --- the same numbers as the program ---

def test_flow_map_is_bit_for_bit_the_programs_fields_on_the_papers_first_example(tmp_path):
    experiment = base_experiment(grid={"x": [-1.9, 1.9], "y": [-1.1, 1.1], "n": [97, 53]}, time={"t0": 0, "t1": T},
                                 products=["ftle", "flow_map"])
    done = run_program("run", write_json(tmp_path / "e.json", experiment), "--out", tmp_path / "cli", "--quiet")
    assert done.returncode == 0, done.stderr
    fields, _ = read_fields_nc(tmp_path / "cli" / "fields.nc")
    points = grid_points(fields["x"][0], fields["y"][0])
    system, forcing = duffing()
    states, DF = geobarrier.flow_map(system, points, 0, T, forcing=forcing, derivative=True)
    # fields.nc holds the fill value (NaN here) where a point is masked; here none is.
    assert np.array_equal(states[:, 0], fields["flow_x"][0].ravel())
    assert np.array_equal(states[:, 1], fields["flow_y"][0].ravel())
    assert np.array_equal(geobarrier.ftle(DF, T), fields["ftle"][0].ravel())
    # The flow map alone (no variational equations) against a run of the flow_map product alone.
    alone = geobarrier.run(dict(experiment, products=["flow_map"]), xarray=False)
    states = geobarrier.flow_map(system, points, 0, T, forcing=forcing)
    assert np.array_equal(states[:, 0], alone.fields.flow_x.ravel())
    assert np.array_equal(states[:, 1], alone.fields.flow_y.ravel())


def test_random_points_are_the_runs_numbers_whatever_their_batch_mates():
    # A random point is the first point of a 3 x 3 grid starting there (grid point 0 is exactly (x_min, y_min)): its
    # run's numbers, with 8 batch mates, equal flow_map's among 500 random points.
    system, forcing = duffing()
    points = np.random.default_rng(7).uniform([-1.8, -1.2], [1.8, 1.2], size=(500, 2))
    states, DF = geobarrier.flow_map(system, points, 0, T, forcing=forcing, derivative=True)
    ftle = geobarrier.ftle(DF, T)
    for k in (0, 137, 499):
        x, y = points[k]
        r = geobarrier.run(base_experiment(grid={"x": [x, x + 0.5], "y": [y, y + 0.5], "n": [3, 3]},
                                           time={"t0": 0, "t1": T}, products=["ftle", "flow_map"]), xarray=False)
        assert r.fields.x[0] == x and r.fields.y[0] == y
        assert (r.fields.flow_x[0, 0], r.fields.flow_y[0, 0], r.fields.ftle[0, 0]) == (*states[k], ftle[k])


def test_a_four_dimensional_system_is_the_runs_numbers_on_a_slice():
    # The run integrates whole states too (the slice's fixed components as given): the same final states bit for
    # bit. Its FTLE over the slice goes through the slice's 2 x 2 view of the SVD (slice_tensor "full"), ours
    # through the SVD directly: the same to rounding.
    system = geobarrier.System("coupled-duffing")
    names = system.state_names
    experiment = {"system": {"plugin": "coupled-duffing"},
                  "grid": {"axes": names[:2], names[0]: [-1, 1], names[1]: [-0.5, 0.5], "n": [23, 17],
                           "fixed": {names[2]: 0.1, names[3]: -0.2}},
                  "time": {"t0": 0, "t1": 5}, "products": ["flow_map", "ftle"]}
    r = geobarrier.run(experiment, xarray=False)
    plane = grid_points(r.fields.x, r.fields.y)
    points = np.column_stack([plane, np.full(len(plane), 0.1), np.full(len(plane), -0.2)])
    states, DF = geobarrier.flow_map(system, points, 0, 5, derivative=True)
    assert np.array_equal(states[:, 0], r.fields.flow_x.ravel())
    assert np.array_equal(states[:, 1], r.fields.flow_y.ravel())
    np.testing.assert_allclose(geobarrier.ftle(DF, 5), r.fields.ftle.ravel(), rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("quality", ["draft", "publication"])
def test_each_quality_preset_is_the_experiments(quality):
    experiment = base_experiment(quality=quality, products=["ftle", "flow_map"])
    r = geobarrier.run(experiment, xarray=False)
    system, forcing = duffing()
    states, DF = geobarrier.flow_map(system, grid_points(r.fields.x, r.fields.y), 0, 2, forcing=forcing,
                                     derivative=True, quality=quality)
    assert np.array_equal(states[:, 0], r.fields.flow_x.ravel())
    assert np.array_equal(geobarrier.ftle(DF, 2), r.fields.ftle.ravel())


def test_results_do_not_depend_on_threads_or_on_concurrent_calls():
    system, forcing = duffing()
    points = np.random.default_rng(3).uniform(-1, 1, size=(3000, 2))
    alone = geobarrier.flow_map(system, points, 0, 10, forcing=forcing, threads=1)
    results = [None] * 3

    def work(i):
        results[i] = geobarrier.flow_map(system, points, 0, 10, forcing=forcing, threads=2)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        assert np.array_equal(r, alone)


def test_the_gil_is_released_while_the_core_integrates():
    system, forcing = duffing()
    points = np.random.default_rng(8).uniform(-1, 1, size=(100000, 2))
    finished, results = threading.Event(), []

    def work():
        try:
            results.append(geobarrier.flow_map(system, points, 0, 60, forcing=forcing, derivative=True, threads=1))
        finally:
            finished.set()

    thread = threading.Thread(target=work)
    thread.start()
    ticks = 0
    while not finished.is_set():
        ticks += 1
    thread.join()
    assert results and results[0][1].shape == (100000, 2, 2)
    assert ticks > 1000


CTRL_C = textwrap.dedent("""
    import os, signal, threading, time
    import numpy as np
    import geobarrier
    system, forcing = geobarrier.System("duffing"), geobarrier.Forcing("cosine")
    points = np.random.default_rng(0).uniform(-1, 1, size=(2000000, 2))  # minutes of work
    threading.Timer(1.0, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
    start = time.perf_counter()
    try:
        geobarrier.flow_map(system, points, 0, 500, forcing=forcing, derivative=True)
        print("finished")
    except KeyboardInterrupt:
        print("interrupted after", time.perf_counter() - start)
    print("handler restored:", signal.getsignal(signal.SIGINT) is signal.default_int_handler)
    print("next call:", geobarrier.flow_map(system, [[0.1, 0.2]], 0, 1, forcing=forcing).shape)
""")


def test_ctrl_c_stops_a_flow_map_and_the_next_call_works():
    done = subprocess.run([sys.executable, "-c", CTRL_C], capture_output=True, text=True, timeout=300)
    lines = done.stdout.splitlines()
    assert done.returncode == 0 and lines[0].startswith("interrupted after"), done.stdout + done.stderr
    assert float(lines[0].split()[-1]) < 60
    assert lines[1:] == ["handler restored: True", "next call: (1, 2)"]


def test_non_contiguous_and_integer_points_are_copied_to_float64():
    system, forcing = duffing()
    base = np.random.default_rng(4).uniform(-1, 1, size=(200, 2))
    expected = geobarrier.flow_map(system, base[::2], 0, 3, forcing=forcing)
    assert np.array_equal(geobarrier.flow_map(system, np.asfortranarray(base[::2]), 0, 3, forcing=forcing), expected)
    wide = np.zeros((100, 4))
    wide[:, ::2] = base[::2]
    assert np.array_equal(geobarrier.flow_map(system, wide[:, ::2], 0, 3, forcing=forcing), expected)
    assert np.array_equal(geobarrier.flow_map(system, np.array([[1, 0]]), 0, 3, forcing=forcing),
                          geobarrier.flow_map(system, np.array([[1.0, 0.0]]), 0, 3, forcing=forcing))
    assert geobarrier.flow_map(system, np.zeros((0, 2)), 0, 3).shape == (0, 2)


def test_masked_trajectories_are_nan_rows():
    # x' = x^2 - like blow-up: Duffing with beta = -1 escapes to infinity from far out.
    system = geobarrier.System("duffing", alpha=1, beta=-1, delta=0)
    states, DF = geobarrier.flow_map(system, [[0.0, 0.0], [5.0, 5.0]], 0, 20, derivative=True)
    assert np.all(np.isfinite(states[0])) and np.all(np.isnan(states[1])) and np.all(np.isnan(DF[1]))
    values = geobarrier.ftle(DF, 20)
    assert math.isfinite(values[0]) and math.isnan(values[1])


# --- Cauchy–Green and FTLE from given gradients ---

def test_cauchy_green_agrees_with_numpy():
    rng = np.random.default_rng(5)
    for n in (2, 3, 5):
        DF = rng.normal(size=(50, n, n))
        cg = geobarrier.cauchy_green(DF, 2.0)
        C = np.einsum("kij,kil->kjl", DF, DF)
        np.testing.assert_allclose(cg.C, C, rtol=1e-13, atol=1e-13)
        values, vectors = np.linalg.eigh(C)
        np.testing.assert_allclose(cg.eigenvalues, values, rtol=1e-9, atol=1e-12)
        # Each column is a unit eigenvector: C v = lambda v.
        np.testing.assert_allclose(np.einsum("kij,kjl->kil", C, cg.eigenvectors),
                                   cg.eigenvectors * cg.eigenvalues[:, None, :], rtol=1e-8, atol=1e-9)
        np.testing.assert_allclose(cg.ftle, np.log(values[:, -1]) / 4.0, rtol=1e-12)
        np.testing.assert_allclose(geobarrier.ftle(C, -2.0, of="C"), cg.ftle, rtol=1e-12)
        assert cg.ftle.shape == (50,) and cg.eigenvectors.shape == (50, n, n)
    single = geobarrier.cauchy_green(np.eye(2) * 2)
    assert single.C.shape == (2, 2) and single.ftle is None and np.allclose(single.eigenvalues, [4, 4])


def test_non_finite_gradients_give_nan():
    DF = np.array([np.eye(2), [[np.nan, 0], [0, 1]], [[np.inf, 0], [0, 1]]])
    values = geobarrier.ftle(DF, 1.0)
    assert values[0] == 0.0 and np.isnan(values[1:]).all()
    cg = geobarrier.cauchy_green(DF)
    assert np.isnan(cg.eigenvalues[1:]).all() and np.isnan(cg.C[1:]).all()


# --- systems and forcings ---

def test_system_and_forcing_objects_carry_their_schemas():
    system, forcing = duffing()
    listed = {(p["kind"], p["name"]): p for p in geobarrier.plugins()}
    assert system.parameters == listed[("system", "duffing")]["params"]
    assert forcing.parameters == listed[("forcing", "cosine")]["params"]
    assert system.params == {"alpha": 1.0, "beta": 1.0, "delta": 0.0}
    assert system.dimension == 2 and system.has_jacobian and system.uses_forcing and system.name == "duffing"
    assert forcing.params["amplitude"] == 0.08 and forcing.params["omega"] == 1.0
    t = np.linspace(0, 10, 7)
    np.testing.assert_allclose(forcing(t), 0.08 * np.cos(t), rtol=1e-15, atol=1e-17)
    assert forcing(0.0) == 0.08
    total = geobarrier.Forcing("sum", terms=[forcing, geobarrier.Forcing("cosine", amplitude=0.02, omega=2)])
    np.testing.assert_allclose(total(t), 0.08 * np.cos(t) + 0.02 * np.cos(2 * t), rtol=1e-14, atol=1e-16)
    assert "duffing" in repr(system) and "sum" in repr(total)


def test_a_system_written_as_equations_integrates_like_the_plugin():
    system = geobarrier.System.from_equations(["x", "y"], ["y", "a*x - x^3 + f"], {"a": 1.0})
    assert system.dimension == 2 and system.state_names == ["x", "y"] and system.params["constants"] == {"a": 1.0}
    assert [p["name"] for p in system.parameters] == ["a"]
    duffing_system, forcing = duffing()
    points = np.random.default_rng(6).uniform(-1, 1, size=(64, 2))
    ours, our_DF = geobarrier.flow_map(system, points, 0, 5, forcing=forcing, derivative=True)
    theirs, their_DF = geobarrier.flow_map(duffing_system, points, 0, 5, forcing=forcing, derivative=True)
    np.testing.assert_allclose(ours, theirs, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(our_DF, their_DF, rtol=1e-9, atol=1e-11)


def test_a_plugin_file_and_faulty_plugins_raise_or_mask_but_never_crash():
    rotation = geobarrier.System(TEST_PLUGIN_DIR / "geobarrier-rigid-rotation.so")
    assert rotation.name == "rigid-rotation" and geobarrier.flow_map(rotation, [[1.0, 0.0]], 0, 1).shape == (1, 2)
    folder = [TEST_PLUGIN_DIR / "bad-input"]
    with pytest.raises(geobarrier.PluginError, match="deliberate failure in rhs"):
        geobarrier.flow_map(geobarrier.System("throwing-system", plugin_paths=folder), np.zeros((100, 2)), 0, 1)
    with pytest.raises(geobarrier.PluginError, match="deliberate failure in the factory"):
        geobarrier.System("throwing-factory", plugin_paths=folder)
    with pytest.raises(geobarrier.ConfigError) as info:
        geobarrier.System("seven-dimensional", plugin_paths=folder)
    assert info.value.path == "name" and "dimension 7" in str(info.value)
    # NaN from the field or from the forcing: masked points, NaN rows, no exception.
    states = geobarrier.flow_map(geobarrier.System("nan-system", plugin_paths=folder), np.zeros((10, 2)), 0, 1)
    assert np.isnan(states).all()
    states = geobarrier.flow_map(geobarrier.System("forced-oscillator", plugin_paths=folder), np.zeros((10, 2)), 0, 1,
                                 forcing=geobarrier.Forcing("nan-forcing", plugin_paths=folder))
    assert np.isnan(states).all()


# --- barriers from fields computed before ---

def test_barriers_on_a_runs_fields_are_the_runs_barriers(tmp_path):
    experiment = base_experiment(grid={"x": [-1.9, 1.9], "y": [-1.1, 1.1], "n": [191, 111]},
                                 time={"t0": 0, "t1": T},
                                 products=["ftle", "eigenvalues", "eigenvectors", "strain_deviation"],
                                 extractors=[{"plugin": "elliptic"}, {"plugin": "hyperbolic"}])
    r = geobarrier.run(experiment)
    numpy_fields = geobarrier.run(experiment, xarray=False).fields
    for name in ("elliptic", "hyperbolic"):
        theirs = [b for b in r.barriers if b.extractor == name]
        their_candidates = [b for b in r.candidates if b.extractor == name]
        for fields in (r.fields, numpy_fields):
            ours, candidates = geobarrier.barriers(fields, name, candidates=True)
            assert len(ours) == len(theirs) > 0 and len(candidates) == len(their_candidates)
            for a, b in zip(list(ours) + list(candidates), theirs + their_candidates):
                assert np.array_equal(a.points, b.points) and a.to_dict() == b.to_dict()
    # fields.nc opened with xarray, against the program's barriers.json.
    import json

    import xarray

    experiment = dict(experiment, products=["ftle", "eigenvalues", "eigenvectors"],
                      extractors=[{"plugin": "elliptic", "params": {"launch_points": 300}}])
    done = run_program("run", write_json(tmp_path / "e.json", experiment), "--out", tmp_path / "cli", "--quiet")
    assert done.returncode == 0, done.stderr
    with xarray.open_dataset(tmp_path / "cli" / "fields.nc") as dataset:
        ours = geobarrier.barriers(dataset, "elliptic", launch_points=300)
    theirs = json.loads((tmp_path / "cli" / "barriers.json").read_text())["barriers"]
    assert len(ours) == len(theirs) > 0
    assert all(np.array_equal(a.points, np.array(b["points"])) for a, b in zip(ours, theirs))


def test_flow_map_cauchy_green_and_barriers_compose_into_the_runs_results():
    # Fields computed "elsewhere" (here: by the array functions), without the run's mask or experiment attribute,
    # and the system given: the same eigen-fields and the same barriers as the run, bit for bit.
    import xarray

    experiment = base_experiment(grid={"x": [-1.9, 1.9], "y": [-1.1, 1.1], "n": [191, 111]},
                                 time={"t0": 0, "t1": T}, products=["ftle", "eigenvalues", "eigenvectors"],
                                 extractors=[{"plugin": "elliptic"}])
    r = geobarrier.run(experiment)
    system, forcing = duffing()
    x, y = r.fields.x.values, r.fields.y.values
    _, DF, log_det = geobarrier.flow_map(system, grid_points(x, y), 0, T, forcing=forcing, derivative=True,
                                         log_det=True)
    cg = geobarrier.cauchy_green(DF, T, log_det=log_det)
    shape = (len(y), len(x))
    computed = {"ftle": cg.ftle, "lambda1": cg.eigenvalues[:, 0], "lambda2": cg.eigenvalues[:, 1],
                "xi1_x": cg.eigenvectors[:, 0, 0], "xi1_y": cg.eigenvectors[:, 1, 0]}
    degenerate = (r.fields.mask.values & 32) != 0  # the eigenvectors are fill values there in the run's fields
    for name, values in computed.items():
        theirs = r.fields[name].values
        same = values.reshape(shape) == theirs
        assert same[~degenerate].all() if name.startswith("xi") else same.all(), name
    # Without log_det, lambda1 comes from det DF's entries: close, not equal, where DF stretches most.
    assert not np.array_equal(geobarrier.cauchy_green(DF).eigenvalues[:, 0], cg.eigenvalues[:, 0])
    fields = xarray.Dataset({n: (("y", "x"), v.reshape(shape)) for n, v in computed.items()}, coords={"x": x, "y": y})
    ours = geobarrier.barriers(fields, "elliptic", system=system, forcing=forcing, t0=0, t1=T)
    assert len(ours) == len(r.barriers) > 0
    for a, b in zip(ours, r.barriers):
        assert np.array_equal(a.points, b.points) and a.to_dict() == b.to_dict()


# --- bad input: each argument named, no crash ---

def bad_calls():
    system, forcing = duffing()
    good = np.zeros((4, 2))
    DF = np.tile(np.eye(2), (3, 1, 1))
    fm = geobarrier.flow_map
    return [
        # (id, call, exception, the argument the message names)
        ("system-not-a-System", lambda: fm("duffing", good, 0, 1), TypeError, "system"),
        ("points-wrong-width", lambda: fm(system, np.zeros((4, 3)), 0, 1), geobarrier.ConfigError, "points"),
        ("points-3d", lambda: fm(system, np.zeros((4, 2, 2)), 0, 1), geobarrier.ConfigError, "points"),
        ("points-scalar", lambda: fm(system, 1.0, 0, 1), geobarrier.ConfigError, "points"),
        ("points-complex", lambda: fm(system, good.astype(complex), 0, 1), TypeError, "points"),
        ("points-strings", lambda: fm(system, [["a", "b"]], 0, 1), TypeError, "points"),
        ("points-objects", lambda: fm(system, np.array([[None, 1]], dtype=object), 0, 1), TypeError, "points"),
        ("points-bool", lambda: fm(system, np.ones((2, 2), dtype=bool), 0, 1), TypeError, "points"),
        ("points-ragged", lambda: fm(system, [[1.0, 2.0], [1.0]], 0, 1), (TypeError, geobarrier.ConfigError),
         "points"),
        ("points-nan", lambda: fm(system, [[0.0, np.nan]], 0, 1), geobarrier.ConfigError, "points"),
        ("points-inf", lambda: fm(system, [[np.inf, 0.0]], 0, 1), geobarrier.ConfigError, "points"),
        ("points-huge", lambda: fm(system, np.broadcast_to(np.zeros(2), (10**12, 2)), 0, 1), MemoryError, "points"),
        ("t0-nan", lambda: fm(system, good, math.nan, 1), geobarrier.ConfigError, "t0"),
        ("t1-inf", lambda: fm(system, good, 0, math.inf), geobarrier.ConfigError, "t1"),
        ("t1-equals-t0", lambda: fm(system, good, 1, 1), geobarrier.ConfigError, "t1"),
        ("t0-string", lambda: fm(system, good, "0", 1), TypeError, "t0"),
        ("t1-array", lambda: fm(system, good, 0, np.array([1.0, 2.0])), TypeError, "t1"),
        ("forcing-name", lambda: fm(system, good, 0, 1, forcing="cosine"), TypeError, "forcing"),
        ("derivative-string", lambda: fm(system, good, 0, 1, derivative="yes"), TypeError, "derivative"),
        ("quality-unknown", lambda: fm(system, good, 0, 1, quality="best"), geobarrier.ConfigError, "quality"),
        ("quality-number", lambda: fm(system, good, 0, 1, quality=2), TypeError, "quality"),
        ("threads-zero", lambda: fm(system, good, 0, 1, threads=0), geobarrier.ConfigError, "threads"),
        ("threads-huge", lambda: fm(system, good, 0, 1, threads=10**6), geobarrier.ConfigError, "threads"),
        ("threads-string", lambda: fm(system, good, 0, 1, threads="2"), TypeError, "threads"),
        ("system-unknown", lambda: geobarrier.System("dufing"), geobarrier.ConfigError, "name"),
        ("system-is-a-forcing", lambda: geobarrier.System("cosine"), geobarrier.ConfigError, "name"),
        ("system-name-int", lambda: geobarrier.System(3), TypeError, "name"),
        ("system-param-unknown", lambda: geobarrier.System("duffing", alfa=1), geobarrier.ConfigError, "alfa"),
        ("system-param-nan", lambda: geobarrier.System("duffing", alpha=math.nan), geobarrier.ConfigError, "alpha"),
        ("system-param-string", lambda: geobarrier.System("duffing", alpha="1"), geobarrier.ConfigError, "alpha"),
        ("system-plugin-file-missing", lambda: geobarrier.System("/nonexistent/libnothing.so"),
         geobarrier.ConfigError, "name"),
        ("equations-rhs-count", lambda: geobarrier.System.from_equations(["x", "y"], ["y"]), geobarrier.ConfigError,
         "rhs"),
        ("equations-syntax", lambda: geobarrier.System.from_equations(["x", "y"], ["y", "x +* 2"]),
         geobarrier.ConfigError, "rhs"),
        ("equations-constant-nan",
         lambda: geobarrier.System.from_equations(["x", "y"], ["y", "-d*x"], {"d": math.nan}),
         geobarrier.ConfigError, "/constants/d"),
        ("equations-constants-not-a-dict", lambda: geobarrier.System.from_equations(["x", "y"], ["y", "x"], 3),
         TypeError, "constants"),
        ("equations-state-not-a-list", lambda: geobarrier.System.from_equations(3, ["y", "x"]), TypeError, "state"),
        ("forcing-param-range", lambda: geobarrier.Forcing("cosine", omega=math.inf), geobarrier.ConfigError,
         "omega"),
        ("forcing-composite-without-terms", lambda: geobarrier.Forcing("sum"), geobarrier.ConfigError, "terms"),
        ("forcing-plain-with-terms", lambda: geobarrier.Forcing("cosine", terms=[forcing]), geobarrier.ConfigError,
         "terms"),
        ("forcing-term-not-a-Forcing", lambda: geobarrier.Forcing("sum", terms=["cosine"]), TypeError, "terms[0]"),
        ("forcing-terms-and-base", lambda: geobarrier.Forcing("ramp", terms=[forcing], base=forcing), ValueError,
         "base"),
        ("forcing-at-strings", lambda: forcing(["a"]), TypeError, "t"),
        ("ftle-shape", lambda: geobarrier.ftle(np.zeros((3, 2, 3)), 1), geobarrier.ConfigError, "F"),
        ("ftle-1x1", lambda: geobarrier.ftle(np.zeros((3, 1, 1)), 1), geobarrier.ConfigError, "F"),
        ("ftle-T-zero", lambda: geobarrier.ftle(DF, 0), geobarrier.ConfigError, "T"),
        ("ftle-T-nan", lambda: geobarrier.ftle(DF, math.nan), geobarrier.ConfigError, "T"),
        ("ftle-T-missing-type", lambda: geobarrier.ftle(DF, None), TypeError, "T"),
        ("ftle-of", lambda: geobarrier.ftle(DF, 1, of="G"), geobarrier.ConfigError, "of"),
        ("ftle-complex", lambda: geobarrier.ftle(DF.astype(complex), 1), TypeError, "F"),
        ("ftle-huge", lambda: geobarrier.ftle(np.broadcast_to(np.eye(2), (10**12, 2, 2)), 1), MemoryError, "F"),
        ("cauchy-green-shape", lambda: geobarrier.cauchy_green(np.zeros(4)), geobarrier.ConfigError, "DF"),
        ("cauchy-green-T-string", lambda: geobarrier.cauchy_green(DF, "1"), TypeError, "T"),
        ("barriers-fields-array", lambda: geobarrier.barriers(np.zeros((3, 3))), TypeError, "fields"),
        ("barriers-field-missing", lambda: geobarrier.barriers(run_fields(), "hyperbolic"), geobarrier.ConfigError,
         "fields"),
        ("barriers-extractor-unknown", lambda: geobarrier.barriers(run_fields(), "elliptc"), geobarrier.ConfigError,
         "extractor"),
        ("barriers-extractor-int", lambda: geobarrier.barriers(run_fields(), 3), TypeError, "extractor"),
        ("barriers-param-unknown", lambda: geobarrier.barriers(run_fields(), "elliptic", famlies=2),
         geobarrier.ConfigError, "famlies"),
        ("barriers-no-experiment", lambda: geobarrier.barriers(run_fields(attrs={}), "elliptic"),
         geobarrier.ConfigError, "system"),
        ("barriers-system-not-a-System", lambda: geobarrier.barriers(run_fields(), "elliptic", system="duffing"),
         TypeError, "system"),
        ("barriers-no-t1", lambda: geobarrier.barriers(run_fields(attrs={}), "elliptic", system=system, t0=0),
         geobarrier.ConfigError, "t1"),
        ("barriers-uneven-x", lambda: geobarrier.barriers(uneven_fields(), "elliptic", system=system, t0=0, t1=1),
         geobarrier.ConfigError, "fields"),
        ("barriers-4d-system", lambda: geobarrier.barriers(
            run_fields(), "elliptic", system=geobarrier.System("coupled-duffing"), t0=0, t1=1),
         geobarrier.ConfigError, "system"),
        ("log-det-without-derivative", lambda: fm(system, good, 0, 1, log_det=True), geobarrier.ConfigError,
         "log_det"),
        ("cauchy-green-log-det-shape", lambda: geobarrier.cauchy_green(DF, log_det=np.zeros(5)),
         geobarrier.ConfigError, "log_det"),
        ("barriers-threads", lambda: geobarrier.barriers(run_fields(), "elliptic", threads=-1),
         geobarrier.ConfigError, "threads"),
    ]


def uneven_fields():
    import xarray

    fields = run_fields()
    return xarray.Dataset({n: fields[n] for n in ("ftle", "lambda1", "lambda2", "xi1_x", "xi1_y")},
                          coords={"x": fields.x.values ** 3, "y": fields.y.values})


def run_fields(attrs=None):
    fields = geobarrier.run(base_experiment(products=["ftle", "eigenvalues", "eigenvectors"])).fields
    if attrs is not None:
        fields.attrs = attrs
    return fields


@pytest.mark.parametrize("case", bad_calls(), ids=lambda c: c[0])
def test_bad_arguments_raise_naming_the_argument(case):
    _, call, exception, argument = case
    with pytest.raises(exception) as info:
        call()
    assert argument in str(info.value), str(info.value)
    if isinstance(info.value, geobarrier.ConfigError):
        assert argument.split("[")[0] in info.value.path, info.value.path


def test_a_system_without_a_jacobian_refuses_the_derivative(tmp_path):
    # The program's bad-input battery plugin, or any system that has no Jacobian: skipped when none is built.
    no_jacobian = [p for p in geobarrier.plugins([TEST_PLUGIN_DIR])
                   if p["kind"] == "system" and not p.get("jacobian", True) and p.get("dimension") == 2]
    if not no_jacobian:
        pytest.skip("no planar system without a Jacobian is built")
    system = geobarrier.System(no_jacobian[0]["name"], plugin_paths=[TEST_PLUGIN_DIR])
    with pytest.raises(geobarrier.ConfigError) as info:
        geobarrier.flow_map(system, [[0.1, 0.1]], 0, 1, derivative=True)
    assert info.value.path == "derivative"
