"""The hand's URDF against docs/hand.md (numbers copied here on
purpose: the test must not read them from the generator it checks)."""

from __future__ import annotations

import io
import math
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

REPO = Path(__file__).resolve().parent.parent
URDF = REPO / "urdf" / "shadow_hand.urdf"

# The sheet's zero-pose tip positions in the palm frame (m).
SHEET_TIPS = {
    "fftip": (0.033, 0.0, 0.191),
    "mftip": (0.011, 0.0, 0.195),
    "rftip": (-0.011, 0.0, 0.191),
    "lftip": (-0.033, 0.0, 0.1825),
    "thtip": (0.103, -0.0086, 0.098),
}

# The sheet's joint limits (deg); J3 lower limit: the sheet's main value, -15.
SHEET_LIMITS_DEG = {
    "WRJ2": (-30, 10), "WRJ1": (-40, 28),
    **{f"{f}J4": (-20, 20) for f in ("FF", "MF", "RF", "LF")},
    **{f"{f}J3": (-15, 90) for f in ("FF", "MF", "RF", "LF")},
    **{f"{f}J2": (0, 90) for f in ("FF", "MF", "RF", "LF")},
    **{f"{f}J1": (0, 90) for f in ("FF", "MF", "RF", "LF")},
    "LFJ5": (0, 45),
    "THJ5": (-60, 60), "THJ4": (0, 70), "THJ3": (-12, 12), "THJ2": (-40, 40), "THJ1": (-15, 90),
}  # fmt: skip

# The sheet's effort (N m) / velocity (rad/s) / damping.
SHEET_DRIVE = {
    "WRJ2": (10, 2, 0.1), "WRJ1": (30, 2, 0.1),
    "THJ5": (5, 4, 0.2), "THJ4": (3, 4, 0.2), "THJ3": (2, 4, 0.2), "THJ2": (2, 2, 0.1),
    "THJ1": (1, 4, 0.2),
}  # fmt: skip

# The sheet's mass table (kg), per link; the distal rows include the tip.
SHEET_MASS = {
    "palm": 0.300, "knuckle": 0.008, "proximal": 0.030, "middle": 0.017, "distal": 0.013,
    "lfmetacarpal": 0.030, "thbase": 0.010, "thproximal": 0.040, "thhub": 0.005,
    "thmiddle": 0.020, "thdistal": 0.017,
}  # fmt: skip
HAND_LINKS = (
    ["palm"]
    + [
        f"{f}{k}"
        for f in ("ff", "mf", "rf", "lf")
        for k in ("knuckle", "proximal", "middle", "distal", "tip")
    ]
    + ["lfmetacarpal", "thbase", "thproximal", "thhub", "thmiddle", "thdistal", "thtip"]
)
LONG_FINGERS = ("ff", "mf", "rf", "lf")


@pytest.fixture(scope="module")
def hand():
    client = p.connect(p.DIRECT)
    try:
        body = p.loadURDF(
            str(URDF), useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE,
            physicsClientId=client,
        )  # fmt: skip
        joints, links = {}, {}
        for i in range(p.getNumJoints(body, physicsClientId=client)):
            info = p.getJointInfo(body, i, physicsClientId=client)
            joints[info[1].decode()] = info
            links[info[12].decode()] = i
        yield client, body, joints, links
    finally:
        p.disconnect(client)


def set_pose(hand, angles: dict[str, float]) -> None:
    client, body, joints, _ = hand
    for name, info in joints.items():
        if info[2] == p.JOINT_REVOLUTE:
            p.resetJointState(body, info[0], angles.get(name, 0.0), physicsClientId=client)


def in_palm(hand, link: str) -> np.ndarray:
    """Position of a link's URDF frame in the palm link's frame."""
    client, body, _, links = hand

    def frame(name):
        state = p.getLinkState(
            body, links[name], computeForwardKinematics=True, physicsClientId=client
        )
        return state[4], state[5]

    inv_pos, inv_orn = p.invertTransform(*frame("palm"))
    return np.array(p.multiplyTransforms(inv_pos, inv_orn, *frame(link))[0])


def test_zero_pose_tips_match_sheet(hand):
    set_pose(hand, {})
    for tip, expected in SHEET_TIPS.items():
        got = in_palm(hand, tip)
        assert np.linalg.norm(got - expected) < 1e-3, (tip, got, expected)


