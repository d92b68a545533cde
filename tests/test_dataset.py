"""The dataset on disk: round trip, resume after a kill, corrupted shards, refusals."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from synthetic import SMALL_SWEEP as SMALL

from tactile_bullet.datasets.dataset import open_dataset, read_records, verify
from tactile_bullet.datasets.generate import generate
from tactile_bullet.datasets.integrity import DamagedDataset
from tactile_bullet.datasets.sweeps import Sweep
from tactile_bullet.errors import UsageError


def fake_grasp(task):
    """A stand-in for the simulator: a deterministic record from the task alone."""
    rng = np.random.default_rng(task.seed)
    n = 24
    meta = {
        "format": 1, "shape": task.shape, "params": task.params,
        "pose": {"offset": list(task.pose.offset), "rotation": task.pose.rotation},
        "controller": {"mode": "torque"}, "seed": task.seed,
        "fingers_in_contact": ["ff"], "flags": [], "steps": 10,
        "joint_names": [f"J{i}" for i in range(n)],
    }  # fmt: skip
    arrays = {
        "time": np.arange(5) / 60.0,
        "angles": rng.normal(size=(5, n)),
        "efforts": rng.normal(size=(5, n)),
        "final_angles": rng.normal(size=n),
        "contact_link": np.array(["ffdistal"], dtype="U16"),
        "contact_position": rng.normal(size=(1, 3)),
        "contact_normal": rng.normal(size=(1, 3)),
        "contact_force": rng.random(1),
    }
    if task.index == 5:
        return "UsageError: pose puts the sphere inside the open hand"
    return meta, arrays


def sweep(tmp_path, text=SMALL, name="sweep.toml"):
    path = tmp_path / name
    path.write_text(text)
    return Sweep.from_toml(path)


MANY = """
name = "many"
[[shapes]]
name = "cylinder"
params = { radius = [0.025, 0.03, 0.035, 0.04, 0.045] }
offset_x = [-0.004, 0.0, 0.004]
"""


def test_round_trip_keeps_every_record_and_reports_failures(tmp_path):
    out = tmp_path / "ds"
    doc = generate(sweep(tmp_path, MANY), out, workers=0, shard_size=4, task_fn=fake_grasp)
    assert doc["records"] == 14 and doc["failed"] == 1 and doc["shards"] == 4
    data = open_dataset(out)
    assert len(data) == 14
    records = list(data)
    expected = [fake_grasp(t) for t in sweep(tmp_path, MANY).tasks(0)]
    expected = [e for e in expected if not isinstance(e, str)]
    for rec, (meta, arrays) in zip(records, expected, strict=True):
        assert rec.seed == meta["seed"]
        assert np.array_equal(rec.angles, arrays["angles"])
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["failed"] == [
        {"task": 5, "error": "UsageError: pose puts the sphere inside the open hand"}
    ]
    assert {"tactile_bullet", "pybullet", "numpy"} <= set(manifest["software"])


def test_lazy_records_skip_time_series_and_features_come_shard_by_shard(tmp_path):
    out = tmp_path / "ds"
    generate(sweep(tmp_path, MANY), out, workers=0, shard_size=4, task_fn=fake_grasp)
    data = open_dataset(out)
    light = list(data.records(full=False))
    assert all(r.angles.shape[0] == 0 for r in light)
    assert all(r.final_angles.shape == (24,) for r in light)

    class Final:
        def transform(self, records):
            return np.array([r.final_angles for r in records])

    assert data.features(Final()).shape == (14, 24)
    assert list(data.labels()) == ["cylinder"] * 14


def test_metadata_comes_as_arrays_for_binning(tmp_path):
    text = (
        MANY
        + """
