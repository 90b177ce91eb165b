"""The barrier accuracy suite (scripts/barrier_suite.py, scripts/barrier-accuracy): its scorer on constructed curves,
its ground truth against what it must satisfy, and the hyperbolic extractor against the issue's thresholds.

- Scorer: a barrier on the truth has precision 1, one moved by twice the tolerance precision 0, a truth branch
  reported in two halves counts 2 pieces, candidates are not scored, the distances are exact (brute force), and
  also-true branches (the double gyre's walls) count for precision, not for recall or pieces; agreement between
  two runs tells a moved barrier (both shares fall) from one that runs on farther (one share falls).
- Truth: flow_from, which grows the manifolds, agrees with one trajectory at a time (also where the escape
  oscillator's trajectories leave the bounds); the analytic separatrices lie on their energy levels; the unforced Duffing stable manifold grown by
  grow_branch lies on H = 0 and covers both loops; workload W's saddle orbit is a fixed point of the period map to
  1e-9 (checked by a plain integration over one period), and its grown stable manifold's points do reach the
  saddle orbit, as do the escape oscillator's above the threshold; the double gyre's orbit sits on the wall, and its walls are the stable manifolds of the corners and
  of the top wall's orbit (points on them stay on them and run into those saddles within the horizon); the Van der
  Pol cycle closes.
- End to end (QUICK cases, whose truth costs seconds: the analytic separatrices, the double gyre, the escape
  oscillator forward, grown in about 7 s, and van der Pol's cycle; the others, whose manifolds take minutes to grow the first time, with
  BARRIER_ACCURACY_ALL=1): geobarrier run on the small grid, then precision >= 0.95,
  recall >= 0.9, at most 2 pieces per branch and the rank-1 barrier on the truth, for every case expected to pass.
- Open systems: the grid edges where a run's exit_time jumps lie on the truth and cover it (van der Pol's cycle,
  backward; the escape oscillator's manifolds both ways with BARRIER_ACCURACY_ALL=1).

Run: /usr/bin/python3 -m pytest -q tests/scripts/test_barrier_accuracy.py (GEOBARRIER_BIN names the program;
default build/bin/geobarrier). Needs numpy, scipy and pytest (Debian's python3-scipy, python3-pytest).
"""
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import barrier_suite as bs  # noqa: E402

BIN = os.environ.get("GEOBARRIER_BIN", bs.DEFAULT_BIN)
QUICK = ["duffing-unforced-forward", "duffing-unforced-backward", "pendulum-unforced-forward", "double-gyre-forward",
         "escape-below-forward", "van-der-pol-backward"]
ALL = os.environ.get("BARRIER_ACCURACY_ALL") == "1"
BOX = ((-2.0, 2.0), (-1.0, 1.0))
TOL = 0.02


def doc_of(*curves, ranks=None, candidates=()):
    """A barriers.json document with the given polylines as barriers (rank 1 first)."""
    barriers = []
    for i, c in enumerate(curves):
        r = (ranks[i] if ranks else i + 1)
        barriers.append({"kind": "hyperbolic", "closed": False, "points": np.asarray(c).tolist(), "rank": r,
                         "global_minimum": r == 1})
    return {"barriers": barriers,
            "candidates": [{"kind": "hyperbolic", "closed": False, "points": np.asarray(c).tolist(),
                            "candidate": True} for c in candidates]}


def arc(n=400):
    """A half circle of radius 0.8 in BOX."""
    a = np.linspace(0, math.pi, n)
    return np.stack([0.8 * np.cos(a), 0.8 * np.sin(a)], axis=1)


def line(x0, y0, x1, y1, n=200):
    s = np.linspace(0, 1, n)[:, None]
    return np.array([x0, y0]) * (1 - s) + np.array([x1, y1]) * s


# ---------------------------------------------------------------------------------------------------------------
# The scorer.

def test_barrier_on_the_truth_scores_one():
    truth = [("arc", arc()), ("segment", line(-1.5, -0.5, 1.5, -0.5))]
    r = bs.score(doc_of(arc(97), line(-1.5, -0.5, 1.5, -0.5, 7)), truth, TOL, BOX)
    assert r["precision"] == pytest.approx(1.0)
    assert r["recall"] == pytest.approx(1.0)
    assert r["pieces_per_branch"] == {"arc": 1, "segment": 1}
    assert r["top_on_truth"] and r["passes"]


def test_barrier_moved_by_twice_the_tolerance_scores_zero():
    truth = [("segment", line(-1.5, 0.0, 1.5, 0.0))]
    r = bs.score(doc_of(line(-1.5, 2 * TOL, 1.5, 2 * TOL)), truth, TOL, BOX)
    assert r["precision"] == 0.0 and r["recall"] == 0.0
    assert r["pieces_per_branch"] == {"segment": 0}
    assert not r["top_on_truth"] and not r["passes"]


