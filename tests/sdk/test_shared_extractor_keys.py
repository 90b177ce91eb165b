#!/usr/bin/env python3
"""A parameter key that more than one built-in extractor takes has one type, one range and one set of choices in all
of them (issue 36: `families` was both|plus|minus in one extractor and both|eta+|eta- in another, `singular_gap` was
[0, 1] in one and [0, 0.999] in two). Reads the schemas the program validates (`geobarrier plugins --json`).
Defaults are not compared: a 0 that means "automatic" resolves differently in each extractor, and max_deviation bounds
a different quantity in each (d_g^xi1 of strainlines, d_g^eta of shearlines).

Usage: test_shared_extractor_keys.py PROGRAM
"""
import collections
import json
import subprocess
import sys

COMPARED = ("type", "min", "max", "choices", "unit")

# Differences that are meant, each with its reason; any other difference fails.
MEANT = {
    # hyperbolic: 0 = take seed_distance instead; parabolic has no seed_distance, seeds sit on grid points.
    ("seed_spacing", "min"),
    # d_g^xi1 is a curvature (1/state); d_g^eta adds the dimensionless |1 - alpha| to curvature terms.
    ("max_deviation", "unit"),
}


def differences(plugins):
    """(key, field, {extractor: value}) for every shared key whose field differs between extractors."""
    by_key = collections.defaultdict(dict)
    for plugin in plugins:
        if plugin["kind"] == "extractor":
            for param in plugin["params"]:
                by_key[param["name"]][plugin["name"]] = param
    found = []
    for key, specs in sorted(by_key.items()):
        if len(specs) < 2:
            continue
        for field in COMPARED:
            values = {name: spec.get(field) for name, spec in specs.items()}
            if len({json.dumps(v) for v in values.values()}) > 1:
                found.append((key, field, values))
    return found, by_key


def main():
    listing = json.loads(subprocess.run([sys.argv[1], "plugins", "--json"], check=True, capture_output=True,
                                        text=True).stdout)
    found, by_key = differences(listing["plugins"])
    # The keys this test was written for must still be shared, or it would pass by comparing nothing.
    for key, extractors in (("families", {"elliptic", "parabolic"}),
                            ("singular_gap", {"elliptic", "hyperbolic", "parabolic"})):
        if not extractors <= set(by_key.get(key, {})):
            print(f"FAIL: {key} is no longer taken by {sorted(extractors)}: {sorted(by_key.get(key, {}))}")
            return 1
    failed = False
    for key, field, values in found:
        if (key, field) not in MEANT:
            print(f"FAIL: extractor key {key}: {field} differs: {values}")
            failed = True
    for key, field in sorted(MEANT - {(k, f) for k, f, _ in found}):
        print(f"FAIL: ({key}, {field}) is listed as a meant difference but no longer differs: drop it from MEANT")
        failed = True
    if not failed:
        print(f"{sum(len(s) > 1 for s in by_key.values())} shared extractor keys agree")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
