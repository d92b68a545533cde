"""Beyond one grasp (experiments/exploration.py, docs/exploration.md): fusing grasps, the
reachable set, the planner's choice, and the ``explore`` command."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from tactile_bullet.errors import UsageError
from tactile_bullet.experiments import exploration as E
from tactile_bullet.experiments import fusion as F
from tactile_bullet.records import ControllerSettings, Pose
from tests.cli_helpers import run_error


class _Model:
    classes = ["a", "b", "c"]


def _answer(p, unknown=False, ambiguous=None):
    return {"probabilities": dict(zip(_Model.classes, p, strict=True)), "unknown": unknown,
            "ambiguous": ambiguous}  # fmt: skip


def test_two_grasps_that_agree_are_surer_than_either():
    one = E.fused_answer(_Model(), [_answer([0.7, 0.3, 0.0])])
    two = E.fused_answer(_Model(), [_answer([0.7, 0.3, 0.0]), _answer([0.8, 0.2, 0.0])])
    assert one["shape"] == two["shape"] == "a"
    assert two["posterior"]["a"] > max(0.7, 0.8, one["posterior"]["a"])
    assert one["ambiguous"] == ["a", "b"] and two["ambiguous"] is None


def test_one_grasp_cannot_veto_a_shape_for_good():
    # a knn says 0 for "a" once; two later grasps that favour "a" still bring it back
    post = E.fuse([np.array([0.0, 1.0, 0.0]), np.array([0.9, 0.1, 0.0]),
                   np.array([0.9, 0.1, 0.0])])  # fmt: skip
    assert post.argmax() == 0 and np.isclose(post.sum(), 1.0)


def test_a_single_grasp_keeps_its_own_doubt_and_unknown_needs_half_the_grasps():
    sure_but_seconded = _answer([0.95, 0.05, 0.0], ambiguous=["a", "c"])
    assert E.fused_answer(_Model(), [sure_but_seconded])["ambiguous"] == ["a", "c"]
    answers = [_answer([0.9, 0.1, 0.0], unknown=True), _answer([0.9, 0.1, 0.0]),
               _answer([0.9, 0.1, 0.0])]  # fmt: skip
    assert E.fused_answer(_Model(), answers)["unknown"] is False
    assert E.fused_answer(_Model(), answers[:2])["unknown"] is True


def test_a_grasp_its_contacts_renamed_fuses_as_the_shape_they_named():
    """A torus read as a sphere (probabilities for "a"), renamed "b" by its contacts: the fused
    answer of that one grasp is its own answer, not the classifier's."""
    renamed = _answer([0.9, 0.08, 0.02]) | {"shape": "b", "renamed_from": "a"}
    fused = E.fused_answer(_Model(), [renamed])
    assert fused["shape"] == "b" and fused["posterior"]["b"] > 0.9
    assert E.fused_answer(_Model(), [_answer([0.9, 0.08, 0.02])])["shape"] == "a"


class _Check:
    """A contact check whose verdict on each family is given: ``bad`` families' thresholds
    the contacts miss."""

    def __init__(self, bad):
        self.bad, self.asked = set(bad), []

    def verdicts(self, records, names):
        from tactile_bullet.perception.contact_check import Verdict

        self.asked += list(names)
        return [Verdict(axis_residual=0.002, unknown_why="axis" if n in self.bad else None)
                for n in names]  # fmt: skip


def test_a_grasps_contacts_are_judged_against_the_fused_family(monkeypatch):
    """Two grasps: the first read as "b" and unknown by its contacts (they miss b's axis), the
    second read as "a". Fused, the object is "a"; judged against "a" the first grasp's contacts
    pass, so the fused answer is not unknown (UNKNOWN_AGAINST_FUSED). A grasp the novelty rule
    made unknown stays so; without the switch or the records, the grasps' own flags count."""
    from tactile_bullet.learn.doubt import NOT_REVOLUTION, UNLIKE_TRAINING

    model = _Model()
    model.axis = _Check(bad={"b"})
    first = _answer([0.3, 0.7, 0.0], unknown=True) | {"shape": "b",
                                                      "unknown_why": NOT_REVOLUTION}
    second = _answer([0.95, 0.05, 0.0]) | {"shape": "a"}
    records = [object(), object()]
    monkeypatch.setattr(F, "UNKNOWN_AGAINST_FUSED", False)
    old = E.fused_answer(model, [first, second], records=records)
    assert old["unknown"] is True and old["unknown_grasps"] == 1
    monkeypatch.setattr(F, "UNKNOWN_AGAINST_FUSED", True)
    fused = E.fused_answer(model, [first, second], records=records)
    assert fused["shape"] == "a" and fused["unknown"] is False and fused["unknown_grasps"] == 0
    assert model.axis.asked == ["a"]  # only the grasp that named another family is judged
    assert E.fused_answer(model, [first, second])["unknown"] is True  # no records: own flags
    novel = first | {"unknown_why": UNLIKE_TRAINING}
    assert E.fused_answer(model, [novel, second], records=records)["unknown"] is True
    # the other way: a grasp known as "a" whose contacts miss the fused family "b"
    model.axis = _Check(bad={"b"})
    sure_b = _answer([0.0, 1.0, 0.0]) | {"shape": "b"}
    assert E.unknown_against(model, [second | {"shape": "a"}, sure_b], records, "b") == [
        True, False]  # fmt: skip


