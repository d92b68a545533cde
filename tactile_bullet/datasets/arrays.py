"""Grasp data as arrays, the way scikit-learn's loaders hand it out: ``X, y = load_dataset(...)``.

A user of scikit-learn wants a feature matrix and labels, not records: this module turns a
dataset folder, a folder of ``.npz`` records or one record file into ``(X, y)`` through any
registered descriptor (``"a+b"`` joins), shard by shard so that only one shard's time series
is in memory. ``as_frame`` adds the grasps' metadata (shape, offset, rotation, sizes, seed)
beside the features: a pandas DataFrame where pandas is installed (it is not a dependency),
or the same columns as a dict of numpy arrays, which ``pandas.DataFrame`` or ``polars`` take
as they are.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import UsageError
from ..records import GraspRecord

META_COLUMNS = ("shape", "offset_x", "offset_y", "offset_z", "rotation_deg", "seed")
"""Metadata columns of ``as_frame``, before one ``param_<name>`` column per size parameter
(NaN where a grasp's shape has no such parameter)."""


def _record_batches(path: Path, allow_partial: bool) -> tuple[Iterable[list[GraspRecord]], Any]:
    """Batches of full records (one per shard, or all of a record folder) and the object whose
    ``problems`` says what a partial read skipped (filled as the batches are read)."""
    from .dataset import Dataset, LoadedRecords, is_dataset, read_records

    if is_dataset(path):
        dataset = Dataset(path, allow_partial)
        batches = (dataset._shard(entry, full=True) for entry in dataset.shards)
        return batches, dataset
    loaded: LoadedRecords = read_records(path, allow_partial)
    return [loaded.records], loaded


def _metadata(records: list[GraspRecord]) -> list[dict[str, Any]]:
    rows = []
    for r in records:
        offset = tuple(float(v) for v in r.pose.offset)
        rotation = float(np.degrees(r.pose.rotation))
        row = {"shape": r.shape, "offset_x": offset[0], "offset_y": offset[1],
               "offset_z": offset[2], "rotation_deg": rotation, "seed": int(r.seed)}  # fmt: skip
        row.update({f"param_{k}": float(v) for k, v in dict(r.params).items()})
        rows.append(row)
    return rows


def _columns(
    X: np.ndarray, names: list[str], meta: list[dict[str, Any]]
) -> dict[str, np.ndarray]:
    columns: dict[str, np.ndarray] = {name: X[:, i] for i, name in enumerate(names)}
    params = sorted({k for row in meta for k in row if k.startswith("param_")})
    for key in (*META_COLUMNS, *params):
        if key in columns:
            raise UsageError(f"descriptor feature {key!r} clashes with a metadata column")
        values = [row.get(key, np.nan) for row in meta]
        dtype = str if key == "shape" else np.int64 if key == "seed" else float
        columns[key] = np.array(values, dtype=dtype)
    return columns


def load_dataset(
    path: str | os.PathLike,
    descriptor: str = "signature",
    *,
    descriptor_params: Mapping[str, Any] | None = None,
    allow_partial: bool = False,
    as_frame: bool | str = False,
) -> tuple[Any, np.ndarray]:
    """``(X, y)`` of the grasps at ``path``: X (n, d) float features from ``descriptor`` (any
    registered name, ``"a+b"`` joins; ``descriptor_params`` its parameters), y (n,) the shape
    names, in the data's order.

    ``path`` is a dataset folder (``generate``, ``import``), a folder of ``.npz`` records or
    one record file. Damaged data is an error naming it unless ``allow_partial``, which skips
    it with a :class:`~tactile_bullet.datasets.dataset.PartialDataWarning`.

    ``as_frame=True`` returns X as a pandas DataFrame: one column per feature (the
    descriptor's feature names) and the metadata columns of :data:`META_COLUMNS` plus
    ``param_<name>`` per size parameter; it needs pandas installed. ``as_frame="columns"``
    returns the same columns as a dict of numpy arrays, without pandas.
    """
    from ..plugins import get_descriptor

    if not isinstance(path, str | os.PathLike) or isinstance(path, bytes):
        raise UsageError(f"load_dataset path must be a path (str or os.PathLike), got "
                         f"{type(path).__name__}")  # fmt: skip
    if not isinstance(descriptor, str):
        raise UsageError(f"load_dataset descriptor must be a name (str), got "
                         f"{type(descriptor).__name__}")  # fmt: skip
    if descriptor_params is not None and not isinstance(descriptor_params, Mapping):
        raise UsageError(f"load_dataset descriptor_params must be a mapping of names to "
                         f"values, got {type(descriptor_params).__name__}")  # fmt: skip
    if not isinstance(allow_partial, bool):
        raise UsageError(f"load_dataset allow_partial must be True or False, got "
                         f"{allow_partial!r}")  # fmt: skip
    if isinstance(as_frame, bool | str) is False or as_frame not in (False, True, "columns"):
        raise UsageError(f"as_frame must be False, True or 'columns', got {as_frame!r}")
    if as_frame is True:
        try:
            import pandas
        except ImportError:
            raise UsageError(
                "as_frame=True needs pandas (pip install pandas); as_frame='columns' gives "
                "the same columns as numpy arrays without it"
            ) from None
    path = Path(path)
    if not path.exists():
        raise UsageError(f"data path {path} does not exist")
    desc = get_descriptor(descriptor, **dict(descriptor_params or {}))
    batches, source = _record_batches(path, allow_partial)
    blocks, labels, meta = [], [], []
    for records in batches:
        if not records:
            continue
        blocks.append(np.asarray(desc.transform(records), dtype=float))
        labels += [r.shape for r in records]
        if as_frame:
            meta += _metadata(records)
    if not blocks:
        raise UsageError(f"{path} holds no grasp records")
    from .dataset import LoadedRecords

    LoadedRecords([], list(source.problems)).warn()
    X = np.vstack(blocks)
    y = np.array(labels, dtype=str)
    if not as_frame:
        return X, y
    columns = _columns(X, list(desc.feature_names()), meta)
    if as_frame == "columns":
        return columns, y
    return pandas.DataFrame(columns), y
