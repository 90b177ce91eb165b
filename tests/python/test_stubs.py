"""The type stubs (python/geobarrier/__init__.pyi, _geobarrier.pyi) match the module, and the docstrings help() shows
are there. Without mypy: every public name and parameter of the stubs against the imported module (ast and
inspect). With mypy (Debian: mypy, scripts/install-deps): mypy's stubtest compares them, mypy passes on the examples
(examples/python/*.py and the notebooks' code) against the stubs, and flags a wrong call."""

import ast
import inspect
import pathlib
import pydoc
import shutil
import subprocess
import sys

import pytest

import geobarrier
from geobarrier import _geobarrier
from conftest import SOURCE_DIR

PACKAGE = pathlib.Path(geobarrier.__file__).resolve().parent
MYPY_INI = pathlib.Path(__file__).resolve().parent / "mypy.ini"


def stub(name):
    return ast.parse((PACKAGE / name).read_text(), filename=name)


def public_definitions(body):
    """{name: node} of a stub's (or a class's) public functions, classes and annotated or assigned names."""
    out = {}
    for node in body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            out[node.name] = node
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            out[node.target.id] = node
        elif isinstance(node, ast.Assign):
            out.update({t.id: node for t in node.targets if isinstance(t, ast.Name)})
    return {name: node for name, node in out.items() if not name.startswith("_") or name in ("__version__",
                                                                                              "__all__", "__init__",
                                                                                              "__call__")}


def parameter_names(node):
    a = node.args
    return [p.arg for p in a.posonlyargs + a.args + a.kwonlyargs] + \
        ([a.vararg.arg] if a.vararg else []) + ([a.kwarg.arg] if a.kwarg else [])


def runtime_parameter_names(function):
    return list(inspect.signature(function).parameters)


def test_the_stubs_are_installed_beside_the_module():
    for name in ("__init__.pyi", "_geobarrier.pyi", "py.typed"):
        assert (PACKAGE / name).is_file(), name
        assert (PACKAGE / name).read_bytes() == (SOURCE_DIR / "python" / "geobarrier" / name).read_bytes(), name


def instances():
    """One object of each class the stubs declare, made as a user gets them."""
    import io

    from conftest import base_experiment

    result = geobarrier.run(base_experiment(), xarray=False)
    both = geobarrier.run(base_experiment(time={"t0": 0, "t1": 2, "directions": "both"},
                                          extractors=[{"plugin": "hyperbolic"}]), xarray=False)
    barrier = geobarrier.Barrier({"kind": "elliptic", "closed": True, "extractor": "elliptic",
                                  "points": [[0, 0], [1, 0], [0, 1]], "rank": 1.0})
    return {"Result": result, "BothDirections": both, "Fields": result.fields, "Barrier": barrier,
            "Barriers": geobarrier.Barriers([barrier]), "ProgressLine": geobarrier.ProgressLine(io.StringIO()),
            "ProgressBar": geobarrier.ProgressBar(object),
            "Error": geobarrier.Error("e"), "ConfigError": geobarrier.ConfigError("m", "/grid/n"),
            "PluginError": geobarrier.PluginError("p"), "NumericalError": geobarrier.NumericalError("n"),
            "IoError": geobarrier.IoError("i"), "System": geobarrier.System("linear-saddle"),
            "Forcing": geobarrier.Forcing("cosine"), "CauchyGreen": geobarrier.cauchy_green([[1.0, 0.0], [0.0, 1.0]])}


def test_package_stub_names_match_the_module():
    defined = public_definitions(stub("__init__.pyi").body)
    all_node = defined.pop("__all__")
    assert ast.literal_eval(all_node.value) == geobarrier.__all__
    assert set(defined) == set(geobarrier.__all__) | {"__version__"}
    objects = instances()
    for name, node in defined.items():
        runtime = getattr(geobarrier, name)
        if isinstance(node, ast.FunctionDef):
            assert parameter_names(node) == runtime_parameter_names(runtime), name
        elif isinstance(node, ast.ClassDef):
            assert inspect.isclass(runtime) and isinstance(objects[name], runtime), name
            members = public_definitions(node.body)
            for member, member_node in members.items():
                # Every attribute and method the stub declares is there on a real object, with the same parameters.
                assert member in ("__init__", "__call__") or hasattr(objects[name], member), (name, member)
                if isinstance(member_node, ast.FunctionDef) and callable(vars(runtime).get(member)):
                    assert parameter_names(member_node) == runtime_parameter_names(vars(runtime)[member]), \
                        (name, member)
            # Every public method of the class is in the stub.
            methods = {m for m, v in vars(runtime).items() if callable(v) and not m.startswith("_")}
            assert methods <= set(members), (name, methods - set(members))


