"""statopt.run: a setup run in-process, its tables as DataFrames."""

from __future__ import annotations

import csv
import io
import logging
import os
import shutil
import tempfile
import threading
import uuid
import warnings
import weakref
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import pandas as pd

from . import _native
from ._setup import edit_setup, external_scales
from ._tables import _frame, read_tables

log = logging.getLogger("statopt")

class FramesFailedWarning(RuntimeWarning):
    """Some frames could not be solved (the CLI's exit status 3); their rows
    hold the solver's best point and the diagnostics table says which."""


def _key_matches(key: Optional[Dict[str, Any]], kind: str, w0: Optional[float], stat: Optional[str]) -> bool:
    """Whether a table's key (the run's own, ``statopt::storage::key``,
    handed over with the table by the binding) is of ``kind`` at ``w0`` or
    ``stat`` (neither: every run of a sweep, not its statistics)."""
    if key is None or key["table"] != kind:
        return False
    if stat is not None:
        return key["stat"] == stat
    if w0 is not None:
        return key["w0"] is not None and key["w0"] == float(w0)
    return key["stat"] is None


class Result:
    """What a run produced.

    Tables are DataFrames indexed by time with OpenSim's column names:
    ``activations``, ``forces``, ``diagnostics``, ``contact_forces``,
    ``contact_body_forces``, ``generalized_forces``, ``muscle_power``,
    ``reactions``. A run of several contact weights gives each of these with
    a (w0, time) MultiIndex; :meth:`table` picks one w0 or a statistic of
    the sweep. ``tables`` holds every table by its file's stem, ``summary``
    the run summary (frames, solves, failed, worst_residual, warnings, ...),
    ``metrics`` the setup's ``<Metric>`` values, ``files`` the paths written
    (empty unless ``results_dir`` was given). Tables are read when first used
    (a run without ``results_dir`` hands them over in memory: no file).
    """

    def __init__(self, setup: str, summary: Dict[str, Any], table_files: List[Tuple[str, Path]],
                 metrics: Dict[str, float], files: List[str], scratch: Optional[Path] = None,
                 keys: Optional[List[Optional[Dict[str, Any]]]] = None,
                 kept: Optional[Dict[str, Any]] = None):
        self.setup = setup
        self.summary = summary
        self.metrics = metrics
        self.files = files
        self._table_files = table_files
        # Per table (by its key in ``tables``): the run's typed key of it
        # (setup, analysis, w0, stat, table; the binding's ``keys``), or
        # None (a file no key names; every table the engine writes has one).
        self._keys: Dict[str, Optional[Dict[str, Any]]] = {
            k: key for (k, _), key in zip(table_files, keys or [None] * len(table_files))
        }
        # The outputs of a run kept in memory, by normalised path: a table
        # as its parts (the engine's values), any other output as bytes.
        self._kept = kept
        self._tables: Optional[Dict[str, pd.DataFrame]] = None
        self._lock = threading.Lock()
        # The temporary results folder lives until the tables are read (or
        # this result is dropped).
        self._cleanup = weakref.finalize(self, shutil.rmtree, str(scratch), True) if scratch else None

    @property
    def tables(self) -> Dict[str, pd.DataFrame]:
        """Every table of the run by its file's stem; read (in parallel, with
        the crate's reader) when first used."""
        with self._lock:
            if self._tables is None:
                try:
                    if self._kept is not None:
                        # Tables come as their values; a table kept as
                        # bytes only (none the engine writes) is parsed.
                        kept = [self._kept[os.path.normpath(str(p))] for _, p in self._table_files]
                        as_bytes = [(str(p), k) for (_, p), k in zip(self._table_files, kept)
                                    if isinstance(k, bytes)]
                        parsed = iter(_native.parse_tables(as_bytes) if as_bytes else [])
                        dfs = [_frame(next(parsed) if isinstance(k, bytes) else k) for k in kept]
                        self._kept = None
                    else:
                        dfs = read_tables([p for _, p in self._table_files]) if self._table_files else []
                    self._tables = {k: df for (k, _), df in zip(self._table_files, dfs)}
                finally:
                    if self._cleanup is not None:
                        self._cleanup()
            return self._tables

    # -- summary -------------------------------------------------------
    @property
    def frames(self) -> int:
        return self.summary["frames"]

    @property
    def failed(self) -> int:
        """Static-optimization frame problems that could not be solved."""
        return self.summary["failed"]

    @property
    def ok(self) -> bool:
        return self.summary["failed"] == 0

    @property
    def warnings(self) -> List[str]:
        return self.summary["warnings"]

    # -- tables --------------------------------------------------------
    def table(self, kind: str, w0: Optional[float] = None, stat: Optional[str] = None) -> pd.DataFrame:
        """The table of one kind (the end of its file name: ``activation``,
        ``force``, ``ReactionLoads``, ``MomentArm_knee_angle_r``, ...). ``w0`` picks one contact weight of
        a sweep, ``stat`` one of its statistics (``mean``, ``min``, ``max``);
        without either every w0 of a sweep comes in one DataFrame indexed by
        (w0, time), and tables of several setups (a study) by (table, time).
        """
        found = []
        for key, df in self.tables.items():
            k = self._keys.get(key)
            if _key_matches(k, kind, w0, stat):
                found.append((key, (k["setup"], k["analysis"]), k["w0"], df))
            elif k is None and key == kind and w0 is None and stat is None:
                # A table with no key (none the engine writes): by its whole
                # name.
                found.append((key, None, None, df))
        if not found:
            raise KeyError(
                f"this run wrote no {kind} table"
                + (f" for w0 = {w0}" if w0 is not None else "")
                + (f" ({stat} over w0)" if stat else "")
                + f"; its tables: {', '.join(self.tables) or 'none'}"
            )
        if len(found) == 1:
            return found[0][3]
        runs = {f[1] for f in found}
        if len(runs) == 1 and all(f[2] is not None for f in found):
            found.sort(key=lambda f: f[2])
            return pd.concat([f[3] for f in found], keys=[f[2] for f in found],
                             names=["w0", "time"])
        return pd.concat([f[3] for f in found], keys=[f[0] for f in found], names=["table", "time"])

    activations = property(lambda self: self.table("activation"), doc="Muscle activations (and actuator controls).")
    forces = property(lambda self: self.table("force"), doc="Actuator forces.")
    diagnostics = property(lambda self: self.table("diagnostics"), doc="Solver diagnostics per frame.")
    contact_forces = property(lambda self: self.table("ContactForces"), doc="Contact forces.")
    contact_body_forces = property(lambda self: self.table("ContactBodyForces"), doc="Contact forces per body.")
    generalized_forces = property(lambda self: self.table("GeneralizedForcesBySource"),
                                  doc="Generalized forces by source (muscles, contacts, ...).")
    muscle_power = property(lambda self: self.table("MusclePower"), doc="Muscle power.")
    reactions = property(lambda self: self.table("ReactionLoads"), doc="Joint reaction loads.")
    inverse_dynamics = property(lambda self: self.table("inverse_dynamics"),
                                doc="An InverseDynamicsTool's generalized forces (its setup names the file).")

    @property
    def predicted_grf(self) -> pd.DataFrame:
        """Predicted ground reactions per foot (:func:`statopt.predict_grf`)."""
        for (key, path) in self._table_files:
            k = self._keys.get(key)
            if k is not None and k["table"] == "predicted_grf" and path.suffix == ".sto":
                return self.tables[key]
        raise KeyError(f"this run wrote no predicted_grf table; its tables: {', '.join(self.tables)}")

    def __repr__(self) -> str:
        s = self.summary
        solved = (f"{s['solves'] - s['failed']}/{s['solves']} frame problems solved, "
                  if s["solves"] else "")
        return (f"<statopt.Result {os.path.basename(self.setup)}: {s['frames']} frames, "
                f"{solved}{len(self._table_files)} tables>")


