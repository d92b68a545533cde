"""Issue 20 probes on recordings and outputs: ``--force`` replaces only what this project
wrote, and never a device, FIFO, socket or link; garbage joint values are refused before any
answer is given."""

from __future__ import annotations

import json
import os
import socket

import numpy as np
import pytest
from cli_helpers import run_error

from tactile_bullet.cli import main
from tactile_bullet.errors import UsageError
from tactile_bullet.hand import JOINT_NAMES
from tactile_bullet.realhand.export import export
from tactile_bullet.realhand.recordings import write_dataset

pytest.importorskip("rosbags")


@pytest.fixture(scope="module")
def files(tmp_path_factory, synthetic_split):
    """A test dataset of 4 synthetic grasps, its bag and CSV exports."""
    root = tmp_path_factory.mktemp("hard")
    test = synthetic_split[1][:4]
    write_dataset(test, root / "test", {"test": True})
    export(test, root / "test.bag", "bag")
    export(test, root / "test.csv", "csv")
    return {"root": root, "test": test, "data": str(root / "test")}


def _export(files, fmt, out, *extra):
    return ["export", "--data", files["data"], "--format", fmt, "--out", str(out), *extra]


# --- item 1: --force replaces only this project's files -----------------------------------------


@pytest.mark.parametrize("fmt", ["db3", "mcap"])
def test_export_force_keeps_a_folder_with_the_users_files(tmp_path, capsys, files, fmt):
    out = tmp_path / "paper"
    out.mkdir()
    (out / "metadata.yaml").write_text("title: my thesis\n")
    (out / "thesis.tex").write_text("\\documentclass{article}\n")
    err = run_error(capsys, _export(files, fmt, out, "--force"))
    assert "not replacing" in err
    assert (out / "thesis.tex").read_text() == "\\documentclass{article}\n"
    assert (out / "metadata.yaml").read_text() == "title: my thesis\n"


@pytest.mark.parametrize("fmt", ["db3", "mcap"])
def test_export_force_replaces_its_own_bag_but_not_a_bag_with_extra_files(
    tmp_path, capsys, files, fmt
):
    out = tmp_path / "bag2"
    assert main(_export(files, fmt, out)) == 0
    assert main(_export(files, fmt, out, "--force")) == 0  # its own bag: replaced
    (out / "thesis.tex").write_text("keep")
    err = run_error(capsys, _export(files, fmt, out, "--force"))
    assert "thesis.tex" in err and (out / "thesis.tex").read_text() == "keep"


def test_import_force_keeps_a_folder_whose_manifest_is_not_a_dataset(tmp_path, capsys, files):
    app = tmp_path / "webapp"
    app.mkdir()
    (app / "manifest.json").write_text('{"name": "my app", "start_url": "/"}')
    (app / "index.js").write_text("console.log(1)")
    err = run_error(capsys, ["import", str(files["root"] / "test.bag"), "--out", str(app),
                             "--force"])  # fmt: skip
    assert "manifest.json" in err
    assert (app / "index.js").read_text() == "console.log(1)"
    assert json.loads((app / "manifest.json").read_text())["name"] == "my app"


def test_import_force_keeps_a_dataset_holding_the_users_notes(tmp_path, capsys, files):
    out = tmp_path / "imp"
    bag = str(files["root"] / "test.bag")
    assert main(["import", bag, "--out", str(out)]) == 0
    (out / "NOTES.txt").write_text("recorded on the old hand")
    err = run_error(capsys, ["import", bag, "--out", str(out), "--force"])
    assert "NOTES.txt" in err
    assert (out / "NOTES.txt").read_text() == "recorded on the old hand"
    (out / "NOTES.txt").unlink()
    assert main(["import", bag, "--out", str(out), "--force", "--shape", "cup"]) == 0


# --- item 2: devices, FIFOs, sockets and links are never replaced -------------------------------


