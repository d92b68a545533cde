"""Whether a grasp touched enough of the object to say anything about its shape.

A hand that closed on nothing still ends with joint angles, and every descriptor and
classifier will turn those into a shape name with a confident score. The name means nothing:
the fingers ran to their limits. Every place that names a shape (``identify``, the grasp's
training-free identification) asks :func:`nothing_to_identify` first and answers "no contact"
instead of a name.
"""

from __future__ import annotations

from ..hand import LONG_FINGERS

MIN_LONG_FINGERS = 2
"""Long fingers (ff, mf, rf, lf) that must touch the object for a shape answer. The signature
is a curve across the four fingers: with one finger on the object the other three sit at
their joint limits and the curve describes the hand, not the object. Three fingers (a small
object offset sideways) still carry the shape and are kept, as in the thesis' data."""

NO_CONTACT = "no contact: nothing to identify"
"""The answer, in text and in JSON ``reason``, where a grasp gives no shape information."""


def nothing_to_identify(record) -> str | None:
    """Why ``record`` cannot be identified (a one-line reason starting with
    :data:`NO_CONTACT`), or None when enough long fingers touched the object. A real hand's
    recording (``source`` "recorded") carries no contact sensing: its empty
    ``fingers_in_contact`` means unknown, not none, and it is never refused here."""
    if getattr(record, "source", "simulated") != "simulated":
        return None
    if "no_finger_moved" in record.flags:
        return (f"{NO_CONTACT} (no long finger moved: the hand's actuators or gains keep it "
                "open)")  # fmt: skip
    touching = [f for f in LONG_FINGERS if f in record.fingers_in_contact]
    if "no_contact" in record.flags or not touching:
        return f"{NO_CONTACT} (no finger touched the object)"
    if len(touching) < MIN_LONG_FINGERS:
        return (
            f"{NO_CONTACT} (only {', '.join(touching)} of the four long fingers touched the "
            f"object; at least {MIN_LONG_FINGERS} are needed)"
        )
    return None
