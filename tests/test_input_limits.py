"""Every path a user names is checked one way before it is read (a regular file, or the folder a
format expects, within a size bound per kind; a FIFO is never opened), archives are checked
member by member before they are inflated, and declared counts are bounded before any loop."""

from __future__ import annotations

import json
import os
import threading
import zipfile

import numpy as np
import pytest
from cli_helpers import run_error

from tactile_bullet import files
from tactile_bullet.cli import main
from tactile_bullet.errors import UsageError


@pytest.fixture
def fifo(tmp_path):
    """``fifo(name) -> path``: a FIFO whose writer end opens (and closes at once) when a reader
    opens it, so code that wrongly opens it sees an empty file instead of hanging the suite."""
    made = []

    def make(name: str):
        path = tmp_path / name
        os.mkfifo(path)

        def writer():
            with open(path, "wb"):
                pass

        threading.Thread(target=writer, daemon=True).start()
        made.append(path)
        return path

    yield make
    for path in made:  # release writers still waiting for a reader
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        os.close(fd)


def _model(tmp_path, synthetic_split):
    from tactile_bullet.experiments import workflow
    from tactile_bullet.learn.models import save_model

    model = workflow.train(synthetic_split[0], "signature", "knn")
    return save_model(tmp_path / "model.npz", model)


def test_fifo_and_device_inputs_exit_2_without_being_opened(tmp_path, capsys, fifo):
    out = str(tmp_path / "out")
    for name in ("rec.bag", "rec.csv", "rec.parquet"):
        err = run_error(capsys, ["import", str(fifo(name)), "--out", out])
        assert "is a FIFO, not a regular file" in err
    err = run_error(capsys, ["import", "/dev/zero", "--out", out])
    assert "is a character device, not a regular file" in err
    bag = tmp_path / "a.bag"
    bag.write_bytes(b"\0" * 4096)  # a sparse or zeroed file is not read into memory whole
    assert "does not start as a .bag file does" in run_error(
        capsys, ["import", str(bag), "--out", out]
    )
    cal = str(fifo("cal.toml"))
    err = run_error(capsys, ["import", str(bag), "--out", out, "--calibration", cal])
    assert "calibration file" in err and "FIFO" in err
    err = run_error(capsys, ["import", str(bag), "--out", out, "--calibration", "/dev/urandom"])
    assert "calibration file /dev/urandom is a character device" in err
    err = run_error(capsys, ["generate", "--config", str(fifo("c.toml")), "--out", out])
    assert "config file" in err and "FIFO" in err
    err = run_error(capsys, ["generate", "--config", "/dev/zero", "--out", out])
    assert "config file /dev/zero is a character device" in err
    fifo("manifest.json")  # not taken for a dataset's manifest, never opened
    err = run_error(capsys, ["verify", "--data", str(tmp_path)])
    assert "neither a dataset nor a folder of grasp records" in err
    assert not (tmp_path / "out").exists()


def test_each_kind_of_input_has_a_size_bound(tmp_path, capsys, monkeypatch):
    cal = tmp_path / "cal.toml"
    cal.write_text("[joints]\n" + "".join(f"# padding {i}\n" for i in range(100)))
    monkeypatch.setitem(files.INPUT_LIMITS, "calibration file", 1000)
    err = run_error(capsys, ["import", "x.bag", "--out", str(tmp_path / "o"),
                             "--calibration", str(cal)])  # fmt: skip
    assert "over the 1,000-byte limit for a calibration file" in err
    csv = tmp_path / "big.csv"
    csv.write_text("time,FFJ3\n" + "".join(f"{i * 0.01},0.1\n" for i in range(200)))
    monkeypatch.setitem(files.INPUT_LIMITS, "table", 1000)
    err = run_error(capsys, ["import", str(csv), "--out", str(tmp_path / "o")])
    assert "over the 1,000-byte limit" in err


def test_input_path_accepts_a_folder_only_where_the_format_is_one(tmp_path):
    assert files.input_path(tmp_path, "recording", folder=True) == tmp_path
    with pytest.raises(UsageError, match="is a folder, not a file"):
        files.input_path(tmp_path, "model file")


