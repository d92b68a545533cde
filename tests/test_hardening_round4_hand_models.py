"""Issue 29's probes on hand models (``--hand-model FILE.xml``): every file a model includes or
references keeps the rule every input keeps, a model's physics that goes wrong never becomes a
record, an actuator drives the joint its name says, a grasp where no finger moved carries no
shape, and a dataset never mixes two hands."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_error
from synthetic import make_record

from tactile_bullet.cli import main
from tactile_bullet.errors import UsageError

pytest.importorskip("mujoco")

REPO = Path(__file__).resolve().parents[1]
OWN = (REPO / "urdf" / "shadow_hand.xml").read_text()


def hand(folder: Path, text: str = OWN, name: str = "hand.xml") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(text)
    return path


def with_asset(text: str, asset: str) -> str:
    """The model with ``asset`` (an <include> or an <asset> block) before its worldbody."""
    return text.replace("<worldbody>", f"{asset}<worldbody>", 1)


def split_hand(folder: Path) -> Path:
    """The project's hand with its actuators in an included file (``actuators.xml``)."""
    block = re.search(r"  <actuator>.*?</actuator>", OWN, re.S).group(0)
    hand(folder, f"<mujoco>{block}</mujoco>", "actuators.xml")
    return hand(folder, OWN.replace(block, '  <include file="actuators.xml"/>'))


def load_in_child(path: Path, timeout: float = 60.0) -> subprocess.CompletedProcess:
    """``load_hand_spec(path)`` in a child process: a FIFO that is opened hangs it (the
    timeout turns a hang into a failed test rather than a stuck suite)."""
    code = ("import sys\nfrom tactile_bullet.errors import UsageError\n"
            "from tactile_bullet.sim.engines.mujoco_hand import load_hand_spec\n"
            f"try:\n    load_hand_spec({str(path)!r})\nexcept UsageError as e:\n"
            "    print(e); sys.exit(2)\n")  # fmt: skip
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=timeout, env=env, cwd=path.parent)  # fmt: skip


# --- item 8: FIFOs a model names are never opened ---------------------------------------------


@pytest.mark.parametrize("asset", ['<include file="fifo.xml"/>',
                                   '<asset><mesh name="x" file="fifo.stl"/></asset>'])  # fmt: skip
def test_a_fifo_a_hand_model_includes_or_references_is_refused_never_opened(tmp_path, asset):
    folder = tmp_path / "m"
    folder.mkdir()
    os.mkfifo(folder / "fifo.xml")
    os.mkfifo(folder / "fifo.stl")
    path = hand(folder, with_asset(OWN, asset))
    try:
        done = load_in_child(path)
    except subprocess.TimeoutExpired:
        pytest.fail("loading the model opened the FIFO and hung")
    assert done.returncode == 2 and "is a FIFO, not a regular file" in done.stdout


def test_grasp_with_a_model_naming_a_fifo_exits_2_on_one_line(tmp_path):
    folder = tmp_path / "m"
    folder.mkdir()
    os.mkfifo(folder / "fifo.xml")
    path = hand(folder, with_asset(OWN, '<include file="fifo.xml"/>'))
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    argv = [sys.executable, "-m", "tactile_bullet.cli", "grasp", "--shape", "sphere",
            "--hand-model", str(path)]  # fmt: skip
    try:
        done = subprocess.run(argv, capture_output=True, text=True, timeout=60, env=env,
                              cwd=tmp_path)  # fmt: skip
    except subprocess.TimeoutExpired:
        pytest.fail("grasp opened the FIFO the model includes and hung")
    assert done.returncode == 2 and "fifo.xml" in done.stderr and "FIFO" in done.stderr
    assert done.stderr.count("\n") == 1


# --- item 9: a referenced file's size is bounded ----------------------------------------------


def test_a_huge_mesh_a_hand_model_references_is_refused_before_it_is_read(tmp_path):
    from tactile_bullet.sim.engines.mujoco_hand import load_hand_spec

    folder = tmp_path / "m"
    folder.mkdir()
    with open(folder / "big.stl", "wb") as fh:
        fh.truncate(300 << 20)  # sparse: no disk used, but 300 MB to a reader
    path = hand(folder, with_asset(OWN, '<asset><mesh name="x" file="big.stl"/></asset>'))
    with pytest.raises(UsageError, match="big.stl.*over the .*-byte limit"):
        load_hand_spec(path)


