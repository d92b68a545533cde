"""Contacts that fit no solid of revolution (perception/revolution.py): the axis residual is
near zero for contacts on any surface of revolution, turned or not, large for a box, absent
without contacts; models keep per-engine, per-family thresholds and refuse damaged ones; a
simulated box is answered unknown for that reason."""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from tactile_bullet.errors import UsageError
from tactile_bullet.learn import doubt
from tactile_bullet.perception.contact_check import FLOOR, ContactCheck, Verdict
from tactile_bullet.perception.revolution import MIN_LINKS, axis_residual, axis_residuals

FINGER_X = (-0.033, -0.011, 0.011, 0.033)
LINKS = ("proximal", "middle", "distal")


def _record(points, normals, engine="bullet", links=None):
    links = links or [f"l{i}" for i in range(len(points))]
    return SimpleNamespace(contact_link=np.array(links), contact_position=np.asarray(points, float),
                           contact_normal=np.asarray(normals, float),
                           controller=SimpleNamespace(engine=engine))  # fmt: skip


def _turn(beta):
    """Rotation about the palm normal (y): the object's axis turned in the x-z plane."""
    c, s = math.cos(beta), math.sin(beta)
    return np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])


def _revolution(profile, beta=0.0, centre=(0.0, -0.06, 0.12), rng=None):
    """Contacts on the solid r(u) about an axis along x turned by ``beta``: one per finger
    and phalanx, at azimuths around the axis where phalanges would wrap it."""
    rng = rng or np.random.default_rng(0)
    turn, points, normals = _turn(beta), [], []
    for x in FINGER_X:
        for k in range(len(LINKS)):
            u = x + rng.uniform(-0.004, 0.004)
            r, slope = profile(u)
            phi = math.radians(200 + 60 * k + rng.uniform(-10, 10))  # around the section
            radial = np.array([0.0, math.cos(phi), math.sin(phi)])
            normal = radial - slope * np.array([1.0, 0, 0])
            points.append(turn @ (np.array([u, 0, 0]) + r * radial) + centre)
            normals.append(turn @ (normal / np.linalg.norm(normal)))
    return _record(points, normals)


def _box(half=(0.06, 0.025, 0.035), centre=(0.0, -0.06, 0.12)):
    """Contacts on three faces of a box, the phalanges lying flat on them."""
    points, normals = [], []
    for x in FINGER_X:
        for face, (axis, sign) in enumerate(((1, 1.0), (2, -1.0), (1, -1.0))):
            p = np.array([x, 0.0, 0.0])
            p[axis] = sign * half[axis]
            other = 2 if axis == 1 else 1
            p[other] = (0.3 + 0.2 * face) * half[other] * (1 if x > 0 else -1)
            n = np.zeros(3)
            n[axis] = sign
            points.append(p + centre)
            normals.append(n)
    return _record(points, normals)


CYLINDER = lambda u: (0.035, 0.0)  # noqa: E731
CONE = lambda u: (0.03 - 0.15 * u, -0.15)  # noqa: E731
SPHERE = lambda u: (math.sqrt(0.045**2 - u**2), -u / math.sqrt(0.045**2 - u**2))  # noqa: E731
HYPERBOLOID = lambda u: (math.sqrt(0.03**2 + 0.5 * u**2),  # noqa: E731
                         0.5 * u / math.sqrt(0.03**2 + 0.5 * u**2))


@pytest.mark.parametrize("profile", [CYLINDER, CONE, SPHERE, HYPERBOLOID])
@pytest.mark.parametrize("beta_deg", [0.0, 20.0])
def test_contacts_on_a_solid_of_revolution_meet_one_axis(profile, beta_deg):
    assert axis_residual(_revolution(profile, math.radians(beta_deg))) < 1e-5


def test_a_box_misses_every_axis_by_millimetres():
    assert axis_residual(_box()) > 0.005


def test_no_residual_without_enough_touching_links():
    few = _revolution(CYLINDER)
    few.contact_link = np.array(["a", "b", "c", "d"] * 3)  # 4 links, their contacts averaged
    assert axis_residual(few) is None
    assert axis_residual(_record(np.zeros((0, 3)), np.zeros((0, 3)), links=[])) is None
    assert MIN_LINKS == 5


def test_a_batch_gives_each_grasp_its_own_residual():
    records = [_revolution(CYLINDER), _box(), _record(np.zeros((0, 3)), np.zeros((0, 3)),
                                                      links=[]), _revolution(SPHERE)]  # fmt: skip
    batch = axis_residuals(records)
    assert batch[2] is None
    for i in (0, 1, 3):
        assert batch[i] == pytest.approx(axis_residual(records[i]), abs=1e-9)


