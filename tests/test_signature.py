"""The signature pipeline on analytic joint angles: FCI scale, raw lines, enhancement."""

import numpy as np
import pytest

from tactile_bullet.hand import FCI_JOINTS, JOINT_NAMES, LONG_FINGERS, PHALANX_LENGTHS
from tactile_bullet.perception.patterns import theoretical_angles
from tactile_bullet.perception.signature import (
    UPSCALE,
    end_point_angle,
    enhance,
    fci,
    level_line,
    raw_signature,
    signature_from_angles,
    signature_of,
)
from tactile_bullet.records import ControllerSettings, GraspRecord, Pose

FINGER_CENTRES = [UPSCALE // 2 + UPSCALE * k for k in range(4)]
"""Upscaled columns over each finger's own FCI pixel."""


def wrapped(radii) -> np.ndarray:
    """theta = l / r per phalanx (eq. 2.3) for fingers on circles of the given radii."""
    return np.asarray(PHALANX_LENGTHS)[:, None] / np.asarray(radii, float)[None, :]


def test_fci_is_cumulative_and_scaled_to_grey_levels():
    angles = np.tile([[np.pi / 2], [np.pi / 2], [np.pi / 2]], (1, 4))
    image = fci(angles, bits=8)
    np.testing.assert_allclose(image[:, 0], [256 / 3, 512 / 3, 256])
    assert fci(angles, bits=4)[2, 0] == pytest.approx(16)


def test_fci_keeps_out_of_range_angles_instead_of_clipping():
    angles = np.full((3, 4), 0.3)
    angles[0, 1] = -0.2  # J3 of the middle finger slightly extended
    angles[:, 2] = 2.0  # 3 x 115 deg: beyond the nominal full scale
    image = fci(angles)
    assert image[0, 1] < 0
    assert image[2, 2] > 256


def test_cylinder_gives_a_flat_signature():
    sig = signature_from_angles(wrapped([0.035] * 4))
    assert np.all(sig.lower == 0) and np.all(sig.upper == 0)
    assert sig.alpha_lower == pytest.approx(0, abs=1e-9)
    assert sig.bulge_upper == pytest.approx(0, abs=1e-9)


def test_cone_gives_monotone_sloped_raw_lines():
    radii = 0.05 * (0.5 - np.array([0.033, 0.011, -0.011, -0.033]) / 0.16)  # base at lf
    sig = signature_from_angles(wrapped(radii))
    for raw in (sig.raw_lower, sig.raw_upper):
        assert np.all(np.diff(raw[FINGER_CENTRES]) < 0)  # wider toward lf: less flexion
    assert sig.alpha_lower < 0 and sig.alpha_upper < sig.alpha_lower


def test_rotation_step_removes_a_known_slope():
    x = np.arange(200.0)
    slope = 0.3
    assert end_point_angle(5 + slope * x) == pytest.approx(np.degrees(np.arctan(slope)))
    np.testing.assert_allclose(level_line(5 + slope * x), 0, atol=1e-9)
    # A bump on the slope survives, shortened by cos(alpha) as a rotation (not a shear) does.
    bump = 4 * np.sin(np.pi * x / 199)
    levelled = level_line(5 + slope * x + bump)
    assert levelled.max() == pytest.approx(4 * np.cos(np.arctan(slope)), rel=0.02)


@pytest.mark.parametrize("seed", range(5))
def test_enhanced_lines_span_exactly_minus_one_to_one(seed):
    angles = np.random.default_rng(seed).uniform(0.1, 1.4, (3, 4))
    sig = signature_from_angles(angles, floor=0)
    for line in (sig.lower, sig.upper):
        assert line.min() >= -1 and line.max() <= 1
        assert np.abs(line).max() == 1.0


def test_flat_floor_keeps_noise_small():
    angles = wrapped([0.035] * 4) * (1 + 1e-3 * np.array([1, -1, 1, -1]))
    assert np.abs(signature_from_angles(angles).upper).max() < 0.2
    assert np.abs(signature_from_angles(angles, floor=0).upper).max() == 1.0


def test_size_and_offset_of_the_angles_do_not_change_the_enhanced_signature():
    sphere = wrapped(np.sqrt(0.045**2 - np.array([0.033, 0.011, -0.011, -0.033]) ** 2))
    ref = signature_from_angles(sphere)
    for changed in (sphere * 1.4, sphere * 0.6, sphere + 0.15, sphere - 0.1):
        sig = signature_from_angles(changed)
        np.testing.assert_allclose(sig.lower, ref.lower, atol=1e-6)
        np.testing.assert_allclose(sig.upper, ref.upper, atol=1e-6)


def test_scale_invariance_of_a_sloped_line_is_approximate():
    """Rotating a sloped line warps its abscissa a little (a shear would not): within 0.06
    for the default cone's slopes (alpha -9 and -24 deg)."""
    cone = theoretical_angles("cone")
    ref = signature_from_angles(cone)
    sig = signature_from_angles(cone * 1.3)
    assert np.abs(sig.upper - ref.upper).max() < 0.06
    assert np.abs(sig.lower - ref.lower).max() < 0.06


@pytest.mark.parametrize(
    "bad",
    [
        np.full((3, 4), np.nan),
        np.where(np.eye(3, 4) > 0, np.inf, 0.5),
        np.zeros((4, 3)),
        np.zeros((3, 5)),
        np.zeros(12),
        [["a"] * 4] * 3,
    ],
)
def test_bad_angles_raise_value_error(bad):
    with pytest.raises(ValueError, match="angles"):
        signature_from_angles(bad)


def test_bad_bits_and_lines_raise_value_error():
    with pytest.raises(ValueError, match="bits"):
        fci(np.zeros((3, 4)), bits=0)
    with pytest.raises(ValueError, match="FCI"):
        raw_signature(np.zeros((2, 4)))
    with pytest.raises(ValueError, match="NaN"):
        enhance([0.0, np.nan, 1.0])


def _record(final: np.ndarray) -> GraspRecord:
    n = len(JOINT_NAMES)
    empty = np.zeros((0, 3))
    return GraspRecord(
        shape="cylinder",
        params={},
        pose=Pose(),
        controller=ControllerSettings(),
        seed=0,
        time=np.zeros(1),
        angles=final[None, :],
        efforts=np.zeros((1, n)),
        final_angles=final,
        contact_link=np.array([], dtype="U16"),
        contact_position=empty,
        contact_normal=empty,
        contact_force=np.zeros(0),
        fingers_in_contact=(),
    )


def test_signature_of_a_record_reads_j3_j2_j1_of_the_four_fingers():
    angles = np.random.default_rng(7).uniform(0.2, 1.2, (3, 4))
    final = np.full(len(JOINT_NAMES), 9.0)  # wrist, J4, thumb: must not leak in
    for col, finger in enumerate(LONG_FINGERS):
        for row, joint in enumerate(FCI_JOINTS[finger]):
            final[JOINT_NAMES.index(joint)] = angles[row, col]
    sig = signature_of(_record(final))
    np.testing.assert_array_equal(sig.fci, fci(angles))
    assert sig.vector().shape == (400,)


def test_grasp_signature_figure_is_a_png_and_a_bad_path_is_a_usage_error(tmp_path):
    from tactile_bullet.errors import UsageError
    from tactile_bullet.experiments.figures_signature import plot_grasp_signature

    angles = theoretical_angles("cone")
    final = np.zeros(len(JOINT_NAMES))
    for col, finger in enumerate(LONG_FINGERS):
        for row, joint in enumerate(FCI_JOINTS[finger]):
            final[JOINT_NAMES.index(joint)] = angles[row, col]
    out = plot_grasp_signature(_record(final), tmp_path / "sig.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(UsageError, match="cannot write"):
        plot_grasp_signature(_record(final), tmp_path / "missing" / "sig.png")