# --- item 14: includes and glTF buffers: one rule, inside the naming file's folder ------------


@pytest.mark.parametrize("where", ["../outside.xml", "/etc/passwd", "link.xml"])
def test_an_include_outside_the_hand_models_folder_is_refused_as_a_gltf_buffer_is(
    tmp_path, where
):
    from tactile_bullet.sim.engines.mujoco_hand import load_hand_spec

    block = re.search(r"  <actuator>.*?</actuator>", OWN, re.S).group(0)
    (tmp_path / "outside.xml").write_text(f"<mujoco>{block}</mujoco>")  # a valid fragment
    folder = tmp_path / "m"
    folder.mkdir()
    (folder / "link.xml").symlink_to(tmp_path / "outside.xml")
    path = hand(folder, OWN.replace(block, f'  <include file="{where}"/>'))
    with pytest.raises(UsageError, match="lies outside the hand model's folder"):
        load_hand_spec(path)


def test_includes_and_meshes_inside_the_folder_still_load(tmp_path):
    from tactile_bullet.sim.engines.mujoco_hand import load_hand_spec, model_files

    path = split_hand(tmp_path / "m")
    load_hand_spec(path)
    assert sorted(model_files(path)) == ["actuators.xml", "hand.xml"]


def test_gltf_buffers_and_hand_model_includes_share_one_rule(tmp_path):
    from tactile_bullet.objects import meshes

    folder = tmp_path / "g"
    folder.mkdir()
    gltf = folder / "thing.gltf"
    gltf.write_text(json.dumps({"asset": {"version": "2.0"},
                                "buffers": [{"uri": "../x.bin", "byteLength": 12}]}))  # fmt: skip
    with pytest.raises(UsageError, match="lies outside the mesh's folder .*every file it includes"):
        meshes.gltf_buffer(gltf, "../x.bin")


# --- item 2: physics that went wrong is never a record ----------------------------------------


