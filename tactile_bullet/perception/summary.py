"""The ``signature`` block of ``grasp --json``: every training-free reading of one grasp.

It joins the patterns' DTW identification, the rotation estimate and the ch. 3 correction, so
it sits above ``patterns``, ``rotation`` and ``temporal`` (which use each other's parts only
downward).
"""

from __future__ import annotations

from .contact import nothing_to_identify
from .patterns import identify, in_identification_range, size_matched_library
from .rotation import alpha_of, estimate_rotation_deg, load_calibration
from .signature import signature_of
from .temporal import identify_corrected


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
        "identified": corrected.identification.name,
        "identified_uncorrected": ident.name,
        "nearest_pattern": ident.nearest,
        "correction": {"detector": corrected.correction, "fingers": list(corrected.kept)},
        "distances": ident.distances,
        "in_identification_range": in_range,
    }


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
    if not lo <= value <= hi:
        return None, f"{value:.0f} deg is outside the calibrated {lo:g}-{hi:g} deg"
    return value, None
