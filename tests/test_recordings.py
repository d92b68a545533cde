"""Real-hand recordings: bags and tables written with rosbags' writers (and the csv module) from
simulated and synthetic records read back as the same grasps, the name conventions of a real
Shadow hand, segmentation, calibration, and the streaming identifier."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tactile_bullet.errors import UsageError
from tactile_bullet.experiments import workflow
from tactile_bullet.hand import JOINT_NAMES
from tactile_bullet.realhand.calibration import Calibration, calibration_from_dict
from tactile_bullet.realhand.export import export, published_names
from tactile_bullet.realhand.joints import J2_MAX, JointMap
from tactile_bullet.realhand.names import canonical_joint, split_name
from tactile_bullet.realhand.recordings import identify_grasps, read_recording, record_from_samples

pytest.importorskip("rosbags")

BAG_FORMATS = ("bag", "db3", "mcap", "csv")
SUFFIX = {"bag": ".bag", "db3": "", "mcap": "", "csv": ".csv"}


def _with_efforts(records, seed=0):
    """Synthetic records carry zero efforts: give them some, so the round trip checks them."""
    rng = np.random.default_rng(seed)
    return [dataclasses.replace(r, efforts=rng.normal(0, 0.2, r.angles.shape)) for r in records]


@pytest.fixture(scope="session")
def simulated():
    """Two simulated grasps (real time series, efforts and settle) of different shapes."""
    from tactile_bullet.sim.grasp import simulate_grasp

    return [
        simulate_grasp("cylinder", {"radius": 0.035}),
        simulate_grasp("sphere", {"radius": 0.045}),
    ]


@pytest.fixture(scope="session")
def model(synthetic_split):
    return workflow.train(synthetic_split[0], "signature", "svm")


@pytest.fixture(scope="session")
def held_out_records(synthetic_split):
    return _with_efforts(synthetic_split[1][::2])


def _out(tmp_path, fmt, name="rec"):
    return tmp_path / f"{name}{SUFFIX[fmt]}"


def assert_same_grasp(got, want):
    assert got.source == "recorded"
    assert got.time.shape == want.time.shape
    np.testing.assert_allclose(got.time, want.time - want.time[0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got.angles, want.angles, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got.efforts, want.efforts, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got.final_angles, want.final_angles, rtol=0, atol=1e-12)
    assert got.shape == want.shape
    assert got.contact_link.size == 0


# --- names --------------------------------------------------------------------------------------


def test_published_names_are_read_with_or_without_a_hand_prefix():
    assert split_name("rh_FFJ3") == ("rh", "FFJ3")
    assert split_name("lh_thj1") == ("lh", "THJ1")
    assert canonical_joint("MFJ0") == "MFJ0"
    assert canonical_joint("THJ0") is None  # the thumb has no coupled joint
    assert canonical_joint("rh_XXJ3") is None
    assert canonical_joint("elbow") is None


def test_coupled_j0_goes_to_j2_first_then_to_j1():
    names = published_names(coupled=True)
    assert "FFJ0" in names and "FFJ1" not in names and "FFJ2" not in names
    jmap = JointMap(names)
    raw = np.zeros(len(names))
    raw[names.index("FFJ0")] = 2.0  # past J2's limit: the rest is J1's
    raw[names.index("MFJ0")] = 1.0  # within it: all J2
    raw[names.index("FFJ3")] = 0.4
    q = jmap.positions(raw)
    col = JOINT_NAMES.index
    assert q[col("FFJ2")] == pytest.approx(J2_MAX)
    assert q[col("FFJ1")] == pytest.approx(2.0 - J2_MAX)
    assert q[col("MFJ2")] == pytest.approx(1.0) and q[col("MFJ1")] == 0.0
    # the signature's two lines read J3 and J3 + J0: exact whatever the split
    assert q[col("FFJ3")] + q[col("FFJ2")] + q[col("FFJ1")] == pytest.approx(2.4)


def test_unknown_missing_and_mixed_names_are_named_in_the_error():
    names = ["rh_" + n for n in JOINT_NAMES]
    with pytest.raises(UsageError, match="unknown joint names: rh_elbow"):
        JointMap([*names, "rh_elbow"])
    with pytest.raises(UsageError, match="missing joints: rh_RFJ3"):
        JointMap([n for n in names if n != "rh_RFJ3"])
    with pytest.raises(UsageError, match="mix hand prefixes"):
        JointMap([*names[:-1], "lh_THJ1"])
    JointMap([n for n in names if "WR" not in n])  # the wrist may be absent


# --- round trips --------------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", BAG_FORMATS)
def test_exported_grasps_read_back_equal(tmp_path, simulated, held_out_records, fmt):
    records = [*simulated, *held_out_records[:3]]
    out = _out(tmp_path, fmt)
    doc = export(records, out, fmt)
    assert doc["messages"] == sum(r.time.size for r in records)
    grasps = read_recording(out)
    assert len(grasps) == len(records)
    for g, rec in zip(grasps, records, strict=True):
        assert_same_grasp(g.record, rec)


def test_parquet_reads_like_csv(tmp_path, simulated):
    pa = pytest.importorskip("pyarrow")
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    export(simulated, tmp_path / "r.csv", "csv")
    pq.write_table(pacsv.read_csv(tmp_path / "r.csv"), tmp_path / "r.parquet")
    assert pa is not None
    grasps = read_recording(tmp_path / "r.parquet")
    for g, rec in zip(grasps, simulated, strict=True):
        assert_same_grasp(g.record, rec)


@pytest.mark.parametrize("fmt", ("bag", "csv"))
def test_silence_between_grasps_cuts_them_without_markers(tmp_path, simulated, fmt):
    out = _out(tmp_path, fmt)
    export([*simulated, *simulated], out, fmt)
    grasps = read_recording(out, marker="none")
    assert len(grasps) == 4
    for g, rec in zip(grasps, [*simulated, *simulated], strict=True):
        np.testing.assert_allclose(g.record.final_angles, rec.final_angles, atol=1e-12)
        np.testing.assert_allclose(g.record.time, rec.time, atol=1e-9)


def test_a_continuous_stream_is_cut_where_the_hand_opens(tmp_path, simulated):
    """No gap, no marker: close, hold, open, close again, as a real hand publishing at 60 Hz."""
    a, b = simulated
    opening = np.linspace(1.0, 0.0, 30)[:, None] * a.final_angles[None, :]
    angles = np.vstack([a.angles, opening, b.angles])
    time = np.arange(len(angles)) / 60.0
    header = "time," + ",".join("rh_" + n for n in JOINT_NAMES)
    rows = [
        f"{float(t)!r}," + ",".join(repr(float(v)) for v in q)
        for t, q in zip(time, angles, strict=True)
    ]
    path = tmp_path / "stream.csv"
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    grasps = read_recording(path)
    assert len(grasps) == 2
    np.testing.assert_allclose(grasps[0].record.final_angles, a.final_angles, atol=1e-12)
    np.testing.assert_allclose(grasps[1].record.final_angles, b.final_angles, atol=1e-12)
    assert "no_efforts" in grasps[0].record.flags


def test_coupled_bag_keeps_both_signature_lines(tmp_path, simulated):
    out = tmp_path / "j0.bag"
    export(simulated, out, "bag", coupled=True)
    for g, rec in zip(read_recording(out), simulated, strict=True):
        got, want = g.record.fci_angles(), rec.fci_angles()
        np.testing.assert_allclose(got[0], want[0], atol=1e-12)  # J3
        np.testing.assert_allclose(got.sum(axis=0), want.sum(axis=0), atol=1e-12)  # J3 + J0
        np.testing.assert_allclose(got[1], np.minimum(want[1] + want[2], J2_MAX), atol=1e-12)


# --- classification -----------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", ("bag", "mcap", "csv"))
def test_reimported_grasps_classify_as_the_originals(
    tmp_path, model, simulated, held_out_records, fmt
):
    records = [*simulated, *held_out_records]
    out = _out(tmp_path, fmt)
    export(records, out, fmt)
    answers = identify_grasps(model, read_recording(out))
    assert [a["shape"] for a in answers] == list(workflow.predict(model, records))
    assert [a["label"] for a in answers] == [r.shape for r in records]
    for a, rec in zip(answers, records, strict=True):
        expected = workflow.identify(model, rec)["probabilities"]
        assert a["probabilities"] == pytest.approx(expected, abs=1e-9)


def test_j0_only_recordings_classify_as_their_split(tmp_path, model, held_out_records):
    """A J0-only hand loses how J0 was shared between J2 and J1: the reader's answer is the
    model's answer on the original grasp with J0 split by the documented rule."""
    from tactile_bullet.realhand.export import published_values

    out = tmp_path / "j0.csv"
    export(held_out_records, out, "csv", coupled=True)
    answers = identify_grasps(model, read_recording(out))
    jmap = JointMap(published_names(coupled=True))
    split = [
        record_from_samples(r.time, jmap.positions(published_values(r, True)[0]), r.efforts)
        for r in held_out_records
    ]
    assert [a["shape"] for a in answers] == list(workflow.predict(model, split))