def test_a_hand_model_with_nan_gains_is_refused_before_any_grasp(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo logs the NaN it reads into ./MUJOCO_LOG.TXT
    path = hand(tmp_path / "m", re.sub(r'kp="[^"]*"', 'kp="nan"', OWN))
    for argv in (["grasp", "--shape", "sphere"],
                 ["generate", "--preset", "smoke", "--out", str(tmp_path / "ds")]):  # fmt: skip
        err = run_error(capsys, [*argv, "--hand-model", str(path)])
        assert "not a finite number" in err
    assert not (tmp_path / "ds").exists()


def test_a_grasp_whose_angles_are_not_finite_is_never_a_record(tmp_path):
    from tactile_bullet.records import load_record, save_record

    good = make_record("sphere")
    with pytest.raises(UsageError, match="angles are not finite"):
        type(good)(**{**good.__dict__, "angles": np.full_like(good.angles, np.nan)})
    path = save_record(good, tmp_path / "rec.npz")
    with np.load(path) as data:  # the same record on disk with NaN angles, as a bad hand wrote
        members = {k: data[k] for k in data.files}
    members["final_angles"] = np.full_like(members["final_angles"], np.nan)
    np.savez(path, **members)
    with pytest.raises(UsageError, match="rec.npz.*not finite"):
        load_record(path)


def test_verify_and_load_dataset_never_call_nan_records_sound(tmp_path, capsys):
    from tactile_bullet.datasets.arrays import load_dataset
    from tactile_bullet.records import save_record

    folder = tmp_path / "recs"
    folder.mkdir()
    rec = make_record("cone")
    save_record(rec, folder / "rec00000.npz")
    path = save_record(make_record("sphere"), folder / "rec00001.npz")
    with np.load(path) as data:
        members = {k: data[k] for k in data.files}
    members["efforts"] = np.full_like(members["efforts"], np.inf)
    np.savez(path, **members)
    with pytest.raises(UsageError, match="not finite"):
        load_dataset(folder)
    assert main(["verify", str(folder)]) != 0
    capsys.readouterr()


# --- item 7: actuators named for one joint and wired to another; fingers that never moved -----


def test_an_actuator_driving_another_joint_than_its_name_says_is_refused(tmp_path, capsys):
    text = OWN.replace('name="A_FFJ3" joint="FFJ3"', 'name="A_FFJ3" joint="FFJ4"')
    path = hand(tmp_path / "m", text)
    err = run_error(capsys, ["grasp", "--shape", "sphere", "--hand-model", str(path)])
    assert "A_FFJ3 drives FFJ4, not FFJ3" in err


def test_a_grasp_where_no_long_finger_moved_is_flagged_and_names_no_shape(tmp_path, capsys):
    from tactile_bullet.perception.contact import nothing_to_identify
    from tactile_bullet.records import ControllerSettings, Pose
    from tactile_bullet.sim.grasp import simulate_grasp

    path = hand(tmp_path / "m", re.sub(r'kp="[^"]*"', 'kp="0.0001"', OWN))
    ctl = ControllerSettings(engine="mujoco", hand_model=str(path))
    record = simulate_grasp("sphere", None, Pose(), ctl)
    assert "no_finger_moved" in record.flags
    assert "no long finger moved" in nothing_to_identify(record)
    assert main(["grasp", "--shape", "sphere", "--hand-model", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert "no_finger_moved" in doc["flags"]


# --- item 3: provenance of the hand on --resume -----------------------------------------------


def test_records_and_manifest_keep_the_hand_models_content_digest(tmp_path, capsys):
    from tactile_bullet.datasets.dataset import read_records
    from tactile_bullet.sim.engines.mujoco_hand import model_digest

    path = split_hand(tmp_path / "m")
    out = tmp_path / "ds"
    argv = ["generate", "--preset", "smoke", "--hand-model", str(path), "--out", str(out)]
    assert main(argv) == 0
    capsys.readouterr()
    digest, files = model_digest(path)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["config"]["sweep"]["controller"]["hand_model_digest"] == digest
    assert manifest["hand_model_files"] == files
    assert {r.controller.hand_model_digest for r in read_records(out).records} == {digest}


def test_generate_resume_refuses_a_changed_hand_naming_the_file(tmp_path, capsys):
    path = split_hand(tmp_path / "m")
    out = tmp_path / "ds"
    argv = ["generate", "--preset", "smoke", "--hand-model", str(path), "--out", str(out)]
    assert main(argv) == 0
    capsys.readouterr()
    before = (out / "manifest.json").read_bytes()
    included = tmp_path / "m" / "actuators.xml"
    included.write_text(included.read_text().replace('kp="20"', 'kp="15"', 1))
    err = run_error(capsys, [*argv, "--resume"])
    assert "another hand" in err and "actuators.xml" in err
    assert (out / "manifest.json").read_bytes() == before


def test_a_grasp_refuses_a_hand_model_changed_since_its_settings_were_made(tmp_path):
    from tactile_bullet.records import ControllerSettings, Pose
    from tactile_bullet.sim.engines.mujoco_hand import model_digest
    from tactile_bullet.sim.grasp import simulate_grasp

    path = hand(tmp_path / "m")
    ctl = ControllerSettings(engine="mujoco", hand_model=str(path),
                             hand_model_digest=model_digest(path)[0])  # fmt: skip
    path.write_text(OWN.replace('kp="20"', 'kp="15"', 1))
    with pytest.raises(UsageError, match="changed since"):
        simulate_grasp("sphere", None, Pose(), ctl)


def test_a_grasp_made_from_python_keeps_its_hand_models_digest(tmp_path):
    from tactile_bullet.records import ControllerSettings, Pose
    from tactile_bullet.sim.engines.mujoco_hand import model_digest
    from tactile_bullet.sim.grasp import simulate_grasp

    path = split_hand(tmp_path / "m")
    record = simulate_grasp("sphere", None, Pose(),
                            ControllerSettings(engine="mujoco", hand_model=str(path)))  # fmt: skip
    assert record.controller.hand_model_digest == model_digest(path)[0]
    assert record.metadata()["controller"]["hand_model_digest"] == model_digest(path)[0]
