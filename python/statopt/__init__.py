"""statopt: static optimization of muscle and frictional contact forces for
OpenSim models (Krüger & Wartzack 2017), from Python.

The engine (the Rust crate behind ``statopt-tool``) runs in-process:

>>> import statopt
>>> res = statopt.run("setups/leg_extension_cam1.xml", contact_weight=500)
>>> res.activations            # DataFrame indexed by time, OpenSim's columns
>>> statopt.sweep("setups/leg_extension_cam1.xml", {"contact_weight": [1, 500, 1000]})

See docs/python.md.
"""

from ._native import InputError, StatoptError, __version__
from ._run import FramesFailedWarning, Result, check, predict_grf, run
from ._sweep import Scene, force_sweep, summary_metrics, sweep
from ._tables import read_table, write_table

__all__ = [
    "run",
    "predict_grf",
    "sweep",
    "force_sweep",
    "Scene",
    "check",
    "read_table",
    "write_table",
    "Result",
    "summary_metrics",
    "StatoptError",
    "InputError",
    "FramesFailedWarning",
    "__version__",
]
