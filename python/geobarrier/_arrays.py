"""Array functions on the core's engine (docs/python.md, "Arrays"): systems and forcings as objects, the flow map of
given states with its gradient, and the Cauchy–Green tensor and FTLE of given gradients. No JSON and no files for
arrays: NumPy buffers go to the core, which computes with the GIL released. Every argument is checked here first and
a bad one raises with its name (TypeError for a wrong type, ConfigError, a ValueError, with ``e.path`` the argument's
name, for a wrong value)."""

import json
import math
import numbers
import os
import signal
import threading

import numpy as np

from ._errors import ConfigError
from . import _geobarrier as _native
from . import _openmp

_QUALITIES = ("draft", "standard", "publication")


def _schema(schema_text):
    """A plugin's parameter schema as plugins() gives it: a list of dicts (an unbounded side of a range is inf)."""
    params = json.loads(schema_text).get("params", [])
    for param in params:
        for key, unbounded in (("min", -math.inf), ("max", math.inf)):
            if key in param and param[key] is None:
                param[key] = unbounded
    return params


def non_finite(value, path=""):
    """(JSON path, value) of the first NaN or infinity in a JSON document as json.loads gives it, or None."""
    if isinstance(value, float) and not math.isfinite(value):
        return path, value
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    # JSON Pointer (RFC 6901) escapes "~" and "/" in a key.
    return next((found for key, v in items
                 for found in [non_finite(v, f"{path}/{str(key).replace('~', '~0').replace('/', '~1')}")] if found),
                None)


def _params_text(params):
    """Parameters as JSON text for the core; NaN and infinity (which JSON has not) raise naming the parameter."""
    try:
        return json.dumps(params, allow_nan=False, default=lambda v: v.tolist() if hasattr(v, "tolist") else str(v))
    except ValueError:
        path, value = non_finite(json.loads(json.dumps(params, default=lambda v: v.tolist() if hasattr(
            v, "tolist") else str(v)))) or ("", math.nan)
        raise ConfigError(f"{path or '/'}: {value!r} is not finite (JSON has no NaN or infinity)", path or "/") \
            from None


def _plugin_paths(plugin_paths):
    if isinstance(plugin_paths, (str, os.PathLike)):
        plugin_paths = [plugin_paths]
    try:
        return [os.fspath(p) for p in plugin_paths]
    except TypeError:
        raise TypeError("plugin_paths: expected a list of folder paths") from None


def _name(name, what):
    if isinstance(name, os.PathLike):
        name = os.fspath(name)
    if not isinstance(name, str):
        raise TypeError(f"name: a {what} plugin's name or file is a str, not {type(name).__name__}")
    return name


