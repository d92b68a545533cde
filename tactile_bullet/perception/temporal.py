"""Temporal analysis of the grasp (thesis chapter 3): image G, Gbin, non-contact fingers.

Pure functions on a grasp's joint-angle time series, so a real hand's recorded joint states go
through the same code as simulated grasps. The input is ``time`` (T,) in s and ``angles``
(T, 3, 4) in rad: rows J3, J2, J1, columns ff, mf, rf, lf, as ``GraspRecord.fci_series``.

Pipeline::

    angles (T, 3, 4) --image_g--> G (N, 4) grey levels at f_G --gbin--> Gbin (N, 4) 0/1
        --finger_areas--> per finger: contact time (end of area 1), adaptation end (area 2.1)
    G --DynamicDetector (row by row)--> per finger contact / no contact and when it was known
    angles --position_detector--> the same from the joint limits

What G holds. Row i of G is, per finger, the spread (max - min) of the FCI column at time
t_i: with the FCI's cumulative grey levels (``signature.fci``) that is the coupled distal angle
J0 = J2 + J1 in grey levels. Algorithm 1 closes J3 first and J0 after it, so a finger's column
stays at 0 while the proximal phalanx travels to the object (area 1), rises while the finger
conforms to it (area 2.1: the tendon wraps the middle and distal phalanges), then holds
(area 2.2) until the grasp ends; rows after the end are area 3. A finger that misses the object
runs J3 to its limit and then J0 to its own limit in one uninterrupted rise.

The two detectors of thesis 3.2:

- position-based: a finger whose J3 and coupled J0 = J1 + J2 both reached their limits never
  met anything. The test is on the sum because the J1/J2 tendon shares its travel between the
  two joints: a finger whose middle phalanx is blocked by the object still runs J1 alone to its
  limit (J0 well short of pi), while a free finger ends with both. It can only say "contact"
  once the grasp is over (a finger still closing may yet run to its limits).
- dynamic-based: from Gbin as it grows (:class:`DynamicDetector`, fed one row at a time). A
  finger in contact stops rising within a run of about one phalanx's travel: its middle or
  distal phalanx meets the object, and the tendon's hand-over from a blocked J2 to J1 shows as
  a stall in Gbin. A free finger's column rises without a stall for the whole J0 range. So a
  column that has risen without a stall for longer than ``run_s`` is a finger out of contact,
  known long before it reaches its limits, and a column that has stopped for ``settle_s`` is a
  finger in contact.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError
from ..hand import LONG_FINGERS
from .signature import (
    FCI_SHAPE,
    FLAT_FLOOR,
    JOINT_FULL_SCALE,
    UPSCALE,
    fci,
    resample_line,
    signature_from_angles,
    signature_from_lines,
)

F_G = 60.0
"""Rate (Hz) at which rows of G are sampled: the simulator's record rate."""

NOMINAL_SPEED = 1.44
"""Closing speed (rad/s) of a joint under the default controller (0.006 rad per 1/240 s tick):
the speed the detector's defaults below are set for."""

GBIN_THRESHOLD = 30.0
"""|dG/dt| (grey levels per s, 8-bit FCI) above which a Gbin pixel is 1: about 40% of the
simulated free closing speed of J0 (1.44 rad/s, 78 grey levels per s), well above the drift of
a settled finger (< 5 per s)."""

RUN_S = 1.4
"""Dynamic detector: a column rising this long without a stall is a finger out of contact. A
free finger's J0 rises for about 2.1 s; over a third of the thesis preset (1,524 fingers, all in
contact) the longest stall-free rise of a finger in contact was 1.27 s."""

SETTLE_S = 0.1
"""Dynamic detector: a column that stays still this long after rising is a finger in contact."""

STALL_ROWS = 2
"""Rows of Gbin = 0 that end a run (one row can be a rounding blip)."""

J3_LIMIT_FRACTION = 0.9
"""Position detector: J3 at or past this fraction of its range (90 deg) counts as at the limit."""

J0_LIMIT_FRACTION = 0.9
"""Position detector: J0 = J1 + J2 at or past this fraction of its range (180 deg)."""

MIN_SAMPLES = 3
"""Shortest time series the temporal functions accept (a derivative needs three rows)."""


