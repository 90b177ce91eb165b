"""geobarrier from Python: run experiments on the C++ core and get NumPy arrays or xarray Datasets back.

    import geobarrier
    r = geobarrier.run("experiments/demo.json")     # or a dict in the experiment format
    r.fields.ftle                                     # xarray.DataArray (ny, nx), as in fields.nc
    r.barriers[0].points                              # (n, 2) array; r.barriers[0].rank, an int
    r.barriers.to_dataframe()                         # one row per barrier (pandas)
    r.plot()                                          # FTLE with the barriers over it (matplotlib Axes)
    r.manifest["integrator_stats"]

docs/python.md is the guide; docs/experiment-format.md describes experiments.
"""

import importlib
import json
import math
import numbers
import os
import signal
import threading

from . import _openmp

# First of all, before anything loads the native extension and with it the OpenMP runtime: idle threads sleep unless
# the user chose otherwise (_openmp.py says why). "user", "passive", "too late" or "unknown". Once: importlib.reload
# (and a notebook's autoreload) runs this file again in the same namespace, with the extension loaded by then.
if "_openmp_wait" not in globals():
    _openmp_wait = _openmp.import_with_passive_wait(lambda: importlib.import_module("._geobarrier", __name__))

from . import _fields  # noqa: E402 (after the extension's import above)
from . import _geobarrier as _native
if not globals().get("_forks_guarded"):  # once, as above
    _openmp.guard_forks(_native)  # one thread in a fork child whose OpenMP worker threads stayed behind (_openmp.py)
    _forks_guarded = True
from numpy import bool_ as _np_bool
from ._errors import ConfigError, Error, IoError, NumericalError, PluginError
from ._geobarrier import version as __version__
from ._arrays import CauchyGreen, Forcing, System, barriers, cauchy_green, flow_map, ftle, non_finite
from ._arrays import _plugin_paths
from ._barriers import Barrier, Barriers
from ._fields import Fields
from ._plot import plot
from ._progress import InContext, ProgressBar, ProgressLine, default_progress

__all__ = ["run", "validate", "plugins", "set_log_level", "plot", "Result", "BothDirections", "Barrier", "Barriers",
           "Fields", "Error", "ConfigError", "PluginError", "NumericalError", "IoError", "ProgressLine", "ProgressBar",
           "flow_map", "cauchy_green", "ftle", "barriers", "System", "Forcing", "CauchyGreen"]


class Result:
    """What run() returns: ``fields`` (an xarray.Dataset as fields.nc holds it, with its CF attributes, or
    geobarrier.Fields of NumPy arrays without xarray), ``barriers`` (Barriers: a list of Barrier), ``candidates``
    (Barriers: curves an extractor reported but does not assert, barriers.json's "candidates"), ``manifest`` (dict,
    as manifest.json), ``warnings`` (the manifest's), ``output_dir`` and ``files`` (what was written; empty when
    nothing was). ``plot()`` draws a field with the barriers, ``to_dataframe()`` tabulates the barriers."""

    def __init__(self, native, use_xarray=True):
        self.fields = _fields.build(native, use_xarray)
        self.barriers = Barriers(Barrier(b) for b in json.loads(native["barriers"]))
        # Curves an extractor reported but does not assert as barriers (barriers.json's "candidates").
        self.candidates = Barriers(Barrier(b) for b in json.loads(native.get("candidates", "[]")))
        self.manifest = json.loads(native["manifest"])
        self.warnings = self.manifest.get("warnings", [])
        self.output_dir = native["output_dir"] or None
        self.files = list(native["files"])

    def plot(self, variable="ftle", *, ax=None, candidates=False, **kwargs):
        """Draws the field ``variable`` (default "ftle") with the barriers over it, and the candidates dashed when
        ``candidates`` is True; returns the matplotlib Axes. Keyword arguments as for geobarrier.plot()."""
        return plot(self.fields, self.barriers, variable=variable, ax=ax,
                    candidates=self.candidates if candidates else (), **kwargs)

    def to_dataframe(self, candidates=False):
        """The barriers' figures as a pandas.DataFrame (Barriers.to_dataframe), one row per barrier; with
        ``candidates`` True the candidates follow, and a bool column "candidate" tells them apart."""
        if not candidates:
            return self.barriers.to_dataframe()
        frame = Barriers(list(self.barriers) + list(self.candidates)).to_dataframe()
        frame["candidate"] = [False] * len(self.barriers) + [True] * len(self.candidates)
        return frame

    def __repr__(self):
        names = [n for n in self.fields if n != "mask"] if not hasattr(self.fields, "data_vars") else [
            n for n in self.fields.data_vars if n != "mask"]
        return f"<geobarrier.Result fields: {', '.join(names) or 'none'}; {len(self.barriers)} barriers>"