def test_agreement_tells_a_moved_barrier_from_a_longer_one():
    d = 0.02
    base = doc_of(line(0.0, 0.0, 1.0, 0.0))
    # The same curve half the distance off and running on 0.5 farther: all of the base is reproduced, a third of the
    # longer one (0.5 - d beyond the base's end) is new.
    longer = (1.0 + math.sqrt(d * d - 0.01 ** 2)) / 1.5
    assert bs.agreement(base, doc_of(line(0.0, 0.01, 1.5, 0.01)), d) == pytest.approx((1.0, longer), abs=2e-3)
    # Moved by twice the distance: neither reproduces the other.
    assert bs.agreement(base, doc_of(line(0.0, 2 * d, 1.0, 2 * d)), d) == (0.0, 0.0)
    # No barriers on one side.
    assert bs.agreement(base, {"barriers": []}, d) == (0.0, 0.0)


def test_partial_cover_measures_length_shares():
    truth = [("segment", line(-1.5, 0.0, 1.5, 0.0))]
    # A barrier along the first third of the truth, then 1.0 more off it: precision 1/2, recall 1/3.
    barrier = np.vstack([line(-1.5, 0.0, -0.5, 0.0), line(-0.5, 0.5, 0.5, 0.5)])
    r = bs.score(doc_of(barrier), truth, TOL, BOX)
    # The joint from (-0.5, 0) to (-0.5, 0.5) is 0.5 long and within TOL for its first TOL: precision ~ 1.02 / 2.5.
    assert r["precision"] == pytest.approx((1.0 + TOL) / 2.5, abs=2e-3)
    # The truth is within TOL of the barrier's end for TOL beyond it.
    assert r["recall"] == pytest.approx((1.0 + TOL) / 3.0, abs=2e-3)
    assert r["pieces_per_branch"] == {"segment": 0}


def test_two_halves_count_two_pieces():
    truth = [("arc", arc())]
    a = arc(400)
    r = bs.score(doc_of(a[:200], a[200:]), truth, TOL, BOX)
    assert r["pieces_per_branch"] == {"arc": 2}
    assert r["precision"] == pytest.approx(1.0) and r["recall"] == pytest.approx(1.0)
    # Three pieces exceed the threshold.
    r = bs.score(doc_of(a[:130], a[130:270], a[270:]), truth, TOL, BOX)
    assert r["max_pieces"] == 3 and not r["passes"]


def test_top_is_the_rank_one_barrier_and_candidates_are_not_scored():
    truth = [("arc", arc())]
    off = line(-1.5, -0.9, 1.5, -0.9)
    r = bs.score(doc_of(arc(50), off, ranks=[2, 1], candidates=[off]), truth, TOL, BOX)
    assert r["barriers"] == 2 and r["candidates"] == 1
    assert not r["top_on_truth"]
    assert r["top_share"] == 0.0
    length_arc, length_off = 0.8 * math.pi, 3.0
    assert r["precision"] == pytest.approx(length_arc / (length_arc + length_off), abs=2e-3)


def test_truth_outside_the_box_is_not_asked_for():
    truth = [("long", line(-3.0, 0.0, 3.0, 0.0))]
    r = bs.score(doc_of(line(-2.0, 0.0, 2.0, 0.0)), truth, TOL, BOX)
    assert r["recall"] == pytest.approx(1.0)
    assert r["truth_length_in_box"] == pytest.approx(4.0, abs=TOL / 4)


def test_also_true_branches_count_for_precision_not_recall():
    """A barrier on an also-true branch (Case.also: the double gyre's walls) is right but not asked for."""
    truth = [("segment", line(-1.5, 0.0, 1.5, 0.0))]
    wall = [("wall", line(-2.0, -1.0, 2.0, -1.0))]
    doc = doc_of(line(-1.5, -1.0, 1.5, -1.0), line(-1.5, 0.0, 0.0, 0.0))  # rank 1 on the wall, 3.0 + 1.5 long
    without, with_wall = bs.score(doc, truth, TOL, BOX), bs.score(doc, truth, TOL, BOX, also=wall)
    assert without["precision"] == pytest.approx(1.5 / 4.5, abs=2e-3) and not without["top_on_truth"]
    assert with_wall["precision"] == pytest.approx(1.0) and with_wall["top_on_truth"]
    assert with_wall["recall"] == without["recall"] == pytest.approx((1.5 + TOL) / 3.0, abs=2e-3)
    assert with_wall["pieces_per_branch"] == {"segment": 1}  # the wall is no branch to count pieces of


