"""Sweep configs: what a TOML file or a preset expands into, and how bad configs are refused."""

from __future__ import annotations

import math

import pytest

from tactile_bullet.datasets.presets import PRESETS, preset
from tactile_bullet.datasets.sweeps import Sweep
from tactile_bullet.errors import UsageError


def write(tmp_path, text: str):
    path = tmp_path / "sweep.toml"
    path.write_text(text)
    return path


GRID = """
name = "grid"
[[shapes]]
name = "cylinder"
params = { radius = [0.03, 0.04] }
offset_x = [-0.005, 0.005]
rotation_deg = [0, 10]
"""


def test_grid_is_the_product_of_the_value_lists(tmp_path):
    tasks = Sweep.from_toml(write(tmp_path, GRID)).tasks(seed=1)
    assert len(tasks) == 2 * 2 * 2
    combos = {
        (t.params["radius"], t.pose.offset[0], round(math.degrees(t.pose.rotation))) for t in tasks
    }
    assert len(combos) == 8
    assert all(t.params["length"] == 0.12 for t in tasks)  # default for unlisted sizes
    assert [t.index for t in tasks] == list(range(8))


def test_random_mode_draws_samples_within_ranges_reproducibly(tmp_path):
    text = """
mode = "random"
samples = 7
[[shapes]]
name = "sphere"
params = { radius = { min = 0.04, max = 0.05 } }
offset_z = { min = -0.01, max = 0.01 }
"""
    sweep = Sweep.from_toml(write(tmp_path, text))
    a, b, c = sweep.tasks(3), sweep.tasks(3), sweep.tasks(4)
    assert len(a) == 7
    assert all(0.04 <= t.params["radius"] <= 0.05 for t in a)
    assert all(-0.01 <= t.pose.offset[2] <= 0.01 for t in a)
    assert a == b
    assert [t.params for t in a] != [t.params for t in c]


def test_every_task_has_its_own_seed(tmp_path):
    tasks = Sweep.from_toml(write(tmp_path, GRID)).tasks(seed=0)
    assert len({t.seed for t in tasks}) == len(tasks)


def test_thesis_preset_covers_the_five_shapes_and_rotates_three():
    tasks = preset("thesis").tasks()
    assert {t.shape for t in tasks} == {"cone", "torus", "sphere", "hyperboloid", "cylinder"}
    rotated = {t.shape for t in tasks if t.pose.rotation > 0}
    assert rotated == {"torus", "hyperboloid", "cylinder"}
    angles = {round(math.degrees(t.pose.rotation)) for t in tasks}
    assert angles == {0, 5, 10, 15, 20, 25}


def test_presets_expand():
    assert {t.shape for t in preset("modified").tasks()} == {"ovoid", "hexagonal_pyramid"}
    assert 0 < len(preset("smoke").tasks()) <= 8
    assert set(PRESETS) == {"thesis", "modified", "sequential", "smoke", "temporal", "randomized",
                            "tour"}
    rotated = {t.shape for t in preset("sequential").tasks() if t.pose.rotation > 1.5}
    assert rotated == {"cylinder", "cone"}
    # chapter 3's grasps: small objects moved far enough sideways for a finger to miss them
    temporal = preset("temporal").tasks()
    assert len(temporal) <= 300
    assert max(abs(t.pose.offset[0]) for t in temporal) > 0.025


@pytest.mark.parametrize(
    "text, message",
    [
        ("name = 'x'\n[[shapes]]\nname = 'blob'\n", "unknown shape"),
        ("[[shapes]]\nname = 'sphere'\nparams = { radius = [0.5] }\n", "outside the valid range"),
        ("[[shapes]]\nname = 'sphere'\nparams = { height = [0.05] }\n", "unknown key 'height'"),
        ("colour = 'red'\n[[shapes]]\nname = 'sphere'\n", "unknown key 'colour'"),
        ("mode = 'spiral'\n[[shapes]]\nname = 'sphere'\n", "mode must be"),
        ("name = 'x'\n", "at least one"),
        ("[[shapes]]\nname = 'sphere'\noffset_x = { min = 0.0, max = 0.01 }\n", "steps"),
        ("[[shapes]\nname = 'sphere'\n", "not valid TOML"),
        ("[controller]\nmode = 'psychic'\n[[shapes]]\nname = 'sphere'\n", "mode must be"),
    ],
)
def test_bad_configs_are_refused_with_the_key_named(tmp_path, text, message):
    with pytest.raises(UsageError, match=message):
        Sweep.from_toml(write(tmp_path, text))


def test_unknown_preset_lists_the_presets():
    with pytest.raises(UsageError, match="thesis, modified, sequential, smoke"):
        preset("everything")
