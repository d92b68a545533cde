"""A hand calibrated from grasps of known shape (issue 21 item 3): ``perception/hand_fit.py``,
the file ``tactile-bullet calibrate`` writes (``realhand/hand_calibration.py``), and
``--hand-calibration`` on the commands and the streaming ``Identifier``.

The "other hand" here is the shape fit's own forward model with other per-finger offsets (J3 and
J0 read 2-7 deg off, a different sign per finger, as a real hand's sensors and tendons give), so
the tests need no simulator and know the truth. (A shift shared by every finger is mostly taken
up by the fitted sizes, so labels alone cannot tell it apart from a smaller object.)
"""

from __future__ import annotations

import json
import re
from dataclasses import replace

import numpy as np
import pytest
from cli_helpers import run_error
from synthetic import make_record

from tactile_bullet.cli import main
from tactile_bullet.errors import UsageError
from tactile_bullet.perception.hand_fit import fit_hand
from tactile_bullet.perception.shape_fit import fit_family, predicted_angles
from tactile_bullet.perception.shape_model import load_calibration, use_calibration
from tactile_bullet.realhand.hand_calibration import load, load_sizes, render, write

SHIPPED = load_calibration()
OFFSETS_RAD = np.array([[0.06, -0.04, 0.05, -0.05], [-0.1, 0.1, -0.08, 0.12]])
OTHER = replace(SHIPPED, intercept=SHIPPED.intercept + OFFSETS_RAD)
"""The other hand: the same geometry, each finger's J3 and J0 read with its own offset."""

RADII = (0.038, 0.052, 0.044, 0.04, 0.048, 0.042)
OFFSETS = ((0.0, 0.0), (0.006, -0.004), (-0.005, 0.003))


def other_hand_grasps(which: slice, cal=OTHER):
    """(angles 3 x 4, shape, sizes) of grasps by the hand ``cal`` (the other one by default):
    J3, J0 as J2, J1 = 0; spheres and cylinders of radii ``RADII[which]``."""
    out = []
    for i, radius in list(enumerate(RADII))[which]:
        cylinder = {"radius": radius - 0.004, "length": 0.15}
        for shape, params in (("sphere", {"radius": radius}), ("cylinder", cylinder)):
            j3, j0 = predicted_angles(shape, params, OFFSETS[i % 3], cal)
            out.append((np.stack([j3, j0, np.zeros(4)]), shape, params))
    return out


def own_family_residual(grasps, cal) -> float:
    return float(np.mean([fit_family(a, s, cal).residual for a, s, _ in grasps]))


def test_a_refit_explains_the_other_hands_unseen_grasps_better_than_the_shipped_coefficients():
    known = other_hand_grasps(slice(0, 4))
    hand = fit_hand([a for a, _, _ in known], [s for _, s, _ in known], strengths=(1.0,), folds=2)
    unseen = other_hand_grasps(slice(4, 6))
    assert not hand.kept_start
    assert hand.grasps_per_shape == {"sphere": 4, "cylinder": 4}
    assert own_family_residual(unseen, hand.calibration) < 0.5 * own_family_residual(
        unseen, SHIPPED
    )
    # each finger's fitted offset has that hand's sign
    shift = hand.calibration.intercept - SHIPPED.intercept
    assert np.array_equal(np.sign(shift), np.sign(OFFSETS_RAD))


def test_known_sizes_fit_only_the_pose_and_still_recover_the_hand():
    known = other_hand_grasps(slice(0, 4))
    hand = fit_hand([a for a, _, _ in known], [s for _, s, _ in known],
                    sizes=[z for _, _, z in known], strengths=(1.0,), folds=2)  # fmt: skip
    assert hand.report["known_sizes"] == 8
    unseen = other_hand_grasps(slice(4, 6))
    assert own_family_residual(unseen, hand.calibration) < 0.5 * own_family_residual(
        unseen, SHIPPED
    )


FAMILY_RAD = {"sphere": np.array([[0.0] * 4, [0.15] * 4]),
              "cylinder": np.array([[0.0] * 4, [-0.1] * 4])}  # fmt: skip
SQUEEZING = replace(OTHER, family=FAMILY_RAD)
"""A hand that also closes J0 further on a sphere and less far on a cylinder than the finger
chain says (as MuJoCo's hand does on its families, benchmarks/calibration_residuals.py)."""


