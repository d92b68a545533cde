"""The `bullet` engine's records are byte-identical to those made before the engine interface.

The digests were taken from the code as it stood before ``sim/scene.py`` moved behind
``sim/engines/`` (commit 413218c): sha256 over each record's metadata and every array. A change
here means every saved dataset and every quoted figure would move; it must be deliberate.
Digests are of float bytes, so they hold for one PyBullet build on one CPU family (x86-64).
"""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from tactile_bullet.records import ControllerSettings, Pose
from tactile_bullet.sim.grasp import simulate_grasp

CENTRED = Pose((0.004, 0.0, 0.0), 0.1)
SIDEWAYS = Pose((0.025, -0.005, 0.0), 0.0)
EARLY = ControllerSettings(early_stop=True, preshape=True)

REFERENCE = {
    ("cone", "torque"): "13afa8475793aa6d",
    ("torus", "torque"): "dfd70d5079d311bf",
    ("sphere", "torque"): "d1bf6e5f2e561fbf",
    ("hyperboloid", "torque"): "7f3e466441655d56",
    ("cylinder", "torque"): "b82596a69193310f",
    ("cone", "contact"): "eafdc664f7f597c2",
    ("torus", "contact"): "57689410c95d1b84",
    ("sphere", "contact"): "2c7d08c9fb15c2fb",
    ("hyperboloid", "contact"): "6c16e1c71f483d5a",
    ("cylinder", "contact"): "e70c16d7fba1c38f",
    ("cone", "early"): "7a1fd8b3c84c913b",
    ("torus", "early"): "9a98e4fd9cbc81f4",
    ("sphere", "early"): "4ddd6e1f4cd2d580",
    ("hyperboloid", "early"): "1eab0c05043c4c4f",
    ("cylinder", "early"): "d4879ca6672f3c63",
}


def record_digest(record) -> str:
    """sha256 (16 hex digits) of the record's saved metadata and every saved array."""
    h = hashlib.sha256(json.dumps(record.metadata(), sort_keys=True).encode())
    for key, value in sorted(record.arrays().items()):
        h.update(key.encode())
        h.update(np.ascontiguousarray(value).tobytes())
    return h.hexdigest()[:16]


@pytest.mark.parametrize(("shape", "case"), sorted(REFERENCE))
def test_bullet_records_match_the_pre_interface_digests(shape, case):
    if case == "early":
        record = simulate_grasp(shape, None, SIDEWAYS, EARLY, seed=2)
    else:
        record = simulate_grasp(shape, None, CENTRED, ControllerSettings(mode=case), seed=1)
    assert record_digest(record) == REFERENCE[(shape, case)]
