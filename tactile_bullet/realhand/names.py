"""The names a recording uses: Shadow's joint names (with a hand prefix or not), the coupled J0,
and the topics and columns the readers and ``export`` agree on.

Kept below the calibration and the readers, which all need a published name's canonical form.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from ..errors import UsageError
from ..hand import JOINT_NAMES, LONG_FINGERS

DEFAULT_TOPIC = "/joint_states"
MARKER_TOPIC = "/tactile_bullet/grasp"
"""The marker topic ``export`` writes; used on import when present and no other is named."""
MARKER_COLUMN = "grasp"
"""The marker column ``export`` writes; used on import when present."""
TIME_COLUMN = "time"
LABEL_COLUMN = "shape"
NO_MARKER = "none"
"""``--marker none``: ignore the file's markers, cut by silence between closures."""
UNKNOWN_SHAPE = "unknown"
"""Label of a recorded grasp whose object the user did not name."""
JOINT_STATE = "sensor_msgs/msg/JointState"
OBJECT_COLUMN = "object"
"""Table column naming the object a grasp was made on: grasps with the same value are grasps
of one object, which ``identify --recording`` fuses into one answer."""

COUPLED_FINGERS = LONG_FINGERS
OPTIONAL_JOINTS = frozenset({"WRJ1", "WRJ2"})
"""Joints a recording may leave out (recorded as 0, as the simulated wrist is welded)."""

_NAME = re.compile(
    r"^(?:(?P<prefix>[A-Za-z][A-Za-z0-9]*)_)?(?P<joint>(?:FF|MF|RF|LF|TH|WR)J\d)$", re.I
)
_KNOWN = frozenset(JOINT_NAMES) | {f"{f.upper()}J0" for f in COUPLED_FINGERS}


def split_name(name: str) -> tuple[str, str] | None:
    """(prefix, canonical joint) of a published name (``rh_FFJ3`` -> ("rh", "FFJ3")), or None
    for a name that is no Shadow joint."""
    match = _NAME.match(str(name).strip())
    if match is None:
        return None
    joint = match["joint"].upper()
    return (match["prefix"] or "", joint) if joint in _KNOWN else None


def is_hand_message(names: Sequence[str]) -> bool:
    """Whether a joint-state message is the hand's: it names at least one Shadow joint.
    Messages of other robots on the same topic (an arm's, on a shared /joint_states) are
    skipped; a hand message with an unknown name is an error."""
    return any(split_name(n) is not None for n in names)


def canonical_joint(name: str) -> str | None:
    """``rh_FFJ3`` -> ``FFJ3``; None for a name that is no Shadow joint."""
    parts = split_name(name)
    return None if parts is None else parts[1]


_TOPIC = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*)+")


def check_topic(topic: str, what: str = "--topic") -> str:
    """A topic as a bag records it: a fully qualified ROS name (``/`` then tokens of letters,
    digits and underscores, none starting with a digit, separated by single ``/``, no
    trailing ``/``): what both ROS 1 and ROS 2 accept, so a bag written here plays back."""
    if not isinstance(topic, str) or not _TOPIC.fullmatch(topic):
        raise UsageError(
            f"{what} {topic!r} is not a ROS topic name: '/' then names of letters, digits and "
            "_ (not starting with a digit), separated by single '/', e.g. /joint_states"
        )
    return topic


def hand_prefix(names: Sequence[str]) -> str:
    """The hand prefix ("rh") of the first Shadow joint among ``names``; "" for none."""
    for name in names:
        parts = split_name(name)
        if parts is not None:
            return parts[0].lower()
    return ""


def prefix_option(text: str | None) -> str | None:
    """``--prefix rh_`` (or ``rh``) as the prefix names carry ("rh"); "none" for names
    without one; None when not given (a recording must then hold one hand)."""
    if text is None:
        return None
    value = text.strip().rstrip("_").lower()
    if value.lower() == "none":
        return ""
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9]*", value):
        raise UsageError(f"--prefix must be letters and digits like 'rh_', got {text!r}")
    return value
