"""Type stubs of the native module (python/src/lib.rs)."""

from typing import Any, Callable, Dict, List, Optional, Tuple

__version__: str
DEFAULT_PRECISION: int

class StatoptError(Exception): ...

class InputError(StatoptError):
    file: Optional[str]
    line: Optional[int]
    element: Optional[str]
    reason: str

_TableParts = Tuple[str, List[str], bytes, bytes, bool, List[Tuple[str, str]]]

def run(
    setup: str,
    text: Optional[str] = None,
    results_dir: Optional[str] = None,
    precision: Optional[int] = None,
    threads: Optional[int] = None,
    reduce: bool = False,
    resume: bool = False,
    sync: bool = False,
    progress: Optional[Callable[[str, int, int], Any]] = None,
    allow_unknown: bool = False,
    in_memory: bool = False,
    external_scales: List[Tuple[str, float]] = ...,
) -> Dict[str, Any]: ...
# run's summary: ``files`` and ``keys`` (one each: the run's typed key of
# that output as a dict, setup, analysis, w0, stat, table, or None); with
# ``in_memory``, ``in_memory_root`` and ``outputs`` ((path, key, table parts
# or bytes) per output). predict_grf's likewise.
def predict_grf(
    setup: str,
    text: Optional[str] = None,
    results_dir: Optional[str] = None,
    threads: Optional[int] = None,
    progress: Optional[Callable[[str, int, int], Any]] = None,
    allow_unknown: bool = False,
    in_memory: bool = False,
) -> Dict[str, Any]: ...
def force_sweep(
    setup: str,
    candidates: List[Dict[str, Any]],
    text: Optional[str] = None,
    threads: Optional[int] = None,
    warm: bool = True,
    allow_unknown: bool = False,
    tables: Optional[List[str]] = None,
) -> Dict[str, Any]: ...
class Scene:
    frames: int
    warnings: List[str]
    def __init__(self, setup: str, text: Optional[str] = None, threads: Optional[int] = None) -> None: ...
    def run(self, candidates: List[Dict[str, Any]], warm: bool = True) -> Dict[str, Any]: ...

def read_table(path: str) -> _TableParts: ...
def read_tables(paths: List[str]) -> List[_TableParts]: ...
def write_table(
    path: str,
    name: str,
    labels: List[str],
    time: bytes,
    data: bytes,
    in_degrees: bool,
    metadata: List[Tuple[str, str]],
    precision: int,
) -> None: ...
def check(setup: str, results_dir: Optional[str] = None, reduce: bool = False,
          allow_unknown: bool = False) -> Tuple[List[str], List[str], List[str], List[str]]: ...
def parse_tables(outputs: List[Tuple[str, bytes]]) -> List[_TableParts]: ...
def single_w0_references(setup: str, text: str, values: List[str]) -> List[str]: ...
def output_name(setup: str, table: str, analysis: Optional[str] = None, w0: Optional[float] = None,
                stat: Optional[str] = None) -> str: ...
def output_tables() -> List[str]: ...
