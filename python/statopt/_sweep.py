"""statopt.sweep: many runs as independent tasks on dask.distributed."""

from __future__ import annotations

import itertools
import math
import numbers
import os
import shutil
import tempfile
import time
import traceback
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import pandas as pd

from . import _native
from ._run import Result, run
from ._setup import edit_setup, external_scales, is_study, metric_elements

MetricsSpec = Union[None, Callable[[Result], Mapping[str, Any]], Mapping[str, Callable[[Result], Any]]]


def summary_metrics(res: Result) -> Dict[str, Any]:
    """The default metrics of a run without ``<Metric>`` elements: frames
    solved and failed, the mean objective over frames, the worst equation
    residual, and each joint's peak reaction force (N, the largest resultant
    over time and w0)."""
    s = res.summary
    out: Dict[str, Any] = {
        "frames": s["frames"],
        "solved": s["solves"] - s["failed"],
        "failed": s["failed"],
    }
    objectives = []
    peaks: Dict[str, float] = {}
    for key, df in res.tables.items():
        k = res._keys.get(key) or {"table": None, "stat": None}
        if k["table"] == "diagnostics" and "objective" in df.columns:
            objectives.append(df["objective"].to_numpy())
        if k["table"] == "ReactionLoads" and k["stat"] is None:
            for c in df.columns:
                if c.endswith("_fx"):
                    base = c[:-3]
                    cols = [base + "_fx", base + "_fy", base + "_fz"]
                    if all(k in df.columns for k in cols):
                        f = np.sqrt(sum(df[k].to_numpy() ** 2 for k in cols))
                        name = f"peak_{base}_force_N"
                        peaks[name] = max(peaks.get(name, 0.0), float(np.max(f)) if len(f) else 0.0)
    if objectives:
        out["objective_mean"] = float(np.mean(np.concatenate(objectives)))
    if s["solves"]:
        out["worst_residual"] = s["worst_residual"]
    out.update(peaks)
    return out


def _metrics(res: Result, metrics: MetricsSpec) -> Dict[str, Any]:
    if metrics is None:
        if res.metrics:
            return {"frames": res.summary["frames"], "failed": res.summary["failed"], **res.metrics}
        return summary_metrics(res)
    if callable(metrics):
        return dict(metrics(res))
    return {name: f(res) for name, f in metrics.items()}


def _run_point(setup: str, overrides: Dict[str, Any], metrics: MetricsSpec,
               threads: Optional[int], results_dir: Optional[str] = None) -> Dict[str, Any]:
    """One point of a sweep (runs on a dask worker). Never raises: a failure
    is returned as the row's ``error``. With ``results_dir`` its tables are
    written there."""
    start = time.perf_counter()
    try:
        ov = dict(overrides)
        if not is_study(Path(setup)):
            ov["_drop_figures"] = True
        res = run(setup, progress=False, threads=threads, results_dir=results_dir, **ov)
        row = _metrics(res, metrics)
        if results_dir is not None:
            row["tables"] = results_dir
        row["error"] = None
    except Exception as e:  # reported in the row, never lost
        row = {"error": f"{type(e).__name__}: {e}"}
        if not isinstance(e, (ValueError, TypeError, KeyError, OSError)) and type(e).__module__ != "statopt":
            row["error"] += "\n" + traceback.format_exc(limit=5)
    row["seconds"] = time.perf_counter() - start
    return row


def _points(setup, grid) -> List[tuple]:
    """(setup, overrides, parameter columns) per point."""
    if isinstance(grid, Mapping):
        keys = list(grid)
        values = [list(v) if isinstance(v, (list, tuple, range, np.ndarray)) else [v] for v in grid.values()]
        out = []
        for combo in itertools.product(*values):
            ov = dict(zip(keys, combo))
            s = ov.pop("setup", setup)
            if s is None:
                raise ValueError("sweep: no setup (give one, or a 'setup' key in the grid)")
            params = {"setup": os.fspath(s)} if "setup" in keys else {}
            params.update({k: v for k, v in zip(keys, combo) if k != "setup"})
            out.append((os.fspath(s), ov, params))
        return out
    out = []
    for item in grid:
        if isinstance(item, Mapping):
            ov = dict(item)
            s = ov.pop("setup", setup)
            out.append((os.fspath(s), ov, {"setup": os.fspath(s), **ov}))
        else:
            s = os.fspath(item)
            ov = {}
            out.append((s, ov, {"setup": s}))
    return out


# -- force sweeps: points that differ only in forces, batched -------------

#: model_properties a force sweep sets per candidate (the property's last
#: path element), and the type of their values.
_BATCHED_PROPERTIES = {"expression": str, "optimal_force": numbers.Real}


