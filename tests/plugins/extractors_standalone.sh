#!/bin/sh
# The built-in extractors are plugins on the C ABI alone (issue 36): none needs libgeobarrier, none leaves a symbol of
# the core's C++ API (namespace geobarrier) to be found at load time, and none exports one: the extractor kit they
# compile in is hidden. Usage: extractors_standalone.sh PLUGIN.so ...
status=0
for plugin in "$@"; do
  bad=0
  if ! dynamic=$(readelf -d "$plugin"); then
    echo "FAIL $plugin: readelf cannot read it" >&2
    status=1
    continue
  fi
  if echo "$dynamic" | grep -q 'NEEDED.*libgeobarrier'; then
    echo "FAIL $plugin needs libgeobarrier:" >&2
    echo "$dynamic" | grep NEEDED >&2
    bad=1
  fi
  undefined=$(nm -D --undefined-only -C "$plugin" | grep -E ' U geobarrier::')
  if [ -n "$undefined" ]; then
    echo "FAIL $plugin leaves the core's C++ symbols to the loader:" >&2
    echo "$undefined" >&2
    bad=1
  fi
  exported=$(nm -D --defined-only -C "$plugin" | grep -E ' [A-Za-z] geobarrier::')
  if [ -n "$exported" ]; then
    echo "FAIL $plugin exports C++ symbols of geobarrier (the kit should be hidden):" >&2
    echo "$exported" | head -5 >&2
    bad=1
  fi
  if [ "$bad" -eq 0 ]; then echo "ok $plugin"; else status=1; fi
done
exit $status