def test_growth_fractions_cut_the_truth_by_entry_time():
    pts = line(-1.5, 0.0, 1.5, 0.0, 301)
    entry = np.linspace(0.0, 10.0, 301)  # entry time grows along the branch; horizon 10
    r = bs.score(doc_of(line(-1.5, 0.0, 0.0, 0.0)), [("b", pts, entry)], TOL, BOX, horizon=10.0)
    assert r["recall"] == pytest.approx(0.5, abs=0.01)
    assert r["recall_at"]["0.5"] == pytest.approx(1.0, abs=0.01)
    assert r["recall_at"]["0.25"] == pytest.approx(1.0, abs=0.01)
    # The truth at 0.25 ends at x = -0.75: the barrier is within TOL of it up to x = -0.75 + TOL.
    assert r["precision_at"]["0.25"] == pytest.approx((0.75 + TOL) / 1.5, abs=3e-3)


def test_curve_distances_are_exact():
    rng = np.random.default_rng(3)
    curves = [arc(37), line(-1.0, -0.8, 1.2, 0.3, 5)]
    cs = bs.CurveSet(curves, 0.01)
    P = rng.uniform([-2, -1], [2, 1], size=(300, 2))

    def brute(p):
        best = math.inf
        for c in curves:
            for a, b in zip(c[:-1], c[1:]):
                u = b - a
                t = min(1.0, max(0.0, float(np.dot(p - a, u) / np.dot(u, u))))
                best = min(best, float(np.hypot(*(p - a - t * u))))
        return best
    expected = np.array([brute(p) for p in P])
    assert np.allclose(cs.distance(P), expected, atol=1e-12)


def test_clip_to_box_splits_runs():
    poly = line(-3.0, 0.0, 3.0, 0.0, 61)
    poly[30] = [0.0, 5.0]  # one point outside in the middle
    runs = bs.clip_to_box(poly, BOX)
    assert len(runs) == 2
    assert all(np.all(np.abs(r[:, 0]) <= 2.0) for r in runs)


# ---------------------------------------------------------------------------------------------------------------
# The ground truth.

def energy_duffing(p):
    return p[:, 1] ** 2 / 2 - p[:, 0] ** 2 / 2 + p[:, 0] ** 4 / 4


def test_analytic_duffing_loops_have_zero_energy():
    for _, loop in bs.duffing_loops(bs.CASES["duffing-unforced-forward"]):
        assert np.max(np.abs(energy_duffing(loop))) < 1e-12


def test_analytic_pendulum_separatrices_have_the_saddles_energy():
    branches = bs.pendulum_separatrices(bs.CASES["pendulum-unforced-forward"])
    assert len(branches) == 6
    for _, b in branches:
        assert np.max(np.abs(b[:, 1] ** 2 / 2 - np.cos(b[:, 0]) - 1.0)) < 1e-12


def test_grown_unforced_duffing_manifold_lies_on_the_loops():
    case = bs.CASES["duffing-unforced-forward"]
    system = bs.system_of(case.experiment)
    saddle = bs.find_saddle(system, [0.01, -0.01], 0.0)
    assert np.linalg.norm(saddle.point) < 1e-14
    assert saddle.stable_exponent == pytest.approx(-1.0) and saddle.unstable_exponent == pytest.approx(1.0)
    grown = []
    for sign in (1, -1):
        # Grown for 8 time units from the 0.1-ball (12.6 from rho = 1e-3): nearly once round the loop. Longer, the
        # curve would come back to the saddle closer than its start points' rounding, and its images beyond would
        # be rounding noise (a homoclinic loop is not transverse).
        poly, entry = bs.grow_branch(system, saddle, "stable", sign, 0.0, 8.0, 0.1, case.tol / 4)
        # rho = 1e-3 along the eigenvector: H = O(rho^3) there, and the flow keeps H.
        assert np.nanmax(np.abs(energy_duffing(poly))) < 1e-6
        # No gap wider than max_gap (but where the curve is broken: it came back to the saddle and split).
        assert np.nanmax(np.hypot(*(poly[1:] - poly[:-1]).T)) <= case.tol / 4 + 1e-12
        grown.append(("b", poly, entry))
    # Together they cover both analytic loops but their ends' last ~0.03 at the saddle.
    loops = bs.duffing_loops(case)
    r = bs.score(doc_of(*[p for _, p, _ in grown]), loops, case.tol, case.box)
    assert r["recall"] > 0.99 and r["precision"] > 0.999


