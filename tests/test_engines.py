"""The engine layer: the MuJoCo hand matches the sheet, concave objects stay concave, and
choosing an engine fails clearly before any work."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_error

from tactile_bullet.objects.shapes import BUILTIN_SHAPES
from tactile_bullet.records import ControllerSettings, Pose
from tactile_bullet.sim.engines.mujoco_objects import (
    object_geoms,
    overfill,
    revolved_depth,
    torus_depth,
)

REPO = Path(__file__).resolve().parent.parent
SHAPES = {s.name: s for s in BUILTIN_SHAPES}
TIPS = {  # docs/hand.md, zero pose, palm frame; the distal frame sits 26 mm (thumb 27.5) below
    "ffdistal": (0.033, 0.0, 0.191 - 0.026),
    "mfdistal": (0.011, 0.0, 0.195 - 0.026),
    "lfdistal": (-0.033, 0.0, 0.1825 - 0.026),
}


def test_mjcf_generator_reproduces_committed_file(tmp_path):
    out = tmp_path / "hand.xml"
    subprocess.run([sys.executable, str(REPO / "tools" / "make_mjcf.py"), str(out)], check=True,
                   capture_output=True)  # fmt: skip
    assert out.read_text() == (REPO / "urdf" / "shadow_hand.xml").read_text()


def test_mjcf_hand_has_the_sheets_kinematics_and_one_tendon_actuator_per_finger():
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(REPO / "urdf" / "shadow_hand.xml"))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    for body, xyz in TIPS.items():
        assert np.allclose(d.body(body).xpos, xyz, atol=1e-4), body
    assert np.degrees(m.joint("FFJ3").range).round(3).tolist() == [-15.0, 90.0]
    # J1 and J2 share one tendon actuator whose pull is J1 + J2 (coefficients 1, 1)
    for f in ("FF", "MF", "RF", "LF"):
        act = m.actuator(f"A_{f}J0")
        assert act.trntype[0] == mujoco.mjtTrn.mjTRN_TENDON
        assert np.allclose(m.actuator_forcerange[act.id], (-1.0, 1.0))
        with pytest.raises(KeyError):
            m.actuator(f"A_{f}J1")
    assert np.allclose(m.actuator_forcerange[m.actuator("A_THJ5").id], (-5.0, 5.0))


def test_torus_and_hyperboloid_pieces_keep_hole_and_waist_within_a_fifth_of_a_mm():
    torus = SHAPES["torus"]
    params = torus.resolve({})
    cells = [g.vertices for g in object_geoms(torus, params)]
    assert len(cells) > 1
    worst, _ = overfill(cells, lambda p: torus_depth(p, **params))
    assert worst < 2e-4
    # the hole stays open: no piece reaches the axis
    import trimesh

    axis = np.array([[0.0, 0.0, 0.0], [0.02, 0.0, 0.0]])
    assert not any(trimesh.convex.convex_hull(c).contains(axis).any() for c in cells)
    hyper = SHAPES["hyperboloid"]
    params = hyper.resolve({})
    cells = [g.vertices for g in object_geoms(hyper, params)]
    worst, _ = overfill(cells, lambda p: revolved_depth(p, hyper, params))
    assert worst < 2e-4
    # the waist stays: a point just outside the waist but inside the end radius is free
    waist = np.array([[0.0, params["waist_radius"] + 0.003, 0.0]])
    assert not any(trimesh.convex.convex_hull(c).contains(waist).any() for c in cells)


def test_sphere_and_cylinder_are_native_geoms():
    assert [g.kind for g in object_geoms(SHAPES["sphere"], SHAPES["sphere"].resolve({}))] == [
        "sphere"
    ]
    cyl = object_geoms(SHAPES["cylinder"], SHAPES["cylinder"].resolve({"radius": 0.03}))
    assert [g.kind for g in cyl] == ["cylinder"] and cyl[0].size[0] == 0.03


def test_same_size_at_another_pose_matches_a_fresh_compile():
    """The compiled-model cache only moves the object: a grasp after another pose of the same
    size is bit-identical to one on an empty cache."""
    from tactile_bullet.sim.engines.mujoco import clear_compiled
    from tactile_bullet.sim.grasp import simulate_grasp

    ctl = ControllerSettings(engine="mujoco", mode="contact")
    pose = Pose((0.004, 0.0, 0.002), 0.2)
    simulate_grasp("torus", None, Pose(), ctl)
    warm = simulate_grasp("torus", None, pose, ctl)
    clear_compiled()
    cold = simulate_grasp("torus", None, pose, ctl)
    assert warm.equals(cold)
    assert warm.metadata()["controller"]["engine"] == "mujoco"


def test_a_reused_model_forgets_the_last_grasps_friction_and_force_limits():
    """A grasp reuses the last finished grasp's model and data of its size: what that grasp
    set (friction, motor force limits, joint state) must not leak into the next record, and
    two engines alive at once must not share a model."""
    from tactile_bullet.plugins import get_engine
    from tactile_bullet.sim.engines.mujoco import clear_compiled
    from tactile_bullet.sim.grasp import simulate_grasp

    ctl = ControllerSettings(engine="mujoco")
    simulate_grasp("sphere", None, Pose(), ControllerSettings(engine="mujoco", friction=0.3,
                                                              motor_force=0.6))  # fmt: skip
    warm = simulate_grasp("sphere", None, Pose(), ctl)
    clear_compiled()
    cold = simulate_grasp("sphere", None, Pose(), ctl)
    assert warm.equals(cold)
    spec = SHAPES["sphere"]
    factory = get_engine("mujoco")
    with factory(spec, spec.resolve(None), Pose(), ctl) as a:
        with factory(spec, spec.resolve(None), Pose(), ctl) as b:
            assert a.model is not b.model and a.data is not b.data


def test_unknown_engine_exits_2_listing_the_installed_ones(capsys):
    err = run_error(capsys, ["grasp", "--shape", "sphere", "--engine", "ode"])
    assert "unknown engine 'ode'" in err and "bullet, mujoco" in err


def test_missing_mujoco_exits_2_naming_the_extra(capsys, monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "mujoco" else real(name, *a)
    )
    err = run_error(capsys, ["grasp", "--shape", "sphere", "--engine", "mujoco"])
    assert "pip install 'tactile-bullet[mujoco]'" in err


def test_sweep_engine_is_checked_before_any_grasp(tmp_path):
    from tactile_bullet.datasets.sweeps import Sweep
    from tactile_bullet.errors import UsageError

    table = {"engine": "mujoco", "shapes": [{"name": "sphere"}]}
    assert Sweep.from_dict(table).controller.engine == "mujoco"
    with pytest.raises(UsageError, match="unknown engine 'odee'"):
        Sweep.from_dict({"engine": "odee", "shapes": [{"name": "sphere"}]})
    with pytest.raises(UsageError, match="disagree"):
        Sweep.from_dict({"engine": "mujoco", "controller": {"engine": "bullet"},
                         "shapes": [{"name": "sphere"}]})  # fmt: skip


def test_sweep_hand_model_is_checked_before_any_grasp(tmp_path):
    """A sweep's [controller] hand_model that is missing, not MJCF, or given without the
    mujoco engine is refused when the sweep is read; before, every grasp failed on its own
    and generate ended with status 0 and an empty dataset."""
    from tactile_bullet.datasets.sweeps import Sweep
    from tactile_bullet.errors import UsageError

    shapes = [{"name": "sphere"}]
    missing = str(tmp_path / "missing.xml")
    with pytest.raises(UsageError, match="missing.xml"):
        Sweep.from_dict({"engine": "mujoco", "controller": {"hand_model": missing},
                         "shapes": shapes})  # fmt: skip
    with pytest.raises(UsageError, match="mujoco engine"):
        Sweep.from_dict({"controller": {"hand_model": missing}, "shapes": shapes})
    text = tmp_path / "hand.txt"
    text.write_text("<mujoco/>")
    with pytest.raises(UsageError, match="MJCF"):
        Sweep.from_dict({"engine": "mujoco", "controller": {"hand_model": str(text)},
                         "shapes": shapes})  # fmt: skip


def test_verify_says_when_records_mix_engines(tmp_path, capsys):
    from tactile_bullet.cli import main
    from tactile_bullet.records import save_record
    from tactile_bullet.sim.grasp import simulate_grasp

    for engine in ("bullet", "mujoco"):
        ctl = ControllerSettings(engine=engine, mode="contact")
        save_record(simulate_grasp("sphere", None, Pose(), ctl), tmp_path / f"{engine}.npz")
    assert main(["verify", "--data", str(tmp_path)]) == 0
    assert "mixes physics engines: bullet, mujoco" in capsys.readouterr().out


def _prefixed_hand(tmp_path, wrist: bool = False) -> Path:
    """The project's MJCF as another model would name it (``rh_`` prefixes, as the MuJoCo
    Menagerie's); with ``wrist``, mounted on a turned, offset forearm with two wrist joints."""
    import re

    text = (REPO / "urdf" / "shadow_hand.xml").read_text()
    text = re.sub(
        r'(name|joint|tendon)="([^"]+)"',
        lambda m: m.group(0) if m.group(2) in ("grey", "dark", "skin")
        else f'{m.group(1)}="rh_{m.group(2)}"',
        text,
    )  # fmt: skip
    if wrist:
        inertial = '<inertial pos="0 0 0" mass="0.5" diaginertia="1e-3 1e-3 1e-3"/>'
        text = text.replace(
            '<body name="rh_palm">',
            '<body name="rh_forearm" pos="0.1 0.2 0.3" quat="0.9238795 0 0 0.3826834">'
            f'{inertial}<joint name="rh_WRJ2" axis="0 1 0" range="-0.5 0.2"/>'
            f'<body name="rh_wrist" pos="0 0 0.01">{inertial}'
            '<joint name="rh_WRJ1" axis="1 0 0" range="-0.6 0.4"/>'
            '<body name="rh_palm" pos="0 0 0.02">',
            1,
        )
        text = text.replace("  </worldbody>", "  </body></body></worldbody>", 1)
        text = text.replace(
            "  <actuator>", '  <actuator>\n    <position name="rh_A_WRJ2" joint="rh_WRJ2"/>', 1
        )
    path = tmp_path / ("wrist.xml" if wrist else "rh.xml")
    path.write_text(text)
    return path


