"""Cutting a stream of joint samples into grasps where no marker says where they are.

A gap without messages ends a grasp; a grasp starts where the hand's closure (the mean of
J3 + J2 + J1 over the long fingers) rises above its lowest value and ends where the hand opens
(see :class:`GraspSegmenter`).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import UsageError
from .joints import closure

GAP_S = 0.5
"""Silence (s) without messages that ends a grasp."""
START_RISE = 0.1
"""Closure rise (rad, mean J3 + J2 + J1 over the long fingers) that starts a grasp."""
RELEASE_DROP = 0.3
"""Closure fall (rad) below the peak that means the hand opened: the grasp is over."""
HOLD_TOL = 0.05
"""Samples within this closure (rad) of the peak still belong to the held grasp."""
SETTLE_S = 0.15
"""Time (s) the closure must stay within ``STILL_TOL`` for a grasp to count as settled
(streaming: ``grasp_over``); with sensor noise, the span of each of two successive windows
of this length whose mean closures agree within ``STILL_TOL``."""
STILL_TOL = 0.01
"""Closure change (rad) that counts as motion. A real hand's 1 deg joint noise moves single
samples of the closure by ~0.015 rad, so samples alone never stay within it; window means
of 0.15 s (15 samples at 100 Hz) wander by ~0.004 rad and do."""

# --- segmentation -----------------------------------------------------------------------------


class GraspSegmenter:
    """Cuts a stream of (time, closure) samples into grasps by silence between closures.

    Fed one sample at a time (the streaming identifier) or a whole recording
    (:func:`segment_by_silence`); ``push`` returns the (start, end) sample indices of a grasp
    the new sample has ended (a gap, or the hand opening), ``finish`` the one still running.
    """

    def __init__(self, gap_s: float = GAP_S) -> None:
        if isinstance(gap_s, bool) or not isinstance(gap_s, int | float) or not (
            math.isfinite(gap_s) and gap_s > 0
        ):  # "0.5" or True is no number of seconds
            raise UsageError(f"gap must be a positive number of seconds, got {gap_s!r}")
        self.gap_s = float(gap_s)
        self.reset()

    def reset(self) -> None:
        self.last_t: float | None = None
        self.last_i = -1
        self.closing = False
        self.start = 0
        self.c_min = math.inf
        self.i_min = 0
        self.c_max = -math.inf
        self.i_high = 0
        self.c_ref = 0.0
        self.still_since = 0.0
        self.settled = False
        self.level = 0.0
        # the settled closure: a window mean, or the still samples' reference
        self._window = (0.0, 0.0, 0)  # start time, sum, count of the running window
        self._prev_mean: float | None = None

    def _open_at(self, i: int, c: float) -> None:
        self.closing = False
        self.settled = False
        self.c_min, self.i_min = c, i

    def push(self, i: int, t: float, c: float) -> tuple[int, int] | None:
        done = None
        if self.last_t is not None and t - self.last_t > self.gap_s:
            done = self.finish()
            self._open_at(i, c)
        self.last_t, self.last_i = t, i
        if not self.closing:
            if c < self.c_min:
                self.c_min, self.i_min = c, i
            elif c > self.c_min + START_RISE:
                self.closing, self.start = True, self.i_min
                self.c_max, self.i_high = c, i
                self.c_ref, self.still_since = c, t
                self._window, self._prev_mean = (t, 0.0, 0), None
            return done
        if c >= self.c_max:
            self.c_max = c
        if c >= self.c_max - HOLD_TOL:
            self.i_high = i
        if c < self.c_max - RELEASE_DROP:
            done = (self.start, self.i_high)
            self._open_at(i, c)
            return done
        self._settle(t, c)
        return done

    def _settle(self, t: float, c: float) -> None:
        """Settled: the samples stayed within STILL_TOL for SETTLE_S (a clean sensor), or two
        successive SETTLE_S windows' mean closures agree within it (a noisy one). Once
        settled, it holds until a window's mean moves off the settled level by 2 STILL_TOL or
        a sample by 2 HOLD_TOL: motion, not noise (3.6 and 6.6 standard deviations of the
        closure's noise at 1 deg per joint, so a noisy hold is not undecided every few s)."""
        if abs(c - self.c_ref) > STILL_TOL:
            self.c_ref, self.still_since = c, t
        start, total, n = self._window
        total, n = total + c, n + 1
        mean = None
        if t - start >= SETTLE_S:
            mean, self._window = total / n, (t, 0.0, 0)
        else:
            self._window = (start, total, n)
        if self.settled:
            moved = abs(c - self.level) > 2 * HOLD_TOL or (
                mean is not None and abs(mean - self.level) > 2 * STILL_TOL
            )  # fmt: skip
            if moved:
                self.settled = False
                self.c_ref, self.still_since = c, t
        elif t - self.still_since >= SETTLE_S:
            self.settled, self.level = True, self.c_ref
        elif mean is not None and self._prev_mean is not None:
            if abs(mean - self._prev_mean) <= STILL_TOL:
                self.settled, self.level = True, mean
        if mean is not None:
            self._prev_mean = mean

    def finish(self) -> tuple[int, int] | None:
        """The grasp running at the end of the data (or before a gap), if any."""
        if not self.closing:
            return None
        self.closing = False
        return (self.start, self.last_i)


def segment_by_silence(time: np.ndarray, angles: np.ndarray, gap_s: float = GAP_S):
    """(start, end) inclusive sample ranges of the grasps in a recording (see module doc)."""
    seg = GraspSegmenter(gap_s)
    out = []
    levels = closure(angles).tolist()
    for i, (t, c) in enumerate(zip(time.tolist(), levels, strict=True)):
        done = seg.push(i, t, c)
        if done is not None:
            out.append(done)
    done = seg.finish()
    if done is not None:
        out.append(done)
    return out
