"""Issue 29's probes beyond hand models: ``--force`` replaces only this project's files, a hand
calibration's coefficients stay within what ``calibrate`` writes, the shape-fit cache is not
vouched for by its own entries, ``train --known`` refuses what would silently do nothing, a
model's known arrays are bounded, deep TOML is one line, the Python API raises UsageError, and
``[randomize]`` never clamps or reads strings and booleans as numbers."""

from __future__ import annotations

import dataclasses
import json
import re

import numpy as np
import pytest
from cli_helpers import run_error
from synthetic import make_record, make_records, write_records

from tactile_bullet.cli import main
from tactile_bullet.errors import UsageError


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """Synthetic records (3 per thesis shape), a knn model, and a raw-joints model trained
    with 2 known grasps per shape."""
    root = tmp_path_factory.mktemp("round4")
    train = write_records(root / "train", make_records(per_shape=3, seed=5))
    known = write_records(root / "known", make_records(per_shape=2, seed=9))
    model = root / "model.npz"
    assert main(["train", "--data", str(train), "--classifier", "knn", "--out", str(model)]) == 0
    with_known = root / "known.npz"
    assert main(["train", "--data", str(train), "--known", str(known), "--descriptor",
                 "raw-joints", "--out", str(with_known)]) == 0  # fmt: skip
    return {"root": root, "train": train, "known": known, "model": model, "with_known": with_known}


# --- item 1: --force replaces only what this project wrote ------------------------------------


@pytest.mark.parametrize("name", ["train.toml", "ball.ply"])
def test_make_objects_force_never_replaces_a_file_it_did_not_write(tmp_path, capsys, name):
    out = tmp_path / "objects"
    out.mkdir()
    (out / name).write_text("notes\n")
    err = run_error(capsys, ["make-objects", "--out", str(out), "--force"])
    assert name in err and "did not write" in err
    assert (out / name).read_text() == "notes\n"
    assert sorted(p.name for p in out.iterdir()) == [name]  # nothing written beside it


def test_make_objects_force_refuses_a_link_before_writing_any_mesh(tmp_path, capsys):
    out = tmp_path / "objects"
    out.mkdir()
    (tmp_path / "mine.toml").write_text("kept\n")
    (out / "train.toml").symlink_to(tmp_path / "mine.toml")
    err = run_error(capsys, ["make-objects", "--out", str(out), "--force"])
    assert "symbolic link" in err
    assert sorted(p.name for p in out.iterdir()) == ["train.toml"]  # no mesh written first
    assert (tmp_path / "mine.toml").read_text() == "kept\n"


def test_make_objects_force_replaces_its_own_files_but_not_one_edited_since(tmp_path, capsys):
    out = tmp_path / "objects"
    argv = ["make-objects", "--out", str(out), "--only", "ball,can"]
    assert main(argv) == 0
    assert main([*argv, "--force"]) == 0  # its own, unchanged: replaced
    with open(out / "train.toml", "a") as fh:
        fh.write("# my edit\n")
    capsys.readouterr()
    assert "train.toml" in run_error(capsys, [*argv, "--force"])
    assert (out / "train.toml").read_text().endswith("# my edit\n")


def test_evaluate_report_force_never_replaces_a_file_it_did_not_write(data, capsys, tmp_path):
    (tmp_path / "confusion_matrix.png").write_bytes(b"my figure")
    argv = ["evaluate", "--model", str(data["model"]), "--data", str(data["train"]),
            "--report", str(tmp_path), "--force"]  # fmt: skip
    assert "confusion_matrix.png" in run_error(capsys, argv)
    assert (tmp_path / "confusion_matrix.png").read_bytes() == b"my figure"
    assert not (tmp_path / "report.json").exists()


# --- item 4 and 11: a hand calibration's coefficients are bounded ----------------------------


def _calibration(tmp_path):
    from tactile_bullet.perception.shape_model import load_calibration
    from tactile_bullet.realhand.hand_calibration import render, write

    text = render(load_calibration(), "", "known-grasps", {"sphere": 2, "cylinder": 2},
                  {"strength": 1.0})  # fmt: skip
    return write(tmp_path / "hand.toml", text)