class _TqdmProgress:
    """A tqdm bar per frame loop; shown once a loop has run ``delay`` s."""

    def __init__(self, delay: float):
        from tqdm.auto import tqdm  # noqa: F401 (fails early without tqdm)

        self.delay = delay
        self.bar = None
        self.label = None

    def __call__(self, label: str, done: int, total: int) -> None:
        from tqdm.auto import tqdm

        if self.bar is None or label != self.label:
            self.close()
            self.bar = tqdm(total=total, desc=label, unit="frame", delay=self.delay, leave=False)
            self.label = label
        self.bar.update(done - self.bar.n)
        if done >= total:
            self.close()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def _progress_callback(progress) -> Optional[Callable]:
    if progress is False:
        return None
    if callable(progress):
        return progress
    try:
        return _TqdmProgress(delay=0.0 if progress is True else 1.0)
    except ImportError:
        if progress is True:
            raise
        return None


def _table_files(files: List[str]) -> List[Tuple[str, Path]]:
    """(key, path) of every table a run wrote: the file's stem; with its
    folder in front when two folders hold the same name (a study); the file
    name when one folder does (``x_predicted_grf.sto`` and ``.mot``)."""
    paths = [Path(f) for f in files if Path(f).suffix in (".sto", ".mot")]
    stems = [p.stem for p in paths]
    in_dir = [(p.parent, p.stem) for p in paths]
    out = []
    for p in paths:
        if stems.count(p.stem) == 1:
            key = p.stem
        elif in_dir.count((p.parent, p.stem)) == 1:
            key = f"{p.parent.name}/{p.stem}"
        else:
            key = p.name
        out.append((key, p))
    return out


