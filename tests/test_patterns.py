"""Theoretical patterns, DTW identification and the grasp --json summary."""

import numpy as np
import pytest

from tactile_bullet.hand import PHALANX_LENGTHS
from tactile_bullet.perception.patterns import (
    PAD_RADIUS,
    Thresholds,
    arc_angles,
    default_library,
    dtw_distance,
    identify,
    pattern,
    theoretical_angles,
)
from tactile_bullet.perception.rotation import estimate_rotation_deg, fit_calibration
from tactile_bullet.perception.signature import signature_from_angles
from tactile_bullet.records import Pose


def test_arc_angles_follow_eq_2_3_on_large_circles():
    r = np.array([0.5, 1.0])
    total = arc_angles(r).sum(axis=0)
    np.testing.assert_allclose(total, sum(PHALANX_LENGTHS) / (r + PAD_RADIUS), rtol=1e-3)


def test_arc_angles_shrink_as_the_circle_grows_and_max_out_without_object():
    theta = arc_angles(np.array([0.0, 0.02, 0.04, 0.08]))
    assert np.all(theta[:, 0] == pytest.approx(np.pi / 2))
    assert np.all(np.diff(theta[:, 1:], axis=1) < 0)


def test_reach_profile_grows_the_solid_by_the_phalanx_radius():
    from tactile_bullet.objects.shapes import cylinder_radius, sphere_radius
    from tactile_bullet.perception.patterns import reach_profile

    x = np.array([0.0, 0.033])
    sphere = reach_profile(lambda u: sphere_radius(u, 0.045), x, pad=0.009, samples=2001)
    np.testing.assert_allclose(sphere, np.sqrt(0.054**2 - x**2), rtol=1e-4)
    cyl = reach_profile(lambda u: cylinder_radius(u, 0.03, 0.12), x, pad=0.009)
    np.testing.assert_allclose(cyl, 0.039)
    assert reach_profile(lambda u: sphere_radius(u, 0.02), np.array([0.04]))[0] == 0


def test_patterns_have_the_thesis_shapes():
    lib = default_library()
    assert set(lib) == {"cone", "torus", "sphere", "hyperboloid", "cylinder"}
    assert lib["hyperboloid"].bulge_upper > lib["cylinder"].bulge_upper  # the waist
    assert lib["sphere"].bulge_upper < 0 and lib["torus"].bulge_upper < 0
    assert lib["cone"].alpha_deg < -5  # the taper is a slope, removed by the rotation step


def test_theory_predicts_alpha_growing_linearly_with_the_object_rotation():
    def alpha(deg):
        turned = theoretical_angles("cylinder", pose=Pose(rotation=np.radians(deg)))
        return signature_from_angles(turned).alpha_upper

    steps = np.diff([alpha(0), alpha(10), alpha(20)])
    assert np.all(steps < -1)  # turned one way, the signature tilts one way
    assert steps[0] == pytest.approx(steps[1], rel=0.05)


def test_dtw_distance_is_zero_on_itself_and_grows_with_difference():
    x = np.sin(np.linspace(0, 3, 200))
    assert dtw_distance(x, x) == 0
    assert 0 < dtw_distance(x, 0.5 * x) < dtw_distance(x, -x)


def _between_pair() -> Thresholds:
    lib = default_library()
    mid = 0.5 * (lib["hyperboloid"].bulge_upper + lib["cylinder"].bulge_upper)
    return Thresholds(integral=mid)


@pytest.mark.parametrize("name", ["cone", "hyperboloid", "cylinder"])
def test_a_pattern_identifies_as_its_own_shape(name):
    result = identify(pattern(name), thresholds=_between_pair())
    assert result.name == name
    assert result.distances[name] == pytest.approx(0, abs=1e-9)


def test_the_integral_rule_decides_between_hyperboloid_and_cylinder():
    """Their enhanced lines nearly coincide once the hand's knuckles are modelled; the bulge
    of the upper line (how far the middle fingers close past the outer ones) decides."""
    lib = default_library()
    assert dtw_distance(lib["hyperboloid"].upper, lib["cylinder"].upper) < 1
    low = identify(lib["hyperboloid"], thresholds=Thresholds(integral=1.0))
    assert low.integral_rule and low.name == "cylinder"
    high = identify(lib["cylinder"], thresholds=Thresholds(integral=-1.0))
    assert high.name == "hyperboloid"


def test_beyond_the_correspondence_threshold_the_shape_is_unknown():
    angles = theoretical_angles("cone")[:, ::-1]  # a cone turned end for end
    result = identify(pattern("cone", None), thresholds=Thresholds(correspondence=1e-6))
    assert result.name == "cone"
    from tactile_bullet.perception.signature import signature_from_angles

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


@pytest.fixture(scope="module")
def grasps():
    from tactile_bullet.sim.grasp import simulate_grasp

    sizes = {
        "cylinder": ({"radius": 0.025}, {"radius": 0.03}),
        "cone": ({"radius": 0.04, "length": 0.14}, {"radius": 0.05, "length": 0.16}),
    }
    return {name: [simulate_grasp(name, p) for p in pair] for name, pair in sizes.items()}


