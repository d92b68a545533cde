"""ROS 1 ``.bag`` files and ROS 2 bag folders (``.db3``, ``.mcap``) -> joint samples.

Read with the pure-Python ``rosbags`` library (the ``ros`` extra; no ROS install):
``sensor_msgs/JointState`` on one topic, and optional grasp markers on another.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..files import input_path
from ..hand import JOINT_NAMES
from .calibration import Calibration
from .joints import JointMap, JointSamples, _check_finite, _check_time
from .names import (
    DEFAULT_TOPIC,
    JOINT_STATE,
    MARKER_TOPIC,
    NO_MARKER,
    hand_prefix,
    is_hand_message,
)  # fmt: skip

# --- bags ---------------------------------------------------------------------------------------


def _rosbags():
    try:
        import rosbags.highlevel  # noqa: F401
        import rosbags.typesys  # noqa: F401
    except ImportError:
        raise UsageError(
            "reading ROS bags needs the rosbags library: pip install 'tactile-bullet[ros]'"
        ) from None
    return rosbags


def _bag_root(path: Path) -> Path:
    """A ROS 2 bag is its folder: a .db3/.mcap file inside one is read through the folder."""
    if path.is_dir():
        return path
    if path.suffix in (".db3", ".mcap") and (path.parent / "metadata.yaml").is_file():
        return path.parent
    if path.suffix in (".db3", ".mcap"):
        raise UsageError(f"{path}: a ROS 2 bag file needs its folder's metadata.yaml beside it")
    return path


_MAGIC = {".bag": b"#ROSBAG V2.0\n", ".db3": b"SQLite format 3\0", ".mcap": b"\x89MCAP0\r\n"}
"""How each storage file begins: checked before the bag library reads anything (given a
device or a sparse file it reads the whole file into memory before it looks)."""


def _check_storage(root: Path) -> None:
    """Every storage file of a bag is a regular file within the recording limit and starts as
    its format does."""
    files = [root] if root.is_file() else [
        f for f in root.iterdir() if f.suffix.lower() in _MAGIC
    ]  # fmt: skip
    for file in files:
        input_path(file, "recording")
        magic = _MAGIC.get(file.suffix.lower())
        if magic is None:
            continue
        try:
            with open(file, "rb") as fh:
                head = fh.read(len(magic))
        except OSError as exc:
            raise UsageError(f"cannot read recording {file}: {exc.strerror or exc}") from None
        if head != magic:
            raise UsageError(f"{file} is not a readable bag (it does not start as a "
                             f"{file.suffix.lower()} file does)")  # fmt: skip


def read_bag(
    path: str | Path,
    topic: str = DEFAULT_TOPIC,
    marker: str | None = None,
    calibration: Calibration | None = None,
    prefix: str | None = None,
) -> JointSamples:
    """Joint states on ``topic`` (and grasp markers on ``marker``) of a ROS 1 or ROS 2 bag;
    one hand's: ``prefix`` ("rh") picks it where the bag holds two, which is refused
    otherwise (two hands' samples interleaved make nonsense grasps)."""
    _rosbags()
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    path = input_path(path, "recording", folder=True)
    root = _bag_root(path)
    _check_storage(root)
    where = str(path)
    try:
        with AnyReader([root], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            topics = {c.topic: c.msgtype for c in reader.connections}
            if topic not in topics:
                states = sorted(t for t, m in topics.items() if m == JOINT_STATE)
                hint = (
                    f"JointState topics: {', '.join(states)}" if states else "no JointState topic"
                )
                raise UsageError(f"{where} has no topic {topic} ({hint}); choose one with --topic")
            if topics[topic] != JOINT_STATE:
                raise UsageError(
                    f"{where}: topic {topic} carries {topics[topic]}, not {JOINT_STATE}"
                )
            marker_topic = None if marker == NO_MARKER else marker
            if marker is None and MARKER_TOPIC in topics:
                marker_topic = MARKER_TOPIC
            if marker_topic is not None and marker_topic not in topics:
                raise UsageError(f"{where} has no marker topic {marker_topic}")
            wanted = [c for c in reader.connections if c.topic in (topic, marker_topic)]
            maps: dict[tuple[str, ...], JointMap] = {}
            stamps, receive, pos_rows, eff_rows, events, keys = [], [], [], [], [], []
            others: set[tuple[str, ...]] = set()
            has_eff = True
            current = None
            for conn, t_recv, raw in reader.messages(connections=wanted):
                msg = reader.deserialize(raw, conn.msgtype)
                if conn.topic != topic:
                    state = conn.msgtype == "std_msgs/msg/Bool"
                    events.append((t_recv, _marker_event(msg, conn.msgtype, where), state))
                    continue
                names = tuple(msg.name)
                if current is None or names != current.names:
                    if names in others or not is_hand_message(names):
                        others.add(names)  # another robot on the same topic (an arm)
                        continue
                    current = maps.get(names)
                    if current is None:
                        hand = hand_prefix(names)
                        if prefix is not None and hand != prefix:
                            others.add(names)  # the other hand, not chosen
                            continue
                        current = maps[names] = JointMap(names, calibration, where)
                        hands = sorted({m.prefix.lower() for m in maps.values()})
                        if len(hands) > 1:
                            shown = ", ".join(repr(h + "_" if h else "(none)") for h in hands)
                            raise UsageError(
                                f"{where} holds joint states of two hands ({shown}): "
                                f"choose one with --prefix {hands[-1] or 'none'}_"
                            )
                position, effort = msg.position, msg.effort
                if len(position) != len(names):
                    raise UsageError(
                        f"{where}: a message has {len(names)} names but {len(position)} positions"
                    )
                if len(effort) != len(names):
                    has_eff = False
                pos_rows.append(position)
                eff_rows.append(effort)
                keys.append(current)
                stamp = msg.header.stamp
                stamps.append(int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec))
                receive.append(int(t_recv))
    except UsageError:
        raise
    except Exception as exc:  # noqa: BLE001 - a damaged bag is the user's input
        text = str(exc).strip().splitlines()
        raise UsageError(
            f"{where} is not a readable bag ({text[0] if text else type(exc).__name__})"
        ) from None
    if not pos_rows:
        what = "no Shadow hand joints" if others else "no messages"
        if prefix is not None and others:
            what = f"no joint states of hand prefix {prefix + '_' if prefix else '(none)'!r}"
        raise UsageError(f"{where}: topic {topic} holds {what}")
    stamp_ns = np.array(stamps, np.int64)
    recv_ns = np.array(receive, np.int64)
    if np.all(stamp_ns == 0):
        stamp_ns = recv_ns
    time = (stamp_ns - stamp_ns[0]) / 1e9
    _check_time(time, where)
    angles = np.zeros((len(pos_rows), len(JOINT_NAMES)))
    efforts = np.zeros_like(angles)
    for jmap in maps.values():  # one batch per distinct name list (usually one)
        rows = [k for k, m in enumerate(keys) if m is jmap] if len(maps) > 1 else slice(None)
        chosen = pos_rows if len(maps) == 1 else [pos_rows[k] for k in rows]
        angles[rows] = jmap.positions(np.array(chosen, float), time[rows])
        if has_eff:
            chosen = eff_rows if len(maps) == 1 else [eff_rows[k] for k in rows]
            efforts[rows] = jmap.efforts(np.array(chosen, float))
    _check_finite(angles, where, "joint positions")
    _check_finite(efforts, where, "efforts")
    origin = int(recv_ns[0])
    receive_s = (recv_ns - origin) / 1e9
    windows, objects = None, []
    if marker_topic is not None:
        windows, marks = _windows(events, origin, where)
        objects = _row_objects(receive_s, windows, marks)
    any_map = next(iter(maps.values()))
    return JointSamples(
        source=where,
        time=time,
        receive=receive_s,
        angles=angles,
        efforts=efforts,
        has_efforts=has_eff,
        windows=windows,
        objects=objects,
        coupled=any(m.coupled for m in maps.values()),
        prefix=any_map.prefix,
    )


def _marker_event(msg, msgtype: str, where: str) -> tuple[str, str | None, str | None]:
    """('start'|'end', shape label, object mark) from one marker message. A JSON marker may
    name the object the grasp is made on (``"object"``): grasps of one object are fused."""
    if msgtype == "std_msgs/msg/Bool":
        return ("start" if msg.data else "end", None, None)
    if msgtype != "std_msgs/msg/String":
        raise UsageError(f"{where}: marker topic carries {msgtype}; use std_msgs String or Bool")
    text = str(msg.data).strip()
    label = obj = None
    if text.startswith("{"):
        try:
            doc = json.loads(text)
            text, label, obj = str(doc["event"]), doc.get("shape"), doc.get("object")
        except (ValueError, KeyError, TypeError, AttributeError):
            raise UsageError(f"{where}: unreadable marker message {text[:40]!r}") from None
    event = text.lower()
    if event not in ("start", "end"):
        raise UsageError(f"{where}: marker message {text[:40]!r} is neither 'start' nor 'end'")
    return event, (str(label) if label is not None else None), (
        str(obj) if obj not in (None, "") else None
    )


def _windows(
    events, origin_ns: int, where: str
) -> tuple[list[tuple[float, float, str | None]], list[str | None]]:
    """Pair marker events (receive time, (event, label, object), whether a Bool state) into
    (start, end, label) windows (s from ``origin_ns``), with each window's object mark; a
    UsageError where a grasp's start and end name two objects or two shapes (its marks
    disagree), or where a 'start' comes while a grasp is still open (its 'end' is missing: the
    window would take in the open hand's idle time up to the next grasp). A last grasp left
    open runs to the end of the recording. A Bool state repeated unchanged, or false before
    any grasp, is no event."""
    windows, objects = [], []
    open_at, label, obj, last_state = None, None, None, None
    for t_ns, (event, lab, ob), state in sorted(events, key=lambda e: e[0]):
        t = (int(t_ns) - origin_ns) / 1e9
        if state:  # a Bool marker publishes the state, true while grasping
            if event == last_state or (event == "end" and open_at is None):
                last_state = event
                continue  # unchanged, or open before any grasp: no event
            last_state = event
        if event == "start":
            if open_at is not None:
                raise UsageError(f"{where}: grasp marker 'start' at {t:.3f} s while the grasp "
                                 f"started at {open_at:.3f} s has no 'end'")  # fmt: skip
            open_at, label, obj = t, lab, ob
        elif open_at is None:
            raise UsageError(f"{where}: grasp marker 'end' at {t:.3f} s without a 'start'")
        else:
            for what, first, last in (("object", obj, ob), ("shape", label, lab)):
                if first is not None and last is not None and first != last:
                    raise UsageError(
                        f"{where}: the grasp marked from {open_at:.3f} s to {t:.3f} s starts "
                        f"on {what} {first!r} and ends on {last!r}: its {what} marks disagree"
                    )
            windows.append((open_at, t, label or lab))
            objects.append(obj or ob)
            open_at = None
    if open_at is not None:
        windows.append((open_at, math.inf, label))
        objects.append(obj)
    return windows, objects


def _row_objects(
    receive_s: np.ndarray, windows: list[tuple[float, float, str | None]], marks: list
) -> list[str | None]:
    """Per sample, the object mark of the window it falls in ([] where no window names one):
    the table reader's ``object`` column, so both kinds of recording fuse alike."""
    if not any(marks):
        return []
    rows: list[str | None] = [None] * len(receive_s)
    for (start, end, _), mark in zip(windows, marks, strict=True):
        if mark is None:
            continue
        inside = np.flatnonzero((receive_s >= start) & (receive_s <= end))
        for i in inside:
            rows[i] = mark
    return rows