def test_native_stub_matches_the_compiled_module():
    defined = public_definitions(stub("_geobarrier.pyi").body)
    runtime = {n for n in dir(_geobarrier) if not n.startswith("_")}
    assert set(defined) == runtime
    for name, node in defined.items():
        if isinstance(node, ast.FunctionDef):
            # pybind11 writes the signature as the docstring's first line: "run(text: str, file: str, ...) -> dict".
            signature = getattr(_geobarrier, name).__doc__.splitlines()[0]
            names = [p.split(":")[0].strip() for p in signature[signature.index("(") + 1:signature.index(")")]
                     .split(",") if p.strip()]
            assert parameter_names(node) == names, name
    assert isinstance(_geobarrier.version, str) and isinstance(_geobarrier.max_threads, int)


def test_help_shows_the_docstrings():
    text = pydoc.render_doc(geobarrier, renderer=pydoc.plaintext)
    for phrase in ("Runs an experiment", "write the usual output folder", "class Barrier", "to_dataframe",
                   "Draws one field"):
        assert phrase in text, phrase
    assert "counts (rank, island" in pydoc.render_doc(geobarrier.Barrier, renderer=pydoc.plaintext)
    for name in geobarrier.__all__:
        assert inspect.getdoc(getattr(geobarrier, name)), name


mypy = pytest.mark.skipif(shutil.which("mypy") is None and not pathlib.Path("/usr/lib/python3/dist-packages/mypy")
                          .exists(), reason="needs mypy (Debian: mypy, scripts/install-deps)")


def run_mypy(module_args, tmp_path, config="--config-file"):
    env = {"PATH": "/usr/bin:/bin", "MYPYPATH": str(PACKAGE.parent), "PYTHONPATH": str(PACKAGE.parent),
           "HOME": str(tmp_path)}
    return subprocess.run([sys.executable, "-m", *module_args, config, str(MYPY_INI)], capture_output=True,
                          text=True, env=env, cwd=tmp_path, timeout=300)


@mypy
def test_stubtest_finds_the_stubs_true_to_the_module(tmp_path):
    done = run_mypy(["mypy.stubtest", "geobarrier"], tmp_path, config="--mypy-config-file")
    assert done.returncode == 0 and "Success" in done.stdout, done.stdout + done.stderr


@mypy
def test_mypy_passes_on_the_examples_and_catches_a_wrong_call(tmp_path):
    import nbformat

    files = [str(SOURCE_DIR / "examples" / "python" / "paper_first_example.py")]
    for notebook in sorted((SOURCE_DIR / "examples" / "python").glob("*.ipynb")):
        code = [c.source for c in nbformat.read(notebook, as_version=4).cells if c.cell_type == "code"]
        path = tmp_path / f"notebook_{notebook.stem}.py"
        path.write_text("\n\n".join(code) + "\n")
        files.append(str(path))
    wrong = tmp_path / "wrong.py"
    wrong.write_text("import geobarrier\n"
                     "r = geobarrier.run({}, threads='2')\n"
                     "rank: str = r.barriers[0].kind\n"
                     "n: int = r.barriers[0].kind\n"
                     "r.plot(colour=1).set_title('x')\n"
                     "geobarrier.set_log_level('verbose')\n")
    done = run_mypy(["mypy", "--cache-dir", str(tmp_path / "cache"), *files], tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"no issues found in {len(files)} source files" in done.stdout
    done = run_mypy(["mypy", "--cache-dir", str(tmp_path / "cache"), str(wrong)], tmp_path)
    errors = [line for line in done.stdout.splitlines() if ": error:" in line]
    assert [int(line.split(":")[1]) for line in errors] == [2, 4, 6], done.stdout
    assert 'Argument "threads" to "run" has incompatible type "str"; expected "Optional[int]"' in errors[0]
    assert "set_log_level" in errors[2] and "'verbose'" in errors[2]
