"""Type stubs of geobarrier's native part (python/src/bindings.cpp). Use the geobarrier package instead: these are
the calls it makes, with the experiment as JSON text and the results as JSON text and NumPy arrays."""

from typing import Any, Callable, Dict, List, Optional, Union

_ProgressCallback = Callable[[str, int, int], object]

version: str
max_threads: int

def run(text: str, file: str, out: Optional[str], write: bool, threads: int,
        progress: Optional[_ProgressCallback], handle_interrupt: bool) -> Dict[str, Any]:
    """Runs an experiment given as JSON text (or, with text "", the file `file`); the result's "fields",
    "coordinates", "mask", "attributes", "barriers", "candidates", "manifest", "output_dir" and "files"."""
def validate(text: str, file: str) -> str:
    """Checks an experiment; the summary as JSON text."""
def plugins(extra_folders: List[str]) -> str:
    """The plugins found, as JSON text (geobarrier plugins --json)."""
def set_log_level(level: str) -> None:
    """The core's log level on stderr: "debug", "info", "warning", "error" or "off"."""
def mask_attributes() -> Dict[str, Union[str, List[int]]]:
    """fields.nc's mask variable attributes: flag_masks, flag_meanings, long_name."""
