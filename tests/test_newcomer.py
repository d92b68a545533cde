"""Issue 30, the newcomer's path: long commands say how long is left; the smaller things a
first user trips on (pybullet's banner, contradicting contact lines, subnormal JSON numbers,
"accuracy by size: unknown", a folder left unnamed, impossible preset grasps, help without
names, an unknown plugin name without its package)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from synthetic import write_records
from test_workflow import synthetic_set

from tactile_bullet.cli import main
from tactile_bullet.console import duration, json_ready, progress_line


def test_a_progress_line_says_done_total_rate_and_time_left():
    line = progress_line("generate: grasps", 10, 40, 5.0)
    assert line.startswith("generate: grasps: 10/40 (25%), 2.00/s")
    assert line.endswith("15 s left")
    assert duration(125) == "2 min 05 s" and duration(3725) == "1 h 02 min"


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    root = tmp_path_factory.mktemp("newcomer")
    train = write_records(root / "train", synthetic_set(6, seed=21))
    test = write_records(root / "test", synthetic_set(3, seed=22))
    return root, train, test


def _progress(capsys, monkeypatch, argv) -> str:
    monkeypatch.setenv("TACTILE_BULLET_PROGRESS_EVERY", "0")
    assert main(argv) == 0
    return capsys.readouterr().err


@pytest.mark.parametrize("command", ["train", "evaluate", "compare"])
def test_long_commands_print_progress_with_time_left(command, folders, capsys, monkeypatch):
    root, train, test = folders
    model = root / "svm.npz"
    if not model.exists():
        assert main(["train", "--data", str(train), "--out", str(model)]) == 0
        capsys.readouterr()
    argv = {
        "train": ["train", "--data", str(train), "--out", str(root / "m2.npz"), "--force"],
        "evaluate": ["evaluate", "--model", str(model), "--data", str(test)],
        "compare": ["compare", "--data", str(train), "--test", str(test),
                    "--descriptor", "signature,raw-joints", "--classifier", "svm,knn"],
    }[command]  # fmt: skip
    err = _progress(capsys, monkeypatch, argv)
    lines = [line for line in err.splitlines() if line.endswith(" left")]
    assert lines, err
    assert all("/s" in line and "/" in line.split(":")[-1] for line in lines)
    # under --json with stderr not a terminal: quiet
    err = _progress(capsys, monkeypatch, [*argv, "--json"])
    assert " left" not in err


def test_generate_prints_progress_per_grasp_and_no_pybullet_banner(tmp_path):
    env = {"TACTILE_BULLET_PROGRESS_EVERY": "0", "PATH": "/usr/bin:/bin"}
    import os

    env = {**os.environ, **env}
    proc = subprocess.run(
        [sys.executable, "-m", "tactile_bullet.cli", "generate", "--preset", "smoke", "--out",
         str(tmp_path / "d"), "--workers", "1"],
        capture_output=True, text=True, env=env, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "generate: grasps: 4/4 (100%)" in proc.stderr and " left" in proc.stderr
    assert "build time" not in proc.stdout + proc.stderr


def test_pybullet_is_imported_in_one_place():
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent / "tactile_bullet"
    importers = sorted(
        str(p.relative_to(root))
        for p in root.rglob("*.py")
        if any(line.strip().startswith(("import pybullet", "from pybullet"))
               for line in p.read_text().splitlines())  # fmt: skip
    )
    assert importers == ["sim/scene.py"]


def test_json_never_carries_subnormal_numbers():
    doc = json_ready({"a": 1.5e-323, "b": [np.float64(-5e-324), 0.25], "c": np.array([1e-320])})
    assert doc == {"a": 0.0, "b": [0.0, 0.25], "c": [0.0]}
    assert "e-32" not in json.dumps(doc)


def test_the_detector_line_never_contradicts_the_contacts():
    from tactile_bullet.cli.grasp import _detector_line

    dyn = {"non_contact": ["ff", "mf", "rf", "lf"], "decided_at_s": 2.2}
    line = _detector_line(["ff", "mf", "rf", "lf", "th"], dyn, "mujoco")
    assert "fingers off the object:" not in line
    assert "wrong here, the simulator has them in contact" in line and "mujoco" in line
    line = _detector_line(["ff", "mf"], {"non_contact": ["lf"], "decided_at_s": 1.0}, "bullet")
    assert line.startswith("fingers off the object by the joint angles alone") and "lf" in line


def test_evaluate_on_recordings_says_size_and_pose_are_not_known():
    from tactile_bullet.experiments.reports import summary_text

    unknown = {"unknown": {"accuracy": 0.95, "support": 20}}
    doc = {"accuracy": 0.95, "records": 20, "classes": ["a", "b"],
           "confusion_matrix": [[10, 0], [1, 9]], "by_size": unknown,
           "by_position": unknown, "by_rotation": unknown}  # fmt: skip
    text = summary_text(doc)
    assert "unknown 95%" not in text
    assert "accuracy by size, position, rotation: not known" in text


def test_temporal_names_the_folder_it_wrote(tmp_path, capsys):
    data, out = tmp_path / "smoke", tmp_path / "temporal-report"
    assert main(["generate", "--preset", "smoke", "--out", str(data), "--workers", "0"]) == 0
    assert main(["temporal", "--data", str(data), "--out", str(out)]) == 0
    last = capsys.readouterr().out.splitlines()[-1]
    assert last.startswith("wrote ") and f"to {out}/" in last


def test_the_temporal_preset_makes_no_impossible_grasp():
    """Every cone draw of the preset (the shape that overlapped the little finger's metacarpal)
    fits the open hand: checked as the grasp does, before any finger moves."""
    from tactile_bullet.datasets.presets import preset
    from tactile_bullet.plugins import get_engine
    from tactile_bullet.sim.grasp import PENETRATION_TOLERANCE, _frozen, resolve_shape

    tasks = [t for t in preset("temporal").tasks(0) if "cone" in str(t.target())]
    assert len(tasks) == 40
    for task in tasks:
        spec = task.target()
        spec = resolve_shape(spec) if isinstance(spec, str) else spec
        engine = get_engine("bullet")(spec, spec.resolve(task.params), task.pose, task.controller)
        try:
            movable = _frozen(engine.columns)
            engine.reset_joints(movable, [0.0] * len(movable))
            assert not engine.penetrations(PENETRATION_TOLERANCE), (task.params, task.pose)
        finally:
            engine.close()


def test_generate_says_why_grasps_failed(tmp_path):
    from tactile_bullet.cli.generate import failure_lines

    failed = [{"task": i, "error": "UsageError: pose puts the cone inside the open hand"}
              for i in (3, 9)]  # fmt: skip
    manifest = {"format": 1, "config": {"sweep": {}, "seed": 0, "shard_size": 32}, "tasks": 10,
                "software": {}, "shards": [], "failed": failed}  # fmt: skip
    (tmp_path / "manifest.json").write_text(json.dumps(manifest))
    lines = failure_lines(str(tmp_path))
    assert lines == ["failed: 2 grasps (task 3, 9): UsageError: pose puts the cone inside the "
                     "open hand"]  # fmt: skip


def test_help_lists_names_and_preset_sizes(capsys):
    assert main(["train", "--help"]) == 0
    out = capsys.readouterr().out
    assert "classifiers: svm, knn" in out and "descriptors (join with +): signature" in out
    assert main(["generate", "--help"]) == 0
    out = capsys.readouterr().out
    assert "tour (39 grasps" in out and "thesis (1,143 grasps, ~" in out


def test_an_unknown_example_plugin_name_says_how_to_install_it(folders, capsys):
    from cli_helpers import run_error

    root, train, _ = folders
    err = run_error(capsys, ["train", "--data", str(train), "--classifier", "random-forest",
                             "--out", str(root / "rf.npz")])  # fmt: skip
    assert "pip install ./plugins/tactile-bullet-example" in err


def test_a_grasps_shape_fit_is_computed_once(monkeypatch):
    from tactile_bullet.perception import shape_fit

    calls = []
    real = shape_fit._fit
    monkeypatch.setattr(shape_fit, "_fit", lambda *a: calls.append(1) or real(*a))
    angles = np.full((3, 4), 0.6) + np.arange(12).reshape(3, 4) * 1e-3
    first = shape_fit.fit_shape(angles)
    again = shape_fit.fit_shape(angles.copy())
    assert again is first and len(calls) == 1
    shape_fit.fit_shape(angles, ["sphere", "torus"])  # other families: fitted anew
    assert len(calls) == 2


def _recording(root, test):
    """The test set exported as a hand's CSV (made once per module)."""
    path = root / "session.csv"
    if not path.exists():
        assert main(["export", "--data", str(test), "--format", "csv", "--out", str(path)]) == 0
    return path


@pytest.mark.parametrize(
    "command", ["calibrate", "import", "identify --recording", "temporal", "sequential"]
)
def test_the_other_long_commands_print_progress_with_time_left(command, folders, capsys,
                                                               monkeypatch):  # fmt: skip
    root, train, test = folders
    csv = _recording(root, test)
    if command == "temporal":  # chapter 3 reads the grasps as they ran: four simulated ones
        train = root / "smoke"
        if not train.exists():
            assert main(["generate", "--preset", "smoke", "--out", str(train),
                         "--workers", "1"]) == 0  # fmt: skip
    capsys.readouterr()
    out = root / command.replace(" --", "-")
    argv = {
        "calibrate": ["calibrate", "--data", str(train), "--out", str(out) + ".toml", "--force"],
        "import": ["import", str(csv), "--out", str(out), "--force"],
        "identify --recording": ["identify", "--recording", str(csv)],
        "temporal": ["temporal", "--data", str(train), "--out", str(out), "--force"],
        "sequential": ["sequential", "--data", str(train), "--out", str(out), "--orders", "1",
                       "--n-updates", "5", "--recalibration", "2", "--force"],
    }[command]  # fmt: skip
    err = _progress(capsys, monkeypatch, argv)
    lines = [line for line in err.splitlines() if line.endswith(" left")]
    assert lines, err
    assert all("/s" in line for line in lines)


def test_benchmark_prints_progress_with_time_left(tmp_path, capsys, monkeypatch):
    argv = ["benchmark", "--scale", "tiny", "--protocol", "in-distribution", "--descriptor",
            "signature", "--classifier", "knn", "--training", "clean", "--out",
            str(tmp_path / "b"), "--workers", "1"]  # fmt: skip
    err = _progress(capsys, monkeypatch, argv)
    lines = [line for line in err.splitlines() if line.endswith(" left")]
    assert lines, err
    assert all("/s" in line for line in lines)
