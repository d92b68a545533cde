"""Model files: a saved model predicts exactly what it did, and loading never runs code."""

from __future__ import annotations

import io
import json
import pickle
import re
import zipfile

import numpy as np
import pytest
import sklearn

from tactile_bullet import __version__, plugins
from tactile_bullet.errors import UsageError
from tactile_bullet.experiments import workflow
from tactile_bullet.learn.models import (
    MODEL_FORMAT_VERSION,
    Model,
    load_model,
    save_model,
)

CLASSIFIERS = plugins.classifier_names()
SAVED_ELSEWHERE = {"fusion": "tests/test_fusion.py, on two grasps (a shape fit per grasp)"}
"""Classifiers whose save/load round trip is tested in their own module, on fewer grasps."""


def _descriptor_for(classifier: str) -> str:
    return plugins.required_descriptor(classifier) or "contact-normals"


@pytest.fixture(scope="module")
def svm_model(synthetic_split):
    return workflow.train(synthetic_split[0], "signature+contact-normals", "svm")


@pytest.mark.parametrize("classifier", [
    pytest.param(c, marks=pytest.mark.skip(SAVED_ELSEWHERE[c])) if c in SAVED_ELSEWHERE else c
    for c in CLASSIFIERS
])  # fmt: skip
def test_saved_model_predicts_exactly_what_it_did(classifier, synthetic_split, tmp_path):
    train, test = synthetic_split
    model = workflow.train(train, _descriptor_for(classifier), classifier)
    path = save_model(tmp_path / "model.npz", model)
    loaded = load_model(path)
    light = plugins.fitted_form(classifier)  # a predict-only form, where one is declared
    assert type(loaded.estimator) is (light or type(model.estimator))
    assert loaded.classes == model.classes
    assert (loaded.descriptor, loaded.classifier) == (model.descriptor, classifier)
    np.testing.assert_array_equal(loaded.predict_records(test), model.predict_records(test))
    if light is None:  # the estimator itself, restored: bitwise
        np.testing.assert_array_equal(
            loaded.predict_proba_records(test), model.predict_proba_records(test)
        )
    else:  # the same arithmetic in another order (numpy against libsvm's C)
        np.testing.assert_allclose(
            loaded.predict_proba_records(test), model.predict_proba_records(test), atol=1e-9
        )


def test_model_remembers_names_parameters_and_versions(synthetic_split, tmp_path):
    model = workflow.train(
        synthetic_split[0],
        "signature",
        "knn",
        descriptor_params={"points": 20},
        params={"n_neighbors": 3},
    )
    model.info["records"] = len(synthetic_split[0])
    loaded = load_model(save_model(tmp_path / "m.npz", model))
    assert loaded.descriptor_params == {
        "points": 20, "alpha": False, "level": False, "floor": 0.05, "correction": "none"
    }  # fmt: skip
    assert loaded.classifier_params == {"n_neighbors": 3}
    assert loaded.estimator.n_neighbors == 3
    assert loaded.info["records"] == len(synthetic_split[0])
    assert loaded.info["doubt"] == model.info["doubt"]  # the calibrated margin travels too
    assert loaded.software_version == __version__
    assert loaded.format_version == MODEL_FORMAT_VERSION
    assert loaded.features(synthetic_split[1][:2]).shape == (2, 42)


def test_predictions_are_shape_names_with_one_probability_per_class(svm_model, synthetic_split):
    test = synthetic_split[1]
    names = svm_model.predict_records(test)
    proba = svm_model.predict_proba_records(test)
    assert set(names) <= set(svm_model.classes) and len(names) == len(test)
    assert proba.shape == (len(test), len(svm_model.classes))
    np.testing.assert_allclose(proba.sum(axis=1), 1.0)


# --- files that must be refused --------------------------------------------------------------


