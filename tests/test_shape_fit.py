"""The second training-free identifier: sizes and position fitted to the absolute angles."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tactile_bullet import plugins
from tactile_bullet.errors import UsageError
from tactile_bullet.perception import search_steps, shape_fit
from tactile_bullet.perception.patterns import identify, size_matched_library
from tactile_bullet.perception.signature import signature_from_angles
from tactile_bullet.records import Pose

GRASPS = {
    # DTW names this sphere (a quarter into its size range) a torus
    "sphere": ("sphere", {"radius": 0.04375}, (0.0, 0.0, 0.0)),
    # and this hyperboloid (three quarters into its ranges) a cylinder
    "hyperboloid": (
        "hyperboloid",
        {"waist_radius": 0.035, "end_radius": 0.05375, "length": 0.145},
        (0.0, 0.0, 0.0),
    ),
    # a small sphere 18 mm along O-O': the little finger has nothing under it
    "far": ("sphere", {"radius": 0.035}, (0.018, 0.0, 0.0)),
}


@pytest.fixture(scope="session")
def grasps():
    """Final FCI angles (3, 4) of a few simulated grasps, each simulated once."""
    from tactile_bullet.sim.grasp import simulate_grasp

    out = {}
    for key, (shape, params, offset) in GRASPS.items():
        record = simulate_grasp(shape, params, Pose(offset))
        out[key] = (record.fci_angles(), record.fingers_in_contact)
    return out


def test_a_finger_with_nothing_under_it_is_predicted_at_its_limits():
    centred = shape_fit.predicted_angles("sphere", {"radius": 0.035}, (0.0, 0.0))
    far = shape_fit.predicted_angles("sphere", {"radius": 0.035}, (0.02, 0.0))
    assert np.all(centred[0] < 1.3)  # every finger stopped on the sphere
    lf = 3
    assert far[0, lf] == pytest.approx(math.pi / 2)  # J3 at its limit
    assert far[1, lf] == pytest.approx(math.pi)  # J2 + J1 at theirs
    assert np.all(far[0, :3] < 1.3)


def test_a_larger_sphere_closes_the_fingers_less():
    small = shape_fit.predicted_angles("sphere", {"radius": 0.035})
    large = shape_fit.predicted_angles("sphere", {"radius": 0.07})
    assert np.all(large[0] < small[0])
    assert large[1].sum() < small[1].sum()


def test_fit_recovers_exact_model_angles():
    """On angles the model itself predicts, the fit finds the family, size and offset."""
    truth = {"radius": 0.05}
    predicted = shape_fit.predicted_angles("sphere", truth, (0.006, -0.004))
    angles = np.vstack([predicted[0], predicted[1] / 2, predicted[1] / 2])
    fit = shape_fit.fit_shape(angles)
    assert fit.shape == "sphere"
    assert fit.params["radius"] == pytest.approx(0.05, abs=0.002)
    assert fit.best.offset == pytest.approx((0.006, -0.004), abs=0.002)


@pytest.mark.slow
def test_sphere_radius_recovered_from_simulated_grasps(grasps):
    """Within 5 mm (the grid's mean error is 4 mm), larger for the larger sphere, and the far
    sphere's offset along O-O' found."""
    centred = shape_fit.fit_family(grasps["sphere"][0], "sphere")
    far = shape_fit.fit_family(grasps["far"][0], "sphere")
    assert abs(centred.params["radius"] - 0.04375) < 0.005
    assert abs(far.params["radius"] - 0.035) <= 0.0055
    assert centred.params["radius"] > far.params["radius"]
    assert far.offset[0] == pytest.approx(0.018, abs=0.006)
    assert abs(centred.offset[0]) < 0.006


@pytest.mark.slow
@pytest.mark.parametrize(("key", "dtw_says"), [("sphere", "torus"), ("hyperboloid", "cylinder")])
def test_fit_separates_what_dtw_confuses(grasps, key, dtw_says):
    angles, _ = grasps[key]
    assert identify(signature_from_angles(angles), size_matched_library()).name == dtw_says
    fit = shape_fit.fit_shape(angles)
    assert fit.shape == key
    other = fit.fits[dtw_says]
    assert other.score > fit.best.score


@pytest.mark.slow
def test_far_offset_small_object_is_still_named(grasps):
    angles, touching = grasps["far"]
    assert "lf" not in touching  # the little finger closed on nothing
    fit = shape_fit.fit_shape(angles)
    assert fit.shape == "sphere"
    assert fit.best.predicted[0, 3] == pytest.approx(math.pi / 2)


@pytest.mark.parametrize(
    ("angles", "message"),
    [
        (np.zeros((3, 3)), "3 x 4"),
        (np.zeros(12), "3 x 4"),
        (np.where(np.eye(3, 4) > 0, np.nan, 0.5), "NaN"),
        ([["a"] * 4] * 3, "numbers"),
    ],
)
def test_bad_angles_are_a_usage_error(angles, message):
    with pytest.raises(UsageError, match=message):
        shape_fit.fit_shape(angles)


def test_unknown_family_and_bad_offset_are_usage_errors():
    with pytest.raises(UsageError, match="teapot"):
        shape_fit.fit_shape(np.full((3, 4), 0.5), ["sphere", "teapot"])
    with pytest.raises(UsageError, match="offset"):
        shape_fit.predicted_angles("sphere", None, (0.0, float("nan")))
    with pytest.raises(UsageError, match="out of range"):
        shape_fit.predicted_angles("sphere", {"radius": 1.0})


def test_a_sphere_turned_about_its_centre_is_the_same_sphere():
    """Rotation about the palm normal moves nothing on a sphere; on a cylinder it lowers the
    section under one outer finger and raises it under the other, so their J3 part ways."""
    sphere = {"radius": 0.05}
    square = shape_fit.predicted_angles("sphere", sphere, (0.005, 0.0))
    for deg in (-25.0, 10.0, 25.0):
        turned = shape_fit.predicted_angles("sphere", sphere, (0.005, 0.0), rotation_deg=deg)
        np.testing.assert_allclose(turned, square, atol=np.radians(0.1))  # sampled heights
    cylinder = {"radius": 0.03, "length": 0.15}
    flat = shape_fit.predicted_angles("cylinder", cylinder)
    up = shape_fit.predicted_angles("cylinder", cylinder, rotation_deg=15.0)
    down = shape_fit.predicted_angles("cylinder", cylinder, rotation_deg=-15.0)
    ff, lf = 0, 3
    assert up[0, ff] > flat[0, ff] > down[0, ff]
    assert up[0, lf] < flat[0, lf] < down[0, lf]


def test_fit_recovers_the_rotation_of_exact_model_angles():
    truth = {"radius": 0.03, "length": 0.15}
    predicted = shape_fit.predicted_angles("cylinder", truth, (0.004, 0.0), rotation_deg=20.0)
    angles = np.vstack([predicted[0], predicted[1] / 2, predicted[1] / 2])
    fit = shape_fit.fit_shape(angles)
    assert fit.shape == "cylinder"
    assert fit.best.rotation_deg == pytest.approx(20.0, abs=2.0)
    assert fit.summary()["rotation_deg"] == fit.best.rotation_deg


@pytest.mark.slow
def test_a_turned_cylinder_is_not_read_as_a_cone():
    """Before the fit had a rotation, a cylinder turned 25 deg scored best as a cone."""
    from tactile_bullet.sim.grasp import simulate_grasp

    record = simulate_grasp(
        "cylinder", {"radius": 0.0419, "length": 0.17}, Pose((0.0, 0.0, 0.0), math.radians(25))
    )
    fit = shape_fit.fit_shape(record.fci_angles())
    assert fit.shape == "cylinder"
    assert fit.best.rotation_deg == pytest.approx(25.0, abs=5.0)


def test_rotation_out_of_the_searched_range_is_a_usage_error():
    with pytest.raises(UsageError, match="rotation"):
        shape_fit.predicted_angles("sphere", None, rotation_deg=45.0)


def test_shape_fit_classifier_reads_raw_joints(synthetic_split):
    train, _ = synthetic_split
    desc = plugins.get_descriptor("raw-joints")
    X = desc.transform(train[:6])
    y = np.array([r.shape for r in train[:6]])
    est = plugins.get_classifier("shape-fit").fit(X, y)
    assert plugins.required_descriptor("shape-fit") == "raw-joints"
    assert plugins.accepted_descriptors("shape-fit") == ("raw-joints", "robust-joints")
    assert plugins.compatible("robust-joints", "shape-fit")
    assert not plugins.compatible("signature", "shape-fit")
    assert plugins.accepted_descriptors("svm") is None
    proba = est.predict_proba(X[:2])
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)
    # it names what fit_shape names over the same classes
    for x, name in zip(X[:2], est.predict(X[:2]), strict=True):
        names = desc.feature_names()
        fci = np.array([[x[names.index(f"{f}J{j}")] for f in ("FF", "MF", "RF", "LF")]
                        for j in (3, 2, 1)])  # fmt: skip
        assert name == shape_fit.fit_shape(fci, [str(c) for c in est.classes_]).shape
    with pytest.raises(ValueError, match="raw-joints"):
        plugins.get_classifier("shape-fit").fit(X[:, :5], y)


def test_the_searchs_row_dedup_equals_numpys_unique():
    """search_steps.unique_rows replaces np.unique(axis=0) for speed: the same first indices and
    inverse on rows with repeats, ties in leading columns and signed zeros."""
    rng = np.random.default_rng(0)
    for _ in range(200):
        a = rng.integers(-2, 3, (rng.integers(1, 60), rng.integers(1, 6))).astype(float) / 2
        _, first, inverse = np.unique(a, axis=0, return_index=True, return_inverse=True)
        got_first, got_inverse = search_steps.unique_rows(a)
        np.testing.assert_array_equal(got_first, first)
        np.testing.assert_array_equal(got_inverse, inverse.ravel())


def test_the_polishs_batched_solve_leaves_out_only_a_singular_system():
    rng = np.random.default_rng(1)
    systems = rng.normal(size=(4, 3, 3)) + 3 * np.eye(3)
    rhs = rng.normal(size=(4, 3))
    systems[2] = 0.0  # singular
    steps = search_steps.damped_steps(systems, rhs)
    assert np.isnan(steps[2]).all()
    for i in (0, 1, 3):
        np.testing.assert_array_equal(steps[i], -np.linalg.solve(systems[i], rhs[i]))
