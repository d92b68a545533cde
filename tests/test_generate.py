"""Generating datasets: worker crashes, Dask clusters, and the CLI's contract."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys

import pytest
from synthetic import SMALL_SWEEP as SMALL

from tactile_bullet.datasets import executors
from tactile_bullet.datasets.dataset import open_dataset
from tactile_bullet.datasets.executors import CRASH_ENV
from tactile_bullet.datasets.generate import generate
from tactile_bullet.datasets.presets import preset
from tactile_bullet.datasets.sweeps import Sweep
from tactile_bullet.errors import UsageError


@pytest.fixture
def small(tmp_path):
    path = tmp_path / "small.toml"
    path.write_text(SMALL)
    return path


def cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "tactile_bullet.cli", *args],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def test_a_worker_killed_by_a_segfault_does_not_kill_the_run(small, tmp_path, monkeypatch):
    monkeypatch.setenv(CRASH_ENV, "2")
    doc = generate(Sweep.from_toml(small), tmp_path / "ds", workers=2, shard_size=2)
    assert doc["records"] == 3 and doc["failed"] == 1
    manifest = json.loads((tmp_path / "ds" / "manifest.json").read_text())
    assert [f["task"] for f in manifest["failed"]] == [2]
    assert "died" in manifest["failed"][0]["error"]
    assert sorted(r.shape for r in open_dataset(tmp_path / "ds")) == ["cylinder"] * 2 + ["sphere"]


def test_a_pool_that_breaks_while_tasks_are_submitted_loses_no_task(monkeypatch):
    """A worker can die between two submissions; the pool then refuses the next submit. That
    task must stay queued and run later (it once vanished: 3 of 4 records, none failed)."""
    from concurrent.futures import Future
    from concurrent.futures.process import BrokenProcessPool
    from types import SimpleNamespace

    from tactile_bullet.datasets import executors

    pools = []

    class InlinePool:  # runs each task at once; the first pool breaks on its second submit
        def __init__(self, *_args, **_kwargs):
            self.submits = 0
            pools.append(self)

        def submit(self, fn, task):
            self.submits += 1
            if len(pools) == 1 and self.submits == 2:
                raise BrokenProcessPool("a worker died")
            future = Future()
            future.set_result(fn(task))
            return future

        def shutdown(self, wait=True, cancel_futures=False):
            pass

    monkeypatch.setattr(executors, "ProcessPoolExecutor", InlinePool)
    tasks = [SimpleNamespace(index=i) for i in range(4)]
    results = dict(executors.run_local(tasks, workers=2, task_fn=lambda t: f"ran {t.index}"))
    assert results == {i: f"ran {i}" for i in range(4)}


def test_two_workers_give_the_same_records_as_one(small, tmp_path):
    generate(Sweep.from_toml(small), tmp_path / "a", workers=0, shard_size=3)
    generate(Sweep.from_toml(small), tmp_path / "b", workers=2, shard_size=3)
    a, b = list(open_dataset(tmp_path / "a")), list(open_dataset(tmp_path / "b"))
    assert len(a) == 4 and all(x.equals(y) for x, y in zip(a, b, strict=True))


def test_a_dask_cluster_gives_the_same_records_as_a_local_run(small, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        doc = generate(Sweep.from_toml(small), tmp_path / "dask", cluster=cluster.scheduler_address)
    assert doc["records"] == 4
    generate(Sweep.from_toml(small), tmp_path / "local", workers=0)
    a, b = list(open_dataset(tmp_path / "dask")), list(open_dataset(tmp_path / "local"))
    assert all(x.equals(y) for x, y in zip(a, b, strict=True))


def test_a_cluster_worker_with_another_engine_version_is_refused():
    class Client:  # what generate asks of a dask Client: each worker's versions, closing
        closed = False

        def __init__(self, versions):
            self.versions = versions

        def run(self, fn):
            return {"tcp://10.0.0.2:4001": self.versions}

        def close(self):
            self.closed = True

    same = Client(executors._engine_versions())
    executors.check_worker_engines(same)
    assert not same.closed
    other = Client({**executors._engine_versions(), "mujoco": "3.2.0"})
    with pytest.raises(UsageError, match=r"worker tcp://10.0.0.2:4001 has mujoco 3.2.0, this"):
        executors.check_worker_engines(other)
    assert other.closed


def test_unreachable_cluster_is_a_clear_error(small, tmp_path):
    pytest.importorskip("distributed")
    with socket.socket() as s:  # a free loopback port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(UsageError, match="cannot reach the Dask scheduler"):
        generate(Sweep.from_toml(small), tmp_path / "ds", cluster=f"tcp://127.0.0.1:{port}")
    assert not (tmp_path / "ds").exists()  # nothing written: the same --out works next time


def test_cli_json_contract(tmp_path):
    result = cli("generate", "--preset", "smoke", "--out", str(tmp_path / "ds"), "--json")
    assert result.returncode == 0, result.stderr
    doc = json.loads(result.stdout)
    assert set(doc) >= {"out", "records", "shards", "failed", "wall_time_s"}
    assert doc["records"] == len(preset("smoke").tasks()) and doc["failed"] == 0
    assert len(open_dataset(tmp_path / "ds")) == doc["records"]


@pytest.mark.parametrize(
    "args, message",
    [
        (["--preset", "everything"], "unknown preset"),
        (["--config", "missing.toml"], "does not exist"),
        (["--preset", "smoke", "--workers", "-1"], "--workers"),
    ],
)
def test_cli_bad_input_exits_2_with_one_line(tmp_path, args, message):
    result = cli("generate", *args, "--out", str(tmp_path / "ds"))
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr


def test_cli_malformed_toml_names_the_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[[shapes]\nname = 'sphere'\n")
    result = cli("generate", "--config", str(bad), "--out", str(tmp_path / "ds"))
    assert result.returncode == 2 and "bad.toml is not valid TOML" in result.stderr
    assert not (tmp_path / "ds").exists()


def _file_of(fd: int) -> tuple[int, int] | None:
    """(device, inode) of what descriptor ``fd`` of this process holds, None if it is closed."""
    try:
        st = os.fstat(fd)
    except OSError:
        return None
    return st.st_dev, st.st_ino


def test_workers_do_not_keep_the_writer_lock_open(tmp_path):
    """Forked workers close their copy of the dataset's lock (a worker outliving a killed run
    would otherwise hold it and refuse the --resume); preloading makes them start fast."""
    with open(tmp_path / "lock", "a") as handle:
        executors.PARENT_ONLY_FDS.add(handle.fileno())
        try:
            lock = os.fstat(handle.fileno())
            with executors._pool(1, frozenset({"bullet"})) as pool:
                held = pool.submit(_file_of, handle.fileno()).result()
            assert held != (lock.st_dev, lock.st_ino)
        finally:
            executors.PARENT_ONLY_FDS.discard(handle.fileno())
