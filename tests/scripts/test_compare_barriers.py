"""scripts/compare-barriers: its distances against known answers and against a brute-force reference.

The distances must be exact however far apart the curves lie: constructed cases with known answers (parallel lines,
near and hundreds of curve sizes apart; a single point far from a curve; concentric circles; a closed curve's
closing segment; a curve against the same curve cut in two, as one barrier and as a set of curves), then a real
pair against the definition computed by brute force (every point against every segment), output line for line.

The real pair (workload_w*.json): the first four barriers of workload W (x'' = x - x^3 + 0.08 cos t, forward
T = 8 pi, 1000 x 1000, the hyperbolic extractor's defaults) and of the same run with the hyperbolic parameter
"line_step" 0.006, every 8th point of each barrier (and its last). The two barrier sets lie up to hundreds of grid
spacings apart (docs/extractor-measurements.md, "How well the hyperbolic barrier set is determined").

Run by ctest (tests/CMakeLists.txt) or directly: python3 tests/scripts/test_compare_barriers.py
"""
import contextlib
import io
import json
import math
import os
import subprocess
import sys
import tempfile
import unittest
import unittest.mock

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "scripts", "compare-barriers")

from script_module import load_script  # noqa: E402  (tests/scripts, the test's own folder)


cb = load_script("compare-barriers", "compare_barriers")


def point_segment_distance(p, a, b):
    """The distance from p to segment ab, by the textbook projection (written independently of the script)."""
    ux, uy = b[0] - a[0], b[1] - a[1]
    uu = ux * ux + uy * uy
    t = 0.0 if uu == 0 else min(1.0, max(0.0, ((p[0] - a[0]) * ux + (p[1] - a[1]) * uy) / uu))
    return math.hypot(p[0] - (a[0] + t * ux), p[1] - (a[1] + t * uy))


def segments_of(pts, closed):
    ends = list(zip(pts[:-1], pts[1:]))
    if closed and len(pts) > 2:
        ends.append((pts[-1], pts[0]))
    return ends or [(pts[0], pts[0])]


def brute_farthest(points, targets, far=0.0):
    """The contract of compare-barriers' farthest, by brute force: every point against every segment."""
    for p in points:
        far = max(far, min(point_segment_distance(p, a, b) for ends in targets for a, b in ends))
    return far


def barrier(pts, closed=False, kind="hyperbolic", **figures):
    return dict(points=[list(p) for p in pts], closed=closed, kind=kind, **figures)


def line(x0, y0, x1, y1, n):
    return [(x0 + (x1 - x0) * i / (n - 1), y0 + (y1 - y0) * i / (n - 1)) for i in range(n)]


def circle(r, n):
    return [(r * math.cos(2 * math.pi * i / n), r * math.sin(2 * math.pi * i / n)) for i in range(n)]


def loaded(barriers):
    """Barriers as compare-barriers' load gives them."""
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump({"barriers": barriers}, f)
    try:
        return cb.load(f.name)
    finally:
        os.unlink(f.name)


