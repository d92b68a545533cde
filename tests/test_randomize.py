"""Randomised hands (issue 21): the J1/J2 coupling rules, the [randomize] sweep table, the
hand-variation fields of a record, the coupling-invariant descriptors and train --training."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from cli_helpers import run_error
from synthetic import make_record, make_records

from tactile_bullet import Pose, simulate_grasp
from tactile_bullet.cli import main
from tactile_bullet.datasets.presets import preset
from tactile_bullet.datasets.randomize import (
    RANDOMIZED_TABLE,
    SERVO_STIFFNESS_CHOICES,
    TENDON_SPRING_RANGE,
    Randomization,
)
from tactile_bullet.datasets.sweeps import Sweep
from tactile_bullet.errors import UsageError
from tactile_bullet.experiments import protocols as P
from tactile_bullet.learn.coupled import coupled_record, j0_only
from tactile_bullet.plugins import get_descriptor
from tactile_bullet.records import (
    OFFSET_JOINTS,
    ControllerSettings,
    controller_dict,
    load_record,
    save_record,
)
from tactile_bullet.sim.coupling import Tendon, advance

UPPER = (math.pi / 2, math.pi / 2)


def run_tendon(rule, block_at, ticks=400, delta=0.01):
    """Drive one finger's tendon: joint k is blocked once its target passes block_at[k]."""
    t = Tendon()
    for _ in range(ticks):
        blocked = (t.t2 >= block_at[0], t.t1 >= block_at[1])
        t = advance(rule, t, blocked, (t.t2, t.t1), delta, UPPER)
        if t.done:
            return t
    raise AssertionError("tendon never finished")


def test_j2_first_moves_j2_until_blocked_then_j1():
    t = run_tendon("j2-first", (0.3, 0.5))
    assert t.t2 == pytest.approx(0.3, abs=0.011) and t.t1 == pytest.approx(0.5, abs=0.011)
    first = advance("j2-first", Tendon(), (False, False), (0, 0), 0.01, UPPER)
    assert (first.t2, first.t1) == (0.01, 0.0)


def test_distal_first_is_the_mirror():
    first = advance("distal-first", Tendon(), (False, False), (0, 0), 0.01, UPPER)
    assert (first.t2, first.t1) == (0.0, 0.01)
    t = run_tendon("distal-first", (0.3, 0.5))
    assert t.t1 == pytest.approx(0.5, abs=0.011) and t.t2 == pytest.approx(0.3, abs=0.011)


def test_equal_torque_shares_the_travel_and_ends_when_both_stop():
    first = advance("equal-torque", Tendon(), (False, False), (0, 0), 0.01, UPPER)
    assert first.t2 == first.t1 == pytest.approx(0.005)
    t = run_tendon("equal-torque", (0.2, 0.6))
    assert t.t2 == pytest.approx(0.2, abs=0.011) and t.t1 == pytest.approx(0.6, abs=0.011)
    # J2 blocked early: J1 then takes all of the travel (0.01 per tick, not 0.005)
    after = advance("equal-torque", t._replace(free1=True, done=False), (True, False),
                    (t.t2, 0.3), 0.01, UPPER)  # fmt: skip
    assert not after.done and after.t1 == pytest.approx(t.t1 + 0.01)


def test_tendon_stops_at_the_joint_limits():
    for rule in ("j2-first", "equal-torque", "distal-first"):
        t = run_tendon(rule, (9.0, 9.0))  # never blocked
        assert t.t2 == pytest.approx(UPPER[0]) and t.t1 == pytest.approx(UPPER[1])


def test_unknown_coupling_is_refused():
    with pytest.raises(UsageError, match="coupling must be one of"):
        ControllerSettings(coupling="j1-first")


# --- records --------------------------------------------------------------------------------


def test_default_settings_save_without_the_new_fields():
    saved = controller_dict(ControllerSettings())
    assert not {"coupling", "joint_offsets", "contact_stiffness"} & set(saved)