def _batch_split(ov: Dict[str, Any]):
    """``(base overrides, candidate)`` when a point's overrides change the
    setup only in forces one compiled scene can share — one
    ``contact_weight``, expressions of ExpressionBasedCoordinateForces and
    actuators' optimal forces set through ``model_properties``, an
    ``external_load_scale`` — and ``None`` otherwise."""
    ov = dict(ov)
    w0 = ov.pop("contact_weight", None)
    if isinstance(w0, (list, tuple, np.ndarray)) and len(w0) == 1:
        w0 = w0[0]
    if not isinstance(w0, numbers.Real) or isinstance(w0, bool):
        return None
    cand: Dict[str, Any] = {"w0": float(w0), "expressions": {}, "optimal_forces": {}}
    if "external_load_scale" in ov:
        try:
            cand["external_scales"] = external_scales(ov.pop("external_load_scale"))
        except TypeError:
            return None
    rest = {}
    for key, value in (ov.pop("model_properties", None) or {}).items():
        parts = [p for p in str(key).strip("/").split("/") if p]
        kind = _BATCHED_PROPERTIES.get(parts[-1]) if len(parts) >= 2 else None
        if kind is not None and isinstance(value, kind) and not isinstance(value, bool):
            group = "expressions" if parts[-1] == "expression" else "optimal_forces"
            cand[group][parts[-2]] = value if kind is str else float(value)
        else:
            rest[key] = value
    if rest:
        ov["model_properties"] = rest
    return ov, cand


def _freeze(v: Any):
    """A hashable key of an override value (DataFrames by identity)."""
    if isinstance(v, Mapping):
        return tuple(sorted((str(k), _freeze(x)) for k, x in v.items()))
    if isinstance(v, (list, tuple, np.ndarray)):
        return tuple(_freeze(x) for x in v)
    if isinstance(v, pd.DataFrame):
        return ("DataFrame", id(v))
    if isinstance(v, os.PathLike):
        return os.fspath(v)
    return v


def force_sweep(setup, candidates: Sequence[Dict[str, Any]], *, threads: Optional[int] = None,
                warm: bool = True, write_tables: Union[str, "os.PathLike[str]", None] = None,
                **overrides: Any) -> List[Dict[str, Any]]:
    """Candidates of one setup that differ only in forces, on one compiled
    scene, in this process (the engine's ``sweep`` stage): one row
    per candidate, ``frames``, ``failed`` and the setup's ``<Metric>``
    values (unrounded). A candidate is ``{"w0": 500, "expressions":
    {"cam_torque": "-50"}, "optimal_forces": {"reserve_x": 100},
    "external_scales": {"plate1_left": 1.2}}`` (``"*"``: every external
    load's force and torque data times the factor); ``overrides`` (as
    :func:`statopt.run`'s, but ``contact_weight``) apply to the setup they
    share. :func:`sweep` uses it for such points.

    ``write_tables``: a folder; candidate k's tables then go to
    ``<write_tables>/candidate_<k>/`` (or a list of one folder per
    candidate), named as a run of its own setup (one w0) names them, and
    its row's ``tables`` is that folder. Without it (the default) only
    metrics are computed."""
    inputs = None
    tables = None
    if isinstance(write_tables, (list, tuple)):
        tables = [os.fspath(t) for t in write_tables]
    elif write_tables is not None:
        tables = [os.path.join(os.fspath(write_tables), f"candidate_{k}") for k in range(len(candidates))]
    try:
        text = None
        if overrides:
            inputs = Path(tempfile.mkdtemp(prefix="statopt-inputs-"))
            text = edit_setup(Path(setup), overrides, inputs)
        out = _native.force_sweep(os.fspath(setup), list(candidates), text=text, threads=threads, warm=warm,
                                  tables=tables)
    finally:
        if inputs is not None:
            shutil.rmtree(inputs, ignore_errors=True)
    rows = _rows(out)
    if tables is not None:
        for r, t in zip(rows, tables):
            r["tables"] = t
    return rows


def _rows(out: Dict[str, Any]) -> List[Dict[str, Any]]:
    rows = []
    for values, failed in zip(out["values"], out["failed"]):
        row: Dict[str, Any] = {"frames": out["frames"], "failed": failed}
        row.update(zip(out["metric_names"], values))
        rows.append(row)
    return rows


