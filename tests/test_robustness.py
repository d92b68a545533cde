"""The robustness matrix (experiments/robustness.py, docs/robustness.md): the declared rule
picks the default, columns a method was chosen on do not count, a method that cannot read a
column is n/a (never zero), and the CLI refuses what it would not read."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_bullet.errors import UsageError
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


def _full(method, accs, n=100, **kw):
    row = _row(method, "t", accs, n=n, **kw)
    return {**row, "descriptor": method, "params": {}, "classifier": "svm"}


def test_pooled_replicates_choose_on_all_their_grasps():
    """Each run alone names another winner by its mean; pooled, the method that is never
    weak on any column wins (docs/robustness.md, the pooled rule)."""
    run1 = [_full("steady", {"x": 0.92, "y": 0.92}), _full("swing", {"x": 0.93, "y": 0.99})]
    run2 = [_full("steady", {"x": 0.92, "y": 0.92}), _full("swing", {"x": 0.80, "y": 0.99})]
    assert R.winner(run1)["method"] == "swing"
    rows = R.pooled([run1, run2])
    swing = next(r for r in rows if r["method"] == "swing")
    assert swing["columns"]["x"] == {"n": 200, "accuracy": pytest.approx(0.865)}
    assert R.winner(rows)["method"] == "steady"


def test_pooling_keeps_n_a_seen_columns_and_only_methods_every_run_scored():
    run1 = [_full("a", {"x": 0.9, "gymnasium": None}), _full("b", {"x": 0.8}),
            _full("c", {"x": 0.7, "menagerie": 0.2}, seen=("menagerie",))]
    run2 = [_full("a", {"x": 0.9, "gymnasium": 0.5}), _full("c", {"x": 0.7, "menagerie": 0.3})]
    rows = {r["method"]: r for r in R.pooled([run1, run2])}
    assert set(rows) == {"a", "c"}  # b was not scored in the second run
    assert rows["a"]["columns"]["gymnasium"]["accuracy"] is None and not rows["a"]["eligible"]
    assert rows["c"]["seen"] == ["menagerie"] and rows["c"]["score"] == pytest.approx(0.7)


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


def test_a_bad_other_hand_file_is_named_by_the_option_it_came_by(tmp_path, capsys):
    garbage = tmp_path / "garbage.xml"
    garbage.write_text("<mujoco><worldbody><body name='x'/></worldbody></mujoco>")
    err = run_error(capsys, ["benchmark", "--protocol", "robustness", "--scale", "tiny",
                             "--out", str(tmp_path / "m"), "--other-hand",
                             f"gymnasium={garbage}"])  # fmt: skip
    assert f"--other-hand gymnasium={garbage}" in err
    assert "--hand-model" not in err


def test_other_hand_is_refused_outside_the_robustness_protocol(tmp_path, capsys):
    err = run_error(capsys, ["benchmark", "--protocol", "sim-shift", "--other-hand",
                             "menagerie=x.xml", "--out", str(tmp_path / "b")])  # fmt: skip
    assert "--protocol robustness" in err


@pytest.mark.parametrize("protocol", ["sim-shift", "robustness", "active"])
def test_a_cache_that_is_a_file_is_refused_before_any_grasp(tmp_path, capsys, protocol):
    afile = tmp_path / "afile"
    afile.write_text("kept")
    err = run_error(capsys, ["benchmark", "--protocol", protocol, "--scale", "tiny", "--cache",
                             str(afile), "--out", str(tmp_path / "b")])  # fmt: skip
    assert f"--cache {afile} exists and is not a folder" in err
    assert not (tmp_path / "b").exists() and afile.read_text() == "kept"


def test_the_readme_cylinder_is_named_cylinder_and_the_shape_fits_cone_is_detail(capsys):
    """README's first grasp: a 30 mm cylinder. The default identifier names it, and its second
    opinion (the second svm, docs/doubt.md) agrees: no doubt. The shape fit, which rests on the
    four J3 angles, finds a turned cone as good (docs/robustness.md, root causes): a detail
    line that names its identifier, never a second answer or the doubt."""
    import json

    from tactile_bullet.cli import main

    assert main(["grasp", "--shape", "cylinder", "--param", "radius=0.03", "--json"]) == 0
    answer = json.loads(capsys.readouterr().out)["answer"]
    assert answer["shape"] == "cylinder" and answer["identifier"] == "default"
    assert answer["others"]["shape-fit"] == "cone" and answer["cross_check"] == "cylinder"
    assert answer["ambiguous"] is None and answer["unknown"] is False
    assert main(["grasp", "--shape", "cylinder", "--param", "radius=0.03"]) == 0
    first, *rest = [line for line in capsys.readouterr().out.splitlines() if line.strip()][1:]
    assert first.startswith("identified: cylinder by the default identifier")
    assert "AMBIGUOUS" not in first
    # the detail lines name their identifier: none reads as a second answer
    assert not any(line.startswith("identified") for line in rest)
    assert any(line.strip().startswith("shape fit: cone") for line in rest)


def test_a_tight_torus_on_mujoco_is_named_torus_by_its_contacts(capsys, monkeypatch):
    """Physics and the answer: MuJoCo's torus whose tube nearly closes its hole (47 / 40 mm)
    reads as a sphere from the angles; its contact points lie on a torus and off every
    sphere, so the default answers torus, says why, and stays ambiguous with the classifier's
    sphere (docs/robustness.md, the ninth replicate's declaration). Without the renaming the
    same grasp is a sphere answered unknown."""
    import json

    from tactile_bullet.cli import main
    from tactile_bullet.perception import contact_check

    pytest.importorskip("mujoco")
    argv = ["grasp", "--shape", "torus", "--param", "major_radius=0.04725",
            "--param", "minor_radius=0.040125", "--engine", "mujoco"]  # fmt: skip
    assert main([*argv, "--json"]) == 0
    answer = json.loads(capsys.readouterr().out)["answer"]
    assert answer["shape"] == "torus" and answer["renamed_from"] == "sphere"
    assert answer["ambiguous"] == ["torus", "sphere"] and answer["unknown"] is False
    assert main(argv) == 0
    line = capsys.readouterr().out.splitlines()[1]
    assert line.startswith("identified: torus") and "the classifier read sphere" in line
    monkeypatch.setattr(contact_check, "TORUS_FOR_SPHERE", False)
    assert main([*argv, "--json"]) == 0
    answer = json.loads(capsys.readouterr().out)["answer"]
    assert answer["shape"] == "sphere" and answer["renamed_from"] is None
    assert answer["unknown"] is True


def test_the_default_identifier_answers_identify_without_a_model(capsys):
    import json

    from tactile_bullet.cli import main

    assert main(["identify", "--shape", "sphere", "--param", "radius=0.05", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["shape"] == "sphere" and doc["unknown"] is False and doc["novelty"] >= 0


def test_a_damaged_default_model_is_refused_never_used(tmp_path, monkeypatch, capsys):
    from importlib import resources

    from tactile_bullet.learn import default

    real = resources.files("tactile_bullet.data")
    for name in (default.MODEL_FILE, default.META_FILE):
        (tmp_path / name).write_bytes((real / name).read_bytes())
    blob = bytearray((tmp_path / default.MODEL_FILE).read_bytes())
    blob[len(blob) // 2] ^= 0xFF
    (tmp_path / default.MODEL_FILE).write_bytes(bytes(blob))
    monkeypatch.setattr(default, "_data", lambda: tmp_path)
    default.default_model.cache_clear()
    try:
        with pytest.raises(UsageError, match="damaged"):
            default.default_model()
        err = run_error(capsys, ["identify", "--shape", "sphere"])
        assert "default model is damaged" in err
    finally:
        default.default_model.cache_clear()


def test_the_shipped_default_is_the_matrix_winner_it_names():
    from tactile_bullet.learn.default import default_meta, default_model

    meta, model = default_meta(), default_model()
    assert model.descriptor == meta["descriptor"] and model.classifier == meta["classifier"]
    assert model.novelty is not None and model.doubt_margin is not None
    assert sorted(model.classes) == sorted(R.SHAPES)
    assert meta["score"] == min(v for k, v in meta["columns"].items()
                                if v is not None and k not in R.seen_columns(
                                    R.Candidate(meta["descriptor"], meta["classifier"]),
                                    meta["training"], meta.get("replicate", 0)))  # fmt: skip


def test_a_replicate_run_draws_every_test_set_afresh_and_keeps_the_training_sets(tmp_path):
    from tactile_bullet.experiments import robustness_sets as S

    hands = {"menagerie": str(tmp_path / "m.xml")}
    first = S.set_specs("tiny", hands, tmp_path)
    again = S.set_specs("tiny", hands, tmp_path, replicate=2)
    assert set(first) == set(again)
    for short, spec in first.items():
        if short in S.TRAINING_SETS:
            assert again[short] == spec  # the models are fitted on the same grasps
        else:
            assert again[short].name == f"{spec.name}-r2"
            assert again[short].seed == spec.seed + 2 * S.REPLICATE_SEED_STEP
    assert {"test", "turned", "household", "menagerie"} <= set(first) - S.TRAINING_SETS


def test_on_replicate_sets_only_the_hands_stay_seen():
    cand = R.Candidate("finger-points", "svm")
    first = R.seen_columns(cand, "both+posed-randomized")
    assert {"poses", "turned", "household", "mujoco", "j0-only", "menagerie"} <= first
    assert R.seen_columns(cand, "both+posed-randomized", replicate=1) == {"menagerie",
                                                                          "gymnasium"}
    assert R.seen_columns(R.Candidate("signature", "svm"), "posed-randomized", 1) == {
        "gymnasium"}


@pytest.mark.parametrize("argv, message", [
    (["--protocol", "sim-shift", "--replicate", "1"], "other protocols do not read it"),
    (["--protocol", "robustness", "--replicate", "-1"], "--replicate"),
])  # fmt: skip
def test_replicate_is_refused_where_it_means_nothing(argv, message, capsys, tmp_path):
    err = run_error(capsys, ["benchmark", *argv, "--out", str(tmp_path / "o")])
    assert message in err


def test_a_noise_aware_training_presents_each_record_through_joint_noise_too():
    from synthetic import make_records

    from tactile_bullet.experiments import robustness_sets as S
    from tactile_bullet.learn.robust import AUGMENT_COPIES

    records = make_records(per_shape=2, seed=7)
    sets = {short: records for short in S.TRAININGS["both+posed-noise-aware"]}
    plain = R.training_set(sets, "both+posed-randomized")
    noisy = R.training_set(sets, "both+posed-noise-aware")
    assert len(noisy) == len(plain) * (1 + AUGMENT_COPIES)
    assert noisy[: len(plain)] == plain  # the originals first, then the perturbed copies
    moved = [np.abs(n.final_angles - p.final_angles).max()
             for n, p in zip(noisy[len(plain):2 * len(plain)], plain, strict=True)]  # fmt: skip
    assert 0 < float(np.median(moved)) < np.radians(5)
    assert "noise" in R.seen_columns(R.Candidate("signature", "svm"), "both+posed-noise-aware")


def test_the_shipped_defaults_row_is_seconded_by_its_own_second_svm(monkeypatch):
    """The matrix scores the shipped default's doubt as its answers carry it (its second svm
    seconds each answer), every other row's with the shape fit, as a model users train."""
    from tactile_bullet.learn.default import default_meta
    from tactile_bullet.learn.second_opinion import SecondOpinion
    from tests.conftest import make_records

    meta = default_meta()
    names = set(R.TRAININGS[meta["training"]]) | set(R.TRAININGS["bullet"])
    sets = {n: make_records(per_shape=4, seed=k) for k, n in enumerate(sorted(names))}
    sets["sizes"] = make_records(per_shape=4, seed=9)
    cand = R.Candidate(meta["descriptor"], meta["classifier"], (meta["training"], "bullet"))
    assert R.shipped_second(cand, meta["training"]) == meta["second_opinion"]
    assert R.shipped_second(cand, "bullet") is None
    # a second opinion that names every grasp a cone flags every answer that is not a cone
    monkeypatch.setattr(SecondOpinion, "names", lambda self, records: ["cone"] * len(records))
    shipped, other = R.score_matrix(sets, [cand])
    assert shipped["second_opinion"] == "robust-coupled-joints + svm"
    assert other["second_opinion"] == "shape-fit"
    assert shipped["columns"]["sizes"]["right_flagged"] >= 0.75  # 4 of the 5 shapes
    assert other["columns"]["sizes"]["right_flagged"] < 0.75


