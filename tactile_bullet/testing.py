"""A comparison suite for pytest: installed descriptors x classifiers x protocols, with floors.

A plugin author asserts, in their own tests, that their descriptor or classifier keeps a
minimum accuracy on the benchmark's protocols, on a small simulated set built once per test
session under pytest's cache folder (``.pytest_cache``; reused by later sessions, rebuilt if
damaged)::

    import pytest
    from tactile_bullet import testing
    from tactile_bullet.testing import comparison_data  # noqa: F401  (the session fixture)

    FLOORS = {"in-distribution": 0.8, "sensor-noise": 0.6}

    @pytest.mark.parametrize(
        "case", testing.cases(["my-descriptor"], ["svm"], FLOORS), ids=str
    )
    def test_floor(case, comparison_data):
        testing.assert_floor(comparison_data, case, FLOORS)

The sets are the protocols' ``tiny`` scale (``protocols.SCALES``): 5 training and 2 test grasps
per shape, so a floor is coarse (10 test grasps: steps of 10%) and guards against a method
breaking, not a ranking to the point. Only the sets the requested protocols read are simulated
(in-distribution, sensor-noise and sim-shift share theirs: 45 grasps).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .errors import UsageError
from .experiments import protocols as P

SCALE = "tiny"
CACHE_KEY = "tactile-bullet-comparison"
"""Folder under pytest's cache where the sets live."""


@dataclass(frozen=True)
class Case:
    """One comparison: a descriptor + classifier pair, trained one way, on one protocol."""

    protocol: str
    descriptor: str
    classifier: str
    training: str = "clean"

    def __str__(self) -> str:
        extra = "" if self.training == "clean" else f"-{self.training}"
        return f"{self.protocol}-{self.descriptor}-{self.classifier}{extra}"


def cases(
    descriptors: Sequence[str] | None = None,
    classifiers: Sequence[str] | None = None,
    protocols: Iterable[str] = ("in-distribution", "sensor-noise", "sim-shift"),
    trainings: Sequence[str] = ("clean",),
) -> list[Case]:
    """Every compatible combination; None takes every installed descriptor or classifier (so a
    newly installed plugin joins the parametrization for free)."""
    from .experiments.benchmark import check_names
    from .plugins import classifier_names, compatible, descriptor_names

    descriptors = list(descriptors) if descriptors is not None else descriptor_names()
    classifiers = list(classifiers) if classifiers is not None else classifier_names()
    names = P.resolve(list(protocols))
    check_names(descriptors, classifiers, trainings)
    return [
        Case(p, d, c, t)
        for p in names
        for d in descriptors
        for c in classifiers
        if compatible(d, c)
        for t in trainings
    ]


class ComparisonData:
    """The tiny sets under ``root``, simulated on first use, and headline scores, each fit once
    per (train set, training, descriptor, classifier)."""

    def __init__(self, root: str | os.PathLike, workers: int = 2) -> None:
        self.root = Path(root)
        self.workers = int(workers)
        self._sets: dict[str, list] = {}
        self._fits: dict[tuple, Any] = {}

    def records(self, name: str) -> list:
        """Usable records of one set, simulated (or repaired) first if needed."""
        from .experiments.benchmark import load_set, simulate_sets

        if name not in self._sets:
            spec = P.sets(SCALE)[name]
            path = self.root / name
            try:  # resumes a set a killed session left partial
                simulate_sets([spec], self.root, self.workers, False, lambda _m: None)
            except UsageError:  # a set of an older tactile-bullet, or damaged: ours to redo
                import shutil

                shutil.rmtree(path, ignore_errors=True)
                simulate_sets([spec], self.root, self.workers, False, lambda _m: None)
            self._sets[name] = load_set(path)[0]
        return self._sets[name]

    def score(self, case: Case) -> float:
        """Headline accuracy of the case's method on its protocol."""
        from .experiments.benchmark import level_seed
        from .experiments.training import labels_of
        from .learn.perturb import perturb_all
        from .learn.robust import augment
        from .plugins import get_classifier, get_descriptor

        protocol = P.protocols(SCALE)[case.protocol]
        level = protocol.headline
        desc = get_descriptor(case.descriptor)
        key = (protocol.train, case.training, case.descriptor, case.classifier)
        if key not in self._fits:
            train = self.records(protocol.train)
            if case.training == "randomized":
                train = self.records(P.randomized_name(protocol.train))
            if case.training == "noise-aware":
                train = augment(train)
            self._fits[key] = get_classifier(case.classifier).fit(
                desc.transform(train), labels_of(train)
            )
        test = [r for name in level.test for r in self.records(name)]
        if not level.sensor.is_clean:
            test = perturb_all(test, level.sensor, level_seed(case.protocol, level.name, 0))
        predicted = np.asarray(self._fits[key].predict(desc.transform(test))).astype(str)
        return float(np.mean(predicted == labels_of(test)))


def assert_floor(data: ComparisonData, case: Case, floors: Mapping[str, float]) -> float:
    """Score the case and fail (AssertionError naming the method) under its protocol's floor."""
    if case.protocol not in floors:
        raise UsageError(f"no floor set for protocol {case.protocol!r}")
    accuracy = data.score(case)
    floor = float(floors[case.protocol])
    assert accuracy >= floor, (
        f"{case.descriptor} + {case.classifier} ({case.training}) scored {100 * accuracy:.0f}% "
        f"on {case.protocol} ({protocol_level(case.protocol)}), under its floor "
        f"{100 * floor:.0f}%"
    )
    return accuracy


def protocol_level(name: str) -> str:
    return P.protocols(SCALE)[name].headline.name


try:  # the fixture exists where pytest does; the module stays importable without it
    import pytest
except ImportError:  # pragma: no cover
    pytest = None

if pytest is not None:

    @pytest.fixture(scope="session")
    def comparison_data(request) -> ComparisonData:
        """The session's :class:`ComparisonData`, under pytest's cache folder (a temporary
        folder when the cache plugin is off: ``-p no:cacheprovider``)."""
        cache = getattr(request.config, "cache", None)
        if cache is not None:
            return ComparisonData(cache.mkdir(CACHE_KEY))
        return ComparisonData(request.getfixturevalue("tmp_path_factory").mktemp(CACHE_KEY))