def _training(rng, n=40):
    records, labels = [], []
    for name, profile in (("cylinder", CYLINDER), ("sphere", SPHERE)):
        for _ in range(n):
            records.append(_revolution(profile, rng.uniform(0, 0.4), rng=rng))
            labels.append(name)
    return records, labels


def test_thresholds_are_per_engine_and_family_floored_and_fall_back_to_the_largest():
    rng = np.random.default_rng(3)
    records, labels = _training(rng)
    check = ContactCheck.fit(records, labels)
    assert set(check.thresholds) == {"bullet"}
    assert check.threshold("bullet", "cylinder") == FLOOR  # exact contacts fit to ~0
    assert check.threshold("mujoco", "sphere") == FLOOR  # no mujoco grasps: the largest
    assert check.threshold("bullet", "torus") is None  # a family it never saw: no opinion
    box = _box()
    assert check.unknown([box, records[0]], ["cylinder", "cylinder"]).tolist() == [True, False]
    assert check.unknown([box], ["torus"]).tolist() == [False]


def test_too_few_grasps_with_contacts_calibrate_nothing():
    rng = np.random.default_rng(4)
    records, labels = _training(rng, n=10)
    assert ContactCheck.fit(records, labels) is None


def test_copies_of_one_grasp_count_once():
    rng = np.random.default_rng(5)
    records, labels = _training(rng)
    groups = np.arange(len(records)) // 2  # every two records one grasp
    assert ContactCheck.fit(records, labels, groups).grasps == len(records) // 2


def test_contacts_read_through_a_sensor_model_get_no_verdict_and_calibrate_nothing():
    """A calibration bias moves contacts millimetres (learn/perturb.py): the thresholds, set
    on exact contacts, say nothing of them, as they say nothing of a recording's grasps."""
    rng = np.random.default_rng(6)
    records, labels = _training(rng)
    check = ContactCheck.fit(records, labels)
    box = _box()
    sensed = SimpleNamespace(**vars(box), flags=("perturbed",))
    assert check.unknown([box, sensed], ["cylinder", "cylinder"]).tolist() == [True, False]
    verdict = check.verdicts([sensed], ["cylinder"])[0]
    assert verdict == Verdict()  # no residual, no reason
    given = check.verdicts([box, sensed], ["cylinder"] * 2,
                           residuals=lambda recs: [0.01] * len(recs))
    assert [v.unknown_why for v in given] == ["axis", None]  # cached residuals too
    copies = [SimpleNamespace(**vars(r), flags=("perturbed",)) for r in records]
    assert ContactCheck.fit(copies, labels) is None  # nothing exact to set a threshold on
    assert ContactCheck.fit(records + copies, labels + labels).grasps == len(records)


def test_contacts_answer_unknown_with_their_reason_and_novelty_comes_first():
    classes = ["cylinder", "sphere"]
    off = Verdict(axis_residual=0.0062, unknown_why="axis")
    doc = doubt.answer_doubt(classes, "cylinder", None, None, None, 1.0, 2.0, off)
    assert doc["unknown"] and doc["unknown_why"] == doubt.NOT_REVOLUTION
    assert doc["axis_residual_mm"] == pytest.approx(6.2)
    far = doubt.answer_doubt(classes, "cylinder", None, None, None, 3.0, 2.0, off)
    assert far["unknown_why"] == doubt.UNLIKE_TRAINING
    bulge = Verdict(0.0004, 0.0023, unknown_why="profile")
    doc = doubt.answer_doubt(classes, "cylinder", None, None, None, 1.0, 2.0, bulge)
    assert doc["unknown_why"] == doubt.NOT_PROFILE and doc["profile_residual_mm"] == 2.3
    fine = doubt.answer_doubt(classes, "cylinder", None, None, None, 1.0, 2.0, Verdict(0.0004))
    assert not fine["unknown"] and fine["unknown_why"] is None and fine["ambiguous"] is None


def _saved_model(tmp_path, synthetic_split):
    from tactile_bullet.experiments import workflow
    from tactile_bullet.learn.models import save_model

    rng = np.random.default_rng(6)
    model = workflow.train(synthetic_split[0], "raw-joints", "knn", doubt=False)
    model.axis = ContactCheck.fit(*_training(rng))
    return model, save_model(tmp_path / "m.npz", model)


def test_a_saved_model_keeps_its_axis_check(tmp_path, synthetic_split):
    from tactile_bullet.learn.models import load_model

    model, path = _saved_model(tmp_path, synthetic_split)
    loaded = load_model(path)
    assert loaded.axis == model.axis