def test_hand_variation_round_trips_through_a_record(tmp_path):
    ctl = ControllerSettings(coupling="equal-torque", joint_offsets=[0.01] * 12,
                             contact_stiffness=3000.0)  # fmt: skip
    record = replace(make_record("sphere"), controller=ctl)
    back = load_record(save_record(record, tmp_path / "r.npz"))
    assert back.controller == ctl and back.controller.joint_offsets == (0.01,) * 12
    assert back.equals(record)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"joint_offsets": [0.01] * 3}, "needs 12 values"),
        ({"joint_offsets": [1.0] * 12}, "within"),
        ({"joint_offsets": "0.1"}, "list of numbers"),
        ({"contact_stiffness": -5.0}, "contact_stiffness"),
    ],
)
def test_bad_hand_variation_is_one_clear_error(kwargs, message):
    with pytest.raises(UsageError, match=message):
        ControllerSettings(**kwargs)


# --- physics --------------------------------------------------------------------------------

CYLINDER = ("cylinder", {"radius": 0.04})


@pytest.fixture(scope="module")
def rigid():
    return simulate_grasp(*CYLINDER, Pose())


def test_distal_first_curls_the_distal_joint_and_still_grasps(rigid):
    record = simulate_grasp(*CYLINDER, Pose(), ControllerSettings(coupling="distal-first"))
    angles = record.fci_angles()
    assert set(record.fingers_in_contact) >= {"ff", "mf", "rf", "lf"}
    assert np.all(angles[2] > angles[1] + math.radians(30))  # J1 far past J2 on every finger
    assert np.all(rigid.fci_angles()[1] > angles[1])  # J2 led today, so it closed further


def test_grasp_cli_takes_the_coupling(tmp_path, capsys):
    out = tmp_path / "g.npz"
    argv = ["grasp", "--shape", "sphere", "--coupling", "equal-torque", "--out", str(out)]
    assert main(argv) == 0
    assert load_record(out).controller.coupling == "equal-torque"
    assert main(["grasp", "--shape", "sphere", "--coupling", "sideways"]) == 2


def test_joint_offsets_shift_the_readings_not_the_grasp(rigid):
    offsets = np.linspace(-0.04, 0.04, 12)
    record = simulate_grasp(*CYLINDER, Pose(), ControllerSettings(joint_offsets=offsets))
    cols = [rigid.joint_index(n) for n in OFFSET_JOINTS]
    np.testing.assert_allclose(record.final_angles[cols] - rigid.final_angles[cols], offsets,
                               atol=1e-12)  # fmt: skip
    np.testing.assert_allclose(record.angles[:, cols] - rigid.angles[:, cols],
                               np.broadcast_to(offsets, (len(rigid.time), 12)), atol=1e-12)
    others = [i for i in range(len(rigid.joint_names)) if i not in cols]
    assert np.array_equal(record.final_angles[others], rigid.final_angles[others])


def test_soft_contacts_let_the_fingers_close_further(rigid):
    soft = simulate_grasp(*CYLINDER, Pose(), ControllerSettings(contact_stiffness=3000.0))
    assert set(soft.fingers_in_contact) >= {"ff", "mf", "rf", "lf"}
    assert soft.fci_angles().sum() > rigid.fci_angles().sum() + math.radians(5)


# --- the [randomize] table ------------------------------------------------------------------


def small_sweep(**randomize) -> Sweep:
    return Sweep.from_dict({
        "mode": "random", "samples": 6, "randomize": randomize or dict(RANDOMIZED_TABLE),
        "shapes": [{"name": "sphere"}, {"name": "cylinder"}],
    })  # fmt: skip


