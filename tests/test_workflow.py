"""The workflow API (train, evaluate, compare, identify, split) and the report helpers, on
synthetic records: joint angles of a hand wrapped on each shape's radius profile (thesis eq.
2.3), with noise, so every test runs in well under a second without the simulator."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_bullet.errors import UsageError
from tactile_bullet.experiments import reports, workflow
from tactile_bullet.hand import FCI_JOINTS, FINGER_X, JOINT_NAMES, LONG_FINGERS, PHALANX_LENGTHS
from tactile_bullet.objects.shapes import BUILTIN_SHAPES
from tactile_bullet.records import ControllerSettings, GraspRecord, Pose

SHAPES = ("cone", "sphere", "cylinder")
TABLE = {s.name: s for s in BUILTIN_SHAPES}


def wrapped_angles(radius: np.ndarray) -> np.ndarray:
    """(3, n) joint angles of fingers wrapped on circles of these radii (m): each phalanx
    spans its central angle; a finger beside the object (r = 0) closes to 90 degrees."""
    lengths = np.asarray(PHALANX_LENGTHS)[:, None]
    theta = 2.0 * np.arctan(lengths / (2.0 * (radius[None, :] + 0.009)))
    return np.where(radius[None, :] > 0, theta, np.pi / 2)


def synthetic_record(shape: str, fraction: float, offset_x: float, rng) -> GraspRecord:
    """A record whose final long-finger angles wrap ``shape`` at a relative size ``fraction``
    of every parameter's range, shifted ``offset_x`` (m) along O-O', plus 0.01 rad noise."""
    spec = TABLE[shape]
    params = spec.resolve({k: p.min + fraction * (p.max - p.min) for k, p in spec.params.items()})
    x = np.array([FINGER_X[f] for f in LONG_FINGERS]) - offset_x
    fci = wrapped_angles(spec.radius(x, **params)) + rng.normal(0.0, 0.01, (3, 4))
    final = np.zeros(len(JOINT_NAMES))
    for col, finger in enumerate(LONG_FINGERS):
        for row, joint in enumerate(FCI_JOINTS[finger]):
            final[JOINT_NAMES.index(joint)] = fci[row, col]
    return GraspRecord(
        shape=shape,
        params=params,
        pose=Pose((offset_x, 0.0, 0.0)),
        controller=ControllerSettings(),
        seed=0,
        time=np.zeros(1),
        angles=final[None, :],
        efforts=np.zeros((1, len(JOINT_NAMES))),
        final_angles=final,
        contact_link=np.array([], dtype="U16"),
        contact_position=np.zeros((0, 3)),
        contact_normal=np.zeros((0, 3)),
        contact_force=np.zeros(0),
        fingers_in_contact=("ff", "mf", "rf", "lf", "th"),
    )


def synthetic_set(n_per_shape: int, seed: int, shapes=SHAPES) -> list[GraspRecord]:
    rng = np.random.default_rng(seed)
    return [
        synthetic_record(s, float(rng.uniform(0.1, 0.9)), float(rng.uniform(-0.012, 0.012)), rng)
        for s in shapes
        for _ in range(n_per_shape)
    ]


@pytest.fixture(scope="module")
def data():
    return synthetic_set(12, seed=1), synthetic_set(6, seed=2)


@pytest.fixture(scope="module")
def model(data):
    return workflow.train(data[0], "signature", "svm")


def test_trained_model_tells_synthetic_shapes_apart(model, data):
    result = workflow.evaluate(model, data[1])
    assert result["accuracy"] >= 0.9
    assert sorted(result["classes"]) == sorted(SHAPES)


def test_saved_model_predicts_what_the_trained_one_did(model, data, tmp_path):
    from tactile_bullet.learn.models import load_model, save_model

    path = save_model(tmp_path / "model.npz", model)
    loaded = load_model(path)
    assert list(workflow.predict(loaded, data[1])) == list(workflow.predict(model, data[1]))
    assert (
        workflow.evaluate(loaded, data[1])["confusion_matrix"]
        == (workflow.evaluate(model, data[1])["confusion_matrix"])
    )


def test_evaluate_document_keeps_the_contract(model, data):
    doc = workflow.evaluate(model, data[1])
    for key in ("accuracy", "classes", "confusion_matrix", "per_class", "by_size", "by_position"):
        assert key in doc
    cm = np.array(doc["confusion_matrix"])
    assert cm.shape == (len(doc["classes"]), len(doc["classes"]))
    for i, name in enumerate(doc["classes"]):
        assert cm[i].sum() == doc["per_class"][name]["support"]
        assert set(doc["per_class"][name]) >= {"precision", "recall", "support"}
    assert cm.sum() == len(data[1])
    assert doc["accuracy"] == pytest.approx(np.trace(cm) / cm.sum())
    assert sum(b["support"] for b in doc["by_size"].values()) == len(data[1])
    assert sum(b["support"] for b in doc["by_position"].values()) == len(data[1])
    assert doc["by_rotation"] == {"0-2.5 deg": {"accuracy": doc["accuracy"], "support": 18}}


def test_a_shape_the_model_never_saw_counts_as_an_error(model):
    rng = np.random.default_rng(3)
    records = [synthetic_record("cone", 0.5, 0.0, rng), synthetic_record("torus", 0.5, 0.0, rng)]
    doc = workflow.evaluate(model, records)
    assert doc["unknown_classes"] == ["torus"]
    assert doc["classes"][-1] == "torus"
    assert doc["per_class"]["torus"]["recall"] == 0.0


def test_evaluate_refuses_data_with_none_of_the_models_shapes(model):
    rng = np.random.default_rng(4)
    with pytest.raises(UsageError, match="none of the model's classes"):
        workflow.evaluate(model, [synthetic_record("torus", 0.5, 0.0, rng)])


def test_training_refuses_empty_or_single_shape_data(data):
    with pytest.raises(UsageError, match="no grasp records"):
        workflow.train([], "signature", "svm")
    cones = [r for r in data[0] if r.shape == "cone"]
    with pytest.raises(UsageError, match="at least two shapes, the data holds only 'cone'$"):
        workflow.train(cones, "signature", "svm")


def test_unknown_names_and_parameters_list_what_exists(data):
    with pytest.raises(UsageError, match="svm"):
        workflow.train(data[0], "signature", "no-such-classifier")
    with pytest.raises(UsageError, match="signature"):
        workflow.train(data[0], "no-such-descriptor", "svm")
    with pytest.raises(UsageError, match="no parameter"):
        workflow.train(data[0], "signature", "svm", {"no_such_param": 1})


def test_a_classifier_tied_to_one_descriptor_refuses_others(data):
    with pytest.raises(UsageError, match="reads only the signature"):
        workflow.train(data[0], "raw-joints", "dtw-template")


def test_identify_names_one_of_the_models_classes_with_probabilities(model, data):
    doc = workflow.identify(model, data[1][0])
    assert doc["shape"] in model.classes
    assert set(doc["probabilities"]) == {str(c) for c in model.classes}
    assert sum(doc["probabilities"].values()) == pytest.approx(1.0)


def test_compare_returns_every_pair(data):
    descriptors, classifiers = ("signature", "raw-joints"), ("svm", "knn", "dtw-template")
    rows = workflow.compare(data[0], data[1], descriptors, classifiers)
    pairs = [(r["descriptor"], r["classifier"]) for r in rows]
    assert pairs == [(d, c) for d in descriptors for c in classifiers]
    for row in rows:
        assert set(row) >= {"descriptor", "classifier", "accuracy", "fit_time_s",
                            "predict_latency_ms"}  # fmt: skip
        if row["accuracy"] is not None:
            assert 0.0 <= row["accuracy"] <= 1.0
            assert row["predict_latency_ms"] > 0
    skipped = [r for r in rows if r.get("skipped")]
    assert [(r["descriptor"], r["classifier"]) for r in skipped] == [("raw-joints", "dtw-template")]


def test_compare_without_test_data_splits_by_shape_and_seed(data):
    train, test = workflow.split(data[0], 0.25, seed=5)
    again = workflow.split(data[0], 0.25, seed=5)
    assert [id(r) for r in train] == [id(r) for r in again[0]]
    assert {r.shape for r in test} == set(SHAPES)
    assert len(train) + len(test) == len(data[0])
    assert not {id(r) for r in train} & {id(r) for r in test}
    rows = workflow.compare(data[0], None, ["signature"], ["knn"], seed=5, test_fraction=0.25)
    assert rows[0]["test_records"] == len(test)


def test_compare_fails_on_a_typo_before_fitting_anything(data):
    with pytest.raises(UsageError, match="unknown classifier"):
        workflow.compare(data[0], data[1], ["signature"], ["svm", "svn"])


def test_compare_refuses_when_no_pair_asked_for_can_run(data):
    # a table of dashes would look like a result; one pair that can run is still compared
    with pytest.raises(UsageError, match="no descriptor x classifier pair can run: dtw-template"):
        workflow.compare(data[0], data[1], ["raw-joints"], ["dtw-template"])


# --- reports ------------------------------------------------------------------------------------


def test_confusion_matrix_rows_are_true_classes():
    cm = reports.confusion_matrix(["a", "a", "b"], ["a", "b", "b"], ["a", "b"])
    assert cm.tolist() == [[1, 1], [0, 1]]
    scores = reports.per_class_scores(cm, ["a", "b"])
    assert scores["a"] == {"precision": 1.0, "recall": 0.5, "support": 2}
    assert scores["b"]["precision"] == 0.5


def test_size_fraction_spans_the_valid_range():
    spec = TABLE["cylinder"]
    low = {k: p.min for k, p in spec.params.items()}
    high = {k: p.max for k, p in spec.params.items()}
    assert reports.size_fraction("cylinder", low) == 0.0
    assert reports.size_fraction("cylinder", high) == 1.0
    assert reports.size_bin(0.0) == "small" and reports.size_bin(1.0) == "large"


def test_position_bins_follow_offset_distance():
    assert reports.position_bin((0.0, 0.0, 0.0)) == "0-5 mm"
    assert reports.position_bin((0.003, 0.0, -0.004)) == "5-10 mm"
    assert reports.position_bin((0.0, 0.0, 0.05)) == ">=20 mm"


def test_rotation_bins_follow_the_thesis_steps_either_way():
    assert reports.rotation_bin(np.radians(5.0)) == reports.rotation_bin(np.radians(-10.0))
    assert reports.rotation_bin(np.radians(15.0)) == "12.5-22.5 deg"
    assert reports.rotation_bin(np.radians(25.0)) == ">=22.5 deg"


def test_report_folder_holds_json_and_figures(model, data, tmp_path):
    doc = workflow.evaluate(model, data[1])
    written = reports.write_evaluation_report(doc, tmp_path / "rep")
    names = {p.name for p in written}
    assert {"report.json", "confusion_matrix.png", "accuracy_by_size.png"} <= names
    for path in written:
        if path.suffix == ".png":
            assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list((tmp_path / "rep").glob(".*tmp*"))


def test_report_figures_are_titled_with_method_and_accuracy(model, data):
    doc = workflow.evaluate(model, data[1])
    title = reports.report_title(doc, "accuracy by size")
    method = f"{doc['model']['descriptor']} + {doc['model']['classifier']}"
    assert title.startswith(f"{method}: {100 * doc['accuracy']:.1f}% of {doc['records']} grasps")
    assert title.endswith("accuracy by size")
    rec = data[0][0]
    key = reports.grasp_key(rec)  # the signatures.png key names each grasp's sizes and offset
    assert all(f"{1000 * v:.0f}" in key for v in rec.params.values())


def test_confusion_text_lists_every_class():
    text = reports.confusion_text([[2, 0], [1, 3]], ["cone", "sphere"])
    lines = text.splitlines()
    assert lines[1].split()[-2:] == ["2", "0"] and lines[2].split() == ["sphere", "1", "3"]


def test_demo_tests_on_sizes_and_offsets_never_trained_on():
    rng = np.random.default_rng(0)

    def draw(fractions, offsets):
        return [
            s for name in workflow.DEMO_SHAPES
            for s in workflow.draw_specs(name, 25, fractions, offsets, rng)
        ]  # fmt: skip

    train = draw(workflow.TRAIN_FRACTIONS, workflow.TRAIN_OFFSETS)
    test = draw(workflow.TEST_FRACTIONS, workflow.TEST_OFFSETS)
    seen = {(s.shape, k, round(v, 9)) for s in train for k, v in s.params.items()}
    assert not [(s.shape, k) for s in test for k, v in s.params.items()
                if (s.shape, k, round(v, 9)) in seen]  # fmt: skip
    assert not {s.pose.offset for s in train} & {s.pose.offset for s in test}
    for spec in test:
        assert TABLE[spec.shape].resolve(spec.params) == dict(spec.params)
