"""Recordings whose marks contradict themselves are refused, one line, exit 2, before any
answer: a grasp whose rows or markers carry two shape labels, one object marked on grasps of
two shapes, a grasp marker stream missing its 'end'. A Bool marker publishes a state."""

from __future__ import annotations

import csv
import json

import pytest

from tactile_bullet.errors import UsageError
from tactile_bullet.realhand.bags import _windows
from tests.cli_helpers import run_error
from tests.test_exploration import _csv_with_objects


def _relabel(path, label_of_row):
    """Rewrite the ``shape`` column of an exported CSV: ``label_of_row(grasp, row in grasp)``."""
    rows = list(csv.reader(path.open()))
    head, body = rows[0], rows[1:]
    g, s = head.index("grasp"), head.index("shape")
    seen: dict[int, int] = {}
    for row in body:
        k = int(row[g])
        seen[k] = seen.get(k, -1) + 1
        row[s] = label_of_row(k, seen[k])
    with path.open("w", newline="") as fh:
        csv.writer(fh).writerows([head, *body])
    return path


def test_a_grasp_whose_rows_carry_two_shape_labels_is_refused(synthetic_split, tmp_path, capsys):
    _, test = synthetic_split
    path = _csv_with_objects(test[:2], tmp_path / "session.csv", lambda k, row: "")
    _relabel(path, lambda k, row: "cone" if k == 2 or row < 3 else "sphere")
    for command in (["identify", "--recording", str(path)],
                    ["import", str(path), "--out", str(tmp_path / "d")]):  # fmt: skip
        err = run_error(capsys, command)
        assert "spans rows labelled cone, sphere" in err and "shape column disagrees" in err
    assert not (tmp_path / "d").exists()


def test_shape_given_on_the_command_line_overrides_the_rows_labels(synthetic_split, tmp_path,
                                                                   capsys):  # fmt: skip
    from tactile_bullet.cli import main

    _, test = synthetic_split
    path = _csv_with_objects(test[:2], tmp_path / "session.csv", lambda k, row: "")
    _relabel(path, lambda k, row: "cone" if row < 3 else "sphere")
    assert main(["import", str(path), "--shape", "torus", "--out", str(tmp_path / "d")]) == 0


def _remark(path, mark_of_row):
    """Rewrite the ``grasp`` marker column: ``mark_of_row(grasp, row in grasp)``."""
    rows = list(csv.reader(path.open()))
    head, body = rows[0], rows[1:]
    g = head.index("grasp")
    seen: dict[int, int] = {}
    for row in body:
        k = int(row[g])
        seen[k] = seen.get(k, -1) + 1
        row[g] = str(mark_of_row(k, seen[k]))
    with path.open("w", newline="") as fh:
        csv.writer(fh).writerows([head, *body])
    return path


def test_a_grasp_mark_that_returns_after_another_grasp_is_refused(synthetic_split, tmp_path,
                                                                  capsys):  # fmt: skip
    from tactile_bullet.cli import main

    _, test = synthetic_split
    path = _csv_with_objects(test[:3], tmp_path / "session.csv", lambda k, row: "")
    _remark(path, lambda k, row: 1 if k == 3 else k)  # 1, 2, 1: grasp 1 cannot resume
    for command in (["identify", "--recording", str(path)],
                    ["import", str(path), "--out", str(tmp_path / "d")]):  # fmt: skip
        err = run_error(capsys, command)
        assert "the marker's grasp 1 returns at data row" in err and "after grasp 2 began" in err
    assert not (tmp_path / "d").exists()
    # a mark that comes back after rows of 0 is a state (grasping or not): three grasps
    path = _csv_with_objects(test[:3], tmp_path / "flags.csv", lambda k, row: "")
    _remark(path, lambda k, row: 0 if row == 0 and k > 1 else 1)
    assert main(["import", str(path), "--out", str(tmp_path / "d"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["records"] == 3


def test_one_object_marked_on_grasps_of_two_shapes_is_refused(synthetic_split, tmp_path, capsys):
    _, test = synthetic_split
    records = [next(r for r in test if r.shape == s) for s in sorted({r.shape for r in test})[:2]]
    path = _csv_with_objects(records, tmp_path / "session.csv", lambda k, row: "mug")
    err = run_error(capsys, ["identify", "--recording", str(path)])
    first, second = (r.shape for r in records)
    want = f"grasps marked as object 'mug' are labelled {first} (grasp 1), {second} (grasp 2)"
    assert want in err


def test_a_bag_grasp_whose_markers_name_two_shapes_is_refused(synthetic_split, tmp_path,
                                                             capsys, monkeypatch):  # fmt: skip
    pytest.importorskip("rosbags")
    from tactile_bullet.realhand import export as export_module

    _, test = synthetic_split

    def marker(k, rec, event):
        return json.dumps({"event": event, "shape": "cone" if event == "start" else "sphere"})

    monkeypatch.setattr(export_module, "_marker", marker)
    export_module.export(test[:2], tmp_path / "session", "db3")
    err = run_error(capsys, ["identify", "--recording", str(tmp_path / "session")])
    assert "starts on shape 'cone' and ends on 'sphere'" in err


def test_a_bag_whose_grasp_markers_miss_their_end_is_refused(synthetic_split, tmp_path,
                                                            capsys, monkeypatch):  # fmt: skip
    """Every 'end' written as a 'start': each grasp would run on to the next, through the
    open hand's idle time."""
    pytest.importorskip("rosbags")
    from tactile_bullet.realhand import export as export_module

    monkeypatch.setattr(export_module, "_marker", lambda k, rec, event: "start")
    export_module.export(synthetic_split[1][:3], tmp_path / "session", "db3")
    err = run_error(capsys, ["identify", "--recording", str(tmp_path / "session")])
    assert "grasp marker 'start' at" in err and "has no 'end'" in err


def _events(*items):
    """(receive ns, (event, label, object), Bool state) from (seconds, event, state)."""
    return [(int(t * 1e9), (event, None, None), state) for t, event, state in items]


def test_a_bool_marker_is_a_state_republished_at_will():
    """false before any grasp, true repeated while grasping, false repeated after: one window
    per rise of the state."""
    events = _events((0.0, "end", True), (0.5, "start", True), (0.6, "start", True),
                     (1.0, "end", True), (1.2, "end", True), (2.0, "start", True),
                     (3.0, "end", True))  # fmt: skip
    windows, marks = _windows(events, 0, "b.bag")
    assert [(a, b) for a, b, _ in windows] == [(0.5, 1.0), (2.0, 3.0)] and marks == [None, None]


def test_string_markers_keep_their_order_strict():
    with pytest.raises(UsageError, match="has no 'end'"):
        _windows(_events((0.5, "start", False), (0.6, "start", False)), 0, "b.bag")
    with pytest.raises(UsageError, match="without a 'start'"):
        _windows(_events((0.5, "end", False)), 0, "b.bag")
    windows, _ = _windows(_events((0.5, "start", False)), 0, "b.bag")  # cut before its end
    assert windows == [(0.5, float("inf"), None)]
