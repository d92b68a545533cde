"""The sensor model, the protocols' recipes, the robust descriptors and the physics knobs."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from synthetic import make_records

from tactile_bullet.errors import UsageError
from tactile_bullet.experiments import protocols as P
from tactile_bullet.learn.perturb import (
    SensorModel,
    link_pose,
    moved_contacts,
    perturb,
    perturb_all,
)
from tactile_bullet.learn.robust import augment, zeroed
from tactile_bullet.plugins import get_descriptor
from tactile_bullet.records import ControllerSettings, record_from_parts


@pytest.fixture(scope="module")
def records():
    return make_records(per_shape=2, seed=3)


# --- perturb ------------------------------------------------------------------------------


def test_bias_is_one_offset_per_joint_for_the_whole_grasp(records):
    rec = records[0]
    out = perturb(rec, SensorModel.degrees(bias=3.0), 7)
    shift = out.angles - rec.angles
    assert np.allclose(shift, shift[0])  # the same offset at every sample...
    assert np.allclose(out.final_angles - rec.final_angles, shift[0])  # ...and at the end
    assert np.all(np.abs(shift[0]) <= math.radians(3.0))
    assert np.std(shift[0]) > math.radians(0.5)  # joints get different offsets


def test_perturb_is_pure_and_seeded(records):
    rec = records[1]
    before = rec.final_angles.copy()
    model = SensorModel.degrees(sigma=1.0, bias=2.0)
    a, b = perturb(rec, model, 5), perturb(rec, model, 5)
    assert a.equals(b)
    assert not a.equals(perturb(rec, model, 6))
    assert np.array_equal(rec.final_angles, before)
    assert perturb(rec, SensorModel(), 5) is rec  # a perfect sensor changes nothing


def test_noise_has_the_stated_spread(records):
    rec = records[2]
    out = perturb(rec, SensorModel.degrees(sigma=2.0), 1)
    spread = np.degrees(np.std(out.angles - rec.angles))
    assert 1.8 < spread < 2.2
    efforts = perturb(rec, SensorModel(effort_sigma=0.05), 1).efforts - rec.efforts
    assert 0.04 < np.std(efforts) < 0.06


def test_perturb_all_gives_each_record_its_own_draw(records):
    outs = perturb_all(records[:2], SensorModel.degrees(bias=3.0), seed=0)
    assert not np.allclose(
        outs[0].final_angles - records[0].final_angles,
        outs[1].final_angles - records[1].final_angles,
    )


@pytest.mark.parametrize("bad", [{"sigma": -1.0}, {"bias": float("nan")}, {"effort_sigma": "x"}])
def test_sensor_model_refuses_bad_values(bad):
    with pytest.raises(UsageError):
        SensorModel(**bad)


def test_contacts_move_with_their_link_through_the_flexion_errors(records):
    """A real hand places a tactile contact through the kinematics of its measured angles:
    the point and the normal move together, as the link does, about the erring joints."""
    final = np.array(records[0].final_angles, dtype=float)
    final[records[0].joint_index("FFJ4")] = 0.0
    knuckle = np.array([0.033, 0.0, 0.095])  # docs/hand.md
    rec = replace(
        records[0],
        final_angles=final,
        contact_link=np.array(["ffdistal", "thdistal", "ffproximal"]),
        contact_position=np.array([knuckle + [0.0, -0.03, 0.08], [0.0, -0.05, 0.1], knuckle]),
        contact_normal=np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0]]),
    )
    errors = np.zeros(len(rec.joint_names))
    errors[rec.joint_index("FFJ3")], errors[rec.joint_index("FFJ2")] = 0.1, 0.05
    points, normals = moved_contacts(rec, errors)
    assert np.allclose(normals[0], [0.0, math.cos(0.15), math.sin(0.15)])
    # the distal contact turned about the knuckle (J3) and about J2, which itself moved: it
    # keeps its distance from J2, wherever J2 is read to be
    true = dict(zip(rec.joint_names, rec.final_angles, strict=True))
    read = dict(zip(rec.joint_names, rec.final_angles + errors, strict=True))
    j2_true, j2_read = link_pose("ff", true, 2)[1], link_pose("ff", read, 2)[1]
    assert np.linalg.norm(points[0] - j2_read) == pytest.approx(
        np.linalg.norm(rec.contact_position[0] - j2_true)
    )
    assert points[0][0] == pytest.approx(rec.contact_position[0][0])  # flexion keeps x
    assert np.linalg.norm(points[0] - rec.contact_position[0]) > 0.005  # millimetres, not microns
    assert np.allclose(points[1], rec.contact_position[1])  # the thumb's: left as simulated
    assert np.allclose(normals[1], [0.0, 1.0, 0.0])
    assert np.allclose(points[2], knuckle)  # on the J3 axis: it does not move
    only_j3 = np.zeros(len(rec.joint_names))
    only_j3[rec.joint_index("FFJ3")] = 0.1
    points, _ = moved_contacts(rec, only_j3)
    before, after = rec.contact_position[0] - knuckle, points[0] - knuckle
    assert np.linalg.norm(after) == pytest.approx(np.linalg.norm(before))
    turn = math.atan2(after[2], -after[1]) - math.atan2(before[2], -before[1])
    assert turn == pytest.approx(-0.1)  # flexion turns toward -y


def test_perturbed_contacts_are_the_moved_ones(records):
    rec = records[0]
    out = perturb(rec, SensorModel.degrees(bias=3.0), seed=5)
    points, normals = moved_contacts(rec, out.final_angles - rec.final_angles)
    assert np.array_equal(out.contact_position, points)
    assert np.array_equal(out.contact_normal, normals)
    assert not np.allclose(out.contact_position, rec.contact_position)


# --- robust descriptors -------------------------------------------------------------------


def test_zeroing_removes_a_calibration_bias_exactly(records):
    biased = perturb_all(records, SensorModel.degrees(bias=5.0), seed=2)
    robust = get_descriptor("robust-signature")
    plain = get_descriptor("signature")
    assert np.allclose(robust.transform(biased), robust.transform(records))
    assert not np.allclose(plain.transform(biased), plain.transform(records), atol=1e-3)
    joints = get_descriptor("robust-joints")
    assert np.allclose(joints.transform(biased), joints.transform(records))


def test_zeroing_needs_the_time_series(records):
    bare = replace(records[0], angles=np.zeros((0, len(records[0].joint_names))))
    with pytest.raises(UsageError, match="time series"):
        zeroed(bare)


def test_augment_adds_labelled_perturbed_copies(records):
    out = augment(records, copies=2, seed=1)
    assert len(out) == 3 * len(records)
    assert [r.shape for r in out] == [r.shape for r in records] * 3
    assert not np.allclose(out[len(records)].final_angles, records[0].final_angles)
    assert all(a.equals(b) for a, b in zip(augment(records, copies=2, seed=1), out, strict=True))


# --- protocols ----------------------------------------------------------------------------


def test_every_protocol_has_one_headline_at_every_scale():
    for scale in P.SCALES:
        table = P.protocols(scale)
        assert list(table) == list(P.PROTOCOL_NAMES)
        for protocol in table.values():
            assert sum(level.headline for level in protocol.levels) == 1
            sets = P.sets(scale)
            for level in protocol.levels:
                train = P.train_sets(level.train or protocol.train)
                assert all(t in sets for t in train)
                assert all(t in sets and t not in train for t in level.test)
    noise = P.protocols("full")["sensor-noise"].headline
    assert noise.sensor == SensorModel.degrees(sigma=1.0, bias=3.0)
    assert P.protocols("full")["sim-shift"].headline.name == "+-20%"


def test_protocol_names_resolve_or_fail_naming_the_bad_one():
    assert P.resolve("all") == list(P.DEFAULT_PROTOCOLS)  # no optional engine needed
    assert P.resolve("mixed-engine,cross-engine") == ["cross-engine", "mixed-engine"]
    assert P.resolve("sim-shift,in-distribution") == ["in-distribution", "sim-shift"]
    with pytest.raises(UsageError, match="unknown protocol 'noise'"):
        P.resolve("sensor-noise,noise")


def test_cross_engine_sets_are_the_same_grasps_on_each_engine():
    """bullet->mujoco compares like with like: the mujoco sets draw the very same tasks (shape,
    sizes, pose, seed), only the controller's engine differs."""
    sets = P.sets("tiny")
    for kind in ("demo-train", "demo-test"):
        bullet = sets[f"tiny-{kind}"].sweep().tasks(0)
        mujoco = sets[f"tiny-mujoco-{kind}"].sweep().tasks(0)
        assert [(t.shape, t.params, t.pose, t.seed) for t in bullet] == [
            (t.shape, t.params, t.pose, t.seed) for t in mujoco
        ]
        assert {t.controller.engine for t in bullet} == {"bullet"}
        assert {t.controller.engine for t in mujoco} == {"mujoco"}
    cross = P.protocols("tiny")["cross-engine"]
    assert [(lv.name, lv.train) for lv in cross.levels] == [
        ("bullet->mujoco", None),
        ("mujoco->bullet", "tiny-mujoco-demo-train"),
    ]
    assert P.protocols("tiny")["mixed-engine"].train == "tiny-demo-train+tiny-mujoco-demo-train"