class BothDirections(Result):
    """What run() returns for ``"time": {"directions": "both"}``, a Result whose ``barriers`` and ``candidates`` are
    both directions' (the repelling ones first: ``barrier.repelling`` or ``barrier.attracting`` is True) and whose
    ``fields`` are the forward run's; ``forward`` and ``backward`` are a Result each, as a run of one direction
    gives it (the CLI writes them to forward/ and backward/); ``tangle`` is the dict tangle.json holds (the
    barriers' transverse ``crossings`` and their ``counts``; with ``"period"`` the saddle orbits; with
    ``"grow_periods"`` the grown manifolds under ``"grown"``), ``crossings`` its list of crossings, ``manifest`` the
    folder's manifest.json.
    ``plot()`` draws a field of one direction with both barrier sets and the crossings."""

    def __init__(self, native, use_xarray=True):  # not Result.__init__: that reads one run, these are two
        directions = native["directions"]
        self.forward = Result(directions["forward"], use_xarray)
        self.backward = Result(directions["backward"], use_xarray)
        self.fields = self.forward.fields
        self.barriers = Barriers(list(self.forward.barriers) + list(self.backward.barriers))
        self.candidates = Barriers(list(self.forward.candidates) + list(self.backward.candidates))
        self.tangle = json.loads(native["tangle"])
        self.crossings = self.tangle["crossings"]
        self.manifest = json.loads(native["manifest"])
        self.warnings = self.forward.warnings + self.backward.warnings
        self.output_dir = native["output_dir"] or None
        self.files = list(native["files"])

    def plot(self, variable="ftle", *, ax=None, candidates=False, direction="forward", crossings=True, **kwargs):
        """Draws the field ``variable`` of the ``direction`` run ("forward" or "backward") with the repelling
        barriers (red) and the attracting ones (blue) over it, the candidates dashed when ``candidates`` is True,
        and the crossings as black dots when ``crossings`` is True; returns the matplotlib Axes. Keyword arguments
        as for geobarrier.plot()."""
        if direction not in ("forward", "backward"):
            raise ValueError(f'direction is "forward" or "backward", not {direction!r}')
        ax = plot(getattr(self, direction).fields, self.forward.barriers, variable=variable, ax=ax,
                  candidates=self.candidates if candidates else (), barrier_kwargs={"color": "tab:red"}, **kwargs)
        for barrier in self.backward.barriers:
            barrier.plot(ax=ax, color="tab:blue")
        if crossings and self.crossings:
            ax.plot([c["point"][0] for c in self.crossings], [c["point"][1] for c in self.crossings], "k.",
                    markersize=6)
        return ax

    def __repr__(self):
        return (f"<geobarrier.BothDirections {len(self.forward.barriers)} repelling and {len(self.backward.barriers)} "
                f"attracting barriers, {len(self.crossings)} crossings>")


def _json_default(value):
    # NumPy scalars and arrays in an experiment dict (a sweep's np.linspace values) are plain JSON numbers.
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not valid in an experiment (numbers, strings, lists, dicts)")


