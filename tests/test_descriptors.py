"""Descriptors: the documented widths, layouts and values on synthetic records."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from synthetic import make_record, make_records

from tactile_bullet import plugins
from tactile_bullet.errors import UsageError
from tactile_bullet.learn.descriptors import fingertip_normal, raw_joint_names


@pytest.fixture(scope="module")
def records():
    return make_records(per_shape=3, seed=5)


def test_signature_is_both_enhanced_lines_then_the_bulges(records):
    from tactile_bullet.perception.signature import signature_of

    desc = plugins.get_descriptor("signature", points=50)
    X = desc.transform(records)
    assert X.shape == (len(records), 102) and X.dtype == float
    names = desc.feature_names()
    assert len(names) == 102 and names[0] == "lower_000" and names[50] == "upper_000"
    assert names[-2:] == ["bulge_lower", "bulge_upper"]
    assert np.all(np.abs(X[:, :100]) <= 1.0 + 1e-9)
    sig = signature_of(records[0], floor=desc.floor)
    # end points of each line are kept by the resampling
    assert X[0, 0] == pytest.approx(sig.lower[0]) and X[0, 49] == pytest.approx(sig.lower[-1])
    assert X[0, 50] == pytest.approx(sig.upper[0]) and X[0, 99] == pytest.approx(sig.upper[-1])
    assert X[0, 100] == pytest.approx(sig.bulge_lower)
    assert plugins.get_descriptor("signature").transform(records[:1]).shape == (1, 22)


def test_signature_floor_keeps_a_nearly_flat_line_flat():
    """A line wobbling by 2% of its level is stretched to +-1 without a floor (the thesis'
    normalisation) but stays within +-0.6 under the default 5% floor; a clear curve reaches
    +-1 either way."""
    from tactile_bullet.learn.descriptors import SignatureDescriptor
    from tactile_bullet.perception.signature import enhance

    wobble = 100.0 + 2.0 * np.sin(np.linspace(0.0, 3.0 * np.pi, 200))
    assert np.abs(enhance(wobble, floor=0.0)[0]).max() == pytest.approx(1.0)
    assert np.abs(enhance(wobble, floor=SignatureDescriptor().floor)[0]).max() < 0.6
    curve = 100.0 + 20.0 * np.sin(np.linspace(0.0, np.pi, 200))
    assert np.abs(enhance(curve, floor=SignatureDescriptor().floor)[0]).max() == pytest.approx(1.0)
    for bad in (-0.1, 1.5, "x", True):
        with pytest.raises(UsageError, match="floor"):
            plugins.get_descriptor("signature", floor=bad)


def test_signature_points_alpha_and_level_change_the_layout(records):
    from tactile_bullet.perception.signature import signature_of

    desc = plugins.get_descriptor("signature", points=10, alpha=True)
    X = desc.transform(records[:2])
    assert X.shape == (2, 24)
    assert desc.feature_names()[-2:] == ["alpha_lower_deg", "alpha_upper_deg"]
    sig = signature_of(records[0], floor=desc.floor)
    assert X[0, -2:] == pytest.approx([sig.alpha_lower, sig.alpha_upper])
    sized = plugins.get_descriptor("signature", points=10, alpha=True, level=True)
    assert sized.feature_names()[-1] == "level_upper"
    assert sized.transform(records[:1])[0, -1] == pytest.approx(np.mean(sig.raw_upper))
    for bad in (2, 500, 1.5, "ten"):
        with pytest.raises(UsageError, match="points"):
            plugins.get_descriptor("signature", points=bad)


def test_signature_lines_follow_the_shape_not_its_size():
    """The enhancement removes size: two cylinders far apart in radius give nearly the same
    lines, while a cone's differ from both (noise-free records)."""
    desc = plugins.get_descriptor("signature")
    small, large, cone = desc.transform(
        [
            make_record("cylinder", {"radius": 0.025}, noise=0.0),
            make_record("cylinder", {"radius": 0.05}, noise=0.0),
            make_record("cone", noise=0.0),
        ]
    )[:, :100]
    assert np.abs(small - large).mean() < 0.5 * np.abs(small - cone).mean()


def test_raw_joints_are_the_final_angles_of_the_named_joints(records):
    desc = plugins.get_descriptor("raw-joints")
    assert desc.feature_names() == raw_joint_names(False)
    assert desc.feature_names()[:4] == ["FFJ4", "FFJ3", "FFJ2", "FFJ1"]
    assert "LFJ5" in desc.feature_names() and len(desc.feature_names()) == 17
    X = desc.transform(records)
    for col, name in enumerate(desc.feature_names()):
        np.testing.assert_array_equal(X[:, col], [r.final(name) for r in records])
    with_thumb = plugins.get_descriptor("raw-joints", include_thumb=True)
    assert with_thumb.transform(records).shape == (len(records), 22)
    assert with_thumb.feature_names()[-5:] == ["THJ5", "THJ4", "THJ3", "THJ2", "THJ1"]