# --- calibration --------------------------------------------------------------------------------


def test_calibration_corrects_the_published_joint(tmp_path, simulated):
    cal = calibration_from_dict(
        {"joints": {"rh_FFJ3": {"offset_deg": 2.0}, "MFJ3": {"scale": 1.1, "offset": -0.01}}}
    )
    out = tmp_path / "r.csv"
    export(simulated[:1], out, "csv")
    got = read_recording(out, calibration=cal)[0].record
    raw = simulated[0]
    ff, mf = JOINT_NAMES.index("FFJ3"), JOINT_NAMES.index("MFJ3")
    np.testing.assert_allclose(got.angles[:, ff], raw.angles[:, ff] + math.radians(2.0))
    np.testing.assert_allclose(got.angles[:, mf], 1.1 * raw.angles[:, mf] - 0.01)
    np.testing.assert_array_equal(got.angles[:, ff + 1], raw.angles[:, ff + 1])


@pytest.mark.parametrize(
    "doc, message",
    [
        ({"joints": {"FFJ9": {"offset": 0.1}}}, "unknown joint"),
        ({"joints": {"FFJ3": {"ofset": 0.1}}}, "unknown key 'ofset'"),
        ({"joints": {"FFJ3": {"scale": 0.0}}}, "scale"),
        ({"joints": {"FFJ3": {"offset": 3.0}}}, "offset"),
        ({"joint": {}}, "unknown key 'joint'"),
    ],
)
def test_bad_calibration_is_refused(doc, message):
    with pytest.raises(UsageError, match=message):
        calibration_from_dict(doc)


