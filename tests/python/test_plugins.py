"""geobarrier.plugins(): every built-in plugin with its parameter schema, as `geobarrier plugins --json` lists it."""

import json
import math

import geobarrier
from conftest import TEST_PLUGIN_DIR, run_program


def test_plugins_with_their_schemas_match_the_program():
    found = geobarrier.plugins()
    listed = json.loads(run_program("plugins", "--json").stdout)["plugins"]
    assert [(p["kind"], p["name"]) for p in found] == [(p["kind"], p["name"]) for p in listed]
    by_name = {(p["kind"], p["name"]): p for p in found}
    duffing = by_name[("system", "duffing")]
    params = {p["name"]: p for p in duffing["params"]}
    assert set(params) == {"alpha", "beta", "delta"}
    assert params["alpha"]["type"] == "real" and params["alpha"]["default"] == 1.0
    assert params["alpha"]["min"] == -math.inf and params["alpha"]["max"] == math.inf  # numbers, not "inf"
    assert {"cosine", "none", "sum", "ramp"} <= {p["name"] for p in found if p["kind"] == "forcing"}
    assert {"hyperbolic", "elliptic", "parabolic"} <= {p["name"] for p in found if p["kind"] == "extractor"}


def test_extra_plugin_folders_come_first():
    found = geobarrier.plugins([TEST_PLUGIN_DIR / "bad-input"])
    assert "throwing-system" in {p["name"] for p in found}