def test_benchmark_engine_moves_every_single_engine_set_to_it():
    specs = P.needed_sets(["in-distribution", "sim-shift"], "tiny", engine="mujoco")
    assert specs and all(s.name.startswith("tiny-mujoco-") for s in specs)
    assert {s.controller.engine for s in specs} == {"mujoco"}


def _fractions(task) -> list[float]:
    from tactile_bullet.objects.shapes import BUILTIN_SHAPES

    spec = next(s for s in BUILTIN_SHAPES if s.name == task.shape)
    return [(task.params[k] - p.min) / (p.max - p.min) for k, p in spec.params.items()]


def test_unseen_sizes_trains_in_the_middle_and_tests_at_the_ends():
    sets = P.sets("tiny")
    train = sets["tiny-sizes-train"].sweep().tasks(0)
    test = sets["tiny-sizes-test"].sweep().tasks(0)
    assert all(0.3 < f < 0.7 for t in train for f in _fractions(t))
    assert all(f < 0.1 or f > 0.9 for t in test for f in _fractions(t))


def test_unseen_poses_tests_beyond_the_training_poses():
    sets = P.sets("tiny")
    train = sets["tiny-poses-train"].sweep().tasks(0)
    test = sets["tiny-poses-test"].sweep().tasks(0)
    assert all(max(abs(v) for v in t.pose.offset) <= 0.003 and t.pose.rotation == 0 for t in train)
    assert all(abs(t.pose.offset[0]) >= 0.01 or math.degrees(t.pose.rotation) >= 5 for t in test)
    assert any(t.pose.rotation > 0 for t in test) and any(t.pose.offset[0] for t in test)