def _experiment_text(experiment):
    """(text, file) for the native module: a dict becomes JSON text; a path is read by the core ("" text)."""
    if isinstance(experiment, (str, os.PathLike)):
        return "", os.fspath(experiment)
    if not isinstance(experiment, dict):
        raise TypeError(f"an experiment is a dict or a path to a JSON file, not {type(experiment).__name__}")
    try:
        return json.dumps(experiment, allow_nan=False, default=_json_default), ""
    except ValueError as e:  # NaN or infinity, which JSON has not (or a dict that holds itself)
        try:
            found = non_finite(json.loads(json.dumps(experiment, default=_json_default)))
        except ValueError:
            found = None
        if found is None:
            raise ConfigError(f"/: {e}", "/") from None
        path, value = found
        raise ConfigError(f"{path}: {value!r} is not a finite number (JSON has no NaN or infinity)", path) from None


def _output_folder(out):
    """``out`` as the str the core takes, or None: TypeError for what is no path, ValueError for an empty one."""
    if out is None:
        return None
    if not isinstance(out, (str, os.PathLike)) or not isinstance(os.fspath(out), str):
        raise TypeError(f"out: expected a folder path (str or os.PathLike), got {type(out).__name__}")
    out = os.fspath(out)
    if not out:
        raise ValueError('out: "" is no folder; give one ("." for the working directory), or out=None to write nothing')
    return out


def _flow_map_only(text, file):
    """The experiment reduced to its flow map: products ["flow_map"], no extractors, no validation products, no
    convergence check."""
    if not text:
        try:
            with open(file, encoding="utf-8", errors="replace") as f:
                text = f.read()
        except OSError:
            return text, file  # the core reports the file it cannot read (IoError), as without flow_map
    try:
        experiment = json.loads(text)
    except ValueError:
        return text, file  # the core reports where the JSON is malformed
    if isinstance(experiment, dict):
        time = experiment.get("time")
        if isinstance(time, dict) and time.get("directions") == "both":
            # "both" runs both directions for the crossings of their barriers, which a flow map alone has not (the
            # core would say that the experiment has no extractors, which it had).
            raise ConfigError('/time/directions: flow_map=True computes the flow map of one direction, and "both" '
                              'asks for two (for the crossings of their barriers); set it to "one" (t0 to t1), or run '
                              'without flow_map', f"{file}: /time/directions" if file else "/time/directions")
        experiment["products"] = ["flow_map"]
        experiment.pop("extractors", None)
        experiment.pop("validation", None)
        experiment.pop("convergence", None)  # compares barriers, and a flow map alone has none
        text = json.dumps(experiment)
    return text, file


