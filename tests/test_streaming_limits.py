"""The live Identifier under realistic conditions: 1 deg of joint noise during a hold, and a hand
left open and idle for a long time. A hold must be decided, and neither must grow the buffer."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_bullet.experiments import workflow
from tactile_bullet.hand import JOINT_NAMES
from tactile_bullet.realhand import streaming
from tactile_bullet.realhand.streaming import Identifier

NAMES = ["rh_" + n for n in JOINT_NAMES]
NOISE = np.radians(1.0)


@pytest.fixture(scope="module")
def model(synthetic_split):
    return workflow.train(synthetic_split[0], "signature", "svm")


def _grasp(ident, record, rng, t0=0.0, rate=100.0):
    """The record's closing motion resampled at ``rate`` Hz with 1 deg noise on every joint."""
    times = np.arange(0.0, record.time[-1], 1.0 / rate)
    angles = np.column_stack([np.interp(times, record.time, record.angles[:, j])
                              for j in range(record.angles.shape[1])])  # fmt: skip
    for t, q in zip(times, angles, strict=True):
        ident.update(t0 + t, NAMES, q + rng.normal(0.0, NOISE, q.shape))
    return t0 + times[-1]


def test_a_noisy_hold_is_decided_and_keeps_the_buffer_bounded(model, synthetic_split):
    rng = np.random.default_rng(0)
    record = synthetic_split[1][0]
    ident = Identifier(model)
    end = _grasp(ident, record, rng)
    held = record.angles[-1]
    decided_at = None
    for k in range(1, 3001):  # a 30 s hold at 100 Hz, every sample noisy
        ident.update(end + k / 100, NAMES, held + rng.normal(0.0, NOISE, held.shape))
        if decided_at is None and k % 10 == 0 and ident.result()["grasp_over"]:
            decided_at = k / 100
    out = ident.result()
    assert decided_at is not None and decided_at < 1.0  # seconds of hold before the answer
    assert out["grasp_over"] and out["shape"] in model.classes
    grasp_samples = int(record.time[-1] * 100) + 1
    assert out["samples"] < grasp_samples + 200  # not the 3,000 samples of the hold
    assert out["shape"] == workflow.predict(model, [record])[0]


def test_an_idle_open_hand_keeps_a_bounded_buffer_and_still_sees_the_next_grasp(
    model, synthetic_split, monkeypatch
):
    monkeypatch.setattr(streaming, "TRIM_AT", 256)
    rng = np.random.default_rng(1)
    ident = Identifier(model)
    open_hand = np.zeros(len(NAMES))
    for k in range(5000):  # 50 s idle with noise: the lowest closure is an early sample
        ident.update(k / 100, NAMES, open_hand + rng.normal(0.0, NOISE / 2, open_hand.shape))
        assert len(ident._t) <= 256 + 1
    record = synthetic_split[1][1]
    end = _grasp(ident, record, rng, t0=50.0)
    ident.finish()
    out = ident.result()
    assert out["grasp_over"] and out["samples"] <= int(record.time[-1] * 100) + 256
    assert end > 50.0


def test_a_grasp_that_never_settles_is_decided_at_the_sample_cap(model, synthetic_split,
                                                                monkeypatch):  # fmt: skip
    monkeypatch.setattr(streaming, "MAX_GRASP_SAMPLES", 500)
    ident = Identifier(model)
    record = synthetic_split[1][0]
    rng = np.random.default_rng(2)
    end = _grasp(ident, record, rng)
    held = record.angles[-1].copy()
    for k in range(1, 2000):  # the fingers keep creeping: never still
        held[[3, 4, 5]] += 0.0004 * (-1) ** (k // 50)
        ident.update(end + k / 100, NAMES, held)
        assert len(ident._t) <= 600  # the cap, and the samples before the grasp began
    assert ident.result()["grasp_over"]
