"""Where an object sits in front of the open hand: the same for every engine and every model.

The simulators place the object here, and the training-free models (theoretical signatures,
the shape fit) assume it here, so the numbers live below both.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..hand import PALM_HALF_THICKNESS
from ..records import Pose
from .shapes import Shape

STANDOFF = 0.005
"""Gap (m) between the palm's grip surface and the nearest point of the object at zero offset."""

GRASP_Z = 0.09
"""z (m) of the object's axis at zero offset: the sheet's grasp centre height."""

CLEARANCES = (((-0.045, 0.045), PALM_HALF_THICKNESS), ((0.034, 0.115), 0.0206))
"""(x range, depth in front of the palm plane) of what the object must clear at rest: the palm
across the fingers, and the open thumb (its 12 mm capsules lie 8.6 mm in front of the palm
plane from its base at x = 34 mm to its tip near x = 103 mm)."""


def object_position(shape: Shape, params: Mapping[str, float], pose: Pose) -> tuple[float, ...]:
    """Object axis at height GRASP_Z, STANDOFF clear of the open palm and thumb, then the
    pose's offset and its rotation about the palm normal.

    The nominal depth depends on the object's size (a large object sits further out) so that
    the same offset means the same thing for every size: "this far from the resting place".
    """
    # A cross-section at u along O-O' reaches r(u) toward the palm; turned by alpha about the
    # palm normal it sits at x = u cos(alpha). The nearest point over the hand's span sets
    # the depth (a dense profile, not the mesh vertices: a cone's mesh has none mid-length).
    u = np.linspace(-0.3, 0.3, 1201)
    x = u * np.cos(pose.rotation)
    # a mesh's sections reach toward the palm further than their equivalent circles
    radius = (getattr(shape, "palm_reach", None) or shape.radius)(u, **params)
    y0 = 0.0
    for (lo, hi), depth in CLEARANCES:
        reach = radius[(x >= lo) & (x <= hi)]
        if reach.size:
            y0 = min(y0, -depth - STANDOFF - float(reach.max()))
    pos = np.array([0.0, y0, GRASP_Z]) + np.asarray(pose.offset)
    return tuple(float(v) for v in pos)
