"""The simulated Shadow hand as data: joint names, fingers, coupling and the geometry the
signature's theory needs (finger positions along O-O', phalanx lengths).

Numbers come from ``docs/hand.md``; the URDF in ``urdf/`` is
generated from the same sheet by ``tools/make_urdf.py``.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np


def urdf_path() -> Path:
    """Where the hand's URDF is: $TACTILE_BULLET_URDF, the source tree's ``urdf/`` (editable
    installs), or the copy a wheel installs under ``<prefix>/share/tactile-bullet/urdf``."""
    override = os.environ.get("TACTILE_BULLET_URDF")
    if override:
        return Path(override)
    candidates = (
        Path(__file__).resolve().parent.parent / "urdf" / "shadow_hand.urdf",
        Path(sys.prefix) / "share" / "tactile-bullet" / "urdf" / "shadow_hand.urdf",
    )
    for path in candidates:
        if path.is_file():
            return path
    return candidates[0]


FINGERS: tuple[str, ...] = ("ff", "mf", "rf", "lf", "th")
"""Finger names in the order the FCI and every per-finger array use (thumb last)."""

LONG_FINGERS: tuple[str, ...] = ("ff", "mf", "rf", "lf")
"""The four fingers that make the FCI columns (the thumb is excluded, thesis 2.2.1)."""

JOINT_NAMES: tuple[str, ...] = (
    "WRJ2", "WRJ1",
    "FFJ4", "FFJ3", "FFJ2", "FFJ1",
    "MFJ4", "MFJ3", "MFJ2", "MFJ1",
    "RFJ4", "RFJ3", "RFJ2", "RFJ1",
    "LFJ5", "LFJ4", "LFJ3", "LFJ2", "LFJ1",
    "THJ5", "THJ4", "THJ3", "THJ2", "THJ1",
)  # fmt: skip
"""Canonical order of joint columns in every record."""

FCI_JOINTS: dict[str, tuple[str, str, str]] = {
    f: (f"{f.upper()}J3", f"{f.upper()}J2", f"{f.upper()}J1") for f in LONG_FINGERS
}
"""FCI rows per finger, proximal first: theta_1 = J3, theta_2 = J2, theta_3 = J1."""

FINGER_LINKS: dict[str, tuple[str, ...]] = {
    "ff": ("ffknuckle", "ffproximal", "ffmiddle", "ffdistal", "fftip"),
    "mf": ("mfknuckle", "mfproximal", "mfmiddle", "mfdistal", "mftip"),
    "rf": ("rfknuckle", "rfproximal", "rfmiddle", "rfdistal", "rftip"),
    "lf": ("lfmetacarpal", "lfknuckle", "lfproximal", "lfmiddle", "lfdistal", "lftip"),
    "th": ("thbase", "thproximal", "thhub", "thmiddle", "thdistal", "thtip"),
}
"""Links that belong to each finger: a contact on any of them is a contact of that finger."""

FINGER_X: dict[str, float] = {"ff": 0.033, "mf": 0.011, "rf": -0.011, "lf": -0.033}
"""x of each long finger's flexion plane in the palm frame (m): where it samples r(x)."""

KNUCKLE_Z: dict[str, float] = {"ff": 0.095, "mf": 0.099, "rf": 0.095, "lf": 0.08650}
"""z of each long finger's J3 axis in the palm frame at zero pose (m)."""

PHALANX_LENGTHS: tuple[float, float, float] = (0.045, 0.025, 0.032)
"""Proximal, middle and distal (J1 to pad end) lengths (m): the finger's arc length s."""

FINGER_LENGTH: float = float(sum(PHALANX_LENGTHS))

PALM_HALF_THICKNESS: float = 0.0111
"""Half the palm's thickness along y (m): the grip surface is at y = -PALM_HALF_THICKNESS."""

GRASP_CENTRE: tuple[float, float, float] = (0.0, -0.035, 0.09)
"""The sheet's reference grasp centre in front of the palm (m)."""

THUMB_OPPOSED: dict[str, float] = {
    "THJ5": 0.0, "THJ4": 1.2, "THJ3": 0.0, "THJ2": 0.6, "THJ1": 0.5,
}  # fmt: skip
"""Thumb held opposed during the enclosure grasp (rad), from the sheet."""

J0_MAX: float = float(np.pi)
"""Range of the coupled J0 = J1 + J2 (rad)."""


_LONG_LIMITS_DEG = {"J4": (-20.0, 20.0), "J3": (-15.0, 90.0), "J2": (0.0, 90.0),
                    "J1": (0.0, 90.0)}  # fmt: skip
JOINT_LIMITS_DEG: dict[str, tuple[float, float]] = {
    "WRJ2": (-30.0, 10.0), "WRJ1": (-40.0, 28.0),
    **{f"{f.upper()}{k}": lim for f in LONG_FINGERS for k, lim in _LONG_LIMITS_DEG.items()},
    "LFJ5": (0.0, 45.0),
    "THJ5": (-60.0, 60.0), "THJ4": (0.0, 70.0), "THJ3": (-12.0, 12.0), "THJ2": (-40.0, 40.0),
    "THJ1": (-15.0, 90.0),
    **{f"{f.upper()}J0": (0.0, 180.0) for f in LONG_FINGERS},
}  # fmt: skip
"""Each joint's range (deg, docs/hand.md; the URDF's), the coupled J0 = J1 + J2 included."""

RANGE_TOLERANCE_RAD: float = 0.35
"""How far (rad, 20 deg) a recorded joint may lie outside its range before the recording is
refused as garbage (docs/hand.md, "Recorded joint ranges"): a real hand's uncalibrated sensors
read several degrees past the limits, but a value tens of degrees out is a unit mistake, a
wrong column or corruption, and an answer computed from it would be confident nonsense."""


def joint_range(name: str) -> tuple[float, float]:
    """(lowest, highest) value (rad) a recording may hold for canonical joint ``name``."""
    lo, hi = JOINT_LIMITS_DEG[name]
    return np.radians(lo) - RANGE_TOLERANCE_RAD, np.radians(hi) + RANGE_TOLERANCE_RAD


def finger_of_joint(name: str) -> str | None:
    """The finger ('ff' ... 'th') a joint belongs to, None for the wrist."""
    prefix = name[:2].lower()
    return prefix if prefix in FINGERS else None