@pytest.mark.parametrize("name", ["duffing-forced-w", "escape-below-forward"])
def test_flow_from_matches_one_trajectory_at_a_time(name):
    """flow_from (each point its own DOP853 steps, all advanced together) against solve_ivp on one point at a time at
    rtol 1e-13: points from their own start times over up to 20 time units to t0 = 0 agree to 1e-9 (chaotic
    stretching multiplies the local errors), also those that leave the escape oscillator's bounds, which stop where
    they cross them as in the stopped system."""
    case = bs.CASES[name]
    system = bs.system_of(case.experiment)
    rng = np.random.default_rng(1)
    X = rng.uniform([-1.2, -1.2], [1.6, 1.2], (40, 2))
    starts = rng.uniform(0.0, 20.0, 40)
    fast = bs.flow_from(system, X, starts, 0.0)
    # Each point takes its own steps: in chunks of 7 the same states.
    assert np.allclose(bs.flow_from(system, X, starts, 0.0, chunk=7), fast, rtol=0, atol=1e-12)
    one = np.array([bs.flow(system, [x], s, 0.0, rtol=1e-13, atol=1e-15)[0] for x, s in zip(X, starts)])
    assert np.max(np.hypot(*(fast - one).T)) < 1e-9
    if system.inside is not None:
        left = ~system.inside(one)
        assert 5 <= left.sum() < 40  # some left the bounds, backward in time
        (x0, x1), (y0, y1) = case.experiment["bounds"]["x"], case.experiment["bounds"]["y"]
        to_edge = np.min(np.abs(np.stack([fast[:, 0] - x0, fast[:, 0] - x1, fast[:, 1] - y0, fast[:, 1] - y1])),
                         axis=0)
        assert np.all(to_edge[left] < 1e-6)  # stopped on the bounds' edge


def test_workload_w_saddle_orbit_is_a_fixed_point_of_the_period_map():
    case = bs.CASES["duffing-forced-w"]
    system = bs.system_of(case.experiment)
    saddle = bs.find_saddle(system, case.truth_params["guess"], 0.0)
    # Without the variational equations (the saddle repels by e^{2 pi} per period: tight tolerances).
    image = bs.flow(system, [saddle.point], 0.0, 2 * math.pi, rtol=1e-13, atol=1e-15)[0]
    assert np.linalg.norm(image - saddle.point) < 1e-9
    assert saddle.residual < 1e-9
    assert np.linalg.norm(saddle.point - [-0.04, 0.0]) < 0.01  # near the linear response -(A/2) cos t
    assert saddle.stable_exponent < -0.9 and saddle.unstable_exponent > 0.9