class KnownDistances(unittest.TestCase):
    def assertDistance(self, got, want):
        self.assertAlmostEqual(got, want, delta=1e-12 * max(1.0, abs(want)))

    def hausdorff(self, pts_a, pts_b, closed_a=False, closed_b=False):
        a, b = loaded([barrier(pts_a, closed_a), barrier(pts_b, closed_b)])
        return cb.hausdorff(a, b)

    def test_parallel_lines(self):
        # Differently sampled lines over the same x range: every vertex of each lies d from the other.
        for d in (0.37, 1e-7, 300.0):
            with self.subTest(d=d):
                self.assertDistance(self.hausdorff(line(0, 0, 1, 0, 1000), line(0, d, 1, d, 701)), d)

    def test_point_far_from_a_curve(self):
        # A one-point barrier a hundred curve sizes away: the former bucket index fell back to a scan here.
        a, b = loaded([barrier([(100.0, 50.0)]), barrier(line(0, 0, 1, 0, 500))])
        self.assertDistance(cb.farthest(a["_pts"], [b["_line"].segments]), math.hypot(99.0, 50.0))
        self.assertDistance(cb.farthest(b["_pts"], [a["_line"].segments]), math.hypot(100.0, 50.0))
        self.assertDistance(cb.hausdorff(a, b), math.hypot(100.0, 50.0))

    def test_concentric_circles(self):
        # Vertices at the same angles: each vertex's nearest point of the other polygon is the vertex on its ray
        # (the projection onto either adjacent edge falls before the edge's start), so the distance is the
        # difference of the radii, near (0.05) and far (40) apart.
        for outer in (1.05, 41.0):
            with self.subTest(outer=outer):
                self.assertDistance(self.hausdorff(circle(1.0, 2000), circle(outer, 2000), True, True), outer - 1.0)

    def test_closing_segment(self):
        square = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
        point = [(-0.1, 0.5)]
        closed, = loaded([barrier(square, closed=True)])
        open_, = loaded([barrier(square)])
        self.assertDistance(cb.farthest(point, [closed["_line"].segments]), 0.1)
        self.assertDistance(cb.farthest(point, [open_["_line"].segments]), math.hypot(0.1, 0.5))

    def test_curve_cut_in_two(self):
        # A's line against B's two halves of it, 0.01 higher: matched, the far end of A lies hypot(1, 0.01) from
        # either half; as sets of curves 0.01.
        a, b0, b1 = loaded([barrier(line(0, 0, 2, 0, 801)), barrier(line(0, 0.01, 1, 0.01, 300)),
                            barrier(line(1, 0.01, 2, 0.01, 300))])
        self.assertDistance(cb.hausdorff(a, b0), math.hypot(1.0, 0.01))
        self.assertDistance(cb.farthest(a["_pts"], [b0["_line"].segments, b1["_line"].segments]), 0.01)

    def test_nearest_vertex(self):
        # The match's stand-in measures to vertices only: a point above the middle of a two-point segment.
        a, b = loaded([barrier([(0.5, 3.0)]), barrier([(0.0, 0.0), (1.0, 0.0)])])
        self.assertDistance(cb.farthest(a["_pts"], [b["_line"].vertices]), math.hypot(0.5, 3.0))

    def test_command_line(self):
        # Lines 0.5 apart in spacings of 0.1: 5 spacings, as barriers and as sets; --max-distance decides the exit.
        with tempfile.TemporaryDirectory() as tmp:
            paths = []
            for name, y in (("a", 0.0), ("b", 0.5)):
                paths.append(os.path.join(tmp, name + ".json"))
                with open(paths[-1], "w") as f:
                    json.dump({"barriers": [barrier(line(0, y, 1, y, 400), length=1.0)]}, f)
            for limit, status in (("4.9", 1), ("5.1", 0)):
                proc = subprocess.run([sys.executable, SCRIPT, *paths, "--spacing", "0.1", "--max-distance", limit],
                                      capture_output=True, text=True)
                self.assertEqual(proc.returncode, status, proc.stderr)
                self.assertIn("max distance 5 spacings over 1 / 1 barriers (barrier to matched barrier), 5 spacings as "
                              "sets of curves; max relative figure difference 0 (-)", proc.stdout)


class RealPair(unittest.TestCase):
    A = os.path.join(HERE, "workload_w.json")
    B = os.path.join(HERE, "workload_w_line_step_0.006.json")

    def test_distances_match_brute_force(self):
        # Every pair, both ways, to segments and to vertices, and every barrier against the other file's as a set.
        A, B = cb.load(self.A), cb.load(self.B)
        for X, Y in ((A, B), (B, A)):
            for x in X:
                for y in Y:
                    want = brute_farthest(x["_pts"], [segments_of(y["_pts"], y["closed"])])
                    self.assertAlmostEqual(cb.farthest(x["_pts"], [y["_line"].segments]), want, delta=1e-12 * want)
                    want = brute_farthest(x["_pts"][::7], [[(p, p) for p in y["_pts"]]])
                    self.assertAlmostEqual(cb.farthest(x["_pts"][::7], [y["_line"].vertices]), want, delta=1e-12 * want)
                want = brute_farthest(x["_pts"], [segments_of(y["_pts"], y["closed"]) for y in Y])
                got = cb.farthest(x["_pts"], [y["_line"].segments for y in Y])
                self.assertAlmostEqual(got, want, delta=1e-12 * want)
        far = max(cb.hausdorff(x, y) for x in A for y in B)
        self.assertGreater(far / 0.0036, 100, "the pair is meant to lie hundreds of grid spacings apart")

    def test_output_matches_brute_force(self):
        # The whole printout (matches, distances, figures, summary) and the exit status, with compare-barriers'
        # farthest and with brute force in its place.
        argv = [SCRIPT, self.A, self.B, "--spacing", "0.0036", "--max-distance", "400"]
        outputs = []
        for farthest in (cb.farthest, brute_farthest_of_segments):
            out = io.StringIO()
            with contextlib.redirect_stdout(out), unittest.mock.patch.object(sys, "argv", argv), \
                    unittest.mock.patch.object(cb, "farthest", farthest):
                status = cb.main()
            outputs.append((status, out.getvalue()))
        self.assertEqual(outputs[0], outputs[1])
        self.assertEqual(outputs[0][0], 0)
        self.assertIn("max distance 366 spacings over 4 / 4 barriers", outputs[0][1])


def brute_farthest_of_segments(points, targets, far=0.0):
    """brute_farthest on compare-barriers' own Segments."""
    return brute_farthest(points, [t.ends for t in targets], far)


if __name__ == "__main__":
    unittest.main()