def test_randomize_draws_per_grasp_within_its_ranges_and_is_seeded():
    tasks = small_sweep().tasks(seed=3)
    ctls = [t.controller for t in tasks]
    assert len({c.friction for c in ctls}) == len(ctls)
    for c in ctls:
        assert 0.5 <= c.friction <= 1.2 and 0.28 <= c.thres_t <= 0.42
        assert 0.95 <= c.phalanx_scale <= 1.05 and c.control_every in (1, 2)
        speed = c.delta / (c.timestep * c.control_every)
        assert 1.0 - 1e-3 <= speed <= 1.9 + 1e-3
        assert max(abs(v) for v in c.joint_offsets) <= math.radians(3.0)
        assert c.contact_stiffness in (0.0, 3000.0, 10000.0, 30000.0)
    assert {c.coupling for c in ctls} >= {"j2-first", "distal-first"}
    again = small_sweep().tasks(seed=3)
    assert [t.controller for t in again] == ctls
    assert [t.controller for t in small_sweep().tasks(seed=4)] != ctls
    # a task's hand depends on its own seed only: the same grasp in a larger sweep draws alike
    assert tasks[0].controller == Sweep.from_dict(
        {**small_sweep().to_dict(), "samples": 9}).tasks(seed=3)[0].controller


def test_randomize_table_round_trips_and_keys_left_out_stay_put():
    sweep = small_sweep(coupling=["equal-torque"])
    assert Sweep.from_dict(sweep.to_dict()).randomize == sweep.randomize
    for task in sweep.tasks():
        assert task.controller == ControllerSettings(coupling="equal-torque")
    assert "randomize" not in preset("thesis").to_dict()
    assert preset("randomized").to_dict()["randomize"]["coupling"] == list(
        RANDOMIZED_TABLE["coupling"]
    )


def test_randomize_is_checked_against_the_sweeps_controller():
    table = {"control_rate": [10]}  # keeps the controller's closing speed at 10 ticks/s
    Sweep.from_dict({"randomize": table, "shapes": [{"name": "sphere"}]})  # 1.44 rad/s: 0.144
    with pytest.raises(UsageError, match="delta"):  # 12 rad/s: 1.2 rad per tick
        Sweep.from_dict({"randomize": table, "controller": {"delta": 0.05},
                         "shapes": [{"name": "sphere"}]})  # fmt: skip


def test_control_rate_keeps_the_closing_speed():
    (task,) = Sweep.from_dict({"mode": "random", "samples": 1, "randomize": {
        "control_rate": [80]}, "shapes": [{"name": "sphere"}]}).tasks()  # fmt: skip
    base = ControllerSettings()
    assert task.controller.control_every == 3
    assert task.controller.delta == pytest.approx(3 * base.delta)


@pytest.mark.parametrize(
    "table, message",
    [
        ({"gravity": [1]}, "unknown key 'gravity'"),
        ({"engine": ["bullet", "physx"]}, "unknown engine 'physx' \\(engines: bullet, mujoco"),
        ({"engine": []}, "engine must be a non-empty list"),
        ({"engine": ["mujoco", "mujoco"]}, "names an engine twice"),
        ({"engine": ["bullet", "mujoco"], "contact_stiffness": [0, 3000]},
         "contact_stiffness cannot be used with engine 'mujoco'"),
        ({"coupling": ["sideways"]}, "coupling must be"),
        ({"friction": {"min": 1.0, "max": 0.5}}, "min <= max"),
        ({"friction": {"min": 0.0, "max": 0.5}}, "friction must be a positive"),
        ({"phalanx_scale": [1.5]}, "phalanx_scale must be from 0.8"),
        ({"joint_offset_deg": 45}, "joint_offset_deg"),
        ({"control_rate": [0]}, "control_rate"),
        ({"control_rate": [240, 5], "closing_speed": {"min": 1, "max": 8}}, "delta"),
        ("fast", "must be a table"),
    ],
)
def test_bad_randomize_tables_are_refused_on_reading(table, message):
    with pytest.raises(UsageError, match=message):
        Sweep.from_dict({"randomize": table, "shapes": [{"name": "sphere"}]})


