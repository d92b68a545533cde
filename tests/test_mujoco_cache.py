"""MuJoCo's compiled models kept on disk between processes (``sim/engines/mujoco_cache.py``):
read back only when valid, the same grasps from a model read back as from one compiled."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("mujoco")

from tactile_bullet.records import ControllerSettings, Pose  # noqa: E402
from tactile_bullet.sim.engines import mujoco as M  # noqa: E402
from tactile_bullet.sim.engines import mujoco_cache as C  # noqa: E402
from tactile_bullet.sim.grasp import simulate_grasp  # noqa: E402

CTL = ControllerSettings(engine="mujoco")
SPHERE = ("sphere", {"radius": 0.047})


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TACTILE_BULLET_CACHE", str(tmp_path / "cache"))
    M.clear_compiled()
    yield tmp_path / "cache" / "mujoco"
    M.clear_compiled()


def _entries(folder):
    return sorted(folder.glob("*.mjb")) if folder.is_dir() else []


def _no_compiling(monkeypatch):
    import mujoco

    def refuse(self):
        pytest.fail("compiled although a valid entry was on disk")

    monkeypatch.setattr(mujoco.MjSpec, "compile", refuse)


def test_a_model_read_back_grasps_exactly_as_the_compiled_one(cache, monkeypatch):
    compiled = simulate_grasp(*SPHERE, Pose((0.004, 0.0, 0.0)), CTL)
    (entry,) = _entries(cache)
    M.clear_compiled()  # as a new process: nothing in memory, the entry on disk
    _no_compiling(monkeypatch)
    read = simulate_grasp(*SPHERE, Pose((0.004, 0.0, 0.0)), CTL)
    for field in ("final_angles", "angles", "efforts"):
        np.testing.assert_array_equal(getattr(read, field), getattr(compiled, field))
    assert _entries(cache) == [entry]


def test_each_size_and_timestep_has_its_own_entry(cache):
    simulate_grasp(*SPHERE, Pose(), CTL)
    simulate_grasp("sphere", {"radius": 0.05}, Pose(), CTL)
    simulate_grasp(*SPHERE, Pose(), ControllerSettings(engine="mujoco", timestep=1 / 200))
    assert len(_entries(cache)) == 3


@pytest.mark.parametrize("damage", ["truncated", "edited", "other key", "no digest",
                                    "not json"])  # fmt: skip
def test_a_damaged_entry_is_compiled_again_never_used(cache, damage, monkeypatch):
    good = simulate_grasp(*SPHERE, Pose(), CTL)
    (entry,) = _entries(cache)
    meta_path = entry.with_suffix(".json")
    data, meta = entry.read_bytes(), json.loads(meta_path.read_text())
    if damage == "truncated":
        entry.write_bytes(data[: len(data) // 2])
    elif damage == "edited":
        entry.write_bytes(data[:1000] + bytes([data[1000] ^ 0xFF]) + data[1001:])
    elif damage == "other key":
        meta_path.write_text(json.dumps(meta | {"key": "0" * 64}))
    elif damage == "no digest":
        meta_path.write_text(json.dumps({k: v for k, v in meta.items() if k != "hmac"}))
    else:
        meta_path.write_text("not json")
    M.clear_compiled()
    compiles = _counting_compiles(monkeypatch)
    again = simulate_grasp(*SPHERE, Pose(), CTL)
    assert compiles == [1]  # the entry was not used: the model was compiled again
    np.testing.assert_array_equal(again.final_angles, good.final_angles)
    key = C.model_key(_sphere_geoms(), CTL.timestep / M.SUBSTEPS, 1.0)
    assert C._read(entry, key) is not None  # and rewritten, valid


def _counting_compiles(monkeypatch) -> list[int]:
    import mujoco

    count = [0]
    original = mujoco.MjSpec.compile

    def counted(self):
        count[0] += 1
        return original(self)

    monkeypatch.setattr(mujoco.MjSpec, "compile", counted)
    return count


def _sphere_geoms():
    from tactile_bullet.objects.shapes import BUILTIN_SHAPES
    from tactile_bullet.sim.engines.mujoco_objects import object_geoms

    shape = {s.name: s for s in BUILTIN_SHAPES}["sphere"]
    return object_geoms(shape, shape.resolve(SPHERE[1]))


def test_an_unwritable_cache_costs_only_speed(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("TACTILE_BULLET_CACHE", str(blocker))
    M.clear_compiled()
    record = simulate_grasp(*SPHERE, Pose(), CTL)
    assert record.final_angles.shape and blocker.read_text() == "not a folder"
    M.clear_compiled()


def test_the_key_follows_the_code_the_step_and_the_phalanx_scale():
    assert len(C.code_key()) == 64
    assert "sim/engines/mujoco_objects.py" in C._SOURCES
    geoms = _sphere_geoms()
    base = C.model_key(geoms, 0.002, 1.0)
    assert C.model_key(geoms, 0.002, 1.0) == base
    assert C.model_key(geoms, 0.001, 1.0) != base
    assert C.model_key(geoms, 0.002, 1.1) != base


def test_the_folder_keeps_the_most_recently_used_entries_within_its_budget(tmp_path):
    import os

    for i in range(10):
        entry = tmp_path / f"{i:02d}.mjb"
        entry.write_bytes(b"x" * 1000)
        entry.with_suffix(".json").write_text("{}")
        os.utime(entry, (1000.0 + i, 1000.0 + i))  # 00 the least recently used
    assert C.prune(tmp_path, budget=20_000) == 0
    assert C.prune(tmp_path, budget=8_000) == 4  # down to 3/4 of the budget: 6 kB
    kept = [f"{i:02d}" for i in range(4, 10)]
    assert sorted(e.stem for e in tmp_path.glob("*.mjb")) == kept
    assert sorted(e.stem for e in tmp_path.glob("*.json")) == kept  # each digest with its model


def test_reading_an_entry_marks_it_used(cache):
    import os

    simulate_grasp(*SPHERE, Pose(), CTL)
    (entry,) = _entries(cache)
    os.utime(entry, (1000.0, 1000.0))
    M.clear_compiled()
    simulate_grasp(*SPHERE, Pose(), CTL)
    assert entry.stat().st_mtime > 1000.0


def test_a_process_checks_the_budget_on_its_first_write(cache, monkeypatch):
    """A one-grasp command writes one entry per run: the folder is checked on a process's
    first write, not only every PRUNE_EVERY writes, so such runs cannot grow it past the
    budget."""
    checked = []
    monkeypatch.setattr(C, "_WRITTEN", 0)
    monkeypatch.setattr(C, "prune", lambda folder, budget=None: checked.append(folder) or 0)
    simulate_grasp(*SPHERE, Pose(), CTL)
    simulate_grasp("sphere", {"radius": 0.05}, Pose(), CTL)
    assert checked == [cache]
