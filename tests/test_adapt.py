"""``adapt`` (a hand's known grasps -> its model) and ``import``'s labelling of many
recordings: the choice among the candidate ways on small synthetic sets, the honesty of its
cross-validation (no known grasp ever in its own model), its refusals (exit 2, one line, before
any work), and a written model that ``evaluate`` and ``identify`` read as is."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from cli_helpers import run_error
from synthetic import make_records
from test_json_docs import check

from tactile_bullet.cli import main
from tactile_bullet.experiments import adapt as A
from tactile_bullet.experiments import workflow
from tactile_bullet.learn.models import load_model
from tactile_bullet.realhand.export import export
from tactile_bullet.realhand.recordings import write_dataset

SWAP = {"cone": "sphere", "sphere": "cone"}


def _json(capsys, argv) -> dict:
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.fixture(scope="module")
def known(tmp_path_factory):
    """Known grasps, 4 per thesis shape, as an imported dataset would hold them."""
    root = tmp_path_factory.mktemp("known")
    records = make_records(per_shape=4, seed=3)
    write_dataset(records, root / "known", {"test": True})
    return root / "known", records


def test_wilson_interval():
    assert A.wilson(0, 10)[0] == 0.0 and A.wilson(10, 10)[1] == pytest.approx(1.0)
    lo, hi = A.wilson(5, 10)
    assert lo == pytest.approx(0.2366, abs=1e-3) and hi == pytest.approx(0.7634, abs=1e-3)


def test_the_folds_hold_every_grasp_out_once_and_never_fit_on_it():
    y = np.array(["a"] * 3 + ["b"] * 4)
    seen = []

    def spy(train, test):
        assert not set(train) & set(test)  # never in its own model
        seen.extend(test.tolist())
        return np.array(["a"] * len(test))

    A.cross_validate(A.Way("spy", spy), y, A.folds_of(y))
    assert sorted(seen) == list(range(len(y)))
    big = np.array(["a", "b", "c"] * 30)
    folds = A.folds_of(big)
    assert len(folds) == A.MAX_FOLDS and sorted(np.concatenate(folds)) == list(range(90))


def test_labels_that_follow_no_feature_score_at_chance_not_perfect(known):
    """Were a held-out grasp in its own model, the nearest known grasp would name it every
    time: with the labels shuffled it must fall to about chance."""
    _, records = known
    labels = np.random.default_rng(0).permutation([r.shape for r in records])
    shuffled = [replace(r, shape=str(s)) for r, s in zip(records, labels, strict=True)]
    doc = A.adapt(shuffled)
    nearest = next(w for w in doc["ways"] if w["way"] == "nearest-known")
    assert nearest["accuracy"] < 0.6


def test_adapt_keeps_the_default_where_it_names_the_hand_and_a_known_way_where_not(
    tmp_path, capsys, known, monkeypatch
):
    folder, records = known
    doc = _json(capsys, ["adapt", "--known", str(folder), "--out", str(tmp_path / "a.npz")])
    rows = {w["way"]: w for w in doc["ways"]}
    assert set(rows) == {"default", "nearest-known", "default-shifted"}
    assert doc["skipped"] == {"train-known": "no --data (a simulated training set) given",
                              "calibrated-shape-fit": "not asked for (--calibrate)"}
    assert doc["accuracy"] == max(w["accuracy"] for w in doc["ways"])
    assert doc["folds"] == "leave-one-out" and doc["known_grasps"] == 20
    lo, hi = doc["interval"]
    assert lo <= doc["accuracy"] <= hi
    assert doc["curve"] and doc["advice"]
    check("adapt", doc)  # every field docs/json.md documents, and no other
    # where the default is kept, it learns nothing from known grasps: the curve printed is
    # another way's, and the line says so
    from tactile_bullet.experiments import adapt as A

    kept = dict(doc, chosen="default", curve_way="default-shifted")
    monkeypatch.setattr(A, "adapt", lambda *a, **k: kept)
    assert main(["adapt", "--known", str(folder), "--out", str(tmp_path / "c.npz")]) == 0
    assert ("learning curve of default-shifted (the best way that learns from known grasps; "
            "default does not)") in capsys.readouterr().out  # fmt: skip
    monkeypatch.undo()
    # a hand whose cone reads as our sphere and back: the default names them wrong, the known
    # grasps teach the swap
    swapped = [replace(r, shape=SWAP.get(r.shape, r.shape)) for r in records]
    write_dataset(swapped, tmp_path / "swapped", {"test": True})
    out = tmp_path / "b.npz"
    doc = _json(capsys, ["adapt", "--known", str(tmp_path / "swapped"), "--out", str(out)])
    rows = {w["way"]: w for w in doc["ways"]}
    assert doc["chosen"] != "default"
    assert rows["default"]["accuracy"] <= 0.7 < rows[doc["chosen"]]["accuracy"]
    # the model file is read as is: by load_model, evaluate and identify
    model = load_model(out)
    assert model.info["adapt"]["chosen"] == doc["chosen"]
    test = [replace(r, shape=SWAP.get(r.shape, r.shape)) for r in make_records(per_shape=2,
                                                                              seed=9)]
    write_dataset(test, tmp_path / "test", {"test": True})
    scored = _json(capsys, ["evaluate", "--model", str(out), "--data", str(tmp_path / "test")])
    assert scored["accuracy"] >= 0.7
    assert workflow.evaluate(model, test)["accuracy"] == scored["accuracy"]
    export(test[:1], tmp_path / "one.csv", "csv")
    answer = _json(capsys, ["identify", "--model", str(out), "--recording",
                            str(tmp_path / "one.csv")])  # fmt: skip
    assert answer["shapes"] and answer["shapes"][0] in model.classes
    text = main(["adapt", "--known", str(tmp_path / "swapped"), "--out", str(out), "--force"])
    assert text == 0 and "chosen: " in capsys.readouterr().out


def test_adapt_tries_train_known_with_data(tmp_path, capsys, known):
    folder, _ = known
    write_dataset(make_records(per_shape=6, seed=5), tmp_path / "sim", {"test": True})
    doc = _json(capsys, ["adapt", "--known", str(folder), "--data", str(tmp_path / "sim"),
                         "--out", str(tmp_path / "m.npz")])  # fmt: skip
    assert "train-known" in {w["way"] for w in doc["ways"]}
    assert list(doc["skipped"]) == ["calibrated-shape-fit"]  # not asked for
    load_model(tmp_path / "m.npz")


@pytest.mark.parametrize(
    "relabel, words",
    [
        (lambda r, i: replace(r, shape="unknown"), "no labelled grasps"),
        (lambda r, i: replace(r, shape="sphere"), "one shape only"),
        (lambda r, i: r if r.shape != "cone" or i % 4 == 0 else None, "at least 2"),
        (lambda r, i: replace(r, shape="cylindr") if r.shape == "cylinder" else r, "cylindr"),
    ],
    ids=["unlabelled", "one-shape", "one-grasp", "unknown-name"],
)
def test_adapt_refuses_known_sets_it_cannot_cross_validate(tmp_path, capsys, known, relabel,
                                                           words):  # fmt: skip
    _, records = known
    bad = [x for i, r in enumerate(records) if (x := relabel(r, i)) is not None]
    write_dataset(bad, tmp_path / "bad", {"test": True})
    err = run_error(capsys, ["adapt", "--known", str(tmp_path / "bad"), "--out",
                             str(tmp_path / "m.npz")])  # fmt: skip
    assert words in err and not (tmp_path / "m.npz").exists()


def test_adapt_refuses_an_existing_model_without_force(tmp_path, capsys, known):
    folder, _ = known
    out = tmp_path / "m.npz"
    out.write_text("mine")
    assert "--force" in run_error(capsys, ["adapt", "--known", str(folder), "--out", str(out)])
    assert out.read_text() == "mine"


# --- import: one labelled dataset from many recordings --------------------------------------


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """Two unlabelled CSV recordings: 2 cone grasps, then 3 grasps (sphere, sphere, torus)."""
    root = tmp_path_factory.mktemp("recs")
    records = make_records(per_shape=3, seed=4)
    cones = [r for r in records if r.shape == "cone"][:2]
    mixed = [r for r in records if r.shape == "sphere"][:2]
    mixed.append(next(r for r in records if r.shape == "torus"))
    unlabelled = lambda rs: [replace(r, shape="unknown") for r in rs]  # noqa: E731
    export(unlabelled(cones), root / "cones.csv", "csv")
    export(unlabelled(mixed), root / "mixed.csv", "csv")
    return root


def _shapes(folder) -> list[str]:
    return [r.shape for r in workflow.records_from(folder)]


def test_import_labels_each_file_with_its_own_shape(tmp_path, capsys, recordings):
    cones, mixed = str(recordings / "cones.csv"), str(recordings / "mixed.csv")
    doc = _json(capsys, ["import", cones, mixed, "--shape", "cone", "--shape", "sphere",
                         "--out", str(tmp_path / "a")])  # fmt: skip
    assert doc["labels"] == {"cone": 2, "sphere": 3}
    err = run_error(capsys, ["import", cones, mixed, "--shape", "a", "--shape", "b", "--shape",
                             "c", "--out", str(tmp_path / "b")])  # fmt: skip
    assert "once per file" in err and not (tmp_path / "b").exists()


def test_import_labels_grasps_from_a_labels_file(tmp_path, capsys, recordings):
    cones, mixed = str(recordings / "cones.csv"), str(recordings / "mixed.csv")
    labels = tmp_path / "labels.csv"
    labels.write_text(f"recording,grasp,shape\ncones.csv,cone\n{mixed},0,sphere\n"
                      "mixed.csv,1,sphere\nmixed.csv,2,torus\n")  # fmt: skip
    doc = _json(capsys, ["import", cones, mixed, "--labels", str(labels),
                         "--out", str(tmp_path / "a")])  # fmt: skip
    assert doc["labels"] == {"cone": 2, "sphere": 2, "torus": 1}
    assert _shapes(tmp_path / "a") == ["cone", "cone", "sphere", "sphere", "torus"]
    for text, words in [
        ("nothing.csv,cone\n", "not one of the recordings"),
        ("mixed.csv,7,torus\n", "does not hold"),
        ("mixed.csv,-1,torus\n", "index from 0"),
        ("mixed.csv,cone,sphere,torus\n", "expected"),
        ("mixed.csv,0,cone\nmixed.csv,0,torus\n", "labelled twice"),
    ]:
        labels.write_text(text)
        err = run_error(capsys, ["import", cones, mixed, "--labels", str(labels),
                                 "--out", str(tmp_path / "b")])  # fmt: skip
        assert words in err and not (tmp_path / "b").exists(), text
    err = run_error(capsys, ["import", cones, "--labels", str(labels), "--shape", "cone",
                             "--out", str(tmp_path / "b")])  # fmt: skip
    assert "give one" in err


def test_import_refuses_a_recording_given_twice_and_a_shape_name_in_other_case(
    tmp_path, capsys, recordings
):
    """The same file twice (under two paths) would count its grasps twice or label them two
    ways; 'CONE' would be a class of its own beside 'cone'. Any other name is the user's own
    class and is kept."""
    cones = str(recordings / "cones.csv")
    twice = f"{recordings}/./cones.csv"
    for argv, words in [
        ([cones, cones, "--shape", "cone", "--shape", "sphere"], "is given twice"),
        ([cones, twice, "--shape", "cone"], f"is given twice (as {cones} and {twice})"),
        ([cones, "--shape", "CONE"], "did you mean 'cone'"),
    ]:
        err = run_error(capsys, ["import", *argv, "--out", str(tmp_path / "b")])
        assert words in err and not (tmp_path / "b").exists(), argv
    labels = tmp_path / "labels.csv"
    labels.write_text("cones.csv,Sphere\n")
    argv = ["import", cones, "--labels", str(labels), "--out", str(tmp_path / "b")]
    assert "did you mean 'sphere'" in run_error(capsys, argv)
    doc = _json(capsys, ["import", cones, "--shape", "mug", "--out", str(tmp_path / "a")])
    assert doc["labels"] == {"mug": 2}


@pytest.fixture(scope="module")
def few_known(tmp_path_factory):
    """Two known grasps of each of three shapes (the calibrated way costs a fit per grasp)."""
    root = tmp_path_factory.mktemp("few")
    records = [r for r in make_records(per_shape=2, seed=5)
               if r.shape in ("cylinder", "sphere", "torus")]  # fmt: skip
    write_dataset(records, root / "known", {"test": True})
    return root / "known", records


def test_the_calibrated_shape_fit_is_tried_only_when_asked_for(tmp_path, capsys, few_known):
    folder, _ = few_known
    argv = ["adapt", "--known", str(folder), "--out", str(tmp_path / "a.npz")]
    plain = _json(capsys, argv)
    assert "calibrated-shape-fit" not in {w["way"] for w in plain["ways"]}
    assert "--calibrate" in plain["skipped"]["calibrated-shape-fit"]
    asked = _json(capsys, [*argv, "--calibrate", "--force"])
    row = next(w for w in asked["ways"] if w["way"] == "calibrated-shape-fit")
    assert row["held_out"] == 6 and 0.0 <= row["accuracy"] <= 1.0


def test_a_calibrated_shape_fit_model_carries_its_hands_coefficients(tmp_path, few_known):
    from tactile_bullet.learn.models import save_model
    from tactile_bullet.perception.shape_fit import fit_shape

    _, records = few_known
    model = A.build("calibrated-shape-fit", records)
    param = model.classifier_params["calibration"]
    loaded = load_model(save_model(tmp_path / "m.npz", model))
    cal = loaded.estimator.calibration_
    assert loaded.classifier == "shape-fit" and cal is not None
    assert np.allclose(cal.gain, param["gain"]) and np.allclose(cal.intercept, param["intercept"])
    families = sorted({r.shape for r in records})
    expected = [fit_shape(a, families, cal).shape for a in A._known_fit_angles(records)]
    assert list(loaded.predict_records(records)) == expected


def test_a_model_whose_hand_coefficients_are_out_of_bounds_is_refused(tmp_path, few_known):
    from tactile_bullet.errors import UsageError
    from tactile_bullet.learn.models import save_model

    _, records = few_known
    model = A.build("calibrated-shape-fit", records)
    path = save_model(tmp_path / "m.npz", model)
    with np.load(path, allow_pickle=False) as data:
        members = {k: data[k] for k in data.files}
    state = json.loads(str(members["estimator_state"]))
    state["params"]["calibration"]["gain"][0][0] = 40.0
    members["estimator_state"] = np.array(json.dumps(state))
    np.savez(tmp_path / "bad.npz", **members)
    with pytest.raises(UsageError, match="gain must be within") as info:
        load_model(tmp_path / "bad.npz")
    assert "\n" not in str(info.value)
