"""scripts/extractor-cost: what its table says, from runs with known figures (no program is run).

A run's CPU ratio is the extractor's CPU seconds over the flow map's; the row shows the run with the least extractor
CPU and, beside it, the lowest and highest ratio of all runs; the commit is the manifest's, shortened, with its
"-dirty" mark; the builds' barriers lists are compared list for list.

Run by ctest (tests/CMakeLists.txt) or directly: /usr/bin/python3 tests/scripts/test_extractor_cost.py
"""
import json
import math
import os
import tempfile
import unittest

from script_module import load_script  # tests/scripts, this test's own folder


ec = load_script("extractor-cost", "extractor_cost")


def run(flow_cpu, extractor_cpu, flow_wall=1.0, extractor_wall=0.4):
    """A run as run_case returns it, with the fields table_cells reads."""
    return {"cpu": {"flow map": flow_cpu, "extractor hyperbolic": extractor_cpu},
            "wall": {"flow map": flow_wall, "extractor hyperbolic": extractor_wall}, "points": 7166075,
            "minor_faults": 84500, "max_rss_mib": 316.9}


class CpuRatio(unittest.TestCase):
    def test_extractor_over_flow_map(self):
        self.assertAlmostEqual(ec.cpu_ratio(run(1.6, 0.8)), 0.5, places=15)

    def test_no_flow_map_is_nan(self):
        self.assertTrue(math.isnan(ec.cpu_ratio(run(0.0, 0.8))))


class CommitOf(unittest.TestCase):
    def test_short_commit(self):
        manifest = {"provenance": {"build": {"commit": "dd242c2164c4a5fe2b34e7f5165144a58bfc22ba"}}}
        self.assertEqual(ec.commit_of(manifest), "dd242c2")

    def test_dirty_mark_kept(self):
        manifest = {"provenance": {"build": {"commit": "dd242c2164c4a5fe2b34e7f5165144a58bfc22ba-dirty"}}}
        self.assertEqual(ec.commit_of(manifest), "dd242c2-dirty")

    def test_no_provenance(self):
        self.assertEqual(ec.commit_of({}), "?")


class TableCells(unittest.TestCase):
    def test_row_and_spread(self):
        r = run(1.70, 0.80, 1.75, 0.70)
        r["cpu_ratios"] = sorted([0.80 / 1.70, 0.85 / 1.70, 0.83 / 1.66])
        cells = [c.strip() for c in ec.table_cells(r).split("|")]
        # flow map CPU, extractor CPU, ratio 0.80 / 1.70 = 0.47, all runs 0.47-0.50, walls, ratio 0.40, 7.17 M
        # points, 85 k faults (84.5 k rounds to even), 317 MiB, met on CPU and wall.
        self.assertEqual(cells[:11], ["1.70", "0.80", "0.47", "0.47–0.50", "1.75", "0.70", "0.40", "7.17 M", "84 k",
                                      "317", "yes"])

    def test_one_run_one_figure(self):
        r = run(1.0, 0.6)
        r["cpu_ratios"] = [0.6]
        cells = [c.strip() for c in ec.table_cells(r).split("|")]
        self.assertEqual(cells[2:4], ["0.60", "0.60"])
        self.assertEqual(cells[10], "wall only")  # CPU 0.6 > 0.5, wall 0.4 <= 0.5


class SameBarriers(unittest.TestCase):
    def write(self, out, label, barriers):
        folder = os.path.join(out, "case", label, "run")
        os.makedirs(folder)
        with open(os.path.join(folder, "barriers.json"), "w") as f:
            json.dump({"barriers": barriers, "candidates": [label]}, f)

    def test_lists_compared_not_files(self):
        with tempfile.TemporaryDirectory() as out:
            self.write(out, "native", [{"q": 0.5, "xy": [0, 1]}])
            self.write(out, "v3", [{"q": 0.5, "xy": [0, 1]}])
            self.assertTrue(ec.same_barriers(out, "case", [("native", "a"), ("v3", "b")]))

    def test_differing_lists(self):
        with tempfile.TemporaryDirectory() as out:
            self.write(out, "native", [{"q": 0.5, "xy": [0, 1]}])
            self.write(out, "v3", [{"q": 0.5, "xy": [0, 1.0000000000000002]}])
            self.assertFalse(ec.same_barriers(out, "case", [("native", "a"), ("v3", "b")]))


if __name__ == "__main__":
    unittest.main()