@dataclass(frozen=True, eq=False)
class ImageG:
    """Image G: ``rows`` (N, 4) grey levels, one row per ``time`` (N,) s, one column per long
    finger (ff, mf, rf, lf); ``rate`` the sampling rate f_G (Hz)."""

    time: np.ndarray
    rows: np.ndarray
    rate: float
    bits: int = 8


@dataclass(frozen=True)
class FingerAreas:
    """Where the areas of Fig 3.3 lie in one finger's column, as times (s).

    ``contact_s``: end of area 1 (the finger reached the object, or J3 its limit); ``adapted_s``:
    end of area 2.1 (the finger stopped conforming); both None when the column never rose.
    ``end_s``: the last filled row (area 3 follows in a fixed-height image)."""

    contact_s: float | None
    adapted_s: float | None
    end_s: float


@dataclass(frozen=True)
class Detection:
    """A detector's verdict: per long finger whether it is out of contact and when (s) that was
    known, and the time by which every finger was decided."""

    non_contact: tuple[bool, ...]
    decided_s: tuple[float, ...]
    method: str

    @property
    def decided_at_s(self) -> float:
        return float(max(self.decided_s))

    @property
    def non_contact_fingers(self) -> tuple[str, ...]:
        return tuple(f for f, out in zip(LONG_FINGERS, self.non_contact, strict=True) if out)

    @property
    def contact_mask(self) -> np.ndarray:
        return ~np.asarray(self.non_contact, dtype=bool)

    def summary(self) -> dict:
        """The ``grasp --json`` form: ``{"non_contact": [...], "decided_at_s": ...}``."""
        return {
            "non_contact": list(self.non_contact_fingers),
            "decided_at_s": self.decided_at_s,
            "decided_s": dict(zip(LONG_FINGERS, map(float, self.decided_s), strict=True)),
        }


# --- input ----------------------------------------------------------------------------------


def check_series(time, angles) -> tuple[np.ndarray, np.ndarray]:
    """``time`` (T,) increasing and ``angles`` (T, 3, 4) finite, T >= MIN_SAMPLES."""
    try:
        t = np.asarray(time, dtype=float)
        a = np.asarray(angles, dtype=float)
    except (TypeError, ValueError):
        raise UsageError("a joint-angle time series must be numbers") from None
    if t.ndim != 1 or t.size < MIN_SAMPLES:
        raise UsageError(
            f"the temporal analysis needs a time series of at least {MIN_SAMPLES} samples, "
            f"got {t.size if t.ndim == 1 else t.shape} (a record of final angles only has none)"
        )
    if a.shape != (t.size, *FCI_SHAPE):
        raise UsageError(
            f"joint angles over time must be (T, 3, 4) with T = {t.size} (rows J3, J2, J1; "
            f"columns ff, mf, rf, lf), got shape {a.shape}"
        )
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(a))):
        raise UsageError("the time series contains NaN or infinity")
    if np.any(np.diff(t) <= 0):
        raise UsageError("the time series' times must increase strictly")
    return t, a


def record_series(record) -> tuple[np.ndarray, np.ndarray]:
    """(time, angles (T, 3, 4)) of a GraspRecord, checked; a record without a time series (e.g.
    final angles imported from a real hand) is a UsageError."""
    time = np.asarray(getattr(record, "time", np.empty(0)), dtype=float)
    angles = np.asarray(getattr(record, "angles", np.empty(0)), dtype=float)
    if time.ndim != 1 or time.size < MIN_SAMPLES or angles.ndim != 2 or len(angles) != time.size:
        raise UsageError(
            f"record of {getattr(record, 'shape', '?')} has no joint-angle time series "
            f"({time.size} samples): the temporal analysis needs the grasp as it ran"
        )
    return check_series(time, record.fci_series())


# --- image G and Gbin -----------------------------------------------------------------------


def g_row(angles, bits: int = 8) -> np.ndarray:
    """One row of G from one (3, 4) configuration: per finger, max - min of its FCI column."""
    k = 2.0**bits / 3.0
    column = k * np.cumsum(np.asarray(angles, dtype=float), axis=-2) / JOINT_FULL_SCALE
    return column.max(axis=-2) - column.min(axis=-2)


