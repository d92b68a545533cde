"""Chapter 3: image G, Gbin and its areas, the non-contact detectors, signature correction.

Synthetic angle series with known contact times check the arithmetic; a few simulated grasps
(a small sphere moved sideways so one outer finger misses it, a centred cylinder) check the
detectors against the contacts the simulator recorded.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from cli_helpers import run_error

from tactile_bullet.errors import UsageError
from tactile_bullet.perception.temporal import (
    DynamicDetector,
    contact_truth,
    corrected_signature,
    detect,
    dynamic_detector,
    finger_areas,
    g_of,
    g_row,
    gbin,
    image_g,
    position_detector,
    record_series,
)

RATE = 60.0
SPEED = 1.44  # rad/s: the default controller's closing speed
LIMIT = np.pi / 2 * 0.97  # where a free simulated joint stops (87 deg)


def closing(contact_s, adapted_s, end=3.5):
    """(time, angles (T, 3, 4)) of Algorithm 1 at the default speed: J3 closes until
    ``contact_s[f]`` (or its limit), then the tendon (J2 then J1) until ``adapted_s[f]`` (or
    both limits); None for either means "runs to the limit"."""
    t = np.arange(0.0, end, 1.0 / RATE)
    a = np.zeros((t.size, 3, 4))
    for f in range(4):
        stop3 = contact_s[f] if contact_s[f] is not None else LIMIT / SPEED
        j3 = np.clip(SPEED * t, 0.0, SPEED * stop3)
        stop0 = adapted_s[f] if adapted_s[f] is not None else stop3 + 2 * LIMIT / SPEED
        j0 = np.clip(SPEED * (np.minimum(t, stop0) - stop3), 0.0, 2 * LIMIT)
        a[:, 0, f] = np.minimum(j3, LIMIT)
        a[:, 1, f] = np.minimum(j0, LIMIT)
        a[:, 2, f] = np.clip(j0 - LIMIT, 0.0, LIMIT)
    return t, a


def test_g_is_the_spread_of_each_fci_column_so_the_coupled_distal_angle():
    angles = np.radians([[30, 40, 50, 60], [10, 20, 0, 90], [5, 0, 0, 90]])
    row = g_row(angles)
    k = 256 / 3 / (np.pi / 2)
    assert row == pytest.approx(k * np.radians([15, 20, 0, 180]))


def test_areas_of_each_finger_are_found_at_the_known_contact_and_adaptation_times():
    contact, adapted = (0.5, 0.7, 0.9, 0.6), (1.2, 1.5, 1.4, 1.0)
    image = image_g(*closing(contact, adapted), rate=RATE)
    binary = gbin(image)
    for f, area in enumerate(finger_areas(image, binary)):
        assert area.contact_s == pytest.approx(contact[f], abs=2.5 / RATE)
        assert area.adapted_s == pytest.approx(adapted[f], abs=2.5 / RATE)
        # Gbin is 1 exactly while the finger adapts (area 2.1), 0 in areas 1 and 2.2
        t = image.time
        assert not binary[(t < contact[f] - 2 / RATE), f].any()
        assert binary[(t > contact[f] + 2 / RATE) & (t < adapted[f] - 2 / RATE), f].all()
        assert not binary[(t > adapted[f] + 2 / RATE), f].any()


def test_g_is_resampled_at_f_g_whatever_the_recording_rate():
    t, a = closing((0.5,) * 4, (1.0,) * 4)
    image = image_g(t, a, rate=20.0)
    assert np.diff(image.time) == pytest.approx(1 / 20.0)
    assert image.rows[-1] == pytest.approx(g_row(a[-1]))


def test_a_free_finger_is_found_by_both_detectors_the_dynamic_one_first():
    contact = (0.5, 0.55, 0.6, None)  # lf never meets anything: J3 and J0 run to their limits
    adapted = (1.1, 1.2, 1.3, None)
    t, a = closing(contact, adapted)
    pos = position_detector(t, a)
    dyn = dynamic_detector(image_g(t, a))
    assert pos.non_contact_fingers == dyn.non_contact_fingers == ("lf",)
    assert dyn.decided_s[3] < pos.decided_s[3] - 0.5
    assert dyn.decided_at_s < pos.decided_at_s
    # fingers in contact: known once they settle (dynamic), only at the end (position)
    assert max(dyn.decided_s[:3]) < 1.6
    assert pos.decided_s[:3] == (t[-1],) * 3


def test_a_finger_blocked_at_the_middle_phalanx_is_not_taken_for_a_free_one():
    """J3 and J1 both at their limits but J2 stopped by the object: J0 = J1 + J2 is short of
    its range, so the coupled threshold says contact (a threshold per joint would not)."""
    t, a = closing((None,) * 4, (None,) * 4)
    a[:, 1, 0] = np.minimum(a[:, 1, 0], np.radians(50))  # ff's middle phalanx blocked
    assert position_detector(t, a).non_contact_fingers == ("mf", "rf", "lf")


def test_the_row_by_row_detector_gives_the_whole_image_verdict_and_decides_online():
    t, a = closing((0.5, 0.55, 0.6, None), (1.1, 1.2, 1.3, None))
    image = image_g(t, a)
    det = DynamicDetector()
    known_at = None
    for row, when in zip(image.rows, image.time, strict=True):
        decided = det.push(row, when)
        if decided[3] and known_at is None:
            known_at = when
    online = det.finish()
    batch = dynamic_detector(image)
    assert online.non_contact == batch.non_contact and online.decided_s == batch.decided_s
    assert known_at is not None and known_at < t[-1] - 0.5  # known while the grasp still ran


@pytest.mark.parametrize(
    "call",
    [
        lambda: image_g(np.arange(2) / 60.0, np.zeros((2, 3, 4))),
        lambda: image_g(np.arange(5) / 60.0, np.zeros((5, 4, 3))),
        lambda: image_g(np.array([0.0, 0.1, 0.1]), np.zeros((3, 3, 4))),
        lambda: position_detector(np.arange(5.0), np.full((5, 3, 4), np.nan)),
    ],
)
def test_bad_series_are_one_line_usage_errors(call):
    with pytest.raises(UsageError) as info:
        call()
    assert "\n" not in str(info.value)


def test_a_record_with_final_angles_only_is_refused(sphere_off):
    base = sphere_off["raw"]
    bare = dataclasses.replace(base, time=np.empty(0), angles=np.empty((0, 24)))
    with pytest.raises(UsageError, match="no joint-angle time series"):
        record_series(bare)
    with pytest.raises(UsageError, match="time series"):
        detect(bare, "dynamic")


# --- simulated grasps -----------------------------------------------------------------------


@pytest.fixture(scope="session")
def sphere_off():
    """A 35 mm sphere moved 25 mm toward the first finger: the little finger misses it."""
    from tactile_bullet.records import ControllerSettings, Pose
    from tactile_bullet.sim.grasp import simulate_grasp

    pose = Pose((0.025, 0.0, 0.0))
    raw = simulate_grasp("sphere", {"radius": 0.035}, pose)
    early = simulate_grasp("sphere", {"radius": 0.035}, pose, ControllerSettings(early_stop=True))
    return {"raw": raw, "early": early}


@pytest.fixture(scope="session")
def cylinder_centred():
    from tactile_bullet.records import ControllerSettings
    from tactile_bullet.sim.grasp import simulate_grasp

    return (
        simulate_grasp("cylinder", {"radius": 0.03}),
        simulate_grasp(
            "cylinder", {"radius": 0.03}, controller=ControllerSettings(early_stop=True)
        ),
    )


@pytest.mark.slow
@pytest.mark.parametrize("method", ["position", "dynamic"])
def test_detectors_agree_with_the_simulated_contacts(sphere_off, cylinder_centred, method):
    off = sphere_off["raw"]
    assert "lf" not in off.fingers_in_contact  # the physics the test relies on
    for record in (off, cylinder_centred[0]):
        found = detect(record, method)
        assert (found.contact_mask == contact_truth(record)).all()
    if method == "dynamic":
        pos = detect(off, "position")
        assert detect(off, "dynamic").decided_at_s < pos.decided_at_s - 0.5


@pytest.mark.slow
def test_areas_of_a_simulated_grasp_are_ordered_and_the_free_finger_adapts_last(sphere_off):
    image = g_of(sphere_off["raw"])
    areas = finger_areas(image)
    for area in areas:
        assert area.contact_s is not None and area.contact_s < area.adapted_s <= area.end_s
    # the free finger runs J3 to its limit before its column rises, and rises the longest
    assert areas[3].contact_s == max(a.contact_s for a in areas)
    assert areas[3].adapted_s - areas[3].contact_s > 1.8


@pytest.mark.slow
def test_corrected_signature_of_an_offset_small_sphere_is_closer_to_the_sphere(sphere_off):
    from tactile_bullet.perception.patterns import (
        closest_in_size,
        signature_distance,
        size_matched_library,
    )

    record = sphere_off["raw"]
    family = size_matched_library()["sphere"]
    raw = corrected_signature(record.fci_angles(), np.ones(4, bool))
    fixed = corrected_signature(record.fci_angles(), detect(record, "dynamic").contact_mask)
    d_raw = signature_distance(raw, closest_in_size(raw, family))
    d_fixed = signature_distance(fixed, closest_in_size(fixed, family))
    assert d_fixed < 0.85 * d_raw


@pytest.mark.slow
def test_early_stop_saves_steps_only_where_a_finger_misses(sphere_off, cylinder_centred):
    raw, early = sphere_off["raw"], sphere_off["early"]
    assert early.steps < 0.85 * raw.steps
    assert early.controller.early_stop and not raw.controller.early_stop
    # the fingers on the object end within 2 deg of where they did (the grasp ends sooner, so
    # they have had less time to creep); only the free one stopped short
    touching = contact_truth(raw)
    change = np.abs(early.fci_angles()[:, touching] - raw.fci_angles()[:, touching])
    assert change.max() < np.radians(2.0)
    assert early.fci_angles()[:, 3].sum() < raw.fci_angles()[:, 3].sum() - 0.5
    base, stopped = cylinder_centred
    assert stopped.steps == base.steps
    assert np.array_equal(stopped.final_angles, base.final_angles)


def test_records_saved_before_early_stop_load_with_it_off(sphere_off):
    from tactile_bullet.records import record_from_parts

    record = sphere_off["early"]
    meta = record.metadata()
    del meta["controller"]["early_stop"]
    assert record_from_parts(meta, record.arrays()).controller.early_stop is False
    meta["controller"]["early_stop"] = "yes"
    with pytest.raises(UsageError, match="early_stop"):
        record_from_parts(meta, record.arrays())


def test_descriptor_correction_drops_the_free_finger(sphere_off):
    from tactile_bullet.plugins import get_descriptor

    rec = sphere_off["raw"]
    plain = get_descriptor("signature").transform([rec])
    fixed = get_descriptor("signature", correction="dynamic").transform([rec])
    assert get_descriptor("signature", correction=None).correction == "none"
    assert not np.allclose(plain, fixed)
    with pytest.raises(UsageError, match="correction"):
        get_descriptor("signature", correction="magic")


# --- CLI --------------------------------------------------------------------------------------


def test_temporal_command_writes_figures_and_refuses_to_overwrite(sphere_off, tmp_path, capsys):
    import json

    from tactile_bullet.cli import main
    from tactile_bullet.records import save_record

    data = tmp_path / "data"
    data.mkdir()
    save_record(sphere_off["raw"], data / "rec00000.npz")
    out = tmp_path / "out"
    assert main(["temporal", "--data", str(data), "--out", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["detectors"]["dynamic"]["agreement"] == 1.0
    assert (out / "g_gbin.png").stat().st_size > 0 and (out / "temporal.json").is_file()
    before = (out / "temporal.json").read_bytes()
    err = run_error(capsys, ["temporal", "--data", str(data), "--out", str(out)])
    assert "--force" in err
    assert (out / "temporal.json").read_bytes() == before
    assert main(["temporal", "--data", str(data), "--out", str(out), "--force"]) == 0


def test_temporal_command_bad_input_exits_2(sphere_off, tmp_path, capsys):
    from tactile_bullet.records import save_record

    run_error(capsys, ["temporal", "--data", str(tmp_path / "none"), "--out", str(tmp_path)])
    bare = dataclasses.replace(sphere_off["raw"], time=np.empty(0), angles=np.empty((0, 24)))
    path = save_record(bare, tmp_path / "bare.npz")
    err = run_error(capsys, ["temporal", "--data", str(path), "--out", str(tmp_path / "o")])
    assert "time series" in err


def test_a_sweep_can_ask_for_early_stop_and_old_manifests_still_match():
    from tactile_bullet.datasets.sweeps import Sweep

    data = {"controller": {"early_stop": True}, "shapes": [{"name": "sphere"}]}
    sweep = Sweep.from_dict(data)
    assert all(t.controller.early_stop for t in sweep.tasks())
    assert sweep.to_dict()["controller"]["early_stop"] is True
    plain = Sweep.from_dict({"shapes": [{"name": "sphere"}]}).to_dict()
    assert "early_stop" not in plain["controller"]  # as manifests written before it existed
    assert Sweep.from_dict(plain).to_dict() == plain


def test_the_svm_scores_whole_lies_between_its_centred_and_off_centre_parts():
    """Pooled over the splits' held-out grasps: with few grasps a split can hold no off-centre
    one, and a mean over splits then put ``all`` below both parts (66.7 beside 75 and 80%)."""
    from synthetic import make_records

    from tactile_bullet.experiments.temporal import svm_scores
    from tactile_bullet.records import Pose

    records = make_records(per_shape=4, seed=3)
    moved = [dataclasses.replace(r, pose=Pose((0.015, 0.0, 0.0), 0.0)) if i % 4 == 0 else r
             for i, r in enumerate(records)]  # fmt: skip
    scores, _ = svm_scores(moved, seeds=(0, 1, 2, 3, 4))
    for correction in ("none", "position", "dynamic"):
        s = scores[correction]
        parts = [s[k] for k in ("centred", "off_centre") if s[k]]
        assert s["all"]["n"] == sum(p["n"] for p in parts) == 5 * 6  # 30% of 20, five splits
        low, high = min(p["mean"] for p in parts), max(p["mean"] for p in parts)
        assert low - 1e-12 <= s["all"]["mean"] <= high + 1e-12