def test_known_sizes_learn_how_far_the_hand_squeezes_each_family():
    from tactile_bullet.perception.hand_fit import _alternate

    known = other_hand_grasps(slice(0, 4), SQUEEZING)
    angles, shapes, sizes = ([g[i] for g in known] for i in range(3))
    measured = np.array([np.stack([a[0], a[1] + a[2]]) for a in angles])
    # a weak pull toward the shipped coefficients, as cross-validation picks for MuJoCo's hand
    cal = _alternate(measured, shapes, sizes, SHIPPED, 0.25 * len(shapes), per_family=True)
    assert set(cal.family) == {"sphere", "cylinder"}
    # the sphere's J0 offset lies above the cylinder's on every finger, as the hand's (by
    # 0.25 rad; the ridge pull toward none shrinks it), and J3's stay near the hand's none
    gap = cal.family["sphere"] - cal.family["cylinder"]
    assert np.all(gap[1] > 0.12) and np.all(np.abs(gap[0]) < 0.03)
    unseen = other_hand_grasps(slice(4, 6), SQUEEZING)
    without = replace(cal, family={})
    assert own_family_residual(unseen, cal) < 0.5 * own_family_residual(unseen, without)
    # calibrate tries each pull with and without family terms where sizes are known, and
    # never fits them from labels alone (the fitted sizes would take the offsets up)
    hand = fit_hand(angles, shapes, sizes=sizes, strengths=(0.25,), folds=2)
    assert [c["family_terms"] for c in hand.report["candidates"]] == [False, False, True]
    blind = fit_hand(angles, shapes, strengths=(0.25,), folds=2)
    assert [c["family_terms"] for c in blind.report["candidates"]] == [False, False]
    assert blind.calibration.family == {}


def test_the_shipped_hand_itself_keeps_its_coefficients_in_effect():
    known = other_hand_grasps(slice(0, 4), SHIPPED)
    hand = fit_hand([a for a, _, _ in known], [s for _, s, _ in known], strengths=(1.0,), folds=2)
    for angles, shape, _ in other_hand_grasps(slice(4, 6), SHIPPED):
        fit = fit_family(angles, shape, hand.calibration)
        assert np.degrees(fit.residual) < 1.0


@pytest.mark.parametrize(
    ("angles", "shapes", "sizes", "message"),
    [
        ([], [], None, "at least one grasp"),
        ([np.zeros((3, 4))] * 2, ["sphere"], None, "2 grasps but 1 shape"),
        ([np.zeros((3, 4))] * 2, ["sphere", "sphere"], None, "at least two shapes"),
        ([np.zeros((3, 4))] * 2, ["sphere", "teapot"], None, "no model of it"),
        ([np.zeros((3, 4))] * 2, ["sphere", "cone"], [None], "2 grasps but 1 entries"),
        ([np.zeros((3, 4))] * 2, ["sphere", "cone"], [{"radius": 5.0}, None], "radius"),
    ],
)
def test_bad_calibration_inputs_are_refused_before_any_fit(angles, shapes, sizes, message):
    with pytest.raises(UsageError, match=message):
        fit_hand(angles, shapes, sizes)


def test_use_calibration_changes_the_fit_only_inside_its_block():
    angles = other_hand_grasps(slice(0, 1))[0][0]
    before = fit_family(angles, "sphere").residual
    with use_calibration(OTHER):
        inside = fit_family(angles, "sphere").residual
    assert inside < before
    assert fit_family(angles, "sphere").residual == before


def test_the_doubt_cross_check_reads_a_hand_with_that_hands_calibration():
    """The second opinion of ``learn/doubt.py`` (what ``evaluate``, ``identify`` and the
    ``Identifier`` flag answers with) is the shape fit under the hand calibration in force: a
    hand whose J3 reads a few degrees more on the index than on the little finger makes a
    cylinder look tapered to the shipped coefficients, not to its own."""
    from types import SimpleNamespace

    from tactile_bullet.learn.doubt import cross_check_names

    d = 0.05
    taper = replace(SHIPPED, intercept=SHIPPED.intercept + np.array([[d, d / 3, -d / 3, -d],
                                                                     [-d, 0, 0, d]]))  # fmt: skip
    j3, j0 = predicted_angles("cylinder", {"radius": 0.035, "length": 0.15}, (0.0, 0.0), taper)
    grasp = SimpleNamespace(fci_angles=lambda: np.stack([j3, j0, np.zeros(4)]))
    assert list(cross_check_names([grasp], ["cone", "cylinder"])) == ["cone"]
    with use_calibration(taper):
        assert list(cross_check_names([grasp], ["cone", "cylinder"])) == ["cylinder"]