def image_g(time, angles, rate: float = F_G, bits: int = 8) -> ImageG:
    """Image G of a grasp (Fig 3.2) sampled at ``rate`` Hz from the first to the last time.

    The series is resampled linearly onto the f_G grid, so a recording at any rate (or with
    jitter) gives rows at the same spacing."""
    t, a = check_series(time, angles)
    if not (np.isfinite(rate) and rate > 0):
        raise UsageError(f"f_G must be a positive rate in Hz, got {rate!r}")
    grid = t[0] + np.arange(int(np.floor((t[-1] - t[0]) * rate + 1e-9)) + 1) / rate
    if grid.size < MIN_SAMPLES:
        raise UsageError(f"at f_G = {rate:g} Hz the grasp gives {grid.size} rows of G (< 3)")
    full = g_row(a, bits)  # (T, 4)
    rows = np.stack([np.interp(grid, t, full[:, f]) for f in range(full.shape[1])], axis=1)
    return ImageG(grid, rows, float(rate), bits)


def g_of(record, rate: float = F_G, bits: int = 8) -> ImageG:
    """Image G of a GraspRecord."""
    return image_g(*record_series(record), rate=rate, bits=bits)


def g_derivative(image: ImageG) -> np.ndarray:
    """dG/dt (N, 4), grey levels per s: OpenCV's Sobel along time (one column per finger, no
    smoothing across fingers), central differences inside, one-sided at the ends."""
    import cv2

    rows = np.ascontiguousarray(image.rows, dtype=np.float64)
    if len(rows) < MIN_SAMPLES:
        raise UsageError(f"image G needs at least {MIN_SAMPLES} rows, got {len(rows)}")
    # ksize=1 is the plain [-1, 0, 1] kernel along y; the border replicated makes the first
    # and last rows one-sided differences (half the kernel's reach, hence the factor 2 there).
    d = cv2.Sobel(rows, cv2.CV_64F, 0, 1, ksize=1, borderType=cv2.BORDER_REPLICATE)
    d[1:-1] *= image.rate / 2.0
    d[[0, -1]] *= image.rate
    return d


def gbin(image: ImageG, threshold: float = GBIN_THRESHOLD) -> np.ndarray:
    """Binarised G (Fig 3.3 B): 1 where the finger's coupled angle is changing faster than
    ``threshold`` grey levels per s (scaled to the image's bit depth), else 0. uint8 (N, 4)."""
    if not (np.isfinite(threshold) and threshold > 0):
        raise UsageError(f"the Gbin threshold must be a positive number, got {threshold!r}")
    scale = 2.0 ** (image.bits - 8)
    return (np.abs(g_derivative(image)) > threshold * scale).astype(np.uint8)


def _runs(column: np.ndarray, stall: int) -> list[tuple[int, int]]:
    """[start, end) row ranges of 1s in a 0/1 column, gaps shorter than ``stall`` bridged."""
    on = np.flatnonzero(column)
    if on.size == 0:
        return []
    runs, start, last = [], int(on[0]), int(on[0])
    for i in on[1:]:
        if i - last - 1 >= stall:
            runs.append((start, last + 1))
            start = int(i)
        last = int(i)
    runs.append((start, last + 1))
    return runs


def finger_areas(image: ImageG, binary=None, stall: int = STALL_ROWS) -> tuple[FingerAreas, ...]:
    """Areas 1 / 2.1 / 2.2 of each finger's column (Fig 3.3): area 2.1 spans from the first
    row the column rises to the last (stalls shorter than ``stall`` rows bridged; later
    isolated blips, a neighbour's push, ignored when shorter than a tenth of a second)."""
    b = gbin(image) if binary is None else np.asarray(binary)
    blip = max(stall, int(round(0.1 * image.rate)))
    out = []
    for f in range(b.shape[1]):
        runs = _runs(b[:, f], stall)
        if not runs:
            out.append(FingerAreas(None, None, float(image.time[-1])))
            continue
        kept = [runs[0]] + [r for r in runs[1:] if r[1] - r[0] >= blip]
        start, end = kept[0][0], kept[-1][1]
        adapted = float(image.time[min(end, len(image.time) - 1)])
        out.append(FingerAreas(float(image.time[start]), adapted, float(image.time[-1])))
    return tuple(out)


def area_labels(image: ImageG, areas, rows: int | None = None) -> np.ndarray:
    """(rows, 4) int image of area codes: 1, 21 (2.1), 22 (2.2), 3 (not filled). ``rows``
    defaults to G's own height; a larger one (e.g. max_time * f_G) shows area 3."""
    n = len(image.time) if rows is None else int(rows)
    out = np.full((n, len(areas)), 3, dtype=np.int16)
    filled = min(n, len(image.time))
    for f, area in enumerate(areas):
        col = out[:filled, f]
        col[:] = 1
        if area.contact_s is None:
            continue
        t = image.time[:filled]
        col[t >= area.contact_s] = 21
        col[t >= area.adapted_s] = 22
    return out