class System:
    """A dynamical system x' = v(x, t; f) of the core: a built-in or plugin system by name, a plugin file
    (``System("path/libmine.so")``), or equations (``System.from_equations``). Its parameters are checked against
    the plugin's schema as an experiment's are (an unknown or out-of-range one raises ConfigError with ``e.path``
    "/name").

        duffing = geobarrier.System("duffing", alpha=1, beta=1, delta=0)
        duffing.parameters      # the schema: name, type, default, min, max, unit, doc of each parameter
        duffing.params          # the values used, defaults filled in
    """

    def __init__(self, name, /, *, plugin_paths=(), **params):
        text, paths = _params_text(params), _plugin_paths(plugin_paths)
        self._native = _native.make_system(_name(name, "system"), text, paths)
        # As an experiment names it (barriers() on fields computed elsewhere builds one).
        self._spec, self._plugin_paths = {"plugin": _name(name, "system"), "params": json.loads(text)}, paths

    def __reduce__(self):
        # Pickled as what makes it (a multiprocessing "spawn" worker gets it so): the native object is the process's.
        if self._spec["plugin"] == "equations" and not self._plugin_paths and "state" in self._spec["params"]:
            p = self._spec["params"]
            return _equations_system, (p["state"], p["rhs"], p.get("constants"))
        return _system, (self._spec["plugin"], self._plugin_paths, self._spec["params"])

    @classmethod
    def from_equations(cls, state, rhs, constants=None):
        """A system written as equations, as an experiment's "equations" system (docs/experiment-format.md): e.g.
        ``System.from_equations(["x", "v"], ["v", "x - x^3 - d*v + f"], {"d": 0.15})`` (f is the forcing). It is
        compiled once with this build's compiler and cached; new constants need no new compile."""
        params = {}
        for name, value in (("state", state), ("rhs", rhs)):
            try:
                params[name] = value if isinstance(value, str) else list(value)
            except TypeError:
                raise TypeError(f"{name}: expected a list of strings, got {type(value).__name__}") from None
        if constants is not None:
            try:
                params["constants"] = dict(constants)
            except (TypeError, ValueError):
                raise TypeError(f"constants: expected a dict of names and numbers, got {type(constants).__name__}") \
                    from None
        system = cls.__new__(cls)
        text = _params_text(params)
        system._native = _native.make_equations_system(text)
        system._spec, system._plugin_paths = {"plugin": "equations", "params": json.loads(text)}, []
        return system

    @property
    def name(self):
        """The plugin's name ("duffing"; "equations" for equations)."""
        return self._native.name

    @property
    def dimension(self):
        """The number of state components."""
        return self._native.dimension

    @property
    def state_names(self):
        """The state components' names as the system declares them ([] when it declares none)."""
        return list(self._native.state_names)

    @property
    def has_jacobian(self):
        """Whether the system has a Jacobian (flow_map(..., derivative=True) needs one)."""
        return self._native.has_jacobian

    @property
    def uses_forcing(self):
        """Whether the vector field reads the forcing f(t)."""
        return self._native.uses_forcing

    @property
    def parameters(self):
        """The parameter schema: a list of dicts (name, type, default, min, max, unit, doc) as plugins() lists them."""
        return _schema(self._native.schema)

    @property
    def params(self):
        """The parameter values in use, defaults filled in (for equations: state, rhs and constants)."""
        return json.loads(self._native.params)

    def __repr__(self):
        return f"<geobarrier.System {self.name} {self.params}>"


class Forcing:
    """A forcing f(t) of the core by name, e.g. ``Forcing("cosine", amplitude=0.08)``, or a composite one with its
    terms: ``Forcing("sum", terms=[Forcing("cosine"), Forcing("cosine", omega=2)])``,
    ``Forcing("ramp", base=Forcing("cosine"))``. ``forcing(t)`` evaluates it at an array of times."""

    def __init__(self, name, /, *, terms=None, base=None, plugin_paths=(), **params):
        if terms is not None and base is not None:
            raise ValueError("terms, base: give one of them (base is a single term)")
        given = [base] if base is not None else list(terms) if terms is not None else []
        for k, term in enumerate(given):
            if not isinstance(term, Forcing):
                raise TypeError(f"{'base' if base is not None else f'terms[{k}]'}: a Forcing, not "
                                f"{type(term).__name__}")
        text, paths = _params_text(params), _plugin_paths(plugin_paths)
        self._native = _native.make_forcing(_name(name, "forcing"), text, [t._native for t in given], paths)
        self._arguments = (_name(name, "forcing"), None if terms is None else given, base, paths, json.loads(text))
        self._spec, self._plugin_paths = {"plugin": _name(name, "forcing"), "params": json.loads(text)}, paths
        if base is not None:
            self._spec["base"] = base._spec
        elif given:
            self._spec["terms"] = [t._spec for t in given]
        for term in given:
            self._plugin_paths = self._plugin_paths + [p for p in term._plugin_paths if p not in self._plugin_paths]

    @property
    def name(self):
        """The plugin's name."""
        return self._native.name

    @property
    def parameters(self):
        """The parameter schema: a list of dicts (name, type, default, min, max, unit, doc)."""
        return _schema(self._native.schema)

    @property
    def params(self):
        """The parameter values in use, defaults filled in (a composite: {"params": ..., "terms": [...]})."""
        return json.loads(self._native.params)

    def __call__(self, t):
        """f at the times ``t`` (a number or an array): a float or an array of t's shape."""
        scalar = np.ndim(t) == 0
        times = _real_array(t, "t", allow_nan=True).reshape(-1)
        values = self._native.evaluate(times)
        return float(values[0]) if scalar else values.reshape(np.shape(t))

    def __reduce__(self):
        return _forcing, self._arguments  # pickled as what makes it, as a System

    def __repr__(self):
        return f"<geobarrier.Forcing {self.name} {self.params}>"