@pytest.mark.parametrize(
    "damage, message",
    [
        (lambda a: a.update({"thresholds": {"bullet": {"cylinder": -1.0}}}), "positive"),
        (lambda a: a.update({"thresholds": {"bullet": {"cylinder": "x"}}}), "positive"),
        (lambda a: a.update({"thresholds": {"bullet": 3}}), "not a table"),
        (lambda a: a.pop("thresholds"), "no thresholds"),
        (lambda a: a.update({"rate": 2.0}), "rate"),
    ],
)
def test_a_model_with_a_damaged_axis_check_is_refused(tmp_path, synthetic_split, damage,
                                                       message):  # fmt: skip
    from tactile_bullet.learn.models import load_model

    _, path = _saved_model(tmp_path, synthetic_split)
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    meta_key = next(k for k in arrays if "axis_check" in str(arrays[k]))
    meta = json.loads(str(arrays[meta_key]))
    damage(meta["axis_check"])
    arrays[meta_key] = np.array(json.dumps(meta))
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(UsageError, match=f"not a valid model: .*axis check.*{message}|{message}"):
        load_model(tmp_path / "bad.npz")


@pytest.mark.usefixtures("private_mesh_cache")
def test_a_simulated_box_is_no_solid_of_revolution_and_a_cylinder_is(tmp_path):
    """Physics: Bullet's contact normals on a box's faces miss every axis; on the built-in
    cylinder they meet one to within its facets."""
    import trimesh

    from tactile_bullet.objects.meshes import load_mesh
    from tactile_bullet.sim.grasp import simulate_grasp

    path = tmp_path / "box.stl"
    trimesh.creation.box(extents=(0.05, 0.07, 0.11)).export(path)
    box = simulate_grasp(load_mesh(path, axis="z"))
    cylinder = simulate_grasp("cylinder", {"radius": 0.035, "length": 0.12})
    assert axis_residual(box) > 0.004
    assert axis_residual(cylinder) < 0.002


@pytest.mark.usefixtures("private_mesh_cache")
def test_grasp_answers_a_box_unknown_because_its_contacts_fit_no_solid_of_revolution(
    tmp_path, capsys
):
    """The default identifier names a box (no family) as one of its families by its joint
    angles; its contacts make the answer unknown, the best guess kept, and the text says why."""
    import trimesh

    from tactile_bullet.cli import main

    path = tmp_path / "box.stl"
    trimesh.creation.box(extents=(0.05, 0.07, 0.11)).export(path)
    assert main(["grasp", "--mesh", str(path), "--axis", "z", "--json"]) == 0
    answer = json.loads(capsys.readouterr().out)["answer"]
    assert answer["unknown"] is True and answer["unknown_why"] == doubt.NOT_REVOLUTION
    assert answer["shape"] in answer["probabilities"] and answer["axis_residual_mm"] > 4
    assert main(["grasp", "--mesh", str(path), "--axis", "z"]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("identified:"))
    assert "UNKNOWN" in line and "no solid of revolution" in line


def test_evaluate_text_says_how_many_answers_the_contacts_made_unknown():
    from tactile_bullet.experiments.reports import summary_text

    report = {"accuracy": 0.5, "records": 4, "classes": ["cylinder", "sphere"],
              "confusion_matrix": [[1, 1], [1, 1]],
              "unknown": {"threshold": 1.0, "in_family": 0.25, "out_of_family": None,
                          "in_family_grasps": 4, "out_of_family_grasps": 0, "by_axis": 1,
                          "by_profile": 2}}
    line = next(x for x in summary_text(report).splitlines() if x.startswith("unknown"))
    assert "25% of 4 grasps" in line and "1 because the contacts fit no solid" in line
    assert "2 because they fit no profile" in line


def test_many_verdicts_split_over_workers_equal_those_computed_here():
    from tactile_bullet.perception import contact_check

    rng = np.random.default_rng(7)
    records, labels = _training(rng, n=40)
    check = ContactCheck.fit(records, labels)
    batch = [*records, *[_box() for _ in range(10)]]
    names = [*labels, *["cylinder"] * 10]
    assert len(batch) >= contact_check.MIN_PARALLEL
    here = check.verdicts(batch, names)
    split = check.verdicts_many(batch, names)
    assert [v.unknown_why for v in split] == [v.unknown_why for v in here]
    assert [v.unknown_why for v in split[-10:]] == ["axis"] * 10
    for a, b in zip(here, split, strict=True):
        assert b.axis_residual == pytest.approx(a.axis_residual, abs=1e-9)
