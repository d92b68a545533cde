"""Mesh files as graspable objects: r(x) by slicing, axis detection, the disk cache, refusals
of bad input (exit 2, nothing written) and a grasp on a mesh that touches it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh
from cli_helpers import run_error

from tactile_bullet.cli import main
from tactile_bullet.errors import UsageError
from tactile_bullet.hand import LONG_FINGERS
from tactile_bullet.objects import meshes
from tactile_bullet.objects.shapes import _revolve, ovoid_radius
from tactile_bullet.records import load_record

REPO = Path(__file__).resolve().parent.parent


pytestmark = pytest.mark.usefixtures("private_mesh_cache")


def make_objects_tool():
    from tactile_bullet.objects import examples

    return examples


EGG_X = np.linspace(-0.065, 0.065, 64)
EGG_R = ovoid_radius(EGG_X)
EGG_R[0] = EGG_R[-1] = 0.0


def egg_file(folder: Path, rotation=None, unit_scale: float = 1.0, ext: str = "stl") -> Path:
    """The ovoid's generating profile revolved (axis along x), turned and scaled as given."""
    mesh = _revolve(EGG_X, EGG_R, 48)
    if rotation is not None:
        mesh.apply_transform(rotation)
    mesh.apply_scale(unit_scale)
    path = folder / f"egg.{ext}"
    mesh.export(path)
    return path


TURN = trimesh.transformations.euler_matrix(0.7, -0.4, 1.9)
"""An arbitrary frame: the file's axes have nothing to do with the egg's."""


def test_radius_profile_matches_the_generating_profile(tmp_path):
    shape = meshes.load_mesh(egg_file(tmp_path, TURN, 1000.0), unit="mm")
    x, r = shape.profile_x, shape.profile_r
    # the heavier end goes to -x: the ovoid's blunt end (+x in its own frame) is flipped
    truth = np.interp(-x, EGG_X, EGG_R)
    assert np.abs(r - truth).max() < 0.0005
    assert abs(x[0] + 0.065) < 1e-4 and abs(x[-1] - 0.065) < 1e-4
    assert shape.info.watertight and shape.info.convex


def test_axis_of_a_mesh_given_in_a_rotated_frame(tmp_path):
    shape = meshes.load_mesh(egg_file(tmp_path, TURN))
    true_axis = TURN[:3, :3] @ [1.0, 0.0, 0.0]
    assert abs(abs(float(np.dot(shape.info.axis, true_axis))) - 1.0) < 1e-6
    assert shape.info.size[0] == pytest.approx(0.13, abs=1e-4)
    assert shape.info.size[1] == pytest.approx(2 * EGG_R.max(), abs=1e-3)


def test_named_axis_maps_that_file_axis_onto_o_o(tmp_path):
    upright = trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0])  # x -> -z
    shape = meshes.load_mesh(egg_file(tmp_path, upright), axis="z")
    assert shape.info.axis == pytest.approx((0.0, 0.0, 1.0))
    assert shape.info.size[0] == pytest.approx(0.13, abs=1e-4)


def test_non_revolved_section_uses_the_hull_perimeter_radius(tmp_path):
    path = tmp_path / "box.obj"
    trimesh.creation.box(extents=(0.12, 0.05, 0.07)).export(path)
    shape = meshes.load_mesh(path)
    mid = shape.radius(np.array([0.0]))[0]
    assert mid == pytest.approx(2 * (0.05 + 0.07) / (2 * np.pi), abs=1e-4)
    # placement uses the corner's reach toward the palm, not the equivalent circle
    assert shape.palm_reach(np.array([0.0]))[0] > 0.024


def test_second_load_reads_the_cache_instead_of_processing(tmp_path):
    path = egg_file(tmp_path)
    before = meshes.PROCESSED
    first = meshes.load_mesh(path, name="egg_a")
    cached = meshes.cache_path(first.source)
    mtime = cached.stat().st_mtime_ns
    meshes.forget_loaded()  # a new process: only the disk cache is left
    second = meshes.load_mesh(path, name="egg_b")
    assert meshes.PROCESSED == before + 1
    assert cached.stat().st_mtime_ns == mtime
    assert second.name == "egg_b" and np.array_equal(second.profile_r, first.profile_r)
    # other options are another entry; a damaged entry is processed again, not trusted
    meshes.load_mesh(path, scale=1.1)
    assert meshes.PROCESSED == before + 2
    cached.write_bytes(b"not an npz")
    meshes.forget_loaded()
    meshes.load_mesh(path)
    assert meshes.PROCESSED == before + 3