[[shapes]]
name = "sphere"
params = { radius = [0.045] }
rotation_deg = [10]
"""
    )
    out = tmp_path / "ds"
    generate(sweep(tmp_path, text), out, workers=0, shard_size=4, task_fn=fake_grasp)
    meta = open_dataset(out).metadata()
    records = list(open_dataset(out).records())
    assert list(meta["shape"]) == [r.shape for r in records] == ["cylinder"] * 14 + ["sphere"]
    assert np.array_equal(meta["offset"], [r.pose.offset for r in records])
    assert np.allclose(meta["rotation"][-1], np.radians(10)) and not meta["rotation"][:-1].any()
    radius = meta["params"]["radius"]
    assert sorted(set(radius[:14])) == [0.025, 0.03, 0.035, 0.04, 0.045]
    assert np.isnan(meta["params"]["length"][-1])  # a sphere has no length
    assert list(meta["task"]) == [i for i in range(16) if i != 5]  # task 5 failed


def test_a_corrupted_shard_is_an_error_unless_a_partial_read_is_allowed(tmp_path):
    out = tmp_path / "ds"
    generate(sweep(tmp_path, MANY), out, workers=0, shard_size=4, task_fn=fake_grasp)
    shard = out / "shard-00001.npz"
    data = shard.read_bytes()
    shard.write_bytes(data[:100] + bytes([data[100] ^ 0xFF]) + data[101:])
    with pytest.raises(DamagedDataset, match="shard-00001.npz: checksum mismatch"):
        list(open_dataset(out))
    dataset = open_dataset(out, allow_partial=True)
    records = list(dataset)
    assert len(records) == 14 - 3  # shard 1 held tasks 4, 6, 7 (5 failed)
    assert dataset.corrupted == ["shard-00001.npz"] and dataset.skipped_records == 3


def test_out_holding_a_different_dataset_is_refused_and_left_alone(tmp_path):
    out = tmp_path / "ds"
    generate(sweep(tmp_path), out, workers=0, shard_size=2, task_fn=fake_grasp)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    with pytest.raises(UsageError, match="different dataset .sweep 'small'"):
        generate(sweep(tmp_path, MANY), out, workers=0, task_fn=fake_grasp, shard_size=2)
    with pytest.raises(UsageError, match="different dataset .shard-size 2"):
        generate(sweep(tmp_path), out, workers=0, shard_size=3, resume=True, task_fn=fake_grasp)
    with pytest.raises(UsageError, match="already holds this dataset, complete; use --resume"):
        generate(sweep(tmp_path), out, workers=0, shard_size=2, task_fn=fake_grasp)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_resuming_under_another_engine_version_is_refused_before_any_grasp(tmp_path):
    out = tmp_path / "ds"
    generate(sweep(tmp_path, MANY), out, workers=0, shard_size=4, task_fn=fake_grasp)
    manifest = json.loads((out / "manifest.json").read_text())
    assert {"pybullet", "mujoco"} <= set(manifest["software"])  # the engines' physics
    manifest["software"]["pybullet"] = "0.0.1"
    (out / "manifest.json").write_text(json.dumps(manifest))
    # complete: nothing would be simulated, so nothing mixes; the dataset is left as it is
    generate(sweep(tmp_path, MANY), out, workers=0, shard_size=4, resume=True, task_fn=fake_grasp)
    (out / "shard-00001.npz").unlink()  # a block to simulate again
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    ran = []
    with pytest.raises(UsageError, match="simulated with pybullet 0.0.1, this environment has"):
        generate(sweep(tmp_path, MANY), out, workers=0, shard_size=4, resume=True,
                 task_fn=lambda t: ran.append(t) or fake_grasp(t))  # fmt: skip
    assert ran == []
    after = {p.name: p.read_bytes() for p in out.iterdir()}
    assert after.keys() == before.keys() and after["shard-00000.npz"] == before["shard-00000.npz"]


def test_resume_where_there_is_no_dataset_is_refused_and_writes_nothing(tmp_path):
    # a mistyped --out with --resume would otherwise start the whole run afresh
    with pytest.raises(UsageError, match="--resume: .*typo holds no dataset to resume"):
        generate(sweep(tmp_path), tmp_path / "typo", workers=0, resume=True, task_fn=fake_grasp)
    assert not (tmp_path / "typo").exists()


def test_a_resume_that_differs_in_engine_names_the_engine(tmp_path):
    out = tmp_path / "ds"
    generate(sweep(tmp_path), out, workers=0, shard_size=2, task_fn=fake_grasp)
    mujoco = sweep(tmp_path, SMALL.replace('name = "small"', 'name = "small"\nengine = "mujoco"'),
                   "m.toml")  # fmt: skip
    with pytest.raises(UsageError, match=r"sweep 'small': engine bullet there, mujoco here"):
        generate(mujoco, out, workers=0, shard_size=2, resume=True, task_fn=fake_grasp)


def test_shards_without_their_manifest_are_named_as_such(tmp_path):
    out = tmp_path / "ds"
    generate(sweep(tmp_path, MANY), out, workers=0, shard_size=4, task_fn=fake_grasp)
    (out / "manifest.json").unlink()
    for read in (lambda: read_records(out), lambda: verify(out)):
        with pytest.raises(UsageError, match=r"shards \(shard-00000.npz, ...\) but no manifest"):
            read()


def test_out_that_is_a_non_empty_folder_is_refused(tmp_path):
    (tmp_path / "ds").mkdir()
    (tmp_path / "ds" / "notes.txt").write_text("mine")
    with pytest.raises(UsageError, match="not an empty directory"):
        generate(sweep(tmp_path), tmp_path / "ds", workers=0, task_fn=fake_grasp)
    assert [p.name for p in (tmp_path / "ds").iterdir()] == ["notes.txt"]
    assert (tmp_path / "ds" / "notes.txt").read_text() == "mine"


def test_a_second_writer_on_the_same_dataset_is_refused(tmp_path):
    import fcntl

    out = tmp_path / "ds"
    generate(sweep(tmp_path), out, workers=0, shard_size=8, task_fn=fake_grasp)
    with open(out / ".lock", "a") as held:  # as a generate still running would hold it
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        with pytest.raises(UsageError, match="another generate is writing"):
            generate(sweep(tmp_path), out, workers=0, shard_size=8, resume=True,
                     task_fn=fake_grasp)  # fmt: skip
    doc = generate(sweep(tmp_path), out, workers=0, shard_size=8, resume=True, task_fn=fake_grasp)
    assert doc["records"] == 4  # the lock went with its holder


def listed_shards(out) -> list:
    """The shards the manifest lists (it is replaced atomically, so always whole)."""
    try:
        return json.loads((out / "manifest.json").read_text())["shards"]
    except FileNotFoundError:
        return []


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    """The SMALL sweep simulated without interruption, one grasp per shard: what an
    interrupted run must equal, byte for byte, once resumed."""
    folder = tmp_path_factory.mktemp("whole")
    config = folder / "small.toml"
    config.write_text(SMALL)
    generate(Sweep.from_toml(config), folder / "ds", workers=0, shard_size=1)
    return folder / "ds"


def files(folder) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def start_generate(config, out, workers: int, **pipes):
    """`generate` of the SMALL sweep in a process group of its own, once its first shard is
    listed in the manifest (so a kill lands mid-run)."""
    cmd = [sys.executable, "-m", "tactile_bullet.cli", "generate", "--config", str(config),
           "--out", str(out), "--shard-size", "1", "--workers", str(workers)]  # fmt: skip
    proc = subprocess.Popen(cmd, start_new_session=True, **pipes)
    deadline = time.time() + 120
    while time.time() < deadline and not listed_shards(out) and proc.poll() is None:
        time.sleep(0.02)
    assert proc.poll() is None and listed_shards(out), "generate should still be running"
    return proc


def test_killed_run_resumes_to_the_same_bytes_as_an_uninterrupted_one(tmp_path, whole):
    """A real run (real simulator, worker processes) killed once its first shard is on disk,
    then resumed, holds exactly the files of a run that was never interrupted."""
    config = tmp_path / "small.toml"
    config.write_text(SMALL)
    killed = tmp_path / "killed"
    proc = start_generate(config, killed, 1, stdout=subprocess.DEVNULL,
                          stderr=subprocess.DEVNULL)  # fmt: skip
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert 1 <= len(listed_shards(killed)) < 4, "the kill should land mid-run"
    (killed / ".shard-00003.999.tmp.npz").write_bytes(b"half a shard")  # as a kill leaves

    doc = generate(Sweep.from_toml(config), killed, workers=0, resume=True)  # its shard size
    assert doc["records"] == 4 and doc["shards"] == 4
    assert files(killed) == files(whole)
    a, b = list(open_dataset(killed)), list(open_dataset(whole))
    assert len(a) == len(b) == 4
    assert all(x.equals(y) for x, y in zip(a, b, strict=True))


def live_processes(group: int) -> list[str]:
    """Command lines of the processes of a process group still running, read from /proc
    (zombies, which have exited and wait for init to reap them, left out)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            state, _parent, pgrp = (entry / "stat").read_text().rsplit(")", 1)[1].split()[:3]
            command = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except (OSError, ValueError):
            continue  # exited meanwhile
        if int(pgrp) == group and state != "Z":
            found.append(f"{entry.name}: {command[:80]}")
    return found


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads processes from /proc")
def test_sigterm_stops_every_process_of_the_run_and_leaves_it_resumable(tmp_path, whole):
    """SIGTERM to `generate --workers 2` (the command alone, as a service manager sends it)
    unwinds like Ctrl-C: the workers are stopped, nothing of the run (workers, forkserver,
    resource tracker) keeps the caller's pipe open, no temporary file is left, and --resume
    completes the dataset to the bytes of an uninterrupted run."""
    config = tmp_path / "small.toml"
    config.write_text(SMALL)
    out = tmp_path / "ds"
    proc = start_generate(config, out, 2, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    os.kill(proc.pid, signal.SIGTERM)
    try:  # both pipes reach EOF only once every process holding them has exited
        _, err = proc.communicate(timeout=90)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        pytest.fail(f"the pipe stayed open after SIGTERM: {live_processes(proc.pid)}")
    # stderr is a pipe, so generate also logged plain progress lines before the last word
    assert proc.returncode == 143
    assert err.decode().strip().splitlines()[-1] == "tactile-bullet: terminated"
    deadline = time.time() + 30
    while live_processes(proc.pid) and time.time() < deadline:
        time.sleep(0.05)
    assert live_processes(proc.pid) == []
    assert [p.name for p in out.iterdir() if ".tmp" in p.name] == []
    assert 1 <= len(listed_shards(out)) < 4, "SIGTERM should land mid-run"

    assert generate(Sweep.from_toml(config), out, workers=0, resume=True)["records"] == 4
    assert files(out) == files(whole)
