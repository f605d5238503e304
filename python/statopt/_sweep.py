"""statopt.sweep: many runs as independent tasks on dask.distributed."""

from __future__ import annotations

import itertools
import math
import os
import time
import traceback
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np
import pandas as pd

from ._run import Result, _split_key, run
from ._setup import is_study

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
        diag, loads = _split_key(key, "diagnostics"), _split_key(key, "ReactionLoads")
        if diag is not None and "objective" in df.columns:
            objectives.append(df["objective"].to_numpy())
        if loads is not None and loads[1] not in ("mean", "min", "max"):
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
               threads: Optional[int]) -> Dict[str, Any]:
    """One point of a sweep (runs on a dask worker). Never raises: a failure
    is returned as the row's ``error``."""
    start = time.perf_counter()
    try:
        ov = dict(overrides)
        if not is_study(Path(setup)):
            ov["_drop_figures"] = True
        res = run(setup, progress=False, threads=threads, **ov)
        row = _metrics(res, metrics)
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


def sweep(
    setup: Union[str, "os.PathLike[str]", None],
    grid: Union[Mapping[str, Sequence[Any]], Sequence[Any]],
    client=None,
    metrics: MetricsSpec = None,
    *,
    threads: Optional[int] = None,
    progress: Optional[bool] = None,
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
    """
    points = _points(setup, grid)
    if not points:
        return pd.DataFrame()
    fixed = dict(fixed)
    own = None
    if client is None:
        from dask.distributed import Client, LocalCluster

        n = max(1, min(len(points), os.cpu_count() or 1))
        own = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                           dashboard_address=None)
        client = Client(own)
        if threads is None:
            threads = max(1, (os.cpu_count() or 1) // n)
    try:
        futures = [
            client.submit(_run_point, s, {**fixed, **ov}, metrics, threads, pure=False)
            for s, ov, _ in points
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
        results: Dict[int, Dict[str, Any]] = {}
        try:
            from dask.distributed import as_completed

            index = {f.key: i for i, f in enumerate(futures)}
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
    df = pd.DataFrame(rows)
    # parameters, metrics, then error and seconds
    last = [c for c in ("error", "seconds") if c in df.columns]
    return df[[c for c in df.columns if c not in last] + last]