def test_hand_model_is_found_by_shadow_names_and_grasps_as_the_own_model(tmp_path):
    from tactile_bullet.sim.grasp import simulate_grasp

    own = simulate_grasp("cylinder", None, Pose(), ControllerSettings(engine="mujoco"))
    ctl = ControllerSettings(engine="mujoco", hand_model=str(_prefixed_hand(tmp_path)))
    other = simulate_grasp("cylinder", None, Pose(), ctl)
    assert np.array_equal(own.final_angles, other.final_angles)
    assert other.metadata()["controller"]["hand_model"].endswith("rh.xml")


def test_hand_model_on_a_turned_forearm_has_its_wrist_welded_and_palm_frame_kept(tmp_path):
    """The object is placed, and contacts reported, in the model's palm frame: a hand mounted
    elsewhere grasps the same way (up to gravity's other direction)."""
    from tactile_bullet.sim.grasp import simulate_grasp

    ctl = ControllerSettings(engine="mujoco", mode="contact")
    own = simulate_grasp("cylinder", None, Pose(), ctl)
    moved = ControllerSettings(engine="mujoco", mode="contact",
                               hand_model=str(_prefixed_hand(tmp_path, wrist=True)))  # fmt: skip
    other = simulate_grasp("cylinder", None, Pose(), moved)
    assert other.fingers_in_contact == own.fingers_in_contact
    assert np.abs(other.fci_angles() - own.fci_angles()).max() < 0.02
    assert other.final("WRJ1") == other.final("WRJ2") == 0.0
    # contacts in the palm frame, where the own model (palm = world) reports them
    assert sorted(other.contact_link) == sorted(own.contact_link)
    for link in own.contact_link:
        a, b = own.contact_link == link, other.contact_link == link
        where = own.contact_position[a].mean(0) - other.contact_position[b].mean(0)
        facing = own.contact_normal[a].mean(0) - other.contact_normal[b].mean(0)
        assert np.abs(where).max() < 3e-3 and np.abs(facing).max() < 0.1