# --- detectors ------------------------------------------------------------------------------


def position_detector(
    time,
    angles,
    j3_fraction: float = J3_LIMIT_FRACTION,
    j0_fraction: float = J0_LIMIT_FRACTION,
    limit: float = JOINT_FULL_SCALE,
) -> Detection:
    """Position-based detection: a finger is out of contact from the first sample at which J3
    and the coupled J0 = J2 + J1 both passed their limits' fractions (J3's range ``limit``,
    J0's twice that); every other finger is in contact, known only at the end of the grasp."""
    t, a = check_series(time, angles)
    j3 = a[:, 0, :]
    j0 = a[:, 1, :] + a[:, 2, :]
    at_limit = (j3 >= j3_fraction * limit) & (j0 >= j0_fraction * 2.0 * limit)
    out, when = [], []
    for f in range(a.shape[2]):
        hit = np.flatnonzero(at_limit[:, f])
        out.append(bool(hit.size))
        when.append(float(t[hit[0]]) if hit.size else float(t[-1]))
    return Detection(tuple(out), tuple(when), "position")


class DynamicDetector:
    """Dynamic-based detection, fed G one row at a time (online: during a simulated grasp, or
    on a real hand's joint states as they stream in).

    Gbin of a row needs the next row (central difference), so each verdict lags one row
    (1 / f_G). Per finger: before its column first rises it is travelling (area 1); once it
    rises, a rise without a stall of ``run_s`` means out of contact, and ``settle_s`` without
    a rise means in contact. :meth:`finish` decides the rest at the end of the series
    (a finger still rising, or never risen, counts as in contact: no evidence against it).
    State is a few numbers per finger, so a stream of any length costs constant memory with
    ``history`` set.
    """

    def __init__(
        self,
        rate: float = F_G,
        threshold: float = GBIN_THRESHOLD,
        run_s: float = RUN_S,
        settle_s: float = SETTLE_S,
        stall: int = STALL_ROWS,
        bits: int = 8,
        fingers: int = len(LONG_FINGERS),
        history: int | None = None,
    ) -> None:
        for name, value in (("rate", rate), ("threshold", threshold), ("run_s", run_s),
                            ("settle_s", settle_s)):  # fmt: skip
            if not (np.isfinite(value) and value > 0):
                raise UsageError(f"dynamic detector {name} must be a positive number, got {value}")
        self.rate, self.threshold = float(rate), float(threshold) * 2.0 ** (bits - 8)
        self.run_rows = int(np.ceil(run_s * rate - 1e-9))
        self.settle_rows = max(1, int(np.ceil(settle_s * rate - 1e-9)))
        self.stall = max(1, int(stall))
        self.n = int(fingers)
        self._prev: np.ndarray | None = None
        self._cur: np.ndarray | None = None
        self._cur_t = 0.0
        self.rows = 0
        self.binary: deque[np.ndarray] = deque(maxlen=history)
        """Rows of Gbin so far (the last ``history`` only, when given: a stream can be long)."""
        self.onset = np.full(self.n, -1)
        self._run_start = np.full(self.n, -1)
        self._still = np.zeros(self.n, dtype=int)
        self.decided = np.zeros(self.n, dtype=bool)
        self.non_contact = np.zeros(self.n, dtype=bool)
        self.decided_s = np.full(self.n, np.nan)

    def push(self, row, t: float) -> np.ndarray:
        """Add G's row at time ``t`` (s); returns the fingers decided so far (bool mask)."""
        row = np.asarray(row, dtype=float)
        if row.shape != (self.n,) or not np.all(np.isfinite(row)):
            raise UsageError(f"a row of G must hold {self.n} finite values, got {row.shape}")
        if self._cur is not None:
            prev = self._prev if self._prev is not None else self._cur
            rate = self.rate / 2.0 if self._prev is not None else self.rate
            self._classify(np.abs(row - prev) * rate, self._cur_t)
        self._prev, self._cur, self._cur_t = self._cur, row, float(t)
        return self.decided.copy()

    def push_angles(self, angles, t: float, bits: int = 8) -> np.ndarray:
        """Add one (3, 4) joint configuration (rad) at time ``t``: G's row is built from it."""
        return self.push(g_row(angles, bits), t)

    def finish(self) -> Detection:
        """Classify the last row (one-sided difference) and decide every finger left."""
        if self._cur is not None and self._prev is not None:
            self._classify(np.abs(self._cur - self._prev) * self.rate, self._cur_t)
            self._prev = None
        if self.rows < MIN_SAMPLES - 1:
            raise UsageError(f"the dynamic detector needs at least {MIN_SAMPLES} rows of G")
        left = ~self.decided
        self.decided_s[left] = self._cur_t
        self.decided[left] = True
        return self.detection()

    def detection(self) -> Detection:
        when = np.where(np.isnan(self.decided_s), self._cur_t, self.decided_s)
        return Detection(tuple(map(bool, self.non_contact)), tuple(map(float, when)), "dynamic")

    def _classify(self, speed: np.ndarray, t: float) -> None:
        """One row of Gbin (per-finger |dG/dt| at time t) through each finger's state."""
        on = speed > self.threshold
        self.binary.append(on.astype(np.uint8))
        i = self.rows
        self.rows += 1
        for f in range(self.n):
            if on[f]:
                if self.onset[f] < 0:
                    self.onset[f] = i
                if self._run_start[f] < 0 or self._still[f] >= self.stall:
                    self._run_start[f] = i
                self._still[f] = 0
                if not self.decided[f] and i - self._run_start[f] + 1 >= self.run_rows:
                    self.decided[f] = self.non_contact[f] = True
                    self.decided_s[f] = t
            else:
                self._still[f] += 1
                settled = self.onset[f] >= 0 and self._still[f] >= self.settle_rows
                if settled and not self.decided[f]:
                    self.decided[f] = True
                    self.decided_s[f] = t