def test_a_zeroed_calibration_makes_the_cross_check_read_zeroed_grasps(tmp_path):
    """``calibrate --zeroed`` fits coefficients to angles zeroed on the open hand; a learned
    model's doubt cross-check reads whole records, so under such a file it must zero them too,
    or a sensor offset (here J3 tapered by 0.2 rad from index to little finger) is read as a
    cone by a hand that grasped a cylinder."""
    from synthetic import make_record

    from tactile_bullet.hand import JOINT_NAMES
    from tactile_bullet.learn.doubt import cross_check_names

    rec = make_record("cylinder", {"radius": 0.035, "length": 0.15}, noise=0.0, samples=16)
    bias = np.zeros(len(JOINT_NAMES))
    for finger, k in (("FF", 1.0), ("MF", 1 / 3), ("RF", -1 / 3), ("LF", -1.0)):
        bias[JOINT_NAMES.index(f"{finger}J3")] = 0.2 * k
    biased = replace(rec, angles=rec.angles + bias, final_angles=rec.final_angles + bias)
    families = ["cone", "cylinder", "sphere", "torus", "hyperboloid"]
    text = render(SHIPPED, "rh", "known", {"sphere": 2, "cylinder": 2}, {"angles": "raw"})
    raw = load(write(tmp_path / "raw.toml", text)).calibration
    zeroed = load(write(tmp_path / "zeroed.toml", text.replace('"raw"', '"zeroed"'))).calibration
    assert (raw.angles, zeroed.angles) == ("raw", "zeroed")
    with use_calibration(raw):
        assert list(cross_check_names([biased], families)) == ["cone"]
    with use_calibration(zeroed):
        assert list(cross_check_names([biased], families)) == ["cylinder"]
    bad = write(tmp_path / "bad.toml", text.replace('"raw"', '"degrees"'))
    with pytest.raises(UsageError, match="report.angles must be raw or zeroed"):
        load(bad)


# --- the file ---------------------------------------------------------------------------------


def _file(tmp_path, cal=OTHER):
    report = {"strength": 2.0, "candidates": [{"strength": None, "held_out_right": 3}]}
    text = render(cal, "rh", "known", {"sphere": 2, "cylinder": 2}, report)
    return write(tmp_path / "hand.toml", text)


def test_the_file_round_trips_its_coefficients(tmp_path):
    hand = load(_file(tmp_path))
    np.testing.assert_allclose(hand.calibration.intercept, OTHER.intercept)
    np.testing.assert_allclose(hand.calibration.gain, OTHER.gain)
    assert hand.hand == "rh" and hand.grasps_per_shape == {"sphere": 2, "cylinder": 2}
    assert hand.report["candidates"][0]["strength"] == "shipped"
    assert hand.calibration.family == {}
    (tmp_path / "family").mkdir()
    squeezing = load(_file(tmp_path / "family", SQUEEZING)).calibration
    assert set(squeezing.family) == {"sphere", "cylinder"}
    np.testing.assert_allclose(squeezing.family["sphere"], FAMILY_RAD["sphere"])


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.replace("version = 1", "version = 7"), "version must be 1"),
        (lambda t: t.replace("[grasps_per_shape]", "[counts]"), "unknown key 'counts'"),
        (lambda t: re.sub(r"(?m)^gain = .*$", "gain = [[1.0, 1.0]]", t), "gain must be 2 x 4"),
        (lambda t: re.sub(r"(?m)^sigma = .*$", "sigma = [[0.0, 0, 0, 0], [1, 1, 1, 1]]", t),
         "sigma must be positive"),
        (lambda t: t.replace("sphere = 2", "sphere = 0"), "positive integer"),
        (lambda t: t.replace("sphere = 2", "teapot = 2"), "no fitted shape"),
        (lambda t: t[: len(t) // 3], "not valid TOML"),
    ],
)
def test_a_damaged_file_is_refused_on_one_line(tmp_path, edit, message):
    path = _file(tmp_path)
    path.write_text(edit(path.read_text()))
    with pytest.raises(UsageError, match=message):
        load(path)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.replace("\nsphere = [[", "\nteapot = [["), "no fitted shape"),
        (lambda t: t.replace("\nsphere = [[0.0", "\nsphere = [[1.0"), "within \\+-45 deg"),
        (lambda t: t.replace("\nsphere = [[0.0", "\nsphere = [[[0.0]"), "family sphere must"),
    ],
)
def test_a_damaged_family_offset_is_refused_on_one_line(tmp_path, edit, message):
    path = _file(tmp_path, SQUEEZING)
    assert "[coefficients.family]" in path.read_text()
    path.write_text(edit(path.read_text()))
    with pytest.raises(UsageError, match=message):
        load(path)