def test_every_planned_pose_is_reachable_from_any_reachable_first_pose():
    for first in (Pose(), Pose((0.015, 0.0, -0.010), math.radians(-25.0)),
                  Pose((-0.005, 0.0, 0.01), math.radians(10.0))):  # fmt: skip
        moves = E.reachable_moves(first)
        assert moves and (0.0, 0.0, 0.0) in moves
        for move in moves:
            E.check_reachable(E.moved(first, move))
    with pytest.raises(UsageError, match="reachable set"):
        E.check_reachable(Pose((0.02, 0.0, 0.0)))
    with pytest.raises(UsageError, match="rotation"):
        E.check_reachable(Pose(rotation=math.radians(30.0)))


def test_a_pose_already_grasped_is_no_candidate_until_every_one_was():
    first = Pose((0.005, 0.0, 0.0), math.radians(10.0))
    moves = E.reachable_moves(first)
    second = E.moved(first, (0.0, 0.0, 20.0))
    assert E.move_of(first, second) == pytest.approx((0.0, 0.0, 20.0))
    left = E.unvisited(moves, first, [first, second])
    assert (0.0, 0.0, 0.0) not in left and (0.0, 0.0, 20.0) not in left
    assert set(left) == set(moves) - {(0.0, 0.0, 0.0), (0.0, 0.0, 20.0)}
    every = [E.moved(first, m) for m in moves]
    assert E.unvisited(moves, first, every) == moves  # nothing new left: all stay candidates


@pytest.mark.slow
def test_the_planner_moves_where_the_hypotheses_differ_and_caches_its_simulations():
    """A hyperboloid with a slight waist, grasped off centre, reads as a cylinder or a
    hyperboloid: the planner simulates both (as fitted) at every reachable move and picks a
    move that is expected to tell them apart; a second decision on the same object reuses
    every simulated grasp."""
    from tactile_bullet.sim.grasp import simulate_grasp

    ctl = ControllerSettings(engine="mujoco")
    first = Pose((0.008, 0.0, 0.0))
    record = simulate_grasp("hyperboloid", {"waist_radius": 0.035}, first, ctl)
    cache = E.SimulationCache()
    from tactile_bullet.learn.default import default_model

    decision = E.plan([E.Grasp(record, first)], default_model(), ctl, cache=cache)
    E.check_reachable(decision["pose"])
    names = [h for h, _ in decision["hypotheses"]]
    assert {"cylinder", "hyperboloid"} <= set(names)
    assert decision["gains"][decision["move"]] == max(decision["gains"].values())
    assert decision["gains"][decision["move"]] > 0
    assert decision["simulated"] == len(decision["gains"]) * len(names)
    again = E.plan([E.Grasp(record, first)], default_model(), ctl, cache=cache)
    assert again["simulated"] == 0 and again["pose"] == decision["pose"]