def test_welding_the_wrist_keeps_the_models_skip_of_palm_to_finger_contacts(tmp_path):
    """MuJoCo skips a body's contacts with its parent unless the parent is welded to the world.
    A model written with a moving wrist and self-collision (the Menagerie's) lets its knuckles
    overlap the palm; welding the wrist must not turn that overlap into contacts that throw the
    fingers at the first step."""
    import mujoco

    from tactile_bullet.sim.engines.mujoco_hand import load_hand_spec

    path = _prefixed_hand(tmp_path, wrist=True)
    text = path.read_text().replace('conaffinity="0"', 'conaffinity="1"', 1)  # self-collision
    path.write_text(text)
    model = load_hand_spec(path).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    body = lambda g: mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, model.geom_bodyid[g])  # noqa: E731
    parent = lambda g: model.body_parentid[model.geom_bodyid[g]]  # noqa: E731
    touching = [(body(c.geom1), body(c.geom2)) for c in data.contact[: data.ncon]
                if model.geom_bodyid[c.geom1] == parent(c.geom2)
                or model.geom_bodyid[c.geom2] == parent(c.geom1)]  # fmt: skip
    assert not touching
    # the knuckles do overlap the palm: without the skip they would touch it
    spec = load_hand_spec(path)
    for exclude in list(spec.excludes):
        spec.delete(exclude)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    pairs = {tuple(sorted((body(c.geom1), body(c.geom2)))) for c in data.contact[: data.ncon]}
    assert ("rh_ffknuckle", "rh_palm") in pairs