def _rewrite(path, tmp_path, change, name="tampered.npz"):
    """Copy a model file with its members changed by ``change(dict of arrays)``."""
    with np.load(path, allow_pickle=False) as data:
        members = {k: data[k] for k in data.files}
    change(members)
    out = tmp_path / name
    with open(out, "wb") as fh:
        np.savez(fh, **members)
    return out


def _set_meta(members, **updates):
    meta = json.loads(str(members["meta"]))
    meta.update(updates)
    members["meta"] = np.array(json.dumps(meta))


def _as_skops(path, tmp_path, estimator):
    """The model file at ``path`` with its estimator written by skops: an svm model file as
    written before the svm saved its own state, and as other classifiers' files still are."""
    import skops.io as sio

    def to_skops(members):
        for name in [n for n in members if n == "estimator_state" or n.startswith("state.")]:
            del members[name]
        members["estimator_skops"] = np.frombuffer(sio.dumps(estimator), dtype=np.uint8)
        _set_meta(members, estimator_encoding="skops")

    return _rewrite(path, tmp_path, to_skops, name="skops.npz")


@pytest.fixture(scope="module")
def svm_file(svm_model, tmp_path_factory):
    return save_model(tmp_path_factory.mktemp("svm") / "svm.npz", svm_model)


@pytest.fixture
def saved(svm_file, svm_model, tmp_path):
    """An old svm model file, its estimator written by skops: the refusals below are those of
    every skops-encoded file."""
    return _as_skops(svm_file, tmp_path, svm_model.estimator)


class Payload:
    """Stands for code an attacker would like a model file to construct."""

    def __reduce__(self):
        return (print, ("pwned",))


def test_random_bytes_and_missing_files_are_refused(tmp_path):
    junk = tmp_path / "junk.npz"
    junk.write_bytes(np.random.default_rng(0).bytes(300))
    with pytest.raises(UsageError, match="not a tactile-bullet model"):
        load_model(junk)
    with pytest.raises(UsageError, match="does not exist"):
        load_model(tmp_path / "absent.npz")


def test_a_pickle_is_refused_without_being_run(tmp_path, capsys):
    path = tmp_path / "model.npz"
    path.write_bytes(pickle.dumps(Payload()))
    with pytest.raises(UsageError, match="not a tactile-bullet model"):
        load_model(path)
    assert "pwned" not in capsys.readouterr().out


def test_a_pickled_array_inside_the_archive_is_refused(saved, tmp_path, capsys):
    def add_object_array(members):
        members["estimator_skops"] = np.array([Payload()], dtype=object)

    path = _rewrite(saved, tmp_path, add_object_array)
    with pytest.raises(UsageError):
        load_model(path)
    assert "pwned" not in capsys.readouterr().out


def test_an_estimator_with_untrusted_types_is_refused(saved, tmp_path):
    import skops.io as sio

    from tactile_bullet.learn.classifiers.svm import SVMClassifier

    evil = SVMClassifier()
    evil.classes_ = np.array(["cone"])
    evil.hook_ = Payload.__new__(Payload)

    def swap(members):
        members["estimator_skops"] = np.frombuffer(sio.dumps(evil), dtype=np.uint8)

    with pytest.raises(UsageError, match="test_models.Payload"):
        load_model(_rewrite(saved, tmp_path, swap))


def test_an_estimator_of_another_classifier_than_named_is_refused(saved, tmp_path):
    def claim_knn(members):
        _set_meta(members, classifier={"name": "knn", "params": {}})

    with pytest.raises(UsageError, match="SVMClassifier"):
        load_model(_rewrite(saved, tmp_path, claim_knn))


def test_a_trusted_estimator_that_is_not_the_named_classifier_is_refused(saved, tmp_path):
    import skops.io as sio
    from sklearn.linear_model import LogisticRegression

    other = LogisticRegression().fit([[0.0], [1.0]], ["cone", "torus"])

    def swap(members):
        members["estimator_skops"] = np.frombuffer(sio.dumps(other), dtype=np.uint8)

    with pytest.raises(UsageError, match="not the 'svm' classifier"):
        load_model(_rewrite(saved, tmp_path, swap))


