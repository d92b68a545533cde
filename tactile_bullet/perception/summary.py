"""The ``signature`` block of ``grasp --json``: every training-free reading of one grasp.

It joins the patterns' DTW identification, the rotation estimate and the ch. 3 correction, so
it sits above ``patterns``, ``rotation`` and ``temporal`` (which use each other's parts only
downward).
"""

from __future__ import annotations

from .contact import nothing_to_identify
from .patterns import identify, in_identification_range, size_matched_library
from .rotation import RotationCalibration, alpha_of, estimate_rotation_deg, load_calibration
from .signature import signature_of
from .temporal import identify_corrected


def rotation_from_grasp(
    record, calibration: RotationCalibration | None = None
) -> tuple[float | None, str | None]:
    """(rotation in deg about the palm normal, the family whose line gave it) of one grasp whose
    shape is not known: the signature's alpha read with the line of the calibrated family
    (torus, hyperboloid, cylinder) the shape fit finds best among them; (None, None) without a
    calibration or contact.

    Why not the identified shape's line: a turned cylinder often reads as a cone, which has no
    line (a cone's slope is its shape, not a rotation). The rotation only means something for
    the calibrated families, so the family is chosen among them, from the absolute angles the
    shape fit reads (scale separates cylinder from hyperboloid where the signature cannot).
    ``benchmarks/rotation_end_to_end.py`` measures it."""
    from ..learn.robust import angles_for_shape_fit
    from .shape_fit import fit_shape

    cal = load_calibration() if calibration is None else calibration
    if cal is None or not cal.per_shape or nothing_to_identify(record) is not None:
        return None, None
    fit = fit_shape(angles_for_shape_fit(record), families=sorted(cal.per_shape))
    alpha = alpha_of(signature_of(record), cal.line)
    return cal.estimate(alpha, fit.shape), fit.shape


def signature_summary(record) -> dict:
    """The ``signature`` block of ``grasp --json`` (docs/json.md) for one record:
    ``identified`` is the training-free answer (a shape, or "unknown" beyond the
    correspondence threshold), ``nearest_pattern`` the pattern at the smallest DTW distance
    (they differ where the integral rule or the threshold decides). A grasp that touched too
    little gives neither, and says why under ``reason``."""
    in_range = in_identification_range(record.shape, record.params)
    reason = nothing_to_identify(record)
    if reason is not None:
        return {
            "alpha_deg": None,
            "rotation_estimate_deg": None,
            "rotation_estimate_withheld": None,
            "rotation_deg": None,
            "rotation_family": None,
            "identified": None,
            "nearest_pattern": None,
            "distances": {},
            "reason": reason,
            "in_identification_range": in_range,
        }
    sig = signature_of(record)
    ident = identify(sig, size_matched_library())
    # The identification proper drops the fingers the dynamic detector finds out of contact
    # (thesis ch. 3); a record without a time series is identified uncorrected.
    corrected = identify_corrected(record)
    cal = load_calibration()
    alpha = alpha_of(sig, cal.line if cal is not None else "mean")
    estimate, why_not = calibrated_estimate(alpha, cal, ident.nearest)
    return {
        "alpha_deg": alpha,
        "rotation_estimate_deg": estimate,
        "rotation_estimate_withheld": why_not,
        **_end_to_end(record, cal),
        "identified": corrected.identification.name,
        "identified_uncorrected": ident.name,
        "nearest_pattern": ident.nearest,
        "correction": {"detector": corrected.correction, "fingers": list(corrected.kept)},
        "distances": ident.distances,
        "in_identification_range": in_range,
    }


def _end_to_end(record, cal) -> dict:
    deg, family = rotation_from_grasp(record, cal)
    return {"rotation_deg": deg, "rotation_family": family}


RANGE_SLACK_DEG = 3.0
"""How far outside the calibrated range an estimate is still read as the range's end: the lines'
own error is about 2 deg (at most 3.7 deg, docs/rotation.md), so -1 deg on an unrotated object
is 0 deg, not an extrapolation; 95 deg on an off-centre sphere is still withheld."""


def calibrated_estimate(alpha_deg: float, cal, shape: str) -> tuple[float | None, str | None]:
    """The rotation estimate (deg) and None, or None and why it is withheld: the calibration
    lines were fitted on rotations within ``cal.range_deg`` only, and outside it an
    estimate is an extrapolation of a weak line (a 25 mm off-centre sphere reads 95 deg)."""
    if cal is None:
        return None, "no rotation calibration is installed"
    value = estimate_rotation_deg(alpha_deg, cal, shape)
    if value is None:
        return None, f"no calibration line for the nearest pattern ({shape})"
    lo, hi = cal.range_deg
    if not lo - RANGE_SLACK_DEG <= value <= hi + RANGE_SLACK_DEG:
        return None, f"{value:.0f} deg is outside the calibrated {lo:g}-{hi:g} deg"
    return min(max(value, lo), hi), None
