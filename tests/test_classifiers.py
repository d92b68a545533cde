"""Classifiers: scikit-learn conformance and learning on synthetic grasps, for every registered
classifier (a plugin's joins these tests by being registered)."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.utils.estimator_checks import parametrize_with_checks
from synthetic import make_records

from tactile_bullet import plugins
from tactile_bullet.errors import UsageError

CLASSIFIERS = plugins.classifier_names()
DESCRIPTORS = plugins.descriptor_names()
SAME_LAYOUT = {("coupled-time-series", "neural-forest"): "time-series + neural-forest"}
"""Pairs left out as a second copy of a slow one: the same columns (learn/coupled.py), and the
neural forest on 1,088 time-series columns takes 1-2 min on 2 shared cores."""
PAIRS = [
    (d, c)
    if plugins.compatible(d, c) and (d, c) not in SAME_LAYOUT
    else pytest.param(d, c, marks=pytest.mark.skip(
        f"same layout as {SAME_LAYOUT[d, c]}" if (d, c) in SAME_LAYOUT
        else "reads another descriptor"))  # fmt: skip
    for d in DESCRIPTORS
    for c in CLASSIFIERS
]


CHECKED_ELSEWHERE = {
    "neural-forest": "tests/test_neural_forest.py, with quick settings",
    "tcn": "tests/test_time_series.py, with quick settings",
}
"""Classifiers whose conformance checks run in their own test module (with settings that keep
the checks fast); every other registered classifier, a plugin's included, is checked here."""


def _expected_failures(estimator) -> dict[str, str]:
    declared = getattr(estimator, "expected_failed_checks", None)
    return declared() if callable(declared) else {}


@parametrize_with_checks(
    [plugins.get_classifier(name) for name in CLASSIFIERS if name not in CHECKED_ELSEWHERE],
    expected_failed_checks=_expected_failures,
)
def test_scikit_learn_conformance(estimator, check):
    check(estimator)


@pytest.fixture(scope="module")
def features(synthetic_split):
    train, test = synthetic_split
    cache = {}

    def get(name):
        if name not in cache:
            desc = plugins.get_descriptor(name)
            cache[name] = (desc.transform(train), desc.transform(test))
        return cache[name]

    return get


@pytest.mark.parametrize(("descriptor", "classifier"), PAIRS)
def test_every_pair_beats_chance_on_synthetic_grasps(
    descriptor, classifier, features, synthetic_split
):
    train, test = synthetic_split
    X_train, X_test = features(descriptor)
    y_train = np.array([r.shape for r in train])
    y_test = np.array([r.shape for r in test])
    estimator = plugins.get_classifier(classifier).fit(X_train, y_train)
    proba = estimator.predict_proba(X_test)
    assert proba.shape == (len(test), 5)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)
    accuracy = np.mean(estimator.predict(X_test) == y_test)
    assert accuracy >= 0.5, f"{descriptor} + {classifier}: {accuracy:.2f} (chance 0.20)"


@pytest.mark.parametrize("name", ["svm", "knn", "som", "dtw-template"])
def test_predict_is_the_most_probable_class(name, features, synthetic_split):
    train, test = synthetic_split
    X_train, X_test = features("signature")
    estimator = plugins.get_classifier(name).fit(X_train, [r.shape for r in train])
    proba = estimator.predict_proba(X_test)
    np.testing.assert_array_equal(
        estimator.predict(X_test), estimator.classes_[np.argmax(proba, axis=1)]
    )


def test_som_keeps_its_map_for_figures(features, synthetic_split):
    train, _ = synthetic_split
    X_train, _ = features("signature")
    y = [r.shape for r in train]
    som = plugins.get_classifier("som", rows=5, cols=6).fit(X_train, y)
    assert som.umatrix_.shape == (5, 6) and np.all(som.umatrix_ >= 0)
    assert som.hit_map_.shape == (5, 6) and som.hit_map_.sum() == len(train)
    assert som.hits_.shape == (5, 6, 5)
    assert set(np.unique(som.unit_labels_)) <= set(som.classes_)
    assert som.bmu_coordinates(X_train[:3]).shape == (3, 2)
    again = plugins.get_classifier("som", rows=5, cols=6).fit(X_train, y)
    np.testing.assert_array_equal(som.weights_, again.weights_)