ABSURD = {
    "intercept 1e9": ("intercept", "[[1e9, 0, 0, 0], [0, 0, 0, 0]]"),
    "sigma 1e-300": ("sigma", "[[1e-300, 0.1, 0.1, 0.1], [0.1, 0.1, 0.1, 0.1]]"),
    "sigma 1e300": ("sigma", "[[1e300, 0.1, 0.1, 0.1], [0.1, 0.1, 0.1, 0.1]]"),
    "side 1e300": ("side", "[[1e300, 0, 0, 0], [0, 0, 0, 0]]"),
    "loss_scale 1e300": ("loss_scale", "1e300"),
    "penalty 1e300": ("penalty", "1e300"),
    "gain true": ("gain", "[[true, 1, 1, 1], [1, 1, 1, 1]]"),
    "loss_scale text": ("loss_scale", '"4.0"'),
}


@pytest.mark.parametrize("case", sorted(ABSURD))
def test_hand_calibration_coefficients_beyond_what_calibrate_writes_are_refused(tmp_path, case):
    from tactile_bullet.realhand.hand_calibration import load

    key, value = ABSURD[case]
    path = _calibration(tmp_path)
    load(path)  # the file as calibrate writes it is accepted
    path.write_text(re.sub(rf"(?m)^{key} = .*$", f"{key} = {value}", path.read_text(), count=1))
    with pytest.raises(UsageError, match=key):
        load(path)


def test_evaluate_with_side_1e300_exits_2_before_any_work(data, capsys, tmp_path):
    path = _calibration(tmp_path)
    path.write_text(re.sub(r"(?m)^side = .*$", "side = [[1e300, 0, 0, 0], [0, 0, 0, 0]]",
                           path.read_text()))  # fmt: skip
    err = run_error(capsys, ["evaluate", "--model", str(data["model"]), "--data",
                             str(data["train"]), "--hand-calibration", str(path)])  # fmt: skip
    assert "every side must be within" in err


def test_hand_calibration_report_strength_must_be_a_finite_number(tmp_path):
    from tactile_bullet.realhand.hand_calibration import load

    path = _calibration(tmp_path)
    path.write_text(re.sub(r"(?m)^strength = .*$", "strength = nan", path.read_text()))
    with pytest.raises(UsageError, match="strength"):
        load(path)


# --- item 5: a shape-fit cache entry cannot vouch for itself ----------------------------------


def test_a_shape_fit_cache_entry_edited_with_its_checksum_recomputed_is_not_used(
    tmp_path, monkeypatch
):
    import hashlib

    from tactile_bullet.perception import grid_cache

    monkeypatch.setenv("TACTILE_BULLET_CACHE", str(tmp_path / "cache"))
    grid = np.linspace(0.0, 1.0, 30).reshape(10, 3)
    calls = []

    def compute(g):
        calls.append(1)
        return np.broadcast_to(g.sum(axis=1)[:, None, None], (len(g), 3, 4)).copy()

    good = grid_cache.grid_geometry("sphere", grid, compute)
    path = grid_cache.cache_path("sphere")
    with np.load(path) as entry:
        meta = json.loads(str(entry["meta"]))
    edited = good + 0.5
    plain = hashlib.sha256(np.ascontiguousarray(edited, dtype="<f8").tobytes()).hexdigest()
    meta.update({"sha256": plain, "hmac": plain})  # what an editor can recompute
    with open(path, "wb") as fh:
        np.savez(fh, meta=np.array(json.dumps(meta)), grid=grid, geometry=edited)
    again = grid_cache.grid_geometry("sphere", grid, compute)
    np.testing.assert_array_equal(again, good)
    assert len(calls) == 2


# --- item 6: train --known refuses what would silently do nothing -----------------------------


def test_train_known_refuses_recordings_without_contacts_for_a_contact_descriptor(
    data, capsys, tmp_path
):
    blind = [dataclasses.replace(r, source="recorded", fingers_in_contact=(),
                                 contact_link=np.zeros(0, dtype="U16"),
                                 contact_position=np.zeros((0, 3)),
                                 contact_normal=np.zeros((0, 3)), contact_force=np.zeros(0))
             for r in make_records(per_shape=2, seed=3)]  # fmt: skip
    known = write_records(tmp_path / "rec", blind)
    out = tmp_path / "m.npz"
    err = run_error(capsys, ["train", "--data", str(data["train"]), "--known", str(known),
                             "--descriptor", "signature+contact-normals", "--out", str(out)])
    assert "no contact data" in err and "contact-normals" in err
    assert not out.exists()


