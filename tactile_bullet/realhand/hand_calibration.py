"""The hand calibration file ``tactile-bullet calibrate`` writes, and the known-sizes file it reads.

The file is small TOML a user can read and keep beside their recordings::

    version = 1
    hand = "rh"                      # joint-name prefix of the calibrated hand ("" simulated)
    data = "known-grasps"            # what it was fitted on
    [coefficients]                   # the shape fit's correction (perception/shape_model.py)
    intercept = [[...4], [...4]]     # rows J3, J0; columns ff, mf, rf, lf (rad)
    gain = ...; side = ...; sigma = ...; loss_scale = 2.0; penalty = 0.0
    [coefficients.family]            # only from grasps of known sizes (--sizes): an offset
    sphere = [[...4], [...4]]        # per shape family added to its J3, J0 (rad)
    [offsets_deg]                    # intercepts' change from the shipped ones: the joint
    J3 = [...4]; J0 = [...4]         # offsets the data allowed (informational)
    [grasps_per_shape]
    cone = 2
    [report]                         # how the pull toward the shipped coefficients was chosen
    ...

Every field is checked on load (a wrong version, a missing table, coefficients that are not
2 x 4 finite numbers, a gain outside 0.2-5, a family offset past 45 deg or of no fitted shape):
a damaged file is refused on one line, never used.
The known-sizes file names each calibration object's sizes by shape (m)::

    [cylinder]
    radius = 0.04
    length = 0.2
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..files import read_toml, write_bytes_atomic
from ..perception.shape_model import Calibration, calibration_in_force, load_calibration

VERSION = 1
WHAT = "calibration file"
"""The input kind (``files.INPUT_LIMITS``): a hand calibration is a few hundred bytes."""
GAIN_RANGE = (0.2, 5.0)
"""A gain outside this is no hand's: the fit ran away or the file was edited wrongly."""
FAMILY_RANGE_DEG = 45.0
"""A family offset beyond this is no hand's: the fit ran away or the file was edited wrongly."""
COEFFICIENT_BOUNDS: dict[str, tuple[float, float]] = {
    "intercept": (-math.radians(45.0), math.radians(45.0)),
    "gain": GAIN_RANGE,
    "side": (-5.0, 5.0),
    "sigma": (1e-4, 1.0),
    "loss_scale": (0.1, 100.0),
    "penalty": (0.0, 100.0),
}
"""The range of every coefficient a hand calibration may hold (rad where an angle): wide
around what ``calibrate`` writes (the shipped intercepts within 12 deg, gains 0.8-1.1, side
terms within 0.2, sigma 0.01-0.11 rad; loss_scale 4 and penalty 6 copied from the shipped
file), narrow enough that a file edited to ``intercept = 1e9`` or ``sigma = 1e-300`` is
refused instead of scoring every grasp as noise (docs/calibration.md)."""
_KEYS = {"version", "hand", "data", "coefficients", "offsets_deg", "grasps_per_shape", "report"}


@dataclass(frozen=True)
class HandCalibration:
    """A loaded hand calibration: the coefficients and what the file says about them."""

    calibration: Calibration
    hand: str
    data: str
    grasps_per_shape: dict[str, int]
    report: dict

    def to_dict(self) -> dict:
        """The ``hand_calibration`` block of JSON output (``docs/json.md``)."""
        return {"hand": self.hand, "data": self.data, "grasps_per_shape": self.grasps_per_shape,
                "strength": self.report.get("strength")}  # fmt: skip