def test_palm_origin_in_forearm_frame(hand):
    client, body, _, links = hand
    set_pose(hand, {})
    state = p.getLinkState(
        body, links["palm"], computeForwardKinematics=True, physicsClientId=client
    )
    # Fixed base at the world origin, identity orientation: world frame = forearm frame.
    np.testing.assert_allclose(state[4], (0.0, -0.010, 0.247), atol=1e-6)


def test_joint_names_limits_and_drive(hand):
    _, _, joints, _ = hand
    revolute = {n: i for n, i in joints.items() if i[2] == p.JOINT_REVOLUTE}
    assert set(revolute) == set(SHEET_LIMITS_DEG)
    assert len(revolute) == 24
    for name, (lo, hi) in SHEET_LIMITS_DEG.items():
        info = revolute[name]
        assert math.degrees(info[8]) == pytest.approx(lo, abs=1e-6), name
        assert math.degrees(info[9]) == pytest.approx(hi, abs=1e-6), name
        effort, velocity, damping = SHEET_DRIVE.get(name, (2, 2, 0.1))
        assert info[10] == pytest.approx(effort), name
        assert info[11] == pytest.approx(velocity), name
        assert info[6] == pytest.approx(damping), name


def test_fixed_tip_joints(hand):
    _, _, joints, _ = hand
    fixed = {n: i[12].decode() for n, i in joints.items() if i[2] == p.JOINT_FIXED}
    assert sorted(fixed.values()) == sorted(SHEET_TIPS)


@pytest.mark.parametrize("finger", LONG_FINGERS)
@pytest.mark.parametrize("joint", ("J3", "J2", "J1"))
def test_positive_flexion_moves_tip_to_palm_side(hand, finger, joint):
    tip = f"{finger}tip"
    set_pose(hand, {})
    rest = in_palm(hand, tip)
    set_pose(hand, {f"{finger.upper()}{joint}": 0.3})
    bent = in_palm(hand, tip)
    set_pose(hand, {})
    assert bent[1] < rest[1] - 1e-3, (finger, joint, rest, bent)
    assert abs(bent[0] - rest[0]) < 1e-6  # flexion stays in the finger's plane


def test_hand_mass_matches_sheet(hand):
    client, body, _, links = hand
    expected = 0.0
    for link in HAND_LINKS:
        kind = link
        for suffix in ("knuckle", "proximal", "middle", "distal"):
            if link[:2] in LONG_FINGERS and link.endswith(suffix):
                kind = suffix
        expected += SHEET_MASS.get(kind, 0.0)  # tips: included in distal
    got = sum(p.getDynamicsInfo(body, links[n], physicsClientId=client)[0] for n in HAND_LINKS)
    assert expected == pytest.approx(0.694)
    assert got == pytest.approx(expected, rel=0.02)
    for link in HAND_LINKS:
        assert p.getDynamicsInfo(body, links[link], physicsClientId=client)[0] > 0, link


def test_distal_pad_ends_32mm_past_j1(hand):
    client, body, _, links = hand
    set_pose(hand, {})
    for f in LONG_FINGERS:
        aabb_min, aabb_max = p.getAABB(body, links[f"{f}distal"], physicsClientId=client)
        j1_z = in_palm(hand, f"{f}tip")[2] - 0.026
        # palm frame = forearm frame shifted by (0, -0.010, 0.247) at zero pose
        top = aabb_max[2] - 0.247
        assert top - j1_z == pytest.approx(0.032, abs=2e-3), f


def test_generator_reproduces_committed_file(tmp_path):
    out = tmp_path / "hand.urdf"
    subprocess.run(
        [sys.executable, str(REPO / "tools" / "make_urdf.py"), str(out)],
        check=True,
        capture_output=True,
    )
    assert out.read_text() == URDF.read_text()


# --- strict parsing -------------------------------------------------------------------------
# yourdfpy's parser knows only URDF's four geometries and raises on anything else; PyBullet's
# <capsule radius length> is the one extension this file is allowed. The strict check below
# verifies each capsule on its own (exactly radius and length, both > 0, inside <geometry>),
# swaps it for a <cylinder> with the same attributes (same schema as a cylinder) and hands the
# result to yourdfpy, whose strict validation handler fails on any error.


