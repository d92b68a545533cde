"""The time-series descriptor (layout, resampling, real-hand records) and the tcn classifier
(a proper, seeded estimator that saves without pickle and predicts without torch)."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest
from cli_helpers import run_error
from synthetic import make_record, make_records

from tactile_bullet import plugins
from tactile_bullet.errors import UsageError
from tactile_bullet.learn.time_series import (
    TimeSeriesDescriptor,
    channel_names,
    resample_series,
    time_series_joints,
)


def with_series(record, time, angles, efforts=None):
    efforts = np.zeros_like(angles) if efforts is None else efforts
    return dataclasses.replace(record, time=time, angles=angles, efforts=efforts)


def ramp_record(samples: int, duration: float = 1.0, seed: int = 0):
    """A record whose every joint moves linearly from 0 to its final angle over the grasp."""
    record = make_record("cone", rng=np.random.default_rng(seed), samples=samples)
    t = np.linspace(0.0, duration, samples)
    angles = t[:, None] / duration * record.final_angles[None, :]
    return with_series(record, t, angles, 0.1 * angles)


# -- descriptor --------------------------------------------------------------------------------


def test_layout_is_channels_times_length_in_a_fixed_joint_order():
    records = make_records(per_shape=2, seed=3)
    desc = plugins.get_descriptor("time-series", length=16)
    X = desc.transform(records)
    joints = time_series_joints()
    assert len(joints) == 17 and joints[:4] == ["FFJ4", "FFJ3", "FFJ2", "FFJ1"]
    assert X.shape == (len(records), 2 * 17 * 16)
    assert desc.feature_names()[:2] == ["angle:FFJ4@000", "angle:FFJ4@001"]
    assert desc.feature_names()[17 * 16] == "effort:FFJ4@000"
    # the last instant of each angle channel is the record's last sample of that joint
    last = X.reshape(len(records), 34, 16)[:, :17, -1]
    cols = [records[0].joint_index(j) for j in joints]
    np.testing.assert_allclose(last, np.array([r.angles[-1, cols] for r in records]))


def test_options_change_the_channels():
    assert len(channel_names(include_thumb=False, efforts=False)) == 17
    assert len(channel_names(include_thumb=True, efforts=True)) == 44
    record = ramp_record(20)
    X = TimeSeriesDescriptor(length=8, efforts=False, include_thumb=True).transform([record])
    assert X.shape == (1, 22 * 8)


def test_records_of_different_lengths_and_durations_give_the_same_features():
    """Time is normalised to the grasp: a ramp sampled 7 or 240 times, over 1 s or 3 s, is
    the same ramp."""
    desc = TimeSeriesDescriptor(length=12)
    short, long_, slow = ramp_record(7), ramp_record(240), ramp_record(50, duration=3.0)
    np.testing.assert_allclose(desc.transform([short]), desc.transform([long_]), atol=1e-12)
    np.testing.assert_allclose(desc.transform([short]), desc.transform([slow]), atol=1e-12)


def test_resampling_follows_the_time_stamps_not_the_sample_index():
    t = np.array([0.0, 0.1, 1.0])  # uneven: most of the grasp between the last two samples
    values = np.array([[0.0], [0.1], [1.0]])
    np.testing.assert_allclose(resample_series(t, values, 5)[0], [0.0, 0.25, 0.5, 0.75, 1.0])
    # a clock that does not increase falls back to the sample order
    np.testing.assert_allclose(
        resample_series(np.zeros(3), values, 3)[0], [0.0, 0.1, 1.0], atol=1e-12
    )
    # one sample is held
    np.testing.assert_allclose(resample_series([0.0], [[2.0, 3.0]], 4), [[2.0] * 4, [3.0] * 4])


def test_a_real_hand_record_with_its_own_column_order_and_no_wrist():
    """Joints are found by name: a recording listing them in another order, without the
    wrist and the thumb, gives the features of the same motion in simulation."""
    record = ramp_record(30)
    joints = time_series_joints()
    order = list(reversed(joints))
    cols = [record.joint_index(j) for j in order]
    real = dataclasses.replace(
        record,
        joint_names=tuple(order),
        angles=record.angles[:, cols],
        efforts=record.efforts[:, cols],
        final_angles=record.final_angles[cols],
    )
    desc = TimeSeriesDescriptor(length=10)
    np.testing.assert_allclose(desc.transform([real]), desc.transform([record]))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            {"time": np.zeros(0), "angles": np.zeros((0, 24)), "efforts": np.zeros((0, 24))},
            "no time",
        ),
        ({"angles": np.full((12, 24), np.nan)}, "not finite"),  # no such record can exist
        ({"efforts": np.zeros((12, 3))}, "time series of shape"),
        ({"joint_names": ("FFJ3",) * 24}, "no joint 'FFJ4'"),
    ],
)
def test_records_without_a_usable_series_are_refused(change, message):
    with pytest.raises(UsageError, match=message):
        record = dataclasses.replace(make_record("sphere"), **change)
        TimeSeriesDescriptor().transform([record])


@pytest.mark.parametrize(
    "params", [{"length": 1}, {"length": 513}, {"length": "32"}, {"efforts": "yes"}]
)
def test_bad_descriptor_parameters_are_usage_errors(params):
    with pytest.raises(UsageError, match="time-series"):
        plugins.get_descriptor("time-series", **params)


# -- tcn ---------------------------------------------------------------------------------------

torch_missing = pytest.mark.skipif(
    __import__("importlib").util.find_spec("torch") is None, reason="needs the torch extra"
)

QUICK = {"length": 12, "width": 8, "n_layers": 2, "epochs": 40, "batch_size": 16}
"""A network small enough to fit the synthetic set in about a second."""


@pytest.fixture(scope="module")
def series_split(synthetic_split):
    train, test = synthetic_split
    desc = TimeSeriesDescriptor(length=QUICK["length"])
    y_train = np.array([r.shape for r in train])
    y_test = np.array([r.shape for r in test])
    return desc.transform(train), desc.transform(test), y_train, y_test


@pytest.fixture(scope="module")
def fitted(series_split):
    from tactile_bullet.learn.classifiers.tcn import TCNClassifier

    X_train, _, y_train, _ = series_split
    return TCNClassifier(random_state=3, **QUICK).fit(X_train, y_train)


@torch_missing
def test_tcn_learns_the_shapes_from_the_series(fitted, series_split):
    _, X_test, _, y_test = series_split
    assert fitted.loss_curve_[-1] < 0.5 * fitted.loss_curve_[0]
    assert fitted.score(X_test, y_test) >= 0.8  # chance 0.2
    assert list(fitted.classes_) == sorted(set(y_test))
    assert fitted.n_channels_ == 34


@torch_missing
def test_tcn_same_seed_same_model_other_seed_another(fitted, series_split):
    from tactile_bullet.learn.classifiers.tcn import TCNClassifier

    X_train, X_test, y_train, _ = series_split
    again = TCNClassifier(random_state=3, **QUICK).fit(X_train, y_train)
    other = TCNClassifier(random_state=4, **QUICK).fit(X_train, y_train)
    assert np.array_equal(again.predict_proba(X_test), fitted.predict_proba(X_test))
    assert not np.allclose(other.predict_proba(X_test), fitted.predict_proba(X_test))


@torch_missing
def test_numpy_prediction_is_the_trained_torch_network(fitted, series_split):
    import torch

    from tactile_bullet.learn.classifiers.tcn import _logits_torch

    _, X_test, _, _ = series_split
    h = torch.tensor(fitted._standardise(fitted._reshape(X_test)))
    with torch.no_grad():
        expected = _logits_torch(
            torch,
            h,
            [torch.tensor(w) for w in fitted.conv_weights_],
            [torch.tensor(b) for b in fitted.conv_biases_],
            torch.tensor(fitted.head_weight_),
            torch.tensor(fitted.head_bias_),
            fitted.kernel_size,
        ).numpy()
    np.testing.assert_allclose(fitted._logits(X_test), expected, rtol=1e-9, atol=1e-9)


@torch_missing
def test_saved_tcn_predicts_the_same_without_torch(fitted, series_split, tmp_path):
    from tactile_bullet.learn.models import Model, load_model, save_model

    _, X_test, _, _ = series_split
    model = Model("time-series", {"length": QUICK["length"]}, "tcn", QUICK, fitted)
    path = save_model(tmp_path / "tcn.npz", model)
    with np.load(path, allow_pickle=False) as data:  # plain arrays only
        assert "estimator_skops" not in data.files
    loaded = load_model(path)
    assert np.array_equal(loaded.estimator.predict_proba(X_test), fitted.predict_proba(X_test))
    np.save(tmp_path / "x.npy", X_test)
    code = (
        "import sys, numpy as np\n"
        "from tactile_bullet.learn.models import load_model\n"
        f"m = load_model({str(path)!r})\n"
        f"p = m.estimator.predict_proba(np.load({str(tmp_path / 'x.npy')!r}))\n"
        "assert 'torch' not in sys.modules\n"
        f"np.save({str(tmp_path / 'p.npy')!r}, p)\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
    assert np.array_equal(np.load(tmp_path / "p.npy"), fitted.predict_proba(X_test))


@torch_missing
def test_a_tampered_tcn_state_is_refused(fitted, tmp_path):
    from tactile_bullet.learn.models import Model, load_model, save_model

    model = Model("time-series", {"length": QUICK["length"]}, "tcn", QUICK, fitted)
    path = save_model(tmp_path / "tcn.npz", model)
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["state.conv1_weight"] = arrays["state.conv1_weight"][:, :3]
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(UsageError, match="cannot restore"):
        load_model(tmp_path / "bad.npz")


def test_tcn_is_paired_with_the_time_series_only():
    assert plugins.required_descriptor("tcn") == "time-series"
    assert plugins.compatible("time-series", "tcn")
    assert not plugins.compatible("signature", "tcn")


@pytest.mark.parametrize(
    ("param", "message"),
    [
        ("width=0", "width must be from 1"),
        ("kernel_size=4", "kernel_size must be odd"),
        ("learning_rate=-1", "learning_rate must be"),
        ("length=7", "does not divide"),
        ("n_layers=40", "n_layers must be from 1 to 12"),
    ],
)
def test_bad_tcn_parameters_exit_2_before_training(param, message, capsys, tmp_path):
    from synthetic import write_records

    data = write_records(tmp_path / "data", make_records(per_shape=2, seed=5))
    err = run_error(
        capsys,
        ["train", "--data", str(data), "--descriptor", "time-series", "--classifier", "tcn",
         "--param", param, "--out", str(tmp_path / "m.npz")],
    )  # fmt: skip
    assert message in err
    assert not (tmp_path / "m.npz").exists()


def _checked_tcn():
    from tactile_bullet.learn.classifiers.tcn import TCNClassifier

    # sklearn's checks feed 2- to 20-feature tables: length=1 reads each feature as a channel
    return TCNClassifier(length=1, width=8, n_layers=2, epochs=60, batch_size=32)


if __import__("importlib").util.find_spec("torch") is not None:
    from sklearn.utils.estimator_checks import parametrize_with_checks

    @parametrize_with_checks([_checked_tcn()])
    def test_tcn_passes_scikit_learns_estimator_checks(estimator, check):
        check(estimator)
