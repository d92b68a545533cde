"""Answers of no family (learn/novelty.py): ``unknown`` where a grasp lies far from every
training grasp, calibrated to leave at most 5% of in-family grasps unknown, kept in model
files and refused when damaged."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_bullet.errors import UsageError
from tactile_bullet.experiments import workflow
from tactile_bullet.learn import doubt
from tactile_bullet.learn.models import load_model, save_model
from tactile_bullet.learn.novelty import UNKNOWN_RATE, Novelty


def _families(rng, n):
    """Three well-separated 'families' in 6 features, their labels."""
    centres = np.array([[0, 0, 0, 0, 0, 0], [4, 4, 0, 0, 0, 0], [0, 4, 4, 0, 0, 0]], float)
    y = rng.integers(0, 3, n)
    return centres[y] + rng.normal(0, 0.5, (n, 6)), y.astype(str)


def test_at_most_the_calibrated_share_of_new_in_family_grasps_is_answered_unknown():
    rng = np.random.default_rng(0)
    x, y = _families(rng, 600)
    novelty = Novelty.fit(x, y)
    fresh, _ = _families(rng, 3000)
    # held-out folds set the threshold; fresh grasps of the same families stay near the budget
    assert np.mean(novelty.unknown(fresh)) <= 2 * UNKNOWN_RATE


def test_a_grasp_far_from_every_family_is_unknown_and_one_inside_is_not():
    rng = np.random.default_rng(1)
    x, y = _families(rng, 300)
    novelty = Novelty.fit(x, y)
    far = np.array([[10.0, -6, 3, 5, -4, 2]])
    inside = np.array([[4.0, 4, 0, 0, 0, 0]])
    assert novelty.unknown(far)[0] and not novelty.unknown(inside)[0]
    assert novelty.scores(far)[0] > novelty.threshold > novelty.scores(inside)[0]


def test_a_feature_that_never_varied_in_training_does_not_make_every_grasp_unknown():
    rng = np.random.default_rng(2)
    x, y = _families(rng, 300)
    x[:, 5] = 0.25  # a joint that stayed still in every training grasp
    novelty = Novelty.fit(x, y)
    nudged = x[:50].copy()
    nudged[:, 5] += 0.01  # sensor noise on it
    assert np.mean(novelty.unknown(nudged)) <= 0.1


def test_trained_models_carry_novelty_through_a_save_and_answer_unknown(synthetic_split,
                                                                          tmp_path):
    train, test = synthetic_split
    model = workflow.train(train, "raw-joints", "knn")
    assert model.novelty is not None and model.info["novelty"]["rate"] == UNKNOWN_RATE
    loaded = load_model(save_model(tmp_path / "m.npz", model))
    assert loaded.novelty.threshold == pytest.approx(model.novelty.threshold)
    doc = workflow.identify(loaded, test[0])
    assert doc["unknown"] in (True, False) and doc["novelty"] >= 0
    loaded.novelty = Novelty(loaded.novelty.centre, loaded.novelty.scale,
                             loaded.novelty.reference, -1.0)  # every grasp is "far"
    doc = workflow.identify(loaded, test[0])
    assert doc["unknown"] is True and doc["shape"] in loaded.classes  # best guess still given


@pytest.mark.parametrize(
    "damage, message",
    [
        (lambda a: a.update({"novelty.reference": a["novelty.reference"][:, :2]}), "shape"),
        (lambda a: a.update({"novelty.scale": -a["novelty.scale"]}), "scale"),
        (lambda a: a.update({"novelty.centre": a["novelty.centre"] * np.nan}), "non-numbers"),
        (lambda a: a.pop("novelty.reference"), "incomplete"),
    ],
)
def test_a_model_with_damaged_novelty_is_refused(synthetic_split, tmp_path, damage, message):
    train, _ = synthetic_split
    path = save_model(tmp_path / "m.npz", workflow.train(train, "raw-joints", "knn",
                                                         doubt=False))  # fmt: skip
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    damage(arrays)
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(UsageError, match=f"novelty.*{message}|{message}.*novelty|{message}"):
        load_model(tmp_path / "bad.npz")


def test_evaluate_reports_the_unknown_share_in_and_out_of_family_apart(synthetic_split):
    train, test = synthetic_split
    shapes = sorted({r.shape for r in train})
    model = workflow.train([r for r in train if r.shape != shapes[-1]], "raw-joints", "knn")
    doc = workflow.evaluate(model, test)
    unknown = doc["unknown"]
    assert unknown["out_of_family_grasps"] == sum(r.shape == shapes[-1] for r in test)
    assert unknown["in_family_grasps"] == len(test) - unknown["out_of_family_grasps"]
    assert 0 <= unknown["in_family"] <= 1 and 0 <= unknown["out_of_family"] <= 1


def test_an_answer_is_unknown_only_past_the_threshold():
    kw = dict(classes=["a", "b"], shape="a", proba=np.array([0.9, 0.1]), threshold=0.1)
    assert doubt.answer_doubt(**kw, novelty=2.0, novelty_threshold=1.0)["unknown"] is True
    assert doubt.answer_doubt(**kw, novelty=0.5, novelty_threshold=1.0)["unknown"] is False
    assert doubt.answer_doubt(**kw)["unknown"] is False  # an older model: never unknown


def test_noisy_copies_of_a_grasp_are_held_out_together():
    """Noise-aware training presents each grasp 5 times: calibrated with a grasp's copies in
    the other folds, each held-out grasp finds itself, the threshold collapses and in-family
    grasps are answered unknown (the second replicate run of docs/robustness.md)."""
    from dataclasses import replace

    from synthetic import make_records

    from tactile_bullet.learn.novelty import Novelty, grasp_groups
    from tactile_bullet.learn.robust import augment

    records = make_records(per_shape=12, seed=4)
    copies = augment(records, seed=0)
    groups = grasp_groups(copies)
    assert len(set(groups.tolist())) == len(records)
    assert list(groups[: len(records)]) == list(groups[len(records) : 2 * len(records)])
    relabelled = [replace(r, seed=i) for i, r in enumerate(records)]
    assert len(set(grasp_groups(relabelled).tolist())) == len(records)  # distinct grasps

    from tactile_bullet.plugins import get_descriptor

    x = np.asarray(get_descriptor("raw-joints").transform(copies), float)
    y = np.array([r.shape for r in copies])
    leaky = Novelty.fit(x, y)
    grouped = Novelty.fit(x, y, groups=groups)
    assert grouped.threshold > 1.5 * leaky.threshold


def test_whole_sizes_are_held_out_only_where_every_shape_has_several(monkeypatch):
    """``HOLD_OUT_SIZES``: one group per shape and size, a grasp's copies and its other poses
    in it; where a shape has fewer sizes than folds, or a grasp no known size (a recording),
    the groups stay per grasp, since holding out a size would hold out the shape."""
    from dataclasses import replace

    from synthetic import make_records

    from tactile_bullet.learn import novelty as N

    records = make_records(per_shape=4, seed=4)
    posed = [replace(r, seed=r.seed + 100) for r in records]  # the same sizes, other grasps
    both = records + posed
    per_grasp = N.calibration_groups(both)
    assert len(set(per_grasp.tolist())) == len(both)
    monkeypatch.setattr(N, "HOLD_OUT_SIZES", True)
    sized = N.calibration_groups(both)
    assert len(set(sized.tolist())) == len(records)  # each size with its twin
    assert list(sized[: len(records)]) == list(sized[len(records):])
    few = [r for r in both if r.shape != records[0].shape or r is records[0]]
    assert len(set(N.calibration_groups(few).tolist())) == len(few)  # one size: per grasp
    unsized = [replace(r, params={}) for r in both]
    assert len(set(N.calibration_groups(unsized).tolist())) == len(both)


def _sized_grasps(rng, sizes, per_size):
    """Grasps of one family along a curve of its size (the features bend with it, as a small
    sphere's angles do), ``per_size`` noisy grasps at each of ``sizes``."""
    s = np.repeat(np.asarray(sizes, float), per_size)
    curve = np.stack([s, s**2, np.cos(2 * s)], axis=1)
    return curve + rng.normal(0, 0.02, curve.shape), s


def test_midpoints_of_neighbouring_sizes_bring_a_grasp_between_two_sizes_in():
    """SIZE_MIDPOINTS: a grasp of a size between two training sizes is answered by its family,
    not unknown, once the reference holds their midpoints; one off the family's curve stays
    unknown, and the held-out calibration still leaves few in-family grasps unknown."""
    rng = np.random.default_rng(5)
    grid = np.linspace(0.0, 1.0, 5)
    x, s = _sized_grasps(rng, grid, 40)
    y = np.full(len(x), "sphere")
    ranks = np.searchsorted(grid, s)
    pairs = np.array([(i, int(rng.choice(np.flatnonzero(np.abs(ranks - ranks[i]) == 1))))
                      for i in range(len(x))])  # fmt: skip
    plain = Novelty.fit(x, y)
    mids = Novelty.fit(x, y, pairs=pairs)
    between, _ = _sized_grasps(rng, (grid[:-1] + grid[1:]) / 2, 10)
    assert np.mean(plain.unknown(between)) > 0.9  # the gap the plain reference leaves
    assert np.mean(mids.unknown(between)) < 0.3  # the curve's bend between sizes stays
    off = np.array([[0.5, 0.75, 0.2]])  # a size's first two features, another's third
    assert mids.unknown(off)[0]
    assert len(mids.reference) == len(plain.reference) + len(pairs)
    fresh, _ = _sized_grasps(rng, grid, 20)
    assert np.mean(mids.unknown(fresh)) <= 2 * UNKNOWN_RATE


def test_midpoint_pairs_join_neighbouring_sizes_of_one_shape_on_one_engine(monkeypatch):
    from dataclasses import replace

    from synthetic import make_records

    from tactile_bullet.learn import novelty as N

    records = make_records(per_shape=6, seed=7)
    assert N.midpoint_pairs(records, on=False) is None
    pairs = N.midpoint_pairs(records, on=True)
    assert pairs is not None and len(pairs)
    for i, j in pairs:
        a, b = records[i], records[j]
        assert a.shape == b.shape and a.controller.engine == b.controller.engine
        assert a.params != b.params
        for k in a.params:  # neighbours among the values this shape was grasped at
            values = sorted({r.params[k] for r in records if r.shape == a.shape})
            assert abs(values.index(a.params[k]) - values.index(b.params[k])) <= 1
    monkeypatch.setattr(N, "SIZE_MIDPOINTS", True)  # as kept on the fifteenth replicate
    assert np.array_equal(N.midpoint_pairs(records), pairs)
    monkeypatch.setattr(N, "SIZE_MIDPOINTS", False)
    assert N.midpoint_pairs(records) is None
    unsized = [replace(r, params={}) for r in records]
    assert N.midpoint_pairs(unsized) is None  # a recording's grasps: no known sizes