def load_yourdfpy():
    """yourdfpy is a test-only dependency; without it the strict tests fail, loudly."""
    try:
        import yourdfpy
    except ImportError:  # pragma: no cover
        pytest.fail("the strict URDF tests need yourdfpy (pip install yourdfpy)")
    return yourdfpy


def strict_parse(text: str):
    yourdfpy = load_yourdfpy()
    root = ET.fromstring(text)
    for geometry in root.iter("geometry"):
        children = list(geometry)
        assert len(children) == 1, "a <geometry> must hold exactly one shape"
        shape = children[0]
        assert shape.tag in ("box", "cylinder", "sphere", "mesh", "capsule"), shape.tag
        if shape.tag == "capsule":
            assert set(shape.attrib) == {"radius", "length"}, shape.attrib
            assert float(shape.attrib["radius"]) > 0 and float(shape.attrib["length"]) > 0
    # One tree: unique names, every joint joins known links, every link but the root is the
    # child of exactly one joint (yourdfpy does not check these).
    links = [link.get("name") for link in root.iter("link")]
    joints = list(root.iter("joint"))
    assert len(set(links)) == len(links)
    assert len({j.get("name") for j in joints}) == len(joints)
    children = [j.find("child").get("link") for j in joints]
    assert all(j.find("parent").get("link") in links for j in joints)
    assert sorted(children) == sorted(set(children)) and set(children) <= set(links)
    assert len(set(links) - set(children)) == 1, "exactly one root link"
    standard = re.sub(r"<capsule\b", "<cylinder", text)
    model = yourdfpy.URDF.load(io.StringIO(standard), build_scene_graph=False, load_meshes=False)
    assert model.validate(), model._errors
    return yourdfpy.URDF.load(io.StringIO(standard), build_scene_graph=True, load_meshes=False)


def test_strict_parser_accepts_file():
    text = URDF.read_text()
    assert "<capsule" in text  # the extension is really used (and really checked above)
    with pytest.raises(ValueError, match="capsule"):
        load_yourdfpy().URDF.load(io.StringIO(text), load_meshes=False)
    model = strict_parse(text)
    assert model.base_link == "forearm"
    assert sorted(model.actuated_joint_names) == sorted(SHEET_LIMITS_DEG)
    # Forward kinematics by an independent implementation.
    for tip, expected in SHEET_TIPS.items():
        got = model.get_transform(tip, "palm")[:3, 3]
        assert np.linalg.norm(got - expected) < 1e-3, (tip, got)


@pytest.mark.parametrize("finger", ["ff", "mf", "rf", "lf"])
def test_the_sensor_models_planar_chain_is_the_urdfs_kinematics(finger):
    """learn/perturb.py moves a contact with its link through a planar chain (knuckle, phalanx
    ends); an independent forward kinematics of the URDF must place each phalanx the same."""
    from tactile_bullet.learn.perturb import link_pose

    model = strict_parse(URDF.read_text())
    rng = np.random.default_rng(3)
    up = finger.upper()
    for _ in range(5):
        angles = {f"{up}J4": rng.uniform(-0.3, 0.3), f"{up}J3": rng.uniform(0.0, 1.5),
                  f"{up}J2": rng.uniform(0.0, 1.5), f"{up}J1": rng.uniform(0.0, 1.5)}  # fmt: skip
        model.update_cfg({k: v for k, v in angles.items() if k in model.actuated_joint_names})
        for depth, link in ((1, "proximal"), (2, "middle"), (3, "distal")):
            rot, origin = link_pose(finger, angles, depth)
            frame = model.get_transform(f"{finger}{link}", "palm")
            assert np.allclose(frame[:3, 3], origin, atol=1e-9), (link, angles)
            assert np.allclose(frame[:3, :3], rot, atol=1e-9), (link, angles)


@pytest.mark.parametrize(
    "old, new",
    [
        (' effort="2" velocity="2"/>', ' velocity="2"/>'),  # a limit without effort
        ('<joint name="FFJ2" type="revolute">', '<joint name="FFJ2" type="hinge">'),
        ('<capsule radius="0.009"', '<capsule radius="0.009" fromto="0 0 0 0 0 1"'),
        ('<child link="fftip"/>', '<child link="ffdistal"/>'),  # a link with two parents
    ],
)
def test_strict_parser_rejects_broken_file(old, new):
    text = URDF.read_text()
    assert old in text
    with pytest.raises(AssertionError):
        strict_parse(text.replace(old, new, 1))
