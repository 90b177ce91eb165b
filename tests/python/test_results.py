"""Results people use directly: barriers as objects with typed figures (counts as int), their table (pandas) equal to
barriers.json, and the matplotlib helpers (a field with its barriers over it), with xarray and without."""

import json
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import geobarrier  # noqa: E402
from conftest import SOURCE_DIR  # noqa: E402


def attractor_experiment():
    # The paper's case 2 (experiments/duffing-damped-attractor.json) on a 101 x 61 grid: about a second, with
    # barriers and candidates of the hyperbolic extractor (rank, pieces, probes: counts).
    experiment = json.loads((SOURCE_DIR / "experiments" / "duffing-damped-attractor.json").read_text())
    experiment["grid"]["n"] = [101, 61]
    return experiment


@pytest.fixture(scope="module")
def attractor(tmp_path_factory):
    out = tmp_path_factory.mktemp("attractor")
    return geobarrier.run(attractor_experiment(), out=out, threads=2), out


def test_counts_are_integers_and_measurements_floats(attractor):
    r, _ = attractor
    assert len(r.barriers) >= 1 and len(r.candidates) >= 1
    everything = list(r.barriers) + list(r.candidates)
    for b in everything:
        for name in ("rank", "pieces", "neighbour_probes", "probes_with_smaller_q"):
            assert type(b[name]) is int, (name, b[name])
        assert type(b.length) is float and b.length > 0
        assert type(b["global_minimum"]) is bool
    # rank: 1, 2, ... in order of increasing q, the barriers first, then the candidates (docs/extractors.md).
    assert [b.rank for b in everything] == list(range(1, len(everything) + 1))
    q = [b.relative_stretching for b in r.barriers]
    assert q == sorted(q)


def test_points_are_a_read_only_array(attractor):
    b = attractor[0].barriers[0]
    assert b.points.dtype == np.float64 and b.points.ndim == 2 and b.points.shape[1] == 2 and len(b) > 10
    assert np.array_equal(b.x, b.points[:, 0]) and np.array_equal(b.y, b.points[:, 1])
    with pytest.raises(ValueError):
        b.points[0, 0] = 1.0
    # The attractor lies in the grid's box.
    assert b.x.min() >= -1.8 and b.x.max() <= 1.8 and b.y.min() >= -1.2 and b.y.max() <= 1.2
    with pytest.raises(AttributeError, match="no attribute or figure 'lenght'"):
        b.lenght  # noqa: B018


def test_dataframe_equals_barriers_json(attractor):
    r, out = attractor
    written = json.loads((out / "barriers.json").read_text())
    records = written["barriers"] + written["candidates"]
    frame = r.to_dataframe(candidates=True)
    assert len(frame) == len(records)
    assert str(frame["rank"].dtype) == "int64" and str(frame["pieces"].dtype) == "int64"
    assert str(frame["length"].dtype) == "float64" and str(frame["closed"].dtype) == "bool"
    assert frame["candidate"].tolist() == [False] * len(r.barriers) + [True] * len(r.candidates)
    for (_, row), record in zip(frame.iterrows(), records):
        assert row["kind"] == record["kind"] and row["n_points"] == len(record["points"])
        for name, value in record.items():
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                assert row[name] == value, name  # 3 == 3.0: the same number, typed
    # A figure only some barriers have: NaN elsewhere (segment_relative_stretching, remainders only).
    if "segment_relative_stretching" in frame:
        has = ["segment_relative_stretching" in b.attributes for b in list(r.barriers) + list(r.candidates)]
        assert frame["segment_relative_stretching"].isna().tolist() == [not h for h in has]
    assert len(r.barriers.to_dataframe()) == len(r.barriers)


def test_integer_figures_missing_somewhere_are_nullable_integers():
    a = geobarrier.Barrier({"kind": "elliptic", "closed": True, "extractor": "e", "points": [[0, 0], [1, 0], [0, 1]],
                            "island": 1.0, "length": 3.0, "rank": math.nan})
    b = geobarrier.Barrier({"kind": "elliptic", "closed": False, "extractor": "e", "points": [[0, 0], [1, 1]],
                            "length": 2.5})
    assert type(a.island) is int and a.island == 1
    assert type(a.length) is float  # a measurement stays a float even when whole
    assert math.isnan(a.rank)  # not a whole number: left as it is
    frame = geobarrier.Barriers([a, b]).to_dataframe()
    assert str(frame["island"].dtype) == "Int64" and frame["island"][0] == 1 and frame["island"].isna()[1]
    assert frame["n_points"].tolist() == [3, 2] and frame["length"].tolist() == [3.0, 2.5]


def test_plot_draws_the_field_and_every_barrier(attractor):
    r, _ = attractor
    ax = r.plot(candidates=True)
    assert isinstance(ax, matplotlib.axes.Axes)
    mesh = ax.collections[0]
    ftle = r.fields.ftle.values
    assert mesh.get_array().shape == ftle.shape or mesh.get_array().size == ftle.size
    assert np.allclose(np.ma.filled(mesh.get_array(), np.nan).ravel(), ftle.ravel(), equal_nan=True)
    lines = ax.get_lines()
    assert len(lines) == len(r.barriers) + len(r.candidates)
    first = lines[0].get_xydata()
    assert np.array_equal(first, r.barriers[0].points)  # an open curve, drawn as it is
    assert [line.get_linestyle() for line in lines[len(r.barriers):]] == ["--"] * len(r.candidates)
    colorbar_axes = [a for a in ax.figure.axes if a is not ax]
    assert len(colorbar_axes) == 1 and colorbar_axes[0].get_ylabel() == "finite-time Lyapunov exponent"
    plt.close(ax.figure)


def test_plot_without_xarray_and_closed_barriers():
    experiment = json.loads((SOURCE_DIR / "experiments" / "duffing-kam.json").read_text())
    experiment["grid"]["n"] = [121, 71]
    experiment["extractors"][0]["params"].update(launch_points=100, poincare_iterates=2)
    plain = geobarrier.run(experiment, xarray=False, threads=2)
    assert isinstance(plain.fields, geobarrier.Fields) and plain.barriers
    assert all(type(b.island) is int and type(b.advected_points) is int for b in plain.barriers)
    fig, ax = plt.subplots()
    assert geobarrier.plot(plain.fields, plain.barriers, ax=ax, colorbar=False) is ax
    assert len(fig.axes) == 1
    for line, barrier in zip(ax.get_lines(), plain.barriers):
        drawn = line.get_xydata()
        assert barrier.closed and len(drawn) == len(barrier) + 1 and np.array_equal(drawn[-1], drawn[0])
        assert line.get_color() == "white"  # elliptic
    with pytest.raises(KeyError, match="no field named 'lambda1'"):
        geobarrier.plot(plain.fields, variable="lambda1", ax=ax)
    plt.close(fig)
