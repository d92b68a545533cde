"""Training regimes: what a model is fitted on, given a dataset (``train --training``).

- ``clean``: the records as they are;
- ``noise-aware``: each record also presented ``robust.AUGMENT_COPIES`` times read through
  1 deg of joint noise (``robust.augment``), so the classifier's margins are as wide as a real
  hand's sensors need (``docs/real_hand.md`` recommends it with the robust descriptors);
- ``randomized``: the records as they are, from a dataset whose hand and physics were drawn per
  grasp (``generate --preset randomized`` or a sweep's ``[randomize]`` table): refused on a
  dataset made with one hand, where it would silently be ``clean``.

The benchmark's trainings of the same names (``experiments/benchmark.py``) are these.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..errors import UsageError
from ..records import GraspRecord, controller_dict

TRAININGS: tuple[str, ...] = ("clean", "noise-aware", "randomized")


def check_training(name: str) -> str:
    if name not in TRAININGS:
        raise UsageError(f"unknown training {name!r} (known: {', '.join(TRAININGS)})")
    return name


def hands_in(records: Sequence[GraspRecord]) -> int:
    """How many distinct hand and physics settings the simulated records were made with."""
    import json

    return len({
        json.dumps(controller_dict(r.controller), sort_keys=True)
        for r in records
        if r.source == "simulated"
    })  # fmt: skip


def training_records(
    records: Sequence[GraspRecord], training: str, seed: int = 0
) -> list[GraspRecord]:
    """The records a model of regime ``training`` is fitted on (module doc)."""
    check_training(training)
    records = list(records)
    if training == "noise-aware":
        from .robust import augment

        return augment(records, seed=seed)
    if training == "randomized":
        recorded = sum(r.source != "simulated" for r in records)
        if recorded:
            raise UsageError(
                f"--training randomized needs simulated grasps with the hand drawn per grasp; "
                f"{recorded} of these records come from a recording"
            )
        if hands_in(records) < 2:
            raise UsageError(
                "--training randomized needs a dataset whose hand and physics were drawn per "
                "grasp (generate --preset randomized, or a [randomize] table in the sweep); "
                "every grasp of this one was made with the same settings"
            )
    return records


def with_known(
    fit_on: Sequence[GraspRecord],
    known: Sequence[GraspRecord],
    training: str,
    seed: int = 0,
    descriptor: Any = None,
) -> list[GraspRecord]:
    """``fit_on`` (a regime's records) with grasps of the user's own hand whose shapes are known
    added (``train --known``): the model then learns that hand beside the simulated ones.
    They are read like the rest (``noise-aware`` augments them too) but never checked as a
    randomised dataset; each of their shapes must be one the training data has. A
    ``descriptor`` that reads contacts (``contact-normals``) is refused with recordings of a
    real hand, which carry none: their vectors would all be zero."""
    known = list(known)
    if not known:
        raise UsageError("--known holds no grasps")
    if getattr(descriptor, "reads_contacts", False):
        blind = [r for r in known if r.source != "simulated"]
        if blind:
            raise UsageError(
                f"--known holds {len(blind)} recording(s) of a real hand, which carry no contact "
                f"data, and descriptor {descriptor.name} reads contacts: their features would all "
                "be zero; choose a descriptor of joint angles"
            )
    have = {r.shape for r in fit_on}
    extra = sorted({r.shape for r in known} - have)
    if extra:
        raise UsageError(
            f"--known holds {extra[0]!r}, a shape the training data lacks "
            f"(it has {', '.join(sorted(have))})"
        )
    if training == "noise-aware":
        from .robust import augment

        known = augment(known, seed=seed + 1)
    return [*fit_on, *known]