def test_a_gain_far_from_any_hand_is_refused(tmp_path):
    path = _file(tmp_path, replace(OTHER, gain=OTHER.gain * 0.05))
    with pytest.raises(UsageError, match="within 0.2-5"):
        load(path)


def test_known_sizes_are_checked_as_a_grasps_would_be(tmp_path):
    path = tmp_path / "sizes.toml"
    path.write_text("[cylinder]\nradius = 0.04\nlength = 0.15\n")
    assert load_sizes(path) == {"cylinder": {"radius": 0.04, "length": 0.15}}
    path.write_text("[cylinder]\nradius = 4.0\n")
    with pytest.raises(UsageError, match="radius"):
        load_sizes(path)
    path.write_text("[teapot]\nradius = 0.04\n")
    with pytest.raises(UsageError, match="no model of shape 'teapot'"):
        load_sizes(path)


# --- the command line -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def known(tmp_path_factory):
    """A record folder of 2 spheres and 2 cylinders from the wrapping theory."""
    from tactile_bullet.records import save_record

    root = tmp_path_factory.mktemp("known")
    rng = np.random.default_rng(3)
    for i, (shape, params) in enumerate(
        [("sphere", {"radius": 0.04}), ("sphere", {"radius": 0.05}),
         ("cylinder", {"radius": 0.035, "length": 0.15}),
         ("cylinder", {"radius": 0.045, "length": 0.15})]
    ):  # fmt: skip
        save_record(make_record(shape, params, rng, noise=0.01), root / f"{i}-{shape}.npz")
    return root