def _read_metrics(files: List[str], key_of: Dict[str, Optional[Dict[str, Any]]],
                  kept: Optional[Dict[str, Any]] = None) -> Dict[str, float]:
    """The metrics of the metrics files among ``files`` (their run's key,
    ``key_of`` by normalised path, says which: table ``metrics``; from their
    bytes in ``kept`` for a run kept in memory)."""
    metrics: Dict[str, float] = {}
    csvs = []
    for f in files:
        k = key_of.get(os.path.normpath(f))
        if k is not None and k["table"] == "metrics":
            csvs.append((Path(f), k["setup"]))
    for p, setup in csvs:
        # One file per setup (a study writes several, and its own): then
        # each metric is named after its setup (or study), '<name>.<metric>'.
        prefix = setup + "." if len(csvs) > 1 else ""
        if kept is not None:
            rows = csv.DictReader(io.StringIO(kept[os.path.normpath(str(p))].decode("utf-8"), newline=""))
        else:
            with open(p, newline="") as fh:
                rows = list(csv.DictReader(fh))
        for row in rows:
            metrics[prefix + row["metric"]] = float(row["value"])
    return metrics


def run(
    setup: Union[str, "os.PathLike[str]"],
    results_dir: Union[str, "os.PathLike[str]", None] = None,
    progress: Union[bool, None, Callable[[str, int, int], Any]] = None,
    *,
    threads: Optional[int] = None,
    precision: Optional[int] = None,
    reduce: bool = False,
    resume: bool = False,
    sync: bool = False,
    allow_unknown: bool = False,
    tables: bool = True,
    **overrides: Any,
) -> Result:
    """Run a setup as ``statopt-tool SETUP`` does, in-process (the GIL is
    released while the engine runs).

    Any setup the CLI runs: an AnalyzeTool (StaticOptimization, JointReaction,
    MuscleAnalysis), an InverseDynamicsTool or a study document. Nothing is
    written unless ``results_dir`` is given (the engine then writes there
    exactly what ``statopt-tool SETUP -o results_dir`` writes); otherwise no
    file is created at all (no temporary folder either): the engine keeps
    the run's tables in memory, exactly as their files would hold them, and
    hands them over; they become DataFrames (with the crate's reader, in
    parallel) when the result's tables are first used. With ``results_dir``
    the tables are read from its files when first used. (Overrides that need
    a file of their own, ``model_properties``, a DataFrame ``motion`` and
    ``external_load_scale``, write it to a temporary folder removed after
    the run.)

    ``progress``: None shows a tqdm bar for frame loops that take longer
    than a second, True always, False never; a callable is called as
    ``progress(label, done, total)``.

    Overrides of the setup, without editing its file:
      ``contact_weight`` (w0: a number or a list), ``friction``
      (``"cone"``, ``"pyramid4"``, ``"pyramid8"``), ``time_range``
      (``(t0, t1)``), ``artifact_files`` (machine model file(s)),
      ``model_properties`` (``{"component/property": value}`` set in the
      model, artifact or force-set file that has it, e.g.
      ``{"tibia_pad_r/plane_origin": [0, 0.1, 0]}``), ``motion`` (a
      DataFrame, or a file, instead of the coordinates file; a DataFrame's
      rotational columns are in degrees unless ``df.attrs["in_degrees"]`` is
      False), ``external_load_scale`` (a number: every external load's force
      and torque data times it; a dict ``{ExternalForce name: factor}``: those
      loads'; the engine scales the data as it reads it), and any other setup
      element by name (``step_interval=2``,
      ``lowpass_cutoff_frequency_for_coordinates=6``, ...). Paths given here
      are relative to the working directory; the setup's own paths still
      resolve against its folder.

    ``threads``, ``precision``, ``reduce``, ``resume``, ``sync``,
    ``allow_unknown`` are the CLI's ``-j``, ``--precision``, ``--reduce``,
    ``--resume``, ``--sync`` and ``--allow-unknown`` (an element of the
    setup that neither OpenSim 4.6 nor statopt knows is then a warning
    instead of an InputError).

    Raises :class:`statopt.InputError` (bad input; the CLI's message naming
    the file, line and element) or :class:`statopt.StatoptError`. Frames
    that could not be solved give a :class:`FramesFailedWarning` (the result
    is complete; ``result.failed`` counts them).
    """
    if resume and results_dir is None:
        raise ValueError("resume=True continues the run in results_dir: give results_dir")
    return _execute(_native.run, setup, results_dir, progress, tables, overrides,
                    dict(precision=precision, threads=threads, reduce=reduce, resume=resume,
                         sync=sync, allow_unknown=allow_unknown))


