"""A model's learned second opinion: a second classifier on other features of the same grasps.

The shape fit seconds the answers of the models users train (``learn/doubt.CROSS_CHECK``); it
is calibrated for our own hands, and on others it dissents from right answers as often as from
wrong ones. The shipped default instead carries an svm trained on its own training grasps
through :data:`DESCRIPTOR` (the zeroed, plateau-averaged J4, J3 and J0 of each long finger):
it reads the hand through joint angles where the default reads finger points, and neither a
calibration bias nor the tendon's split of J0 reaches it, so the two rarely fail on the same
grasp. Where it names another family, the answer is ``ambiguous`` (declared before replicate
17 and judged on it: docs/robustness.md).

Saved in the model file as ``second_opinion`` in the metadata (descriptor, its parameters,
the classifier's state) and ``second.*`` arrays.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import UsageError
from ..files import json_value

DESCRIPTOR = "robust-coupled-joints"
"""What the default's second svm reads (``learn/robust.RobustCoupledJointsDescriptor``)."""
WITHOUT_SERIES = {"robust-coupled-joints": "coupled-joints"}
"""The descriptor of the same columns, unzeroed, that reads a record without a series."""
CLASSIFIER = "svm"
ARRAY_PREFIX = "second."
"""Model-file members holding the second classifier's state arrays."""


@dataclass(frozen=True)
class SecondOpinion:
    """A fitted classifier (``estimator``, with ``classes_`` and ``predict``) on ``descriptor``
    (with ``params``) features: the family it names for each grasp."""

    descriptor: str
    params: Mapping[str, Any]
    classifier: str
    estimator: Any

    @classmethod
    def fit(cls, records: Sequence, labels: Sequence[str], descriptor: str = DESCRIPTOR,
            classifier: str = CLASSIFIER) -> SecondOpinion:  # fmt: skip
        """The second opinion trained on ``records`` labelled ``labels`` (a model's own
        training grasps)."""
        from ..plugins import get_classifier, get_descriptor

        x = get_descriptor(descriptor).transform(records)
        est = get_classifier(classifier).fit(x, np.asarray([str(v) for v in labels]))
        return cls(descriptor, {}, classifier, est)

    def names(self, records: Sequence) -> list[str]:
        """The family this opinion names for each record. A record whose time series is too
        short to zero (a recording of final configurations only, records read without their
        series) is read by :data:`WITHOUT_SERIES`'s descriptor of the same columns, unzeroed."""
        from ..plugins import get_descriptor
        from .robust import has_series

        described = get_descriptor(self.descriptor, **dict(self.params))
        zeroing = hasattr(described, "reference")  # a descriptor on zeroed records
        short = [zeroing and not has_series(r, described.reference, described.tail)
                 for r in records]  # fmt: skip
        x = np.empty((len(records), len(described.feature_names())))
        full = [i for i, s in enumerate(short) if not s]
        if full:
            x[full] = described.transform([records[i] for i in full])
        if len(full) < len(records):
            plain = get_descriptor(WITHOUT_SERIES.get(self.descriptor, self.descriptor))
            rest = [i for i, s in enumerate(short) if s]
            x[rest] = plain.transform([records[i] for i in rest])
        return [str(v) for v in self.estimator.predict(x)]

    def to_state(self) -> tuple[dict, dict[str, np.ndarray]]:
        """(metadata, arrays) for the model file; the classifier must save its own state."""
        if not callable(getattr(self.estimator, "to_state", None)):
            raise UsageError(f"cannot save a second opinion of classifier {self.classifier!r}")
        state, arrays = self.estimator.to_state()
        plain = json.loads(json.dumps(state, default=json_value))  # numpy scalars as JSON
        meta = {"descriptor": self.descriptor, "params": dict(self.params),
                "classifier": self.classifier, "state": plain}  # fmt: skip
        return meta, {ARRAY_PREFIX + k: np.asarray(v) for k, v in arrays.items()}

    @classmethod
    def from_state(cls, meta: Any, contents: Mapping[str, np.ndarray], classes: list[str],
                   where: str) -> SecondOpinion:  # fmt: skip
        """The second opinion a model file holds, every part checked (its descriptor and
        classifier installed, its state restorable, its families the model's, its width its
        descriptor's): a UsageError naming ``where`` otherwise, never a silent fallback."""
        from ..plugins import fitted_form, get_descriptor

        bad = f"{where} is not a valid model: its second opinion"
        if not isinstance(meta, dict) or not {"descriptor", "params", "classifier",
                                              "state"} <= set(meta):  # fmt: skip
            raise UsageError(f"{bad} is incomplete")
        if not isinstance(meta["params"], dict) or not isinstance(meta["state"], dict):
            raise UsageError(f"{bad} is incomplete")
        descriptor, classifier = str(meta["descriptor"]), str(meta["classifier"])
        try:
            described = get_descriptor(descriptor, **meta["params"])
            kind = fitted_form(classifier)
        except UsageError as exc:
            raise UsageError(f"{bad} needs {exc}") from None
        if kind is None:
            raise UsageError(f"{bad}'s classifier {classifier!r} cannot be restored")
        arrays = {k[len(ARRAY_PREFIX):]: v for k, v in contents.items()
                  if k.startswith(ARRAY_PREFIX)}  # fmt: skip
        try:
            est = kind.from_state(meta["state"], arrays)
        except Exception as exc:  # noqa: BLE001 - a bad state is a bad file
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise UsageError(f"{bad} cannot be restored ({first})") from None
        if sorted(str(c) for c in getattr(est, "classes_", [])) != sorted(classes):
            raise UsageError(f"{bad} names other families than the model")
        width = getattr(est, "n_features_in_", None)
        if width is not None and int(width) != len(described.feature_names()):
            raise UsageError(f"{bad} was fitted on {int(width)} features, its descriptor "
                             f"{descriptor!r} gives {len(described.feature_names())}")  # fmt: skip
        return cls(descriptor, dict(meta["params"]), classifier, est)
