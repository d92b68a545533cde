"""Neural forest: learns, is reproducible, adds classes one at a time, is a proper estimator."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("torch")

from sklearn.datasets import make_classification  # noqa: E402
from sklearn.model_selection import train_test_split  # noqa: E402
from sklearn.utils.estimator_checks import parametrize_with_checks  # noqa: E402

from tactile_bullet.learn.neural_forest import NeuralForestClassifier, per_class_accuracy  # noqa: E402

SMALL = {"n_trees": 2, "depth": 3, "n_updates": 150, "n_recalibration_updates": 40}
"""A model small enough for the whole file to run in seconds."""


@pytest.fixture(scope="module")
def problem() -> tuple[np.ndarray, ...]:
    """Five separable classes, 20 features, offset and scaled so standardisation matters."""
    X, y = make_classification(
        n_samples=5 * 120,
        n_features=20,
        n_informative=8,
        n_redundant=4,
        n_classes=5,
        n_clusters_per_class=1,
        class_sep=2.0,
        random_state=3,
    )
    X = X * np.linspace(0.1, 30.0, 20) + 50.0
    return tuple(train_test_split(X, y, test_size=0.3, stratify=y, random_state=0))


@pytest.fixture(scope="module")
def sequential(problem: tuple[np.ndarray, ...]) -> dict:
    """A model grown class by class, with the per-class recall after each addition."""
    X_train, X_test, y_train, y_test = problem
    model = NeuralForestClassifier(random_state=0, memory_size=200, **SMALL)
    recalls = []
    for label in np.unique(y_train):
        mask = y_train == label
        model.partial_fit(X_train[mask], y_train[mask])
        recalls.append(per_class_accuracy(model, X_test, y_test, labels=np.unique(y_train)))
    return {"model": model, "recalls": recalls}


def test_import_does_not_load_torch() -> None:
    code = "import sys, tactile_bullet.learn.neural_forest; assert 'torch' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_beats_chance(problem: tuple[np.ndarray, ...]) -> None:
    X_train, X_test, y_train, y_test = problem
    model = NeuralForestClassifier(random_state=0, **SMALL).fit(X_train, y_train)
    assert model.score(X_test, y_test) > 0.8  # chance is 0.2
    assert np.all(model.n_updates_ == SMALL["n_updates"])


def test_same_seed_same_predictions(problem: tuple[np.ndarray, ...]) -> None:
    X_train, X_test, y_train, _ = problem
    first = NeuralForestClassifier(random_state=7, **SMALL).fit(X_train, y_train)
    second = NeuralForestClassifier(random_state=7, **SMALL).fit(X_train, y_train)
    other = NeuralForestClassifier(random_state=8, **SMALL).fit(X_train, y_train)
    assert np.array_equal(first.predict_proba(X_test), second.predict_proba(X_test))
    assert not np.array_equal(first.predict_proba(X_test), other.predict_proba(X_test))


def test_sequential_is_reproducible(problem: tuple[np.ndarray, ...]) -> None:
    X_train, X_test, y_train, _ = problem
    probas = []
    for _ in range(2):
        model = NeuralForestClassifier(random_state=1, n_trees=1, depth=2, n_updates=20)
        for label in (2, 0, 1):
            mask = y_train == label
            model.partial_fit(X_train[mask], y_train[mask])
        probas.append(model.predict_proba(X_test))
    assert np.array_equal(probas[0], probas[1])


def test_proba_rows_sum_to_one_and_columns_follow_classes(
    problem: tuple[np.ndarray, ...],
) -> None:
    X_train, X_test, y_train, y_test = problem
    names = np.array(["sphere", "cube", "cone", "torus", "cylinder"])
    model = NeuralForestClassifier(random_state=0, **SMALL).fit(X_train, names[y_train])
    assert list(model.classes_) == sorted(names)
    proba = model.predict_proba(X_test)
    assert proba.shape == (len(X_test), 5)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)
    assert np.array_equal(model.predict(X_test), model.classes_[proba.argmax(axis=1)])
    for column, label in enumerate(model.classes_):
        own = proba[names[y_test] == label]
        assert own[:, column].mean() > 0.5, label


def test_sequential_close_to_offline(problem: tuple[np.ndarray, ...], sequential: dict) -> None:
    X_train, X_test, y_train, y_test = problem
    offline = NeuralForestClassifier(random_state=0, **SMALL).fit(X_train, y_train)
    model = sequential["model"]
    assert list(model.classes_) == list(offline.classes_)
    assert model.score(X_test, y_test) >= offline.score(X_test, y_test) - 0.05
    assert [entry["classes_added"] for entry in model.history_] == [[c] for c in range(5)]


def test_old_classes_survive_a_new_one(sequential: dict) -> None:
    before, after = sequential["recalls"][-2], sequential["recalls"][-1]
    old = [label for label in before if not np.isnan(before[label]) and label != 4]
    assert after[4] > 0.8  # the newcomer is recognised
    drops = [before[label] - after[label] for label in old]
    assert max(drops) < 0.15, drops


def test_without_memory_old_classes_are_forgotten(
    problem: tuple[np.ndarray, ...], sequential: dict
) -> None:
    """The replay memory is what bounds forgetting: switched off, each new forest sees no
    negatives and claims every sample, and old forests are re-calibrated on the newcomer only."""
    X_train, X_test, y_train, y_test = problem
    model = NeuralForestClassifier(random_state=0, memory_size=0, **SMALL)
    for label in range(5):
        mask = y_train == label
        model.partial_fit(X_train[mask], y_train[mask])
    assert model.memory_X_.shape[0] == 0
    old = range(4)
    forgetful = per_class_accuracy(model, X_test, y_test, labels=old)
    remembering = sequential["recalls"][-1]
    assert np.mean([forgetful[c] for c in old]) < np.mean([remembering[c] for c in old]) - 0.3


def test_memory_is_bounded_and_balanced(sequential: dict) -> None:
    model = sequential["model"]
    assert len(model.memory_y_) <= model.memory_size
    counts = np.unique(model.memory_y_, return_counts=True)[1]
    assert counts.max() <= model.memory_size // 5
    # class 0 alone had nothing to learn; it trained fully with class 1, then re-calibrated
    assert model.n_updates_[0] == SMALL["n_updates"] + 3 * SMALL["n_recalibration_updates"]
    assert model.n_updates_[-1] == SMALL["n_updates"]


def test_statistics_merge_like_offline_and_keep_old_forests(
    problem: tuple[np.ndarray, ...], sequential: dict
) -> None:
    X_train, X_test, y_train, _ = problem
    model = sequential["model"]
    np.testing.assert_allclose(model.mean_, X_train.mean(axis=0))
    np.testing.assert_allclose(model.var_, X_train.var(axis=0))
    # new statistics alone (no training) must not change what the forests compute
    first = NeuralForestClassifier(random_state=0, **SMALL).fit(
        X_train[y_train < 3], y_train[y_train < 3]
    )
    proba = first.predict_proba(X_test)
    first._merge_statistics(X_train[y_train >= 3] * 3.0 - 10.0)
    np.testing.assert_allclose(first.predict_proba(X_test), proba, rtol=1e-9, atol=1e-12)


def test_partial_fit_rejects_labels_outside_classes(problem: tuple[np.ndarray, ...]) -> None:
    X_train, _, y_train, _ = problem
    with pytest.raises(ValueError, match="not in `classes`"):
        NeuralForestClassifier(n_updates=1).partial_fit(X_train, y_train, classes=[0, 1])


def test_announced_classes_get_forests(problem: tuple[np.ndarray, ...]) -> None:
    X_train, _, y_train, _ = problem
    mask = y_train == 0
    model = NeuralForestClassifier(n_updates=5, random_state=0)
    model.partial_fit(X_train[mask], y_train[mask], classes=[0, 1, 2])
    assert list(model.classes_) == [0, 1, 2]
    assert model.predict_proba(X_train[:3]).shape == (3, 3)


CHECKED = NeuralForestClassifier(
    n_trees=2, depth=3, feature_fraction=1.0, n_updates=100, random_state=0
)
"""sklearn's checks train on 2-feature blobs and want 83 % training accuracy: with the default
feature_fraction each tree would see one feature, so the checked instance sees both."""


@parametrize_with_checks([CHECKED])
def test_sklearn_estimator_checks(estimator, check) -> None:
    check(estimator)


# -- bounds (issue 10): sizes and devices refused before any work -----------------------------


def test_a_huge_forest_is_refused_before_anything_is_allocated(problem) -> None:
    """depth=40 means 2**40 leaves per tree: the estimate (petabytes) is refused up front."""
    import tracemalloc

    from tactile_bullet.errors import UsageError

    X_train, _, y_train, _ = problem
    model = NeuralForestClassifier(depth=40)
    assert model.memory_estimate(X_train.shape[1], 5) > 1024**5  # more than a PiB
    tracemalloc.start()
    try:
        with pytest.raises(UsageError, match=r"depth=40.*PiB.*limit is 2 GiB"):
            model.fit(X_train, y_train)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 50 * 1024**2
    assert not hasattr(model, "classes_")


def test_the_estimate_doubles_with_each_level_and_defaults_are_small() -> None:
    assert NeuralForestClassifier().memory_estimate(50, 7) < 50 * 1024**2
    deep = NeuralForestClassifier(depth=10).memory_estimate(50, 7)
    deeper = NeuralForestClassifier(depth=11).memory_estimate(50, 7)
    assert 1.9 < deeper / deep < 2.1


def test_partial_fit_checks_the_size_with_the_new_classes(problem) -> None:
    from tactile_bullet.errors import UsageError

    X_train, _, y_train, _ = problem
    model = NeuralForestClassifier(depth=20, n_trees=1, n_updates=1)
    limit = 2 * 1024**3
    fits = [k for k in range(1, 6) if model.memory_estimate(X_train.shape[1], k) <= limit]
    assert fits and len(fits) < 5  # some classes fit the budget, all five do not
    first = y_train == 0
    model.partial_fit(X_train[first][:5], y_train[first][:5])
    with pytest.raises(UsageError, match="depth=20"):
        model.partial_fit(X_train, y_train)


def test_predict_in_small_chunks_gives_the_same_probabilities(problem, monkeypatch) -> None:
    from tactile_bullet.learn import neural_forest

    X_train, X_test, y_train, _ = problem
    model = NeuralForestClassifier(random_state=0, **SMALL).fit(X_train, y_train)
    whole = model.predict_proba(X_test)
    monkeypatch.setattr(neural_forest, "_PREDICT_CHUNK_BYTES", 1)  # one row at a time
    np.testing.assert_allclose(model.predict_proba(X_test), whole, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("device", ["cuda", "cuda:7", "tpu", "", "mps"])
def test_a_device_this_machine_lacks_is_a_usage_error(device, problem) -> None:
    import torch

    from tactile_bullet.errors import UsageError

    if device.startswith("cuda") and torch.cuda.is_available() and device == "cuda":
        pytest.skip("this machine has a CUDA GPU")
    if device == "mps" and torch.backends.mps.is_available():
        pytest.skip("this machine has MPS")
    X_train, _, y_train, _ = problem
    with pytest.raises(UsageError, match="device"):
        NeuralForestClassifier(device=device, **SMALL).fit(X_train, y_train)


def test_cli_refuses_cuda_on_a_cpu_build_and_huge_depth_with_one_line(capsys, tmp_path) -> None:
    import torch
    from cli_helpers import run_error
    from synthetic import make_records, write_records

    data = write_records(tmp_path / "data", make_records(per_shape=3, seed=4))
    base = ["train", "--data", str(data), "--classifier", "neural-forest"]
    out = ["--out", str(tmp_path / "m.npz")]
    if not torch.cuda.is_available():
        err = run_error(capsys, [*base, "--param", "device=cuda", *out])
        assert "no CUDA" in err
    err = run_error(capsys, [*base, "--param", "depth=40", *out])
    assert "PiB" in err and "limit" in err
    assert not (tmp_path / "m.npz").exists()


def test_whitening_decorrelates_each_trees_inputs_and_is_undone_exactly() -> None:
    from tactile_bullet.learn.neural_forest import _whitening

    rng = np.random.default_rng(0)
    base = rng.normal(size=(300, 3))
    xs = np.hstack([base, base @ rng.normal(size=(3, 3)) + 0.1 * rng.normal(size=(300, 3))])
    idx = np.array([[0, 3, 4, 5], [1, 2, 3, 5]])
    basis, inverse = _whitening(xs, idx)
    for g in range(2):
        z = xs[:, idx[g]] @ basis[g]
        np.testing.assert_allclose(np.cov(z, rowvar=False), np.eye(4), atol=1e-9)
        np.testing.assert_allclose(basis[g] @ inverse[g], np.eye(4), atol=1e-9)


def test_whitened_training_stores_weights_that_predict_in_standardised_coordinates(
    problem,
) -> None:
    """Whitening only reparametrises training: the stored model routes standardised inputs
    like an unwhitened one, and re-fitting from it (partial_fit) keeps it working."""
    X_train, X_test, y_train, y_test = problem
    model = NeuralForestClassifier(random_state=0, **SMALL).fit(X_train, y_train)
    plain = NeuralForestClassifier(random_state=0, whiten=False, **SMALL).fit(X_train, y_train)
    assert model.split_weights_.shape == plain.split_weights_.shape
    assert model.score(X_test, y_test) > 0.8
    model.partial_fit(X_train[y_train == 0], y_train[y_train == 0])
    assert model.score(X_test, y_test) > 0.8