def test_simulated_same_shape_at_two_sizes_is_closer_than_another_shape(grasps):
    from tactile_bullet.perception.patterns import signature_distance
    from tactile_bullet.perception.signature import signature_of

    (cyl_a, cyl_b), (cone_a, cone_b) = (
        [signature_of(r) for r in grasps[k]] for k in ("cylinder", "cone")
    )
    across = [signature_distance(c, k) for c in (cyl_a, cyl_b) for k in (cone_a, cone_b)]
    assert signature_distance(cyl_a, cyl_b) < min(across)
    assert signature_distance(cone_a, cone_b) < min(across)


def test_signature_summary_has_the_grasp_json_fields(grasps):
    import json

    from tactile_bullet.perception.summary import signature_summary

    summary = signature_summary(grasps["cone"][0])
    assert set(summary) == {
        "alpha_deg", "rotation_estimate_deg", "identified", "identified_uncorrected",
        "nearest_pattern", "distances", "in_identification_range", "correction",
        "rotation_estimate_withheld",
        "rotation_deg", "rotation_family",
    }  # fmt: skip
    assert summary["correction"]["detector"] == "dynamic"
    assert set(summary["distances"]) == set(default_library())
    assert summary["identified"] in {*default_library(), "unknown"}
    # nearest_pattern is the smallest DTW distance, whatever the identification decided
    assert summary["nearest_pattern"] == min(summary["distances"], key=summary["distances"].get)
    # the cone of radius 40 mm, length 140 mm lies where identification held; the
    # cylinder of 25 mm does not (tools/invariance.py: only the 20 mm cylinder)
    assert summary["in_identification_range"] is True
    assert signature_summary(grasps["cylinder"][0])["in_identification_range"] is False
    json.dumps(summary)  # plain floats and strings only


def test_identification_ranges_lie_inside_the_valid_ranges(capsys):
    """tools/invariance.py's analogue of thesis Table 2.2, shipped as package data and shown
    by `tactile-bullet shapes`: every range is a sub-range of the shape's valid one."""
    import json

    from tactile_bullet.cli import main
    from tactile_bullet.perception.patterns import identification_ranges

    ranges = identification_ranges()
    assert set(ranges) <= set(default_library()) and ranges
    assert main(["shapes", "--json"]) == 0
    listed = {d["name"]: d["params"] for d in json.loads(capsys.readouterr().out)}
    for shape, params in ranges.items():
        assert set(params) == set(listed[shape])
        for key, (lo, hi) in params.items():
            p = listed[shape][key]
            assert p["min"] - 1e-9 <= lo <= hi <= p["max"] + 1e-9
            assert p["identification_range"] == [lo, hi]
    assert main(["shapes"]) == 0
    text = capsys.readouterr().out
    assert "identified without training in" in text
    # a size where identification held alone is no range: "only at 0.035", never "[0.035, 0.035]"
    points = [lo for params in ranges.values() for lo, hi in params.values() if lo == hi]
    assert points, "the packaged ranges hold single sizes (sphere radius, cone sizes)"
    for lo in points:
        assert f"only at {lo:g}" in text and f"[{lo:g}, {lo:g}]" not in text


def test_rotation_from_the_grasp_alone_follows_a_turned_cylinder():
    """The object turned about the palm normal, its shape unknown: the end-to-end reading
    (benchmarks/rotation_end_to_end.py) picks the cylinder's line and lands within a few degrees,
    and turning the object further reads larger."""
    from tactile_bullet.perception.summary import rotation_from_grasp
    from tactile_bullet.records import Pose
    from tactile_bullet.sim.grasp import simulate_grasp

    read = {}
    for deg in (0, 20):
        rec = simulate_grasp("cylinder", {}, Pose(rotation=np.radians(deg)))
        read[deg], family = rotation_from_grasp(rec)
        assert family == "cylinder"
        assert read[deg] == pytest.approx(deg, abs=3.0)
    assert read[20] - read[0] > 15


def test_rotation_estimate_within_its_error_of_the_range_is_clipped_not_withheld(monkeypatch):
    """An unrotated object read at -1 deg gets 0 deg (the lines' own error is ~2 deg); a
    reading far outside the calibrated range is still withheld with the reason."""
    from tactile_bullet.perception import summary

    cal = summary.load_calibration()
    if cal is None:
        pytest.skip("no rotation calibration installed")
    lo, hi = cal.range_deg
    for raw, expected in ((lo - 1.0, lo), (hi + 2.0, hi), (lo + 5.0, lo + 5.0)):
        monkeypatch.setattr(summary, "estimate_rotation_deg", lambda *_a, v=raw: v)
        assert summary.calibrated_estimate(0.0, cal, "cylinder") == (expected, None)
    monkeypatch.setattr(summary, "estimate_rotation_deg", lambda *_a: 95.0)
    value, why = summary.calibrated_estimate(0.0, cal, "cylinder")
    assert value is None and "outside the calibrated" in why
