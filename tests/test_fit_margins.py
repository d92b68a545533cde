"""The training-free shape fit's doubt calibration, read from its grid where the grid decides:
the same threshold and shares as whole fits give, for a fraction of the fits."""

from __future__ import annotations

import numpy as np

from tactile_bullet import plugins
from tactile_bullet.experiments import workflow
from tactile_bullet.learn import fit_margins
from tactile_bullet.learn.classifiers.shape_fit import ShapeFitClassifier
from tactile_bullet.learn.doubt import margins, threshold_for


def _threshold(false_alarm: float):
    return lambda right: threshold_for(right, false_alarm)


def _fitted(records):
    x = np.asarray(plugins.get_descriptor("raw-joints").transform(records), dtype=float)
    y = np.array([r.shape for r in records])
    return ShapeFitClassifier().fit(x, y), x, y


def test_a_grasp_the_grid_decides_keeps_a_floor_under_its_whole_fits_margin(synthetic_split):
    train, _ = synthetic_split
    est, x, y = _fitted(train)
    # false_alarm 0: the threshold is the lowest right margin, so floors stay floors
    m, right = fit_margins.read_folds([(est, np.arange(len(y)))], x, y, _threshold(0.0))
    floor = fit_margins.margin_floor(len(est.classes_), est.temperature)
    floored = m == floor
    assert floored.any() and not floored.all()  # both kinds of grasp in the set
    names = est.predict(x)
    whole, _ = margins(est.predict_proba(x), np.searchsorted(est.classes_, names))
    assert np.all(whole[floored] >= floor)
    np.testing.assert_allclose(m[~floored], whole[~floored], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(right, names == y)


def test_training_the_shape_fit_calibrates_as_whole_fits_do(synthetic_split, monkeypatch):
    train, _ = synthetic_split
    fast = workflow.train(train, "raw-joints", "shape-fit").info["doubt"]
    monkeypatch.setattr(fit_margins, "is_training_free", lambda estimator: False)
    whole = workflow.train(train, "raw-joints", "shape-fit").info["doubt"]
    assert fast == whole


def test_a_threshold_that_reaches_the_floor_fits_the_floored_grasps_whole(
    synthetic_split, monkeypatch
):
    """A floor of 1.0 lies above every margin: the threshold reaches it, so every floored grasp
    is fitted whole and the margins are the whole fits' own."""
    train, _ = synthetic_split
    est, x, y = _fitted(train)
    monkeypatch.setattr(fit_margins, "margin_floor", lambda classes, temperature: 1.0)
    m, _ = fit_margins.read_folds([(est, np.arange(len(y)))], x, y, _threshold(0.05))
    names = est.predict(x)
    whole, _ = margins(est.predict_proba(x), np.searchsorted(est.classes_, names))
    np.testing.assert_allclose(m, whole, rtol=0, atol=1e-12)