def run(experiment, out=None, *, write=None, threads=0, progress=False, flow_map=False, xarray=True):
    """Runs an experiment (a dict in the experiment format, or a path to an experiment file) and returns a Result.

    out       write the usual output folder (fields.nc, pictures, barriers.json, manifest.json) here;
    write     True: write it to `out`, or to the experiment's output.dir; default: only when `out` is given;
              a run that writes nothing draws no pictures and leaves every folder as it was;
    threads   worker threads (0 or None: OpenMP's default, all cores; at most 1024, as on the command line); the
              setting is the run's own;
    progress  True: a live bar per stage in a Jupyter notebook (tqdm's; a widget with ipywidgets 7 or newer), else
              a progress line on stderr; or a callable(stage, done, total), e.g. ProgressBar(tqdm.tqdm) (ProgressLine and
              ProgressBar objects are closed when the run returns);
    flow_map  True: compute the flow map alone (products ["flow_map"], no extractors, no validation products):
              result.fields.flow_x and .flow_y are F(x0, y0) at t1;
    xarray    False: NumPy arrays (geobarrier.Fields) even when xarray is installed.

    The GIL is released while the core computes. Ctrl-C (a notebook's "interrupt kernel") stops the run and raises
    KeyboardInterrupt; no file of the run is left in the output folder. Bad input raises ConfigError (``e.path``
    is the JSON path); a failed computation raises another geobarrier.Error.

    An experiment with ``"time": {"directions": "both"}`` returns BothDirections: a Result per direction and the
    tangle (what the command line writes to forward/, backward/ and tangle.json).
    """
    text, file = _experiment_text(experiment)
    for name, flag in (("write", write), ("flow_map", flow_map), ("xarray", xarray)):
        # A truthy string ("no") would write files or draw the wrong thing without a word.
        if not (isinstance(flag, (bool, _np_bool)) or (flag is None and name == "write")):
            raise TypeError(f"{name}: expected True or False{' or None' if name == 'write' else ''}, got "
                            f"{type(flag).__name__} {flag!r}")
    out = _output_folder(out)
    if flow_map:
        text, file = _flow_map_only(text, file)
    if write is None:
        write = out is not None
    elif not write and out is not None:
        raise ValueError("out names an output folder but write=False")
    if threads is None:
        threads = 0
    if isinstance(threads, (bool, _np_bool)) or not isinstance(threads, numbers.Integral):
        raise TypeError(f"threads: expected an int (0 or None: all cores), got {type(threads).__name__}")
    threads = int(threads)
    if threads < 0:
        raise ValueError(f"threads must be a non-negative integer, not {threads!r}")
    if threads > _native.max_threads:
        raise ValueError(f"threads must be at most {_native.max_threads} (as on the command line), not {threads!r}")
    threads = _openmp.parallel_threads(threads)
    if progress not in (False, None, True) and not callable(progress):
        raise TypeError("progress is True, False or a callable(stage, done, total)")
    # progress=True draws the default; a ProgressLine or ProgressBar given is drawn and closed the same way.
    line = default_progress() if progress is True else (
        progress if isinstance(progress, (ProgressLine, ProgressBar)) else None)
    callback = line if line is not None else (progress if callable(progress) else None)
    if callback is not None:
        callback = InContext(callback)  # drawn as the caller's output (a notebook cell's), from the core's threads
    # Ctrl-C is the core's to handle only where Python would raise KeyboardInterrupt for it: in the main thread,
    # with Python's default handler in place.
    handle_interrupt = (threading.current_thread() is threading.main_thread()
                        and signal.getsignal(signal.SIGINT) is signal.default_int_handler)
    completed = False
    try:
        native = _native.run(text, file, out, bool(write), threads, callback, handle_interrupt)
        completed = True
    finally:
        if line is not None:
            line.close(completed=completed)
    return BothDirections(native, xarray) if "directions" in native else Result(native, xarray)


def validate(experiment):
    """Checks an experiment completely (structure, values, plugins and their parameters) and computes nothing.
    Returns a summary dict (system, forcing, grid, products, extractors, validation, warnings, and the experiment
    with every default filled in as "resolved"); raises ConfigError for bad input."""
    text, file = _experiment_text(experiment)
    return json.loads(_native.validate(text, file))


def plugins(plugin_paths=()):
    """The plugins found (in `plugin_paths` first: a folder or a list of folders; then GEOBARRIER_PLUGIN_PATH, then
    the built-in ones), each a dict with kind, name, version, doc, file and "params": the schema (name, type,
    default, min, max, unit, doc)."""
    found = json.loads(_native.plugins(_plugin_paths(plugin_paths)))["plugins"]
    for plugin in found:
        for param in plugin.get("params", []):
            # JSON's null for an unbounded side of a numeric range: an infinity in Python, usable in comparisons.
            for key, unbounded in (("min", -math.inf), ("max", math.inf)):
                if key in param and param[key] is None:
                    param[key] = unbounded
    return found


def set_log_level(level):
    """The core's log level on stderr: "debug", "info", "warning" (the default in Python), "error" or "off" (in
    any case: "INFO" as Python's logging spells it)."""
    if not isinstance(level, str):
        raise TypeError(f'level: expected a str ("debug", "info", "warning", "error" or "off"), got '
                        f"{type(level).__name__}")
    _native.set_log_level(level.lower())
