#!/usr/bin/env bash
# An extractor of a third party on the extractor kit (issue 36): built out of the tree against a staged install with
# geobarrier_add_plugin(... KIT), it needs no libgeobarrier (readelf), leaves no symbol of the core's C++ API to the
# loader (nm), and runs in the installed program: its barrier's length is the grid's perimeter, 2 (4 + 4) = 16, and
# its picture, drawn through the core's picture service (ABI 1.4), is a PNG.
# Usage: test_kit_install.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$(cd "$1" && pwd)
build=$(cd "$2" && pwd)
tmp=$(mktemp -d "${TMPDIR:-/tmp}/geobarrier-kit-install.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
fail() { echo "test_kit_install: FAIL: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$tmp/prefix" > "$tmp/install.log" || fail "cmake --install: $(tail -5 "$tmp/install.log")"
cmake -S "$src/tests/sdk/kit-extractor" -B "$tmp/build" -DCMAKE_PREFIX_PATH="$tmp/prefix" > "$tmp/configure.log" 2>&1 ||
  fail "configure: $(tail -20 "$tmp/configure.log")"
cmake --build "$tmp/build" > "$tmp/build.log" 2>&1 || fail "build: $(tail -20 "$tmp/build.log")"
plugin=$tmp/build/plugins/geobarrier-kit-box.so
sh "$src/tests/plugins/extractors_standalone.sh" "$plugin" || fail "the kit extractor is not standalone"

cat > "$tmp/experiment.json" <<JSON
{"system": {"plugin": "parallel-shear"}, "forcing": {"plugin": "none"},
 "time": {"t0": 0, "t1": 1}, "grid": {"x": [0, 4], "y": [-2, 2], "n": [21, 21]},
 "extractors": [{"plugin": "kit-box"}], "output": {"dir": "$tmp/out", "plots": true}}
JSON
GEOBARRIER_PLUGIN_PATH="$tmp/build/plugins" "$tmp/prefix/bin/geobarrier" run -q "$tmp/experiment.json" ||
  fail "the run failed"
/usr/bin/python3 - "$tmp/out" <<'PY' || fail "barriers.json or the picture is not what the extractor made"
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
barriers = json.loads((out / "barriers.json").read_text())["barriers"]
assert len(barriers) == 1, barriers
b = barriers[0]
assert b["extractor"] == "kit-box" and b["closed"] is True, b
assert b["length"] == 16.0, b["length"]
assert b["points"] == [[0, -2], [4, -2], [4, 2], [0, 2]], b["points"]
assert (out / "kit-box.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
PY
echo "test_kit_install: ok"
