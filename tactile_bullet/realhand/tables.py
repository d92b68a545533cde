"""CSV and Parquet tables -> joint samples.

A ``time`` column in seconds, one column per joint (radians), optional ``<joint>_effort``
columns (N m), an optional ``shape`` label column and an optional marker column.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..files import INPUT_LIMITS, input_path
from ..hand import JOINT_NAMES
from .calibration import Calibration
from .joints import JointMap, JointSamples, _check_finite, _check_time
from .names import (
    LABEL_COLUMN,
    MARKER_COLUMN,
    NO_MARKER,
    OBJECT_COLUMN,
    TIME_COLUMN,
    split_name,
)

MAX_TIME_S = 1e11
"""Largest time (s) a table may hold: seconds since 1970 are ~1.7e9, so a value over this
(about 3,000 years) is nanoseconds or microseconds since the epoch, not seconds."""

# --- tables -------------------------------------------------------------------------------------


CSV_BLOCK_ROWS = 4_096
"""Rows parsed at a time: each block's cells become float arrays before the next is read, so
a large CSV never exists in memory as Python strings (a 1M-row file peaked at 14x its size)."""


def _table_columns(path: Path, text: tuple = ()) -> dict[str, list | np.ndarray]:
    """Column name -> values: a float array for a numeric CSV column, else its cells (text for
    CSV, Python values for Parquet). ``text`` names CSV columns always kept as text (labels,
    markers)."""
    if path.suffix.lower() in (".parquet", ".pq"):
        try:
            import pyarrow.parquet as pq
        except ImportError:
            raise UsageError(
                "reading Parquet needs pyarrow: pip install 'tactile-bullet[parquet]'"
            ) from None
        try:
            table = pq.read_table(path)
        except Exception as exc:  # noqa: BLE001 - a damaged file is the user's input
            raise UsageError(f"{path} is not a readable Parquet file ({exc})") from None
        _refuse_duplicates(table.column_names, path)
        out = {}
        for name, kind in zip(table.column_names, table.schema.types, strict=True):
            values = table.column(name).to_pylist()
            if pa_types_bool(kind):  # as text, so a joint column of them is refused, never 1.0 rad
                values = [None if v is None else str(v).lower() for v in values]
            out[name] = values
        return out
    import csv

    try:
        with open(path, newline="") as fh:
            return _csv_columns(path, csv.reader(fh), text)
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise UsageError(f"cannot read {path}: {exc}") from None


def _csv_columns(path: Path, reader, text: tuple) -> dict[str, list | np.ndarray]:
    """The columns of a CSV, parsed block by block (:data:`CSV_BLOCK_ROWS`)."""
    import itertools

    header: list[str] | None = None
    line = 0
    for row in reader:
        line += 1
        if row and not (len(row) == 1 and not row[0].strip()):
            header = [h.strip() for h in row]
            break
    if header is None:
        raise UsageError(f"{path} is empty")
    if header and header[0].startswith("\ufeff"):  # a byte-order mark (Excel's UTF-8 CSV)
        header[0] = header[0][1:].strip()
    _refuse_duplicates(header, path)
    blocks: list[list] = [[] for _ in header]
    read = True
    while read:
        rows, read = [], False
        for row in itertools.islice(reader, CSV_BLOCK_ROWS):
            line, read = line + 1, True
            if not row or (len(row) == 1 and not row[0].strip()):
                continue
            if len(row) != len(header):
                raise UsageError(f"{path}: line {line} has {len(row)} fields, the header "
                                 f"{len(header)}")  # fmt: skip
            rows.append(row)
        for j, cells in enumerate(zip(*rows, strict=True)):
            blocks[j].append(_block_values(cells, header[j] in text))
        del rows
    columns: dict[str, list | np.ndarray] = {}
    for name, parts in zip(header, blocks, strict=True):
        if all(isinstance(p, np.ndarray) for p in parts):
            columns[name] = np.concatenate(parts) if parts else np.zeros(0)
        else:  # text, or a cell that is not a plain number: the checks below name it
            columns[name] = [v for p in parts for v in (p.tolist() if isinstance(p, np.ndarray)
                                                        else p)]  # fmt: skip
        parts.clear()
    return columns


def _block_values(cells: tuple, keep_text: bool) -> list | np.ndarray:
    """A block of one column's cells as floats where every cell is a plain number."""
    if not keep_text and "_" not in "".join(cells):  # "1_0" is not a number here
        try:
            return np.array(cells, dtype=float)
        except ValueError:
            pass
    return list(cells)


def _refuse_duplicates(names: list[str], path: Path) -> None:
    """Two columns of one name: which one is meant cannot be known (the last would win)."""
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise UsageError(f"{path}: column {name!r} appears twice")
        seen.add(name)


def pa_types_bool(kind) -> bool:
    import pyarrow as pa

    return bool(pa.types.is_boolean(kind))