def dynamic_detector(image: ImageG, **params) -> Detection:
    """Dynamic-based detection over a whole image G (the row-by-row detector run to the end)."""
    det = DynamicDetector(rate=image.rate, bits=image.bits, fingers=image.rows.shape[1], **params)
    for row, t in zip(image.rows, image.time, strict=True):
        det.push(row, t)
    return det.finish()


DETECTORS = ("position", "dynamic")


def detect(record, method: str = "dynamic", rate: float = F_G) -> Detection:
    """Non-contact fingers of a GraspRecord by ``method`` ("position" or "dynamic")."""
    if method == "position":
        return position_detector(*record_series(record))
    if method == "dynamic":
        return dynamic_detector(g_of(record, rate))
    raise UsageError(f"detector must be one of {', '.join(DETECTORS)}, got {method!r}")


def contact_truth(record) -> np.ndarray:
    """Ground truth: which long fingers the record has in contact at the end (bool (4,))."""
    return np.array([f in record.fingers_in_contact for f in LONG_FINGERS])


# --- signature correction (Fig 3.11) --------------------------------------------------------

CORRECTIONS = ("none", "position", "dynamic")


def corrected_signature(angles, keep, bits: int = 8, floor: float | None = None):
    """Signature of final angles (3, 4) built from the fingers in ``keep`` (bool (4,)) only.

    The kept FCI columns are upscaled 50x like the full FCI and both lines resampled back to
    200 points, so a corrected signature compares with every pattern as an uncorrected one
    does. Fewer than two kept fingers leave no shape to correct with: the full signature."""
    floor = FLAT_FLOOR if floor is None else floor
    mask = np.asarray(keep, dtype=bool)
    if mask.shape != (FCI_SHAPE[1],):
        raise UsageError(f"keep must be 4 booleans (ff, mf, rf, lf), got shape {mask.shape}")
    if mask.all() or mask.sum() < 2:
        return signature_from_angles(angles, bits, floor)
    import cv2

    image = fci(angles, bits)
    cols = image[:, mask]
    width = cols.shape[1] * UPSCALE
    big = cv2.resize(cols, (width, FCI_SHAPE[0] * UPSCALE), interpolation=cv2.INTER_CUBIC)
    points = FCI_SHAPE[1] * UPSCALE
    lines = [resample_line(big.min(axis=0), points), resample_line(big.max(axis=0), points)]
    return signature_from_lines(image, lines, floor)


