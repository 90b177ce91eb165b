"""Type stubs of the geobarrier package (docs/python.md). Checked by tests/python/test_stubs.py: every public name
of the package is here and every name here is in the package, with the same signatures, and mypy passes on the
examples against them."""

import os
from typing import (Any, Callable, Dict, Iterator, KeysView, List, Literal, Mapping, Optional, Sequence, Tuple, Union,
                    overload)

import numpy as np
import numpy.typing as npt

__version__: str
__all__ = ["run", "validate", "plugins", "set_log_level", "plot", "Result", "BothDirections", "Barrier", "Barriers",
           "Fields", "Error", "ConfigError", "PluginError", "NumericalError", "IoError", "ProgressLine", "ProgressBar",
           "flow_map", "cauchy_green", "ftle", "barriers", "System", "Forcing", "CauchyGreen"]

_Experiment = Union[Dict[str, Any], str, "os.PathLike[str]"]
_ProgressCallback = Callable[[str, int, int], object]
_Figure = Union[int, float, bool, str, None, List[Any], Dict[str, Any]]
_Path = Union[str, "os.PathLike[str]"]
_Quality = Literal["draft", "standard", "publication"]
_Array = npt.NDArray[np.float64]

class Error(Exception):
    """A geobarrier error: the computation failed (a plugin, a numerical stage, a file)."""

class ConfigError(Error, ValueError):
    """Bad input in an experiment; ``path`` is the JSON path (or "file:line:col"), ``file`` the experiment file."""
    file: str
    path: str
    def __init__(self, message: str, where: str = ...) -> None: ...

class PluginError(Error):
    """A plugin that cannot be loaded or that failed a call."""

class NumericalError(Error):
    """A numerical stage that cannot give a trustworthy answer."""

class IoError(Error, OSError):
    """An input or output file that cannot be read or written."""

class Fields:
    """A run's fields as NumPy arrays (without xarray): ``fields.ftle`` or ``fields["ftle"]`` is (ny, nx)."""
    x: npt.NDArray[np.float64]
    y: npt.NDArray[np.float64]
    variable_attrs: Dict[str, Dict[str, Any]]
    attrs: Dict[str, Any]
    coordinate_attrs: Dict[str, Dict[str, Any]]
    def __init__(self, x: npt.NDArray[np.float64], y: npt.NDArray[np.float64], variables: Dict[str, npt.NDArray[Any]],
                 variable_attrs: Dict[str, Dict[str, Any]], attrs: Dict[str, Any]) -> None: ...
    def __getattr__(self, name: str) -> npt.NDArray[Any]: ...
    def __getitem__(self, name: str) -> npt.NDArray[Any]: ...
    def __contains__(self, name: object) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> KeysView[str]: ...

class Barrier:
    """One barrier (or candidate): ``points`` (n, 2) at t0, ``kind``, ``closed``, ``extractor`` and typed figures in
    ``attributes`` (counts as int), also ``barrier["length"]`` or ``barrier.length``."""
    kind: str
    closed: bool
    extractor: str
    points: npt.NDArray[np.float64]
    attributes: Dict[str, _Figure]
    def __init__(self, record: Mapping[str, Any]) -> None: ...
    @property
    def x(self) -> npt.NDArray[np.float64]: ...
    @property
    def y(self) -> npt.NDArray[np.float64]: ...
    def __len__(self) -> int: ...
    def __getitem__(self, name: str) -> Any: ...
    def __getattr__(self, name: str) -> Any: ...
    def to_dict(self) -> Dict[str, _Figure]: ...
    def plot(self, ax: Optional[Any] = ..., **kwargs: Any) -> Any: ...

class Barriers(List[Barrier]):
    """A list of Barrier with to_dataframe() (pandas) and plot()."""
    def to_dataframe(self) -> Any: ...
    def plot(self, ax: Optional[Any] = ..., **kwargs: Any) -> Any: ...

