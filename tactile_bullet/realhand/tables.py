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
from .names import LABEL_COLUMN, MARKER_COLUMN, NO_MARKER, TIME_COLUMN

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
        return {name: table.column(name).to_pylist() for name in table.column_names}
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


def _floats(values: list | np.ndarray, where: str, what: str) -> np.ndarray:
    if isinstance(values, np.ndarray):
        return values
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
) -> JointSamples:
    """Joint states of a CSV or Parquet table (see the module docstring for its columns)."""
    path = Path(path)
    where = str(path)
    input_path(path, "recording", INPUT_LIMITS["table"])
    columns = _table_columns(path, (LABEL_COLUMN, MARKER_COLUMN, marker))
    if time_column not in columns:
        raise UsageError(f"{where} has no {time_column!r} column")
    marker_column = marker if marker is not None else (
        MARKER_COLUMN if MARKER_COLUMN in columns else None
    )  # fmt: skip
    if marker == NO_MARKER:
        marker_column = None
    if marker_column is not None and marker_column not in columns:
        raise UsageError(f"{where} has no marker column {marker_column!r}")
    reserved = {time_column, LABEL_COLUMN, MARKER_COLUMN, marker_column}
    joints, effort_cols = [], {}
    for name in columns:
        if name in reserved or name.endswith("_velocity"):
            continue
        if name.endswith("_effort"):
            effort_cols[name[: -len("_effort")]] = name
        else:
            joints.append(name)
    unknown = [e for e in effort_cols if e not in joints]
    if unknown:
        raise UsageError(f"{where}: effort columns for no position column: {', '.join(unknown)}")
    jmap = JointMap(joints, calibration, where)
    time = _floats(columns[time_column], where, f"column {time_column!r}")
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
    return JointSamples(
        source=where,
        time=time - time[0],
        receive=time - time[0],
        angles=jmap.positions(raw),
        efforts=efforts,
        has_efforts=has_eff,
        row_groups=groups,
        labels=labels,
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
    if value in ("", None):
        return 0
    try:
        number = float(value)
    except (TypeError, ValueError):
        return str(value)
    return 0 if number == 0 or not math.isfinite(number) else number