def _system(name, plugin_paths, params):
    return System(name, plugin_paths=plugin_paths, **params)


def _equations_system(state, rhs, constants):
    return System.from_equations(state, rhs, constants)


def _forcing(name, terms, base, plugin_paths, params):
    return Forcing(name, terms=terms, base=base, plugin_paths=plugin_paths, **params)


def _available_bytes():
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _check_memory(name, needed):
    available = _available_bytes()
    if available is not None and needed > available:
        raise MemoryError(f"{name}: the result needs {needed / 2**30:.3g} GiB and {available / 2**30:.3g} GiB of "
                          "memory are available; pass fewer points at a time")


def _numbers(value, name):
    """`value` as a NumPy array of real numbers, not yet copied or converted: TypeError for anything else."""
    try:
        array = value if isinstance(value, np.ndarray) else np.asarray(value)
    except (ValueError, TypeError) as e:
        raise TypeError(f"{name}: not an array of numbers ({e})") from None
    if array.dtype.kind not in "fiu":
        raise TypeError(f"{name}: expected real numbers (float64), got an array of dtype {array.dtype}")
    return array


def _real_array(value, name, allow_nan=False):
    """`value` as a float64 C-contiguous array (a copy when it is not one already); TypeError for a non-real
    dtype, ConfigError for NaN or Inf (unless allowed)."""
    array = _numbers(value, name)
    _check_memory(name, array.size * 8)
    array = np.ascontiguousarray(array, dtype=np.float64)
    if not allow_nan and array.size and not np.isfinite(array).all():
        index = tuple(int(i) for i in np.argwhere(~np.isfinite(array))[0])
        raise ConfigError(f"{name}: {name}[{', '.join(map(str, index))}] is {array[index]!r}; every value must be "
                          "finite", name)
    return array


def _real(value, name, nonzero=False):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected a real number, got {type(value).__name__}")
    value = float(value)
    if not math.isfinite(value):
        raise ConfigError(f"{name}: {value!r} is not finite", name)
    if nonzero and value == 0.0:
        raise ConfigError(f"{name}: must not be 0 (the integration time)", name)
    return value


def _threads(threads):
    if threads is None:
        return 0
    if isinstance(threads, bool) or not isinstance(threads, numbers.Integral):
        raise TypeError(f"threads: expected an int or None, got {type(threads).__name__}")
    if not 1 <= threads <= _native.max_threads:
        raise ConfigError(f"threads: {threads} worker threads asked for; give 1 to {_native.max_threads} "
                          "(or None: one per core)", "threads")
    return int(threads)


