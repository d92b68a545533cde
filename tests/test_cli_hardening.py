"""Issue 10's probes, each a fact the user relies on: a grasp that touched nothing is never
named, nothing on disk is replaced unasked, ordinary bad input is one line and exit status 2
before any long work, and no input can ask for unbounded work."""

from __future__ import annotations

import json
import os
from dataclasses import replace

import numpy as np
import pytest
from cli_helpers import run_error
from synthetic import make_record, make_records, write_records

from tactile_bullet.cli import join_negative_values, main
from tactile_bullet.errors import UsageError
from tactile_bullet.records import save_record


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """A folder of synthetic records (3 per thesis shape) and a knn model trained on it."""
    root = tmp_path_factory.mktemp("hard")
    train = write_records(root / "train", make_records(per_shape=3, seed=5))
    model = root / "model.npz"
    assert main(["train", "--data", str(train), "--classifier", "knn", "--out", str(model)]) == 0
    return root, train, model


def untouched(path):
    """A file's bytes, to assert later that a refused command left it alone."""
    return path.read_bytes()


# --- 2. a grasp that touched nothing gets no shape name -------------------------------------


def test_identify_an_object_out_of_reach_says_no_contact(data, capsys):
    _, _, model = data
    argv = ["identify", "--model", str(model), "--shape", "cone", "--offset", "1,0,0"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "no contact: nothing to identify" in out
    assert "identified" not in out
    assert main([*argv, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["shape"] is None and doc["reason"].startswith("no contact: nothing to identify")
    assert doc["probabilities"] == {} and doc["grasp"]["fingers_in_contact"] == []


def test_identify_a_record_with_one_finger_on_the_object(data, capsys, tmp_path):
    _, _, model = data
    rec = make_record("sphere")
    one = replace(rec, fingers_in_contact=("ff", "th"), flags=("finger_without_contact",))
    path = save_record(one, tmp_path / "one.npz")
    assert main(["identify", "--model", str(model), "--record", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["shape"] is None and "only ff" in doc["reason"]
    # three long fingers still carry the shape (a small object offset sideways)
    three = replace(rec, fingers_in_contact=("ff", "mf", "rf", "th"))
    path = save_record(three, tmp_path / "three.npz")
    assert main(["identify", "--model", str(model), "--record", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["shape"] in {"sphere", "cone", "torus",
                                                             "hyperboloid", "cylinder"}  # fmt: skip


def test_grasp_that_touches_nothing_names_no_pattern(capsys):
    assert main(["grasp", "--shape", "sphere", "--thres", "1e-6"]) == 0
    out = capsys.readouterr().out
    assert "no contact: nothing to identify" in out and "nearest pattern" not in out
    assert main(["grasp", "--shape", "sphere", "--thres", "1e-6", "--json"]) == 0
    sig = json.loads(capsys.readouterr().out)["signature"]
    assert sig["identified"] is None and sig["nearest_pattern"] is None
    assert sig["reason"].startswith("no contact: nothing to identify")


# --- 3. nothing on disk is replaced unasked -------------------------------------------------


def test_grasp_refuses_an_existing_out_before_simulating(tmp_path, capsys):
    kept = tmp_path / "rec.npz"
    kept.write_bytes(b"earlier grasp")
    err = run_error(capsys, ["grasp", "--shape", "sphere", "--out", str(kept)])
    assert "--force" in err and kept.read_bytes() == b"earlier grasp"
    for flag in ("--snapshot", "--plot"):
        png = tmp_path / "old.png"
        png.write_bytes(b"old figure")
        assert "--force" in run_error(capsys, ["grasp", "--shape", "sphere", flag, str(png)])
        assert png.read_bytes() == b"old figure"


def test_two_outputs_of_one_grasp_may_not_share_a_file(tmp_path, capsys):
    png = str(tmp_path / "a.png")
    err = run_error(capsys, ["grasp", "--shape", "sphere", "--snapshot", png, "--plot", png])
    assert "same file" in err


def test_train_refuses_an_existing_model_unless_forced(data, capsys, tmp_path):
    _, train, model = data
    before = untouched(model)
    argv = ["train", "--data", str(train), "--classifier", "knn", "--out", str(model)]
    assert "--force" in run_error(capsys, argv)
    assert model.read_bytes() == before
    copy = tmp_path / "m.npz"
    copy.write_bytes(b"old model")
    argv[-1] = str(copy)
    assert main([*argv, "--force"]) == 0
    assert copy.read_bytes() != b"old model"


def test_evaluate_keeps_an_earlier_report_unless_forced(data, capsys, tmp_path):
    _, train, model = data
    (tmp_path / "report.json").write_text('{"earlier": true}')
    argv = ["evaluate", "--model", str(model), "--data", str(train), "--report", str(tmp_path)]
    assert "report.json" in run_error(capsys, argv)
    assert json.loads((tmp_path / "report.json").read_text()) == {"earlier": True}
    # --force replaces only a report this project wrote there (issue 29): not the user's
    assert "report.json" in run_error(capsys, [*argv, "--force"])
    assert json.loads((tmp_path / "report.json").read_text()) == {"earlier": True}
    (tmp_path / "report.json").unlink()
    assert main(argv) == 0
    assert main([*argv, "--force"]) == 0
    assert "accuracy" in json.loads((tmp_path / "report.json").read_text())


def test_demo_refuses_its_own_earlier_output_and_deletes_nothing(capsys, tmp_path):
    out = tmp_path / "demo"
    earlier = write_records(out / "train", make_records(shapes=("sphere",), per_shape=2))
    (out / "train" / "rec000.npz").rename(earlier / "rec00000.npz")
    (out / "train" / "rec001.npz").rename(earlier / "rec00001.npz")
    before = sorted(p.name for p in earlier.iterdir())
    assert "--force" in run_error(capsys, ["demo", "--quick", "--out", str(out)])
    # --force may overwrite, but a larger earlier set would be left half-replaced: refused
    many = [make_record("sphere")] * 25
    from tactile_bullet.datasets.bulk import save_records

    save_records(many, out / "test", force=True)
    err = run_error(capsys, ["demo", "--quick", "--out", str(out), "--force"])
    assert "larger demo" in err
    assert sorted(p.name for p in earlier.iterdir()) == before
    assert len(list((out / "test").iterdir())) == 25


def test_save_records_never_deletes_earlier_records(tmp_path):
    from tactile_bullet.datasets.bulk import save_records

    records = make_records(shapes=("sphere",), per_shape=3)
    save_records(records, tmp_path)
    with pytest.raises(UsageError, match="--force"):
        save_records(records[:1], tmp_path)
    with pytest.raises(UsageError, match="left beside"):
        save_records(records[:1], tmp_path, force=True)
    assert len(list(tmp_path.glob("rec*.npz"))) == 3
    save_records(records, tmp_path, force=True)  # the same number: every file replaced


# --- 5. ordinary bad input: exit 2, one line, before long work ------------------------------


def test_a_truncated_record_is_named(data, capsys, tmp_path):
    _, _, model = data
    whole = save_record(make_record("cone"), tmp_path / "cut.npz")
    whole.write_bytes(whole.read_bytes()[:300])
    err = run_error(capsys, ["identify", "--model", str(model), "--record", str(whole)])
    assert "cut.npz" in err
    folder = write_records(tmp_path / "folder", make_records(per_shape=2))
    (folder / "rec001.npz").write_bytes(b"PK\x03\x04 truncated")
    err = run_error(capsys, ["train", "--data", str(folder), "--out", str(tmp_path / "m.npz")])
    assert "rec001.npz" in err


def test_an_image_format_nobody_can_write_is_refused_before_simulating(tmp_path, capsys):
    for flag in ("--snapshot", "--plot"):
        err = run_error(capsys, ["grasp", "--shape", "sphere", flag, str(tmp_path / "x.txt")])
        assert flag in err and "txt" in err
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    "argv",
    [
        ["generate", "--preset", "smoke", "--out", "OUT", "--seed", "-1"],
        ["demo", "--quick", "--out", "OUT", "--seed", "-1"],
        ["grasp", "--shape", "sphere", "--seed", "-1"],
        ["compare", "--data", "OUT", "--seed", "99999999999"],
        ["sequential", "--synthetic", "--orders", "0"],
        ["sequential", "--synthetic", "--seed", "-3"],
        ["demo", "--quick", "--out", "OUT", "--workers", "0"],
        ["generate", "--preset", "smoke", "--out", "OUT", "--workers", "100000"],
        ["generate", "--preset", "smoke", "--out", "OUT", "--shard-size", "1000000000"],
        ["benchmark", "--out", "OUT", "--seed", "-1"],
        ["benchmark", "--out", "OUT", "--workers", "100000"],
    ],
)
def test_counts_and_seeds_out_of_range(tmp_path, capsys, argv):
    argv = [str(tmp_path / "out") if a == "OUT" else a for a in argv]
    run_error(capsys, argv)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("toml", "message"),
    [
        (b'[controller]\ncontrol_every = "two"\n', "control_every"),
        (b"[controller]\ncontrol_every = 1.5\n", "control_every"),
        (b"[controller]\nmax_time = 1e9\n", "max_time"),
        (b'name = "caf\xe9"\n', "UTF-8"),
        (b"[[shapes]]\nname = 'cylinder'\nrotation_deg = [180]\n", "rotation_deg"),
        (b"[[shapes]]\nname = 'cylinder'\noffset_x = [1e300]\n", "offset_x"),
        (b"samples = 1000000000\nmode = 'random'\n", "limit"),
        (
            b"[[shapes]]\nname = 'sphere'\noffset_x = {min = -0.01, max = 0.01, steps = 1000000}"
            b"\noffset_y = {min = 0.0, max = 0.001, steps = 1000000}\n",
            "limit",
        ),
        (
            b"[[shapes]]\nname = 'torus'\nparams = { major_radius = [0.044], minor_radius = "
            b"[0.05] }\n",
            "valid solid",
        ),
    ],
)
def test_sweep_files_are_checked_before_any_work(tmp_path, capsys, toml, message):
    if b"[[shapes]]" not in toml:
        toml += b"[[shapes]]\nname = 'sphere'\n"
    config = tmp_path / "sweep.toml"
    config.write_bytes(toml)
    out = tmp_path / "out"
    err = run_error(capsys, ["generate", "--config", str(config), "--out", str(out)])
    assert message in err
    assert not out.exists()


def test_sequential_refuses_an_unwritable_out_before_training(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    argv = ["sequential", "--synthetic", "--classes", "3", "--per-class", "30"]
    err = run_error(capsys, [*argv, "--out", str(blocker / "figs")])
    assert "--out" in err
    (tmp_path / "figs").mkdir()
    (tmp_path / "figs" / "disturbance_matrix.png").write_bytes(b"earlier")
    assert "--force" in run_error(capsys, [*argv, "--out", str(tmp_path / "figs")])
    assert (tmp_path / "figs" / "disturbance_matrix.png").read_bytes() == b"earlier"


def test_compare_or_train_on_too_few_grasps_per_shape(tmp_path, capsys):
    one = write_records(tmp_path / "one", make_records(per_shape=1))
    two = write_records(tmp_path / "two", make_records(per_shape=2))
    assert "only one record" in run_error(capsys, ["compare", "--data", str(one)])
    assert "at least 2 per shape" in run_error(capsys, ["compare", "--data", str(two)])
    err = run_error(capsys, ["train", "--data", str(one), "--out", str(tmp_path / "m.npz")])
    assert "svm" in err and "cannot be trained" in err


# --- 6. unbounded inputs ----------------------------------------------------------------------


def test_a_sweep_knows_its_size_without_expanding_it():
    from tactile_bullet.datasets.presets import preset
    from tactile_bullet.datasets.sweeps import MAX_GRASPS, Sweep

    assert preset("thesis").size() >= len(preset("thesis").tasks())
    grid = {"min": 0.0, "max": 0.001, "steps": 1_000_000}
    huge = Sweep.from_dict({"shapes": [{"name": "sphere", "offset_x": grid, "offset_z": grid}]})
    assert huge.size() == 10**12 > MAX_GRASPS
    with pytest.raises(UsageError, match="limit"):
        huge.tasks()


@pytest.mark.parametrize(
    "argv",
    [
        ["grasp", "--shape", "sphere", "--max-time", "1e9"],
        ["grasp", "--shape", "sphere", "--thres", "1e9"],
        ["grasp", "--shape", "cylinder", "--param", "radius=0.0_4"],
        ["grasp", "--shape", "sphere", "--offset", "1e300,0,0"],
        ["sequential", "--synthetic", "--classes", "1000", "--per-class", "1000000"],
    ],
)
def test_unbounded_work_is_refused(capsys, argv):
    run_error(capsys, argv)


# --- 7/8. smaller ones ------------------------------------------------------------------------


def test_a_negative_vector_needs_no_equals_sign(tmp_path, capsys):
    assert join_negative_values(["--offset", "-0.01,0,0", "--rotation", "-5"]) == [
        "--offset=-0.01,0,0", "--rotation=-5"
    ]  # fmt: skip
    assert join_negative_values(["--offset=-0.01,0,0"]) == ["--offset=-0.01,0,0"]
    kept = tmp_path / "kept.npz"
    kept.write_bytes(b"x")
    # parsed (the refusal is about --out, not about an option named -0.01,0,0)
    err = run_error(capsys, ["grasp", "--shape", "sphere", "--offset", "-0.01,0,0",
                             "--out", str(kept)])  # fmt: skip
    assert "already exists" in err


def test_sequential_json_and_full_class_names(capsys, tmp_path):
    pytest.importorskip("torch")
    from tactile_bullet.experiments.sequential import disturbance_table

    argv = ["sequential", "--synthetic", "--classes", "3", "--per-class", "30", "--orders", "2",
            "--n-updates", "20", "--recalibration", "5", "--out", str(tmp_path)]  # fmt: skip
    argv.append("--json")
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["classes"] == ["class0", "class1", "class2"] and len(doc["orders"]) == 2
    assert set(doc["final_accuracy"]) == {"offline", "sequential"}
    assert len(doc["accuracy_vs_objects"]["sequential"]) == 3
    assert len(doc["figures"]) == 3 and all(os.path.isfile(p) for p in doc["figures"])
    table = disturbance_table(np.zeros((2, 2)), ["hyperboloid", "cylinder-rot90"])
    assert "hyperboloid" in table and "cylinder-rot90" in table


def test_an_allow_list_naming_no_installed_plugin_is_warned(monkeypatch, capsys):
    from tactile_bullet import plugins

    monkeypatch.setenv("TACTILE_BULLET_PLUGINS", "nope")
    try:
        plugins.reload_plugins()
        assert "'nope', which is not an installed plugin" in capsys.readouterr().err
    finally:
        monkeypatch.delenv("TACTILE_BULLET_PLUGINS")
        plugins.reload_plugins()


def test_package_data_is_a_package():
    """setuptools warned at install that tactile_bullet.data was not listed as a package."""
    from pathlib import Path

    from setuptools import find_packages

    root = Path(__file__).resolve().parent.parent
    assert "tactile_bullet.data" in find_packages(str(root), include=["tactile_bullet*"])


def test_a_real_hands_recording_is_not_taken_for_a_grasp_without_contact():
    """Recordings carry no contact sensing: an empty fingers_in_contact means unknown."""
    from tactile_bullet.perception.contact import nothing_to_identify

    simulated = replace(make_record("sphere"), fingers_in_contact=(), flags=("no_contact",))
    assert nothing_to_identify(simulated).startswith("no contact")
    recorded = replace(simulated, flags=(), source="recorded")
    assert nothing_to_identify(recorded) is None


@pytest.mark.parametrize("make", ["passwd", "fifo", "missing"])
def test_hand_model_must_be_an_mjcf_file_checked_before_mujoco_reads_it(tmp_path, capsys, make):
    """A --hand-model that is not a regular .xml file is refused in one line, before MuJoCo
    opens it (MuJoCo prints a decoder warning on a file without an extension, and a FIFO
    would block it)."""
    pytest.importorskip("mujoco")
    path = tmp_path / ("hand" if make == "passwd" else "hand.xml")
    if make == "passwd":
        path.write_text("root:x:0:0:root:/root:/bin/bash\n")
    elif make == "fifo":
        os.mkfifo(path)
    err = run_error(capsys, ["grasp", "--shape", "sphere", "--hand-model", str(path)])
    assert "hand model" in err or "MJCF" in err


@pytest.mark.parametrize(
    "argv",
    [
        ["grasp", "--shape", "cylinder", "--param", "radius=0.03", "--param", "radius=0.04"],
        ["explore", "--shape", "cylinder", "--param", "radius=0.03", "--param", " radius=0.04"],
        ["train", "--data", "D", "--out", "m.npz", "--param", "C=1", "--param", "C=2"],
    ],
)
def test_a_key_given_twice_is_refused_not_the_last_kept(capsys, argv):
    err = run_error(capsys, argv)
    assert "is given twice" in err and "give it once" in err


@pytest.mark.parametrize(
    "command", [["evaluate", "--data"], ["adapt", "--out", "m.npz", "--known"]]
)
def test_a_recording_given_where_records_are_read_is_named_with_how_to_import_it(
    tmp_path, capsys, command
):
    recording = tmp_path / "session.csv"
    recording.write_text("time,FFJ3\n0.0,0.1\n")
    err = run_error(capsys, [*command, str(recording)])
    assert f"{recording} is not a readable grasp record" in err
    assert f"tactile-bullet import {recording} --out DIR" in err
