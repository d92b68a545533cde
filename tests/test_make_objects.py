"""``tactile-bullet make-objects``: the example objects from any folder, never overwriting."""

from __future__ import annotations

import json

import trimesh
from cli_helpers import run_error

from tactile_bullet.cli import main
from tactile_bullet.files import LEDGER


def test_writes_the_objects_and_sweeps_in_an_empty_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # no repository needed
    assert main(["make-objects", "--out", "objects", "--only", "bottle,bowl", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["objects"] == ["bottle", "bowl"]
    written = (tmp_path / "objects").iterdir()
    assert sorted(p.name for p in written if p.name != LEDGER) == [
        "bottle.stl", "bowl.glb", "test.toml", "train.toml",
    ]  # fmt: skip
    bottle = trimesh.load(tmp_path / "objects" / "bottle.stl")
    assert bottle.is_watertight
    assert 120 < bottle.extents.max() < 140  # written in millimetres: 130 mm tall
    assert 'file = "bowl.glb"' in (tmp_path / "objects" / "train.toml").read_text()


def test_an_existing_file_is_kept_unless_forced(tmp_path, capsys):
    out = tmp_path / "objects"
    out.mkdir()
    (out / "ball.ply").write_text("mine")
    err = run_error(capsys, ["make-objects", "--out", str(out), "--only", "ball,can"])
    assert "ball.ply exists" in err
    assert (out / "ball.ply").read_text() == "mine"
    assert not (out / "can.obj").exists()  # refused before anything was written
    # --force replaces only what make-objects wrote there (issue 29): the user's file stays
    err = run_error(capsys, ["make-objects", "--out", str(out), "--only", "ball", "--force"])
    assert "ball.ply" in err and (out / "ball.ply").read_text() == "mine"
    (out / "ball.ply").unlink()
    assert main(["make-objects", "--out", str(out), "--only", "ball"]) == 0
    before = (out / "ball.ply").read_bytes()
    assert main(["make-objects", "--out", str(out), "--only", "ball", "--force"]) == 0
    assert (out / "ball.ply").read_bytes() == before  # its own file: replaced


def test_unknown_names_and_a_file_as_folder_are_refused(tmp_path, capsys):
    assert "unknown example object 'teapot'" in run_error(
        capsys, ["make-objects", "--out", str(tmp_path), "--only", "ball,teapot"]
    )
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert "not a folder" in run_error(capsys, ["make-objects", "--out", str(blocker)])


def test_the_json_document_lists_every_file_written(tmp_path, capsys):
    assert main(["make-objects", "--out", str(tmp_path), "--only", "egg", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert set(doc) == {"out", "objects", "files"}
    assert sorted(doc["files"]) == sorted(str(p) for p in tmp_path.iterdir() if p.name != LEDGER)
    assert (tmp_path / LEDGER).is_file()  # what --force may replace later (issue 29)
