"""The train / evaluate / compare / identify / demo commands: JSON contracts (docs/json.md)
and bad input (exit 2, one line on stderr, nothing already written lost)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from cli_helpers import run_error
from test_workflow import synthetic_set

from tactile_bullet.cli import main
from tactile_bullet.records import save_record


def write_records(folder, records):
    folder.mkdir()
    for i, rec in enumerate(records):
        save_record(rec, folder / f"rec{i:03d}.npz")
    return folder


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    root = tmp_path_factory.mktemp("cli")
    train = write_records(root / "train", synthetic_set(8, seed=11))
    test = write_records(root / "test", synthetic_set(4, seed=12))
    return root, train, test


@pytest.fixture(scope="module")
def model_file(folders):
    root, train, _ = folders
    path = root / "model.npz"
    code = main(["train", "--data", str(train), "--classifier", "knn", "--out", str(path)])
    assert code == 0
    return path


def run_json(capsys, argv):
    code = main([*argv, "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out)


def test_train_json_names_the_model(folders, capsys, tmp_path):
    _, train, _ = folders
    doc = run_json(
        capsys, ["train", "--data", str(train), "--classifier", "knn",
                 "--param", "n_neighbors=3", "--out", str(tmp_path / "m.npz")],
    )  # fmt: skip
    assert doc["classifier"] == "knn" and doc["descriptor"] == "signature"
    assert doc["classifier_params"] == {"n_neighbors": 3}
    assert doc["train_records"] == 24
    assert (tmp_path / "m.npz").is_file()


def test_evaluate_json_contract_and_report_folder(folders, model_file, capsys, tmp_path):
    _, _, test = folders
    doc = run_json(
        capsys,
        ["evaluate", "--model", str(model_file), "--data", str(test), "--report", str(tmp_path)],
    )
    assert set(doc) >= {"accuracy", "classes", "confusion_matrix", "per_class"}
    cm = np.array(doc["confusion_matrix"])
    assert cm.sum(axis=1).tolist() == [doc["per_class"][c]["support"] for c in doc["classes"]]
    assert (tmp_path / "confusion_matrix.png").is_file()
    assert (tmp_path / "accuracy_by_position.png").is_file()


def test_evaluate_without_a_model_scores_the_default_identifier(folders, capsys):
    """As ``identify`` and ``grasp`` answer with the default when no --model is given, so
    ``evaluate`` scores it (``--model default`` names it too)."""
    from tactile_bullet.learn.default import default_meta

    _, _, test = folders
    doc = run_json(capsys, ["evaluate", "--data", str(test)])
    named = run_json(capsys, ["evaluate", "--model", "default", "--data", str(test)])
    assert doc == named and doc["model"]["descriptor"] == default_meta()["descriptor"]
    assert doc["model"]["classifier"] == default_meta()["classifier"]
    assert sum(map(sum, doc["confusion_matrix"])) == doc["records"]


def test_evaluate_prints_a_confusion_matrix_on_a_terminal(folders, model_file, capsys):
    _, _, test = folders
    assert main(["evaluate", "--model", str(model_file), "--data", str(test)]) == 0
    out = capsys.readouterr().out
    assert "accuracy:" in out and "true \\ predicted" in out


def test_compare_json_lists_every_pair(folders, capsys):
    _, train, test = folders
    rows = run_json(
        capsys, ["compare", "--data", str(train), "--test", str(test),
                 "--descriptor", "signature,raw-joints", "--classifier", "svm,knn"],
    )  # fmt: skip
    assert [(r["descriptor"], r["classifier"]) for r in rows] == [
        ("signature", "svm"), ("signature", "knn"), ("raw-joints", "svm"), ("raw-joints", "knn")
    ]  # fmt: skip
    for row in rows:
        assert set(row) >= {"accuracy", "fit_time_s", "predict_latency_ms"}


def test_identify_a_saved_record(folders, model_file, capsys):
    _, _, test = folders
    record = sorted(test.glob("*.npz"))[0]
    doc = run_json(capsys, ["identify", "--model", str(model_file), "--record", str(record)])
    assert doc["shape"] in doc["probabilities"]
    assert sum(doc["probabilities"].values()) == pytest.approx(1.0)


def test_identify_says_when_the_model_cannot_tell_two_shapes_apart(
    folders, model_file, capsys, tmp_path
):
    from tactile_bullet.learn.models import load_model, save_model

    _, _, test = folders
    record = str(sorted(test.glob("*.npz"))[0])
    doc = run_json(capsys, ["identify", "--model", str(model_file), "--record", record])
    assert "margin" in doc and "ambiguous" in doc and "cross_check" in doc
    model = load_model(model_file)
    model.info["doubt"] = {"margin": 2.0}  # every answer within it: ambiguous
    doubtful = save_model(tmp_path / "doubtful.npz", model)
    doc = run_json(capsys, ["identify", "--model", str(doubtful), "--record", record])
    assert doc["ambiguous"][0] == doc["shape"] and doc["ambiguous"][1] != doc["shape"]
    assert main(["identify", "--model", str(doubtful), "--record", record]) == 0
    text = capsys.readouterr().out
    assert f"AMBIGUOUS: {doc['ambiguous'][0]} or {doc['ambiguous'][1]}" in text


def test_unknown_classifier_lists_the_installed_ones(folders, capsys, tmp_path):
    _, train, _ = folders
    err = run_error(
        capsys, ["train", "--data", str(train), "--classifier", "svn", "--out",
                 str(tmp_path / "m.npz")],
    )  # fmt: skip
    assert "svn" in err and "svm" in err
    assert not (tmp_path / "m.npz").exists()


def test_missing_or_empty_data_is_a_usage_error(capsys, tmp_path):
    out = str(tmp_path / "m.npz")
    assert "does not exist" in run_error(
        capsys, ["train", "--data", str(tmp_path / "nowhere"), "--out", out]
    )
    (tmp_path / "empty").mkdir()
    assert "no grasp records" in run_error(
        capsys, ["train", "--data", str(tmp_path / "empty"), "--out", out]
    )


def test_unwritable_out_fails_before_work_and_keeps_old_model(folders, model_file, capsys):
    _, train, _ = folders
    before = model_file.read_bytes()
    err = run_error(
        capsys, ["train", "--data", str(train), "--out", str(model_file.parent / "no" / "m.npz")]
    )
    assert "does not exist" in err
    assert model_file.read_bytes() == before


def test_unreadable_model_file_is_a_usage_error(folders, capsys, tmp_path):
    _, _, test = folders
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a model at all")
    run_error(capsys, ["evaluate", "--model", str(junk), "--data", str(test)])
    run_error(capsys, ["evaluate", "--model", str(tmp_path / "absent.npz"), "--data", str(test)])


def test_data_with_none_of_the_models_shapes(model_file, capsys, tmp_path):
    folder = write_records(tmp_path / "tori", synthetic_set(2, seed=13, shapes=("torus",)))
    err = run_error(capsys, ["evaluate", "--model", str(model_file), "--data", str(folder)])
    assert "none of the model's classes" in err


def test_model_whose_descriptor_is_not_installed(folders, capsys, tmp_path):
    from tactile_bullet import plugins
    from tactile_bullet.hookspecs import hookimpl
    from tactile_bullet.learn.descriptors import SignatureDescriptor

    class Renamed(SignatureDescriptor):
        name = "renamed-signature"

    class Plugin:
        @hookimpl
        def register_descriptors(self, register):
            register("renamed-signature", Renamed)

    _, train, test = folders
    name = plugins.register_plugin(Plugin(), "tmp-descriptor-plugin")
    try:
        model = tmp_path / "m.npz"
        argv = ["train", "--data", str(train), "--descriptor", "renamed-signature"]
        assert main([*argv, "--classifier", "knn", "--out", str(model)]) == 0
    finally:
        plugins.unregister_plugin(name)
    capsys.readouterr()
    err = run_error(capsys, ["evaluate", "--model", str(model), "--data", str(test)])
    assert "renamed-signature" in err


def test_bad_input_in_a_fresh_process_prints_one_line(tmp_path):
    entry = "import sys; from tactile_bullet.cli import main; sys.exit(main())"
    cmd = [sys.executable, "-c", entry, "compare", "--data", str(tmp_path)]
    proc = subprocess.run([*cmd, "--classifier", "svm,,knn"], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr


@pytest.mark.slow
def test_quick_demo_end_to_end(capsys, tmp_path):
    doc = run_json(capsys, ["demo", "--quick", "--out", str(tmp_path / "demo"), "--seed", "3"])
    assert set(doc) >= {"accuracy", "classes", "confusion_matrix", "train_records",
                        "test_records", "report"}  # fmt: skip
    assert sorted(doc["classes"]) == sorted(["cone", "torus", "sphere", "hyperboloid", "cylinder"])
    cm = np.array(doc["confusion_matrix"])
    assert cm.sum() == doc["test_records"] > 0
    report = tmp_path / "demo" / "report"
    for name in ("confusion_matrix.png", "signatures.png", "report.json", "comparison.json"):
        assert (report / name).is_file()
    # the simulated grasps and the model are reusable with the other commands
    capsys.readouterr()
    again = run_json(capsys, ["evaluate", "--model", doc["model"], "--data", doc["data"]["test"]])
    assert again["confusion_matrix"] == doc["confusion_matrix"]


def test_identify_simulates_a_new_grasp(model_file, capsys):
    argv = ["identify", "--model", str(model_file), "--shape", "sphere", "--offset", "0.003,0,0"]
    doc = run_json(capsys, argv)
    assert doc["true_shape"] == "sphere"
    assert doc["shape"] in doc["probabilities"]
    assert doc["grasp"]["pose"]["offset"] == [0.003, 0.0, 0.0]


def test_identify_rejects_a_bad_pose_or_size(model_file, capsys):
    base = ["identify", "--model", str(model_file), "--shape", "sphere"]
    assert "--offset" in run_error(capsys, [*base, "--offset", "1,2"])
    assert "out of range" in run_error(capsys, [*base, "--param", "radius=2"])
    assert "unknown shape" in run_error(capsys, ["identify", "--model", str(model_file),
                                                 "--shape", "dodecahedron"])  # fmt: skip


def test_report_or_demo_folder_that_is_a_file_fails_before_any_work(folders, model_file, capsys):
    _, _, test = folders
    blocker = model_file.parent / "a-file"
    blocker.write_text("keep me")
    argv = ["evaluate", "--model", str(model_file), "--data", str(test), "--report", str(blocker)]
    assert "not a directory" in run_error(capsys, argv)
    assert "not a directory" in run_error(capsys, ["demo", "--quick", "--out", str(blocker)])
    assert blocker.read_text() == "keep me"


def test_commands_read_a_dataset_folder(capsys, tmp_path):
    from test_workflow import SHAPES, synthetic_record

    from tactile_bullet.datasets.generate import generate
    from tactile_bullet.datasets.sweeps import Sweep

    offsets = [-0.008, -0.004, 0.0, 0.004, 0.008]
    sweep = Sweep.from_dict(
        {"name": "t", "shapes": [{"name": s, "offset_x": offsets} for s in SHAPES]}
    )

    def fake_grasp(task):  # the sweep's own shape and offset, synthetic joint angles
        rec = synthetic_record(
            task.shape, 0.5, task.pose.offset[0], np.random.default_rng(task.seed)
        )
        return rec.metadata(), rec.arrays()

    generate(sweep, tmp_path / "ds", workers=0, shard_size=4, task_fn=fake_grasp)
    model = str(tmp_path / "m.npz")
    doc = run_json(capsys, ["train", "--data", str(tmp_path / "ds"), "--classifier", "knn",
                            "--out", model])  # fmt: skip
    assert doc["train_records"] == 15
    doc = run_json(capsys, ["evaluate", "--model", model, "--data", str(tmp_path / "ds")])
    assert doc["records"] == 15 and sorted(doc["classes"]) == sorted(SHAPES)


def test_demo_never_writes_into_a_folder_of_someone_elses_files(capsys, tmp_path):
    mine = tmp_path / "out" / "train"
    mine.mkdir(parents=True)
    (mine / "notes.txt").write_text("mine")
    err = run_error(capsys, ["demo", "--quick", "--out", str(tmp_path / "out")])
    assert "choose another --out" in err
    assert (mine / "notes.txt").read_text() == "mine"


def test_train_known_grasps_teach_the_model_another_hand(folders, capsys, tmp_path):
    """``train --known``: a few grasps of the user's own hand, shapes known, join the training
    grasps. On a hand whose joints read differently (J3 20 deg further, J1 20 deg less), raw
    joint angles + svm trained on the simulated set alone misread half its grasps; with two
    known grasps of each shape they read the rest of that hand's grasps far better."""
    from tactile_bullet.records import OFFSET_JOINTS
    from tactile_bullet.sim.grasp import offset_readings

    _, train, _ = folders
    shift = [{"3": 0.35, "2": 0.0, "1": -0.35}[j[-1]] for j in OFFSET_JOINTS]
    other = [offset_readings(r, shift) for r in synthetic_set(6, seed=13)]
    first = {r.shape: [] for r in other}
    for r in other:
        first[r.shape].append(r)
    known = write_records(tmp_path / "known", [r for v in first.values() for r in v[:2]])
    test = write_records(tmp_path / "test", [r for v in first.values() for r in v[2:]])
    acc, doubt = {}, {}
    for name, extra in (("alone", []), ("known", ["--known", str(known)])):
        model = tmp_path / f"{name}.npz"
        doc = run_json(capsys, ["train", "--data", str(train), *extra, "--descriptor",
                                "raw-joints", "--out", str(model)])  # fmt: skip
        assert doc["train_records"] == 24 and doc.get("known_records") == (6 if extra else None)
        if extra:
            assert doc["known_check"]["grasps"] == 6
            assert 0.0 <= doc["known_check"]["self_agreement"] <= 1.0
        found = run_json(capsys, ["evaluate", "--model", str(model), "--data", str(test)])
        acc[name], doubt[name] = found["accuracy"], found["ambiguous"]
    assert acc["alone"] <= 0.6 and acc["known"] >= acc["alone"] + 0.25, acc
    # the known grasps, not the shape fit, second the answers of the model fitted with them
    assert doubt["known"]["cross_check"] == "known-grasps", doubt
    assert doubt["alone"]["cross_check"] != "known-grasps"
    assert main(["train", "--data", str(train), "--known", str(known), "--descriptor",
                 "raw-joints", "--out", str(tmp_path / "text.npz")]) == 0  # fmt: skip
    assert "checked against the nearest of the 6 known grasps" in capsys.readouterr().out


def test_train_known_with_a_shape_the_data_lacks_exits_2_and_writes_nothing(
    folders, capsys, tmp_path
):
    _, train, _ = folders
    known = write_records(tmp_path / "known", synthetic_set(1, seed=5, shapes=("ovoid",)))
    out = tmp_path / "m.npz"
    err = run_error(capsys, ["train", "--data", str(train), "--known", str(known),
                             "--out", str(out)])  # fmt: skip
    assert "--known holds 'ovoid', a shape the training data lacks" in err
    assert not out.exists()