def flow_map(system, points, t0, t1, *, forcing=None, derivative=False, log_det=False, quality="standard",
             threads=None):
    """The flow map F(x0) of ``system`` from t0 to t1 (t1 < t0: backward) at the initial states ``points``, on the
    engine of ``geobarrier run`` with the integrator of the quality preset ("draft", "standard", "publication"; as
    an experiment without an "integrator" section). Returns the final states, an (N, n) float64 array (n the
    system's dimension), or with ``derivative=True`` the pair (states, DF) with DF the (N, n, n) gradient of the
    flow map from the variational equations (DF[k, i, j] = d F_i / d x_j at point k; it needs the system's Jacobian),
    and with ``log_det=True`` too the triple (states, DF, log_det): log|det DF| (N,) by Liouville's formula, the
    integral of the divergence along the trajectory, which cauchy_green(DF, log_det=...) uses for the smallest
    eigenvalue as the program does.
    A masked trajectory (it blew up, hit the step limit, left the system's domain) has NaN in its row.

    points     (N, n) array of initial states, or one state (n,) (then the results have no N axis); any real dtype,
               converted to float64 (non-contiguous arrays are copied); NaN and Inf are refused;
    forcing    a Forcing, or None: f = 0 (the experiment format's "none");
    threads    worker threads for this call (None: OpenMP's default, all cores).

    Bit for bit the numbers ``geobarrier run`` computes for the same initial states when they are passed in the same
    order as the run's grid points (row by row): points are integrated in lockstep batches of 64 neighbours in the
    array, and a preset's checked fixed steps are refined per batch where a step fails its error test. The GIL is
    released; Ctrl-C in the main thread raises KeyboardInterrupt.
    """
    if not isinstance(system, System):
        raise TypeError(f"system: expected a geobarrier.System, got {type(system).__name__}")
    if forcing is None:
        forcing = _none_forcing()
    elif not isinstance(forcing, Forcing):
        raise TypeError(f"forcing: expected a geobarrier.Forcing or None, got {type(forcing).__name__}")
    if not isinstance(quality, str):
        raise TypeError(f"quality: expected one of {', '.join(_QUALITIES)}, got {type(quality).__name__}")
    if quality not in _QUALITIES:
        raise ConfigError(f"quality: {quality!r} is not one of {', '.join(_QUALITIES)}", "quality")
    for name, flag in (("derivative", derivative), ("log_det", log_det)):
        if not isinstance(flag, (bool, np.bool_)):
            raise TypeError(f"{name}: expected True or False, got {type(flag).__name__}")
    if log_det and not derivative:
        raise ConfigError("log_det: True needs derivative=True (it comes with DF)", "log_det")
    t0, t1 = _real(t0, "t0"), _real(t1, "t1")
    if t0 == t1:
        raise ConfigError(f"t1: equals t0 ({t0!r}); give an interval of non-zero length", "t1")
    threads = _openmp.parallel_threads(_threads(threads))
    n = system.dimension
    points = _numbers(points, "points")
    shape = points.shape
    single = len(shape) == 1
    if len(shape) not in (1, 2) or shape[-1] != n:
        raise ConfigError(f"points: shape {tuple(shape)}; system '{system.name}' has dimension {n}, so give an "
                          f"array of shape (N, {n}) or one state of shape ({n},)", "points")
    count = 1 if single else shape[0]
    if derivative and not system.has_jacobian:
        raise ConfigError(f"derivative: system '{system.name}' provides no Jacobian, which DF needs", "derivative")
    # The engine's own buffers (states, DF, a lane copy) and the results.
    _check_memory("points", count * 8 * 3 * (n + (n * n + 2 if derivative else 0)))
    array = _real_array(points, "points").reshape(count, n)
    handle_interrupt = (threading.current_thread() is threading.main_thread()
                        and signal.getsignal(signal.SIGINT) is signal.default_int_handler)
    states, dF, log_dets, _mask, _stats = _native.flow_map(system._native, forcing._native, array, t0, t1,
                                                           bool(derivative), quality, threads, handle_interrupt)
    if single:
        states = states[0]
        dF = None if dF is None else dF[0]
        log_dets = None if log_dets is None else float(log_dets[0])
    if log_det:
        return states, dF, log_dets
    return (states, dF) if derivative else states


_NONE = []


def _none_forcing():
    if not _NONE:
        _NONE.append(Forcing("none"))
    return _NONE[0]


def _tensors(value, name):
    """(array (N, n, n), single) of gradients or tensors; NaN and Inf are allowed (masked points give NaN)."""
    value = _numbers(value, name)
    shape = value.shape
    if len(shape) not in (2, 3) or shape[-1] != shape[-2] or not 2 <= shape[-1] <= 64:
        raise ConfigError(f"{name}: shape {tuple(shape)}; expected (N, n, n) or (n, n) with 2 <= n <= 64", name)
    array = _real_array(value, name, allow_nan=True)
    single = array.ndim == 2
    return array.reshape(-1, shape[-1], shape[-1]), single