def _toml_value(value) -> str:
    """A TOML value: numbers, strings and lists of them share JSON's spelling."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError("a calibration file holds finite numbers only")
    if isinstance(value, np.ndarray):
        value = value.tolist()
    return json.dumps(value)


def render(cal: Calibration, hand: str, data: str, counts: Mapping[str, int], report: dict) -> str:
    """The file's text (see the module docstring)."""
    shipped = load_calibration()
    lines = ["# tactile-bullet calibrate: the shape fit's coefficients for one hand",
             f"version = {VERSION}", f"hand = {_toml_value(hand)}", f"data = {_toml_value(data)}",
             "", "[coefficients]"]  # fmt: skip
    coefficients = cal.to_dict()
    family = coefficients.pop("family", {})
    for key, value in coefficients.items():
        lines.append(f"{key} = {_toml_value(value)}")
    if family:  # per-family offsets (rad), fitted on grasps of known sizes
        lines += ["", "[coefficients.family]"]
        lines += [f"{name} = {_toml_value(value)}" for name, value in family.items()]
    lines += ["", "[offsets_deg]"]
    change = np.degrees(cal.intercept - shipped.intercept)
    lines += [f"J3 = {_toml_value(np.round(change[0], 3))}",
              f"J0 = {_toml_value(np.round(change[1], 3))}", "", "[grasps_per_shape]"]  # fmt: skip
    lines += [f"{name} = {int(n)}" for name, n in counts.items()]
    lines += ["", "[report]"]
    for key, value in report.items():
        if key == "candidates":
            continue
        lines.append(f"{key} = {_toml_value('shipped' if value is None else value)}")
    for row in report.get("candidates", []):
        lines += ["", "[[report.candidates]]"]
        for key, value in row.items():
            lines.append(f"{key} = {_toml_value('shipped' if value is None else value)}")
    return "\n".join(lines) + "\n"


def write(path: str | os.PathLike, text: str) -> Path:
    return write_bytes_atomic(path, text.encode("utf-8"), "hand calibration")


def load(path: str | os.PathLike) -> HandCalibration:
    """A hand calibration file, every field checked; UsageError (one line) otherwise."""
    doc = read_toml(path, WHAT)
    where = f"hand calibration {path}"
    extra = sorted(set(doc) - _KEYS)
    if extra:
        raise UsageError(f"{where}: unknown key {extra[0]!r} (keys: {', '.join(sorted(_KEYS))})")
    if doc.get("version") != VERSION:
        raise UsageError(f"{where}: version must be {VERSION}, got {doc.get('version')!r}")
    for key in ("hand", "data"):
        if not isinstance(doc.get(key), str):
            raise UsageError(f"{where}: {key} must be a string")
    for key in ("coefficients", "grasps_per_shape", "report"):
        if not isinstance(doc.get(key), dict):
            raise UsageError(f"{where}: the [{key}] table is missing")
    coefficients = doc["coefficients"]
    strength = doc["report"].get("strength", "shipped")
    if strength != "shipped" and not (
        _is_number(strength) and math.isfinite(strength) and strength >= 0
    ):
        raise UsageError(f"{where}: report.strength must be shipped or a number >= 0, "
                         f"got {strength!r}")  # fmt: skip
    cal = checked_coefficients(coefficients, where)
    from ..perception.shape_fit import fitted_shapes

    counts = doc["grasps_per_shape"]
    for name, n in counts.items():
        if name not in fitted_shapes():
            raise UsageError(f"{where}: grasps_per_shape names {name!r}, which is no fitted shape")
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise UsageError(f"{where}: grasps_per_shape.{name} must be a positive integer")
    if len(counts) < 2:
        raise UsageError(f"{where}: grasps_per_shape must name at least two shapes")
    angles = doc["report"].get("angles", "raw")
    if angles not in ("raw", "zeroed"):
        raise UsageError(f"{where}: report.angles must be raw or zeroed, got {angles!r}")
    cal = replace(cal, angles=angles)
    return HandCalibration(cal, doc["hand"], doc["data"], dict(counts), dict(doc["report"]))


OWN_HAND_FILES = {"mujoco": "data/shape_fit_mujoco.toml"}
"""Per engine, the calibration file of the package's own hand there, where its coefficients
differ from the shipped ones (fitted on Bullet's hand): ``tactile-bullet calibrate`` on the
robustness matrix's MuJoCo training set (docs/robustness.md, the tenth replicate's
declaration)."""