def _floats(values: list | np.ndarray, where: str, what: str) -> np.ndarray:
    if isinstance(values, np.ndarray):
        return values
    bad = next((v for v in values if isinstance(v, str) and "_" in v), None)
    if bad is not None:  # Python's float() reads "1_0" as 10
        raise UsageError(f"{where}: {what} holds {bad!r}, not a number")
    try:
        return np.array([float(v) if v not in ("", None) else math.nan for v in values], float)
    except (TypeError, ValueError):
        bad = next(v for v in values if not _is_number(v))
        raise UsageError(f"{where}: {what} holds {bad!r}, not a number") from None


def _is_number(value) -> bool:
    try:
        float(value)
    except (TypeError, ValueError):
        return False
    return True


def read_table(
    path: str | Path,
    marker: str | None = None,
    calibration: Calibration | None = None,
    time_column: str = TIME_COLUMN,
    prefix: str | None = None,
) -> JointSamples:
    """Joint states of a CSV or Parquet table (see the module docstring for its columns);
    ``prefix`` ("rh") keeps one hand's columns of a table that holds two."""
    path = Path(path)
    where = str(path)
    input_path(path, "recording", INPUT_LIMITS["table"])
    columns = _table_columns(path, (LABEL_COLUMN, MARKER_COLUMN, OBJECT_COLUMN, marker))
    if time_column not in columns:
        raise UsageError(f"{where} has no {time_column!r} column")
    marker_column = marker if marker is not None else (
        MARKER_COLUMN if MARKER_COLUMN in columns else None
    )  # fmt: skip
    if marker == NO_MARKER:
        marker_column = None
    if marker_column is not None and marker_column not in columns:
        raise UsageError(f"{where} has no marker column {marker_column!r}")
    reserved = {time_column, LABEL_COLUMN, MARKER_COLUMN, OBJECT_COLUMN, marker_column}
    joints, effort_cols = [], {}
    for name in columns:
        if name in reserved or name.endswith("_velocity"):
            continue
        if name.endswith("_effort"):
            effort_cols[name[: -len("_effort")]] = name
        else:
            joints.append(name)
    if prefix is not None:
        joints = [j for j in joints if (p := split_name(j)) is None or p[0].lower() == prefix]
        effort_cols = {j: c for j, c in effort_cols.items() if j in joints}
        if not joints:
            shown = prefix + "_" if prefix else "(none)"
            raise UsageError(f"{where}: no joint columns of hand prefix {shown!r}")
    unknown = [e for e in effort_cols if e not in joints]
    if unknown:
        shown = ", ".join(ascii(e + "_effort") for e in unknown)  # ascii: show odd characters
        raise UsageError(f"{where}: effort columns without their position column: {shown}")
    jmap = JointMap(joints, calibration, where)
    time = _floats(columns[time_column], where, f"column {time_column!r}")
    if time.size and np.nanmax(np.abs(time)) > MAX_TIME_S:
        raise UsageError(
            f"{where}: column {time_column!r} holds {np.nanmax(np.abs(time)):.6g}, too large "
            "for seconds: nanoseconds? (divide by 1e9; time is in seconds)"
        )
    _check_time(time, where)
    raw = _stack(columns, joints, where)
    missing = ~np.isfinite(raw)
    if missing.any():
        row, col = (int(v[0]) for v in np.nonzero(missing))
        raise UsageError(f"{where}: joint {joints[col]} has no value on data row {row + 1}")
    has_eff = len(effort_cols) == len(joints)
    if effort_cols and not has_eff:
        absent = [j for j in joints if j not in effort_cols]
        raise UsageError(f"{where}: effort columns missing for {', '.join(absent)}")
    if has_eff:
        raw_eff = _stack(columns, [effort_cols[j] for j in joints], where)
        _check_finite(raw_eff, where, "efforts")
        efforts = jmap.efforts(raw_eff)
        del raw_eff
    else:
        efforts = np.zeros((len(time), len(JOINT_NAMES)))
    groups = None
    if marker_column is not None:
        groups = np.array([_group_key(v) for v in columns[marker_column]], dtype=object)
    labels = [str(v) if v not in ("", None) else None for v in columns.get(LABEL_COLUMN, [])]
    objects = [str(v) if v not in ("", None) else None for v in columns.get(OBJECT_COLUMN, [])]
    return JointSamples(
        source=where,
        time=time - time[0],
        receive=time - time[0],
        angles=jmap.positions(raw, time),
        efforts=efforts,
        has_efforts=has_eff,
        row_groups=groups,
        labels=labels,
        objects=objects,
        coupled=jmap.coupled,
        prefix=jmap.prefix,
    )


def _stack(columns: dict, names: list[str], where: str) -> np.ndarray:
    """The named columns as one (rows, len(names)) float array, each column dropped from
    ``columns`` once copied: a large table is never held twice."""
    out = None
    for k, name in enumerate(names):
        values = _floats(columns[name], where, f"column {name!r}")
        if out is None:
            out = np.empty((len(values), len(names)))
        out[:, k] = values
        columns[name] = []
    return out if out is not None else np.zeros((0, 0))


def _group_key(value):
    """A marker cell as a grasp key; 0 (or empty) for rows between grasps."""
    if value in ("", None, "false"):
        return 0
    try:
        number = float(value)
    except (TypeError, ValueError):
        return str(value)
    return 0 if number == 0 or not math.isfinite(number) else number
