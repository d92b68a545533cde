"""How the coupled J0 = J1 + J2 tendon shares its travel between the middle and distal joints.

PyBullet (and any engine without tendons) ignores the Shadow hand's J1/J2 transmission, so the
controller decides, each control tick of Algorithm 1's stage J0, which of J2 (middle) and J1
(distal) the tendon's increment goes to. Real hands and other hand models differ here: in the
thesis' hand the middle phalanx leads; in a model with one actuator pulling both joints with
equal torque the distal joint curls first (issue 19: J1 ~60 deg while J2 stays near 3 deg).
A rule is a pure function of the tendon's state, so randomised training can draw it per grasp
(``ControllerSettings.coupling``) and descriptors can be tested against a change of it.

- ``j2-first`` (default, every record before the rule existed): the travel goes to J2 while it
  is free, then to J1; the finger is done when J1 is blocked (or at its limit once J2 stopped).
- ``distal-first``: the mirror: J1 first, then J2; done when J2 is blocked (or at its limit
  once J1 stopped).
- ``equal-torque``: both joints share the travel equally while both are free (all of it to the
  one left free); each stops where it is blocked or at its limit; done when both stopped.
"""

from __future__ import annotations

from typing import NamedTuple

from ..records import COUPLINGS

__all__ = ["COUPLINGS", "Tendon", "advance"]


class Tendon(NamedTuple):
    """One finger's J0 stage: the targets of J2 and J1 (rad), which of them still take the
    tendon's travel, and whether the finger is done."""

    t2: float = 0.0
    t1: float = 0.0
    free2: bool = True
    free1: bool = True
    done: bool = False


def advance(
    rule: str,
    tendon: Tendon,
    blocked: tuple[bool, bool],
    measured: tuple[float, float],
    delta: float,
    upper: tuple[float, float],
) -> Tendon:
    """One control tick of stage J0 under ``rule``.

    ``blocked``: whether J2 and J1 are blocked (effort over thresT, or contact) this tick;
    ``measured``: their measured angles (a joint that stops holds the angle it was measured at);
    ``delta``: the tendon's travel per tick (rad); ``upper``: the joints' upper limits.
    """
    if rule == "j2-first":
        return _sequential(tendon, blocked, measured, delta, upper, lead=0)
    if rule == "distal-first":
        return _sequential(tendon, blocked, measured, delta, upper, lead=1)
    if rule == "equal-torque":
        return _shared(tendon, blocked, measured, delta, upper)
    raise ValueError(f"unknown coupling {rule!r} (known: {', '.join(COUPLINGS)})")


def _sequential(tendon, blocked, measured, delta, upper, lead: int) -> Tendon:
    """The ``lead`` joint (0: J2, 1: J1) takes the travel until it stops, then the other; the
    finger ends when the other joint is blocked, or at its limit once the lead stopped."""
    t = [tendon.t2, tendon.t1]
    free = [tendon.free2, tendon.free1]
    other = 1 - lead
    if free[lead] and (blocked[lead] or t[lead] >= upper[lead]):
        free[lead] = False
        t[lead] = measured[lead]
    if blocked[other] or (not free[lead] and t[other] >= upper[other]):
        t[other] = measured[other]
        free[other] = False
        return Tendon(t[0], t[1], free[0], free[1], True)
    moving = lead if free[lead] else other
    t[moving] = min(t[moving] + delta, upper[moving])
    return Tendon(t[0], t[1], free[0], free[1], False)


def _shared(tendon, blocked, measured, delta, upper) -> Tendon:
    t = [tendon.t2, tendon.t1]
    free = [tendon.free2, tendon.free1]
    for k in (0, 1):
        if free[k] and (blocked[k] or t[k] >= upper[k]):
            free[k] = False
            t[k] = measured[k]
    moving = [k for k in (0, 1) if free[k]]
    if not moving:
        return Tendon(t[0], t[1], False, False, True)
    for k in moving:
        t[k] = min(t[k] + delta / len(moving), upper[k])
    return Tendon(t[0], t[1], free[0], free[1], False)
