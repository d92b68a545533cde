"""The proprioceptive shape signature (thesis section 2.3): FCI, raw signature, enhancement.

Pure functions on a (3, 4) array of joint angles (rows J3, J2, J1 from the proximal joint;
columns ff, mf, rf, lf), so recordings of a real hand go through exactly the same code as
simulated grasps and as the theoretical patterns of ``perception/patterns.py``.

Pipeline::

    angles (3, 4) rad --fci--> FCI (3, 4) grey levels --raw_signature--> lower/upper lines (200,)
        --enhance (each line)--> rotated by -alpha, mean removed, scaled into [-1, 1]

Units and conventions (the thesis leaves them open; these are ours):

- Grey levels: eq. 2.2 spreads the P = 2**bits levels equally over the three joints "under the
  assumption that the three joints share the same maximum value". On the Shadow hand that
  maximum is 90 deg for J3, J2 and J1 alike, so one joint at 90 deg is worth k = P / 3 levels:
  ``FCI = (P / 3) * cumsum(theta) / (pi / 2)``. The FCI is kept as a float image: a finger
  bent past the nominal range (J3 down to -15 deg, or a sum over 270 deg) gives values below 0
  or above P, which are kept as they are, never clipped.
- alpha: the angle (deg) of the line through a signature line's end points, measured in the
  upscaled image's own units (one column pixel across, one grey level up), as the thesis
  measures it on the image. Columns run from ff (x = +33 mm on O-O') to lf (x = -33 mm); a
  line rising toward the little finger has a positive alpha. Pixel units keep alpha small
  (a few degrees), where it is proportional to the end-to-end angle difference: the linear
  calibration of ``perception/rotation.py`` turns it into the object's rotation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UsageError

UPSCALE = 50
"""Cubic upscaling factor of the FCI (thesis: 4 x 3 -> 200 x 150)."""

JOINT_FULL_SCALE = np.pi / 2
"""Joint angle (rad) worth k = P / 3 grey levels: the common maximum of J3, J2, J1."""

FLAT_FLOOR = 0.02
"""Relative amplitude under which a line counts as flat (see :func:`enhance`)."""

FCI_SHAPE = (3, 4)


@dataclass(frozen=True, eq=False)
class Signature:
    """One grasp's signature: both enhanced lines and what the enhancement removed.

    ``lower``/``upper`` are the enhanced lines (proximal angle; whole-finger angle), each in
    [-1, 1]; ``alpha_*`` their end-point slope angles (deg, image units); ``bulge_*`` the mean
    height of each line above its end-point chord relative to the line's mean level (the
    thesis' "integral of the signature", made size-invariant: 0 for a cylinder, > 0 where the
    middle fingers close more than the outer ones); ``raw_*`` the lines before enhancement
    (grey levels); ``fci`` the image they came from.
    """

    lower: np.ndarray
    upper: np.ndarray
    alpha_lower: float
    alpha_upper: float
    bulge_lower: float
    bulge_upper: float
    raw_lower: np.ndarray
    raw_upper: np.ndarray
    fci: np.ndarray

    @property
    def alpha_deg(self) -> float:
        """Mean of both lines' alpha: the rotation cue ``perception/rotation.py`` calibrates."""
        return 0.5 * (self.alpha_lower + self.alpha_upper)

    def vector(self) -> np.ndarray:
        """Lower then upper enhanced line as one feature vector (400 values)."""
        return np.concatenate([self.lower, self.upper])


