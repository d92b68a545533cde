"""The robustness matrix (experiments/robustness.py, docs/robustness.md): the declared rule
picks the default, columns a method was chosen on do not count, a method that cannot read a
column is n/a (never zero), and the CLI refuses what it would not read."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_bullet.experiments import robustness as R
from tests.cli_helpers import run_error


def _row(method, training, accs, plugin=False, seen=(), n=10):
    cols = {c: ({"accuracy": a, "n": n} if a is not None else {"accuracy": None, "n": 0,
                                                                 "reason": "no contacts"})
            for c, a in accs.items()}  # fmt: skip
    row = {"method": method, "training": training, "plugin": plugin, "columns": cols,
           "seen": sorted(seen)}  # fmt: skip
    R._summarise(row)
    return row


def test_the_winner_has_the_highest_worst_column_not_the_highest_mean():
    steady = _row("steady", "t", {"a": 0.85, "b": 0.86, "c": 0.84})
    brilliant = _row("brilliant", "t", {"a": 1.0, "b": 1.0, "c": 0.6})
    assert brilliant["mean"] > steady["mean"]
    assert R.winner([brilliant, steady]) is steady


def test_a_column_the_method_was_chosen_on_does_not_count_toward_its_score():
    tuned = _row("tuned", "t", {"a": 0.9, "b": 0.9, "menagerie": 0.5}, seen=("menagerie",))
    assert tuned["score"] == pytest.approx(0.9)
    other = _row("other", "t", {"a": 0.8, "b": 0.8, "menagerie": 0.8})
    assert R.winner([tuned, other]) is tuned
    assert R.seen_columns(R.Candidate("finger-points", "svm"), "bullet") == {"menagerie",
                                                                            "gymnasium"}
    assert "gymnasium" in R.seen_columns(R.Candidate("signature", "svm"), "mujoco-randomized")
    assert {"poses", "turned", "household"} <= R.seen_columns(
        R.Candidate("signature", "svm"), "posed-randomized")


def test_a_method_that_cannot_read_a_column_is_shown_n_a_and_is_not_eligible():
    contacts = _row("contacts", "t", {"a": 1.0, "gymnasium": None})
    assert contacts["score"] is None and not contacts["eligible"]
    assert "n/a on gymnasium" in contacts["not_eligible"]
    plugin = _row("plugin", "t", {"a": 0.99}, plugin=True)
    assert not plugin["eligible"] and "plugin" in plugin["not_eligible"]
    plain = _row("plain", "t", {"a": 0.5})
    assert R.winner([contacts, plugin, plain]) is plain
    text = R.table_text([contacts, plain], plain)
    assert "n/a" in text and "**plain** (default)" in text
    assert "| 0.0 |" not in text  # n/a is never printed as a zero


def test_ties_within_one_grasp_go_to_the_higher_mean():
    a = _row("a", "t", {"x": 0.90, "y": 0.95}, n=10)
    b = _row("b", "t", {"x": 0.85, "y": 1.00}, n=10)  # a whole grasp below a: a wins
    c = _row("c", "t", {"x": 0.91, "y": 0.92}, n=100)
    assert R.winner([a, b]) is a
    assert R.winner([a, c]) is a  # 0.90 vs 0.91 within one grasp of the smaller column (10)


def test_a_recording_replay_keeps_every_grasp_and_its_label_and_drops_contacts(
    synthetic_split,
):
    _, test = synthetic_split
    records = test[:6]
    back = R.replayed(records)
    assert [r.shape for r in back] == [r.shape for r in records]
    assert all(r.source == "recorded" and r.contact_force.size == 0 for r in back)
    assert np.allclose(back[0].final_angles, records[0].final_angles, atol=1e-9)
    j0 = R.replayed(records, coupled=True)
    fci, fci_j0 = records[0].fci_angles(), j0[0].fci_angles()
    # a J0-only hand keeps J3 and J1 + J2 exactly; only the split between them is guessed
    assert np.allclose(fci[0], fci_j0[0]) and np.allclose(fci[1] + fci[2], fci_j0[1] + fci_j0[2])


def test_every_declared_column_and_training_names_a_set():
    specs = R.set_specs("tiny", {"gymnasium": "hand.xml"}, R.Path("objects"))
    for column in R.COLUMNS:
        if column.hand in (None, "gymnasium"):
            assert all(s in specs for s in column.sets), column.name
    for training, parts in R.TRAININGS.items():
        assert all(p in specs for p in parts), training
    assert "menagerie" not in specs  # a hand not given is no set, its column not run
    household = specs["household"].table["objects"]
    assert {o["file"].split(".")[0] for o in household} == set(R.FAMILY_OBJECTS)
    assert not set(R.FAMILY_OBJECTS) & set(R.NO_FAMILY_OBJECTS)
    assert not set(R.AMBIGUOUS_OBJECTS) & (set(R.FAMILY_OBJECTS) | set(R.NO_FAMILY_OBJECTS))


def test_the_validation_objects_are_closed_solids_of_hand_size():
    for name, build in R.VALIDATION_OBJECTS.items():
        mesh = build()
        assert mesh.is_watertight, name
        assert 0.04 <= max(mesh.extents) <= 0.15, name


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--other-hand", "shadow=x.xml"], "NAME=FILE"),
        (["--other-hand", "menagerie"], "NAME=FILE"),
        (["--other-hand", "gymnasium=missing.xml"], "missing.xml"),
        (["--training", "clean"], "--training is not read"),
        (["--engine", "mujoco"], "--engine is not read"),
        (["--descriptor", "nothing-like-it"], "no candidate"),
    ],
)
def test_robustness_refuses_bad_input_before_any_grasp(tmp_path, capsys, extra, message):
    err = run_error(capsys, ["benchmark", "--protocol", "robustness", "--scale", "tiny",
                             "--out", str(tmp_path / "m"), *extra])  # fmt: skip
    assert message in err
    assert not (tmp_path / "m").exists()


def test_other_hand_is_refused_outside_the_robustness_protocol(tmp_path, capsys):
    err = run_error(capsys, ["benchmark", "--protocol", "sim-shift", "--other-hand",
                             "menagerie=x.xml", "--out", str(tmp_path / "b")])  # fmt: skip
    assert "--protocol robustness" in err