def test_som_units_that_won_nothing_answer_like_their_nearest_labelled_unit():
    X = np.array([[0.0, 0.0], [0.1, 0.0], [5.0, 5.0], [5.1, 5.0]])
    som = plugins.get_classifier("som", rows=6, cols=6, epochs=5).fit(X, ["a", "a", "b", "b"])
    assert (som.hit_map_ == 0).any()
    units = som.weights_.reshape(-1, 2)
    labelled = np.flatnonzero(som.hit_map_.ravel() > 0)
    for unit in np.flatnonzero(som.hit_map_.ravel() == 0):
        nearest = labelled[np.argmin(np.linalg.norm(units[labelled] - units[unit], axis=1))]
        np.testing.assert_array_equal(som.unit_proba_[unit], som.unit_proba_[nearest])


def test_dtw_template_is_training_free(features, synthetic_split):
    train, test = synthetic_split
    X_train, X_test = features("signature")
    y = np.array([r.shape for r in train])
    one_each = [int(np.flatnonzero(y == s)[0]) for s in np.unique(y)]
    few = plugins.get_classifier("dtw-template").fit(X_train[one_each], y[one_each])
    many = plugins.get_classifier("dtw-template").fit(X_train, y)
    np.testing.assert_array_equal(few.predict(X_test), many.predict(X_test))


def test_dtw_template_only_knows_registered_shapes_and_the_signature_layout(features):
    X_train, _ = features("signature")
    with pytest.raises(ValueError, match="'teapot'"):
        plugins.get_classifier("dtw-template").fit(X_train[:2], ["cone", "teapot"])
    with pytest.raises(ValueError, match="22 to 25 columns"):
        plugins.get_classifier("dtw-template").fit(X_train[:2, :20], ["cone", "torus"])


@pytest.mark.parametrize("level", [False, True])
def test_dtw_template_decides_as_the_pattern_identifier(level):
    """At full resolution, dtw-template names what ``patterns.identify`` names: with the level
    column against the size-matched families, without it against default-size patterns."""
    import dataclasses

    from tactile_bullet.perception import patterns
    from tactile_bullet.perception.signature import signature_of

    records = make_records(per_shape=2, seed=9)
    X = plugins.get_descriptor("signature", points=200, level=level).transform(records)
    estimator = plugins.get_classifier("dtw-template", points=200)
    estimator.fit(X, [r.shape for r in records])
    thresholds = dataclasses.replace(patterns.load_thresholds(), correspondence=float("inf"))
    library = patterns.size_matched_library() if level else patterns.default_library()
    for record, predicted in zip(records, estimator.predict(X), strict=True):
        assert predicted == patterns.identify(signature_of(record), library, thresholds).name


def test_classifier_parameters_go_through_the_registry():
    assert plugins.get_classifier("knn", n_neighbors=3).n_neighbors == 3
    assert plugins.classifier_parameters("som")["rows"] == 8
    with pytest.raises(UsageError, match="n_neighbors"):
        plugins.get_classifier("knn", k=3)


def test_platt_sigmoid_minimises_the_smoothed_log_loss():
    from scipy.optimize import minimize
    from scipy.special import expit

    from tactile_bullet.learn.classifiers.svm import platt_sigmoid

    rng = np.random.default_rng(0)
    f = rng.normal(size=300)
    positive = f + rng.normal(scale=0.8, size=300) > 0
    n_pos, n_neg = positive.sum(), (~positive).sum()
    target = np.where(positive, (n_pos + 1) / (n_pos + 2), 1 / (n_neg + 2))

    def loss(ab):
        p = expit(-(ab[0] * f + ab[1]))
        return -np.sum(target * np.log(p) + (1 - target) * np.log(1 - p))

    reference = minimize(loss, [0.0, 0.0], method="Nelder-Mead", options={"xatol": 1e-8}).x
    np.testing.assert_allclose(platt_sigmoid(f, positive), reference, atol=1e-3)
    assert platt_sigmoid(f, positive)[0] < 0  # larger decision value, more likely positive


@pytest.mark.parametrize("weights", ["distance", "uniform"])
def test_knn_votes_like_scikit_learns_on_standardised_features(weights, features, synthetic_split):
    from sklearn.neighbors import KNeighborsClassifier
    from sklearn.preprocessing import StandardScaler

    train, test = synthetic_split
    X_train, X_test = features("signature")
    y = [r.shape for r in train]
    ours = plugins.get_classifier("knn", n_neighbors=4, weights=weights).fit(X_train, y)
    scaler = StandardScaler().fit(X_train)
    reference = KNeighborsClassifier(4, weights=weights).fit(scaler.transform(X_train), y)
    np.testing.assert_allclose(
        ours.predict_proba(X_test), reference.predict_proba(scaler.transform(X_test)), atol=1e-12
    )