def test_calibrate_writes_a_file_identify_can_use(known, tmp_path, capsys):
    from test_json_docs import check

    out = tmp_path / "hand.toml"
    assert main(["calibrate", "--data", str(known), "--out", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    check("calibrate", doc)
    assert doc["grasps_per_shape"] == {"sphere": 2, "cylinder": 2}
    assert load(out).grasps_per_shape == {"sphere": 2, "cylinder": 2}
    model = tmp_path / "m.npz"
    assert main(["train", "--data", str(known), "--descriptor", "raw-joints",
                 "--classifier", "shape-fit", "--out", str(model)]) == 0  # fmt: skip
    capsys.readouterr()
    assert main(["identify", "--model", str(model), "--record", str(next(known.glob("0-*"))),
                 "--hand-calibration", str(out)]) == 0  # fmt: skip
    assert "sphere" in capsys.readouterr().out
    # the JSON says which hand calibration answered, so a result can be traced to it
    assert main(["identify", "--model", str(model), "--record", str(next(known.glob("0-*"))),
                 "--hand-calibration", str(out), "--json"]) == 0  # fmt: skip
    used = json.loads(capsys.readouterr().out)["hand_calibration"]
    assert used["file"] == str(out) and used["grasps_per_shape"] == {"sphere": 2, "cylinder": 2}
    assert main(["evaluate", "--model", str(model), "--data", str(known),
                 "--hand-calibration", str(out), "--json"]) == 0  # fmt: skip
    assert json.loads(capsys.readouterr().out)["hand_calibration"]["file"] == str(out)


def test_calibrate_never_overwrites_unasked_and_checks_sizes_first(known, tmp_path, capsys):
    out = tmp_path / "hand.toml"
    out.write_text("keep me")
    assert "already exists" in run_error(capsys, ["calibrate", "--data", str(known), "--out",
                                                  str(out)])  # fmt: skip
    assert out.read_text() == "keep me"
    sizes = tmp_path / "sizes.toml"
    sizes.write_text("[cone]\nradius = 0.04\n")
    err = run_error(capsys, ["calibrate", "--data", str(known), "--out", str(tmp_path / "n.toml"),
                             "--sizes", str(sizes)])  # fmt: skip
    assert "no grasp of" in err and not (tmp_path / "n.toml").exists()


@pytest.mark.parametrize("command", ["identify", "evaluate", "compare", "benchmark"])
def test_a_bad_hand_calibration_is_refused_before_any_work(tmp_path, capsys, command):
    bad = tmp_path / "hand.toml"
    bad.write_text("version = 2\n")
    argv = {
        "identify": ["identify", "--model", "m.npz", "--shape", "sphere"],
        "evaluate": ["evaluate", "--model", "m.npz", "--data", "d"],
        "compare": ["compare", "--data", "d"],
        "benchmark": ["benchmark", "--quick", "--out", str(tmp_path / "b")],
    }[command]
    assert "version must be 1" in run_error(capsys, [*argv, "--hand-calibration", str(bad)])


def test_the_identifier_loads_a_hand_calibration(tmp_path, known, capsys):
    from tactile_bullet.realhand.streaming import Identifier

    model = tmp_path / "m.npz"
    assert main(["train", "--data", str(known), "--descriptor", "raw-joints",
                 "--classifier", "shape-fit", "--out", str(model)]) == 0  # fmt: skip
    ident = Identifier.load(model, hand_calibration=_file(tmp_path))
    np.testing.assert_allclose(ident.hand_calibration.intercept, OTHER.intercept)
    bad = tmp_path / "bad.toml"
    bad.write_text("version = 1\n")
    with pytest.raises(UsageError, match="hand calibration"):
        Identifier.load(model, hand_calibration=bad)


@pytest.mark.slow
def test_the_cross_check_reads_our_mujoco_hand_with_its_own_coefficients(monkeypatch):
    """A grasp of our MuJoCo hand is read by the doubt's cross-check with the coefficients
    fitted on that hand (``data/shape_fit_mujoco.toml``): a fat torus the shipped (Bullet)
    coefficients read as a sphere is a torus to its own. A grasp made with another hand model,
    or under a hand calibration the user put in force, is read as before."""
    from tactile_bullet.learn import doubt
    from tactile_bullet.perception.shape_model import calibration_in_force
    from tactile_bullet.realhand.hand_calibration import own_hand_calibration, record_calibration
    from tactile_bullet.records import ControllerSettings, Pose
    from tactile_bullet.sim.grasp import simulate_grasp

    families = ["cone", "torus", "sphere", "hyperboloid", "cylinder"]
    torus = {"major_radius": 0.05375, "minor_radius": 0.052875}
    ctl = ControllerSettings(engine="mujoco")
    grasp = simulate_grasp("torus", torus, Pose(), ctl)
    own = own_hand_calibration("mujoco")
    assert record_calibration(grasp) is own and not np.allclose(own.intercept, SHIPPED.intercept)
    assert list(doubt.cross_check_names([grasp], families)) == ["torus"]
    other_hand = replace(grasp, controller=replace(ctl, hand_model="their_hand.xml"))
    assert record_calibration(other_hand) is None
    assert list(doubt.cross_check_names([other_hand], families)) == ["sphere"]
    with use_calibration(SHIPPED):
        assert calibration_in_force() is SHIPPED and record_calibration(grasp) is None
        assert list(doubt.cross_check_names([grasp], families)) == ["sphere"]
    monkeypatch.setattr(doubt, "OWN_HAND_COEFFICIENTS", False)
    assert list(doubt.cross_check_names([grasp, other_hand], families)) == ["sphere", "sphere"]


@pytest.mark.slow
def test_grasps_shape_fit_detail_reads_our_mujoco_hand_as_the_cross_check_does(capsys):
    """``grasp --engine mujoco``: the shape fit's detail block and the answer's cross-check read
    the grasp with the same (the MuJoCo hand's own) coefficients, so they name the same family;
    under the shipped coefficients the detail would say sphere."""
    from tactile_bullet.perception.shape_fit import shape_fit_summary
    from tactile_bullet.records import ControllerSettings, Pose
    from tactile_bullet.sim.grasp import simulate_grasp

    argv = ["grasp", "--shape", "torus", "--param", "major_radius=0.05375",
            "--param", "minor_radius=0.052875", "--engine", "mujoco", "--json"]  # fmt: skip
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["shape_fit"]["shape"] == doc["answer"]["cross_check"] == "torus"
    assert doc["answer"]["others"]["shape-fit"] == "torus"
    grasp = simulate_grasp("torus", {"major_radius": 0.05375, "minor_radius": 0.052875}, Pose(),
                           ControllerSettings(engine="mujoco"))  # fmt: skip
    with use_calibration(SHIPPED):
        assert shape_fit_summary(grasp)["shape"] == "sphere"


def test_the_shipped_mujoco_coefficients_are_a_valid_hand_calibration():
    from tactile_bullet.realhand.hand_calibration import OWN_HAND_FILES, own_hand_calibration

    assert set(OWN_HAND_FILES) == {"mujoco"} and own_hand_calibration("bullet") is None
    cal = own_hand_calibration("mujoco")
    assert cal.angles == "raw" and np.all(cal.sigma > 0)


def test_a_damaged_own_hand_file_is_refused_not_used(monkeypatch):
    from tactile_bullet.realhand import hand_calibration as own

    monkeypatch.setitem(own.OWN_HAND_FILES, "mujoco", "data/default_model.json")
    own.own_hand_calibration.cache_clear()
    try:
        with pytest.raises(UsageError, match="damaged"):
            own.own_hand_calibration("mujoco")
    finally:
        monkeypatch.undo()
        own.own_hand_calibration.cache_clear()
