"""Type stubs of geobarrier's native part (python/src/bindings.cpp). Use the geobarrier package instead: these are
the calls it makes, with the experiment as JSON text and the results as JSON text and NumPy arrays."""

from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

_ProgressCallback = Callable[[str, int, int], object]

version: str
max_threads: int

def run(text: str, file: str, out: Optional[str], write: bool, threads: int,
        progress: Optional[_ProgressCallback], handle_interrupt: bool) -> Dict[str, Any]:
    """Runs an experiment given as JSON text (or, with text "", the file `file`); the result's "fields",
    "coordinates", "mask", "attributes", "barriers", "candidates", "manifest", "output_dir" and "files"; for
    "directions": "both" also "directions" ({"forward": ..., "backward": ...}, each such a dict) and "tangle"
    (tangle.json as JSON text)."""
def validate(text: str, file: str) -> str:
    """Checks an experiment; the summary as JSON text."""
def set_default_threads(threads: int) -> None:
    """The OpenMP thread count of the calling thread's later parallel regions (1 in a fork child, _openmp.py)."""
def plugins(extra_folders: List[str]) -> str:
    """The plugins found, as JSON text (geobarrier plugins --json)."""
def set_log_level(level: str) -> None:
    """The core's log level on stderr: "debug", "info", "warning", "error" or "off"."""
def mask_attributes() -> Dict[str, Union[str, List[int]]]:
    """fields.nc's mask variable attributes: flag_masks, flag_meanings, long_name."""
def make_system(name: str, params: str, plugin_paths: List[str]) -> Any:
    """A system plugin by name or file with its parameters (JSON text): an opaque _System."""
def make_equations_system(params: str) -> Any:
    """The "equations" system from its parameters (JSON text: state, rhs, constants): an opaque _System."""
def make_forcing(name: str, params: str, terms: List[Any], plugin_paths: List[str]) -> Any:
    """A forcing plugin by name with its parameters (JSON text) and a composite's terms: an opaque _Forcing."""
def flow_map(system: Any, forcing: Any, points: npt.NDArray[np.float64], t0: float, t1: float, derivative: bool,
             quality: str, threads: int, handle_interrupt: bool) -> Tuple[npt.NDArray[np.float64],
                                                                         Optional[npt.NDArray[np.float64]],
                                                                         Optional[npt.NDArray[np.float64]],
                                                                         npt.NDArray[np.uint8], str]:
    """Final states (N, n), DF (N, n, n) and log|det DF| (N,) or None, the mask (N,) and the integrator statistics
    (JSON text)."""
def ftle_of_gradients(DF: npt.NDArray[np.float64], T: float) -> npt.NDArray[np.float64]:
    """The FTLE of each gradient of an (N, n, n) array over |T|."""
def ftle_of_tensors(C: npt.NDArray[np.float64], T: float) -> npt.NDArray[np.float64]:
    """The FTLE of each Cauchy-Green tensor of an (N, n, n) array over |T|."""
def cauchy_green(DF: npt.NDArray[np.float64], log_det: Optional[npt.NDArray[np.float64]]
                 ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """C = DF^T DF (N, n, n), its eigenvalues (N, n) ascending and eigenvectors (N, n, n; column i for eigenvalue i)."""
def extract_barriers(experiment: str, mask: npt.NDArray[np.uint8], fields: Dict[str, npt.NDArray[np.float64]],
                     threads: int, handle_interrupt: bool) -> Tuple[str, str]:
    """One extractor on given fields with the experiment they came from: barriers and candidates as JSON text."""