def test_converting_a_menagerie_hand_replaces_missing_meshes_and_drops_visuals(tmp_path):
    """hand_conversion.collision_copy makes a model whose meshes are absent loadable: a missing
    fingertip mesh becomes a capsule of the pad's size, visual geoms go, the rest is kept."""
    import mujoco

    from tactile_bullet.errors import UsageError
    from tactile_bullet.sim.engines.mujoco_hand import load_hand_spec
    from tactile_bullet.sim.hand_conversion import collision_copy

    path = _menagerie_style_hand(tmp_path)
    with pytest.raises(UsageError):
        load_hand_spec(path)  # the mesh files are not there
    tree, changes = collision_copy(path)
    out = tmp_path / "copy.xml"
    tree.write(out, encoding="unicode")
    assert changes == ["rh_ffdistal: f_distal_pst -> capsule 0.0085 0.008"]
    model = load_hand_spec(out).compile()
    ffdistal = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "rh_ffdistal")
    geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == ffdistal]
    assert [model.geom_type[g] for g in geoms] == [mujoco.mjtGeom.mjGEOM_CAPSULE]
    assert np.allclose(model.geom_size[geoms[0]][:2], [0.0085, 0.008])
    assert model.nmesh == 0
    for bad, why in (("<robot/>", "not an MJCF model"), ("<mujoco", "not a readable MJCF")):
        (tmp_path / "bad.xml").write_text(bad)
        with pytest.raises(UsageError, match=why):
            collision_copy(tmp_path / "bad.xml")


def _menagerie_style_hand(tmp_path) -> Path:
    """The project's MJCF as the Menagerie writes it (``rh_`` names, a forearm with two wrist
    joints), with a fingertip pad and a visual palm as meshes whose files are absent."""
    path = _prefixed_hand(tmp_path, wrist=True)
    text = path.read_text().replace(
        "<asset>", '<asset>\n    <mesh file="f_distal_pst.obj"/>\n    <mesh file="palm.obj"/>', 1
    )
    pad = '<geom type="capsule" size="0.008 0.012" pos="0 0 0.012" material="skin"/>'
    assert text.count(pad) == 4
    text = text.replace(pad, '<geom type="mesh" mesh="f_distal_pst"/>', 1)
    palm = '<body name="rh_palm" pos="0 0 0.02">'
    visual = '<geom type="mesh" mesh="palm" contype="0" conaffinity="0"/>'
    text = text.replace(palm, palm + visual, 1)
    path.write_text(text)
    return path


def test_hand_model_without_a_required_actuator_exits_2_naming_it(tmp_path, capsys):
    path = _prefixed_hand(tmp_path)
    path.write_text(path.read_text().replace('name="rh_A_MFJ0"', 'name="rh_A_MFJX"'))
    err = run_error(capsys, ["grasp", "--shape", "sphere", "--hand-model", str(path)])
    assert "has no actuator A_MFJ0" in err
    err = run_error(capsys, ["grasp", "--shape", "sphere", "--hand-model", str(tmp_path / "x")])
    assert "does not exist" in err


