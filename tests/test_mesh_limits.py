"""Mesh files and their cache under bad luck: glTF buffers confined to the mesh's folder before
anything is read, triangle budgets kept and input bounded, cache entries that are tampered with
or damaged processed again instead of trusted."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from tactile_bullet.errors import UsageError
from tactile_bullet.objects import mesh_cache, meshes

pytestmark = pytest.mark.usefixtures("private_mesh_cache")


def ball(folder, subdivisions=3, ext="stl"):
    path = folder / f"ball.{ext}"
    trimesh.creation.icosphere(subdivisions, radius=0.04).export(path)
    return path


def _gltf(folder, uri):
    path = folder / "thing.gltf"
    doc = {"asset": {"version": "2.0"}, "buffers": [{"uri": uri, "byteLength": 12}]}
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("uri", ["/dev/zero", "../../../dev/zero", "/etc/passwd", "sub/../../x"])
def test_gltf_buffers_outside_the_mesh_folder_are_refused_before_reading(tmp_path, uri):
    folder = tmp_path / "m"
    folder.mkdir()
    with pytest.raises(UsageError, match="lies outside the mesh's folder"):
        meshes.mesh_source(_gltf(folder, uri))


def test_gltf_buffer_that_is_a_fifo_or_a_link_out_is_refused(tmp_path):
    import os

    os.mkfifo(tmp_path / "buf.bin")  # never opened: the test would hang if it were
    with pytest.raises(UsageError, match="is a FIFO, not a regular file"):
        meshes.mesh_source(_gltf(tmp_path, "buf.bin"))
    (tmp_path / "link.bin").symlink_to("/dev/zero")
    with pytest.raises(UsageError, match="lies outside the mesh's folder"):
        meshes.mesh_source(_gltf(tmp_path, "link.bin"))


def test_mesh_over_the_input_triangle_limit_is_refused_before_parsing(tmp_path, monkeypatch):
    monkeypatch.setattr(meshes, "MAX_INPUT_TRIANGLES", 1000)
    stl = ball(tmp_path, 3)  # 1,280 triangles, counted from the binary STL's header
    parsed = []
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: parsed.append(a))
    with pytest.raises(UsageError, match="holds 1,280 triangles, over the 1,000"):
        meshes.load_mesh(stl)
    assert not parsed
    monkeypatch.undo()
    monkeypatch.setattr(meshes, "MAX_INPUT_TRIANGLES", 1000)
    with pytest.raises(UsageError, match="holds 1,280 triangles"):  # no header: counted parsed
        meshes.load_mesh(ball(tmp_path, 3, "obj"))


def test_budgets_are_kept_when_one_decimation_pass_stops_short(tmp_path, monkeypatch):
    """The decimation library stops short of large reductions (5M -> 20k kept 133k): the
    promised analysis and collision budgets hold all the same."""
    import fast_simplification

    real = fast_simplification.simplify

    def short(points, triangles, target_count):  # reaches at most a 4x reduction a pass
        return real(points, triangles, target_count=max(target_count, len(triangles) // 4))

    monkeypatch.setattr(fast_simplification, "simplify", short)
    shape = meshes.load_mesh(ball(tmp_path, 6), budget=2000)  # 81,920 triangles
    assert shape.info.triangles_in == 81920
    assert shape.info.triangles <= 2000 * 1.05
    assert shape.info.collision_triangles <= meshes.CONVEX_HULL_TRIANGLES * 1.05


def _rewrite(path, meta_change=None, arrays_change=None, keep_checksum=True):
    with np.load(path) as data:
        meta = json.loads(str(data["meta"]))
        arrays = {k: data[k] for k in data.files if k != "meta"}
    if arrays_change:
        arrays.update(arrays_change(arrays))
    if not keep_checksum:
        meta["checksum"] = mesh_cache._cache_checksum(meta, arrays)
    np.savez(path, meta=np.array(json.dumps(meta)), **arrays)


def test_a_tampered_cache_entry_is_processed_again_not_used(tmp_path):
    path = ball(tmp_path)
    first = meshes.load_mesh(path)
    cached = meshes.cache_path(first.source)
    _rewrite(cached, arrays_change=lambda a: {"vertices": a["vertices"] * 1.2,
                                              "profile_r": a["profile_r"] * 1.2})  # fmt: skip
    meshes.forget_loaded()
    before = meshes.PROCESSED
    again = meshes.load_mesh(path)
    assert meshes.PROCESSED == before + 1
    assert np.array_equal(again.profile_r, first.profile_r)


@pytest.mark.parametrize(
    "damage",
    [
        lambda a: {"profile_r": a["profile_r"][:-5]},  # profile arrays of different lengths
        lambda a: {"collision_vertices": np.zeros((0, 3))},  # nothing to collide with
        lambda a: {"faces": a["faces"].reshape(-1)},  # not triangles
    ],
)
def test_a_damaged_cache_entry_with_a_valid_checksum_is_processed_again(tmp_path, damage):
    path = ball(tmp_path)
    first = meshes.load_mesh(path)
    _rewrite(meshes.cache_path(first.source), arrays_change=damage, keep_checksum=False)
    meshes.forget_loaded()
    before = meshes.PROCESSED
    again = meshes.load_mesh(path)
    assert meshes.PROCESSED == before + 1
    assert np.array_equal(again.profile_r, first.profile_r)