def test_engine_is_drawn_last_and_keeps_every_other_draw():
    """Adding the engine key changes nothing else a grasp draws (it is drawn last), picks
    among the named engines only, and round-trips through the sweep's saved form."""
    table = {k: v for k, v in RANDOMIZED_TABLE.items() if k != "contact_stiffness"}
    plain = small_sweep(**table)
    both = small_sweep(**table, engine=["bullet", "mujoco"])
    assert Sweep.from_dict(both.to_dict()).randomize == both.randomize
    drawn = [t.controller for t in both.tasks(seed=5)]
    assert {c.engine for c in drawn} == {"bullet", "mujoco"}
    for before, after in zip(plain.tasks(seed=5), drawn, strict=True):
        if after.engine == "mujoco":  # its tendon reads no coupling rule: the grasp keeps none
            assert after.coupling == "j2-first"
            after = replace(after, coupling=before.controller.coupling)
        assert replace(after, engine="bullet") == before.controller
    alone = {k: v for k, v in table.items() if k != "coupling"}
    assert {t.controller.engine for t in small_sweep(**alone, engine=["mujoco"]).tasks()} == {
        "mujoco"}
    with pytest.raises(UsageError, match="coupling cannot be drawn with engine 'mujoco'"):
        small_sweep(**table, engine=["mujoco"])


def test_engine_draw_is_recorded_per_record_and_verify_names_both(tmp_path, capsys):
    """Each grasp runs on its drawn engine and its record says which; verify reports the mix;
    ``generate --engine`` on such a sweep is a contradiction, refused before any grasp."""
    from tactile_bullet.datasets.dataset import read_records, verify

    config = tmp_path / "mixed.toml"
    config.write_text('mode = "random"\nsamples = 2\n[randomize]\nengine = ["bullet", '
                      '"mujoco"]\n[[shapes]]\nname = "sphere"\n')  # fmt: skip
    out = tmp_path / "mixed"
    argv = ["generate", "--config", str(config), "--out", str(out), "--workers", "1", "--json"]
    assert main([*argv, "--seed", "0"]) == 0
    capsys.readouterr()
    expected = [t.controller.engine for t in Sweep.from_toml(config).tasks(seed=0)]
    assert sorted(expected) == ["bullet", "mujoco"]
    records = read_records(out).records
    assert sorted(r.controller.engine for r in records) == ["bullet", "mujoco"]
    assert verify(out)["engines"] == ["bullet", "mujoco"]
    other = ["generate", "--config", str(config), "--out", str(tmp_path / "x"), "--engine",
             "mujoco"]  # fmt: skip
    err = run_error(capsys, other)
    assert "contradicts the sweep's [randomize] engine draw" in err
    assert not (tmp_path / "x").exists()


def test_mujoco_randomized_twin_draws_grasp_on_mujoco():
    """The cross-engine benchmark's randomised MuJoCo set: its draws (slowest control rate,
    low friction) still make a grasp there, all four fingers on a centred cylinder."""
    from tactile_bullet.datasets.randomize import draw_for_task, randomized_table

    base = ControllerSettings(engine="mujoco")
    table = Randomization.from_dict(randomized_table("mujoco"), base=base)
    # (a stiff servo: at 1-2 N m/rad a finger may spring off a cylinder this slippery)
    seed = next(s for s in range(200) if draw_for_task(table, base, s).control_every == 2
                and draw_for_task(table, base, s).friction < 0.7
                and draw_for_task(table, base, s).servo_stiffness >= 5)  # fmt: skip
    ctl = draw_for_task(table, base, seed)
    record = simulate_grasp(*CYLINDER, Pose(), ctl)
    assert record.controller == ctl and record.controller.engine == "mujoco"
    assert set(record.fingers_in_contact) >= {"ff", "mf", "rf", "lf"}