@pytest.mark.slow
def test_the_planner_can_leave_out_the_poses_already_grasped(monkeypatch):
    """With ``AVOID_VISITED`` (off by default: docs/exploration.md, judged and reverted), a
    third decision chooses neither the first pose nor the second, and weighs neither move."""
    from tactile_bullet.learn.default import default_model
    from tactile_bullet.sim.grasp import simulate_grasp

    monkeypatch.setattr(E, "AVOID_VISITED", True)
    ctl, first, size = ControllerSettings(engine="mujoco"), Pose((0.008, 0.0, 0.0)), {
        "waist_radius": 0.035}  # fmt: skip
    grasps = [E.Grasp(simulate_grasp("hyperboloid", size, first, ctl), first)]
    cache = E.SimulationCache()
    decision = E.plan(grasps, default_model(), ctl, cache=cache)
    assert (0.0, 0.0, 0.0) not in decision["gains"]
    second = decision["pose"]
    grasps.append(E.Grasp(simulate_grasp("hyperboloid", size, second, ctl), second))
    third = E.plan(grasps, default_model(), ctl, cache=cache)
    assert third["pose"] not in (first, second)
    assert not {(0.0, 0.0, 0.0), decision["move"]} & set(third["gains"])


@pytest.mark.slow
def test_the_second_grasp_can_be_a_turn_of_the_hand(monkeypatch):
    """With ``TURN_SECOND`` the second grasp's candidates are the reachable turns only (the
    sign by expected gain); the third decision weighs every move again."""
    from tactile_bullet.learn.default import default_model
    from tactile_bullet.sim.grasp import simulate_grasp

    monkeypatch.setattr(E, "TURN_SECOND", True)
    ctl, size = ControllerSettings(engine="mujoco"), {"waist_radius": 0.035}
    first = Pose((0.008, 0.0, 0.0), math.radians(10.0))  # +20 deg would leave the reach
    grasps = [E.Grasp(simulate_grasp("hyperboloid", size, first, ctl), first)]
    cache = E.SimulationCache()
    decision = E.plan(grasps, default_model(), ctl, cache=cache)
    assert set(decision["gains"]) == {(0.0, 0.0, -20.0)} and decision["move"] == (0.0, 0.0, -20.0)
    second = decision["pose"]
    grasps.append(E.Grasp(simulate_grasp("hyperboloid", size, second, ctl), second))
    third = E.plan(grasps, default_model(), ctl, cache=cache)
    assert set(third["gains"]) == set(E.reachable_moves(first))


def test_a_decisions_grasps_simulated_on_every_core_are_the_grasps_made_here():
    """prefetch runs a decision's new hypothesis grasps on forked workers (where it may): each
    record equals the one simulated in this process, a refused size is no outcome, and a
    grasp already cached is not simulated again."""
    from tactile_bullet.sim.grasp import simulate_grasp

    ctl = ControllerSettings(engine="mujoco")
    jobs = [("sphere", {"radius": r}, Pose((x, 0.0, 0.0)), ctl)
            for r in (0.04, 0.05) for x in (-0.005, 0.005)]  # fmt: skip
    cache = E.SimulationCache()
    cache.prefetch([*jobs, ("sphere", {"radius": 0.5}, Pose(), ctl)])
    assert cache.simulated == 5
    for job in jobs:
        got, want = cache.grasp(*job), simulate_grasp(*job)
        assert np.array_equal(got.angles, want.angles)
    assert cache.grasp("sphere", {"radius": 0.5}, Pose(), ctl) is None
    cache.prefetch(jobs)
    assert cache.simulated == 5


@pytest.mark.slow
def test_explore_json_has_the_answer_and_every_grasp(capsys, tmp_path):
    plot = tmp_path / "posterior.png"
    argv = ["explore", "--shape", "sphere", "--param", "radius=0.05", "--engine", "mujoco",
            "--max-grasps", "2", "--plot", str(plot), "--json"]  # fmt: skip
    from tactile_bullet.cli import main

    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["answer"]["shape"] == "sphere" and doc["answer"]["identifier"] == "default"
    assert 1 <= doc["answer"]["grasps"] == len(doc["grasps"]) <= 2
    assert 1 <= doc["answer"]["distinct_grasps"] <= doc["answer"]["grasps"]
    for g in doc["grasps"]:
        assert set(g) == {"pose", "answer", "posterior"}
        assert math.isclose(sum(g["posterior"].values()), 1.0)
    assert plot.stat().st_size > 0


@pytest.mark.parametrize(
    "args, message",
    [
        (["--max-grasps", "0"], "at least 1"),
        (["--max-grasps", "two"], "whole number"),
        (["--max-grasps", "8"], f"from 1 to {E.MAX_GRASPS} (the first pose and its reachable"),
        (["--max-grasps", "99999999999999999999"], "from 1 to 7"),
        (["--offset", "0.018,0,0"], "reachable set"),
        (["--rotation", "28"], "reachable set"),
        (["--strategy", "greedy"], "invalid choice"),
    ],
)
def test_explore_refuses_bad_input_before_any_grasp(capsys, args, message):
    assert message in run_error(capsys, ["explore", "--shape", "sphere", *args])


