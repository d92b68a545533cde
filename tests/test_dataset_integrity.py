"""Damaged data is never used silently: manifests validated, shards checked against their
sha256, damaged parts an error unless --allow-partial, `verify`, and --resume re-simulating
what is damaged (issue 10, item 1).

Datasets here are written by `generate` with a stand-in for the simulator (synthetic records
from the wrapping theory, deterministic per task), so they take milliseconds."""

from __future__ import annotations

import json
import os
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_error
from synthetic import make_record

from tactile_bullet.cli import main
from tactile_bullet.datasets.dataset import PartialDataWarning, open_dataset, read_records, verify
from tactile_bullet.datasets.generate import generate
from tactile_bullet.datasets.integrity import DamagedDataset
from tactile_bullet.datasets.sweeps import Sweep
from tactile_bullet.errors import UsageError
from tactile_bullet.experiments.workflow import records_from
from tactile_bullet.records import save_record

MIX = """
name = "mix"
[[shapes]]
name = "cylinder"
params = { radius = [0.025, 0.03, 0.035, 0.04, 0.045] }
offset_x = [-0.004, 0.004]
[[shapes]]
name = "sphere"
params = { radius = [0.04, 0.0425, 0.045, 0.0475, 0.05] }
offset_x = [-0.004, 0.004]
"""
"""20 tasks; with 4 per shard, 5 shards of 4 records (cylinders in 0-2, spheres in 2-4)."""
SHARD_SIZE = 4
N_RECORDS = 20


def synthetic_grasp(task):
    """A stand-in for the simulator: a theory-made record, the same every time for a task."""
    rng = np.random.default_rng(task.seed)
    record = make_record(task.shape, task.params, rng, offset_x=task.pose.offset[0])
    return record.metadata(), record.arrays()


def mix_sweep(tmp_path: Path) -> Sweep:
    path = tmp_path / "mix.toml"
    path.write_text(MIX)
    return Sweep.from_toml(path)


def write(sweep: Sweep, out: Path, **kw) -> dict:
    kw.setdefault("shard_size", SHARD_SIZE)
    return generate(sweep, out, workers=0, task_fn=synthetic_grasp, **kw)


@pytest.fixture(scope="module")
def pristine(tmp_path_factory) -> Path:
    """A sound dataset, written once; tests damage copies of it."""
    folder = tmp_path_factory.mktemp("pristine")
    doc = write(mix_sweep(folder), folder / "ds")
    assert doc["records"] == N_RECORDS and doc["shards"] == 5
    return folder / "ds"


@pytest.fixture
def ds(pristine, tmp_path) -> Path:
    out = tmp_path / "ds"
    shutil.copytree(pristine, out)
    return out


def flip_byte(path: Path, at: int = 200) -> None:
    data = bytearray(path.read_bytes())
    data[at] ^= 0xFF
    path.write_bytes(bytes(data))


def truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def delete(path: Path) -> None:
    path.unlink()


DAMAGE = {"flipped byte": flip_byte, "truncated": truncate, "deleted": delete}
SAYS = {"flipped byte": "checksum mismatch", "truncated": "truncated", "deleted": "missing"}


def manifest(ds: Path) -> dict:
    return json.loads((ds / "manifest.json").read_text())


def rewrite_manifest(ds: Path, change) -> None:
    data = manifest(ds)
    change(data)
    (ds / "manifest.json").write_text(json.dumps(data))


def files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


# --- reading a damaged dataset is an error, or a counted partial read -----------------------


@pytest.mark.parametrize("damage", DAMAGE)
def test_a_damaged_shard_is_an_error_naming_it(ds, damage):
    DAMAGE[damage](ds / "shard-00001.npz")
    with pytest.raises(DamagedDataset, match=f"shard-00001.npz: {SAYS[damage]}"):
        list(open_dataset(ds))
    with pytest.raises(UsageError, match="shard-00001.npz"):
        records_from(ds)


@pytest.mark.parametrize("damage", DAMAGE)
def test_train_and_evaluate_refuse_a_damaged_dataset(ds, pristine, tmp_path, capsys, damage):
    model = tmp_path / "model.npz"
    assert main(["train", "--data", str(pristine), "--out", str(model)]) == 0
    DAMAGE[damage](ds / "shard-00002.npz")
    err = run_error(capsys, ["train", "--data", str(ds), "--out", str(tmp_path / "m2.npz")])
    assert "shard-00002.npz" in err and SAYS[damage] in err
    assert not (tmp_path / "m2.npz").exists()
    err = run_error(capsys, ["evaluate", "--model", str(model), "--data", str(ds), "--json"])
    assert "shard-00002.npz" in err and SAYS[damage] in err
    err = run_error(capsys, ["compare", "--data", str(ds), "--classifier", "knn",
                             "--descriptor", "signature"])  # fmt: skip
    assert "shard-00002.npz" in err