def test_a_model_whose_descriptor_is_not_installed_is_refused(saved, tmp_path):
    def rename(members):
        _set_meta(members, descriptor={"name": "fingerprint-3d", "params": {}})

    with pytest.raises(UsageError, match="fingerprint-3d"):
        load_model(_rewrite(saved, tmp_path, rename))


def test_a_model_whose_descriptor_gives_rows_its_classifier_cannot_read_is_refused(
    svm_file, tmp_path
):
    # its metadata edited: the signature's points changed, the fitted svm left as it was
    def more_points(members):
        meta = json.loads(str(members["meta"]))
        _set_meta(members, descriptor={**meta["descriptor"], "params": {
            **meta["descriptor"]["params"], "signature.points": 20}})  # fmt: skip

    with pytest.raises(UsageError, match=r"its descriptor 'signature\+contact-normals' gives "
                                         r"\d+ features, its classifier was fitted on \d+"):
        load_model(_rewrite(svm_file, tmp_path, more_points))


def test_a_model_whose_rows_its_descriptor_does_not_give_is_not_saved(svm_model, tmp_path):
    from dataclasses import replace

    wrong = replace(svm_model, descriptor_params={"signature.points": 20})
    with pytest.raises(UsageError, match="gives \\d+ features, its classifier was fitted on"):
        save_model(tmp_path / "m.npz", wrong)
    assert not (tmp_path / "m.npz").exists()


def test_a_newer_format_is_refused_with_both_versions(saved, tmp_path):
    path = _rewrite(saved, tmp_path, lambda m: _set_meta(m, format_version=99))
    with pytest.raises(UsageError, match="99") as info:
        load_model(path)
    assert str(MODEL_FORMAT_VERSION) in str(info.value)


def test_another_zip_archive_is_refused(tmp_path):
    path = tmp_path / "other.npz"
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("readme.txt", "hello")
    path.write_bytes(buffer.getvalue())
    with pytest.raises(UsageError, match="not a tactile-bullet model"):
        load_model(path)


def test_an_unfitted_model_is_not_saved(tmp_path):
    model = Model("signature", {}, "svm", {}, plugins.get_classifier("svm"))
    with pytest.raises(UsageError, match="not been fitted"):
        save_model(tmp_path / "m.npz", model)
    assert not (tmp_path / "m.npz").exists()


class StateCentroid:
    """A classifier saved through the to_state/from_state protocol (no skops)."""

    def __init__(self, shrink=0.0):
        self.shrink = shrink

    def get_params(self, deep=True):
        return {"shrink": self.shrink}

    def set_params(self, **params):
        self.__dict__.update(params)
        return self

    def fit(self, X, y):
        self.classes_, idx = np.unique(y, return_inverse=True)
        self.centroids_ = np.array([X[idx == k].mean(axis=0) for k in range(len(self.classes_))])
        return self

    def predict_proba(self, X):
        d = np.linalg.norm(X[:, None, :] - self.centroids_[None], axis=-1)
        w = np.exp(-(d - d.min(axis=1, keepdims=True)))
        return w / w.sum(axis=1, keepdims=True)

    def predict(self, X):
        return self.classes_[np.argmax(self.predict_proba(X), axis=1)]

    def to_state(self):
        return {"shrink": self.shrink, "classes": self.classes_.tolist()}, {
            "centroids": self.centroids_
        }

    @classmethod
    def from_state(cls, state, arrays):
        est = cls(shrink=state["shrink"])
        est.classes_ = np.array(state["classes"])
        est.centroids_ = np.asarray(arrays["centroids"], dtype=float)
        return est


