"""The shape fit's grid cache: used only when valid, recomputed when damaged or stale."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tactile_bullet.perception import grid_cache


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TACTILE_BULLET_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


class Counting:
    """A stand-in forward model that counts its calls."""

    def __init__(self) -> None:
        self.calls = 0

    def __call__(self, grid: np.ndarray) -> np.ndarray:
        self.calls += 1
        return np.broadcast_to(grid.sum(axis=1)[:, None, None], (len(grid), 3, 4)).copy()


GRID = np.linspace(0.0, 1.0, 30).reshape(10, 3)


def test_second_use_reads_the_cache(cache):
    compute = Counting()
    first = grid_cache.grid_geometry("sphere", GRID, compute)
    second = grid_cache.grid_geometry("sphere", GRID, compute)
    assert compute.calls == 1
    np.testing.assert_array_equal(first, second)
    assert grid_cache.cache_path("sphere").is_file()


def test_a_truncated_file_is_recomputed_and_rewritten(cache):
    compute = Counting()
    grid_cache.grid_geometry("sphere", GRID, compute)
    path = grid_cache.cache_path("sphere")
    path.write_bytes(path.read_bytes()[:100])
    again = grid_cache.grid_geometry("sphere", GRID, compute)
    assert compute.calls == 2
    np.testing.assert_array_equal(again, Counting()(GRID))
    grid_cache.grid_geometry("sphere", GRID, compute)
    assert compute.calls == 2  # the rewritten file was read


def test_edited_values_fail_the_checksum(cache):
    compute = Counting()
    good = grid_cache.grid_geometry("sphere", GRID, compute)
    path = grid_cache.cache_path("sphere")
    with np.load(path) as data:
        meta, grid = str(data["meta"]), data["grid"]
    with open(path, "wb") as fh:  # a valid archive whose values no longer match their sha256
        np.savez(fh, meta=np.array(meta), grid=grid, geometry=good + 0.1)
    np.testing.assert_array_equal(grid_cache.grid_geometry("sphere", GRID, compute), good)
    assert compute.calls == 2


def test_another_code_version_or_grid_is_not_used(cache, monkeypatch):
    compute = Counting()
    grid_cache.grid_geometry("sphere", GRID, compute)
    path = grid_cache.cache_path("sphere")
    with np.load(path) as data:
        meta = json.loads(str(data["meta"]))
        grid, geometry = data["grid"], data["geometry"]
    with open(path, "wb") as fh:
        np.savez(fh, meta=np.array(json.dumps({**meta, "key": "0" * 64})), grid=grid,
                 geometry=geometry)  # fmt: skip
    grid_cache.grid_geometry("sphere", GRID, compute)
    assert compute.calls == 2
    grid_cache.grid_geometry("sphere", GRID[:-1], compute)
    assert compute.calls == 3


def test_an_unwritable_cache_costs_only_speed(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("TACTILE_BULLET_CACHE", str(blocker))
    compute = Counting()
    out = grid_cache.grid_geometry("sphere", GRID, compute)
    np.testing.assert_array_equal(out, Counting()(GRID))
    assert compute.calls == 1


def test_the_key_follows_the_model_source():
    assert len(grid_cache.code_key()) == 64
    assert "perception/shape_model.py" in grid_cache._SOURCES


def test_a_family_from_the_cache_fits_as_computed(cache):
    from tactile_bullet.perception import shape_fit

    computed = shape_fit._Family(shape_fit._TABLE["sphere"])  # writes the cache
    cached = shape_fit._Family(shape_fit._TABLE["sphere"])  # reads it
    assert grid_cache.cache_path("sphere").is_file()
    np.testing.assert_array_equal(cached.grid_geometry, computed.grid_geometry)
    direct = computed._grid_geometry(computed.grid)
    np.testing.assert_array_equal(cached.grid_geometry, direct)


def test_without_readable_sources_nothing_is_cached(cache, monkeypatch):
    monkeypatch.setattr(grid_cache, "code_key", lambda: "")
    compute = Counting()
    grid_cache.grid_geometry("sphere", GRID, compute)
    grid_cache.grid_geometry("sphere", GRID, compute)
    assert compute.calls == 2 and not cache.exists()


def test_an_entry_with_a_member_it_never_writes_is_recomputed_unread(cache, monkeypatch):
    """A cache entry carrying an extra (possibly zip-bomb) member is refused before any array
    is inflated, like every other .npz the project reads, and recomputed."""
    compute = Counting()
    good = grid_cache.grid_geometry("sphere", GRID, compute)
    path = grid_cache.cache_path("sphere")
    with np.load(path) as data:
        members = {k: data[k] for k in data.files}
    with open(path, "wb") as fh:
        np.savez(fh, **members, extra=np.zeros(10))
    loads = []
    monkeypatch.setattr(grid_cache.np, "load", lambda *a, **k: loads.append(a) or 1 / 0)
    again = grid_cache.grid_geometry("sphere", GRID, compute)
    assert compute.calls == 2 and not loads
    np.testing.assert_array_equal(again, good)
