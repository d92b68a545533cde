"""``import``, ``export`` and ``identify --recording`` from the command line: round trips through
a dataset the other commands accept, refusals of bad recordings (exit 2, one line, nothing
written) and of outputs that already exist."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_helpers import run_error

from tactile_bullet.cli import main
from tactile_bullet.experiments import workflow
from tactile_bullet.hand import JOINT_NAMES
from tactile_bullet.learn.models import save_model
from tactile_bullet.realhand.export import export
from tactile_bullet.realhand.recordings import write_dataset

pytest.importorskip("rosbags")


@pytest.fixture(scope="module")
def files(tmp_path_factory, synthetic_split):
    """A model trained on synthetic grasps, a test dataset of 10 others and its bag export."""
    root = tmp_path_factory.mktemp("rec")
    train, test = synthetic_split
    test = test[::3]
    model = workflow.train(train, "signature", "svm")
    save_model(root / "model.npz", model)
    write_dataset(test, root / "test", {"test": True})
    export(test, root / "test.bag", "bag")
    return {"root": root, "model": model, "test": test}


def _json(capsys, argv):
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_import_writes_a_dataset_that_evaluate_and_train_accept(tmp_path, capsys, files):
    root = files["root"]
    doc = _json(capsys, ["import", str(root / "test.bag"), "--out", str(tmp_path / "imp")])
    assert doc["records"] == len(files["test"])
    assert doc["labels"] == {s: sum(r.shape == s for r in files["test"]) for s in doc["labels"]}
    assert main(["verify", "--data", str(tmp_path / "imp")]) == 0  # a sound dataset
    capsys.readouterr()
    model = str(root / "model.npz")
    imported = _json(capsys, ["evaluate", "--model", model, "--data", str(tmp_path / "imp")])
    original = _json(capsys, ["evaluate", "--model", model, "--data", str(root / "test")])
    assert imported["confusion_matrix"] == original["confusion_matrix"]
    n = len(files["test"])  # a recording's pose and sizes are unknown, not "centred"
    assert imported["by_position"] == {"unknown": {"accuracy": imported["accuracy"], "support": n}}
    assert list(imported["by_rotation"]) == ["unknown"] == list(imported["by_size"])
    out = _json(capsys, ["train", "--data", str(tmp_path / "imp"), "--out", str(tmp_path / "m")])
    assert sorted(out["classes"]) == sorted({r.shape for r in files["test"]})


def test_identify_recording_names_every_grasp(capsys, files):
    root = files["root"]
    doc = _json(
        capsys,
        ["identify", "--model", str(root / "model.npz"), "--recording", str(root / "test.bag")],
    )
    want = workflow.predict(files["model"], files["test"])
    assert doc["shapes"] == list(want)
    assert [g["label"] for g in doc["grasps"]] == [r.shape for r in files["test"]]
    starts = [g["start_s"] for g in doc["grasps"]]
    assert starts == sorted(starts) and "shape" not in doc  # several grasps: no single answer
    labels = [r.shape for r in files["test"]]
    right = sum(s == t for s, t in zip(want, labels, strict=True))
    assert doc["tally"] == {
        "grasps": len(labels), "shapes": {s: list(want).count(s) for s in doc["tally"]["shapes"]},
        "labelled": len(labels), "correct": right,
        "ambiguous": sum(g["ambiguous"] is not None for g in doc["grasps"]),
        "unknown": sum(g["unknown"] for g in doc["grasps"]),
    }  # fmt: skip
    assert sum(doc["tally"]["shapes"].values()) == len(labels)
    argv = ["identify", "--model", str(root / "model.npz"), "--recording", str(root / "test.bag")]
    assert main(argv) == 0
    last = capsys.readouterr().out.splitlines()[-1]
    assert last.startswith(f"{len(labels)} grasps: ")
    assert last.endswith(f"; {right} of {len(labels)} labelled grasps named as labelled")


def test_identify_recording_of_one_grasp_keeps_the_identify_contract(tmp_path, capsys, files):
    one = files["test"][0]
    export([one], tmp_path / "one.csv", "csv")
    doc = _json(
        capsys,
        ["identify", "--model", str(files["root"] / "model.npz"),
         "--recording", str(tmp_path / "one.csv")],
    )  # fmt: skip
    assert doc["shape"] == workflow.identify(files["model"], one)["shape"]
    assert set(doc["probabilities"]) == set(files["model"].classes)


def test_export_refuses_to_overwrite_without_force(tmp_path, capsys, files):
    data = str(files["root"] / "test")
    out = tmp_path / "x.csv"
    out.write_text("mine\n")
    err = run_error(capsys, ["export", "--data", data, "--format", "csv", "--out", str(out)])
    assert "--force" in err and out.read_text() == "mine\n"
    doc = _json(capsys, ["export", "--data", data, "--format", "csv", "--out", str(out), "--force"])
    assert doc["grasps"] == len(files["test"]) and out.read_text().startswith("time,grasp")
    err = run_error(capsys, ["export", "--data", data, "--format", "mcap", "--out", str(tmp_path)])
    assert "--force" in err


def test_a_topic_given_where_only_tables_are_read_or_written_is_refused(tmp_path, capsys, files):
    # a table has no topics: a --topic there would be ignored, not followed
    csv_file = tmp_path / "one.csv"
    export(files["test"][:1], csv_file, "csv")
    data = str(files["root"] / "test")
    for argv in (["import", str(csv_file), "--out", str(tmp_path / "d"), "--topic", "/arm"],
                 ["identify", "--recording", str(csv_file), "--topic", "/arm"],
                 ["export", "--data", data, "--format", "csv", "--out", str(tmp_path / "e.csv"),
                  "--topic", "/arm"]):  # fmt: skip
        err = run_error(capsys, argv)
        assert "--topic names a bag's JointState topic" in err, err
    assert not (tmp_path / "d").exists() and not (tmp_path / "e.csv").exists()
    # a bag among the files: the topic is the bag's
    export(files["test"], tmp_path / "arm.bag", "bag", topic="/arm")
    doc = _json(capsys, ["import", str(csv_file), str(tmp_path / "arm.bag"), "--out",
                         str(tmp_path / "d"), "--topic", "/arm"])  # fmt: skip
    assert doc["records"] == 1 + len(files["test"])


def test_import_refuses_an_existing_dataset_without_force_and_other_files_always(
    tmp_path, capsys, files
):
    bag = str(files["root"] / "test.bag")
    out = tmp_path / "imp"
    assert main(["import", bag, "--out", str(out)]) == 0
    capsys.readouterr()
    before = sorted(p.name for p in out.iterdir())
    assert "--force" in run_error(capsys, ["import", bag, "--out", str(out)])
    assert main(["import", bag, "--out", str(out), "--force", "--shape", "cup"]) == 0
    capsys.readouterr()
    assert sorted(p.name for p in out.iterdir()) == before
    assert {r.shape for r in workflow.records_from(out)} == {"cup"}
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("keep")
    run_error(capsys, ["import", bag, "--out", str(tmp_path / "other"), "--force"])
    assert (tmp_path / "other" / "notes.txt").read_text() == "keep"


def _csv(path, names, rows):
    path.write_text(
        ",".join(["time", *names]) + "\n" + "\n".join(",".join(map(str, r)) for r in rows)
    )
    return path


def _bad_inputs(tmp, files):
    """name -> (file, extra args, words the error must hold)."""
    root = files["root"]
    data = (root / "test.bag").read_bytes()
    truncated = tmp / "truncated.bag"
    truncated.write_bytes(data[: len(data) // 2])
    names = ["rh_" + n for n in JOINT_NAMES]
    zero = [0.0] * len(names)
    return {
        "truncated bag": (truncated, [], "not a readable bag"),
        "bag without the topic": (root / "test.bag", ["--topic", "/hand/joints"], "no topic"),
        "missing joint": (_csv(tmp / "m.csv", names[:-1], [[0.0, *zero[:-1]]]), [], "rh_THJ1"),
        "unknown joint": (
            _csv(tmp / "u.csv", [*names, "rh_elbow"], [[0.0, *zero, 0.0]]), [], "rh_elbow"
        ),
        "time going back": (
            _csv(tmp / "t.csv", names, [[0.0, *zero], [0.2, *zero], [0.1, *zero]]), [],
            "not increasing",
        ),
        "empty value": (_csv(tmp / "e.csv", names, [[0.0, "", *zero[1:]]]), [], "no value"),
        "value out of range": (
            _csv(tmp / "r.csv", names, [[0.0, 1e300, *zero[1:]]]), [],
            f"{tmp / 'r.csv'}: joint {names[0]} at 0 s: value 1e+300 rad is outside",
        ),
        "not a recording": (_csv(tmp / "n.txt", names, []), [], "unknown recording type"),
        "missing file": (tmp / "nope.bag", [], "does not exist"),
    }  # fmt: skip


@pytest.mark.parametrize(
    "case",
    ["truncated bag", "bag without the topic", "missing joint", "unknown joint",
     "time going back", "empty value", "value out of range", "not a recording", "missing file"],
)  # fmt: skip
def test_bad_recordings_exit_2_with_one_line_and_write_nothing(tmp_path, capsys, files, case):
    path, extra, words = _bad_inputs(tmp_path, files)[case]
    out = tmp_path / "out"
    err = run_error(capsys, ["import", str(path), "--out", str(out), *extra])
    assert words in err
    assert not out.exists()
    model = str(files["root"] / "model.npz")
    err = run_error(capsys, ["identify", "--model", model, "--recording", str(path), *extra])
    assert words in err


def test_bad_calibration_file_exits_2(tmp_path, capsys, files):
    cal = tmp_path / "cal.toml"
    cal.write_text("[joints]\nFFJ3 = { offset = 0.1, gain = 2 }\n")
    err = run_error(
        capsys,
        ["import", str(files["root"] / "test.bag"), "--out", str(tmp_path / "o"),
         "--calibration", str(cal)],
    )  # fmt: skip
    assert "unknown key 'gain'" in err and not (tmp_path / "o").exists()


def test_export_j0_and_prefix_options(tmp_path, capsys, files):
    out = tmp_path / "j0.csv"
    data = str(files["root"] / "test")
    argv = ["export", "--data", data, "--format", "csv", "--out", str(out), "--coupled"]
    assert main([*argv, "--prefix", "lh"]) == 0
    header = out.read_text().splitlines()[0].split(",")
    assert "lh_FFJ0" in header and "lh_FFJ1" not in header
    err = run_error(capsys, [*argv, "--force", "--prefix", "r h"])
    assert "--prefix" in err
    rows = np.loadtxt(out, delimiter=",", skiprows=1, usecols=[0])
    assert rows.size == sum(r.time.size for r in files["test"])
