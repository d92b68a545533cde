"""``finger-closure``: how far each long finger wrapped, J3 + J2 + J1 (rad)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from tactile_bullet.learn.descriptors import check_records

FINGERS = ("ff", "mf", "rf", "lf")


@dataclass(frozen=True)
class FingerClosure:
    """Total flexion of each long finger: theta = s / r, the radius each finger felt."""

    name: ClassVar[str] = "finger-closure"

    @property
    def params(self) -> dict:
        return {}

    def feature_names(self) -> list[str]:
        return [f"{f}_closure" for f in FINGERS]

    def transform(self, records) -> np.ndarray:
        records = check_records(records)  # a clear error for anything but a list of records
        rows = [np.asarray(r.fci_angles(), dtype=float).sum(axis=0) for r in records]
        return np.asarray(rows, dtype=float).reshape(len(rows), len(FINGERS))