# --- records ------------------------------------------------------------------------------------


def test_recordings_at_a_real_hands_rate_and_length_make_valid_records():
    """A hand publishing at 1 kHz, a grasp held for two minutes: both beyond what the
    simulator's settings allow, both a valid recorded record."""
    time = np.arange(0.0, 120.0, 0.001)
    angles = np.zeros((time.size, len(JOINT_NAMES)))
    rec = record_from_samples(time, angles, angles)
    assert rec.controller.sample_rate == pytest.approx(1000.0)
    assert rec.time[-1] == pytest.approx(120.0, abs=0.01)


def test_recorded_source_survives_a_dataset_and_old_records_stay_simulated(tmp_path, simulated):
    from tactile_bullet.datasets.dataset import open_dataset
    from tactile_bullet.realhand.recordings import write_dataset

    rec = simulated[0]
    assert "source" not in rec.metadata()  # simulated records are written as before
    recorded = record_from_samples(rec.time, rec.angles, rec.efforts, "cylinder")
    write_dataset([rec, recorded], tmp_path / "ds", {"test": True})
    back = list(open_dataset(tmp_path / "ds"))
    assert [r.source for r in back] == ["simulated", "recorded"]
    assert back[0].equals(rec)


# --- streaming ----------------------------------------------------------------------------------


def _replay(ident, record, t0=0.0, hold_s=0.3, names=None):
    names = names or ["rh_" + n for n in JOINT_NAMES]
    for t, q, e in zip(record.time, record.angles, record.efforts, strict=True):
        ident.update(t0 + t, names, q, e)
    mid = ident.result()
    end = t0 + record.time[-1]
    for k in range(1, int(hold_s * 100) + 1):  # a real hand keeps publishing its held pose
        ident.update(end + k / 100, names, record.angles[-1], record.efforts[-1])
    return mid, end + hold_s


def test_streaming_names_the_shape_once_the_grasp_is_held(model, held_out_records):
    from tactile_bullet import Identifier

    ident = Identifier.load(model)
    assert ident.result() == {"shape": None, "probabilities": {}, "margin": None,
                              "ambiguous": None, "cross_check": None, "unknown": False,
                              "novelty": None, "unknown_why": None,
                              "axis_residual_mm": None, "profile_residual_mm": None,
                              "renamed_from": None, "rotation_deg": None,
                              "grasp_over": False, "samples": 0}  # fmt: skip
    t0 = 0.0
    want = workflow.predict(model, held_out_records)
    for rec, expected in zip(held_out_records, want, strict=True):
        mid, t0 = _replay(ident, rec, t0)
        assert mid["shape"] is None and not mid["grasp_over"]
        assert set(mid["probabilities"]) == set(model.classes)
        out = ident.result()
        assert out["grasp_over"] and out["shape"] == expected
        once = workflow.identify(model, rec)
        assert out["probabilities"] == pytest.approx(once["probabilities"], abs=1e-9)
        # the same doubt as a one-off identification (the model's calibrated margin)
        assert out["margin"] == pytest.approx(once["margin"], abs=1e-9)
        assert out["ambiguous"] == once["ambiguous"]
        assert out["cross_check"] == once["cross_check"]
        t0 += 1.0  # silence before the next grasp