def test_changed_file_is_refused_under_its_recorded_identity(tmp_path):
    path = egg_file(tmp_path)
    source = meshes.mesh_source(path)
    egg_file(tmp_path, unit_scale=1.05)  # same name, new content, nothing cached yet
    with pytest.raises(UsageError, match="changed"):
        meshes.load_source(source)


@pytest.mark.slow
def test_grasp_on_a_mesh_touches_it_and_its_record_finds_the_mesh_again(tmp_path, capsys):
    path = egg_file(tmp_path, TURN, 100.0, ext="ply")
    rec = tmp_path / "rec.npz"
    argv = ["grasp", "--mesh", str(path), "--unit", "cm", "--name", "my_egg",
            "--out", str(rec), "--json"]  # fmt: skip
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["shape"] == "my_egg" and doc["params"] == {}
    assert set(LONG_FINGERS) <= set(doc["fingers_in_contact"])
    assert doc["mesh"]["pattern"]["nearest"] in doc["mesh"]["pattern"]["distances"]
    record = load_record(rec)
    assert record.mesh["sha256"] == doc["mesh"]["sha256"] and record.mesh["unit"] == "cm"
    assert len(record.contact_force) > 0 and record.contact_force.max() > 0
    # the record alone finds its mesh (cache) to re-simulate, bit for bit
    path.unlink()
    meshes.forget_loaded()
    from tactile_bullet.sim.grasp import simulate_grasp

    again = simulate_grasp(meshes.shape_of_record(record), pose=record.pose, seed=record.seed)
    assert again.equals(record)


def test_shape_info_json_and_plot(tmp_path, capsys):
    path = egg_file(tmp_path, TURN, 1000.0)
    png = tmp_path / "egg.png"
    assert main(["shape-info", "--mesh", str(path), "--unit", "mm", "--plot", str(png),
                 "--json"]) == 0  # fmt: skip
    doc = json.loads(capsys.readouterr().out)
    profile = doc["radius_profile"]
    assert len(profile["x"]) == len(profile["r"]) == meshes.PROFILE_SAMPLES
    assert min(profile["x"]) == pytest.approx(-0.065, abs=1e-4)
    assert max(profile["r"]) == pytest.approx(EGG_R.max(), abs=5e-4)
    assert doc["watertight"] and doc["triangles"]["input"] == doc["triangles"]["analysis"]
    assert doc["pattern"]["nearest"] == "sphere"  # an egg is nearest the sphere's pattern
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "--force" in run_error(capsys, ["shape-info", "--mesh", str(path), "--plot", str(png)])


def test_large_mesh_is_simplified_to_the_budget(tmp_path):
    path = tmp_path / "ball.stl"
    trimesh.creation.icosphere(subdivisions=5, radius=0.04).export(path)  # 20480 triangles
    shape = meshes.load_mesh(path, budget=4000)
    assert shape.info.triangles_in == 20480 and shape.info.triangles <= 4000
    assert shape.info.watertight
    assert shape.profile_r.max() == pytest.approx(0.04, abs=5e-4)


def _bad_files(tmp_path: Path) -> dict[str, Path]:
    text = tmp_path / "notes.ply"
    text.write_text("this is not a mesh at all\n")
    empty = tmp_path / "empty.obj"
    empty.write_text("# nothing here\n")
    flat = tmp_path / "flat.obj"
    flat.write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    sheet = tmp_path / "sheet.stl"  # an open hemisphere: no volume, no inertia axes
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.04)
    ball.slice_plane([0, 0, 0], [0, 0, 1]).export(sheet)
    return {"text": text, "empty": empty, "flat": flat, "sheet": sheet}