def test_state_protocol_saves_a_plugin_classifier(register_test_plugin, synthetic_split, tmp_path):
    from tactile_bullet.hookspecs import hookimpl
    from tactile_bullet.learn.models import StatefulEstimator

    class Plugin:
        @hookimpl
        def register_classifiers(self, register):
            register("test-state-centroid", StateCentroid)

    register_test_plugin(Plugin(), "test-state-plugin")
    train, test = synthetic_split
    model = workflow.train(train, "contact-normals", "test-state-centroid")
    assert isinstance(model.estimator, StatefulEstimator)
    path = save_model(tmp_path / "m.npz", model)
    with np.load(path, allow_pickle=False) as data:
        assert "estimator_skops" not in data.files
    loaded = load_model(path)
    np.testing.assert_array_equal(loaded.predict_records(test), model.predict_records(test))


@pytest.fixture
def saved_with_known(synthetic_split, tmp_path):
    train, test = synthetic_split
    model = workflow.train(train, "signature", "svm", known=test[:4], doubt=False)
    return save_model(tmp_path / "known.npz", model)


@pytest.mark.parametrize("damage, message", [
    (lambda m: m.pop("known.labels"), "known grasps are incomplete"),
    (lambda m: m.update({"known.labels": np.array(["ovoid"] * 4)}), "'ovoid', not one of"),
    (lambda m: m.update({"known.features": m["known.features"][:2]}), "do not match"),
    (lambda m: m.update({"known.features": m["known.features"] * np.nan}), "not finite"),
    (lambda m: _set_meta(m, known_descriptor="fingerprint-3d"), "fingerprint-3d"),
])  # fmt: skip
def test_a_model_with_damaged_known_grasps_is_refused(saved_with_known, tmp_path, damage, message):
    """The known grasps second the model's answers: damaged, they are refused, never used."""
    assert load_model(saved_with_known).known is not None
    with pytest.raises(UsageError, match=message):
        load_model(_rewrite(saved_with_known, tmp_path, damage))


# --- the svm saves its own state (no skops) --------------------------------------------------


@pytest.fixture(scope="module")
def two_shape_svm(synthetic_split):
    """An svm of two shapes (one Platt sigmoid, one decision value per grasp)."""
    train = [r for r in synthetic_split[0] if r.shape in ("cone", "sphere")]
    return workflow.train(train, "signature", "svm", doubt=False)


@pytest.mark.parametrize("which", ["two_shape_svm", "svm_model"])
def test_an_svm_file_holds_its_state_and_predicts_the_same(
    which, request, synthetic_split, tmp_path
):
    from tactile_bullet.learn.classifiers.svm import SVMClassifier

    model = request.getfixturevalue(which)
    path = save_model(tmp_path / "m.npz", model)
    with np.load(path, allow_pickle=False) as data:
        assert "estimator_skops" not in data.files and "estimator_state" in data.files
    loaded = load_model(path)
    x = model.features(synthetic_split[1])  # held out
    # the estimator restored from the state (scikit-learn's SVC inside): bitwise
    again = SVMClassifier.from_state(*model.estimator.to_state())
    assert np.array_equal(again.predict_proba(x), model.estimator.predict_proba(x))
    # what a model file loads as (numpy, no scikit-learn): the same answers
    assert np.allclose(loaded.estimator.predict_proba(x), model.estimator.predict_proba(x),
                       rtol=0, atol=1e-9)  # fmt: skip
    assert np.array_equal(loaded.estimator.predict(x), model.estimator.predict(x))
    assert loaded.estimator.get_params() == model.estimator.get_params()


@pytest.mark.parametrize("kernel", ["rbf", "linear", "poly", "sigmoid"])
@pytest.mark.parametrize("k", [2, 3, 5])
def test_a_loaded_svm_decides_as_scikit_learns_svc_on_every_kernel(kernel, k):
    from tactile_bullet.learn.svm_state import SVMVote

    rng = np.random.default_rng(k)
    labels = np.array(list("abcde"[:k]))
    y = labels[np.arange(90) % k]
    x = rng.normal(size=(90, 6)) + 0.7 * (np.searchsorted(labels, y)[:, None])
    est = plugins.get_classifier("svm", kernel=kernel).fit(x, y)
    vote = SVMVote.from_state(*est.to_state())
    queries = np.vstack([2 * rng.normal(size=(40, 6)), x[:10]])
    z = (queries - est.mean_) / est.scale_
    assert np.allclose(vote.decision_function(z), est.svc_.decision_function(z), rtol=0,
                       atol=1e-9)  # fmt: skip
    assert np.array_equal(vote.predict(queries), est.predict(queries))