def contact_mask(record, correction: str) -> np.ndarray:
    """Fingers kept by a correction: all for "none", the detector's contacts otherwise."""
    if correction == "none":
        return np.ones(len(LONG_FINGERS), dtype=bool)
    if correction not in CORRECTIONS:
        raise UsageError(f"correction must be one of {', '.join(CORRECTIONS)}, got {correction!r}")
    return detect(record, correction).contact_mask


def signature_corrected(record, correction: str = "dynamic", bits: int = 8, floor=None):
    """A record's signature with the non-contact fingers found by ``correction`` dropped."""
    return corrected_signature(record.fci_angles(), contact_mask(record, correction), bits, floor)


def temporal_summary(record) -> dict:
    """The ``temporal`` block of ``grasp --json``: both detectors' verdicts."""
    return {m: detect(record, m).summary() for m in DETECTORS}


# --- training-free identification on corrected signatures ----------------------------------

PATTERN_MATCH = ("full", "same-fingers")
"""What a corrected signature is compared with: the full four-finger patterns (the thesis, and
the default: the kept fingers span the object as four span a centred one) or each pattern with
the same fingers dropped. On an off-centre 35 mm sphere with the little finger off it, the
corrected signature lies 8.3 from the sphere patterns in full against 17.0 with the same
fingers dropped (11.4 uncorrected); over the temporal preset both name 66-67% of the grasps."""


def _angles_of_fci(image: np.ndarray, bits: int = 8) -> np.ndarray:
    """Joint angles (3, 4) back from an FCI (the inverse of ``signature.fci``)."""
    k = 2.0**bits / 3.0
    return np.diff(np.vstack([np.zeros((1, image.shape[1])), image]), axis=0) * JOINT_FULL_SCALE / k


_LIBRARIES: dict[tuple, dict] = {}


def corrected_library(keep, floor: float | None = None) -> dict:
    """:func:`patterns.size_matched_library` with the fingers not in ``keep`` dropped from every
    pattern, built once per set of kept fingers."""
    from .patterns import size_matched_library

    key = (tuple(bool(v) for v in keep), floor)
    if key not in _LIBRARIES:
        _LIBRARIES[key] = {
            name: tuple(
                corrected_signature(_angles_of_fci(m.fci), key[0], floor=floor) for m in family
            )  # fmt: skip
            for name, family in size_matched_library().items()
        }
    return _LIBRARIES[key]


@dataclass(frozen=True)
class CorrectedIdentification:
    """Training-free identification of a grasp on its corrected signature."""

    identification: object
    """``patterns.Identification`` of the corrected signature."""
    correction: str
    """The correction used: the one asked for, or "none" where the record has no time
    series to detect non-contact fingers with."""
    kept: tuple[str, ...]


def identify_corrected(
    record, correction: str = "dynamic", match: str = "full", thresholds=None
) -> CorrectedIdentification:
    """Identify a record by DTW to the theoretical patterns after dropping the fingers the
    ``correction`` detector finds out of contact. A record without a time series (final angles
    only) is identified uncorrected, and says so in ``correction``."""
    try:
        keep = contact_mask(record, correction)
    except UsageError:
        if correction == "none" or getattr(record, "time", np.empty(0)).size >= MIN_SAMPLES:
            raise
        keep, correction = np.ones(len(LONG_FINGERS), dtype=bool), "none"
    ident, keep = identify_masked(record.fci_angles(), keep, match, thresholds)
    kept = tuple(f for f, k in zip(LONG_FINGERS, keep, strict=True) if k)
    return CorrectedIdentification(ident, correction, kept)


def identify_masked(angles, keep, match: str = "full", thresholds=None):
    """``patterns.identify`` of final angles (3, 4) with only the fingers in ``keep``:
    (Identification, the mask used; all four where fewer than two were kept)."""
    from .patterns import identify, size_matched_library
    from .signature import FLAT_FLOOR

    if match not in PATTERN_MATCH:
        raise UsageError(f"match must be one of {', '.join(PATTERN_MATCH)}, got {match!r}")
    keep = np.asarray(keep, dtype=bool)
    if keep.sum() < 2:
        keep = np.ones(len(LONG_FINGERS), dtype=bool)
    sig = corrected_signature(angles, keep, floor=FLAT_FLOOR)
    if keep.all() or match == "full":
        lib = size_matched_library()
    else:
        lib = corrected_library(keep, FLAT_FLOOR)
    return identify(sig, lib, thresholds), keep