def test_workload_w_grown_stable_manifold_reaches_the_saddle_orbit():
    case = bs.CASES["duffing-forced-w"]
    system = bs.system_of(case.experiment)
    saddle = bs.find_saddle(system, case.truth_params["guess"], 0.0)
    poly, entry = bs.grow_branch(system, saddle, "stable", 1, 0.0, 2 * math.pi, 0.1, case.tol / 4)
    # Points that enter the 0.1-ball within one period lie within 0.1 e^{-2 pi} of the orbit two periods on, up to
    # their error transverse to the manifold times e^{4 pi}.
    chosen = poly[np.linspace(2, len(poly) - 1, 40).astype(int)]
    later = bs.flow(system, chosen, 0.0, 4 * math.pi)
    assert np.max(np.hypot(*(later - saddle.point).T)) < 0.01
    # ... while points beside the manifold (0.02 off along the unstable direction) do not.
    beside = bs.flow(system, chosen[len(chosen) // 2:][:5] + 0.02 * saddle.unstable, 0.0, 4 * math.pi)
    assert np.min(np.hypot(*(beside - saddle.point).T)) > 0.05


def test_escape_above_grown_stable_manifold_reaches_the_saddle_orbit():
    """The escape oscillator above Melnikov's threshold (the stopped system, grown with flow_from): each point of its
    stable manifold grown for one period, carried forward by one plain integration to the time at which it was
    started, lies rho = 1e-3 from the saddle orbit along its stable direction, while points 0.02 beside it along
    the unstable direction end far from it. (Forward, transverse errors grow like e^{0.95 t}: only the first period
    can be checked this way.)"""
    case = bs.CASES["escape-above-forward"]
    system = bs.system_of(case.experiment)
    saddle = bs.find_saddle(system, case.truth_params["guess"], 0.0)
    assert saddle.residual < 1e-9
    poly, entry = bs.grow_branch(system, saddle, "stable", 1, 0.0, system.period, 0.1, case.tol / 4)
    linear = math.log(0.1 / 1e-3) / abs(saddle.stable_exponent)  # the time from rho to the 0.1-ball
    orbit = bs.SaddleOrbit(system, saddle, "stable")
    outside = np.nonzero(entry >= 0)[0]  # points started outside the ball, not on the straight head
    for i in outside[np.linspace(0, len(outside) - 1, 8).astype(int)]:
        start = entry[i] + linear
        p, v = orbit.at(start)
        x = bs.flow(system, [poly[i]], 0.0, start, rtol=1e-13, atol=1e-15)[0]
        assert np.hypot(*(x - p[0])) == pytest.approx(1e-3, abs=1e-8)
        assert np.dot(x - p[0], v[0]) == pytest.approx(1e-3, abs=1e-8)
        beside = bs.flow(system, [poly[i] + 0.02 * saddle.unstable], 0.0, start, rtol=1e-13, atol=1e-15)[0]
        assert np.hypot(*(beside - p[0])) > 0.5


def test_double_gyre_orbit_sits_on_the_wall():
    case = bs.CASES["double-gyre-forward"]
    system = bs.system_of(case.experiment)
    guess = bs.wall_fixed_point(system, 0.0, *case.truth_params["wall_bracket"])
    saddle = bs.find_saddle(system, guess, 0.0)
    assert saddle.point[1] == 0.0 and 0.9 < saddle.point[0] < 1.3
    # The orbit repels along the wall by e^{9.9} per period: the plain check needs the tightest tolerances.
    image = bs.flow(system, [saddle.point], 0.0, 10.0, rtol=1e-13, atol=1e-15)[0]
    assert np.linalg.norm(image - saddle.point) < 1e-9
    assert abs(saddle.stable[0]) < 1e-9  # the stable direction is normal to the invariant wall


def test_double_gyre_walls_are_stable_manifolds():
    """Each wall segment of double_gyre_walls, checked by plain integration at tight tolerances: points on it stay on
    the wall and are within the reach-ball of the saddle the segment names after the horizon; the velocity along the
    walls has the signs the stream function gives; and the segments cover the walls but for the points next to the
    saddles they leave."""
    case = bs.CASES["double-gyre-forward"]
    system = bs.system_of(case.experiment)
    horizon, reach = case.horizon, case.truth_params["reach"]
    walls = bs.double_gyre_walls(case)
    assert len(walls) == 6
    top = walls[4][1][-1]  # the top segments end at the top wall's orbit at t0
    assert top[1] == 1.0 and 0.8 < top[0] < 1.0
    top_later = bs.flow(system, [top], 0.0, horizon, rtol=1e-13, atol=1e-15)[0]
    targets = [(0.0, 0.0), (2.0, 0.0), (0.0, 1.0), (2.0, 1.0), tuple(top_later), tuple(top_later)]
    times = np.linspace(0.0, horizon, 31)
    wall_lengths = {}
    for (name, poly, entry), target in zip(walls, targets):
        assert not np.isnan(poly).any() and np.all(entry <= horizon)
        # Away from the upstream end (there points leave the saddle they start at slowly) and the downstream one.
        chosen = poly[np.linspace(len(poly) // 20, len(poly) - 2, 8).astype(int)]
        fixed = 1 if np.ptp(poly[:, 1]) == 0.0 else 0  # the coordinate constant along the wall
        path = [chosen]
        for a, b in zip(times[:-1], times[1:]):
            path.append(bs.flow(system, path[-1], a, b, rtol=1e-12, atol=1e-14))
        path = np.array(path)  # time, point, coordinate
        assert np.max(np.abs(path[:, :, fixed] - poly[0, fixed])) < 1e-9, name
        # Not monotonically: the bottom and top orbits swing between x = 0.89 and 1.11 over a period, so a point
        # between runs one way, then the other, before it leaves them behind.
        assert np.all(np.hypot(*(path[-1] - np.array(target)).T) < reach), name
        wall = name.split(":")[0].replace(" left of its orbit", "").replace(" right of its orbit", "")
        wall_lengths[wall] = wall_lengths.get(wall, 0.0) + bs.polyline_length(poly)
    # Each wall's segments cover it but for a point spacing (tol / 4) at each saddle they leave.
    assert wall_lengths["bottom wall"] == pytest.approx(2.0, abs=2 * case.tol / 4 + 1e-9)
    assert wall_lengths["top wall"] == pytest.approx(2.0, abs=2 * case.tol / 4 + 1e-9)
    assert wall_lengths["left wall"] == pytest.approx(1.0, abs=case.tol / 4 + 1e-9)
    assert wall_lengths["right wall"] == pytest.approx(1.0, abs=case.tol / 4 + 1e-9)
    # The signs from psi = A sin(pi g) sin(pi y) over a period: along y = 0, u = -pi A sin(pi g) < 0 where g < 1 and
    # > 0 where g > 1 (g = 1 between x = 3 - sqrt(5) and sqrt(5) - 1 as sin(omega t) swings); along y = 1 the
    # opposite; along x = 0 and x = 2, v > 0.
    for t in np.linspace(0.0, 10.0, 9):
        bottom = system.rhs(t, np.array([[x, 0.0] for x in (0.3, 0.7, 1.3, 1.7)]))[:, 0]
        top_wall = system.rhs(t, np.array([[x, 1.0] for x in (0.3, 0.7, 1.3, 1.7)]))[:, 0]
        assert np.all(bottom * [-1, -1, 1, 1] > 0) and np.all(top_wall * [1, 1, -1, -1] > 0)
        side = system.rhs(t, np.array([[0.0, y] for y in (0.1, 0.5, 0.9)] + [[2.0, y] for y in (0.1, 0.5, 0.9)]))
        assert np.all(side[:, 1] > 0)


def test_van_der_pol_cycle_closes():
    case = bs.CASES["van-der-pol-backward"]
    (_, cyc), = bs.limit_cycle(case)
    assert np.linalg.norm(cyc[0] - cyc[-1]) == 0.0
    assert 1.9 < np.max(cyc[:, 0]) < 2.1  # mu = 1: amplitude about 2.01
    assert len(bs.clip_to_box(cyc, case.box)) == 1


def test_equations_systems_evaluate_their_text():
    """An equations experiment's Python truth reads the rhs text itself: the damped Duffing written as equations
    equals the suite's hand-written Duffing, value and Jacobian."""
    exp = json.load(open(os.path.join(bs.ROOT, "experiments", "duffing-damped-attractor-equations.json")))
    mine, theirs = bs.plain_system_of(exp), bs.duffing(delta=0.15, forcing=exp["forcing"])
    X = np.array([[0.3, -0.2], [-1.1, 0.7], [1.5, 1.0]])
    for t in (0.0, 1.3):
        assert np.allclose(mine.rhs(t, X), theirs.rhs(t, X), rtol=1e-14, atol=1e-14)
        assert np.allclose(mine.jac(t, X[1]), theirs.jac(t, X[1]), atol=1e-8)


def test_escape_saddle_orbit_and_the_stopped_box():
    """The escape oscillator's hilltop orbit is a saddle fixed point of the period map near x = 1; the system the
    truth uses (stopped outside the bounds) is the system inside them and still outside them."""
    case = bs.CASES["escape-below-forward"]
    system = bs.system_of(case.experiment)
    saddle = bs.find_saddle(system, case.truth_params["guess"], 0.0)
    assert saddle.residual < 1e-9
    assert abs(saddle.point[0] - 0.97) < 0.01 and abs(saddle.point[1]) < 0.01
    assert saddle.stable_exponent < 0 < saddle.unstable_exponent
    plain = bs.plain_system_of(case.experiment)
    inside, outside = np.array([[0.5, 0.5]]), np.array([[5.0, 0.0]])
    assert np.array_equal(system.rhs(0.7, inside), plain.rhs(0.7, inside))
    assert np.array_equal(system.rhs(0.7, outside), np.zeros((1, 2)))


# ---------------------------------------------------------------------------------------------------------------
# End to end: the extractor against the thresholds.

def end_to_end_cases():
    out = []
    for name, case in bs.CASES.items():
        if not case.expected_to_pass:
            continue
        marks = [] if name in QUICK or ALL else [pytest.mark.skip(reason="truth takes minutes to grow the first "
                                                                         "time; BARRIER_ACCURACY_ALL=1 runs it")]
        out.append(pytest.param(name, marks=marks, id=name))
    return out


@pytest.mark.parametrize("name", end_to_end_cases())
def test_extractor_meets_the_thresholds(name, tmp_path):
    if not os.access(BIN, os.X_OK):
        pytest.skip(f"no geobarrier program at {BIN}")
    case = bs.CASES[name]
    r = bs.evaluate(case, BIN, "small", str(tmp_path))
    summary = bs.table_row(r)
    assert r["precision"] >= bs.THRESHOLDS["precision"], summary
    assert r["recall"] >= bs.THRESHOLDS["recall"], summary
    assert r["max_pieces"] <= bs.THRESHOLDS["pieces"], summary
    assert r["top_on_truth"], summary


def test_double_gyre_on_a_finer_grid_keeps_the_interior_barrier(tmp_path):
    """The double gyre on 451 x 226 (its small grid x 1.5, a refinement of the suite): the part of a candidate left
    once its interior run is covered ran along the bottom and left walls, which the experiment does not declare
    invariant; its q, small along a wall, ranked it first and pushed the stable manifold below min_strength (one
    barrier, 2.2 units along the walls, recall 0.007). A remainder is now held to the wall test on its own: the one
    barrier is the interior manifold, scored without the walls (measured: precision 1.000, recall 0.789)."""
    if not os.access(BIN, os.X_OK):
        pytest.skip(f"no geobarrier program at {BIN}")
    case = bs.CASES["double-gyre-forward"]
    r = bs.evaluate(case, BIN, "451,226", str(tmp_path))
    with open(os.path.join(r["folder"], "run", "barriers.json")) as f:
        doc = json.load(f)
    interior = bs.score(doc, bs.truth_full(case), case.tol, case.box, case.horizon)  # the walls not counted
    assert interior["top_on_truth"], bs.table_row(r)
    assert interior["precision"] >= bs.THRESHOLDS["precision"], bs.table_row(r)
    assert interior["recall"] >= 0.75, bs.table_row(r)


@pytest.mark.parametrize("grid", ["301,151", "401,201"])
def test_double_gyre_barrier_runs_on_to_the_orbit(grid, tmp_path):
    """The double gyre on its suite grids: the best barrier's strainline runs to max_length (4 box diagonals from its
    seed) 0.4-0.6 above the bottom wall's orbit, and the stem below, on the stable manifold, was only the last part of
    longer candidates, too short a part of them to be a remainder. Where a barrier's strainline ran out, that part is
    joined to it: the truth grown for |T| / 4 from the orbit (the stem and the first turn) is covered (measured: 0.98
    on 301 x 151, 0.84 on 401 x 201; 0.51 and 0.32 before), and precision stays at the thresholds."""
    if not os.access(BIN, os.X_OK):
        pytest.skip(f"no geobarrier program at {BIN}")
    case = bs.CASES["double-gyre-forward"]
    r = bs.evaluate(case, BIN, grid, str(tmp_path))
    assert r["recall_at"]["0.25"] >= 0.8, bs.table_row(r)
    assert r["precision"] >= bs.THRESHOLDS["precision"], bs.table_row(r)
    assert r["top_on_truth"] and r["max_pieces"] == 1, bs.table_row(r)


@pytest.mark.skipif(not ALL, reason="the escape truth takes minutes to grow the first time; BARRIER_ACCURACY_ALL=1 "
                    "runs it")
def test_grown_manifolds_of_the_escape_oscillator_meet_the_thresholds(tmp_path):
    """Both directions with grow_periods 2 (experiments/escape-oscillator.json's system, 281 x 241): the grown
    repelling and attracting barriers (the barriers and their images over one and two periods) against the stable
    and unstable manifolds grown with SciPy. The attracting barriers alone cover 0.61 of the unstable manifold within
    the horizon's reach; grown, all of it."""
    if not os.access(BIN, os.X_OK):
        pytest.skip(f"no geobarrier program at {BIN}")
    forward = bs.CASES["escape-below-forward"]
    exp = bs.case_experiment(forward, (281, 241), str(tmp_path / "out"))
    exp["time"].update({"directions": "both", "period": 2 * math.pi / 0.85, "grow_periods": 2})
    with open(tmp_path / "exp.json", "w") as f:
        json.dump(exp, f)
    subprocess.run([BIN, "run", str(tmp_path / "exp.json"), "--quiet"], check=True)
    with open(tmp_path / "out" / "tangle.json") as f:
        grown = json.load(f)["grown"]
    for case_name, key in (("escape-below-forward", "repelling_pieces"), ("escape-below-backward",
                                                                          "attracting_pieces")):
        case = bs.CASES[case_name]
        doc = {"barriers": [{"kind": "hyperbolic", "closed": False, "points": p["points"], "rank": i + 1,
                             "global_minimum": i == 0} for i, p in enumerate(grown[key])]}
        r = bs.score(doc, bs.truth_full(case), case.tol, case.box, horizon=case.horizon)
        assert r["precision"] >= bs.THRESHOLDS["precision"], (case_name, r["precision"], r["recall"])
        assert r["recall"] >= bs.THRESHOLDS["recall"], (case_name, r["precision"], r["recall"])


@pytest.mark.skipif(not ALL, reason="the escape truth takes minutes to grow the first time; BARRIER_ACCURACY_ALL=1 "
                    "runs it")
def test_escape_above_backward_on_the_full_grid_meets_the_thresholds(tmp_path):
    """The escape oscillator above the threshold, backward, on its full grid (561 x 481): the unstable manifold's
    left branch in two pieces. A third, an exit-time piece 0.45 long in a sliver of the captured set, 160 times less
    contracted than the best barrier and covering nothing the others did not (recall 0.972 with or without it), was a
    barrier while exit-time pieces near a jump were exempt from step 8; only those on a jump are (measured: precision
    0.998, recall 0.972, 2 pieces)."""
    if not os.access(BIN, os.X_OK):
        pytest.skip(f"no geobarrier program at {BIN}")
    r = bs.evaluate(bs.CASES["escape-above-backward"], BIN, "full", str(tmp_path))
    summary = bs.table_row(r)
    assert r["precision"] >= bs.THRESHOLDS["precision"], summary
    assert r["recall"] >= bs.THRESHOLDS["recall"], summary
    assert r["max_pieces"] <= bs.THRESHOLDS["pieces"], summary
    assert r["top_on_truth"], summary


@pytest.mark.skipif(not ALL, reason="the tangles' truth takes minutes to grow the first time; BARRIER_ACCURACY_ALL=1 "
                    "runs it")
@pytest.mark.parametrize("name", ["duffing-forced-w", "duffing-damped-attractor", "escape-above-forward",
                                  "escape-above-backward"])
def test_grown_tangles_meet_precision_and_recall(name, tmp_path):
    """Workload W's stable manifold and the damped attractor (301 x 201), the escape oscillator's manifolds above
    Melnikov's threshold (281 x 241): one run's barriers cover only bundles of the tangle's strands (recall 0.68,
    0.62 and 0.845 forward, the cases' reasons), while the barriers grown over one forcing period
    (barrier_suite.grown) lie on the manifold and cover it to the issue's thresholds (measured: precision 0.997,
    1.000, 0.999 and 0.978, recall 0.921, 0.936, 0.992 and 0.999)."""
    if not os.access(BIN, os.X_OK):
        pytest.skip(f"no geobarrier program at {BIN}")
    g = bs.grown(bs.CASES[name], 1, BIN, "small", str(tmp_path))
    assert g["curves"] > 0
    assert g["precision"] >= bs.THRESHOLDS["precision"], g
    assert g["recall"] >= bs.THRESHOLDS["recall"], g


def test_grown_needs_a_periodic_system():
    assert bs.grown(bs.CASES["duffing-unforced-forward"], 1) is None


def exit_edges_of(case_name, tmp_path):
    """geobarrier run of a suite case (small grid) and barrier_suite.exit_time_edges of its fields.nc."""
    case = bs.CASES[case_name]
    exp = bs.case_experiment(case, list(case.small), str(tmp_path / case_name))
    with open(tmp_path / f"{case_name}.json", "w") as f:
        json.dump(exp, f)
    subprocess.run([BIN, "run", str(tmp_path / f"{case_name}.json"), "--quiet"], check=True)
    return bs.exit_time_edges(str(tmp_path / case_name / "fields.nc"), bs.truth_full(case), case.tol, case.box)


def test_exit_time_jumps_on_the_van_der_pol_cycle(tmp_path):
    """Backward time, bounds whose exits stop: inside the limit cycle the backward trajectories converge to the origin
    and never leave, outside they leave, so the exit time jumps from finite to never across the cycle (the
    independent truth, a long SciPy trajectory): every jump lies on it and together they cover it."""
    if not os.access(BIN, os.X_OK):
        pytest.skip(f"no geobarrier program at {BIN}")
    edges = exit_edges_of("van-der-pol-backward", tmp_path)
    assert edges["edges"] > 0
    assert edges["on_truth"] >= 0.95, edges
    assert edges["truth_covered"] >= 0.95, edges


@pytest.mark.skipif(not ALL, reason="the escape truth takes minutes to grow the first time; BARRIER_ACCURACY_ALL=1 "
                    "runs it")
@pytest.mark.parametrize("name", ["escape-below-forward", "escape-below-backward", "escape-above-backward"])
def test_exit_time_jumps_on_the_escape_manifolds(name, tmp_path):
    """The escape oscillator (281 x 241): the exit time jumps across the stable (forward) and unstable (backward)
    manifold of the hilltop's saddle orbit grown with SciPy, where trajectories on either side leave over the hilltop
    one turn apart; the jumps lie on the manifold and cover it, also the far part of the unstable one that the
    hyperbolic barriers miss. Above the threshold backward too (0.966 on it, covering 0.993); forward there the
    jumps lie on the tangle (1.000) but cover 0.924 of it, so it is not asserted."""
    if not os.access(BIN, os.X_OK):
        pytest.skip(f"no geobarrier program at {BIN}")
    edges = exit_edges_of(name, tmp_path)
    assert edges["on_truth"] >= 0.95, edges
    assert edges["truth_covered"] >= 0.95, edges