def predict_grf(
    setup: Union[str, "os.PathLike[str]"],
    results_dir: Union[str, "os.PathLike[str]", None] = None,
    progress: Union[bool, None, Callable[[str, int, int], Any]] = None,
    *,
    threads: Optional[int] = None,
    allow_unknown: bool = False,
    tables: bool = True,
    **overrides: Any,
) -> Result:
    """``statopt-tool predict-grf SETUP``: ground reactions from kinematics
    alone (docs/grf_prediction.md), with :func:`run`'s ``results_dir``,
    ``progress``, ``allow_unknown`` and overrides.

    ``result.predicted_grf`` is the predicted force, centre of pressure and
    free moment per foot; with measured loads in the setup ``result.metrics``
    holds the agreement per foot and axis (``r_y_rho``, ``r_y_rmse_N``,
    ``r_y_rmse_BW_percent``, ``r_y_peak_error_N``, ...) and over stance
    (``r_cop_error_mm``, ``r_heel_strike_error_ms``, ``r_toe_off_error_ms``);
    ``result.summary["prediction"]`` has them as lists, with the foot
    contacts (points, floor height, belt velocity) and the body weight.
    """
    res = _execute(_native.predict_grf, setup, results_dir, progress, tables, overrides,
                   dict(threads=threads, allow_unknown=allow_unknown))
    pred = res.summary["prediction"]
    for m in pred["metrics"]:
        for k in ("rho", "rmse_N", "rmse_BW_percent", "peak_error_N"):
            res.metrics[f"{m['side']}_{m['axis']}_{k}"] = m[k]
    for st in pred["stance"]:
        for k in ("cop_error_mm", "heel_strike_error_ms", "toe_off_error_ms"):
            res.metrics[f"{st['side']}_{k}"] = st[k]
    return res


def _in_memory(line: str, scratch: str, tables: bool) -> str:
    """A report line of a run without ``results_dir``: "N files written to
    <temporary folder>" says where the tables went instead (the folder is
    removed)."""
    if scratch not in line:
        return line
    head = line.split(" written to ")[0]
    where = ("read into the result's tables (results_dir=None: nothing kept on disk)"
             if tables else "not kept (results_dir=None, tables=False)")
    return f"{head} {where}"


