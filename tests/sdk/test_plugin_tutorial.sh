#!/usr/bin/env bash
# Runs docs/plugins.md word for word, as a new user on a fresh machine would: every ```sh block, in order, in one
# shell whose HOME is a temporary folder and whose working directory starts as a stand-in for the geobarrier
# checkout (its build/ is this build tree). So the tutorial installs geobarrier into $HOME/geobarrier, copies the
# template out of the tree, builds it against the install and runs it. Every ```cpp, ```cmake and ```json excerpt
# must be a verbatim part of a file the build compiles or the test runs. Prints each block's wall time.
# Usage: test_plugin_tutorial.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$(cd "$1" && pwd)
build=$(cd "$2" && pwd)
doc=$src/docs/plugins.md
tmp=$(mktemp -d "${TMPDIR:-/tmp}/geobarrier-tutorial.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
fail() { echo "test_plugin_tutorial: FAIL: $*" >&2; exit 1; }

# Split the tutorial into its fenced blocks: $tmp/blocks/NNN.<language>.
mkdir -p "$tmp/blocks"
awk -v dir="$tmp/blocks" '
  /^```/ {
    if (inside) { inside = 0; close(file); next }
    lang = substr($0, 4); if (lang == "") lang = "plain"
    file = sprintf("%s/%03d.%s", dir, ++n, lang); inside = 1; printf "" > file; next
  }
  inside { print > file }' "$doc"
ls "$tmp/blocks"/*.sh >/dev/null 2>&1 || fail "no sh blocks in $doc"

# 1. Excerpts are real code.
sources=("$src"/examples/plugin-template/* "$src"/systems/*/*.cpp "$src"/forcings/*/*.cpp)
for block in "$tmp/blocks"/*.cpp "$tmp/blocks"/*.cmake "$tmp/blocks"/*.json; do
  [ -e "$block" ] || continue
  excerpt=$(cat "$block")
  found=
  for f in "${sources[@]}"; do
    [ -f "$f" ] || continue
    if [[ "$(cat "$f")" == *"$excerpt"* ]]; then found=$f; break; fi
  done
  [ -n "$found" ] || fail "the excerpt in $(basename "$block") of docs/plugins.md is in no template or plugin file:
$excerpt"
done

# 2. The commands, in one shell, each block timed.
mkdir -p "$tmp/home" "$tmp/checkout"
ln -s "$build" "$tmp/checkout/build"
script=$tmp/tutorial.sh
{
  echo 'set -euo pipefail'
  for block in "$tmp/blocks"/*.sh; do
    name=$(basename "$block")
    echo "echo; echo '--- docs/plugins.md, block $name:'; sed 's/^/    /' '$block'"
    echo '__start=$EPOCHREALTIME'
    cat "$block"
    echo "awk -v a=\"\$__start\" -v b=\"\$EPOCHREALTIME\" 'BEGIN { printf \"--- block $name took %.1f s\\n\", b - a }'"
  done
} > "$script"
core_before=$(stat -c %Y "$build"/lib/libgeobarrier.so*)
(cd "$tmp/checkout" && env -u GEOBARRIER_PLUGIN_PATH -u CMAKE_PREFIX_PATH HOME="$tmp/home" bash "$script") ||
  fail "a command of docs/plugins.md failed (output above)"
[ "$(stat -c %Y "$build"/lib/libgeobarrier.so*)" = "$core_before" ] || fail "the tutorial rebuilt the core"

# 3. What the commands should have produced.
home=$tmp/home
for f in fields.nc ftle.png barriers.json manifest.json; do
  [ -s "$home/my-plugins/out/template/$f" ] || fail "out/template/$f was not written"
done
grep -q '"hyperbolic"' "$home/my-plugins/out/template/barriers.json" ||
  fail "the ftle-ridge extractor reported no barrier"
for p in shaken-pendulum chirp ftle-ridge; do
  grep -q "\"name\": \"$p\"" "$home/my-plugins/out/template/manifest.json" || fail "manifest.json does not list $p"
done
grep -q '"name": "chirp"' "$home/my-plugins/out/template-ramped/manifest.json" ||
  fail "the ramped experiment's manifest does not list its chirp term"
[ -f "$home/geobarrier/lib/geobarrier/plugins/geobarrier-shaken-pendulum.so" ] ||
  fail "cmake --install did not put the plugin beside the built-in ones"
[ -f "$home/my-plugins/by-hand/geobarrier-chirp.so" ] || fail "the pkg-config build made no plugin"
# Every relative link of the installed documents resolves in the install (plugins.md links to experiment-format.md,
# which links to extractors.md, ...).
docs=$home/geobarrier/share/doc/geobarrier
[ -f "$docs/plugins.md" ] || fail "plugins.md is not installed"
for md in "$docs"/*.md; do
  while read -r target; do
    [ -e "$docs/$target" ] || fail "the installed $(basename "$md") links to $target, which is not installed"
  done < <(grep -o '](\([^)#]*\)' "$md" | sed 's/^](//' | grep -v '^$' | grep -v '://' | grep -v '^docs/' | sort -u)
done
# The out-of-tree plugins were compiled like the built-ins (geobarrier_add_plugin: fast by default).
checked=$("$home/geobarrier/bin/geobarrier" check-plugin "$home/my-plugins/build/plugins/geobarrier-shaken-pendulum.so")
grep -q "^PASS  code_generation " <<<"$checked" || fail "the template's system was not compiled like the built-ins:
$checked"
grep -q "^PASS  advance_equals_stages " <<<"$checked" || fail "the template's system has no fused step:
$checked"
grep -q "derived by automatic differentiation" <<<"$checked" || fail "the template's Jacobian is not derived:
$checked"
# The installed program finds the built-in plugins, and the installed template ones, with no environment variable.
listing=$(cd / && env -u GEOBARRIER_PLUGIN_PATH "$home/geobarrier/bin/geobarrier" plugins)
for p in duffing cosine ramp shaken-pendulum; do
  grep -q "^  $p " <<<"$listing" || fail "the installed geobarrier does not list $p"
done
echo
echo "test_plugin_tutorial: every command of docs/plugins.md ran (the out-of-tree build: the block with 'cmake -S . -B build')"