def test_benchmark_sets_randomized_twins_and_coupling_shift():
    sets = P.sets("tiny")
    twin, train = sets[P.randomized_name("tiny-demo-train")], sets["tiny-demo-train"]
    assert twin.sweep().shapes == train.sweep().shapes and twin.seed == train.seed
    assert twin.randomize == Randomization.from_dict(RANDOMIZED_TABLE)
    # MuJoCo has no contact-stiffness knob, and its tendon, not the coupling rule, splits J0:
    # its randomised twin draws the tendon's spring instead, and every other key the same
    mj = sets[P.randomized_name("tiny-mujoco-demo-train")].randomize
    assert mj.contact_stiffness is None and mj.coupling is None
    assert mj.tendon_spring == TENDON_SPRING_RANGE
    assert mj.servo_stiffness == SERVO_STIFFNESS_CHOICES
    same = replace(mj, contact_stiffness=twin.randomize.contact_stiffness,
                   coupling=twin.randomize.coupling, tendon_spring=None,
                   servo_stiffness=None)  # fmt: skip
    assert same == twin.randomize
    assert sets["tiny-coupling-distal-first"].controller.coupling == "distal-first"
    names = [s.name for s in P.needed_sets(["coupling-shift"], "tiny", ("clean",))]
    assert names == ["tiny-demo-train", "tiny-coupling-equal-torque",
                     "tiny-coupling-distal-first"]  # fmt: skip
    names = [s.name for s in P.needed_sets(["coupling-shift"], "tiny", ("randomized",))]
    assert P.randomized_name("tiny-demo-train") in names


# --- coupling-invariant descriptors ---------------------------------------------------------


def resplit(record, share_j2: float):
    """The same J0 on every finger, split with J2 taking ``share_j2`` of it."""
    final = record.final_angles.copy()
    for f in ("FF", "MF", "RF", "LF"):
        j2, j1 = record.joint_index(f"{f}J2"), record.joint_index(f"{f}J1")
        j0 = final[j2] + final[j1]
        final[j2], final[j1] = share_j2 * j0, (1 - share_j2) * j0
    ramp = np.linspace(0.0, 1.0, len(record.time))[:, None]
    return replace(record, final_angles=final, angles=ramp * final[None, :])


@pytest.mark.parametrize(
    "name", ["coupled-signature", "coupled-joints", "coupled-time-series", "coupled-finger-points"]
)
def test_coupled_descriptors_ignore_the_split_of_j0(name):
    records = make_records(per_shape=2, seed=1)
    desc = get_descriptor(name)
    base = desc.transform(records)
    for variant in ([resplit(r, 0.1) for r in records], [resplit(r, 0.9) for r in records],
                    [j0_only(r) for r in records]):  # fmt: skip
        np.testing.assert_allclose(desc.transform(variant), base, atol=1e-9)
    plain = get_descriptor({"coupled-joints": "raw-joints"}.get(name, name[len("coupled-"):]))
    assert not np.allclose(plain.transform([resplit(r, 0.9) for r in records]),
                           plain.transform(records), atol=1e-3)  # fmt: skip


def test_coupled_record_keeps_j3_and_j0():
    record = make_record("torus")
    even = coupled_record(record)
    for f in ("FF", "MF", "RF", "LF"):
        j0 = record.final(f"{f}J2") + record.final(f"{f}J1")
        assert even.final(f"{f}J2") == even.final(f"{f}J1") == pytest.approx(j0 / 2)
        assert even.final(f"{f}J3") == record.final(f"{f}J3")


# --- train --training -----------------------------------------------------------------------


def write(folder, records):
    folder.mkdir(parents=True, exist_ok=True)
    for i, rec in enumerate(records):
        save_record(rec, folder / f"rec{i:03d}.npz")
    return folder