def _check_angles(angles) -> np.ndarray:
    try:
        arr = np.asarray(angles, dtype=float)
    except (TypeError, ValueError):
        raise UsageError("joint angles must be numbers (3 x 4: J3, J2, J1 x ff..lf)") from None
    if arr.shape != FCI_SHAPE:
        raise UsageError(
            f"joint angles must be a 3 x 4 array (rows J3, J2, J1; columns ff, mf, rf, lf), "
            f"got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise UsageError("joint angles contain NaN or infinity")
    return arr


def _check_line(line) -> np.ndarray:
    arr = np.asarray(line, dtype=float)
    if arr.ndim != 1 or arr.size < 3:
        raise UsageError(f"a signature line must be 1-D with at least 3 points, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise UsageError("signature line contains NaN or infinity")
    return arr


def fci(angles, bits: int = 8) -> np.ndarray:
    """Finger Configuration Image (eq. 2.1-2.2) of final angles (3, 4) in rad.

    Pixel (y, f) is the absolute direction of phalanx y of finger f (the sum of the joint
    angles up to it) in grey levels, k = 2**bits / 3 levels per 90 deg. Float, not clipped.
    """
    arr = _check_angles(angles)
    if isinstance(bits, bool) or not isinstance(bits, int | np.integer) or not 1 <= bits <= 16:
        raise UsageError(f"bits must be an integer from 1 to 16, got {bits!r}")
    k = 2.0**bits / 3.0
    return k * np.cumsum(arr, axis=0) / JOINT_FULL_SCALE


def raw_signature(image) -> np.ndarray:
    """The two lines of eq. 2.4: per column of the 50x cubic-upscaled FCI, its min and max.

    Returns a (2, 200) array: row 0 the lower line, row 1 the upper line (grey levels).
    The cubic kernel is OpenCV's (the thesis' tool); it smooths the jump between fingers.
    """
    import cv2

    arr = np.asarray(image, dtype=float)
    if arr.shape != FCI_SHAPE:
        raise UsageError(f"an FCI must be a 3 x 4 image, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise UsageError("FCI contains NaN or infinity")
    rows, cols = FCI_SHAPE
    big = cv2.resize(arr, (cols * UPSCALE, rows * UPSCALE), interpolation=cv2.INTER_CUBIC)
    return np.stack([big.min(axis=0), big.max(axis=0)])


def end_point_angle(line) -> float:
    """alpha (deg): angle of the line through the first and last points, in pixel units."""
    arr = _check_line(line)
    return float(np.degrees(np.arctan2(arr[-1] - arr[0], arr.size - 1)))


def level_line(line) -> np.ndarray:
    """Step 1 of the enhancement: rotate the points by -alpha about the first one so that the
    end points lie on y = 0, then resample on evenly spaced columns (same count)."""
    arr = _check_line(line)
    a = np.arctan2(arr[-1] - arr[0], arr.size - 1)
    x = np.arange(arr.size, dtype=float)
    dy = arr - arr[0]
    xr = x * np.cos(a) + dy * np.sin(a)
    yr = -x * np.sin(a) + dy * np.cos(a)
    # A steep, wiggly line can fold back after rotation; keep the abscissa non-decreasing.
    xr = np.maximum.accumulate(xr)
    grid = np.linspace(xr[0], xr[-1], arr.size)
    out = np.interp(grid, xr, yr)
    out[0] = out[-1] = 0.0
    return out


def bulge(line) -> float:
    """Mean height of the levelled line relative to the line's mean level (size-free).

    Signed: > 0 when the middle of the line lies above its end-point chord. ``nan``-free: a
    line whose mean level is 0 has no scale, and its bulge is reported as 0.
    """
    arr = _check_line(line)
    level = abs(float(arr.mean()))
    if level == 0.0:
        return 0.0
    return float(level_line(arr).mean() / level)


def enhance(line, floor: float = FLAT_FLOOR) -> tuple[np.ndarray, float]:
    """Three-step enhancement of one line (thesis 2.3.3): rotation by -alpha, mean
    subtraction, normalisation into [-1, 1]. Returns (enhanced line, alpha in deg).

    Normalisation divides by the largest deviation from the mean, but never by less than
    ``floor`` times the line's mean level: a line flatter than that (a cylinder's, up to
    simulation noise) stays near 0 instead of having its noise blown up to +-1, which is
    what made the thesis' cylinder look like a hyperboloid. ``floor=0`` is the thesis as
    written (every non-constant line reaches +-1). A constant line enhances to zeros.
    """
    arr = _check_line(line)
    if not (np.isfinite(floor) and floor >= 0):
        raise UsageError(f"floor must be a finite number >= 0, got {floor!r}")
    alpha = end_point_angle(arr)
    centred = level_line(arr)
    centred -= centred.mean()
    peak = float(np.abs(centred).max())
    scale = max(peak, floor * abs(float(arr.mean())))
    if scale == 0.0 or peak <= 1e-12 * max(1.0, float(np.abs(arr).max())):
        return np.zeros_like(arr), alpha
    return centred / scale, alpha


def signature_from_angles(angles, bits: int = 8, floor: float = FLAT_FLOOR) -> Signature:
    """Signature of final joint angles (3, 4): rows J3, J2, J1; columns ff, mf, rf, lf (rad)."""
    image = fci(angles, bits)
    return signature_from_lines(image, raw_signature(image), floor)


def signature_from_lines(image, lines, floor: float = FLAT_FLOOR) -> Signature:
    """The enhanced Signature of raw (lower, upper) lines taken from the FCI ``image``; shared
    by the four-finger signature and chapter 3's corrected one (fewer columns)."""
    (lower, a_lo), (upper, a_up) = (enhance(line, floor) for line in lines)
    return Signature(
        lower=lower,
        upper=upper,
        alpha_lower=a_lo,
        alpha_upper=a_up,
        bulge_lower=bulge(lines[0]),
        bulge_upper=bulge(lines[1]),
        raw_lower=lines[0],
        raw_upper=lines[1],
        fci=image,
    )


def signature_of(record, bits: int = 8, floor: float = FLAT_FLOOR) -> Signature:
    """Signature of a GraspRecord's final configuration."""
    return signature_from_angles(record.fci_angles(), bits, floor)


def resample_line(line: np.ndarray, points: int) -> np.ndarray:
    """A line resampled to ``points`` evenly spaced values, end points kept (linear)."""
    line = np.asarray(line, dtype=float)
    grid = np.linspace(0.0, line.size - 1.0, points)
    return np.interp(grid, np.arange(line.size, dtype=float), line)