@pytest.mark.parametrize(
    ("case", "extra", "message"),
    [
        ("text", [], "not a readable mesh"),
        ("empty", [], "no triangles"),
        ("flat", [], "degenerate"),
        ("sheet", [], "not watertight"),
        ("egg_m_as_mm", ["--unit", "mm"], "too small"),
        ("egg_mm_as_m", [], "too large"),
        ("egg_mm_as_m", ["--unit", "mm", "--scale", "0"], "scale must be"),
        ("missing", [], "does not exist"),
        ("wrong_ext", [], "unsupported mesh format"),
        ("egg_mm_as_m", ["--unit", "mm", "--name", "sphere"], "registered shape"),
    ],
)
def test_bad_mesh_input_is_one_line_exit_2_and_writes_nothing(
    tmp_path, capsys, case, extra, message
):
    files = _bad_files(tmp_path)
    files["egg_m_as_mm"] = egg_file(tmp_path)
    (tmp_path / "mm").mkdir()
    files["egg_mm_as_m"] = egg_file(tmp_path / "mm", unit_scale=1000.0)
    files["missing"] = tmp_path / "gone.stl"
    files["wrong_ext"] = tmp_path / "egg.step"
    files["wrong_ext"].write_text("solid")
    out, plot = tmp_path / "out" / "rec.npz", tmp_path / "out" / "p.png"
    out.parent.mkdir()
    for argv in (
        ["grasp", "--mesh", str(files[case]), *extra, "--out", str(out), "--json"],
        ["shape-info", "--mesh", str(files[case]), *extra, "--plot", str(plot), "--json"],
    ):
        err = run_error(capsys, argv)
        assert message in err
    assert not any(out.parent.iterdir())
    cache = Path(meshes.cache_dir())
    assert not cache.exists() or not any(cache.rglob("*.npz"))


def test_param_with_a_mesh_is_refused_before_the_mesh_is_read(tmp_path, capsys):
    # a mesh's sizes are its own: a --param would be read as a shape parameter it lacks
    argv = ["grasp", "--mesh", str(tmp_path / "not-read.stl"), "--param", "radius=0.05"]
    err = run_error(capsys, argv)
    assert "--param sets a --shape's sizes: a --mesh has its own" in err


def test_sheet_mesh_with_a_named_axis_is_accepted(tmp_path):
    """Watertightness matters for the inertia axis only: name the axis and it loads."""
    path = _bad_files(tmp_path)["sheet"]
    shape = meshes.load_mesh(path, axis="x")
    assert not shape.info.watertight and not shape.info.convex
    assert shape.info.size[0] == pytest.approx(0.08, abs=1e-3)


def test_mesh_options_without_mesh_are_refused(capsys):
    assert "--unit" in run_error(capsys, ["grasp", "--shape", "sphere", "--unit", "mm"])


def test_object_set_sweep_labels_grasps_by_object_name(tmp_path):
    tool = make_objects_tool()
    written = tool.write_set(tmp_path, ["ball", "box", "cup"])
    assert {p.suffix for p in written} == {".ply", ".stl", ".glb", ".toml"}
    from tactile_bullet.datasets.sweeps import Sweep

    train = Sweep.from_toml(tmp_path / "train.toml")
    test = Sweep.from_toml(tmp_path / "test.toml")
    tasks = train.tasks()
    assert {t.shape for t in tasks} == {"ball", "box", "cup"}
    assert all(t.mesh is not None and t.params == {} for t in tasks)
    held_out = {(t.shape, t.pose) for t in test.tasks()}
    assert len(held_out) == 3 * tool.TEST_SAMPLES
    assert not held_out & {(t.shape, t.pose) for t in tasks}
    # the manifest form names each file by path and content hash, and reads back
    again = Sweep.from_dict(train.to_dict())
    assert again.to_dict() == train.to_dict()
    assert again.objects[1].source.sha256 == train.objects[1].source.sha256


def test_objects_folder_and_duplicate_names(tmp_path):
    make_objects_tool().write_set(tmp_path, ["ball", "can"])
    from tactile_bullet.datasets.sweeps import Sweep

    sweep = Sweep.from_dict({"objects": [{"folder": ".", "unit": "m"}]}, base=tmp_path)
    assert [o.name for o in sweep.objects] == ["ball", "can"]
    with pytest.raises(UsageError, match="two objects are named 'ball'"):
        Sweep.from_dict(
            {"objects": [{"file": "ball.ply"}, {"file": "can.obj", "name": "ball"}]},
            base=tmp_path,
        )
    with pytest.raises(UsageError, match="exactly one of file"):
        Sweep.from_dict({"objects": [{"name": "x"}]}, base=tmp_path)