class CauchyGreen:
    """What cauchy_green() returns: ``C`` (N, n, n) = DFᵀDF, ``eigenvalues`` (N, n) ascending, ``eigenvectors``
    (N, n, n) unit, column i for eigenvalue i (numpy.linalg.eigh's layout; for n = 2 the columns are xi1 and xi2 of
    the paper, xi2 = Omega xi1), and ``ftle`` (N,) when T was given (else None). Without an N axis for one DF."""

    def __init__(self, C, eigenvalues, eigenvectors, ftle):
        self.C, self.eigenvalues, self.eigenvectors, self.ftle = C, eigenvalues, eigenvectors, ftle

    def __repr__(self):
        return f"<geobarrier.CauchyGreen of {self.C.shape[0] if self.C.ndim == 3 else 1} point(s)>"


def cauchy_green(DF, T=None, *, log_det=None):
    """The Cauchy–Green strain tensor C = DFᵀDF of each gradient in ``DF`` ((N, n, n) or (n, n), e.g. from
    flow_map(..., derivative=True)) with its eigenvalues and eigenvectors, computed as the core computes its fields:
    for n = 2 lambda2 from the dominant root and lambda1 = det(DF)² / lambda2 (no cancellation), xi1 rotated from xi2;
    for n > 2 from the singular value decomposition of DF. With ``T`` (the integration time t1 - t0), also the FTLE.
    With ``log_det`` (log|det DF| per gradient, from flow_map(..., log_det=True); zeros for an area-preserving flow)
    the smallest eigenvalue comes from it, as in the program's fields: det DF from the entries loses digits where DF
    stretches strongly (lambda1 off by percents where lambda2 ~ 1e8). A DF with NaN or Inf entries (a masked point)
    gives NaN. Returns a CauchyGreen."""
    array, single = _tensors(DF, "DF")
    if log_det is not None:
        log_det = _real_array(log_det, "log_det", allow_nan=True).reshape(-1)
        if log_det.shape != (array.shape[0],):
            raise ConfigError(f"log_det: {log_det.size} values for {array.shape[0]} gradients", "log_det")
    duration = None if T is None else _real(T, "T", nonzero=True)
    _openmp.parallel_threads(0)  # OpenMP's default count: noted for forks (one thread in a child, _openmp.py)
    C, eigenvalues, eigenvectors = _native.cauchy_green(array, log_det)
    ftle_values = None if duration is None else _native.ftle_of_gradients(array, duration)
    if single:
        C, eigenvalues, eigenvectors = C[0], eigenvalues[0], eigenvectors[0]
        ftle_values = None if ftle_values is None else ftle_values[0]
    return CauchyGreen(C, eigenvalues, eigenvectors, ftle_values)


def ftle(F, T, *, of="DF"):
    """The finite-time Lyapunov exponent log(lambda_max(C)) / (2|T|) of each gradient DF (``of="DF"``, the
    default: C = DFᵀDF) or Cauchy–Green tensor C (``of="C"``) in ``F``, (N, n, n) or (n, n); T is the integration
    time t1 - t0 (non-zero). From DF the core's own code computes it: for n = 2 the same numbers, bit for bit, as
    ``geobarrier run``'s ftle field for the same DF. NaN where F has NaN or Inf entries. Returns (N,) or a float."""
    if of not in ("DF", "C"):
        raise ConfigError(f"of: {of!r} is not \"DF\" or \"C\"", "of")
    array, single = _tensors(F, "F")
    duration = _real(T, "T", nonzero=True)
    _openmp.parallel_threads(0)  # as in cauchy_green
    values = (_native.ftle_of_gradients if of == "DF" else _native.ftle_of_tensors)(array, duration)
    return float(values[0]) if single else values


def not_fields_message(fields):
    """What a TypeError says of a ``fields`` argument that is neither an xarray Dataset nor a Fields, with the fix for
    the two mistakes a user makes: a Result (its .fields is meant) and the path of fields.nc (not opened)."""
    hint = ""
    if hasattr(fields, "fields") and hasattr(fields, "barriers"):
        hint = " (a run's Result: pass result.fields)"
    elif isinstance(fields, (str, bytes, os.PathLike)):
        hint = " (a path: open fields.nc with xarray.open_dataset(path) and pass the Dataset)"
    return (f"fields: expected an xarray.Dataset (variables over coordinates y, x) or the fields of a run, got "
            f"{type(fields).__name__}{hint}")