def test_evaluate_report_names_the_engines_of_mixed_test_data():
    from tactile_bullet.experiments.workflow import evaluate, train
    from tactile_bullet.sim.grasp import simulate_grasp

    records = [
        simulate_grasp(shape, None, Pose(), ControllerSettings(engine=engine, mode="contact"))
        for shape in ("sphere", "cylinder")
        for engine in ("bullet", "mujoco")
    ]
    model = train(records, "raw-joints", "knn")
    assert evaluate(model, records)["engines"] == ["bullet", "mujoco"]
    assert "engines" not in evaluate(model, records[::2])  # bullet only: as before engines


def test_generate_on_mujoco_and_no_resume_across_engines(tmp_path, capsys):
    """A dataset says which engine made it, and resuming it with another engine is refused
    (a resumed run never mixes simulators)."""
    import json

    from tactile_bullet.cli import main
    from tactile_bullet.datasets.dataset import read_records, verify

    out = tmp_path / "smoke"
    argv = ["generate", "--preset", "smoke", "--out", str(out), "--workers", "1", "--json"]
    assert main([*argv, "--engine", "mujoco"]) == 0
    assert json.loads(capsys.readouterr().out)["records"] == 4
    records = read_records(out).records
    assert {r.controller.engine for r in records} == {"mujoco"}
    assert verify(out)["engines"] == ["mujoco"]
    err = run_error(capsys, [*argv, "--resume"])  # bullet now: another dataset
    assert "holds a different dataset" in err


def test_the_tendon_spring_holds_the_distal_joint_back():
    """MuJoCo's tendon splits J0 = J1 + J2 by its physics, so the coupling rule that splits it
    in Bullet does nothing there; a return spring on J1 is what varies the split: with it the
    middle phalanx closes first (more J2, less J1 on every long finger), while J3, which
    closes before the tendon moves, stays within a few degrees (the spring's torque reaches
    it only through the stop rule's downstream efforts). A reused model forgets the spring."""
    from tactile_bullet.sim.grasp import simulate_grasp

    pose = Pose(offset=(-0.01, 0.0, 0.005))
    args = ("sphere", {"radius": 0.045}, pose)
    free = simulate_grasp(*args, ControllerSettings(engine="mujoco"))
    sprung = simulate_grasp(*args, ControllerSettings(engine="mujoco", tendon_spring=0.3))
    again = simulate_grasp(*args, ControllerSettings(engine="mujoco"))
    assert again.equals(free)
    assert sprung.controller.tendon_spring == 0.3
    j3f, j2f, j1f = np.degrees(free.fci_angles())
    j3s, j2s, j1s = np.degrees(sprung.fci_angles())
    assert np.all(j2s > j2f + 5.0) and np.all(j1s < j1f - 10.0)
    np.testing.assert_allclose(j3s, j3f, atol=4.0)


def test_a_soft_finger_servo_gives_back_j3_when_the_tendon_squeezes():
    """``servo_stiffness`` sets the long fingers' position servos: at our model's own 20 N m/rad
    the grasp is the model's; at 1 (the MuJoCo Menagerie hand's) J3 stops where it meets the
    object but yields afterwards, when the tendon presses the distal phalanges on, so it ends
    several degrees more open on every long finger. A reused model forgets it."""
    from tactile_bullet.sim.grasp import simulate_grasp

    args = ("sphere", {"radius": 0.045}, Pose(offset=(-0.01, 0.0, 0.005)))
    own = simulate_grasp(*args, ControllerSettings(engine="mujoco"))
    stiff = simulate_grasp(*args, ControllerSettings(engine="mujoco", servo_stiffness=20.0))
    soft = simulate_grasp(*args, ControllerSettings(engine="mujoco", servo_stiffness=1.0))
    again = simulate_grasp(*args, ControllerSettings(engine="mujoco"))
    np.testing.assert_array_equal(stiff.final_angles, own.final_angles)
    assert again.equals(own)
    assert np.all(np.degrees(own.fci_angles()[0] - soft.fci_angles()[0]) > 5.0)