def test_allow_partial_skips_the_damage_and_says_how_many_records(ds, pristine, tmp_path, capsys):
    model = tmp_path / "model.npz"
    assert main(["train", "--data", str(pristine), "--out", str(model)]) == 0
    capsys.readouterr()
    flip_byte(ds / "shard-00001.npz")
    delete(ds / "shard-00003.npz")
    args = ["--data", str(ds), "--allow-partial", "--json"]
    assert main(["train", *args, "--out", str(tmp_path / "partial.npz")]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["train_records"] == N_RECORDS - 8
    assert doc["data_skipped"]["records"] == 8
    assert sorted(Path(p["file"]).name for p in doc["data_skipped"]["problems"]) == [
        "shard-00001.npz", "shard-00003.npz"]  # fmt: skip
    assert main(["evaluate", "--model", str(model), *args]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["data_skipped"]["records"] == 8
    assert sum(sum(row) for row in doc["confusion_matrix"]) == N_RECORDS - 8
    assert main(["evaluate", "--model", str(model), "--data", str(ds), "--allow-partial"]) == 0
    out = capsys.readouterr().out
    assert "8 records skipped" in out and "shard-00001.npz: checksum mismatch" in out
    # a sound dataset read with --allow-partial says that nothing was skipped
    assert main(["evaluate", "--model", str(model), "--data", str(pristine), "--json",
                 "--allow-partial"]) == 0  # fmt: skip
    assert json.loads(capsys.readouterr().out)["data_skipped"] == {"records": 0, "problems": []}


def test_the_python_api_reads_partially_only_when_asked_and_warns(ds):
    truncate(ds / "shard-00004.npz")
    with pytest.raises(DamagedDataset):
        records_from(ds)
    with pytest.warns(PartialDataWarning, match="4 records skipped"):
        records = records_from(ds, allow_partial=True)
    assert len(records) == N_RECORDS - 4
    loaded = read_records(ds, allow_partial=True)
    assert loaded.skipped_records == 4 and len(loaded.records) == N_RECORDS - 4
    data = open_dataset(ds, allow_partial=True)
    assert len(data.metadata()["shape"]) == N_RECORDS - 4 == len(data.metadata()["task"])
    assert data.corrupted == ["shard-00004.npz"] and data.skipped_records == 4


def test_an_unfinished_dataset_is_partial_data(ds):
    """A run killed before its last blocks: reading it trains on a subset, so it is refused
    like damage (and counted under --allow-partial)."""
    rewrite_manifest(ds, lambda m: m.update(shards=m["shards"][:3]))
    delete(ds / "shard-00003.npz")
    delete(ds / "shard-00004.npz")
    with pytest.raises(DamagedDataset, match="shard-00003.npz: not generated"):
        open_dataset(ds)
    loaded = read_records(ds, allow_partial=True)
    assert len(loaded.records) == 12 and "8 tasks never generated" in loaded.summary()


def test_a_damaged_record_file_in_a_folder_is_named(tmp_path):
    folder = tmp_path / "records"
    folder.mkdir()
    for i, shape in enumerate(["cylinder", "sphere", "cone"]):
        save_record(make_record(shape), folder / f"rec{i:05d}.npz")
    truncate(folder / "rec00001.npz")
    with pytest.raises(UsageError, match="rec00001.npz"):
        records_from(folder)
    with pytest.warns(PartialDataWarning, match="1 record skipped"):
        assert [r.shape for r in records_from(folder, allow_partial=True)] == ["cylinder", "cone"]
    delete(folder / "rec00001.npz")
    os.mkfifo(folder / "rec00001.npz")  # reading it would block forever
    with pytest.raises(UsageError, match="rec00001.npz is not a regular file"):
        records_from(folder)


def test_a_lock_file_that_links_elsewhere_is_not_followed(ds, tmp_path):
    (ds / ".lock").unlink()
    os.symlink(tmp_path / "elsewhere", ds / ".lock")
    with pytest.raises(UsageError, match="is a link"):
        write(mix_sweep(ds.parent), ds, resume=True)
    assert not (tmp_path / "elsewhere").exists()


# --- manifests are validated on load --------------------------------------------------------


def duplicate_entry(m):
    m["shards"].append(dict(m["shards"][1]))


def outside(name):
    def change(m):
        m["shards"][2]["file"] = name

    return change


def drop_field(field):
    def change(m):
        del m["shards"][0][field]

    return change


def more_records(m):
    m["shards"][0]["records"] += 1


def unknown_format(m):
    m["format"] = 99


def no_config(m):
    del m["config"]


TAMPERED = {
    "duplicated entry": (duplicate_entry, "shard-00001.npz: listed twice"),
    "parent path": (outside("../x"), "'../x' is not a plain file name"),
    "absolute path": (outside("/dev/zero"), "'/dev/zero' is not a plain file name"),
    "nested path": (outside("sub/shard-00002.npz"), "is not a plain file name"),
    "no sha256": (drop_field("sha256"), "entry without sha256"),
    "no tasks": (drop_field("tasks"), "entry without tasks"),
    "count": (more_records, "lists 5 records but 4 tasks"),
    "format": (unknown_format, "dataset format 99 is not supported"),
    "config": (no_config, "missing field config"),
}


@pytest.mark.parametrize("case", TAMPERED)
def test_a_tampered_manifest_is_refused_with_the_reason(ds, tmp_path, capsys, case):
    change, message = TAMPERED[case]
    rewrite_manifest(ds, change)
    with pytest.raises(UsageError, match=message):
        list(open_dataset(ds))
    err = run_error(capsys, ["train", "--data", str(ds), "--out", str(tmp_path / "m.npz")])
    assert message.split(": ")[-1].strip("'") in err
    assert main(["verify", "--data", str(ds)]) == 2
    assert message in capsys.readouterr().out


def test_a_duplicated_entry_never_doubles_the_records(ds):
    """The issue's probe: a shard listed twice trained on 312 of 280 records."""
    rewrite_manifest(ds, duplicate_entry)
    loaded = read_records(ds, allow_partial=True)
    assert len(loaded.records) == N_RECORDS
    assert [str(p) for p in loaded.problems] == [f"{ds}/shard-00001.npz: listed twice in the "
                                                 "manifest"]  # fmt: skip


def test_a_shard_that_links_outside_the_dataset_is_refused(ds, tmp_path):
    elsewhere = tmp_path / "elsewhere.npz"
    shutil.move(ds / "shard-00002.npz", elsewhere)
    os.symlink(elsewhere, ds / "shard-00002.npz")
    with pytest.raises(DamagedDataset, match="shard-00002.npz: a link to .*outside the dataset"):
        open_dataset(ds)
    os.unlink(ds / "shard-00002.npz")
    os.symlink("/dev/zero", ds / "shard-00002.npz")
    with pytest.raises(DamagedDataset, match="outside the dataset"):
        open_dataset(ds)


def test_a_shard_that_is_not_a_regular_file_is_refused(ds):
    delete(ds / "shard-00000.npz")
    os.mkfifo(ds / "shard-00000.npz")  # reading it would block forever
    with pytest.raises(DamagedDataset, match="shard-00000.npz: not a regular file"):
        open_dataset(ds)


# --- verify ---------------------------------------------------------------------------------


def test_verify_passes_a_sound_dataset(pristine, capsys):
    assert main(["verify", "--data", str(pristine), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["ok"] and doc["records"] == doc["listed_records"] == N_RECORDS
    assert doc["problems"] == [] and doc["shards"] == 5 and doc["tasks"] == N_RECORDS
    assert main(["verify", "--data", str(pristine)]) == 0
    assert "20 of 20 records readable" in capsys.readouterr().out


def test_verify_names_each_problem(ds, capsys):
    flip_byte(ds / "shard-00000.npz")
    truncate(ds / "shard-00002.npz")
    delete(ds / "shard-00004.npz")
    rewrite_manifest(ds, duplicate_entry)
    assert main(["verify", "--data", str(ds), "--json"]) == 2
    captured = capsys.readouterr()
    doc = json.loads(captured.out)
    assert not doc["ok"] and doc["records"] == 8 and doc["listed_records"] == N_RECORDS
    found = {Path(p["file"]).name: p["problem"] for p in doc["problems"]}
    assert sorted(found) == [f"shard-0000{i}.npz" for i in (0, 1, 2, 4)]
    assert found["shard-00000.npz"].startswith("checksum mismatch")
    assert found["shard-00001.npz"] == "listed twice in the manifest"
    assert found["shard-00002.npz"].startswith("truncated")
    assert found["shard-00004.npz"] == "missing"
    assert captured.err.strip() == f"tactile-bullet verify: error: {ds} has 4 problems"


def test_verify_checks_record_folders_and_unreadable_manifests(ds, tmp_path, capsys):
    folder = tmp_path / "records"
    folder.mkdir()
    save_record(make_record("sphere"), folder / "rec00000.npz")
    assert main(["verify", "--data", str(folder)]) == 0
    assert "1 readable grasp record: sound" in capsys.readouterr().out
    flip_byte(folder / "rec00000.npz", at=-30)
    assert verify(folder)["problems"][0]["file"] == str(folder / "rec00000.npz")
    (ds / "manifest.json").write_text('{"format": 1, "shards": [')
    assert main(["verify", "--data", str(ds), "--json"]) == 2
    doc = json.loads(capsys.readouterr().out)
    assert doc["problems"][0]["file"].endswith("manifest.json")
    assert "unreadable" in doc["problems"][0]["problem"]
    run_error(capsys, ["verify", "--data", str(tmp_path / "nothing")])
    (tmp_path / "empty").mkdir()
    assert "neither a dataset" in run_error(capsys, ["verify", "--data", str(tmp_path / "empty")])


# --- --resume re-simulates what is damaged or missing ---------------------------------------


def test_resume_resimulates_damaged_missing_and_mislisted_shards_byte_equal(ds, pristine):
    flip_byte(ds / "shard-00000.npz")
    truncate(ds / "shard-00001.npz")
    delete(ds / "shard-00003.npz")
    rewrite_manifest(ds, lambda m: (duplicate_entry(m), outside("../x")(m)))
    doc = write(mix_sweep(ds.parent), ds, resume=True)
    assert doc["records"] == N_RECORDS and doc["failed"] == 0
    assert sorted(Path(p["file"]).name for p in doc["repaired"]) == [
        "shard-00000.npz", "shard-00001.npz", "shard-00001.npz", "shard-00002.npz",
        "shard-00003.npz"]  # fmt: skip
    assert files(ds) == files(pristine)
    again = write(mix_sweep(ds.parent), ds, resume=True)
    assert again["repaired"] == [] and files(ds) == files(pristine)


def test_a_killed_resume_never_lists_the_damaged_shard_again(ds, pristine):
    """The damaged entry leaves the manifest before simulation starts: a resume killed
    before re-writing the shard leaves a dataset that says it is unfinished."""
    flip_byte(ds / "shard-00002.npz")

    def killed(task):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        generate(mix_sweep(ds.parent), ds, workers=0, shard_size=SHARD_SIZE, resume=True,
                 task_fn=killed)  # fmt: skip
    with pytest.raises(DamagedDataset, match="shard-00002.npz: not generated"):
        open_dataset(ds)
    write(mix_sweep(ds.parent), ds, resume=True)
    assert files(ds) == files(pristine)


def test_generate_without_resume_says_the_dataset_is_damaged(ds):
    delete(ds / "shard-00001.npz")
    with pytest.raises(UsageError, match=r"damaged \(.*shard-00001.npz: missing.*use --resume"):
        write(mix_sweep(ds.parent), ds)


def test_a_model_file_cut_short_is_refused_by_name(pristine, tmp_path, capsys):
    model = tmp_path / "model.npz"
    assert main(["train", "--data", str(pristine), "--out", str(model)]) == 0
    truncate(model)
    err = run_error(capsys, ["evaluate", "--model", str(model), "--data", str(pristine)])
    assert str(model) in err
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a sound dataset reads without any warning
        assert len(records_from(pristine, allow_partial=True)) == N_RECORDS


def test_sequential_refuses_a_damaged_dataset_unless_allowed(ds, tmp_path, capsys):
    from argparse import Namespace

    from tactile_bullet.cli.sequential import load_data

    delete(ds / "shard-00000.npz")
    err = run_error(capsys, ["sequential", "--data", str(ds), "--out", str(tmp_path / "seq")])
    assert "shard-00000.npz: missing" in err
    args = Namespace(synthetic=False, data=ds, descriptor="signature", descriptor_param=None,
                     allow_partial=True)  # fmt: skip
    X, y, names = load_data(args)  # what `sequential --allow-partial` learns from
    assert len(X) == len(y) == N_RECORDS - 4 and names == ["cylinder", "sphere"]
    assert "--allow-partial: 4 records skipped" in capsys.readouterr().out


def test_messages_count_in_the_singular(tmp_path, capsys):
    # "1 shards", "(1 records)" read as bugs; a one-shard dataset with one damaged record says
    # "1 shard" and "(1 record)"
    out = tmp_path / "one"
    assert write(mix_sweep(tmp_path), out, shard_size=N_RECORDS)["shards"] == 1
    assert main(["verify", "--data", str(out)]) == 0
    head = capsys.readouterr().out.splitlines()[0]
    assert f"{N_RECORDS} of {N_RECORDS} records readable, 1 shard listed for " in head
    assert "(0 tasks the simulator" in head
    from tactile_bullet.datasets.integrity import Problem

    assert str(Problem("shard-00000.npz", "damaged", records=1)).endswith("damaged (1 record)")
    from tactile_bullet.console import plural

    assert [plural(n, "file") for n in (0, 1, 2)] == ["0 files", "1 file", "2 files"]
    assert plural(1, "class", "classes") == "1 class"
    assert plural(3, "class", "classes") == "3 classes"