class Result:
    """What run() returns."""
    fields: Any  # an xarray.Dataset, or Fields with xarray=False (xarray has no type information in Debian 12)
    barriers: Barriers
    candidates: Barriers
    manifest: Dict[str, Any]
    warnings: List[Any]
    output_dir: Optional[str]
    files: List[str]
    def __init__(self, native: Dict[str, Any], use_xarray: bool = ...) -> None: ...
    def plot(self, variable: str = ..., *, ax: Optional[Any] = ..., candidates: bool = ..., **kwargs: Any) -> Any: ...
    def to_dataframe(self, candidates: bool = ...) -> Any: ...

class BothDirections(Result):
    """What run() returns for "directions": "both": both directions' barriers, a Result per direction, the tangle."""
    forward: Result
    backward: Result
    tangle: Dict[str, Any]
    crossings: List[Dict[str, Any]]
    def __init__(self, native: Dict[str, Any], use_xarray: bool = ...) -> None: ...
    def plot(self, variable: str = ..., *, ax: Optional[Any] = ..., candidates: bool = ...,
             direction: Literal["forward", "backward"] = ..., crossings: bool = ..., **kwargs: Any) -> Any: ...

class ProgressLine:
    """The text progress line on stderr: progress(stage, done, total)."""
    width: int
    def __init__(self, stream: Optional[Any] = ...) -> None: ...
    def __call__(self, stage: str, done: int, total: int) -> None: ...
    def close(self, completed: bool = ...) -> None: ...

class ProgressBar:
    """One tqdm bar per stage: ProgressBar(tqdm.tqdm) or ProgressBar(tqdm.notebook.tqdm)."""
    tqdm_class: Callable[..., Any]
    def __init__(self, tqdm_class: Callable[..., Any]) -> None: ...
    def __call__(self, stage: str, done: int, total: int) -> None: ...
    def close(self, completed: bool = ...) -> None: ...

def run(experiment: _Experiment, out: Union[str, "os.PathLike[str]", None] = ..., *, write: Optional[bool] = ...,
        threads: Optional[int] = ..., progress: Union[bool, None, _ProgressCallback] = ..., flow_map: bool = ...,
        xarray: bool = ...) -> Result:
    """Runs an experiment (a dict or the path of an experiment file) and returns a Result."""
def validate(experiment: _Experiment) -> Dict[str, Any]:
    """Checks an experiment completely and computes nothing; a summary dict."""
def plugins(plugin_paths: Union[_Path, Sequence[_Path]] = ...) -> List[Dict[str, Any]]:
    """The plugins found, each a dict with its parameter schema."""
def set_log_level(level: Literal["debug", "info", "warning", "error", "off", "DEBUG", "INFO", "WARNING", "ERROR",
                                 "OFF"]) -> None:
    """The core's log level on stderr."""
def plot(fields: Any, barriers: Sequence[Barrier] = ..., *, variable: str = ..., ax: Optional[Any] = ...,
         candidates: Sequence[Barrier] = ..., colorbar: bool = ..., cmap: Any = ..., aspect: Any = ...,
         barrier_kwargs: Optional[Dict[str, Any]] = ..., **kwargs: Any) -> Any:
    """Draws one field with barriers over it; returns the matplotlib Axes."""

class System:
    """A dynamical system of the core: a plugin by name or file, or equations (System.from_equations)."""
    def __init__(self, name: _Path, /, *, plugin_paths: Union[_Path, Sequence[_Path]] = ..., **params: Any) -> None: ...
    @classmethod
    def from_equations(cls, state: Sequence[str], rhs: Sequence[str],
                       constants: Optional[Mapping[str, float]] = ...) -> "System":
        """A system written as equations (the experiment format's "equations" system)."""
    @property
    def name(self) -> str: ...
    @property
    def dimension(self) -> int: ...
    @property
    def state_names(self) -> List[str]: ...
    @property
    def has_jacobian(self) -> bool: ...
    @property
    def uses_forcing(self) -> bool: ...
    @property
    def parameters(self) -> List[Dict[str, Any]]: ...
    @property
    def params(self) -> Dict[str, Any]: ...