def test_streaming_silence_ends_a_grasp_and_finish_ends_the_last(model, held_out_records):
    from tactile_bullet import Identifier

    ident = Identifier(model)
    a, b = held_out_records[:2]
    names = list(published_names(coupled=False))
    for t, q in zip(a.time, a.angles, strict=True):
        ident.update(t, names, q)
    assert not ident.result()["grasp_over"]
    ident.update(a.time[-1] + 2.0, names, b.angles[0])  # silence, then the next grasp begins
    over = ident.result()
    assert over["grasp_over"] and over["shape"] == workflow.predict(model, [a])[0]
    for t, q in zip(b.time[1:], b.angles[1:], strict=True):
        ident.update(a.time[-1] + 2.0 + t, names, q)
    assert ident.result()["shape"] is None
    ident.finish()
    assert ident.result()["shape"] == workflow.predict(model, [b])[0]


def test_streaming_keeps_one_sample_while_the_object_is_held(model, held_out_records):
    from tactile_bullet import Identifier

    ident = Identifier(model)
    rec = held_out_records[0]
    _, _ = _replay(ident, rec, hold_s=0.3)
    kept = ident.result()["samples"]
    _replay(ident, dataclasses.replace(rec, time=rec.time[-1:], angles=rec.angles[-1:],
                                       efforts=rec.efforts[-1:]), t0=0.31, hold_s=60.0)  # fmt: skip
    out = ident.result()
    assert out["grasp_over"] and out["samples"] == kept
    assert ident.current_record().time[-1] > 60.0  # the kept sample followed the held hand
    assert out["shape"] == workflow.predict(model, [rec])[0]


def test_streaming_refuses_bad_messages(model):
    from tactile_bullet import Identifier

    ident = Identifier(model)
    names = list(JOINT_NAMES)
    with pytest.raises(UsageError, match="unknown joint names: elbow"):
        ident.update(0.0, [*names, "elbow"], np.zeros(len(names) + 1))
    ident.update(1.0, names, np.zeros(len(names)))
    ident.update(1.5, ["shoulder_pan_joint", "elbow_joint"], [0.1, 0.2])  # an arm: ignored
    assert ident.samples == 1
    with pytest.raises(UsageError, match="backwards"):
        ident.update(0.5, names, np.zeros(len(names)))
    with pytest.raises(UsageError, match="positions"):
        ident.update(2.0, names, np.zeros(3))


def test_identifier_is_exported_lazily():
    import subprocess
    import sys

    code = (
        "import sys, tactile_bullet; "
        "assert 'tactile_bullet.realhand.streaming' not in sys.modules; "
        "from tactile_bullet import Identifier; print(Identifier.__module__)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "tactile_bullet.realhand.streaming"


def test_calibration_default_is_identity():
    scale, offset = Calibration().vectors(("FFJ3",))
    assert scale.tolist() == [1.0] and offset.tolist() == [0.0]


def test_parquet_without_pyarrow_names_the_extra(tmp_path, monkeypatch, capsys):
    import sys

    from cli_helpers import run_error

    monkeypatch.setitem(sys.modules, "pyarrow", None)  # as if not installed
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    (tmp_path / "r.parquet").write_bytes(b"PAR1")
    err = run_error(capsys, ["import", str(tmp_path / "r.parquet"), "--out", str(tmp_path / "o")])
    assert "tactile-bullet[parquet]" in err and not (tmp_path / "o").exists()


def test_bags_without_rosbags_name_the_extra(tmp_path, monkeypatch, capsys, simulated):
    import sys

    from cli_helpers import run_error

    export(simulated[:1], tmp_path / "r.bag", "bag")
    for name in ("rosbags", "rosbags.highlevel", "rosbags.rosbag1", "rosbags.typesys"):
        monkeypatch.setitem(sys.modules, name, None)  # as if not installed
    err = run_error(capsys, ["import", str(tmp_path / "r.bag"), "--out", str(tmp_path / "o")])
    assert "tactile-bullet[ros]" in err and not (tmp_path / "o").exists()
    export(simulated[:1], tmp_path / "r.csv", "csv")  # CSV needs no extra
    assert len(read_recording(tmp_path / "r.csv")) == 1
