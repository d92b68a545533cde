"""Smaller limits of issue 20: ROS topic names a bag may carry, a sweep's grasp count with mesh
objects, and the wrap model on a finger that has no object in its plane."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh
from cli_helpers import run_error

from tactile_bullet.datasets.sweeps import MAX_GRASPS, Sweep
from tactile_bullet.errors import UsageError
from tactile_bullet.perception.patterns import JOINT_LIMIT, hand_wrap_angles
from tactile_bullet.realhand.names import check_topic


@pytest.mark.parametrize("topic", ["", "nos", "/a b", "//x", "/x/", "/1x", "/x//y", "/x-y"])
def test_invalid_ros_topic_names_are_refused(topic):
    with pytest.raises(UsageError, match="is not a ROS topic name"):
        check_topic(topic)


@pytest.mark.parametrize("topic", ["/joint_states", "/rh/joint_states", "/_private/x1"])
def test_valid_ros_topic_names_pass(topic):
    assert check_topic(topic) == topic


def test_export_refuses_a_bad_topic_before_writing(tmp_path, capsys, synthetic_split):
    from tactile_bullet.realhand.recordings import write_dataset

    pytest.importorskip("rosbags")
    write_dataset(synthetic_split[1][:2], tmp_path / "ds", {"test": True})
    out = tmp_path / "x.bag"
    err = run_error(capsys, ["export", "--data", str(tmp_path / "ds"), "--out", str(out),
                             "--format", "bag", "--topic", "/a b"])  # fmt: skip
    assert "is not a ROS topic name" in err and not out.exists()


def test_sweep_limit_counts_mesh_object_samples(tmp_path, monkeypatch):
    mesh = tmp_path / "ball.stl"
    trimesh.creation.icosphere(2, radius=0.04).export(mesh)
    monkeypatch.setenv("TACTILE_BULLET_CACHE", str(tmp_path / "cache"))
    data = {"name": "big", "mode": "random", "samples": 1,
            "objects": [{"file": str(mesh), "samples": 1_000_000_000}]}  # fmt: skip
    sweep = Sweep.from_dict(data)
    assert sweep.size() == 1_000_000_000 > MAX_GRASPS
    with pytest.raises(UsageError, match="over the limit"):
        sweep.tasks()
    grid = {"name": "g", "mode": "grid",
            "objects": [{"file": str(mesh), "rotation_deg": {"min": -90, "max": 90,
                                                             "steps": 1001},
                         "offset_x": {"min": -0.01, "max": 0.01, "steps": 1001}}]}  # fmt: skip
    assert Sweep.from_dict(grid).size() == 1001 * 1001


def test_wrap_angles_of_fingers_past_the_object_are_finite_and_silent():
    """A hemisphere on its axis leaves fingers with nothing in their plane (r = 0): they close
    to the joint limit, without divide-by-zero warnings."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        theta = hand_wrap_angles(np.array([0.04, 0.03, 0.0, 0.0]), 0.05,
                                 reach=np.array([0.05, 0.04, 0.0, 0.0]))  # fmt: skip
    assert np.all(np.isfinite(theta))
    assert np.all(theta[:, 2:] == JOINT_LIMIT)
    assert np.all(theta[:, :2] < JOINT_LIMIT)
