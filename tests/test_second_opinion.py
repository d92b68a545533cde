"""A model's learned second opinion (``learn/second_opinion.py``): saved and loaded with the
model, checked when loaded, and what flags an answer ambiguous in place of the shape fit."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tactile_bullet.errors import UsageError
from tactile_bullet.experiments import workflow
from tactile_bullet.learn import doubt as D
from tactile_bullet.learn.models import load_model, save_model
from tactile_bullet.learn.second_opinion import SecondOpinion
from tactile_bullet.plugins import get_descriptor


@pytest.fixture(scope="module")
def seconded(synthetic_split):
    """A signature + svm model carrying a second svm on robust-coupled-joints."""
    train, _ = synthetic_split
    model = workflow.train(train, "signature", "svm")
    model.second = SecondOpinion.fit(train, [r.shape for r in train])
    return model


def test_the_descriptor_is_coupled_joints_of_the_zeroed_record(synthetic_split):
    from tactile_bullet.learn.coupled import coupled_record
    from tactile_bullet.learn.robust import zeroed

    _, test = synthetic_split
    got = get_descriptor("robust-coupled-joints").transform(test)
    want = get_descriptor("coupled-joints").transform([coupled_record(zeroed(r, 5, 3))
                                                        for r in test])  # fmt: skip
    assert got.shape == (len(test), 13) and np.array_equal(got, want)
    # a bias on a joint's readings is gone: the open hand's reading is subtracted
    biased = [r.__class__(**{**r.__dict__, "angles": r.angles + 0.05,
                             "final_angles": r.final_angles + 0.05}) for r in test]  # fmt: skip
    np.testing.assert_allclose(get_descriptor("robust-coupled-joints").transform(biased), got,
                               atol=1e-12)  # fmt: skip


def test_a_saved_second_opinion_names_what_it_named(seconded, synthetic_split, tmp_path):
    _, test = synthetic_split
    loaded = load_model(save_model(tmp_path / "m.npz", seconded))
    assert loaded.second.descriptor == "robust-coupled-joints"
    assert loaded.second.names(test) == seconded.second.names(test)
    assert D.second_opinion(loaded) == D.SECOND_MODEL


def test_it_seconds_the_answers_in_place_of_the_shape_fit(seconded, synthetic_split):
    _, test = synthetic_split
    names, proba, was = seconded.answers(test)
    others = seconded.second.names(test)
    found = D.doubts(seconded, test, names, proba, renamed_from=was)
    for name, other, doubt in zip(names, others, found, strict=True):
        assert doubt["cross_check"] == other
        if other != name:
            assert doubt["ambiguous"] == [name, other]
    # a second opinion that always dissents flags every answer
    stubborn = SecondOpinion("robust-coupled-joints", {}, "svm", _Always("no-such-family"))
    model = seconded.__class__(**{**seconded.__dict__, "second": stubborn})
    assert all(d["ambiguous"] is not None for d in D.doubts(model, test, names, proba))


def test_a_grasp_without_its_series_is_read_unzeroed_not_refused(seconded, synthetic_split):
    # a recording of final configurations only has nothing to zero: the same columns, raw
    _, test = synthetic_split
    bare = [r.__class__(**{**r.__dict__, "time": r.time[-1:], "angles": r.angles[-1:]})
            for r in test]  # fmt: skip
    x = get_descriptor("coupled-joints").transform(bare)
    want = [str(v) for v in seconded.second.estimator.predict(x)]
    assert seconded.second.names(bare) == want
    mixed = [bare[0], *test[1:]]  # one short grasp among whole ones: each read its own way
    assert seconded.second.names(mixed) == [want[0], *seconded.second.names(test[1:])]


class _Always:
    def __init__(self, name):
        self.name = name

    def predict(self, x):
        return np.full(len(x), self.name)


def _rewrite(path, tmp_path, change):
    with np.load(path, allow_pickle=False) as data:
        members = {k: data[k] for k in data.files}
    meta = json.loads(str(members["meta"]))
    change(meta, members)
    members["meta"] = np.array(json.dumps(meta))
    out = tmp_path / "tampered.npz"
    with open(out, "wb") as fh:
        np.savez(fh, **members)
    return out


@pytest.mark.parametrize(("change", "why"), [
    (lambda m, a: m["second_opinion"].pop("state"), "second opinion is incomplete"),
    (lambda m, a: m["second_opinion"].update(descriptor="no-such"), "second opinion needs"),
    (lambda m, a: m["second_opinion"].update(descriptor="raw-joints"),
     "second opinion was fitted on 13 features, its descriptor 'raw-joints' gives 17"),
    (lambda m, a: [a.pop(k) for k in list(a) if k.startswith("second.")],
     "second opinion cannot be restored"),
])  # fmt: skip
def test_a_damaged_second_opinion_is_refused(seconded, tmp_path, change, why):
    path = save_model(tmp_path / "m.npz", seconded)
    with pytest.raises(UsageError, match=why):
        load_model(_rewrite(path, tmp_path, change))
