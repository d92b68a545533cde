"""Physics facts of the simulated enclosure grasp (thesis Algorithm 1) that users rely on.

Each grasp takes ~0.3-1 s on one core; the suite keeps to a few dozen of them.
"""

from __future__ import annotations

import numpy as np
import pytest

from tactile_bullet.errors import UsageError
from tactile_bullet.hand import LONG_FINGERS
from tactile_bullet.objects.shapes import BUILTIN_SHAPES, THESIS_SHAPES
from tactile_bullet.records import ControllerSettings, Pose, load_record, save_record
from tactile_bullet.sim.grasp import simulate_grasp

SHAPES = {s.name: s for s in BUILTIN_SHAPES}
CONTACT = ControllerSettings(mode="contact")
ENGINES = ("bullet", "mujoco")
"""Every physical fact below holds on both engines (MuJoCo grasps take ~0.1 s)."""


def on(engine: str, **settings) -> ControllerSettings:
    return ControllerSettings(engine=engine, **settings)


def mid_size(name: str) -> dict[str, float]:
    return {k: (p.min + p.max) / 2 for k, p in SHAPES[name].params.items()}


def total_flexion(record) -> np.ndarray:
    """Per long finger, J3 + J2 + J1: the arc the finger subtends on the object (eq. 2.3)."""
    return record.fci_angles().sum(axis=0)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("shape", THESIS_SHAPES)
def test_all_four_fingers_touch_a_centred_mid_size_object(shape, engine):
    record = simulate_grasp(shape, mid_size(shape), controller=on(engine, mode="contact"))
    assert set(LONG_FINGERS) <= set(record.fingers_in_contact), record.fingers_in_contact
    assert "unstable" not in record.flags


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("shape", ["sphere", "cylinder"])
def test_larger_radius_gives_smaller_flexion(shape, engine):
    """s = r theta: the same finger wrapped on a larger circle subtends a smaller angle."""
    radii = (0.038, 0.046, 0.054) if shape == "sphere" else (0.025, 0.035, 0.045)
    flex = [
        total_flexion(simulate_grasp(shape, {"radius": r}, controller=on(engine))).mean()
        for r in radii
    ]
    assert flex[0] > flex[1] > flex[2], flex


@pytest.mark.parametrize("engine", ENGINES)
def test_cylinder_gives_nearly_equal_angles_across_fingers(engine):
    """Same radius under every finger: the arcs agree to within the hand's own asymmetry
    (the little finger's knuckle sits 8.5 mm lower on its metacarpal)."""
    flex = total_flexion(simulate_grasp("cylinder", {"radius": 0.035}, controller=on(engine)))
    assert flex.std() / flex.mean() < 0.1, flex
    cone = total_flexion(
        simulate_grasp("cone", {"radius": 0.05, "length": 0.17}, controller=on(engine))
    )
    assert np.ptp(flex) < np.ptp(cone), (flex, cone)


@pytest.mark.parametrize("engine", ENGINES)
def test_cone_gives_a_monotone_trend_from_apex_to_base(engine):
    """The base (radius large) is toward the little finger: flexion falls from ff to lf."""
    flex = total_flexion(
        simulate_grasp("cone", {"radius": 0.05, "length": 0.17},
                       controller=on(engine, mode="contact"))
    )  # fmt: skip
    assert flex[0] > flex[2] > flex[3], flex
    # On mujoco the tendon curls the distal phalanx first, and contact mode ends J0 when it
    # touches, before the middle phalanx has wrapped: the spread is smaller (0.50 rad).
    assert flex[0] - flex[3] > {"bullet": 0.5, "mujoco": 0.4}[engine]


def test_small_object_offset_sideways_leaves_the_far_finger_without_contact():
    record = simulate_grasp("sphere", {"radius": 0.035}, Pose(offset=(0.03, 0.0, 0.0)))
    assert "lf" not in record.fingers_in_contact
    assert "ff" in record.fingers_in_contact
    assert "finger_without_contact" in record.flags


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("mode", ["torque", "contact"])
@pytest.mark.parametrize("shape", [s.name for s in BUILTIN_SHAPES])
def test_both_modes_terminate_on_every_shape(shape, mode, engine):
    ctl = on(engine, mode=mode)
    record = simulate_grasp(shape, controller=ctl)
    assert "did_not_settle" not in record.flags
    assert record.sim_time_s < ctl.max_time
    assert record.fingers_in_contact  # it touched the object at all


@pytest.mark.parametrize("engine", ENGINES)
def test_grasp_ends_when_algorithm_1_says_so_not_after_a_fixed_time(engine):
    """A bigger cylinder stops the fingers earlier: fewer steps."""
    ctl = on(engine, mode="contact")
    small = simulate_grasp("cylinder", {"radius": 0.025}, controller=ctl)
    large = simulate_grasp("cylinder", {"radius": 0.05}, controller=ctl)
    assert large.steps < small.steps