def _special(tmp_path, kind):
    path = tmp_path / f"{kind}.csv"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "symlink":
        target = tmp_path / "target.csv"
        target.write_text("the user's data\n")
        path.symlink_to(target)
    elif kind == "socket":
        sock = socket.socket(socket.AF_UNIX)
        sock.bind(str(path))
        sock.close()
    return path


@pytest.mark.parametrize("kind", ["fifo", "symlink", "socket"])
def test_export_force_refuses_a_special_file(tmp_path, capsys, files, kind):
    path = _special(tmp_path, kind)
    before = os.lstat(path).st_mode
    err = run_error(capsys, _export(files, "csv", path, "--force"))
    assert "not a regular file" in err
    assert os.lstat(path).st_mode == before
    if kind == "symlink":
        assert (tmp_path / "target.csv").read_text() == "the user's data\n"


def test_force_refuses_a_device_for_every_writer(tmp_path, capsys, files):
    """A device stays a device (run as root, a rename over /dev/null replaced the node). The
    probe is a null device made in tmp_path, so a regression cannot damage the machine's."""
    import stat

    null = str(tmp_path / "null")
    try:
        os.mknod(null, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    except (PermissionError, OSError):
        pytest.skip("making a device node needs root")
    err = run_error(capsys, _export(files, "bag", null, "--force"))
    assert "character device" in err
    err = run_error(capsys, ["import", str(files["root"] / "test.bag"), "--out", null,
                             "--force"])  # fmt: skip
    assert "character device" in err
    from tactile_bullet.files import write_bytes_atomic

    with pytest.raises(UsageError, match="character device"):
        write_bytes_atomic(null, b"x", "report")
    assert stat.S_ISCHR(os.lstat(null).st_mode)


def test_grasp_out_force_refuses_a_link(tmp_path, capsys):
    link = _special(tmp_path, "symlink")
    err = run_error(capsys, ["grasp", "--shape", "cylinder", "--out", str(link), "--force"])
    assert "symbolic link" in err


# --- items 3, 4: joint values no hand can have, NaN and infinity -------------------------------


def _model_path(root, synthetic_split):
    path = root / "model.npz"
    if not path.exists():
        from tactile_bullet.experiments import workflow
        from tactile_bullet.learn.models import save_model

        save_model(path, workflow.train(synthetic_split[0], "signature", "svm"))
    return str(path)


def _spoiled(record, joint="FFJ3", value=100.0, what="angles", row=3):
    import dataclasses

    array = getattr(record, what).copy()
    array[row, record.joint_index(joint)] = value
    spoiled = dataclasses.replace(record)
    # as a broken device would record it: a simulated record with NaN is refused since issue 29
    object.__setattr__(spoiled, what, array)
    return spoiled


@pytest.mark.parametrize("fmt", ["bag", "csv", "db3"])
@pytest.mark.parametrize("value", [100.0, 1e6, 1e300])
def test_joint_values_outside_the_hands_range_are_refused_naming_joint_time_value(
    tmp_path, capsys, files, synthetic_split, fmt, value
):
    rec = _spoiled(files["test"][0], value=value)
    path = tmp_path / ("r" + {"bag": ".bag", "csv": ".csv", "db3": ""}[fmt])
    export([rec], path, fmt)
    t = rec.time[3] - rec.time[0]
    err = run_error(capsys, ["import", str(path), "--out", str(tmp_path / "o")])
    assert "rh_FFJ3" in err and f"{value:.6g}" in err and f"{t:.6g} s" in err
    assert not (tmp_path / "o").exists()
    model = _model_path(files["root"], synthetic_split)
    err = run_error(capsys, ["identify", "--model", model, "--recording", str(path)])
    assert "rh_FFJ3" in err and "range" in err


def test_calibration_is_applied_before_the_range_check(tmp_path, capsys, files):
    """A hand whose FFJ3 sensor reads 1.2 rad high is corrected, not refused."""
    rec = files["test"][0]
    high = _spoiled(rec, value=float(rec.angles[3, rec.joint_index("FFJ3")]) + 1.2)
    high.angles[:, rec.joint_index("FFJ3")] = rec.angles[:, rec.joint_index("FFJ3")] + 1.2
    path = tmp_path / "high.csv"
    export([high], path, "csv")
    cal = tmp_path / "cal.toml"
    cal.write_text("[joints]\nrh_FFJ3 = { offset = -1.2 }\n")
    assert "rh_FFJ3" in run_error(capsys, ["import", str(path), "--out", str(tmp_path / "a")])
    assert main(["import", str(path), "--out", str(tmp_path / "b"),
                 "--calibration", str(cal)]) == 0  # fmt: skip


def test_nan_and_infinite_efforts_in_a_bag_are_refused(tmp_path, capsys, files):
    for value in (np.nan, np.inf):
        path = tmp_path / f"e{value}.bag"
        export([_spoiled(files["test"][0], value=value, what="efforts")], path, "bag")
        err = run_error(capsys, ["import", str(path), "--out", str(tmp_path / "o")])
        assert "efforts hold NaN or infinity" in err


def test_identifier_refuses_garbage_values_with_the_joint_time_and_value(synthetic_split):
    from tactile_bullet import Identifier

    ident = Identifier(synthetic_split and _trained(synthetic_split))
    names = ["rh_" + n for n in JOINT_NAMES]
    pos = np.zeros(len(names))
    pos[names.index("rh_FFJ3")] = 100.0
    with pytest.raises(UsageError, match=r"rh_FFJ3 at 2\.5 s: value 100 rad is outside"):
        ident.update(2.5, names, pos)
    with pytest.raises(UsageError, match="efforts hold NaN"):
        ident.update(3.0, names, np.zeros(len(names)), np.full(len(names), np.nan))
    assert ident.samples == 0


def _trained(split):
    from tactile_bullet.experiments import workflow

    return workflow.train(split[0], "signature", "svm")


# --- item 24: the Python API speaks the CLI's language ------------------------------------------


@pytest.mark.parametrize(
    "args, words",
    [((0.0, None, [0.0]), "joint names must be a list"),
     (("abc", list(JOINT_NAMES), np.zeros(24)), "time must be a number"),
     ((0.0, list(JOINT_NAMES), ["a"] * 24), "positions must be numbers"),
     ((0.0, list(JOINT_NAMES), np.zeros((1, 24))), "array of shape (1, 24)"),
     ((0.0, list(JOINT_NAMES), None), "positions must be a list"),
     ((0.0, [1, 2], [0.0, 0.0]), "joint names must be strings")],
)  # fmt: skip
def test_identifier_update_refuses_wrong_types_with_usage_errors(synthetic_split, args, words):
    from tactile_bullet import Identifier

    ident = Identifier(_trained(synthetic_split))
    with pytest.raises(UsageError, match=None) as info:
        ident.update(*args)
    assert words in str(info.value)


# --- items 5, 8: one hand per file ---------------------------------------------------------------


def _two_hand_bag(path, record):
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC)
    header, stamp = ts.types["std_msgs/msg/Header"], ts.types["builtin_interfaces/msg/Time"]
    state = ts.types["sensor_msgs/msg/JointState"]
    with Writer(path) as writer:
        conn = writer.add_connection("/joint_states", state.__msgtype__, typestore=ts)
        for i, t in enumerate(record.time):
            for hand in ("rh_", "lh_"):
                ns = 10**9 + int(t * 1e9) + (hand == "lh_")
                msg = state(
                    header=header(seq=i, stamp=stamp(sec=ns // 10**9, nanosec=ns % 10**9),
                                  frame_id=""),
                    name=[hand + n for n in JOINT_NAMES], position=record.angles[i],
                    velocity=np.zeros(0), effort=record.efforts[i],
                )  # fmt: skip
                writer.write(conn, ns, ts.serialize_ros1(msg, state.__msgtype__))


def test_a_bag_of_two_hands_is_refused_and_prefix_picks_one(tmp_path, capsys, files):
    path = tmp_path / "two.bag"
    _two_hand_bag(path, files["test"][0])
    err = run_error(capsys, ["import", str(path), "--out", str(tmp_path / "o")])
    assert "two hands" in err and "--prefix" in err
    doc = json.loads(_ok(capsys, ["import", str(path), "--out", str(tmp_path / "o"),
                                  "--prefix", "rh_", "--json"]))  # fmt: skip
    assert doc["records"] == 1
    err = run_error(capsys, ["import", str(path), "--out", str(tmp_path / "p"),
                             "--prefix", "xh_"])  # fmt: skip
    assert "'xh_'" in err


def _ok(capsys, argv):
    assert main(argv) == 0
    return capsys.readouterr().out


def test_a_table_of_two_hands_is_refused_and_prefix_picks_one(tmp_path, capsys, files):
    rec = files["test"][0]
    path = tmp_path / "rh.csv"
    export([rec], path, "csv")
    lines = path.read_text().splitlines()
    head = lines[0].split(",")
    extra = [h.replace("rh_", "lh_") for h in head if h.startswith("rh_")]
    n = len(extra)
    rows = [",".join([*line.split(","), *line.split(",")[-n:]]) for line in lines[1:]]
    path.write_text("\n".join([",".join([*head, *extra]), *rows]) + "\n")
    assert "prefixes" in run_error(capsys, ["import", str(path), "--out", str(tmp_path / "o")])
    assert main(["import", str(path), "--out", str(tmp_path / "o"), "--prefix", "lh"]) == 0


def test_a_calibration_for_the_other_hand_is_refused(tmp_path, capsys, files):
    cal = tmp_path / "cal.toml"
    cal.write_text("[joints]\nlh_MFJ3 = { offset = 0.05 }\n")
    err = run_error(capsys, ["import", str(files["root"] / "test.bag"), "--out",
                             str(tmp_path / "o"), "--calibration", str(cal)])  # fmt: skip
    assert "'lh'" in err and "'rh'" in err
    cal.write_text("[joints]\nlh_MFJ3 = { offset = 0.05 }\nrh_FFJ3 = { offset = 0.05 }\n")
    assert "one hand per calibration" in run_error(
        capsys, ["import", str(files["root"] / "test.bag"), "--out", str(tmp_path / "o"),
                 "--calibration", str(cal)])  # fmt: skip


# --- items 6, 7, 25: tables ------------------------------------------------------------------


def _table(tmp_path, files, edit, name="t.csv"):
    path = tmp_path / name
    export([files["test"][0]], path, "csv")
    path.write_text(edit(path.read_text()))
    return path


@pytest.mark.parametrize("column", ["rh_FFJ3", "time", "grasp", "shape"])
def test_a_duplicate_csv_column_is_refused_naming_it(tmp_path, capsys, files, column):
    def dup(text):
        lines = text.splitlines()
        k = lines[0].split(",").index(column)
        return "\n".join(f"{line},{line.split(',')[k]}" for line in lines) + "\n"

    path = _table(tmp_path, files, dup)
    err = run_error(capsys, ["import", str(path), "--out", str(tmp_path / "o")])
    assert f"column {column!r} appears twice" in err


def test_a_boolean_parquet_joint_column_is_refused(tmp_path, capsys, files):
    pa = pytest.importorskip("pyarrow")
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    csv = tmp_path / "b.csv"
    export([files["test"][0]], csv, "csv")
    table = pacsv.read_csv(csv)
    k = table.column_names.index("rh_FFJ3")
    table = table.set_column(k, "rh_FFJ3", pa.array([True] * table.num_rows))
    pq.write_table(table, tmp_path / "b.parquet")
    err = run_error(capsys, ["import", str(tmp_path / "b.parquet"), "--out", str(tmp_path / "o")])
    assert "rh_FFJ3" in err and "'true'" in err and "not a number" in err


def test_a_bom_prefixed_csv_is_read(tmp_path, capsys, files):
    path = _table(tmp_path, files, lambda text: "\ufeff" + text)
    assert main(["import", str(path), "--out", str(tmp_path / "o")]) == 0


def test_underscored_numbers_and_nanosecond_times_are_refused(tmp_path, capsys, files):
    def underscore(text):
        lines = text.splitlines()
        cells = lines[2].split(",")
        cells[5] = "1_0"
        return "\n".join([*lines[:2], ",".join(cells), *lines[3:]]) + "\n"

    path = _table(tmp_path, files, underscore)
    assert "'1_0'" in run_error(capsys, ["import", str(path), "--out", str(tmp_path / "o")])

    def nanoseconds(text):
        lines = text.splitlines()
        out = [lines[0]]
        for line in lines[1:]:
            t, rest = line.split(",", 1)
            out.append(f"{1_600_000_000_000_000_000 + int(float(t) * 1e9)},{rest}")
        return "\n".join(out) + "\n"

    path = _table(tmp_path, files, nanoseconds, "ns.csv")
    assert "nanoseconds" in run_error(capsys, ["import", str(path), "--out", str(tmp_path / "o")])


def test_the_recorded_ranges_are_the_urdfs_limits():
    """hand.JOINT_LIMITS_DEG (what recordings are checked against) is the URDF's."""
    import math
    import xml.etree.ElementTree as ET

    from tactile_bullet.hand import JOINT_LIMITS_DEG, urdf_path

    root = ET.parse(urdf_path()).getroot()
    limits = {j.get("name"): j.find("limit") for j in root.iter("joint")}
    for name in JOINT_NAMES:
        lim = limits[name]
        got = (math.degrees(float(lim.get("lower"))), math.degrees(float(lim.get("upper"))))
        assert got == pytest.approx(JOINT_LIMITS_DEG[name], abs=1e-3), name


# --- item 10: a grasp that touched nothing names no shape ---------------------------------------


def test_shape_fit_names_no_shape_for_a_grasp_that_touched_nothing(synthetic_split):
    import dataclasses

    from tactile_bullet.perception.contact import nothing_to_identify
    from tactile_bullet.perception.shape_fit import shape_fit_summary

    touched = synthetic_split[1][0]
    assert shape_fit_summary(touched)["shape"]  # the same angles with contact: a shape
    for fingers in ((), ("ff",)):
        air = dataclasses.replace(touched, fingers_in_contact=fingers)
        assert nothing_to_identify(air) and shape_fit_summary(air) is None
    recorded = dataclasses.replace(touched, fingers_in_contact=(), source="recorded")
    assert shape_fit_summary(recorded)["shape"]  # no contact sensing: not judged so


# --- item 23: never advise unpickling -----------------------------------------------------------


def test_a_non_model_file_is_never_answered_with_unpickling_advice(tmp_path, capsys, files):
    toml = tmp_path / "held-out.toml"
    toml.write_text("[sweep]\nshapes = ['cone']\n")
    err = run_error(capsys, ["evaluate", "--model", str(toml), "--data", files["data"]])
    assert "not a tactile-bullet model" in err and "pickle" in err
    assert "allow_pickle" not in err and "unsafe" not in err
    from tactile_bullet.records import load_record

    with pytest.raises(UsageError) as info:
        load_record(toml)
    assert "allow_pickle" not in str(info.value)


# --- item 25: messages that say what is wrong -------------------------------------------------


@pytest.mark.parametrize("kind, words", [("fifo", "is a FIFO"), ("folder", "is a folder")])
def test_a_recording_of_the_wrong_kind_is_not_called_missing(tmp_path, capsys, kind, words):
    path = tmp_path / "rec.csv"
    os.mkfifo(path) if kind == "fifo" else path.mkdir()
    err = run_error(capsys, ["import", str(path), "--out", str(tmp_path / "o")])
    assert words in err and "does not exist" not in err


def test_a_lookalike_unicode_joint_name_is_shown_as_such(tmp_path, capsys, files):
    cyrillic = "rh_FF\u04083"  # a Cyrillic Je where the J belongs
    path = _table(tmp_path, files, lambda text: text.replace("rh_FFJ3", cyrillic))
    err = run_error(capsys, ["import", str(path), "--out", str(tmp_path / "o")])
    assert "\\u0408" in err and "not ASCII" in err


# --- item 9: recordings have no contact truth -------------------------------------------------


def test_temporal_on_recordings_reports_no_agreement_figure(tmp_path, capsys, synthetic_split):
    from tactile_bullet.experiments.temporal import run_experiment, summary_text
    from tactile_bullet.realhand.recordings import read_recording

    path = tmp_path / "rec.csv"
    export(synthetic_split[1][:3], path, "csv")
    records = [g.record for g in read_recording(path, marker="none", gap_s=0.5)]
    doc = run_experiment(records, tmp_path / "out")
    det = doc["detectors"]
    assert det["contact_truth"] is False and det["measured_non_contact"] is None
    for method in ("position", "dynamic"):
        assert det[method]["agreement"] is None and det[method]["false_non_contact"] is None
        assert 0 <= det[method]["detected_non_contact"] <= det["fingers"]
    assert doc["dtw"]["raw"]["identified"] is not None  # the file labels its grasps
    import dataclasses

    unlabelled = [dataclasses.replace(r, shape="unknown") for r in records]
    doc = run_experiment(unlabelled, tmp_path / "out", force=True)
    assert doc["dtw"]["raw"]["identified"] is None  # neither right nor wrong
    text = summary_text(doc)
    assert "no contact truth" in text and "agreement" not in text.replace("without an agree", "")
    assert "out of contact at the end" not in text and "%" not in text
    simulated = run_experiment(synthetic_split[1][:3], tmp_path / "sim")["detectors"]
    assert simulated["contact_truth"] is True and simulated["position"]["agreement"] is not None


# --- item 27: long work is never silent, also when stderr is a log -----------------------------


def test_progress_lines_reach_a_log_from_deep_loops(tmp_path, capsys, monkeypatch, synthetic_split):
    """stderr here is not a terminal (a log): train --classifier tcn reports its epochs, and
    the grasp loops of generate/demo report through console.progress."""
    from tactile_bullet import console

    monkeypatch.setattr(console, "PROGRESS_EVERY_S", 0.0)
    data = tmp_path / "train"
    write_dataset(synthetic_split[0][:30], data, {"test": True})
    argv = ["train", "--data", str(data), "--descriptor", "time-series", "--classifier", "tcn",
            "--param", "epochs=3", "--out", str(tmp_path / "m.npz")]  # fmt: skip
    assert main(argv) == 0  # (under --json a log stays quiet: docs/cli.md)
    out, err = capsys.readouterr()
    assert "tcn training epochs" not in out  # progress goes to stderr only
    assert "tcn training epochs: 1/3" in err and "tcn training epochs: 2/3" in err
    # the neural forest's updates too: a compare or the demo is seconds of them
    argv = ["train", "--data", str(data), "--classifier", "neural-forest", "--param",
            "n_updates=20", "--out", str(tmp_path / "f.npz")]  # fmt: skip
    assert main(argv) == 0
    assert "neural-forest: training updates: 10/20" in capsys.readouterr().err
    with console.reporting(True):
        assert list(console.progress(range(3), 3, "grasps", enabled=False)) == [0, 1, 2]
    assert "grasps: 3/3 (100%)" in capsys.readouterr().err
    assert list(console.progress(range(3), 3, "grasps", enabled=False)) == [0, 1, 2]
    assert capsys.readouterr().err == ""  # library use, no reporting asked: silent


def test_identifier_takes_one_hand(synthetic_split):
    from tactile_bullet import Identifier

    ident = Identifier(_trained(synthetic_split))
    ident.update(0.0, ["rh_" + n for n in JOINT_NAMES], np.zeros(len(JOINT_NAMES)))
    with pytest.raises(UsageError, match="one hand per Identifier"):
        ident.update(0.1, ["lh_" + n for n in JOINT_NAMES], np.zeros(len(JOINT_NAMES)))
    assert ident.samples == 1