def _field_arrays(fields):
    """(attrs, {name: (ny, nx) float64 array}, mask or None, x, y) of an xarray Dataset or a geobarrier.Fields."""
    if hasattr(fields, "data_vars"):  # xarray.Dataset
        values = {str(n): np.asarray(fields[n].values) for n in fields.data_vars}
        x = np.asarray(fields["x"].values) if "x" in fields.coords else None
        y = np.asarray(fields["y"].values) if "y" in fields.coords else None
    elif hasattr(fields, "variable_attrs") and hasattr(fields, "keys"):  # geobarrier.Fields
        values = {n: np.asarray(fields[n]) for n in fields.keys()}
        x, y = np.asarray(fields.x), np.asarray(fields.y)
    else:
        raise TypeError(not_fields_message(fields))
    mask = values.pop("mask", None)
    if mask is not None:
        if mask.dtype.kind not in "iu":
            raise TypeError(f"fields: the mask is of dtype {mask.dtype}, expected unsigned integers (MaskBits)")
        mask = np.ascontiguousarray(mask, dtype=np.uint8)
    arrays = {}
    for name, value in values.items():
        if value.dtype.kind in "fiu" and value.ndim == 2:
            arrays[name] = np.ascontiguousarray(value, dtype=np.float64)
    return dict(getattr(fields, "attrs", {})), arrays, mask, x, y


def _axis(values, name):
    """(min, max, n) of an evenly spaced coordinate, as an experiment's grid gives it."""
    if values is None or values.ndim != 1 or values.size < 3 or values.dtype.kind not in "fiu":
        raise ConfigError(f"fields: no coordinate {name} of 3 or more numbers", "fields")
    values = values.astype(np.float64)
    step = (values[-1] - values[0]) / (values.size - 1)
    if not np.isfinite(values).all() or not step > 0 or \
            not np.allclose(np.diff(values), step, rtol=1e-9, atol=0):
        raise ConfigError(f"fields: the coordinate {name} is not increasing in even steps (a grid's)", "fields")
    return [float(values[0]), float(values[-1])], int(values.size)


def _experiment_of(fields_attrs, x, y, system, forcing, t0, t1, quality):
    """The experiment the extractor runs in: fields' own ("experiment" attribute), or one made of the system and
    forcing given, over the fields' coordinates."""
    if system is None:
        try:
            experiment = json.loads(fields_attrs["experiment"])
            if not isinstance(experiment, dict):
                raise ValueError
        except (KeyError, TypeError, ValueError):
            raise ConfigError("system: the fields have no \"experiment\" attribute (the resolved experiment a run "
                              "writes into its "
                              "fields and fields.nc): give the system (and forcing, t0, t1) the fields belong to",
                              "system") from None
        # The experiment as written, with its echo-only keys dropped.
        experiment.pop("validation", None)
        experiment.get("integrator", {}).pop("fixed_steps", None)
        experiment.get("system", {}).pop("compiled", None)
        experiment["time"] = {k: v for k, v in experiment.get("time", {}).items() if k in ("t0", "t1")}
        return experiment
    if not isinstance(system, System):
        raise TypeError(f"system: expected a geobarrier.System, got {type(system).__name__}")
    if forcing is not None and not isinstance(forcing, Forcing):
        raise TypeError(f"forcing: expected a geobarrier.Forcing or None, got {type(forcing).__name__}")
    if system.dimension != 2:
        raise ConfigError(f"system: '{system.name}' has dimension {system.dimension}; barriers() on given fields "
                          "takes planar systems", "system")
    times = {}
    for name, value in (("t0", t0), ("t1", t1)):
        value = fields_attrs.get(name) if value is None else value
        if value is None:
            raise ConfigError(f"{name}: the fields do not say it; give {name}", name)
        times[name] = _real(value.item() if hasattr(value, "item") else value, name)
    if times["t0"] == times["t1"]:
        raise ConfigError(f"t1: equals t0 ({times['t0']!r})", "t1")
    if quality not in _QUALITIES:
        raise ConfigError(f"quality: {quality!r} is not one of {', '.join(_QUALITIES)}", "quality")
    (x_range, nx), (y_range, ny) = _axis(x, "x"), _axis(y, "y")
    experiment = {"system": system._spec, "grid": {"x": x_range, "y": y_range, "n": [nx, ny]}, "time": times,
                  "quality": quality}
    paths = list(system._plugin_paths)
    if forcing is not None:
        experiment["forcing"] = forcing._spec
        paths += [p for p in forcing._plugin_paths if p not in paths]
    if paths:
        experiment["plugin_paths"] = paths
    return experiment


