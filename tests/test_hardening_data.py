"""Issue 20 probes on recordings and outputs: ``--force`` replaces only what this project
wrote, and never a device, FIFO, socket or link; garbage joint values are refused before any
answer is given."""

from __future__ import annotations

import json
import os
import socket

import numpy as np
import pytest
from cli_helpers import run_error

from tactile_bullet.cli import main
from tactile_bullet.errors import UsageError
from tactile_bullet.hand import JOINT_NAMES
from tactile_bullet.realhand.export import export
from tactile_bullet.realhand.recordings import write_dataset

pytest.importorskip("rosbags")


@pytest.fixture(scope="module")
def files(tmp_path_factory, synthetic_split):
    """A test dataset of 4 synthetic grasps, its bag and CSV exports."""
    root = tmp_path_factory.mktemp("hard")
    test = synthetic_split[1][:4]
    write_dataset(test, root / "test", {"test": True})
    export(test, root / "test.bag", "bag")
    export(test, root / "test.csv", "csv")
    return {"root": root, "test": test, "data": str(root / "test")}


def _export(files, fmt, out, *extra):
    return ["export", "--data", files["data"], "--format", fmt, "--out", str(out), *extra]


# --- item 1: --force replaces only this project's files -----------------------------------------


@pytest.mark.parametrize("fmt", ["db3", "mcap"])
def test_export_force_keeps_a_folder_with_the_users_files(tmp_path, capsys, files, fmt):
    out = tmp_path / "paper"
    out.mkdir()
    (out / "metadata.yaml").write_text("title: my thesis\n")
    (out / "thesis.tex").write_text("\\documentclass{article}\n")
    err = run_error(capsys, _export(files, fmt, out, "--force"))
    assert "not replacing" in err
    assert (out / "thesis.tex").read_text() == "\\documentclass{article}\n"
    assert (out / "metadata.yaml").read_text() == "title: my thesis\n"


@pytest.mark.parametrize("fmt", ["db3", "mcap"])
def test_export_force_replaces_its_own_bag_but_not_a_bag_with_extra_files(
    tmp_path, capsys, files, fmt
):
    out = tmp_path / "bag2"
    assert main(_export(files, fmt, out)) == 0
    assert main(_export(files, fmt, out, "--force")) == 0  # its own bag: replaced
    (out / "thesis.tex").write_text("keep")
    err = run_error(capsys, _export(files, fmt, out, "--force"))
    assert "thesis.tex" in err and (out / "thesis.tex").read_text() == "keep"


def test_import_force_keeps_a_folder_whose_manifest_is_not_a_dataset(tmp_path, capsys, files):
    app = tmp_path / "webapp"
    app.mkdir()
    (app / "manifest.json").write_text('{"name": "my app", "start_url": "/"}')
    (app / "index.js").write_text("console.log(1)")
    err = run_error(capsys, ["import", str(files["root"] / "test.bag"), "--out", str(app),
                             "--force"])  # fmt: skip
    assert "manifest.json" in err
    assert (app / "index.js").read_text() == "console.log(1)"
    assert json.loads((app / "manifest.json").read_text())["name"] == "my app"


def test_import_force_keeps_a_dataset_holding_the_users_notes(tmp_path, capsys, files):
    out = tmp_path / "imp"
    bag = str(files["root"] / "test.bag")
    assert main(["import", bag, "--out", str(out)]) == 0
    (out / "NOTES.txt").write_text("recorded on the old hand")
    err = run_error(capsys, ["import", bag, "--out", str(out), "--force"])
    assert "NOTES.txt" in err
    assert (out / "NOTES.txt").read_text() == "recorded on the old hand"
    (out / "NOTES.txt").unlink()
    assert main(["import", bag, "--out", str(out), "--force", "--shape", "cup"]) == 0


# --- item 2: devices, FIFOs, sockets and links are never replaced -------------------------------


def _special(tmp_path, kind):
    path = tmp_path / f"{kind}.csv"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "symlink":
        target = tmp_path / "target.csv"
        target.write_text("the user's data\n")
        path.symlink_to(target)
    elif kind == "socket":
        sock = socket.socket(socket.AF_UNIX)
        sock.bind(str(path))
        sock.close()
    return path


@pytest.mark.parametrize("kind", ["fifo", "symlink", "socket"])
def test_export_force_refuses_a_special_file(tmp_path, capsys, files, kind):
    path = _special(tmp_path, kind)
    before = os.lstat(path).st_mode
    err = run_error(capsys, _export(files, "csv", path, "--force"))
    assert "not a regular file" in err
    assert os.lstat(path).st_mode == before
    if kind == "symlink":
        assert (tmp_path / "target.csv").read_text() == "the user's data\n"


def test_force_refuses_a_device_for_every_writer(tmp_path, capsys, files):
    """/dev/null stays a device (as root, a rename over it would replace the node)."""
    null = "/dev/null"
    err = run_error(capsys, _export(files, "bag", null, "--force"))
    assert "character device" in err
    err = run_error(capsys, ["import", str(files["root"] / "test.bag"), "--out", null,
                             "--force"])  # fmt: skip
    assert "character device" in err
    from tactile_bullet.files import write_bytes_atomic

    with pytest.raises(UsageError, match="character device"):
        write_bytes_atomic(null, b"x", "report")
    assert os.path.exists(null) and not os.path.isfile(null)


def test_grasp_out_force_refuses_a_link(tmp_path, capsys):
    link = _special(tmp_path, "symlink")
    err = run_error(capsys, ["grasp", "--shape", "cylinder", "--out", str(link), "--force"])
    assert "symbolic link" in err
