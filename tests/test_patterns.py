"""Theoretical patterns, DTW identification and the grasp --json summary."""

import numpy as np
import pytest

from tactile_bullet.hand import PHALANX_LENGTHS
from tactile_bullet.patterns import (
    PAD_RADIUS,
    Thresholds,
    default_library,
    dtw_distance,
    identify,
    pattern,
    theoretical_angles,
    wrap_angles,
)
from tactile_bullet.rotation import estimate_rotation_deg, fit_calibration


def test_wrap_angles_follow_eq_2_3_on_large_circles():
    r = np.array([0.5, 1.0])
    total = wrap_angles(r).sum(axis=0)
    np.testing.assert_allclose(total, sum(PHALANX_LENGTHS) / (r + PAD_RADIUS), rtol=1e-3)


def test_wrap_angles_shrink_as_the_circle_grows_and_max_out_without_object():
    theta = wrap_angles(np.array([0.0, 0.02, 0.04, 0.08]))
    assert np.all(theta[:, 0] == pytest.approx(np.pi / 2))
    assert np.all(np.diff(theta[:, 1:], axis=1) < 0)


def test_patterns_have_the_thesis_shapes():
    lib = default_library()
    assert set(lib) == {"cone", "torus", "sphere", "hyperboloid", "cylinder"}
    assert np.all(lib["cylinder"].upper == 0)
    assert lib["hyperboloid"].bulge > 0  # the waist: middle fingers close more
    assert lib["sphere"].bulge < lib["torus"].bulge < 0
    assert lib["cone"].alpha_deg < -5  # the taper is a slope, removed by the rotation step


def test_dtw_distance_is_zero_on_itself_and_grows_with_difference():
    x = np.sin(np.linspace(0, 3, 200))
    assert dtw_distance(x, x) == 0
    assert 0 < dtw_distance(x, 0.5 * x) < dtw_distance(x, -x)


@pytest.mark.parametrize("name", ["cone", "hyperboloid", "cylinder"])
def test_a_pattern_identifies_as_its_own_shape(name):
    result = identify(pattern(name), thresholds=Thresholds())
    assert result.name == name
    assert result.distances[name] == pytest.approx(0, abs=1e-9)


def test_beyond_the_correspondence_threshold_the_shape_is_unknown():
    angles = theoretical_angles("cone")[:, ::-1]  # a cone turned end for end
    result = identify(pattern("cone", None), thresholds=Thresholds(correspondence=1e-6))
    assert result.name == "cone"
    from tactile_bullet.signature import signature_from_angles

    far = identify(signature_from_angles(angles), thresholds=Thresholds(correspondence=1.0))
    assert far.name == "unknown"
    assert far.distances["cone"] > 1.0


def test_rotation_calibration_inverts_a_linear_relation():
    actual = np.repeat(np.arange(0, 30, 5.0), 3)
    alpha = 0.4 * actual - 1.5
    cal = fit_calibration(actual, alpha, shapes=["a", "b", "c"] * 6)
    assert cal.r2 == pytest.approx(1)
    assert cal.mae_deg == pytest.approx(0, abs=1e-9)
    assert estimate_rotation_deg(0.4 * 12 - 1.5, cal) == pytest.approx(12)
    with pytest.raises(ValueError):
        fit_calibration([0, 0, 0], [1, 2, 3])