def barriers(fields, extractor="hyperbolic", *, system=None, forcing=None, t0=None, t1=None, quality="standard",
             candidates=False, threads=None, plugin_paths=(), **params):
    """Runs one barrier extractor ("hyperbolic", "elliptic", "parabolic" or a plugin's name) with its parameters
    on fields computed before, and returns a Barriers list, or with ``candidates=True`` the pair (barriers,
    candidates).

    From a run: ``result.fields`` (xarray.Dataset or geobarrier.Fields) or fields.nc opened with xarray carry the
    experiment they were computed with (the "experiment" attribute): its grid, time interval, system, forcing and
    integrator are the extractor's, for the curves it advects, so a run's fields give that run's barriers.

    From elsewhere: an xarray.Dataset of (y, x) variables over evenly spaced coordinates x and y (3 or more each),
    with ``system`` (a planar geobarrier.System), ``forcing``, ``t0``, ``t1`` (unless the Dataset's attributes say
    them) and ``quality`` (the integrator of the advected curves). A "mask" variable (MaskBits) is optional; without
    one, points where a field is NaN are masked.

    The fields must hold the extractor's required fields, by the names of fields.nc: lambda1, lambda2, xi1_x, xi1_y,
    ftle (the products "eigenvalues", "eigenvectors", "ftle"), and for the hyperbolic extractor strain_deviation, with
    exit_time where trajectories could leave bounds (without it nothing exits; its NaN, "stays", masks nothing)."""
    from ._barriers import Barrier, Barriers

    attrs, arrays, mask, x, y = _field_arrays(fields)
    if not isinstance(extractor, str):
        raise TypeError(f"extractor: an extractor plugin's name is a str, not {type(extractor).__name__}")
    experiment = _experiment_of(attrs, x, y, system, forcing, t0, t1, quality)
    experiment["products"] = ["ftle"]
    experiment["extractors"] = [{"plugin": extractor, "params": json.loads(_params_text(params))}]
    experiment["output"] = {"dir": "unused", "plots": False}
    paths = _plugin_paths(plugin_paths)
    if paths:
        experiment["plugin_paths"] = list(experiment.get("plugin_paths", [])) + paths
    if mask is None:
        shape = next(iter(arrays.values())).shape if arrays else (0, 0)
        mask = np.zeros(shape, dtype=np.uint8)
        for name, value in arrays.items():
            # exit_time is NaN where a trajectory stayed within the bounds: data, not a failure.
            if value.shape == shape and name != "exit_time":
                mask[~np.isfinite(value)] |= 2  # mask_non_finite (fields.nc's flag_masks)
    handle_interrupt = (threading.current_thread() is threading.main_thread()
                        and signal.getsignal(signal.SIGINT) is signal.default_int_handler)
    threads = _openmp.parallel_threads(_threads(threads))
    try:
        found, others = _native.extract_barriers(json.dumps(experiment), mask, arrays, threads, handle_interrupt)
    except ConfigError as e:
        # Settings by their Python names: "/extractors/0/params/x" is x, the extractor's plugin "extractor", the
        # system's parameters "/system/params/a" are the System's (as System() names them: "/a").
        for prefix, name in (("/extractors/0/params", ""), ("/extractors/0/plugin", "extractor"),
                             ("/extractors/0", "extractor"), ("/grid", "fields"), ("/time/t0", "t0"),
                             ("/time/t1", "t1"), ("/time", "t1")):
            if e.path.startswith(prefix):
                where = name + e.path[len(prefix):]
                raise ConfigError(where + str(e)[str(e).index(": "):], where) from None
        raise
    result = Barriers(Barrier(b) for b in json.loads(found))
    if candidates:
        return result, Barriers(Barrier(b) for b in json.loads(others))
    return result