class Scene:
    """A setup compiled and every frame of its motion assembled once, kept
    in memory, to solve batch after batch of candidates that differ only in
    forces (an optimiser's iterates) without compiling or assembling again:

    >>> scene = statopt.Scene("setups/leg_extension_rajagopal_cam2.xml")
    >>> scene.run([{"w0": 500, "expressions": {"cam_torque": "-50"}}])
    [{'frames': 101, 'failed': 0, 'quadriceps_work_J': 120.045..., ...}]

    Candidates and rows as :func:`force_sweep`'s; ``overrides`` as
    :func:`statopt.run`'s (but ``contact_weight``) apply to the scene.
    Memory grows with the frames (each keeps its assembled program and
    reaction bases: about 0.3 MB a frame for the Rajagopal leg extension).
    """

    def __init__(self, setup, *, threads: Optional[int] = None, **overrides: Any):
        inputs = None
        try:
            text = None
            if overrides:
                inputs = Path(tempfile.mkdtemp(prefix="statopt-inputs-"))
                text = edit_setup(Path(setup), overrides, inputs)
            self._scene = _native.Scene(os.fspath(setup), text=text, threads=threads)
        finally:
            if inputs is not None:
                shutil.rmtree(inputs, ignore_errors=True)
        self.setup = os.fspath(setup)

    @property
    def frames(self) -> int:
        return self._scene.frames

    @property
    def warnings(self) -> List[str]:
        return self._scene.warnings

    def run(self, candidates: Sequence[Dict[str, Any]], warm: bool = True) -> List[Dict[str, Any]]:
        """One row per candidate: ``frames``, ``failed`` and the setup's
        ``<Metric>`` values (unrounded)."""
        return _rows(self._scene.run(list(candidates), warm=warm))

    def __repr__(self) -> str:
        return f"<statopt.Scene {os.path.basename(self.setup)}: {self.frames} frames>"


def _run_batch(setup: str, base: Dict[str, Any], cands: List[Dict[str, Any]],
               threads: Optional[int], tables: Optional[List[str]] = None) -> List[Dict[str, Any]]:
    """One batch of a sweep (in-process or on a dask worker); raises on
    failure (the caller then runs its points one by one)."""
    start = time.perf_counter()
    rows = force_sweep(setup, cands, threads=threads, write_tables=tables, **base)
    seconds = (time.perf_counter() - start) / max(1, len(cands))
    for r in rows:
        r["error"] = None
        r["seconds"] = seconds
    return rows


def _batches(points, metrics, batch) -> Tuple[Dict[Any, List[int]], Dict[int, tuple]]:
    """The points a force sweep can batch, grouped by what they share:
    {group key: [point index]}, and each batched point's (setup, base
    overrides, candidate)."""
    groups: Dict[Any, List[int]] = {}
    split: Dict[int, tuple] = {}
    if batch is False or metrics is not None:
        return groups, split
    batchable: Dict[str, bool] = {}
    for i, (s, ov, _) in enumerate(points):
        if s not in batchable:
            batchable[s] = not is_study(Path(s)) and metric_elements(Path(s))
        if not batchable[s]:
            continue
        bs = _batch_split(ov)
        if bs is None:
            continue
        base, cand = bs
        key = (s, _freeze(base))
        groups.setdefault(key, []).append(i)
        split[i] = (s, base, cand)
    return groups, split


