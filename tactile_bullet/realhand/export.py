"""Simulated grasps out, as a real hand would publish them: ROS bags and CSV.

Each record's time series becomes one ``sensor_msgs/JointState`` message per sample (names with
a hand prefix such as ``rh_``, positions in rad, efforts in N m, no velocities), so users can
replay simulated grasps through their own ROS tools, and ``import`` / ``identify --recording``
read them back. Grasps follow each other with ``PAUSE_S`` of silence between them, and each
is framed by two messages on ``recordings.MARKER_TOPIC`` (``std_msgs/String`` holding
``{"event": "start", "shape": ..., "index": k}`` and ``{"event": "end"}``) at its first and
last sample, which ``import`` uses to cut the grasps and to label them.

Formats: ``bag`` (ROS 1, one file), ``db3`` and ``mcap`` (ROS 2 bag folders, sqlite3 or MCAP
storage), ``csv`` (``time`` in s, the ``grasp`` number, the ``shape``, one column per joint and
one ``<joint>_effort`` per joint). ``coupled=True`` publishes ``FFJ0 = FFJ1 + FFJ2`` (and the
same for MF, RF, LF) instead of J1 and J2, as some Shadow drivers do.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..files import refuse_special
from ..hand import JOINT_NAMES, LONG_FINGERS
from ..records import GraspRecord
from .names import (
    DEFAULT_TOPIC,
    LABEL_COLUMN,
    MARKER_COLUMN,
    MARKER_TOPIC,
    TIME_COLUMN,
    check_topic,
)

FORMATS: tuple[str, ...] = ("bag", "db3", "mcap", "csv")
PAUSE_S = 1.0
"""Silence (s) between two exported grasps: over ``recordings.GAP_S``, so the grasps are also
found without the markers."""
START_S = 1_600_000_000
"""Stamp (s since the epoch) of the first exported sample: any fixed, positive time works."""


def published_names(coupled: bool = False) -> tuple[str, ...]:
    """Canonical joint names in publishing order; J0 replaces J1 and J2 when ``coupled``."""
    names = []
    for name in JOINT_NAMES:
        finger, k = name[:2].lower(), name[3:]
        if coupled and finger in LONG_FINGERS and k in ("2", "1"):
            if k == "2":
                names.append(f"{name[:2]}J0")
            continue
        names.append(name)
    return tuple(names)


def published_values(record: GraspRecord, coupled: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(positions, efforts), each (T, k) in :func:`published_names` order; J0's effort is the
    distal joint's (the one the tendon stage watches)."""
    cols = [record.joint_index(n) for n in JOINT_NAMES]
    angles, efforts = record.angles[:, cols], record.efforts[:, cols]
    if not coupled:
        return np.ascontiguousarray(angles), np.ascontiguousarray(efforts)
    pos_cols, eff_cols = [], []
    index = {n: i for i, n in enumerate(JOINT_NAMES)}
    for name in published_names(True):
        if name.endswith("J0"):
            pos_cols.append((index[f"{name[:2]}J2"], index[f"{name[:2]}J1"]))
            eff_cols.append(index[f"{name[:2]}J1"])
        else:
            pos_cols.append((index[name],))
            eff_cols.append(index[name])
    pos = np.column_stack([angles[:, list(c)].sum(axis=1) for c in pos_cols])
    return np.ascontiguousarray(pos), np.ascontiguousarray(efforts[:, eff_cols])


def _timeline(records: Sequence[GraspRecord]) -> list[np.ndarray]:
    """Each record's sample stamps (ns since the epoch), grasps ``PAUSE_S`` apart."""
    out, base = [], START_S * 1_000_000_000
    for rec in records:
        if rec.time.size == 0:
            raise UsageError("a record has no time series to export (load it with its series)")
        stamps = base + np.round((rec.time - rec.time[0]) * 1e9).astype(np.int64)
        out.append(stamps)
        base = int(stamps[-1]) + int(PAUSE_S * 1e9)
    return out