def test_contact_normals_are_unit_vectors_with_an_indicator(records):
    desc = plugins.get_descriptor("contact-normals")
    X = desc.transform(records)
    assert X.shape == (len(records), 20)
    assert desc.feature_names()[:4] == ["ff_nx", "ff_ny", "ff_nz", "ff_contact"]
    for finger in range(5):
        block = X[:, 4 * finger : 4 * finger + 4]
        touched = block[:, 3] == 1.0
        np.testing.assert_allclose(np.linalg.norm(block[touched, :3], axis=1), 1.0)
        np.testing.assert_array_equal(block[~touched], 0.0)
    assert plugins.get_descriptor("contact-normals", include_thumb=False).transform(
        records
    ).shape == (len(records), 16)


def _with_contacts(record, links, normals, forces):
    return dataclasses.replace(
        record,
        contact_link=np.asarray(links, dtype="U16"),
        contact_normal=np.asarray(normals, dtype=float).reshape(-1, 3),
        contact_position=np.zeros((len(links), 3)),
        contact_force=np.asarray(forces, dtype=float),
    )


def test_fingertip_normal_is_force_weighted_and_ignores_other_links():
    base = make_record("sphere")
    record = _with_contacts(
        base,
        ["ffdistal", "fftip", "ffproximal"],
        [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
        [3.0, 1.0, 50.0],
    )
    normal, touched = fingertip_normal(record, "ff")
    assert touched
    np.testing.assert_allclose(normal, np.array([3.0, 1.0, 0.0]) / np.sqrt(10.0))


def test_a_finger_without_tip_contact_reads_zeros_and_indicator_zero():
    record = _with_contacts(make_record("sphere"), ["mfproximal"], [[0, 1, 0]], [2.0])
    X = plugins.get_descriptor("contact-normals").transform([record])[0]
    np.testing.assert_array_equal(X, 0.0)


def test_combination_is_the_parts_side_by_side(records):
    combo = plugins.get_descriptor("raw-joints+contact-normals")
    X = combo.transform(records)
    parts = [
        plugins.get_descriptor(n).transform(records) for n in ("raw-joints", "contact-normals")
    ]
    np.testing.assert_array_equal(X, np.hstack(parts))
    assert combo.name == "raw-joints+contact-normals"
    assert combo.feature_names()[0] == "raw-joints:FFJ4"
    assert len(combo.feature_names()) == X.shape[1]


@pytest.mark.parametrize("name", plugins.descriptor_names())
def test_every_descriptor_maps_records_to_a_float_matrix(name, records):
    desc = plugins.get_descriptor(name)
    X = desc.transform(records)
    assert X.shape == (len(records), len(desc.feature_names()))
    assert np.all(np.isfinite(X))
    assert desc.transform([]).shape == (0, len(desc.feature_names()))
    with pytest.raises(UsageError, match="single record"):
        desc.transform(records[0])


def test_finger_points_at_the_zero_pose_are_the_sheets_fingertips():
    """docs/hand.md: with every joint at 0 the tips sit at z = 0.191, 0.195, 0.191 and
    0.1825 m (ff, mf, rf, lf; LF's knuckle on its metacarpal), y = 0, in the palm frame."""
    from tactile_bullet.learn.finger_points import finger_points

    points = finger_points(np.zeros((3, 4)))
    np.testing.assert_allclose(points[:, 2, 1], [0.191, 0.195, 0.191, 0.1825], atol=1e-9)
    np.testing.assert_allclose(points[..., 0], 0.0, atol=1e-12)


def test_finger_points_follow_each_phalanx_through_the_fcis_cumulative_angles():
    """J3 at 90 deg lays the proximal phalanx along -y (toward the object); J2 at 90 deg more
    points the middle one back down (-z); J1 at 90 deg more turns the distal one toward the
    palm (+y). Each end is 45, 25 and 26 mm along its phalanx (docs/hand.md)."""
    from tactile_bullet.learn.finger_points import finger_points

    ff = finger_points(np.full((3, 4), np.pi / 2))[0]
    np.testing.assert_allclose(ff, [[-0.045, 0.095], [-0.045, 0.070], [-0.019, 0.070]], atol=1e-9)
    desc = plugins.get_descriptor("finger-points")
    record = make_record("sphere")
    row = desc.transform([record])[0]
    assert len(desc.feature_names()) == row.size == 24
    np.testing.assert_allclose(row, finger_points(record.fci_angles()).ravel())


def test_finger_points_profile_is_the_fingers_mean_and_each_fingers_deviation():
    """``profile=true``: the four fingers' mean point (the size) and each finger's deviation
    from it (the shape), the same information as the plain layout."""
    records = make_records(per_shape=1, seed=3)
    plain = plugins.get_descriptor("finger-points").transform(records)
    desc = plugins.get_descriptor("finger-points", profile=True)
    split = desc.transform(records)
    assert split.shape == (len(records), 30) == (len(records), len(desc.feature_names()))
    mean, deviation = split[:, :6], split[:, 6:].reshape(len(records), 4, 6)
    np.testing.assert_allclose(deviation.sum(axis=1), 0.0, atol=1e-12)
    np.testing.assert_allclose((deviation + mean[:, None, :]).reshape(len(records), -1), plain)
    with pytest.raises(UsageError, match="profile must be true or false"):
        plugins.get_descriptor("finger-points", profile="yes")
