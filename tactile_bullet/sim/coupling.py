"""How the controller splits the coupled J0 = J1 + J2 of a long finger between J2 and J1.

On the real hand one motor pulls a tendon that moves both joints; PyBullet has no tendons, so
on the ``bullet`` engine the controller decides where each increment of J0 goes. That decision
is one pure function here, chosen by name, so another rule (J2 first, equal torque, distal
first, ...) is one entry in :data:`COUPLINGS`. An engine that couples the joints itself
(``Engine.tendon``, e.g. ``mujoco``'s fixed tendon) only takes the sum of the two targets; the
rule still decides, from what the joints report, when the finger is done.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple


class TendonState(NamedTuple):
    """A finger's J0 stage: the J2 and J1 targets (rad), whether J2 still takes the travel,
    and whether the finger is done."""

    t2: float
    t1: float
    j2_free: bool
    done: bool


def j2_first(
    state: TendonState,
    j2_blocked: bool,
    j1_blocked: bool,
    q2: float,
    q1: float,
    upper2: float,
    upper1: float,
    delta: float,
) -> TendonState:
    """J0's travel goes to J2 while it is free, then to J1 (the middle phalanx leads, as the
    sheet describes the real hand); the finger is done when J1 is blocked, or at its limit
    once J2 is. A joint that stops holds the angle it was measured at (``q2``, ``q1``)."""
    t2, t1, j2_free = state.t2, state.t1, state.j2_free
    if j2_free and (j2_blocked or t2 >= upper2):
        j2_free, t2 = False, q2
    if j1_blocked or (not j2_free and t1 >= upper1):
        return TendonState(t2, q1, j2_free, True)
    if j2_free:
        t2 = min(t2 + delta, upper2)
    else:
        t1 = min(t1 + delta, upper1)
    return TendonState(t2, t1, j2_free, False)


Coupling = Callable[..., TendonState]

COUPLINGS: dict[str, Coupling] = {"j2-first": j2_first}
"""Coupling rules by name (``Engine.coupling``)."""

DEFAULT_COUPLING = "j2-first"
"""Today's rule; every record made so far used it."""
