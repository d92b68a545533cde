"""The shape fits a process keeps: each grasp's fit is computed once however often it is asked
for (``predict`` then ``predict_proba``, the doubt calibration's folds, the cross-check of the
same records), and a family the grid alone decided (:func:`.shape_fit.name_or_fit`) is kept
apart from whole fits, so that code needing the sizes still computes them. Keyed by the
measured angles, the families and the calibration object."""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence

from .family_fit import ShapeFit, measured_features
from .shape_model import Calibration

FIT_CACHE = 8192
"""Fits (and, apart, grid-decided names) kept in memory: the oldest go first."""

_FITS: OrderedDict = OrderedDict()
"""Whole fits (:func:`.shape_fit.fit_shape`), keyed by :func:`_key`."""
_NAMES: OrderedDict = OrderedDict()
"""Families :func:`.shape_fit.name_or_fit` decided on the grid alone, keyed as :data:`_FITS`."""


def _key(angles, families: Sequence[str], cal: Calibration, features: bool) -> tuple:
    measured = angles if features else measured_features(angles)
    return (measured.tobytes(), tuple(dict.fromkeys(families)), id(cal))


def cached_fit(
    angles, families: Sequence[str], cal: Calibration, features: bool = False
) -> ShapeFit | None:
    """The whole fit kept for final angles (3, 4) (or, ``features``, their measured features),
    ``families`` and ``cal``; None where there is none."""
    return _lookup(_FITS, _key(angles, families, cal, features), cal)


def _lookup(table: OrderedDict, key: tuple, cal: Calibration):
    hit = table.get(key)
    if hit is None or hit[0] is not cal:
        return None
    table.move_to_end(key)
    return hit[1]


def keep_fit(
    angles, families: Sequence[str], cal: Calibration, fit: ShapeFit, features: bool = False
) -> ShapeFit:
    """Keep ``fit`` as :func:`.shape_fit.fit_shape`'s answer for these angles, families and
    coefficients (perhaps computed in another process of :mod:`.fit_batch`); returns it."""
    _FITS[_key(angles, families, cal, features)] = (cal, fit)
    if len(_FITS) > FIT_CACHE:
        _FITS.popitem(last=False)
    return fit


def cached_answer(
    angles, families: Sequence[str], cal: Calibration, features: bool = False
) -> ShapeFit | str | None:
    """What this process knows of the shape fit of these angles: the whole fit where one is
    kept, else the family name the grid decided, else None (the key computed once)."""
    key = _key(angles, families, cal, features)
    found = _lookup(_FITS, key, cal)
    return found if found is not None else _lookup(_NAMES, key, cal)


def keep_name(
    angles, families: Sequence[str], cal: Calibration, name: str, features: bool = False
) -> str:
    """Keep ``name`` as :func:`.shape_fit.name_or_fit`'s answer (decided on the grid, perhaps
    in another process) for these angles, families and coefficients; returns it."""
    _NAMES[_key(angles, families, cal, features)] = (cal, name)
    if len(_NAMES) > FIT_CACHE:
        _NAMES.popitem(last=False)
    return name
