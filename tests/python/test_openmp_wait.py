"""Idle OpenMP threads sleep in the module as in the program (python/geobarrier/_openmp.py): a fresh interpreter
that imports geobarrier has libgomp's passive policy (its verbose environment display shows the spin count the
runtime read: 0 for passive, 300000 for libgomp's default, 30000000000 for active), a user's choice stands, the
environment of what the user starts afterwards is as it was, and a runtime loaded before geobarrier keeps its
setting with a warning that says why."""

import os
import subprocess
import sys

import pytest

import geobarrier

# libgomp's display (GNU's runtime); the module's runtime is another in a build with LLVM's.
pytestmark = pytest.mark.skipif(
    not any(os.path.basename(p).startswith("libgomp") for p in (geobarrier._openmp._mapped_runtimes() or ())),
    reason="the module is not linked with libgomp (the display's format and its load-time reading are libgomp's)")

SHOW = ("import os, geobarrier; print('policy', geobarrier._openmp_wait); "
        "print('env', os.environ.get('OMP_WAIT_POLICY'), os.environ.get('GOMP_SPINCOUNT'))")


def fresh_interpreter(code, **environment):
    """(stdout, stderr) of `python -c code` with the test's environment less the OpenMP variables, plus these."""
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "OMP_DISPLAY_ENV")}
    env.update(OMP_DISPLAY_ENV="verbose", **environment)
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout, done.stderr


def test_a_fresh_interpreter_gets_the_passive_policy_and_keeps_its_environment():
    out, err = fresh_interpreter(SHOW)
    assert "GOMP_SPINCOUNT = '0'" in err
    assert "policy passive" in out
    assert "env None None" in out  # the variable was there for libgomp's constructor only


@pytest.mark.parametrize("variable, value, display", [
    ("OMP_WAIT_POLICY", "active", "GOMP_SPINCOUNT = '30000000000'"),
    ("OMP_WAIT_POLICY", "passive", "GOMP_SPINCOUNT = '0'"),
    ("GOMP_SPINCOUNT", "1000", "GOMP_SPINCOUNT = '1000'"),
])
def test_the_users_choice_stands(variable, value, display):
    out, err = fresh_interpreter(SHOW, **{variable: value})
    assert display in err
    assert "policy user" in out
    assert f"env {value if variable == 'OMP_WAIT_POLICY' else None} {value if variable == 'GOMP_SPINCOUNT' else None}" \
        in out


def test_a_runtime_loaded_before_keeps_its_default_with_a_warning():
    # As another library would: libgomp is in the process before geobarrier's import.
    out, err = fresh_interpreter("import ctypes; ctypes.CDLL('libgomp.so.1'); " + SHOW)
    assert "GOMP_SPINCOUNT = '300000'" in err  # libgomp's default spin, read when ctypes loaded it
    assert "GOMP_SPINCOUNT = '0'" not in err
    assert "policy too late" in out
    assert "RuntimeWarning: geobarrier: the OpenMP runtime" in err and "set OMP_WAIT_POLICY" in err
    assert "env None None" in out


def test_a_runtime_loaded_before_with_the_users_policy_warns_of_nothing():
    out, err = fresh_interpreter("import ctypes; ctypes.CDLL('libgomp.so.1'); " + SHOW, OMP_WAIT_POLICY="active")
    assert "policy user" in out
    assert "RuntimeWarning" not in err


def test_reloading_the_module_is_no_second_import():
    # importlib.reload (a notebook's autoreload) found the runtime loaded and warned that it was too late.
    out, err = fresh_interpreter("import importlib, warnings; warnings.simplefilter('error'); " + SHOW.replace(
        "import os, geobarrier; ", "import os, geobarrier; importlib.reload(geobarrier); "))
    assert "policy passive" in out and "RuntimeWarning" not in err
    assert err.count("GOMP_SPINCOUNT = '0'") == 1