def test_train_noise_aware_and_randomized(tmp_path, capsys):
    records = make_records(per_shape=3, seed=2)
    one_hand = write(tmp_path / "one", records)
    model = tmp_path / "m.npz"
    argv = ["train", "--data", str(one_hand), "--classifier", "knn", "--json"]
    assert main([*argv, "--training", "noise-aware", "--out", str(model)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["training"] == "noise-aware" and doc["train_records"] == len(records)
    err = run_error(capsys, [*argv, "--training", "randomized", "--out", str(tmp_path / "r.npz")])
    assert "drawn per grasp" in err and not (tmp_path / "r.npz").exists()
    hands = [replace(r, controller=ControllerSettings(friction=0.5 + 0.01 * i))
             for i, r in enumerate(records)]  # fmt: skip
    many = write(tmp_path / "many", hands)
    assert main(["train", "--data", str(many), "--classifier", "knn", "--json",
                 "--training", "randomized", "--out", str(tmp_path / "r.npz")]) == 0  # fmt: skip
    assert json.loads(capsys.readouterr().out)["training"] == "randomized"


# --- the tendon's spring: what the coupling rule is to an engine whose tendon splits J0 -----


def test_tendon_spring_is_refused_where_coupling_splits_j0(tmp_path, capsys):
    """Bullet splits J0 by ``coupling`` and its motors are constraints; a tendon spring or a
    servo stiffness it would silently ignore is refused when the settings, the sweep, its
    [randomize] table or ``generate --engine`` ask for one."""
    for name in ("tendon_spring", "servo_stiffness"):
        with pytest.raises(UsageError, match=f"{name} is a mujoco knob"):
            ControllerSettings(**{name: 0.3})
        with pytest.raises(UsageError, match=f"{name} must be from 0"):
            ControllerSettings(engine="mujoco", **{name: -0.1})
        with pytest.raises(UsageError, match=f"{name} cannot be used with engine 'bullet'"):
            Randomization.from_dict({name: [1.0]})
    shapes = [{"name": "sphere"}]
    with pytest.raises(UsageError, match="tendon_spring"):
        Sweep.from_dict({"controller": {"tendon_spring": 0.3}, "shapes": shapes})
    with pytest.raises(UsageError, match="tendon_spring cannot be used with engine 'bullet'"):
        Sweep.from_dict({"randomize": {"tendon_spring": [0.1, 0.3]}, "shapes": shapes})
    config = tmp_path / "sweep.toml"
    config.write_text('engine = "mujoco"\nsamples = 2\nmode = "random"\n'
                      '[[shapes]]\nname = "sphere"\n'
                      '[randomize]\ntendon_spring = { min = 0.0, max = 0.5 }\n')  # fmt: skip
    assert Sweep.from_toml(config).randomize.tendon_spring == {"min": 0.0, "max": 0.5}
    out = tmp_path / "data"
    err = run_error(capsys, ["generate", "--config", str(config), "--out", str(out),
                             "--engine", "bullet"])  # fmt: skip
    assert "tendon_spring cannot be used with engine 'bullet', which lacks a tendon" in err
    assert not out.exists()


def test_randomized_preset_fits_its_table_to_the_engine():
    """``generate --preset randomized --engine mujoco`` draws MuJoCo's knobs: before, it drew
    Bullet's contact stiffness, which the mujoco engine refuses, so three grasps in four
    failed."""
    bullet, mujoco = preset("randomized"), preset("randomized", "mujoco")
    assert bullet.randomize == Randomization.from_dict(RANDOMIZED_TABLE)
    assert mujoco.controller.engine == "mujoco"
    assert mujoco.randomize.contact_stiffness is None and mujoco.randomize.coupling is None
    assert mujoco.randomize.tendon_spring == TENDON_SPRING_RANGE
    assert mujoco.randomize.servo_stiffness == SERVO_STIFFNESS_CHOICES
    drawn = [mujoco.randomize.draw(mujoco.controller, np.random.default_rng(s)) for s in range(20)]
    springs = [c.tendon_spring for c in drawn]
    assert all(0.0 <= k <= 0.5 for k in springs) and len(set(springs)) == 20
    assert {c.servo_stiffness for c in drawn} <= set(SERVO_STIFFNESS_CHOICES)
    saved = controller_dict(drawn[0])
    assert saved["tendon_spring"] == drawn[0].tendon_spring
    assert saved["servo_stiffness"] == drawn[0].servo_stiffness
    plain = controller_dict(ControllerSettings(engine="mujoco"))
    assert "tendon_spring" not in plain and "servo_stiffness" not in plain