def test_next_pose_needs_a_grasp():
    with pytest.raises(UsageError, match="at least one grasp"):
        E.next_pose([])


def _csv_with_objects(records, path, object_of_row):
    """Export ``records`` as a hand's CSV, then add an ``object`` column (value per row from
    ``object_of_row(grasp_number, row_in_grasp)``)."""
    import csv

    from tactile_bullet.realhand.export import export

    export(records, path, "csv")
    rows = list(csv.reader(path.open()))
    head, body = rows[0], rows[1:]
    grasp_col = head.index("grasp")
    seen: dict[str, int] = {}
    out = [head + ["object"]]
    for row in body:
        k = int(row[grasp_col])
        seen[k] = seen.get(k, -1) + 1
        out.append(row + [object_of_row(k, seen[k])])
    with path.open("w", newline="") as fh:
        csv.writer(fh).writerows(out)
    return path


def test_identify_recording_fuses_the_grasps_marked_as_one_object(synthetic_split, tmp_path,
                                                                   capsys):
    from tactile_bullet.cli import main

    _, test = synthetic_split
    records = [r for r in test if r.shape == test[0].shape][:2] + \
        [r for r in test if r.shape != test[0].shape][:1]  # fmt: skip
    path = _csv_with_objects(records, tmp_path / "session.csv",
                             lambda k, _row: "mug" if k <= 2 else "other")  # fmt: skip
    assert main(["identify", "--recording", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [g["object"] for g in doc["grasps"]] == ["mug", "mug", "other"]
    objects = {o["object"]: o for o in doc["objects"]}
    assert objects["mug"]["grasps"] == [0, 1] and objects["other"]["grasps"] == [2]
    fused = objects["mug"]["posterior"]
    assert math.isclose(sum(fused.values()), 1.0)


def test_object_marks_that_disagree_with_the_grasps_are_refused(synthetic_split, tmp_path,
                                                                capsys):
    _, test = synthetic_split
    path = _csv_with_objects(test[:2], tmp_path / "session.csv",
                             lambda k, row: "a" if k == 2 or row < 3 else "b")  # fmt: skip
    err = run_error(capsys, ["identify", "--recording", str(path)])
    assert "spans rows of objects a, b" in err


def _bag_with_objects(records, path, monkeypatch, start_object, end_object):
    """Export ``records`` as a ROS 2 bag whose grasp markers name an object: grasp k's start
    marker names ``start_object(k)``, its end marker ``end_object(k)``."""
    pytest.importorskip("rosbags")
    from tactile_bullet.realhand import export as export_module

    def marker(k, rec, event):
        obj = start_object(k) if event == "start" else end_object(k)
        return json.dumps({"event": event, "shape": rec.shape, "object": obj})

    monkeypatch.setattr(export_module, "_marker", marker)
    export_module.export(records, path, "db3")
    return path


def test_identify_recording_fuses_the_grasps_a_bag_marks_as_one_object(
    synthetic_split, tmp_path, capsys, monkeypatch
):
    from tactile_bullet.cli import main

    _, test = synthetic_split
    records = [r for r in test if r.shape == test[0].shape][:2] + \
        [r for r in test if r.shape != test[0].shape][:1]  # fmt: skip
    name = lambda k: "mug" if k < 2 else "other"  # noqa: E731
    path = _bag_with_objects(records, tmp_path / "session", monkeypatch, name, name)
    assert main(["identify", "--recording", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [g["object"] for g in doc["grasps"]] == ["mug", "mug", "other"]
    objects = {o["object"]: o for o in doc["objects"]}
    assert objects["mug"]["grasps"] == [0, 1] and objects["other"]["grasps"] == [2]
    assert math.isclose(sum(objects["mug"]["posterior"].values()), 1.0)


def test_a_bag_grasp_whose_markers_name_two_objects_is_refused(
    synthetic_split, tmp_path, capsys, monkeypatch
):
    _, test = synthetic_split
    path = _bag_with_objects(test[:2], tmp_path / "session", monkeypatch,
                             lambda k: "a", lambda k: "a" if k == 0 else "b")  # fmt: skip
    err = run_error(capsys, ["identify", "--recording", str(path)])
    assert "starts on object 'a' and ends on 'b'" in err


@pytest.mark.parametrize(
    "args, message",
    [
        (["--protocol", "active,sim-shift"], "runs alone"),
        (["--protocol", "active", "--other-hand", "shadow=x.xml"], "NAME=FILE"),
    ],
)
def test_the_active_protocol_refuses_bad_input_before_any_grasp(tmp_path, capsys, args,
                                                                message):
    err = run_error(capsys, ["benchmark", *args, "--out", str(tmp_path / "a")])
    assert message in err and not (tmp_path / "a").exists()


def test_the_active_protocol_keeps_an_earlier_run(tmp_path, capsys):
    out = tmp_path / "a"
    out.mkdir()
    (out / "active.json").write_text("{}")
    err = run_error(capsys, ["benchmark", "--protocol", "active", "--scale", "tiny", "--out",
                             str(out)])  # fmt: skip
    assert "not empty" in err and (out / "active.json").read_text() == "{}"


def test_every_hard_object_of_the_active_protocol_is_a_valid_grasp(tmp_path):
    from tactile_bullet.experiments.active import columns

    assert "household" not in columns("tiny", {})
    cols = columns("quick", {"gymnasium": "hand.xml"}, objects=tmp_path)
    assert set(cols) == {"border", "unseen-poses", "household", "out-of-family", "gymnasium"}
    for name, (_controller, objects) in cols.items():
        assert objects, name
        for _shape, _params, pose, *_family in objects:
            E.check_reachable(pose)
    # the household meshes are scored against the family a person would call them
    household = cols["household"][1]
    assert {family for *_, family in household} == {"cylinder", "sphere", "hyperboloid", "cone"}
    assert all(0.0 <= math.degrees(pose.rotation) <= 25.0 for _, _, pose, _ in household)
    border = cols["border"][1]
    tori = [p for s, p, _ in border if s == "torus"]
    assert all(p["major_radius"] - p["minor_radius"] <= 0.006 for p in tori)  # hole nearly shut
    assert cols["gymnasium"][0].hand_model.endswith("hand.xml")
    # objects of no family: every one is right only where answered unknown
    oof = cols["out-of-family"][1]
    assert len(oof) == 3 * 10 and all(family is None for *_, family in oof)
    names = {s if isinstance(s, str) else s.name for s, *_ in oof}
    assert {"ovoid", "hexagonal_pyramid"} <= names and len(names) == 10
    assert not E.settled({"ambiguous": None, "unknown": True})
    from tactile_bullet.experiments.active import is_right

    assert is_right({"shape": "cylinder", "unknown": True}, None)
    assert not is_right({"shape": "cylinder", "unknown": False}, None)
    assert is_right({"shape": "cylinder", "unknown": True}, "cylinder")


@pytest.mark.slow
def test_explore_reads_and_plans_with_the_model_given(synthetic_split, capsys, tmp_path):
    """``--model``: every grasp is read by that model (its classes are the posterior's) and the
    answer names it; the default identifier is not used."""
    from tactile_bullet.cli import main
    from tactile_bullet.experiments.training import train
    from tactile_bullet.learn.models import save_model

    three = [r for r in synthetic_split[0] if r.shape in ("cone", "sphere", "cylinder")]
    path = save_model(tmp_path / "m.npz", train(three, "raw-joints", "knn", doubt=False))
    argv = ["explore", "--shape", "sphere", "--param", "radius=0.05", "--engine", "mujoco",
            "--max-grasps", "2", "--model", str(path), "--json"]  # fmt: skip
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["answer"]["identifier"] == "model"
    assert doc["answer"]["method"]["name"] == "raw-joints + knn"
    assert doc["answer"]["method"]["file"] == str(path)
    assert set(doc["answer"]["probabilities"]) == {"cone", "sphere", "cylinder"}
    for g in doc["grasps"]:
        assert set(g["posterior"]) == {"cone", "sphere", "cylinder"}


def test_explore_refuses_a_damaged_model_before_any_grasp(capsys, tmp_path, monkeypatch):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a model")
    import tactile_bullet.sim.grasp as G

    monkeypatch.setattr(G, "simulate_grasp", lambda *a, **k: pytest.fail("grasped"))
    message = run_error(capsys, ["explore", "--shape", "sphere", "--model", str(bad)])
    assert "bad.npz" in message


@pytest.mark.slow
def test_the_hypotheses_are_fitted_with_the_hands_own_coefficients(monkeypatch):
    """A first grasp of our MuJoCo hand: each hypothesis carries the sizes and pose the shape
    fit gives with that hand's coefficients (``OWN_HAND_HYPOTHESES``); with the switch off,
    with the shipped ones."""
    from tactile_bullet.learn.robust import angles_for_shape_fit
    from tactile_bullet.perception.shape_fit import fit_family
    from tactile_bullet.perception.shape_model import load_calibration
    from tactile_bullet.realhand.hand_calibration import own_hand_calibration
    from tactile_bullet.sim.grasp import simulate_grasp

    first = Pose((0.004, 0.0, 0.0))
    record = simulate_grasp("torus", {"major_radius": 0.05375, "minor_radius": 0.052875}, first,
                            ControllerSettings(engine="mujoco"))  # fmt: skip
    answer = {"posterior": {"torus": 0.6, "sphere": 0.4}}
    angles = angles_for_shape_fit(record)
    sizes = []
    for on, cal in ((True, own_hand_calibration("mujoco")), (False, load_calibration())):
        monkeypatch.setattr(E, "OWN_HAND_HYPOTHESES", on)
        hyps = E.hypotheses(None, [E.Grasp(record, first)], answer)
        assert [h.shape for h in hyps] == ["torus", "sphere"]
        for h in hyps:
            fit = fit_family(angles, h.shape, cal)
            assert h.params == dict(fit.params)
            assert h.pose.offset == pytest.approx((fit.offset[0], 0.0, fit.offset[1]))
        sizes.append([h.params for h in hyps])
    assert sizes[0] != sizes[1]  # the two hands' coefficients fit other objects


@pytest.mark.slow
def test_an_active_row_keeps_each_grasp_so_its_table_can_be_fused_again():
    """The row's ``made`` grasps fused again by the package's rule (each distinct grasp once)
    give back its ``right`` table (what benchmarks/active_fusion.py checks before scoring
    another rule)."""
    import sys
    from pathlib import Path

    from tactile_bullet.experiments.active import GRASPS, score_column
    from tactile_bullet.learn.default import default_model

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from active_fusion import RULES, score

    objects = [("cylinder", {"radius": 0.035}, Pose((0.0, 0.0, 0.0), 0.0)),
               ("sphere", {"radius": 0.05}, Pose((0.008, 0.0, 0.0), math.radians(10.0)))]
    row, _ = score_column(objects, ControllerSettings(engine="mujoco"), default_model(),
                          "random", seed=1)  # fmt: skip
    row = json.loads(json.dumps(row))  # as active.json keeps it
    assert [m["truth"] for m in row["made"]] == ["cylinder", "sphere"]
    for made in row["made"]:
        assert len(made["grasps"]) == GRASPS
        assert set(made["grasps"][0]["probabilities"]) == set(default_model().classes)
        assert made["grasps"][0]["pose"] != made["grasps"][1]["pose"]  # random moves it
    after, stop, right = score(row, RULES["distinct"])
    assert right == row["right"] and after == row["after"] and stop == row["with_stopping"]


def test_a_repeated_grasp_is_fused_once(monkeypatch):
    """In simulation a grasp made again at a pose already grasped is the same grasp: it must
    not make the answer surer (FUSE_REPEATS off); a grasp at the same pose that differs (a real
    hand's noise) is fused."""
    import dataclasses

    rec = _record_with_final(np.zeros(24))
    here, there = Pose((0.0, 0.0, 0.0), 0.0), Pose((0.005, 0.0, 0.0), 0.0)
    other = dataclasses.replace(rec, final_angles=np.full(24, 0.01))
    grasps = [E.Grasp(rec, here), E.Grasp(rec, there), E.Grasp(rec, here), E.Grasp(other, here)]
    assert E.distinct(grasps) == [0, 1, 3]
    monkeypatch.setattr(E, "FUSE_REPEATS", True)
    assert E.distinct(grasps) == [0, 1, 2, 3]


@pytest.mark.slow
def test_repeating_the_first_pose_leaves_the_posterior_as_one_grasp_left_it():
    doc = E.explore("cylinder", {"radius": 0.03}, Pose((0.0, 0.0, 0.0), 0.0),
                    ControllerSettings(engine="mujoco"), max_grasps=2, strategy="repeat",
                    until_settled=False)  # fmt: skip
    one, two = doc["fused"]
    assert two["posterior"] == one["posterior"]
    assert (two["grasps"], two["distinct_grasps"]) == (2, 1)


def _record_with_final(final):
    import dataclasses

    from synthetic import make_records

    rec = make_records(per_shape=1, seed=0)[0]
    return dataclasses.replace(rec, final_angles=np.asarray(final, dtype=float))


def test_pooled_active_runs_compare_planned_and_random_object_by_object():
    """benchmarks/active_pooled.py: counts summed over seeds, and the discordant pairs (one
    strategy right, the other wrong) that its sign test reads."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from active_pooled import pooled, sign_test

    def run(planned, random):
        return {"rows": [{"column": "border", "strategy": "planned", "right": planned},
                         {"column": "border", "strategy": "random", "right": random}]}  # fmt: skip

    t, f = True, False
    docs = [run([[f, t, t], [t, t, t]], [[f, f, t], [t, f, f]]), run([[f, t, f]], [[f, t, t]])]
    counts, pairs = pooled(docs)
    assert counts[("border", "planned")] == [3, 1, 3, 2]
    assert counts[("border", "random")] == [3, 1, 1, 2]
    after_two = [(p[1], r[1]) for p, r in pairs["border"]]
    assert after_two == [(t, f), (t, f), (t, t)]
    switch = {"seed": 9, "rows": {"border": {"without": {"right": [[f, t, t]]},
                                             "with": {"right": [[t, t, t]]},
                                             "random": {"right": [[f, f, t]]}}}}  # fmt: skip
    import json as _json
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "seed9.json"
        path.write_text(_json.dumps(switch))
        from active_pooled import read_run

        run9 = read_run(path)
    assert run9["config"]["seed"] == 9
    assert {(r["strategy"], str(r["right"])) for r in run9["rows"]} == {
        ("planned", str([[f, t, t]])), ("random", str([[f, f, t]]))}  # the switch's off arm
    assert sign_test(0, 0) == 1.0
    assert sign_test(2, 0) == pytest.approx(0.5)  # 2 of 2 one way: 2 * (1/4)
    assert sign_test(15, 5) == pytest.approx(0.0414, abs=1e-4)
    assert sign_test(5, 15) == sign_test(15, 5)


def test_a_move_where_every_hypothesis_reads_alike_gains_nothing_by_readings():
    """``reading_gain`` is the mutual information between the hypothesis and the reading:
    zero where the hypotheses would read as the same shape however surely (the fused-entropy
    gain counts that move as informative), the hypotheses' own entropy where each reads as
    itself, and a hypothesis with no simulated outcome reads as a uniform answer."""
    classes = ["cone", "cylinder", "hyperboloid"]
    sure = {"cylinder": [0.0, 1.0, 0.0], "hyperboloid": [0.0, 0.0, 1.0]}

    class Model:
        def __init__(self, readings):
            self.classes, self.readings = classes, readings

        def predict_with_proba(self, records):
            rows = np.array([self.readings[r] for r in records], float)
            return np.array([classes[i] for i in rows.argmax(axis=1)]), rows

    class Cache:
        def grasp(self, shape, sizes, pose, controller):
            return None if shape == "cone" else shape

    hyps = [E.Hypothesis("cylinder", {}, Pose(), 0.6), E.Hypothesis("hyperboloid", {}, Pose(), 0.4)]
    args = (np.full(3, 1 / 3), hyps, (0.0, 0.0, 0.0), Pose(), None, Cache())
    alike = Model({"cylinder": sure["cylinder"], "hyperboloid": sure["cylinder"]})
    apart = Model(sure)
    assert E.reading_gain(alike, *args) == pytest.approx(0.0, abs=1e-12)
    assert E.expected_gain(alike, *args) > 0.5  # the fused-entropy gain rewards a sure misreading
    w = np.array([0.6, 0.4])
    own = E.smoothed(np.eye(3)[[1, 2]])
    expected = E._entropy(w @ own) - sum(wi * E._entropy(r) for wi, r in zip(w, own, strict=True))
    assert E.reading_gain(apart, *args) == pytest.approx(expected)
    assert E.reading_gain(apart, *args) > 0.8  # nearly the hypotheses' entropy, 0.97 bits
    blind = [E.Hypothesis("cone", {}, Pose(), 0.5), E.Hypothesis("cylinder", {}, Pose(), 0.5)]
    gain = E.reading_gain(apart, np.full(3, 1 / 3), blind, (0.0, 0.0, 0.0), Pose(), None, Cache())
    assert 0 < gain < E.reading_gain(apart, *args)


@pytest.mark.slow
def test_scored_by_readings_the_planner_never_regrasps_the_first_pose(monkeypatch):
    """With ``GAIN_BY_READINGS`` (off by default; declared before seed 9) the first pose, whose
    reading is known, is not a candidate, and the move chosen carries the largest reading
    gain."""
    from tactile_bullet.learn.default import default_model
    from tactile_bullet.sim.grasp import simulate_grasp

    monkeypatch.setattr(E, "GAIN_BY_READINGS", True)
    ctl, first = ControllerSettings(engine="mujoco"), Pose((0.008, 0.0, 0.0))
    record = simulate_grasp("hyperboloid", {"waist_radius": 0.035}, first, ctl)
    decision = E.plan([E.Grasp(record, first)], default_model(), ctl)
    assert (0.0, 0.0, 0.0) not in decision["gains"]
    assert set(decision["gains"]) == set(E.reachable_moves(first)) - {(0.0, 0.0, 0.0)}
    assert decision["gains"][decision["move"]] == max(decision["gains"].values()) > 0


def test_a_planned_loop_stops_in_doubt_rather_than_grasp_a_pose_again():
    """Where the planner's next pose is one already grasped, the simulated grasp would be the
    first again, counted once, and every later decision the same: ``explore`` stops there and
    says why (it made 3 identical grasps before). The ``active`` protocol, which scores every
    count, still grasps to the end."""
    ctl, first = ControllerSettings(engine="mujoco"), Pose((0.002, 0.0, 0.0))
    size = {"waist_radius": 0.036, "end_radius": 0.042}
    doc = E.explore("hyperboloid", size, first, ctl, max_grasps=3)
    assert doc["answer"]["grasps"] == 1 and doc["stopped"] == E.REPEAT_STOP
    assert not E.settled(doc["answer"])  # stopped in doubt, not settled
    assert tuple(doc["decisions"][0]["move"]) == (0.0, 0.0, 0.0)
    scored = E.explore("hyperboloid", size, first, ctl, max_grasps=3, until_settled=False)
    assert scored["answer"]["grasps"] == 3 and scored["stopped"] is None
    assert scored["answer"]["posterior"] == doc["answer"]["posterior"]  # nothing lost


def test_explore_says_why_it_stopped_in_doubt(capsys):
    from tactile_bullet.cli import main

    argv = ["explore", "--shape", "hyperboloid", "--param", "waist_radius=0.036", "--param",
            "end_radius=0.042", "--offset", "0.002,0,0", "--engine", "mujoco"]  # fmt: skip
    assert main(argv) == 0
    assert "stopped after 1 grasp(s): the planner's next pose is one already grasped" in \
        capsys.readouterr().out  # fmt: skip
    assert main([*argv, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["stopped"] == E.REPEAT_STOP


def test_the_active_protocol_stops_where_explore_stops():
    """With the stopping rule, a planned object whose next pose repeats one already grasped
    counts the grasps ``explore`` makes (1 here, not 3), the same answer."""
    from tactile_bullet.experiments.active import score_column
    from tactile_bullet.learn.default import default_model

    first, turned = Pose((0.0, 0.0, 0.0), 0.0), Pose((0.0, 0.0, 0.0), math.radians(20.0))
    assert E.visited((0.0, 0.0, 0.0), first, [first])  # the first pose again
    assert E.visited((0.0, 0.0, 20.0), first, [first, turned])
    assert not E.visited((0.01, 0.0, 0.0), first, [first, turned])
    objects = [("hyperboloid", {"waist_radius": 0.036, "end_radius": 0.042},
                Pose((0.002, 0.0, 0.0), 0.0))]  # fmt: skip
    row, _ = score_column(objects, ControllerSettings(engine="mujoco"), default_model(),
                          "planned", seed=0)  # fmt: skip
    assert row["mean_grasps"] == 1.0 and len(row["made"][0]["grasps"]) == 3
    assert row["stop_right"] == [row["right"][0][0]]
    doc = E.explore(*objects[0], ControllerSettings(engine="mujoco"), max_grasps=3,
                    until_settled=False)  # fmt: skip
    assert [d["repeats"] for d in doc["decisions"]] == [True, True]  # what the row reads