def test_loading_an_svm_file_imports_neither_skops_nor_scikit_learn(
    svm_file, svm_model, synthetic_split, tmp_path
):
    """skops's import (~2 s) was most of an svm model's ``evaluate``."""
    import subprocess
    import sys

    x = svm_model.features(synthetic_split[1])
    np.save(tmp_path / "x.npy", x)
    code = (
        "import sys, numpy as np\n"
        "from tactile_bullet.learn.models import load_model\n"
        f"m = load_model({str(svm_file)!r})\n"
        f"np.save({str(tmp_path / 'p.npy')!r}, m.estimator.predict_proba(np.load("
        f"{str(tmp_path / 'x.npy')!r})))\n"
        "assert 'skops' not in sys.modules, 'skops was imported'\n"
        "assert 'sklearn' not in sys.modules, 'scikit-learn was imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
    assert np.allclose(np.load(tmp_path / "p.npy"), svm_model.estimator.predict_proba(x),
                       rtol=0, atol=1e-9)  # fmt: skip


def test_an_old_svm_file_written_by_skops_still_loads(saved, svm_model, synthetic_split):
    with np.load(saved, allow_pickle=False) as data:
        assert "estimator_skops" in data.files and "estimator_state" not in data.files
    loaded = load_model(saved)
    test = synthetic_split[1]
    np.testing.assert_array_equal(
        loaded.predict_proba_records(test), svm_model.predict_proba_records(test)
    )


def _svc_state(**updates):
    """A change to the saved SVC's JSON attributes."""

    def change(members):
        state = json.loads(str(members["estimator_state"]))
        state["svc"].update(updates)
        members["estimator_state"] = np.array(json.dumps(state))

    return change


def _array(name, change):
    return lambda m: m.update({f"state.{name}": change(m[f"state.{name}"].copy())})


def _set(index, value):
    def change(a):
        a[index] = value
        return a

    return change


@pytest.mark.parametrize("damage, message", [
    (_array("svc.dual_coef_", lambda a: a[:, :-1]), "dual_coef_ has shape"),
    (_array("svc.intercept_", lambda a: a[:-1]), "intercept_ has shape"),
    (_array("platt", lambda a: a[:-1]), "platt is float64"),
    (_array("mean", lambda a: a[:-1]), "mean is float64"),
    (_array("svc.support_vectors_", _set((0, 0), np.nan)), "support_vectors_ holds non-numbers"),
    (_array("svc._intercept_", _set(0, np.inf)), "_intercept_ holds non-numbers"),
    (_array("mean", _set(0, np.nan)), "mean holds non-numbers"),
    (_array("scale", _set(0, 0.0)), "scale is not positive"),
    (_svc_state(_gamma=float("nan")), "_gamma is not finite"),
    (lambda m: m.update({"state.svc.hook_": np.zeros(3)}), "unknown or missing SVC .*hook_"),
    (_svc_state(hook_="os.system"), "unknown or missing SVC attributes: hook_"),
    (lambda m: m.pop("state.svc._probA"), "unknown or missing SVC attributes: _probA"),
    (lambda m: m.update({"state.hook": np.zeros(3)}), "unknown svm arrays: hook"),
    (_array("svc.support_", lambda a: a.astype(np.int64)), "support_ is int64, not int32"),
    (_array("scale", lambda a: a.astype(np.float32)), "scale is float32"),
    (_array("classes", lambda a: a[:1]), "classes are not 2 or more"),
    (_svc_state(_gamma="0.1"), "_gamma is a str"),
    (_svc_state(shape_fit_=[10, 3]), "shape_fit_"),
    (_svc_state(kernel="precomputed"), "settings"),
    (_array("svc._n_support", _set(0, 10**6)), "_n_support does not count"),
    (_array("svc._n_support", _set(0, -1)), "_n_support does not count"),
    (_array("svc.support_", _set(0, 10**6)), "support_ indices lie outside"),
    (_array("svc.classes_", lambda a: a[::-1].copy()), "classes_ are not the class indices"),
    (lambda m: _set_meta(m, classifier={"name": "knn", "params": {}}), "n_neighbors"),
])  # fmt: skip
def test_a_damaged_svm_state_is_refused_in_one_line(svm_file, tmp_path, damage, message):
    with pytest.raises(UsageError, match="cannot restore the estimator") as info:
        load_model(_rewrite(svm_file, tmp_path, damage))
    assert re.search(message, str(info.value)) and "\n" not in str(info.value)


def test_an_svm_file_of_another_patch_release_loads(svm_file, svm_model, synthetic_split,
                                                    tmp_path):
    major, minor = sklearn.__version__.split(".")[:2]
    path = _rewrite(svm_file, tmp_path, _svc_state(_sklearn_version=f"{major}.{minor}.99"))
    loaded = load_model(path)
    test = synthetic_split[1]
    np.testing.assert_allclose(
        loaded.predict_proba_records(test), svm_model.predict_proba_records(test), atol=1e-9
    )


def test_an_svm_file_of_another_release_series_is_read_but_not_restored_into_libsvm(
    svm_file, svm_model, synthetic_split, tmp_path
):
    """A model file loads as the numpy SVMVote under any scikit-learn (the shipped default is
    an svm); only restoring scikit-learn's own SVC, which reads the arrays as its release series
    laid them out, needs the series that wrote them."""
    from tactile_bullet.learn.classifiers.svm import SVMClassifier

    path = _rewrite(svm_file, tmp_path, _svc_state(_sklearn_version="1.8.0"))
    loaded = load_model(path)
    test = synthetic_split[1]
    np.testing.assert_allclose(
        loaded.predict_proba_records(test), svm_model.predict_proba_records(test), atol=1e-9
    )
    state, arrays = loaded.estimator.to_state()
    with pytest.raises(ValueError, match=f"made by scikit-learn 1.8.0, this is scikit-learn "
                                         f"{sklearn.__version__}; retrain"):  # fmt: skip
        SVMClassifier.from_state(state, arrays)


def test_an_svm_of_a_value_no_model_file_holds_is_not_saved(tmp_path):
    from tactile_bullet.learn.classifiers.svm import SVMClassifier

    width = len(plugins.get_descriptor("signature").feature_names())
    X = np.random.default_rng(0).normal(size=(12, width))
    est = SVMClassifier(class_weight={0: 1.0, 1: 2.0}).fit(X, ["cone", "torus"] * 6)
    model = Model("signature", {}, "svm", {}, est)
    with pytest.raises(UsageError, match="cannot save the 'svm' classifier: .*dict"):
        save_model(tmp_path / "m.npz", model)
    assert not (tmp_path / "m.npz").exists()


def test_an_svc_of_another_layout_is_saved_through_skops(svm_model, monkeypatch, tmp_path):
    """Another scikit-learn's SVC (here: one more attribute than 1.9's) is written by skops
    rather than refused, and reads back."""
    from tactile_bullet.learn.classifiers import svm

    monkeypatch.setitem(svm.SVC_SCALARS, "new_attribute_", (int,))
    path = save_model(tmp_path / "m.npz", svm_model)
    with np.load(path, allow_pickle=False) as data:
        assert "estimator_skops" in data.files and "estimator_state" not in data.files
    assert isinstance(load_model(path).estimator, svm.SVMClassifier)