def check_out(out: Path, fmt: str, force: bool) -> None:
    """Refuse, before any work, an unknown format, an unwritable folder, or an existing output
    without ``force`` (and with it, anything but the kind of output about to be written)."""
    if fmt not in FORMATS:
        raise UsageError(f"unknown format {fmt!r} (formats: {', '.join(FORMATS)})")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"--out folder {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise UsageError(f"--out folder {parent} is not writable")
    refuse_special(out, "--out")
    if not out.exists():
        return
    if not force:
        raise UsageError(f"--out {out} exists; use --force to replace it")
    if fmt in ("db3", "mcap"):
        foreign = foreign_in_ros2_bag(out)
        if foreign:
            raise UsageError(
                f"--out {out} holds {foreign}, which is not part of a ROS 2 bag: "
                "not replacing it (choose another folder)"
            )
    elif out.is_dir():
        raise UsageError(f"--out {out} is a folder")


_BAG_META = "metadata.yaml"
_BAG_STORAGE = (".db3", ".mcap", ".db3-wal", ".db3-shm", ".db3-journal")


def foreign_in_ros2_bag(folder: Path) -> str | None:
    """The first entry of ``folder`` that a ROS 2 bag does not hold, or None for a bag that
    ``--force`` may replace whole: a ``metadata.yaml`` of bag information and the storage files
    it lists, nothing else (a user's ``metadata.yaml`` beside a ``thesis.tex`` is not a bag)."""
    if not folder.is_dir():
        return f"{folder.name} (a file, not a bag folder)"
    meta = folder / _BAG_META
    try:
        text = meta.read_text(encoding="utf-8", errors="replace") if meta.is_file() else ""
    except OSError:
        text = ""
    if not text.lstrip().startswith("rosbag2_bagfile_information:"):
        return f"{_BAG_META} of no ROS 2 bag" if meta.exists() else f"no {_BAG_META}"
    for entry in sorted(folder.iterdir()):
        if entry.name == _BAG_META:
            continue
        if entry.is_symlink() or not entry.is_file() or not entry.name.endswith(_BAG_STORAGE):
            return entry.name
        stem = entry.name.split(".db3")[0] if ".db3" in entry.name else entry.name
        if stem not in text:
            return entry.name
    return None


def export(
    records: Sequence[GraspRecord],
    out: str | Path,
    fmt: str,
    *,
    topic: str = DEFAULT_TOPIC,
    prefix: str = "rh_",
    coupled: bool = False,
    force: bool = False,
) -> dict:
    """Write ``records`` to ``out`` in format ``fmt`` (see the module docstring); the output
    appears whole or not at all. Returns ``{"out", "format", "grasps", "messages"}``."""
    out = Path(out)
    check_out(out, fmt, force)
    records = list(records)
    if not records:
        raise UsageError("no grasps to export")
    if prefix and not re.fullmatch(r"[A-Za-z][A-Za-z0-9]*_?", prefix):
        raise UsageError(f"--prefix must be letters and digits like 'rh_', got {prefix!r}")
    if prefix and not prefix.endswith("_"):
        prefix += "_"
    if fmt != "csv":
        check_topic(topic)
    names = tuple(prefix + n for n in published_names(coupled))
    stamps = _timeline(records)
    parent = out.parent if str(out.parent) else Path(".")
    work = parent / f".{out.name}.{os.getpid()}.tmp"
    shutil.rmtree(work, ignore_errors=True)
    tmp = work / out.name  # the final name: a ROS 2 bag names its storage file after it
    try:
        work.mkdir()
        if fmt == "csv":
            count = _write_csv(tmp, records, stamps, names, coupled)
        elif fmt == "bag":
            count = _write_bag1(tmp, records, stamps, names, coupled, topic)
        else:
            count = _write_bag2(tmp, records, stamps, names, coupled, topic, fmt)
        if out.exists():
            old = work / f"{out.name}.old"
            os.replace(out, old)
        os.replace(tmp, out)
    except OSError as exc:
        raise UsageError(f"cannot write {out}: {exc.strerror or exc}") from None
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return {"out": str(out), "format": fmt, "grasps": len(records), "messages": count}