@cache
def own_hand_calibration(engine: str) -> Calibration | None:
    """The coefficients of the package's own hand on ``engine`` (None: the shipped ones), read
    and checked as any hand calibration file is (:func:`load`); a damaged file is refused in
    one line, never used."""
    name = OWN_HAND_FILES.get(engine)
    if name is None:
        return None
    from importlib import resources

    try:
        with resources.as_file(resources.files("tactile_bullet").joinpath(name)) as path:
            return load(path).calibration
    except UsageError as exc:
        raise UsageError(f"{name} is missing or damaged ({exc}); reinstall tactile-bullet"
                         ) from None


def record_calibration(record) -> Calibration | None:
    """The coefficients that read ``record``'s hand, where the package has its own for it:
    a grasp of our hand on an engine in :data:`OWN_HAND_FILES` (no ``--hand-model``), with no
    hand calibration in force. None otherwise (the coefficients in force, or the shipped)."""
    if calibration_in_force() is not None:
        return None
    controller = getattr(record, "controller", None)
    if controller is None or getattr(controller, "hand_model", None):
        return None
    return own_hand_calibration(str(getattr(controller, "engine", "")))


def checked_coefficients(coefficients: Mapping, where: str) -> Calibration:
    """The shape fit's coefficients of a hand (``Calibration.to_dict``'s mapping), every value
    a number within the bounds of docs/calibration.md; UsageError (one line) otherwise. A hand
    calibration file and a model that carries its hand's calibration (``adapt``) read them
    alike."""
    from ..perception.shape_fit import fitted_shapes

    _only_numbers(coefficients, f"{where}: coefficients")
    cal = Calibration.from_dict(coefficients, where)
    for name, (lo, hi) in COEFFICIENT_BOUNDS.items():
        value = np.asarray(getattr(cal, name), float)
        if not np.all((value >= lo) & (value <= hi)):
            worst = value.flat[int(np.argmax(np.maximum(lo - value, value - hi)))]
            span = f"{lo:g}-{hi:g}" if lo >= 0 else f"{lo:g} to {hi:g}"
            raise UsageError(f"{where}: every {name} must be within {span}, got {worst:g} "
                             "(docs/calibration.md)")  # fmt: skip
    for name, offset in cal.family.items():
        if name not in fitted_shapes():
            raise UsageError(f"{where}: coefficients.family names {name!r}: no fitted shape")
        if not np.all(np.abs(np.degrees(offset)) <= FAMILY_RANGE_DEG):
            raise UsageError(f"{where}: coefficients.family.{name} must lie within "
                             f"+-{FAMILY_RANGE_DEG:g} deg")  # fmt: skip
    return cal


def _is_number(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _only_numbers(value, where: str) -> None:
    """Refuse a string or a boolean anywhere in the coefficients: ``"0.5"`` and ``true``
    would otherwise be read as numbers."""
    if isinstance(value, Mapping):
        for key, item in value.items():
            _only_numbers(item, f"{where}.{key}")
    elif isinstance(value, list):
        for item in value:
            _only_numbers(item, where)
    elif not _is_number(value):
        raise UsageError(f"{where} must hold numbers only, got {value!r}")


def load_sizes(path: str | os.PathLike) -> dict[str, dict[str, float]]:
    """Known sizes by shape (m) from a TOML file of ``[shape]`` tables; each table's values are
    resolved (defaults filled, ranges checked) as a grasp's would be."""
    from ..objects.shapes import check_consistent
    from ..perception.shape_fit import _resolve_family

    doc = read_toml(path, "sizes file")
    if not doc:
        raise UsageError(f"sizes file {path} names no shape")
    out = {}
    for name, table in doc.items():
        if not isinstance(table, dict):
            raise UsageError(f"sizes file {path}: {name} must be a table of sizes ([{name}])")
        for key, value in table.items():
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise UsageError(f"sizes file {path}: {name}.{key} must be a number (m)")
        shape = _resolve_family(name).shape
        values = shape.resolve(table)
        check_consistent(name, values)
        out[name] = {k: float(v) for k, v in values.items()}
    return out
