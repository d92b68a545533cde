"""Grasps of the user's own hand whose shapes are known, kept in a model file
(``train --known``) to second its answers in place of the shape fit (:mod:`.doubt`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

KNOWN_DESCRIPTOR = "signature+coupled-joints"
"""What the known grasps are compared in: the signature's shape of the closure and the
absolute joint angles, J1 + J2 read together so no J1/J2 split is assumed."""


MAX_KNOWN_GRASPS = 100_000
"""Most known grasps a model keeps (``train --known``): ~30 MB of features. A model file whose
``known.*`` arrays declare more is refused before they are read (``models.KNOWN_MEMBER_LIMIT``)."""


@dataclass(frozen=True)
class KnownGrasps:
    """Grasps of the user's hand whose shapes are known, kept in a model file to second its
    answers: each answer is checked against the shape of the nearest known grasp.

    ``features`` (n, d) are ``descriptor``'s features of the grasps; distances scale each
    feature by its spread over the known grasps (features that do not vary among them are
    left out: they cannot tell the grasps apart, and a zero spread would magnify noise)."""

    features: np.ndarray
    labels: np.ndarray
    descriptor: str = KNOWN_DESCRIPTOR

    @classmethod
    def from_records(cls, records: Sequence, descriptor: str = KNOWN_DESCRIPTOR) -> KnownGrasps:
        from ..errors import UsageError
        from ..plugins import get_descriptor

        x = np.asarray(get_descriptor(descriptor).transform(list(records)), dtype=float)
        known = cls(x, np.array([str(r.shape) for r in records]), descriptor)
        if len(records) > MAX_KNOWN_GRASPS:
            raise UsageError(f"--known holds {len(records):,} grasps; at most "
                             f"{MAX_KNOWN_GRASPS:,} can second a model's answers")  # fmt: skip
        if not known.varies():
            raise UsageError(
                f"--known: the known grasps' {descriptor} features do not vary among them, so "
                "no known grasp could be told nearer than another and the check of answers "
                "would be off; give grasps of at least two shapes"
            )
        return known

    def varies(self) -> bool:
        """Whether any feature varies among the known grasps (none: the check is off)."""
        x = np.asarray(self.features, dtype=float)
        return x.ndim == 2 and len(x) > 1 and bool(np.any(x.std(axis=0) > 1e-9))

    def _scaled(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        mean, spread = self.features.mean(axis=0), self.features.std(axis=0)
        keep = spread > 1e-9
        return ((self.features - mean)[:, keep] / spread[keep],
                (np.asarray(x, dtype=float) - mean)[:, keep] / spread[keep])  # fmt: skip

    def nearest_of(self, x: np.ndarray) -> np.ndarray:
        """The shape of the nearest known grasp to each row of ``x`` (the features); '' (no
        opinion) for every row where no feature varies among the known grasps."""
        known, rows = self._scaled(x)
        if len(rows) == 0 or known.shape[1] == 0:
            return np.full(len(rows), "", dtype=object).astype(str)
        distance = np.linalg.norm(rows[:, None, :] - known[None, :, :], axis=2)
        return self.labels[np.argmin(distance, axis=1)].astype(str)

    def nearest(self, records: Sequence) -> np.ndarray:
        """The shape of the nearest known grasp to each record."""
        from ..plugins import get_descriptor

        x = np.asarray(get_descriptor(self.descriptor).transform(list(records)), dtype=float)
        return self.nearest_of(x)

    def self_agreement(self) -> float | None:
        """Share of known grasps whose nearest *other* known grasp has their shape (None with
        fewer than two grasps of every shape): how far the check can be trusted on this hand."""
        _, counts = np.unique(self.labels, return_counts=True)
        known, _ = self._scaled(self.features[:0])
        if len(counts) < 2 or counts.min() < 2 or known.shape[1] == 0:
            return None
        distance = np.linalg.norm(known[:, None, :] - known[None, :, :], axis=2)
        np.fill_diagonal(distance, np.inf)
        return float(np.mean(self.labels[np.argmin(distance, axis=1)] == self.labels))

    def check(self, classes: Sequence[str]) -> None:
        """Refuse (ValueError) grasps the model cannot have been fitted with."""
        x, y = self.features, self.labels
        if x.ndim != 2 or y.ndim != 1 or len(x) != len(y) or len(y) == 0:
            raise ValueError("known grasps' features and labels do not match")
        if not np.all(np.isfinite(x)):
            raise ValueError("known grasps' features are not finite")
        if len(y) > MAX_KNOWN_GRASPS:
            raise ValueError(f"it holds {len(y):,} known grasps, over the {MAX_KNOWN_GRASPS:,} "
                             "train --known writes")  # fmt: skip
        if not self.varies():
            raise ValueError("its known grasps' features do not vary: they cannot second answers")
        extra = {str(v) for v in y} - {str(c) for c in classes}
        if extra:
            raise ValueError(f"a known grasp is a {sorted(extra)[0]!r}, not one of its classes")