def _execute(native, setup, results_dir, progress, tables, overrides, options) -> Result:
    setup = Path(setup)
    inputs = None
    out = Path(results_dir) if results_dir is not None else None
    # A run without results_dir is kept in memory by the engine: no file.
    in_memory = results_dir is None and native in (_native.run, _native.predict_grf)
    overrides = dict(overrides)
    if "external_load_scale" in overrides:
        # Scaled by the engine as it reads the loads (no scaled copy).
        if native is not _native.run:
            raise TypeError("external_load_scale: an override of statopt.run() and statopt.sweep(), "
                            "not of predict_grf (it predicts the loads)")
        scales = external_scales(overrides.pop("external_load_scale"))
        options = dict(options, external_scales=list(scales.items()))
    try:
        text = None
        if overrides:
            # Created only when an override needs a file of its own.
            inputs = Path(tempfile.gettempdir()) / f"statopt-inputs-{os.getpid()}-{uuid.uuid4().hex}"
            text = edit_setup(setup, overrides, inputs)
        if out is None and not in_memory:
            out = Path(tempfile.mkdtemp(prefix="statopt-results-"))
        cb = _progress_callback(progress)
        where = dict(in_memory=True) if in_memory else dict(results_dir=str(out))
        try:
            summary = native(str(setup), text=text, progress=cb, **where, **options)
        finally:
            if isinstance(cb, _TqdmProgress):
                cb.close()
        # Each output's key (setup, analysis, w0, stat, table) is the run's
        # own, handed over with its path: no name is taken apart or
        # matched against a plan.
        key_of = {os.path.normpath(f): k for f, k in zip(summary["files"], summary.pop("keys"))}
        kept = None
        if in_memory:
            out = Path(summary.pop("in_memory_root"))
            kept = {}
            for p, k, v in summary.pop("outputs"):
                kept[os.path.normpath(p)] = v
                key_of.setdefault(os.path.normpath(p), k)
        if results_dir is None:
            # Messages name tables by file; here they are res.tables' keys.
            # The temporary folder is removed: the report names no folder.
            here = str(out) + os.sep
            for k in ("warnings", "report"):
                summary[k] = [w.replace(here, "") for w in summary[k]]
            summary["report"] = [_in_memory(line, str(out), tables) for line in summary["report"]]
            if summary["failure_line"]:
                summary["failure_line"] = summary["failure_line"].replace(here, "")
        seen = set()
        for w in summary["warnings"]:
            if w not in seen:
                seen.add(w)
                log.warning("%s", w)
        if summary["failure_line"]:
            warnings.warn(summary["failure_line"], FramesFailedWarning, stacklevel=3)
        metrics = _read_metrics(summary["files"], key_of, kept)
        table_files = _table_files(summary["files"]) if tables else []
        files = list(summary["files"]) if results_dir is not None else []
        scratch = None
        if results_dir is None:
            summary["files"] = []
            summary["results_dirs"] = []
            if in_memory:
                out = None  # never created
            elif table_files:
                scratch, out = out, None  # the result removes it once read
        keys = [key_of.get(os.path.normpath(str(p))) for _, p in table_files]
        return Result(str(setup), summary, table_files, metrics, files, scratch, keys,
                      kept if tables else None)
    finally:
        if inputs is not None:
            shutil.rmtree(inputs, ignore_errors=True)
        if results_dir is None and out is not None:
            shutil.rmtree(out, ignore_errors=True)


def check(
    setup: Union[str, "os.PathLike[str]"],
    results_dir: Union[str, "os.PathLike[str]", None] = None,
    *,
    reduce: bool = False,
    allow_unknown: bool = False,
) -> Dict[str, List[str]]:
    """``statopt-tool --check SETUP``: read and compile everything the setup
    (or study) names without running, as :func:`run` with the same
    ``results_dir``, ``reduce`` and ``allow_unknown`` would (a
    ``results_dir`` that is a file, or cannot be created, is an error).
    Returns ``{"errors": [...], "warnings": [...], "notes": [...],
    "checked": [...]}``: errors the root causes first (an unknown element
    before what follows from it), notes what was not checked and why; with
    ``allow_unknown=True`` unknown elements are warnings, not errors."""
    errors, warns, notes, checked = _native.check(
        os.fspath(setup),
        results_dir=None if results_dir is None else os.fspath(results_dir),
        reduce=reduce,
        allow_unknown=allow_unknown,
    )
    return {"errors": errors, "warnings": warns, "notes": notes, "checked": checked}