def test_knobs_an_engine_does_not_read_are_refused_before_any_grasp(tmp_path, capsys):
    """A record must not claim a setting its engine ignored: MuJoCo's tendon reads no coupling
    rule (it was silently dropped), Bullet's motors have no servo stiffness and its J0 no
    tendon spring; the benchmark's coupling-shift has no rule to shift on MuJoCo."""
    from tactile_bullet.experiments.protocols import resolve
    from tactile_bullet.records import load_record

    err = run_error(capsys, ["grasp", "--shape", "sphere", "--engine", "mujoco",
                             "--coupling", "distal-first"])  # fmt: skip
    assert "coupling distal-first is a controller's rule for splitting J0" in err
    err = run_error(capsys, ["grasp", "--shape", "sphere", "--servo-stiffness", "1"])
    assert "servo_stiffness is a mujoco knob" in err
    out = tmp_path / "soft.npz"
    from tactile_bullet.cli import main

    assert main(["grasp", "--shape", "sphere", "--engine", "mujoco", "--servo-stiffness", "2",
                 "--tendon-spring", "0.3", "--out", str(out)]) == 0  # fmt: skip
    controller = load_record(out).controller
    assert (controller.servo_stiffness, controller.tendon_spring) == (2.0, 0.3)
    assert "coupling-shift" in resolve("all") and "coupling-shift" not in resolve("all", "mujoco")
    bench = tmp_path / "bench"
    err = run_error(capsys, ["benchmark", "--engine", "mujoco", "--protocol", "coupling-shift",
                             "--out", str(bench)])  # fmt: skip
    assert "coupling-shift changes a controller's rule" in err and not bench.exists()


def _gym_style_hand(folder: Path) -> Path:
    """The project's MJCF laid out as gymnasium-robotics' hand: Shadow's older numbering
    (FFJ3 .. FFJ0, J0 distal) behind ``robot0:``, the body tree in ``robot.xml``, defaults,
    tendons and actuators in ``shared.xml``, and each long finger's flexion driven by a servo
    on its middle joint (``A_FFJ1``) instead of a J0 tendon."""
    import re

    text = (REPO / "urdf" / "shadow_hand.xml").read_text()

    def old(m):  # FFJ4 -> robot0:FFJ3, LFJ5 -> robot0:LFJ4, THJ1 -> robot0:THJ0
        return f'{m.group(1)}="robot0:{m.group(2) or ""}{m.group(3)}J{int(m.group(4)) - 1}"'

    text = re.sub(r'(name|joint)="(A_)?(FF|MF|RF|LF|TH)J([1-5])"', old, text)
    text = re.sub(r'<body name="([a-z]+)"', r'<body name="robot0:\1"', text)
    for f in ("FF", "MF", "RF", "LF"):
        text = re.sub(rf'<fixed name="{f}J0">', f'<fixed name="robot0:T_{f}J1c">', text)
        text = re.sub(
            rf'<position name="A_{f}J0" tendon="{f}J0"([^>]*) ctrlrange="[^"]*"/>',
            rf'<position name="robot0:A_{f}J1" joint="robot0:{f}J1"\1 ctrlrange="0 1.571"/>',
            text,
        )
    section = {t: re.search(rf"  <{t}>.*?</{t}>", text, re.S).group(0)
               for t in ("default", "tendon", "actuator")}  # fmt: skip
    bodies = re.search(r"<worldbody>(.*)</worldbody>", text, re.S).group(1)
    folder.mkdir()
    (folder / "robot.xml").write_text(f"<mujoco>{bodies}</mujoco>")
    (folder / "shared.xml").write_text("<mujoco>" + "".join(section.values()) + "</mujoco>")
    return folder


def test_converting_a_gym_hand_renumbers_the_joints_and_gives_each_finger_a_j0_servo(tmp_path):
    """hand_conversion.from_gymnasium turns a hand in gymnasium-robotics' layout and older
    numbering into one --hand-model reads: joints one up, the middle-joint servo on a J1 + J2
    tendon with its own gain, so one J0 target closes both joints of every long finger in a
    grasp."""
    import mujoco

    from tactile_bullet.errors import UsageError
    from tactile_bullet.sim import hand_conversion as tool
    from tactile_bullet.sim.engines.mujoco_hand import load_hand_spec
    from tactile_bullet.sim.grasp import simulate_grasp

    assert tool.renumbered("robot0:FFJ0") == "robot0:FFJ1"
    assert tool.renumbered("robot0:LFJ4") == "robot0:LFJ5"
    assert tool.renumbered("robot0:palm") == "robot0:palm"
    tree, _ = tool.from_gymnasium(_gym_style_hand(tmp_path / "hand"))
    out = tmp_path / "hand.xml"
    tree.write(out, encoding="unicode")
    model = load_hand_spec(out).compile()
    act = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, "robot0:A_FFJ0")
    assert model.actuator_trntype[act] == mujoco.mjtTrn.mjTRN_TENDON
    assert model.actuator_gainprm[act, 0] == 20.0
    tendon = model.actuator_trnid[act, 0]
    adr, num = model.tendon_adr[tendon], model.tendon_num[tendon]
    joints = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, model.wrap_objid[w])
              for w in range(adr, adr + num)}  # fmt: skip
    assert joints == {"robot0:FFJ2", "robot0:FFJ1"}
    record = simulate_grasp("sphere", None, Pose(),
                            ControllerSettings(engine="mujoco", hand_model=str(out)))  # fmt: skip
    j2, j1 = np.degrees(record.fci_angles()[1:])  # one J0 target moves both joints
    assert np.all(j2 > 5.0) and np.all(j1 > 20.0) and "ff" in record.fingers_in_contact
    for bad in (tmp_path / "nothing", tmp_path):
        with pytest.raises(UsageError):
            tool.from_gymnasium(bad)


