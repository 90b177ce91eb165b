"""The module from an install prefix (cmake --install): it imports with PYTHONPATH set to the prefix's
package folder, finds libgeobarrier and the installed plugins, and runs an experiment."""

import os
import pathlib
import subprocess
import sys

import pytest

import geobarrier

BUILD_DIR = pathlib.Path(geobarrier.__file__).resolve().parents[2]


def test_run_from_an_install_prefix(tmp_path):
    if not (BUILD_DIR / "CMakeCache.txt").exists():
        pytest.fail(f"{BUILD_DIR} is not a build tree: run this suite through ctest")
    prefix = tmp_path / "prefix"
    installed = subprocess.run(["cmake", "--install", str(BUILD_DIR), "--prefix", str(prefix)],
                               capture_output=True, text=True)
    assert installed.returncode == 0, installed.stderr
    packages = [p.parent for p in prefix.glob("lib/python3*/*-packages/geobarrier")]
    assert len(packages) == 1
    # The type stubs and the PEP 561 marker are installed with the sources (test_stubs.py checks what they say).
    assert {p.name for p in packages[0].glob("geobarrier/*.pyi")} == {"__init__.pyi", "_geobarrier.pyi"}
    assert (packages[0] / "geobarrier" / "py.typed").is_file()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "GEOBARRIER_PLUGIN_PATH")}
    env["PYTHONPATH"] = str(packages[0])
    script = ("import geobarrier, json; "
              "r = geobarrier.run({'system': {'plugin': 'duffing'}, 'grid': {'x': [-1, 1], 'y': [-1, 1], "
              "'n': [7, 5]}, 'time': {'t0': 0, 't1': 1}, 'products': ['ftle']}); "
              "print(geobarrier.__file__); print(r.fields.ftle.shape); print(r.manifest['plugins'][0]['file'])")
    ran = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr
    module, shape, plugin = ran.stdout.splitlines()
    assert module.startswith(str(prefix)) and shape == "(5, 7)"
    assert plugin.startswith(str(prefix / "lib" / "geobarrier" / "plugins"))