def sweep(
    setup: Union[str, "os.PathLike[str]", None],
    grid: Union[Mapping[str, Sequence[Any]], Sequence[Any]],
    client=None,
    metrics: MetricsSpec = None,
    *,
    threads: Optional[int] = None,
    progress: Optional[bool] = None,
    batch: Optional[bool] = None,
    write_tables: Union[str, "os.PathLike[str]", None] = None,
    **fixed: Any,
) -> pd.DataFrame:
    """Run many variants of a setup as independent tasks on dask.distributed
    and return one tidy DataFrame, one row per point.

    ``grid`` is a dict of lists, every combination a point and each key an
    override of :func:`statopt.run` (``{"contact_weight": [1, 500, 1000],
    "artifact_files": [cam1, cam2]}``; a ``"setup"`` key varies the setup),
    or a list of setup paths (or of dicts of overrides). ``fixed`` overrides
    apply to every point.

    ``client`` is a ``dask.distributed.Client`` (e.g.
    ``Client("tcp://scheduler:8786")``); without one a LocalCluster of one
    single-threaded worker process per core (at most one per point) is
    started and closed again. Every worker needs ``statopt`` installed and
    the setup's files at the same paths.

    ``metrics``: None takes the setup's ``<Metric>`` elements if it has any
    (see setups/leg_extension_cam1.xml), else :func:`summary_metrics`
    (frames solved and failed, mean objective, peak joint reactions); a
    callable ``f(result) -> dict``; or a dict ``{name: f(result)}``.

    Columns: the parameters, the metrics, ``error`` (None, or what went
    wrong: a failing point is reported, never lost) and ``seconds``.

    ``progress``: None shows a tqdm bar of the points done once the sweep
    has run a second, True at once, False never.

    ``write_tables``: a folder; point i's tables then go to
    ``<write_tables>/point_<i>/`` (a batched point's as a run of its own
    setup writes them, a point run on its own as ``statopt.run(...,
    results_dir=...)`` does) and its row's ``tables`` names the folder.
    Without it (the default) a batched point computes metrics only.

    **Force sweeps.** Points that differ only in forces — one
    ``contact_weight`` each, ``model_properties`` that set an
    ExpressionBasedCoordinateForce's ``expression`` or an actuator's
    ``optimal_force``, and ``external_load_scale`` (a number, or
    ``{ExternalForce name: factor}``) — with the setup's ``<Metric>``s as metrics are
    batched (``batch=None``; ``False`` never): every group of points that
    share everything else runs as one force sweep (:func:`force_sweep`) on
    one compiled scene, in this process without ``client``, split into one
    task per worker with one. Their metrics are unrounded (a point run on
    its own has the 6 decimals of ``<name>_metrics.csv``) and equal those
    of a run of the point's own setup to 1e-9 relative. A batch that fails
    runs its points one by one, so errors are reported per point.
    """
    points = _points(setup, grid)
    if not points:
        return pd.DataFrame()
    folder = (lambda i: None) if write_tables is None else (
        lambda i: os.path.join(os.fspath(write_tables), f"point_{i}"))
    fixed = dict(fixed)
    results: Dict[int, Dict[str, Any]] = {}
    # Points that differ only in forces: one force sweep per group.
    groups, split = _batches([(s, {**fixed, **ov}, p) for s, ov, p in points], metrics, batch)
    if groups and client is None:
        for idx in groups.values():
            s, base, _ = split[idx[0]]
            try:
                rows = _run_batch(s, base, [split[i][2] for i in idx], threads,
                                  None if write_tables is None else [folder(i) for i in idx])
            except Exception:  # noqa: BLE001 - its points run one by one below
                continue
            results.update(zip(idx, rows))
    elif groups:
        workers = max(1, len(client.scheduler_info().get("workers", {})))
        tasks = []
        for idx in groups.values():
            s, base, _ = split[idx[0]]
            for chunk in np.array_split(np.arange(len(idx)), min(workers, len(idx))):
                ids = [idx[j] for j in chunk]
                tasks.append((ids, client.submit(_run_batch, s, base, [split[i][2] for i in ids], threads,
                                                 None if write_tables is None else [folder(i) for i in ids],
                                                 pure=False)))
        for ids, fut in tasks:
            try:
                results.update(zip(ids, fut.result()))
            except Exception:  # noqa: BLE001 - its points run one by one below
                continue
    todo = [i for i in range(len(points)) if i not in results]
    if not todo:
        rows = [{**params, **results[i]} for i, (_, _, params) in enumerate(points)]
        return _frame(rows)
    own = None
    if client is None:
        from dask.distributed import Client, LocalCluster

        n = max(1, min(len(todo), os.cpu_count() or 1))
        own = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                           dashboard_address=None)
        client = Client(own)
        if threads is None:
            threads = max(1, (os.cpu_count() or 1) // n)
    try:
        futures = [
            client.submit(_run_point, points[i][0], {**fixed, **points[i][1]}, metrics, threads, folder(i),
                          pure=False)
            for i in todo
        ]
        bar = None
        if progress is not False:
            try:
                from tqdm.auto import tqdm

                bar = tqdm(total=len(futures), desc="sweep", unit="point", leave=False,
                           delay=0.0 if progress else 1.0)
            except ImportError:
                if progress:
                    raise
        try:
            from dask.distributed import as_completed

            index = {f.key: i for i, f in zip(todo, futures)}
            for fut in as_completed(futures):
                try:
                    r = fut.result()
                except Exception as e:  # the task itself failed (a worker died, ...)
                    r = {"error": f"{type(e).__name__}: {e}"}
                results[index[fut.key]] = r
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
        rows = [{**params, **results[i]} for i, (_, _, params) in enumerate(points)]
    finally:
        if own is not None:
            client.close()
            own.close()
    return _frame(rows)


def _frame(rows: List[Dict[str, Any]]) -> pd.DataFrame:
    df = pd.DataFrame(rows)
    # parameters, metrics, then error and seconds
    last = [c for c in ("error", "seconds") if c in df.columns]
    return df[[c for c in df.columns if c not in last] + last]