def test_train_known_refuses_known_grasps_whose_features_do_not_vary(data, capsys, tmp_path):
    one = make_record("sphere", noise=0.0)
    same = [one, dataclasses.replace(one, shape="cylinder")]  # two labels, one grasp
    known = write_records(tmp_path / "same", same)
    out = tmp_path / "m.npz"
    err = run_error(capsys, ["train", "--data", str(data["train"]), "--known", str(known),
                             "--descriptor", "raw-joints", "--out", str(out)])  # fmt: skip
    assert "do not vary" in err
    assert not out.exists()


# --- items 9 and 11: a model's known arrays are bounded and shaped as its descriptor ----------


def _rewrite_model(src, dst, **members):
    with np.load(src) as data:
        contents = {k: data[k] for k in data.files}
    contents.update(members)
    with open(dst, "wb") as fh:
        np.savez_compressed(fh, **contents)
    return dst


def test_a_model_whose_known_arrays_declare_more_than_train_known_writes_is_refused_unread(
    data, tmp_path
):
    from tactile_bullet.learn.models import load_model

    big = np.zeros(((70 << 20) // 8 // 35 + 1, 35))  # over 70 MiB, compressed ~70 kB
    path = _rewrite_model(data["with_known"], tmp_path / "big.npz", **{"known.features": big})
    with pytest.raises(UsageError, match="known.features.*over the 67,108,864-byte limit"):
        load_model(path)


def test_a_model_whose_known_features_have_the_wrong_columns_is_refused_on_load(
    data, tmp_path, capsys
):
    from tactile_bullet.learn.models import load_model

    with np.load(data["with_known"]) as stored:
        features = stored["known.features"]
    path = _rewrite_model(data["with_known"], tmp_path / "cols.npz",
                          **{"known.features": features[:, :10]})  # fmt: skip
    with pytest.raises(UsageError, match="10 features"):
        load_model(path)
    err = run_error(capsys, ["evaluate", "--model", str(path), "--data", str(data["train"])])
    assert "10 features" in err


# --- item 10: TOML nested thousands deep is one line ------------------------------------------


@pytest.mark.parametrize("deep", ["x = " + "[" * 4000 + "]" * 4000,
                                  "x = " + "{a = " * 3000 + "1" + "}" * 3000])  # fmt: skip
def test_every_toml_reader_refuses_deep_nesting_on_one_line(tmp_path, capsys, data, deep):
    from tactile_bullet.datasets.sweeps import Sweep
    from tactile_bullet.realhand import calibration, hand_calibration

    path = tmp_path / "deep.toml"
    path.write_text(deep + "\n")
    for reader in (Sweep.from_toml, hand_calibration.load, hand_calibration.load_sizes,
                   calibration.load_calibration):  # fmt: skip
        with pytest.raises(UsageError, match="nested too deep"):
            reader(path)
    for argv in (["generate", "--config", str(path), "--out", str(tmp_path / "ds")],
                 ["evaluate", "--model", str(data["model"]), "--data", str(data["train"]),
                  "--hand-calibration", str(path)]):  # fmt: skip
        assert "nested too deep" in run_error(capsys, argv)


# --- item 12: the Python API raises UsageError, never TypeError -------------------------------


@pytest.mark.parametrize("call", [
    lambda root: __import__("tactile_bullet").load_dataset(123),
    lambda root: __import__("tactile_bullet").load_dataset(None),
    lambda root: __import__("tactile_bullet").load_dataset(b"data"),
    lambda root: __import__("tactile_bullet").load_dataset([str(root / "train")]),
    lambda root: __import__("tactile_bullet").load_dataset(root / "train",
                                                           descriptor_params=[1, 2]),
    lambda root: __import__("tactile_bullet").load_dataset(root / "train", allow_partial="no"),
    lambda root: __import__("tactile_bullet").load_dataset(root / "train", descriptor=5),
], ids=["int", "None", "bytes", "list", "params-list", "allow_partial-str", "descriptor-int"])
def test_load_dataset_refuses_wrong_types_with_a_usage_error(data, call):
    with pytest.raises(UsageError):
        call(data["root"])


@pytest.mark.parametrize("kwargs", [{"model": 5}, {"gap_s": "0.5"}, {"gap_s": True},
                                    {"calibration": 5}, {"hand_calibration": 5},
                                    {"cross_check": "no"}],
                         ids=["model", "gap-str", "gap-bool", "calibration", "hand_calibration",
                              "cross_check"])  # fmt: skip
def test_identifier_load_refuses_wrong_types_with_a_usage_error(data, kwargs):
    from tactile_bullet.realhand.streaming import Identifier

    args = {"model": data["model"], **kwargs}
    with pytest.raises(UsageError):
        Identifier.load(args.pop("model"), **args)


# --- item 13: [randomize] never clamps, and strings or booleans are no numbers ----------------


@pytest.mark.parametrize(("table", "message"), [
    ({"control_rate": [1e12]}, "control_rate must be above 0 Hz and at most one tick"),
    ({"control_rate": {"min": 120, "max": 1e9}}, "control_rate must be above 0 Hz"),
    ({"control_rate": [-5]}, "control_rate must be above 0 Hz"),
    ({"friction": {"min": "0.5", "max": "1.0"}}, "numeric min and max"),
    ({"friction": {"min": True, "max": 1.0}}, "numeric min and max"),
    ({"thres_t": [True, 0.3]}, "list of numbers"),
])  # fmt: skip
def test_randomize_refuses_clamped_rates_and_strings_or_booleans_as_numbers(table, message):
    from tactile_bullet.datasets.randomize import Randomization

    with pytest.raises(UsageError, match=message):
        Randomization.from_dict(table)


@pytest.mark.parametrize("key", ["delta", "thres_t", "max_time", "friction", "motor_force",
                                 "timestep", "sample_rate"])  # fmt: skip
def test_controller_numbers_refuse_booleans(key):
    from tactile_bullet.datasets.sweeps import Sweep

    with pytest.raises(UsageError, match=key):
        Sweep.from_dict({"controller": {key: True}, "shapes": [{"name": "sphere"}]})


# --- the class of item 8: every file a reader follows, an OBJ's material too ------------------


def test_an_obj_whose_material_file_is_a_fifo_is_read_without_opening_it(tmp_path):
    """An OBJ's ``mtllib`` is followed by the mesh loader: a FIFO there hung ``shape-info`` and
    ``grasp --mesh``. It now goes through the rule every referenced file keeps (the material is
    skipped; geometry needs none)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    os.mkfifo(tmp_path / "fifo.mtl")
    faces = "f 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n"
    (tmp_path / "t.obj").write_text("mtllib fifo.mtl\nusemtl a\nv 0 0 0\nv 0.05 0 0\n"
                                    f"v 0 0.05 0\nv 0 0 0.05\n{faces}")  # fmt: skip
    repo = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": str(repo),
           "TACTILE_BULLET_CACHE": str(tmp_path / "cache")}  # fmt: skip
    argv = [sys.executable, "-m", "tactile_bullet.cli", "shape-info", "--mesh",
            str(tmp_path / "t.obj"), "--json"]  # fmt: skip
    try:
        done = subprocess.run(argv, capture_output=True, text=True, timeout=90, env=env)
    except subprocess.TimeoutExpired:
        pytest.fail("loading the OBJ opened its FIFO material file and hung")
    assert done.returncode == 0, done.stderr


def test_a_controller_delta_too_small_to_close_the_hand_is_refused_before_any_grasp():
    """Re-running item 13's class over every float of ``[controller]``: ``delta = 1e-300``
    was accepted and made the thumb's sweep 1e300 ticks long (a hang)."""
    from tactile_bullet.datasets.sweeps import Sweep

    with pytest.raises(UsageError, match="delta 1e-300 rad per tick is out of range"):
        Sweep.from_dict({"controller": {"delta": 1e-300}, "shapes": [{"name": "sphere"}]})
