"""The ``fusion`` classifier: trees on the time series seconded by the shape fit where it fits well
(learn/classifiers/fusion.py). Its scikit-learn conformance runs in test_classifiers.py."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_bullet import plugins
from tactile_bullet.errors import UsageError
from tactile_bullet.experiments import workflow
from tactile_bullet.learn.classifiers.fusion import WEIGHTS, fuse, joint_columns

DESCRIPTOR = "time-series+robust-joints"


def _log(p):
    return np.log(np.asarray(p, dtype=float))


def test_a_split_forest_is_decided_by_a_well_fitting_shape_fit():
    # trees split evenly between classes 0 and 1; the shape fit prefers 1 and fits as well as
    # the training grasps did (best score = the reference): its answer wins
    trees = _log([[0.45, 0.45, 0.1]])
    scores = np.array([[14.0 + 3.0, 14.0, 30.0]])
    assert np.argmax(fuse(trees, scores, weight=1.0, reference=14.0, sharpness=8.0)) == 1
    # with weight 0 the shape fit has no say (a tie goes to the first class)
    assert np.argmax(fuse(trees, scores, weight=0.0, reference=14.0, sharpness=8.0)) == 0


def test_a_sure_forest_outvotes_a_shape_fit_that_fits_the_grasp_badly():
    # trees sure of class 0; the shape fit names 2 but explains the grasp twice as badly as a
    # typical training grasp (another engine's grasp): trust (1/2)**8, the trees' answer stands
    trees = _log([[0.9, 0.05, 0.05]])
    scores = np.array([[28.0 + 20.0, 40.0, 28.0]])
    fused = fuse(trees, scores, weight=10.0, reference=14.0, sharpness=8.0)
    assert np.argmax(fused) == 0
    # the same grasp fitted as well as the training grasps: the shape fit overrules the trees
    good = scores - 14.0
    assert np.argmax(fuse(trees, good, weight=10.0, reference=14.0, sharpness=8.0)) == 2
    # and with no sharpness the trust is always 1: the badly fitted grasp goes to the shape fit
    assert np.argmax(fuse(trees, scores, weight=10.0, reference=14.0, sharpness=0.0)) == 2


def test_trust_never_exceeds_one_on_a_grasp_fitted_better_than_usual():
    trees = _log([[0.6, 0.4]])
    a = fuse(trees, np.array([[7.0, 8.0]]), 1.0, 14.0, 8.0)
    b = fuse(trees, np.array([[14.0, 15.0]]), 1.0, 14.0, 8.0)
    np.testing.assert_allclose(a, b)  # the same gap, trusted fully both times


def test_joint_columns_follow_the_descriptor_layout():
    desc = plugins.get_descriptor(DESCRIPTOR)
    n = len(desc.feature_names())
    assert joint_columns(n) == 17
    thumb = plugins.get_descriptor(DESCRIPTOR, include_thumb=True)
    assert joint_columns(len(thumb.feature_names())) == 22
    with pytest.raises(ValueError, match="time-series\\+robust-joints"):
        joint_columns(17)


@pytest.fixture(scope="module")
def fused_model(synthetic_split):
    train, _ = synthetic_split
    return workflow.train(train, DESCRIPTOR, "fusion", doubt=False)


def test_fusion_learns_synthetic_grasps_and_keeps_its_chosen_weight(fused_model, synthetic_split):
    _, test = synthetic_split
    est = fused_model.estimator
    assert est.weight_ in WEIGHTS
    assert set(est.held_out_accuracy_) == set(WEIGHTS)
    # the kept weight is the largest within the tolerance of the best held-out accuracy
    best = max(est.held_out_accuracy_.values())
    within = [w for w, a in est.held_out_accuracy_.items() if a >= best - est.tolerance - 1e-12]
    assert est.weight_ == max(within)
    assert est.reference_score_ > 0
    y = np.array([r.shape for r in test])
    proba = est.predict_proba(plugins.get_descriptor(DESCRIPTOR).transform(test))
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)
    assert np.mean(est.classes_[np.argmax(proba, axis=1)] == y) >= 0.8


def test_a_saved_fusion_model_loads_and_answers_the_same(fused_model, synthetic_split, tmp_path):
    from tactile_bullet.learn.models import load_model, save_model

    _, test = synthetic_split
    loaded = load_model(save_model(tmp_path / "fusion.npz", fused_model))
    assert type(loaded.estimator) is type(fused_model.estimator)
    assert loaded.estimator.weight_ == fused_model.estimator.weight_
    np.testing.assert_array_equal(loaded.predict_proba_records(test[:2]),
                                  fused_model.predict_proba_records(test[:2]))  # fmt: skip


def test_weight_zero_is_the_extra_trees_alone(synthetic_split):
    train, test = synthetic_split
    desc = plugins.get_descriptor(DESCRIPTOR)
    x, xt = desc.transform(train), desc.transform(test)
    y = np.array([r.shape for r in train])
    fused = plugins.get_classifier("fusion", weight=0).fit(x, y)
    assert fused.held_out_accuracy_ == {}
    series = plugins.get_descriptor("time-series")
    trees = plugins.get_classifier("extra-trees").fit(series.transform(train), y)
    np.testing.assert_array_equal(fused.predict(xt), trees.predict(series.transform(test)))


def test_fusion_reads_only_its_layout_and_shape_classes(synthetic_split):
    train, _ = synthetic_split
    assert plugins.accepted_descriptors("fusion") == (DESCRIPTOR, "time-series+raw-joints")
    assert not plugins.compatible("time-series", "fusion")
    with pytest.raises(UsageError, match="fusion reads only the time-series\\+robust-joints"):
        workflow.train(train, "time-series", "fusion")
    x = plugins.get_descriptor(DESCRIPTOR).transform(train)
    y = np.array([r.shape for r in train])
    with pytest.raises(ValueError, match="no model of class"):
        plugins.get_classifier("fusion").fit(x, np.where(y == "cone", "mug", y))
    one_each = np.unique(y, return_index=True)[1]
    with pytest.raises(ValueError, match="at least 2 training grasps of each shape"):
        plugins.get_classifier("fusion").fit(x[one_each], y[one_each])
    # a given weight needs no folds
    plugins.get_classifier("fusion", weight=3.0).fit(x[one_each], y[one_each])


@pytest.mark.parametrize(
    ("params", "match"),
    [({"weight": -1}, "weight"), ({"weight": "big"}, "weight"), ({"sharpness": -2}, "sharpness"),
     ({"tolerance": 1.5}, "tolerance"), ({"folds": 1}, "folds"),
     ({"n_estimators": 0}, "n_estimators")],
)  # fmt: skip
def test_bad_parameters_are_a_usage_error_before_training(params, match, synthetic_split):
    train, _ = synthetic_split
    with pytest.raises(UsageError, match=match):
        workflow.train(train, DESCRIPTOR, "fusion", params=params)