def test_an_answer_its_contacts_renamed_counts_as_ambiguous_in_the_matrix(monkeypatch):
    """The answers say so (``renamed_from``): the matrix's doubt figures count it flagged."""
    from tactile_bullet.learn import doubt
    from tactile_bullet.perception.contact_check import ContactCheck
    from tests.conftest import make_records

    sets = {n: make_records(per_shape=4, seed=k) for k, n in enumerate(R.TRAININGS["bullet"])}
    sets["sizes"] = make_records(per_shape=4, seed=9)
    monkeypatch.setattr(doubt, "cross_flags", lambda pred, accepted: np.zeros(len(pred), bool))
    monkeypatch.setattr(ContactCheck, "fit", classmethod(lambda cls, *a, **k: cls({})))
    monkeypatch.setattr(ContactCheck, "contact_names", lambda self, records, names, *a:
                        ["torus" if n == "cone" else None for n in names])  # fmt: skip
    [row] = R.score_matrix(sets, [R.Candidate("signature", "svm", ("bullet",))])
    cell = row["columns"]["sizes"]
    wrong = round(cell["n"] * (1 - cell["accuracy"]))
    assert wrong >= 4  # the four cones (the svm names them), renamed torus
    assert round(cell["wrong_flagged"] * wrong) >= 4