class Forcing:
    """A forcing f(t) of the core by name; a composite one (sum, ramp) with its terms or base."""
    def __init__(self, name: _Path, /, *, terms: Optional[Sequence["Forcing"]] = ..., base: Optional["Forcing"] = ...,
                 plugin_paths: Union[_Path, Sequence[_Path]] = ..., **params: Any) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def parameters(self) -> List[Dict[str, Any]]: ...
    @property
    def params(self) -> Dict[str, Any]: ...
    @overload
    def __call__(self, t: float) -> float: ...
    @overload
    def __call__(self, t: npt.ArrayLike) -> Any: ...

class CauchyGreen:
    """What cauchy_green() returns: C, eigenvalues (ascending), eigenvectors (columns), ftle (None without T)."""
    C: _Array
    eigenvalues: _Array
    eigenvectors: _Array
    ftle: Any
    def __init__(self, C: _Array, eigenvalues: _Array, eigenvectors: _Array, ftle: Any) -> None: ...

@overload
def flow_map(system: System, points: npt.ArrayLike, t0: float, t1: float, *, forcing: Optional[Forcing] = ...,
             derivative: Literal[False] = ..., log_det: Literal[False] = ..., quality: _Quality = ...,
             threads: Optional[int] = ...) -> _Array:
    """The final states (N, n) of the points integrated from t0 to t1; with derivative=True also DF (N, n, n), and
    with log_det=True also log|det DF| (N,)."""
@overload
def flow_map(system: System, points: npt.ArrayLike, t0: float, t1: float, *, forcing: Optional[Forcing] = ...,
             derivative: Literal[True], log_det: Literal[False] = ..., quality: _Quality = ...,
             threads: Optional[int] = ...) -> Tuple[_Array, _Array]: ...
@overload
def flow_map(system: System, points: npt.ArrayLike, t0: float, t1: float, *, forcing: Optional[Forcing] = ...,
             derivative: Literal[True], log_det: Literal[True], quality: _Quality = ...,
             threads: Optional[int] = ...) -> Tuple[_Array, _Array, Any]: ...
@overload
def flow_map(system: System, points: npt.ArrayLike, t0: float, t1: float, *, forcing: Optional[Forcing] = ...,
             derivative: bool, log_det: bool = ..., quality: _Quality = ...,
             threads: Optional[int] = ...) -> Union[_Array, Tuple[_Array, _Array], Tuple[_Array, _Array, Any]]: ...
def cauchy_green(DF: npt.ArrayLike, T: Optional[float] = ..., *, log_det: Optional[npt.ArrayLike] = ...) -> CauchyGreen:
    """C = DF^T DF of each gradient with its eigenvalues and eigenvectors (and the FTLE with T)."""
def ftle(F: npt.ArrayLike, T: float, *, of: Literal["DF", "C"] = ...) -> Any:
    """The FTLE of each gradient DF (or tensor C with of="C") over the time T: (N,) or a float."""
@overload
def barriers(fields: Any, extractor: str = ..., *, system: Optional[System] = ..., forcing: Optional[Forcing] = ...,
             t0: Optional[float] = ..., t1: Optional[float] = ..., quality: _Quality = ...,
             candidates: Literal[False] = ..., threads: Optional[int] = ...,
             plugin_paths: Union[_Path, Sequence[_Path]] = ..., **params: Any) -> Barriers:
    """One extractor on a run's fields (or fields.nc's, or given fields with their system); Barriers, or
    (barriers, candidates) with candidates=True."""
@overload
def barriers(fields: Any, extractor: str = ..., *, system: Optional[System] = ..., forcing: Optional[Forcing] = ...,
             t0: Optional[float] = ..., t1: Optional[float] = ..., quality: _Quality = ...,
             candidates: Literal[True], threads: Optional[int] = ...,
             plugin_paths: Union[_Path, Sequence[_Path]] = ..., **params: Any) -> Tuple[Barriers, Barriers]: ...