def test_sim_shift_moves_every_knob_by_the_level():
    base = ControllerSettings()
    up, down = P.shifted(base, 0.2), P.shifted(base, -0.2)
    assert up.friction == pytest.approx(0.96) and down.friction == pytest.approx(0.64)
    assert up.thres_t == pytest.approx(0.42) and up.delta == pytest.approx(0.0072)
    assert up.phalanx_scale == pytest.approx(1.02) and down.phalanx_scale == pytest.approx(0.98)
    sets = P.sets("full")
    assert sets["shift-friction-0.5"].controller.friction == 0.5
    assert sets["shift-up-20"].controller == up


# --- physics knobs ------------------------------------------------------------------------


def test_default_physics_stays_out_of_saved_records(records):
    meta = records[0].metadata()
    assert "friction" not in meta["controller"] and "phalanx_scale" not in meta["controller"]
    shifted = replace(records[0], controller=ControllerSettings(friction=0.5, phalanx_scale=1.03))
    back = record_from_parts(shifted.metadata(), shifted.arrays())
    assert back.controller.friction == 0.5 and back.controller.phalanx_scale == 1.03
    with pytest.raises(UsageError, match="phalanx_scale"):
        ControllerSettings(phalanx_scale=1.5)
    with pytest.raises(UsageError, match="friction"):
        ControllerSettings(friction=0.0)


def test_scaled_hand_has_longer_fingers_and_the_same_palm():
    """Physical fact: at the open hand, a 3% longer phalanx chain puts each fingertip 3% of
    the knuckle-to-tip length farther from its knuckle, and the knuckles do not move."""
    from tactile_bullet.objects.shapes import BUILTIN_SHAPES
    from tactile_bullet.records import Pose
    from tactile_bullet.sim.scene import Scene

    sphere = next(s for s in BUILTIN_SHAPES if s.name == "sphere")

    def tip_and_knuckle(scale: float):
        with Scene(sphere, sphere.resolve({}), Pose(), phalanx_scale=scale) as scene:
            scene.reset_hand()
            c = scene.client
            tip = np.array(c.getLinkState(scene.hand, scene.link_index["ffdistal"])[4])
            knuckle = np.array(c.getLinkState(scene.hand, scene.link_index["ffproximal"])[4])
            return tip, knuckle

    tip1, knuckle1 = tip_and_knuckle(1.0)
    tip2, knuckle2 = tip_and_knuckle(1.03)
    assert np.allclose(knuckle1, knuckle2, atol=1e-9)
    assert np.linalg.norm(tip2 - knuckle2) == pytest.approx(
        1.03 * np.linalg.norm(tip1 - knuckle1), rel=1e-4
    )


def test_settled_averages_the_plateau_not_the_motion():
    from tactile_bullet.learn.robust import settled

    ramp = np.linspace(0.0, 1.0, 60)
    series = np.stack([np.minimum(ramp, 0.4), ramp], axis=1)  # joint 0 stops at 0.4 early
    assert np.allclose(settled(series), [0.4, series[-3:, 1].mean()])  # noiseless: exact
    sigma = math.radians(1.0)
    plateau_err, last3_err, moving_err = [], [], []
    for seed in range(30):
        noisy = series + np.random.default_rng(seed).normal(0.0, sigma, series.shape)
        est = settled(noisy)
        plateau_err.append(abs(est[0] - 0.4))
        last3_err.append(abs(noisy[-3:, 0].mean() - 0.4))
        moving_err.append(abs(est[1] - series[-3:, 1].mean()))
    # the stopped joint is averaged over (most of) its plateau: far less error than 3 samples
    assert np.mean(plateau_err) < 0.6 * np.mean(last3_err)
    # the joint still moving is not dragged toward its past
    assert np.mean(moving_err) < sigma