@pytest.mark.parametrize("engine", ENGINES)
def test_same_inputs_give_a_bit_identical_record(tmp_path, engine):
    pose, ctl = Pose((0.005, 0, 0), 0.1), on(engine)
    a = simulate_grasp("sphere", {"radius": 0.045}, pose, ctl, seed=3)
    b = simulate_grasp("sphere", {"radius": 0.045}, pose, ctl, seed=3)
    assert a.equals(b)
    path = save_record(a, tmp_path / "rec.npz")
    assert load_record(path).equals(a)


def test_record_holds_time_series_contacts_and_final_state():
    record = simulate_grasp("cylinder")
    n = len(record.joint_names)
    assert record.angles.shape == (len(record.time), n) == record.efforts.shape
    assert np.all(np.diff(record.time) > 0)
    assert np.allclose(record.angles[-1], record.final_angles)
    # contacts are on the object's surface: for a centred cylinder, at the radius from its axis
    assert len(record.contact_force) == len(record.contact_link) > 0
    normals = record.contact_normal
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-6)
    assert np.all(record.contact_force >= 0)


@pytest.mark.parametrize("engine", ENGINES)
def test_contact_normals_point_out_of_the_object_in_the_palm_frame(engine):
    """A centred cylinder lies along x: at each finger contact the outward normal points away
    from its axis, and the contact sits on its surface (radius from the axis)."""
    from tactile_bullet.sim.scene import place_object

    record = simulate_grasp("cylinder", {"radius": 0.035}, controller=on(engine))
    axis = np.array(place_object(SHAPES["cylinder"], record.params, record.pose).position)
    fingers = np.isin(record.contact_link, ["ffdistal", "mfdistal", "rfdistal", "lfdistal"])
    pos, nrm = record.contact_position[fingers], record.contact_normal[fingers]
    assert len(pos) >= 4
    radial = pos[:, 1:] - axis[1:]
    dist = np.linalg.norm(radial, axis=1)
    assert np.allclose(dist, 0.035, atol=0.008)  # within a capsule radius of the surface
    cos = np.sum(radial / dist[:, None] * nrm[:, 1:], axis=1)
    assert np.all(cos > 0.9), cos


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"shape": "blob"}, "unknown shape"),
        ({"shape": "sphere", "params": {"radius": -0.01}}, "out of range"),
        ({"shape": "sphere", "params": {"radius": 0.5}}, "out of range"),
        ({"shape": "sphere", "params": {"height": 0.1}}, "no parameter"),
        ({"shape": "sphere", "pose": Pose(offset=(0, 0.04, 0))}, "inside the open hand"),
    ],
)
def test_bad_input_raises_a_clear_usage_error(kwargs, message):
    with pytest.raises(UsageError, match=message):
        simulate_grasp(**kwargs)


@pytest.mark.parametrize("shape", ["sphere", "hyperboloid"])
def test_preshape_skips_only_free_space(shape):
    """Starting the fingers where their sweep comes within 5 mm of the object leaves the final
    configuration where driving them from the open hand puts it (within 3 deg per joint in
    torque mode), in fewer steps; the fingers start bent but still touch at the end."""
    pre = simulate_grasp(shape, controller=ControllerSettings(preshape=True))
    full = simulate_grasp(shape)
    assert pre.controller.preshape and not full.controller.preshape
    assert pre.steps < 0.9 * full.steps
    assert np.degrees(np.abs(pre.fci_angles() - full.fci_angles())).max() < 3.0
    j3 = [pre.joint_names.index(f"{f.upper()}J3") for f in LONG_FINGERS]
    assert np.all(pre.angles[0, j3] > 0.1) and np.all(full.angles[0, j3] == 0.0)
    assert set(LONG_FINGERS) <= set(pre.fingers_in_contact)


def test_thumb_starts_clear_of_the_object_and_ends_on_it():
    """The thumb skips the free part of its sweep (it starts partly opposed, never touching)
    and is still driven onto the object."""
    record = simulate_grasp("sphere", {"radius": 0.05})
    th4 = record.joint_names.index("THJ4")
    assert 0.0 < record.angles[0, th4] < record.final_angles[th4]
    assert "th" in record.fingers_in_contact


def test_records_saved_before_preshape_load_as_driven_from_the_open_hand(tmp_path):
    import json

    from tactile_bullet.records import record_from_parts

    record = simulate_grasp("cylinder", controller=ControllerSettings(preshape=True))
    meta = json.loads(json.dumps(record.metadata()))
    del meta["controller"]["preshape"]
    assert record_from_parts(meta, record.arrays()).controller.preshape is False
    with pytest.raises(UsageError, match="preshape"):
        ControllerSettings(preshape="yes")
