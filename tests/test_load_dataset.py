"""``tactile_bullet.load_dataset``: (X, y) like scikit-learn's loaders, from any grasp data."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from synthetic import make_record

import tactile_bullet
from tactile_bullet.datasets.dataset import PartialDataWarning, open_dataset
from tactile_bullet.datasets.generate import generate
from tactile_bullet.datasets.sweeps import Sweep
from tactile_bullet.errors import UsageError
from tactile_bullet.experiments.workflow import records_from
from tactile_bullet.plugins import get_descriptor
from tactile_bullet.records import save_record

MIX = {
    "name": "mix",
    "shapes": [
        {"name": "cylinder", "params": {"radius": [0.03, 0.04]}, "offset_x": [-0.004, 0.004]},
        {"name": "torus", "offset_x": [-0.004, 0.004], "rotation_deg": [0, 10]},
    ],
}
"""8 grasps, 3 per shard: 3 shards."""


def synthetic_grasp(task):
    """A stand-in for the simulator: a theory-made record, the same every time for a task."""
    rng = np.random.default_rng(task.seed)
    record = make_record(task.shape, task.params, rng, offset_x=task.pose.offset[0])
    return record.metadata(), record.arrays()


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    out = tmp_path_factory.mktemp("load") / "ds"
    generate(Sweep.from_dict(MIX), out, workers=0, shard_size=3, task_fn=synthetic_grasp)
    return out


def test_x_y_are_the_descriptor_of_every_record_in_order(data):
    X, y = tactile_bullet.load_dataset(data, descriptor="raw-joints")
    records = records_from(data)
    assert X.shape == (8, len(get_descriptor("raw-joints").feature_names()))
    assert X.dtype == float and y.dtype.kind == "U"
    np.testing.assert_array_equal(y, [r.shape for r in records])
    np.testing.assert_allclose(X, get_descriptor("raw-joints").transform(records))
    assert sorted(set(y)) == ["cylinder", "torus"]


def test_combined_descriptors_and_parameters(data):
    X, _ = tactile_bullet.load_dataset(
        data, descriptor="signature+raw-joints", descriptor_params={"points": 7}
    )
    expected = get_descriptor("signature+raw-joints", points=7).feature_names()
    assert X.shape == (8, len(expected))


def test_a_record_folder_and_one_record_file(data, tmp_path):
    records = records_from(data)
    for i, record in enumerate(records[:3]):
        save_record(record, tmp_path / f"g{i}.npz")
    X, y = tactile_bullet.load_dataset(tmp_path, descriptor="raw-joints")
    assert X.shape[0] == 3 and list(y) == [r.shape for r in records[:3]]
    X1, y1 = tactile_bullet.load_dataset(tmp_path / "g0.npz", descriptor="raw-joints")
    np.testing.assert_allclose(X1, X[:1])


def test_it_trains_a_scikit_learn_estimator(data):
    from sklearn.neighbors import KNeighborsClassifier

    X, y = tactile_bullet.load_dataset(data, descriptor="raw-joints")
    assert KNeighborsClassifier(1).fit(X, y).score(X, y) == 1.0


def test_columns_hold_features_and_metadata(data):
    columns, y = tactile_bullet.load_dataset(data, descriptor="raw-joints", as_frame="columns")
    records = records_from(data)
    names = get_descriptor("raw-joints").feature_names()
    assert list(columns)[: len(names)] == names
    np.testing.assert_array_equal(columns["shape"], y)
    np.testing.assert_allclose(columns["offset_x"], [r.pose.offset[0] for r in records])
    turned = [np.degrees(r.pose.rotation) for r in records]
    np.testing.assert_allclose(columns["rotation_deg"], turned)
    radius = columns["param_radius"]  # the cylinder's; NaN on tori, which have no radius
    assert np.all(np.isnan(radius[y == "torus"])) and np.all(radius[y == "cylinder"] > 0)
    assert "param_major_radius" in columns
    assert len({len(v) for v in columns.values()}) == 1


def test_a_pandas_frame_only_with_pandas(data, monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)  # as if not installed
    with pytest.raises(UsageError, match="needs pandas"):
        tactile_bullet.load_dataset(data, descriptor="raw-joints", as_frame=True)


def test_a_pandas_frame(data):
    pytest.importorskip("pandas")
    frame, y = tactile_bullet.load_dataset(data, descriptor="raw-joints", as_frame=True)
    assert len(frame) == len(y) == 8
    assert list(frame["shape"]) == list(y)


def test_damaged_data_is_refused_or_skipped_with_a_warning(data, tmp_path):
    import shutil

    copy = tmp_path / "ds"
    shutil.copytree(data, copy)
    shard = sorted(copy.glob("shard-*.npz"))[1]
    shard.write_bytes(shard.read_bytes()[:-10])
    with pytest.raises(UsageError, match=shard.name):
        tactile_bullet.load_dataset(copy, descriptor="raw-joints")
    with pytest.warns(PartialDataWarning, match="3 records skipped"):
        X, y = tactile_bullet.load_dataset(copy, descriptor="raw-joints", allow_partial=True)
    assert len(X) == len(y) == 5


def test_bad_input_is_one_clear_error(data, tmp_path):
    with pytest.raises(UsageError, match="does not exist"):
        tactile_bullet.load_dataset(tmp_path / "nothing", descriptor="raw-joints")
    with pytest.raises(UsageError, match="no-such"):
        tactile_bullet.load_dataset(data, descriptor="no-such")
    with pytest.raises(UsageError, match="as_frame"):
        tactile_bullet.load_dataset(data, descriptor="raw-joints", as_frame="yes")


def test_the_dataset_object_stays_reachable(data):
    assert len(tactile_bullet.open_dataset(data)) == 8
    assert tactile_bullet.open_dataset is open_dataset