def _bomb(path, good: dict, extra: dict):
    """An .npz holding ``good`` members plus ``extra`` ones, written as numpy would."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, arr in {**good, **extra}.items():
            with zf.open(f"{name}.npy", "w", force_zip64=True) as fh:
                np.lib.format.write_array(fh, np.asarray(arr), allow_pickle=False)


def test_model_with_an_unknown_or_oversized_member_is_refused_before_inflating(
    tmp_path, capsys, synthetic_split, monkeypatch
):
    from tactile_bullet.learn import models

    path = _model(tmp_path, synthetic_split)
    with np.load(path) as data:
        good = {k: data[k] for k in data.files}
    _bomb(tmp_path / "extra.npz", good, {"padding": np.zeros(1000)})
    err = run_error(capsys, ["identify", "--model", str(tmp_path / "extra.npz"),
                             "--shape", "sphere", "--param", "radius=0.04"])  # fmt: skip
    assert "unexpected member 'padding.npy'" in err
    monkeypatch.setattr(models, "MODEL_MEMBER_LIMIT", 1000)
    with pytest.raises(UsageError) as info:
        models.load_model(path)
    assert "not a tactile-bullet model (has a member" in str(info.value)
    assert "over the 1,000-byte limit" in str(info.value)


def test_record_and_shard_bombs_are_refused_and_the_dataset_not_called_sound(
    tmp_path, capsys, synthetic_split
):
    from tactile_bullet.realhand.recordings import write_dataset
    from tactile_bullet.records import load_record, save_record

    record = synthetic_split[0][0]
    save_record(record, tmp_path / "r.npz")
    with np.load(tmp_path / "r.npz") as data:
        good = {k: data[k] for k in data.files}
    _bomb(tmp_path / "bomb.npz", good, {"zeros": np.zeros(10)})
    with pytest.raises(UsageError, match="unexpected member 'zeros.npy'"):
        load_record(tmp_path / "bomb.npz")
    # a header that claims more than the member holds (numpy would allocate it first)
    with zipfile.ZipFile(tmp_path / "liar.npz", "w") as zf:
        for name, arr in good.items():
            if name == "time":
                continue
            with zf.open(f"{name}.npy", "w") as fh:
                np.lib.format.write_array(fh, arr, allow_pickle=False)
        header = np.lib.format.header_data_from_array_1_0(np.zeros(10**9))
        with zf.open("time.npy", "w") as fh:  # a "time" member that claims 8 GB
            np.lib.format.write_array_header_1_0(fh, header)
    with pytest.raises(UsageError, match="whose header does not fit it"):
        load_record(tmp_path / "liar.npz")

    ds = tmp_path / "ds"
    write_dataset(synthetic_split[0][:3], ds, {"test": True})
    shard = ds / "shard-00000.npz"
    with np.load(shard) as data:
        good = {k: data[k] for k in data.files}
    _bomb(shard, good, {"zeros": np.zeros(1000)})
    manifest = json.loads((ds / "manifest.json").read_text())
    import hashlib

    entry = manifest["shards"][0]
    entry["sha256"] = hashlib.sha256(shard.read_bytes()).hexdigest()
    entry["bytes"] = shard.stat().st_size  # the manifest vouches for the bomb's bytes
    (ds / "manifest.json").write_text(json.dumps(manifest))
    assert main(["verify", "--data", str(ds)]) != 0
    assert "unexpected member" in capsys.readouterr().out


def test_a_manifest_declaring_a_huge_task_count_is_refused_before_any_loop(
    tmp_path, capsys, synthetic_split
):
    from tactile_bullet.realhand.recordings import write_dataset

    ds = tmp_path / "ds"
    write_dataset(synthetic_split[0][:3], ds, {"test": True})
    manifest = json.loads((ds / "manifest.json").read_text())
    manifest["tasks"] = 1_000_000_000_000
    (ds / "manifest.json").write_text(json.dumps(manifest))
    assert main(["verify", "--data", str(ds), "--json"]) == 2
    problems = json.loads(capsys.readouterr().out)["problems"]
    assert "tasks 1,000,000,000,000 is over the 1,000,000" in problems[0]["problem"]


def test_import_checks_its_output_before_reading_any_recording(tmp_path, capsys, monkeypatch):
    from tactile_bullet.realhand import recordings

    def never(*args, **kwargs):
        raise AssertionError("a recording was read before --out was checked")

    monkeypatch.setattr(recordings, "read_recording", never)
    csv = tmp_path / "r.csv"
    csv.write_text("time,FFJ3\n0,0\n")
    err = run_error(capsys, ["import", str(csv), "--out", str(tmp_path / "no" / "such" / "ds")])
    assert "its folder" in err and "does not exist" in err
