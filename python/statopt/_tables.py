"""OpenSim .sto/.mot tables as pandas DataFrames, read and written by the
engine's own storage reader and writer (src/storage/)."""

from __future__ import annotations

import os
from typing import Mapping, Optional

import numpy as np
import pandas as pd

from . import _native


def read_table(path: "os.PathLike[str] | str") -> pd.DataFrame:
    """Read an OpenSim table (.sto or .mot, legacy Storage or TimeSeriesTable
    format) with statopt's reader.

    Returns a DataFrame indexed by ``time`` with the file's column labels.
    ``df.attrs`` holds ``name`` (the table's name line), ``in_degrees`` and
    ``metadata`` (the other header ``key=value`` pairs; free header text
    under ``header``). Raises :class:`statopt.InputError` naming the file and
    line when the table is malformed.
    """
    return _frame(_native.read_table(os.fspath(path)))


def read_tables(paths) -> "list[pd.DataFrame]":
    """:func:`read_table` for several files, read in parallel."""
    return [_frame(parts) for parts in _native.read_tables([os.fspath(p) for p in paths])]


def _frame(parts) -> pd.DataFrame:
    name, labels, time_b, data_b, in_degrees, metadata = parts
    time = np.frombuffer(time_b, dtype=np.float64)
    values = np.frombuffer(data_b, dtype=np.float64).reshape(len(time), len(labels))
    df = pd.DataFrame(
        values,
        index=pd.Index(time, name="time", copy=True),
        columns=list(labels),
        copy=True,
    )
    df.attrs["name"] = name
    df.attrs["in_degrees"] = bool(in_degrees)
    df.attrs["metadata"] = dict(metadata)
    return df


def write_table(
    df: pd.DataFrame,
    path: "os.PathLike[str] | str",
    *,
    name: Optional[str] = None,
    in_degrees: Optional[bool] = None,
    metadata: Optional[Mapping[str, str]] = None,
    precision: int = _native.DEFAULT_PRECISION,
) -> None:
    """Write a DataFrame as an OpenSim legacy .sto/.mot table with statopt's
    writer (the format ``statopt-tool`` writes).

    The index is the time column (a column named ``time`` is used instead
    when the index is a plain RangeIndex). ``name``, ``in_degrees`` and
    ``metadata`` default to ``df.attrs`` (as :func:`read_table` sets them),
    else the file's stem, ``False`` and none. ``precision`` is the number of
    digits after the decimal point (OpenSim's default 8).
    """
    if "time" in df.columns and isinstance(df.index, pd.RangeIndex):
        df = df.set_index("time")
    try:
        time = np.ascontiguousarray(df.index.to_numpy(dtype=np.float64))
    except (TypeError, ValueError) as e:
        raise ValueError(f"write_table: the index must be time (numbers): {e}") from None
    try:
        values = np.ascontiguousarray(df.to_numpy(dtype=np.float64))
    except (TypeError, ValueError) as e:
        raise ValueError(f"write_table: every column must be numeric: {e}") from None
    if name is None:
        name = df.attrs.get("name") or os.path.splitext(os.path.basename(os.fspath(path)))[0]
    if in_degrees is None:
        in_degrees = bool(df.attrs.get("in_degrees", False))
    if metadata is None:
        metadata = df.attrs.get("metadata") or {}
    if not 1 <= int(precision) <= 20:
        raise ValueError(f"precision must lie in 1..=20, found {precision}")
    _native.write_table(
        os.fspath(path),
        str(name),
        [str(c) for c in df.columns],
        time.tobytes(),
        values.tobytes(),
        bool(in_degrees),
        [(str(k), str(v)) for k, v in metadata.items()],
        int(precision),
    )
