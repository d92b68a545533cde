"""``generate --scale small``: every preset at the README tour's size, the same recipe on fewer
grasps (the tour runs them as written; tests/test_readme.py)."""

from __future__ import annotations

from collections import Counter

from cli_helpers import run_error

from tactile_bullet.datasets.presets import PRESETS, preset, preset_help


def test_small_presets_keep_their_recipe_on_tens_of_grasps():
    sizes = {name: len(preset(name, scale="small").tasks(0)) for name in PRESETS}
    assert sizes == {"tour": 39, "thesis": 39, "modified": 18, "sequential": 42, "smoke": 4,
                     "temporal": 20, "randomized": 39}  # fmt: skip
    small = preset("randomized", scale="small")
    assert small.randomize is not None and small.randomize == preset("randomized").randomize
    tasks = small.tasks(0)
    assert len({t.seed for t in tasks}) == len(tasks)  # the hand drawn per grasp, as in full
    thesis, tour = preset("thesis", scale="small").tasks(0), preset("tour").tasks(0)
    assert [(t.shape, t.params, t.pose) for t in thesis] == [(t.shape, t.params, t.pose)
                                                             for t in tour]  # fmt: skip
    classes = Counter((t.shape, round(t.pose.rotation, 3))
                      for t in preset("sequential", scale="small").tasks(0))  # fmt: skip
    assert len(classes) == 7 and min(classes.values()) >= 3  # the experiment's split needs 3
    assert "randomized (1,143 grasps" in preset_help() and "--scale small: 39" in preset_help()


def test_scale_applies_to_presets_only(tmp_path, capsys):
    config = tmp_path / "s.toml"
    config.write_text('name = "s"\n[[shapes]]\nname = "sphere"\n')
    err = run_error(capsys, ["generate", "--config", str(config), "--scale", "small",
                             "--out", str(tmp_path / "d")])  # fmt: skip
    assert "--scale applies to a --preset" in err and not (tmp_path / "d").exists()