def test_convert_hand_writes_each_layout_as_its_conversion_and_lists_the_changes(tmp_path, capsys):
    """``tactile-bullet convert-hand`` writes what the conversion functions make (the
    Menagerie's copy as parsed, gymnasium-robotics' indented), picks the layout from the source
    (a file, a folder), and prints each change, or them all as JSON."""
    import json
    import xml.etree.ElementTree as ET

    from tactile_bullet.cli import main
    from tactile_bullet.sim.hand_conversion import collision_copy, from_gymnasium

    menagerie = _menagerie_style_hand(tmp_path)
    gym = _gym_style_hand(tmp_path / "gym")
    tree, changes = collision_copy(menagerie)
    expected = {"menagerie": (menagerie, tree, changes)}
    tree, changes = from_gymnasium(gym)
    ET.indent(tree)
    expected["gymnasium"] = (gym, tree, changes)
    for layout, (source, tree, changes) in expected.items():
        want = tmp_path / f"want-{layout}.xml"
        tree.write(want, encoding="unicode")
        out = tmp_path / f"{layout}.xml"
        assert main(["convert-hand", str(source), "--out", str(out)]) == 0
        printed = capsys.readouterr().out.splitlines()
        assert printed == [f"  {line}" for line in changes] + [f"wrote {out}"]
        assert out.read_bytes() == want.read_bytes()
        assert main(["convert-hand", str(source), "--out", str(out), "--force", "--json",
                     "--layout", layout]) == 0  # fmt: skip
        doc = json.loads(capsys.readouterr().out)
        assert doc["layout"] == layout and doc["changes"] == changes and doc["out"] == str(out)
        assert out.read_bytes() == want.read_bytes()


def test_convert_hand_refuses_bad_input_in_one_line_before_any_work(tmp_path, capsys):
    menagerie = _menagerie_style_hand(tmp_path)
    taken = tmp_path / "taken.xml"
    taken.write_text("keep me")
    (tmp_path / "robot.xml").write_text("<robot/>")
    (tmp_path / "ball.xml").write_text(  # MJCF, but no hand: refused, not written
        '<mujoco><worldbody><body name="ball"><geom size="0.1"/></body></worldbody></mujoco>')
    cases = [
        ([str(tmp_path / "missing.xml")], "does not exist"),
        ([str(tmp_path / "robot.xml")], "not an MJCF model"),
        ([str(tmp_path / "ball.xml")], "is not a Shadow hand --hand-model can drive: it has no "
                                       "joint FFJ4 (nor 21 more)"),
        ([str(menagerie), "--out", str(taken)], "already exists; add --force"),
        ([str(menagerie), "--out", str(tmp_path / "hand.txt")], "must end in .xml"),
        ([str(tmp_path)], "shared.xml does not exist"),
        ([str(tmp_path), "--layout", "menagerie"], "is a folder"),
        ([str(menagerie), "--layout", "gymnasium"], "is not a folder"),
    ]
    for argv, why in cases:
        if "--out" not in argv:
            argv = [*argv, "--out", str(tmp_path / "new.xml")]
        err = run_error(capsys, ["convert-hand", *argv])
        assert why in err and err.startswith("tactile-bullet convert-hand: error:"), err
    assert taken.read_text() == "keep me" and not (tmp_path / "new.xml").exists()