def _write_csv(path, records, stamps, names, coupled) -> int:
    header = [TIME_COLUMN, MARKER_COLUMN, LABEL_COLUMN, *names, *(f"{n}_effort" for n in names)]
    rows = 0
    with open(path, "w", newline="") as fh:
        fh.write(",".join(header) + "\n")
        origin = stamps[0][0]
        for k, (rec, ts) in enumerate(zip(records, stamps, strict=True)):
            pos, eff = published_values(rec, coupled)
            t = (ts - origin) / 1e9
            label = rec.shape.replace(",", " ")
            for i in range(len(t)):
                values = ",".join(repr(float(v)) for v in (*pos[i], *eff[i]))
                fh.write(f"{float(t[i])!r},{k + 1},{label},{values}\n")
            rows += len(t)
    return rows


def _marker(k: int, rec: GraspRecord, event: str) -> str:
    doc = {"event": event, "index": k}
    if event == "start":
        doc["shape"] = rec.shape
    return json.dumps(doc)


def _messages(records, stamps, names, coupled):
    """(stamp_ns, kind, payload) in time order: kind 'js' (positions, efforts) or 'marker'."""
    for k, (rec, ts) in enumerate(zip(records, stamps, strict=True)):
        pos, eff = published_values(rec, coupled)
        yield int(ts[0]), "marker", _marker(k, rec, "start")
        for i in range(len(ts)):
            yield int(ts[i]), "js", (pos[i], eff[i])
        yield int(ts[-1]), "marker", _marker(k, rec, "end")


def _rosbags():
    try:
        import rosbags.rosbag1  # noqa: F401
        import rosbags.rosbag2  # noqa: F401
    except ImportError:
        raise UsageError(
            "writing ROS bags needs the rosbags library: pip install 'tactile-bullet[ros]'"
        ) from None


def _write_bag1(path, records, stamps, names, coupled, topic) -> int:
    _rosbags()
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC)
    with Writer(path) as writer:
        return _write_messages(writer, ts, ts.serialize_ros1, True, records, stamps, names,
                               coupled, topic)  # fmt: skip


def _write_bag2(path, records, stamps, names, coupled, topic, fmt) -> int:
    _rosbags()
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    storage = StoragePlugin.MCAP if fmt == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=storage) as writer:
        return _write_messages(writer, ts, ts.serialize_cdr, False, records, stamps, names,
                               coupled, topic)  # fmt: skip


def _write_messages(writer, ts, serialize, with_seq, records, stamps, names, coupled, topic):
    """JointState messages and grasp markers into an open ROS 1 or ROS 2 bag writer (they
    differ in the serializer and in ROS 1's header sequence number); the JointState count."""
    Header, Time = ts.types["std_msgs/msg/Header"], ts.types["builtin_interfaces/msg/Time"]
    JointState, String = ts.types["sensor_msgs/msg/JointState"], ts.types["std_msgs/msg/String"]
    js = writer.add_connection(topic, JointState.__msgtype__, typestore=ts)
    mk = writer.add_connection(MARKER_TOPIC, String.__msgtype__, typestore=ts)
    empty = np.zeros(0)
    count = 0
    for stamp, kind, payload in _messages(records, stamps, names, coupled):
        if kind == "marker":
            writer.write(mk, stamp, serialize(String(data=payload), String.__msgtype__))
            continue
        seq = {"seq": count} if with_seq else {}
        head = Header(**seq, stamp=Time(sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id="")
        msg = JointState(header=head, name=list(names), position=payload[0],
                         velocity=empty, effort=payload[1])  # fmt: skip
        writer.write(js, stamp, serialize(msg, JointState.__msgtype__))
        count += 1
    return count
