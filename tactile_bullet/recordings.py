"""Real-hand recordings in: joint states from ROS bags, CSV and Parquet as GraspRecords.

The thesis trains on simulated grasps and identifies on a real Shadow hand. A recording is a
stream of joint-state samples (time, joint names, positions, optionally efforts); this module
turns it into the same :class:`GraspRecord` a simulation gives (``source="recorded"``, the time
series kept, no contacts, pose and sizes unknown, ``shape`` the user's label or "unknown"), so
every descriptor, classifier and command works on it unchanged.

Sources:

- ROS 1 ``.bag`` files and ROS 2 bag folders (sqlite3 ``.db3`` or ``.mcap`` storage), read with
  the pure-Python ``rosbags`` library (the ``ros`` extra; no ROS install): ``sensor_msgs/
  JointState`` messages on one topic (default ``/joint_states``). A sample's time is the
  message's header stamp (the bag's receive time where the stamp is zero).
- CSV (standard library) and Parquet (``pyarrow``, the ``parquet`` extra) tables: a ``time``
  column in seconds, one column per joint (radians), optional ``<joint>_effort`` columns (N m),
  ``<joint>_velocity`` columns (ignored), an optional ``shape`` column (the grasp's label) and
  an optional marker column (default ``grasp``).

Joint names are Shadow's, as a real hand publishes them: ``FFJ3`` or with a hand prefix
``rh_FFJ3`` / ``lh_FFJ3`` (one prefix per recording). Hands whose driver publishes the coupled
``FFJ0`` (= J1 + J2, the tendon's travel) instead of J1 and J2 are split the way the grasp
controller moves the tendon (grasp.py): J0's travel goes to J2 first, then to J1 once J2 is at
its limit, so J2 = min(J0, pi/2) and J1 = J0 - J2. Its limit: where the middle phalanx stopped
on the object before its limit (J2 blocked by contact), the real J2 is smaller and J1 larger
than this split says. The FCI's proximal and whole-finger rows (J3 and J3 + J0, the two
signature lines) are exact either way; only the middle row is an estimate. Where a hand
publishes J1, J2 and J0, J1 and J2 are used. The wrist may be absent (the simulated wrist is
welded at 0); every other joint must be there: a missing or unknown joint is an error naming it.

Grasps in one recording are cut:

1. by a marker the user names: a topic (``std_msgs/String`` holding ``start`` / ``end`` or a
   JSON object ``{"event": "start"|"end", "shape": label}``, or ``std_msgs/Bool``, true while
   grasping) or a table column (equal non-zero values mark the rows of one grasp). Marker times
   are bag receive times, so joint states are matched to them by their receive times too;
2. otherwise by silence between closures (:class:`GraspSegmenter`): a gap over ``gap_s``
   without messages ends a grasp; a grasp starts where the hand's closure (the mean over the
   four long fingers of J3 + J2 + J1) rises ``START_RISE`` above its lowest value, and ends
   where the hand opens (closure ``RELEASE_DROP`` below its peak: the grasp keeps the samples
   up to the last one within ``HOLD_TOL`` of the peak) or where the recording stops.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .calibration import Calibration
from .errors import UsageError
from .hand import JOINT_NAMES, LONG_FINGERS
from .records import ControllerSettings, GraspRecord, Pose

DEFAULT_TOPIC = "/joint_states"
MARKER_TOPIC = "/tactile_bullet/grasp"
"""The marker topic ``export`` writes; used on import when present and no other is named."""
MARKER_COLUMN = "grasp"
"""The marker column ``export`` writes; used on import when present."""
TIME_COLUMN = "time"
LABEL_COLUMN = "shape"
NO_MARKER = "none"
"""``--marker none``: ignore the file's markers, cut by silence between closures."""
UNKNOWN_SHAPE = "unknown"
"""Label of a recorded grasp whose object the user did not name."""
JOINT_STATE = "sensor_msgs/msg/JointState"

COUPLED_FINGERS = LONG_FINGERS
J2_MAX = math.pi / 2
"""Travel J2 takes from J0 before the rest goes to J1 (the joint's limit)."""
OPTIONAL_JOINTS = frozenset({"WRJ1", "WRJ2"})
"""Joints a recording may leave out (recorded as 0, as the simulated wrist is welded)."""

GAP_S = 0.5
"""Silence (s) without messages that ends a grasp."""
START_RISE = 0.1
"""Closure rise (rad, mean J3 + J2 + J1 over the long fingers) that starts a grasp."""
RELEASE_DROP = 0.3
"""Closure fall (rad) below the peak that means the hand opened: the grasp is over."""
HOLD_TOL = 0.05
"""Samples within this closure (rad) of the peak still belong to the held grasp."""
SETTLE_S = 0.15
"""Time (s) the closure must stay within ``STILL_TOL`` for a grasp to count as settled
(streaming: ``grasp_over``)."""
STILL_TOL = 0.01

_NAME = re.compile(
    r"^(?:(?P<prefix>[A-Za-z][A-Za-z0-9]*)_)?(?P<joint>(?:FF|MF|RF|LF|TH|WR)J\d)$", re.I
)
_KNOWN = frozenset(JOINT_NAMES) | {f"{f.upper()}J0" for f in COUPLED_FINGERS}
_COLUMN = {name: i for i, name in enumerate(JOINT_NAMES)}
_CLOSURE = np.array([_COLUMN[f"{f.upper()}J{k}"] for f in LONG_FINGERS for k in (3, 2, 1)])


# --- joint names ------------------------------------------------------------------------------


def split_name(name: str) -> tuple[str, str] | None:
    """(prefix, canonical joint) of a published name (``rh_FFJ3`` -> ("rh", "FFJ3")), or None
    for a name that is no Shadow joint."""
    match = _NAME.match(str(name).strip())
    if match is None:
        return None
    joint = match["joint"].upper()
    return (match["prefix"] or "", joint) if joint in _KNOWN else None


def is_hand_message(names: Sequence[str]) -> bool:
    """Whether a joint-state message is the hand's: it names at least one Shadow joint.
    Messages of other robots on the same topic (an arm's, on a shared /joint_states) are
    skipped; a hand message with an unknown name is an error."""
    return any(split_name(n) is not None for n in names)


def canonical_joint(name: str) -> str | None:
    """``rh_FFJ3`` -> ``FFJ3``; None for a name that is no Shadow joint."""
    parts = split_name(name)
    return None if parts is None else parts[1]


class JointMap:
    """How one list of published joint names maps onto the record's columns (JOINT_NAMES).

    Built once per distinct name list (a driver publishes the same list every message), then
    applied to each message's (or a whole table's) positions and efforts with a few numpy
    indexing operations. ``calibration`` corrects the sensors before J0 is split.
    """

    def __init__(
        self, names: Sequence[str], calibration: Calibration | None = None, where: str = ""
    ) -> None:
        self.names = tuple(str(n) for n in names)
        where = f"{where}: " if where else ""
        parts = [split_name(n) for n in self.names]
        unknown = [n for n, p in zip(self.names, parts, strict=True) if p is None]
        if unknown:
            raise UsageError(f"{where}unknown joint names: {', '.join(unknown)}")
        prefixes = sorted({p[0] for p in parts if p is not None})
        if len(prefixes) > 1:
            shown = ", ".join(repr(p or "(none)") for p in prefixes)
            raise UsageError(f"{where}joint names mix hand prefixes {shown}: one hand per file")
        canon = [p[1] for p in parts if p is not None]
        seen: set[str] = set()
        dup = [c for c in canon if c in seen or seen.add(c)]
        if dup:
            raise UsageError(f"{where}joint {dup[0]} appears twice")
        self.prefix = prefixes[0] if prefixes else ""
        self.canonical = tuple(canon)
        index = {c: i for i, c in enumerate(canon)}
        direct_src, direct_dst, j0_src, j2_dst, j1_dst = [], [], [], [], []
        missing = []
        for name in JOINT_NAMES:
            if name in index:
                direct_src.append(index[name])
                direct_dst.append(_COLUMN[name])
        for f in COUPLED_FINGERS:
            up = f.upper()
            j0 = f"{up}J0"
            if f"{up}J1" in index and f"{up}J2" in index:
                continue
            if j0 in index and f"{up}J1" not in index and f"{up}J2" not in index:
                j0_src.append(index[j0])
                j2_dst.append(_COLUMN[f"{up}J2"])
                j1_dst.append(_COLUMN[f"{up}J1"])
        covered = {JOINT_NAMES[c] for c in direct_dst + j2_dst + j1_dst}
        missing = [n for n in JOINT_NAMES if n not in covered and n not in OPTIONAL_JOINTS]
        if missing:
            shown = ", ".join(self.prefix + "_" + m if self.prefix else m for m in missing)
            raise UsageError(f"{where}missing joints: {shown}")
        self.coupled = bool(j0_src)
        self._src = np.array(direct_src, int)
        self._dst = np.array(direct_dst, int)
        self._j0 = np.array(j0_src, int)
        self._j2 = np.array(j2_dst, int)
        self._j1 = np.array(j1_dst, int)
        self._scale, self._offset = (calibration or Calibration()).vectors(self.canonical)
        self._identity = bool(np.all(self._scale == 1.0) and np.all(self._offset == 0.0))

    def positions(self, raw: np.ndarray) -> np.ndarray:
        """Published positions (..., k) -> record angles (..., 24): calibrated, J0 split."""
        raw = np.asarray(raw, float)
        if not self._identity:
            raw = raw * self._scale + self._offset
        out = np.zeros(raw.shape[:-1] + (len(JOINT_NAMES),))
        out[..., self._dst] = raw[..., self._src]
        if self.coupled:
            j0 = raw[..., self._j0]
            j2 = np.clip(j0, 0.0, J2_MAX)
            out[..., self._j2] = j2
            out[..., self._j1] = j0 - j2
        return out

    def efforts(self, raw: np.ndarray) -> np.ndarray:
        """Published efforts (..., k) -> record efforts (..., 24); the tendon's J0 effort acts
        on both J2 and J1, so both columns get it."""
        raw = np.asarray(raw, float)
        out = np.zeros(raw.shape[:-1] + (len(JOINT_NAMES),))
        out[..., self._dst] = raw[..., self._src]
        if self.coupled:
            out[..., self._j2] = raw[..., self._j0]
            out[..., self._j1] = raw[..., self._j0]
        return out


def closure(angles: np.ndarray) -> np.ndarray:
    """How far the hand has closed: mean over the long fingers of J3 + J2 + J1 (rad)."""
    return np.asarray(angles)[..., _CLOSURE].sum(axis=-1) / len(LONG_FINGERS)


# --- segmentation -----------------------------------------------------------------------------


class GraspSegmenter:
    """Cuts a stream of (time, closure) samples into grasps by silence between closures.

    Fed one sample at a time (the streaming identifier) or a whole recording
    (:func:`segment_by_silence`); ``push`` returns the (start, end) sample indices of a grasp
    the new sample has ended (a gap, or the hand opening), ``finish`` the one still running.
    """

    def __init__(self, gap_s: float = GAP_S) -> None:
        if not (math.isfinite(gap_s) and gap_s > 0):
            raise UsageError(f"gap must be a positive number of seconds, got {gap_s!r}")
        self.gap_s = float(gap_s)
        self.reset()

    def reset(self) -> None:
        self.last_t: float | None = None
        self.last_i = -1
        self.closing = False
        self.start = 0
        self.c_min = math.inf
        self.i_min = 0
        self.c_max = -math.inf
        self.i_high = 0
        self.c_ref = 0.0
        self.still_since = 0.0
        self.settled = False

    def _open_at(self, i: int, c: float) -> None:
        self.closing = False
        self.settled = False
        self.c_min, self.i_min = c, i

    def push(self, i: int, t: float, c: float) -> tuple[int, int] | None:
        done = None
        if self.last_t is not None and t - self.last_t > self.gap_s:
            done = self.finish()
            self._open_at(i, c)
        self.last_t, self.last_i = t, i
        if not self.closing:
            if c < self.c_min:
                self.c_min, self.i_min = c, i
            elif c > self.c_min + START_RISE:
                self.closing, self.start = True, self.i_min
                self.c_max, self.i_high = c, i
                self.c_ref, self.still_since = c, t
            return done
        if c >= self.c_max:
            self.c_max = c
        if c >= self.c_max - HOLD_TOL:
            self.i_high = i
        if c < self.c_max - RELEASE_DROP:
            done = (self.start, self.i_high)
            self._open_at(i, c)
            return done
        if abs(c - self.c_ref) > STILL_TOL:
            self.c_ref, self.still_since = c, t
        self.settled = t - self.still_since >= SETTLE_S
        return done

    def finish(self) -> tuple[int, int] | None:
        """The grasp running at the end of the data (or before a gap), if any."""
        if not self.closing:
            return None
        self.closing = False
        return (self.start, self.last_i)


def segment_by_silence(time: np.ndarray, angles: np.ndarray, gap_s: float = GAP_S):
    """(start, end) inclusive sample ranges of the grasps in a recording (see module doc)."""
    seg = GraspSegmenter(gap_s)
    out = []
    levels = closure(angles).tolist()
    for i, (t, c) in enumerate(zip(time.tolist(), levels, strict=True)):
        done = seg.push(i, t, c)
        if done is not None:
            out.append(done)
    done = seg.finish()
    if done is not None:
        out.append(done)
    return out


# --- the common intermediate: joint samples ---------------------------------------------------


@dataclass
class JointSamples:
    """A recording as arrays in record columns.

    ``time`` (n,) s from the first sample (header stamps); ``receive`` (n,) s on the marker's
    clock (bag receive time; the table's time column); ``windows`` grasps marked in the file
    as (start, end, label) on the ``receive`` clock, or None when the file marks none."""

    source: str
    time: np.ndarray
    receive: np.ndarray
    angles: np.ndarray
    efforts: np.ndarray
    has_efforts: bool
    windows: list[tuple[float, float, str | None]] | None = None
    row_groups: np.ndarray | None = None
    """Tables: per row, the marker column's grasp key (0 between grasps)."""
    labels: list[str | None] = field(default_factory=list)
    coupled: bool = False
    prefix: str = ""


def _check_time(time: np.ndarray, where: str) -> None:
    if time.size == 0:
        raise UsageError(f"{where}: no joint-state samples")
    if not np.all(np.isfinite(time)):
        raise UsageError(f"{where}: time holds NaN or infinity")
    steps = np.diff(time)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        k = int(bad[0])
        raise UsageError(
            f"{where}: time is not increasing at sample {k + 1} "
            f"({time[k]:.6f} s then {time[k + 1]:.6f} s)"
        )


def _check_finite(values: np.ndarray, where: str, what: str) -> None:
    if not np.all(np.isfinite(values)):
        row = int(np.flatnonzero(~np.all(np.isfinite(values), axis=-1))[0])
        raise UsageError(f"{where}: {what} hold NaN or infinity at sample {row}")


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


def read_bag(
    path: str | Path,
    topic: str = DEFAULT_TOPIC,
    marker: str | None = None,
    calibration: Calibration | None = None,
) -> JointSamples:
    """Joint states on ``topic`` (and grasp markers on ``marker``) of a ROS 1 or ROS 2 bag."""
    _rosbags()
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    path = Path(path)
    if not path.exists():
        raise UsageError(f"recording {path} does not exist")
    root = _bag_root(path)
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
                    events.append((t_recv, _marker_event(msg, conn.msgtype, where)))
                    continue
                names = tuple(msg.name)
                if current is None or names != current.names:
                    if names in others or not is_hand_message(names):
                        others.add(names)  # another robot on the same topic (an arm)
                        continue
                    current = maps.get(names)
                    if current is None:
                        current = maps[names] = JointMap(names, calibration, where)
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
        angles[rows] = jmap.positions(np.array(chosen, float))
        if has_eff:
            chosen = eff_rows if len(maps) == 1 else [eff_rows[k] for k in rows]
            efforts[rows] = jmap.efforts(np.array(chosen, float))
    _check_finite(angles, where, "joint positions")
    origin = int(recv_ns[0])
    windows = None
    if marker_topic is not None:
        windows = _windows(events, origin, where)
    any_map = next(iter(maps.values()))
    return JointSamples(
        source=where,
        time=time,
        receive=(recv_ns - origin) / 1e9,
        angles=angles,
        efforts=efforts,
        has_efforts=has_eff,
        windows=windows,
        coupled=any(m.coupled for m in maps.values()),
        prefix=any_map.prefix,
    )


def _marker_event(msg, msgtype: str, where: str) -> tuple[str, str | None]:
    """('start'|'end', label) from one marker message."""
    if msgtype == "std_msgs/msg/Bool":
        return ("start" if msg.data else "end", None)
    if msgtype != "std_msgs/msg/String":
        raise UsageError(f"{where}: marker topic carries {msgtype}; use std_msgs String or Bool")
    text = str(msg.data).strip()
    label = None
    if text.startswith("{"):
        try:
            doc = json.loads(text)
            text, label = str(doc["event"]), doc.get("shape")
        except (ValueError, KeyError, TypeError):
            raise UsageError(f"{where}: unreadable marker message {text[:40]!r}") from None
    event = text.lower()
    if event not in ("start", "end"):
        raise UsageError(f"{where}: marker message {text[:40]!r} is neither 'start' nor 'end'")
    return event, (str(label) if label is not None else None)


def _windows(events, origin_ns: int, where: str) -> list[tuple[float, float, str | None]]:
    """Pair start/end marker events into (start, end, label) windows (s from ``origin_ns``)."""
    windows = []
    open_at, label = None, None
    for t_ns, (event, lab) in sorted(events, key=lambda e: e[0]):
        t = (int(t_ns) - origin_ns) / 1e9
        if event == "start":
            if open_at is not None:
                windows.append((open_at, t, label))
            open_at, label = t, lab
        elif open_at is None:
            raise UsageError(f"{where}: grasp marker 'end' at {t:.3f} s without a 'start'")
        else:
            windows.append((open_at, t, label or lab))
            open_at = None
    if open_at is not None:
        windows.append((open_at, math.inf, label))
    return windows


# --- tables -------------------------------------------------------------------------------------


def _table_columns(path: Path) -> dict[str, list]:
    """Column name -> values (text for CSV, Python values for Parquet)."""
    if path.suffix.lower() in (".parquet", ".pq"):
        try:
            import pyarrow.parquet as pq
        except ImportError:
            raise UsageError(
                "reading Parquet needs pyarrow: pip install 'tactile-bullet[parquet]'"
            ) from None
        try:
            table = pq.read_table(path)
        except Exception as exc:  # noqa: BLE001 - a damaged file is the user's input
            raise UsageError(f"{path} is not a readable Parquet file ({exc})") from None
        return {name: table.column(name).to_pylist() for name in table.column_names}
    import csv

    try:
        with open(path, newline="") as fh:
            rows = list(csv.reader(fh))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise UsageError(f"cannot read {path}: {exc}") from None
    rows = [r for r in rows if r and not (len(r) == 1 and not r[0].strip())]
    if not rows:
        raise UsageError(f"{path} is empty")
    header = [h.strip() for h in rows[0]]
    body = rows[1:]
    for k, row in enumerate(body):
        if len(row) != len(header):
            raise UsageError(
                f"{path}: line {k + 2} has {len(row)} fields, the header {len(header)}"
            )
    return {h: [r[j] for r in body] for j, h in enumerate(header)}


def _floats(values: list, where: str, what: str) -> np.ndarray:
    try:
        return np.array([float(v) if v not in ("", None) else math.nan for v in values], float)
    except (TypeError, ValueError):
        bad = next(v for v in values if not _is_number(v))
        raise UsageError(f"{where}: {what} holds {bad!r}, not a number") from None


def _is_number(value) -> bool:
    try:
        float(value)
    except (TypeError, ValueError):
        return False
    return True


def read_table(
    path: str | Path,
    marker: str | None = None,
    calibration: Calibration | None = None,
    time_column: str = TIME_COLUMN,
) -> JointSamples:
    """Joint states of a CSV or Parquet table (see the module docstring for its columns)."""
    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise UsageError(f"recording {path} does not exist")
    columns = _table_columns(path)
    if time_column not in columns:
        raise UsageError(f"{where} has no {time_column!r} column")
    marker_column = marker if marker is not None else (
        MARKER_COLUMN if MARKER_COLUMN in columns else None
    )  # fmt: skip
    if marker == NO_MARKER:
        marker_column = None
    if marker_column is not None and marker_column not in columns:
        raise UsageError(f"{where} has no marker column {marker_column!r}")
    reserved = {time_column, LABEL_COLUMN, MARKER_COLUMN, marker_column}
    joints, effort_cols = [], {}
    for name in columns:
        if name in reserved or name.endswith("_velocity"):
            continue
        if name.endswith("_effort"):
            effort_cols[name[: -len("_effort")]] = name
        else:
            joints.append(name)
    unknown = [e for e in effort_cols if e not in joints]
    if unknown:
        raise UsageError(f"{where}: effort columns for no position column: {', '.join(unknown)}")
    jmap = JointMap(joints, calibration, where)
    time = _floats(columns[time_column], where, f"column {time_column!r}")
    _check_time(time, where)
    raw = np.column_stack([_floats(columns[j], where, f"column {j!r}") for j in joints])
    missing = ~np.isfinite(raw)
    if missing.any():
        row, col = (int(v[0]) for v in np.nonzero(missing))
        raise UsageError(f"{where}: joint {joints[col]} has no value on data row {row + 1}")
    has_eff = len(effort_cols) == len(joints)
    if effort_cols and not has_eff:
        absent = [j for j in joints if j not in effort_cols]
        raise UsageError(f"{where}: effort columns missing for {', '.join(absent)}")
    if has_eff:
        raw_eff = np.column_stack(
            [_floats(columns[effort_cols[j]], where, f"column {effort_cols[j]!r}") for j in joints]
        )
        _check_finite(raw_eff, where, "efforts")
        efforts = jmap.efforts(raw_eff)
    else:
        efforts = np.zeros((len(time), len(JOINT_NAMES)))
    groups = None
    if marker_column is not None:
        groups = np.array([_group_key(v) for v in columns[marker_column]], dtype=object)
    labels = [str(v) if v not in ("", None) else None for v in columns.get(LABEL_COLUMN, [])]
    return JointSamples(
        source=where,
        time=time - time[0],
        receive=time - time[0],
        angles=jmap.positions(raw),
        efforts=efforts,
        has_efforts=has_eff,
        row_groups=groups,
        labels=labels,
        coupled=jmap.coupled,
        prefix=jmap.prefix,
    )


def _group_key(value):
    """A marker cell as a grasp key; 0 (or empty) for rows between grasps."""
    if value in ("", None):
        return 0
    try:
        number = float(value)
    except (TypeError, ValueError):
        return str(value)
    return 0 if number == 0 or not math.isfinite(number) else number


# --- samples -> records -------------------------------------------------------------------------


def _ranges(samples: JointSamples, gap_s: float) -> list[tuple[int, int, str | None]]:
    """(start, end, label) inclusive sample ranges of the grasps."""
    if samples.row_groups is not None:
        out, keys = [], samples.row_groups
        k = 0
        n = len(keys)
        while k < n:
            if keys[k] == 0:
                k += 1
                continue
            j = k
            while j + 1 < n and keys[j + 1] == keys[k]:
                j += 1
            out.append((k, j, None))
            k = j + 1
        return out
    if samples.windows is not None:
        out = []
        recv = samples.receive
        for start, end, label in samples.windows:
            lo = int(np.searchsorted(recv, start - 1e-9, side="left"))
            hi = int(np.searchsorted(recv, end + 1e-9, side="right")) - 1
            if hi >= lo:
                out.append((lo, hi, label))
        return out
    return [(s, e, None) for s, e in segment_by_silence(samples.time, samples.angles, gap_s)]


def record_from_samples(
    time: np.ndarray,
    angles: np.ndarray,
    efforts: np.ndarray,
    shape: str | None = None,
    has_efforts: bool = True,
) -> GraspRecord:
    """One recorded grasp as a GraspRecord: time from its first sample, final configuration
    its last sample, no contacts, pose and sizes unknown. The controller settings are the
    simulator's defaults except ``sample_rate``, the recording's mean rate (a hand
    publishing at 1 kHz gets a timestep short enough to allow it); nothing reads the rest."""
    time = np.asarray(time, float)
    duration = float(time[-1] - time[0]) if time.size else 0.0
    rate = (time.size - 1) / duration if time.size > 1 and duration > 0 else 60.0
    default = ControllerSettings()
    controller = ControllerSettings(
        sample_rate=float(rate), timestep=min(default.timestep, 1.0 / float(rate))
    )
    flags = () if has_efforts else ("no_efforts",)
    angles = np.array(angles, float)
    return GraspRecord(
        shape=shape or UNKNOWN_SHAPE,
        params={},
        pose=Pose(),
        controller=controller,
        seed=0,
        time=time - time[0],
        angles=angles,
        efforts=np.array(efforts, float),
        final_angles=angles[-1].copy(),
        contact_link=np.zeros(0, dtype="U16"),
        contact_position=np.zeros((0, 3)),
        contact_normal=np.zeros((0, 3)),
        contact_force=np.zeros(0),
        fingers_in_contact=(),
        flags=flags,
        steps=0,
        source="recorded",
    )


@dataclass(frozen=True)
class RecordedGrasp:
    """A grasp found in a recording: the record and where it lies in the file."""

    record: GraspRecord
    file: str
    index: int
    start_s: float
    end_s: float


def grasps_from_samples(
    samples: JointSamples, shape: str | None = None, gap_s: float = GAP_S
) -> list[RecordedGrasp]:
    out = []
    for k, (lo, hi, label) in enumerate(_ranges(samples, gap_s)):
        if samples.labels and label is None:
            label = next((v for v in samples.labels[lo : hi + 1] if v), None)
        record = record_from_samples(
            samples.time[lo : hi + 1],
            samples.angles[lo : hi + 1],
            samples.efforts[lo : hi + 1],
            shape or label,
            samples.has_efforts,
        )
        out.append(
            RecordedGrasp(
                record, samples.source, k, float(samples.time[lo]), float(samples.time[hi])
            )
        )
    return out


def read_samples(
    path: str | Path,
    topic: str = DEFAULT_TOPIC,
    marker: str | None = None,
    calibration: Calibration | None = None,
) -> JointSamples:
    """A recording of any supported kind, by its suffix (a folder is a ROS 2 bag)."""
    path = Path(path)
    if not path.exists():
        raise UsageError(f"recording {path} does not exist")
    suffix = path.suffix.lower()
    if suffix in (".csv", ".parquet", ".pq"):
        return read_table(path, marker, calibration)
    if suffix in (".bag", ".db3", ".mcap") or path.is_dir():
        if path.is_dir() and not (path / "metadata.yaml").is_file():
            raise UsageError(f"{path} is a folder but not a ROS 2 bag (no metadata.yaml)")
        return read_bag(path, topic, marker, calibration)
    raise UsageError(
        f"{path}: unknown recording type {suffix or '(none)'} "
        "(.bag, a ROS 2 bag folder, .db3, .mcap, .csv, .parquet)"
    )


def read_recording(
    path: str | Path,
    *,
    topic: str = DEFAULT_TOPIC,
    marker: str | None = None,
    shape: str | None = None,
    calibration: Calibration | None = None,
    gap_s: float = GAP_S,
) -> list[RecordedGrasp]:
    """Every grasp in one recording file, in time order; an error when it holds none."""
    samples = read_samples(path, topic, marker, calibration)
    grasps = grasps_from_samples(samples, shape, gap_s)
    if not grasps:
        how = "its markers" if samples.windows is not None or samples.row_groups is not None else (
            "silence between closures"
        )  # fmt: skip
        raise UsageError(f"{path}: no grasp found (cut by {how})")
    return grasps


def read_recordings(
    paths: Sequence[str | Path],
    **options,
) -> list[RecordedGrasp]:
    """Every grasp of several files, file by file."""
    out: list[RecordedGrasp] = []
    for path in paths:
        out += read_recording(path, **options)
    return out


def identify_grasps(model, grasps: Sequence[RecordedGrasp]) -> list[dict]:
    """The model's answer for every grasp of a recording, features computed in one batch:
    ``{"index", "file", "start_s", "end_s", "samples", "label", "shape", "probabilities"}``
    (``label`` the file's or the user's, None when unknown)."""
    records = [g.record for g in grasps]
    if not records:
        return []
    features = model.features(records)
    shapes = np.asarray(model.estimator.predict(features)).astype(str)
    classes = [str(c) for c in model.classes]
    try:
        proba = np.asarray(model.estimator.predict_proba(features), dtype=float)
    except (AttributeError, NotImplementedError):
        proba = np.array([[float(c == s) for c in classes] for s in shapes])
    out = []
    for g, shape, row in zip(grasps, shapes, proba, strict=True):
        out.append(
            {
                "index": g.index,
                "file": g.file,
                "start_s": g.start_s,
                "end_s": g.end_s,
                "samples": int(g.record.time.size),
                "label": None if g.record.shape == UNKNOWN_SHAPE else g.record.shape,
                "shape": str(shape),
                "probabilities": {c: float(p) for c, p in zip(classes, row, strict=True)},
            }
        )
    return out


# --- datasets -----------------------------------------------------------------------------------


def write_dataset(
    records: Sequence[GraspRecord],
    out: str | Path,
    origin: Mapping,
    force: bool = False,
    shard_size: int = 32,
) -> dict:
    """Write records as a dataset folder (manifest + checksummed shards, dataset.py's format)
    that ``train``, ``evaluate``, ``compare`` and ``identify`` read like a simulated one.
    ``origin`` (JSON) says where the records came from; the manifest keeps it as its
    ``config.sweep`` (named "import"), with seed 0, since no sweep generated them.

    Built in a temporary folder beside ``out`` and renamed into place, so a failure leaves
    nothing; an existing ``out`` is refused unless ``force`` (and even then only an empty
    folder or a dataset is replaced, never other files)."""
    import hashlib
    import os
    import shutil

    from .dataset import FORMAT, MANIFEST, encode_shard, software_versions
    from .files import write_bytes_atomic

    out = Path(out)
    check_dataset_out(out, force)
    if not records:
        raise UsageError("no grasps to write")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"--out folder {parent} does not exist")
    tmp = parent / f".{out.name}.{os.getpid()}.tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        tmp.mkdir()
        shards = []
        for block, lo in enumerate(range(0, len(records), shard_size)):
            chunk = records[lo : lo + shard_size]
            data = encode_shard([(r.metadata(), r.arrays()) for r in chunk])
            name = f"shard-{block:05d}.npz"
            write_bytes_atomic(tmp / name, data, "dataset file", durable=True)
            shards.append(
                {
                    "block": block,
                    "file": name,
                    "records": len(chunk),
                    "failed": 0,
                    "tasks": list(range(lo, lo + len(chunk))),
                    "sha256": hashlib.sha256(data).hexdigest(),
                    "bytes": len(data),
                }
            )
        manifest = {
            "format": FORMAT,
            "config": {
                "sweep": {"name": "import", **dict(origin)},
                "seed": 0,
                "shard_size": shard_size,
            },
            "tasks": len(records),
            "software": software_versions(),
            "shards": shards,
            "failed": [],
        }
        text = json.dumps(manifest, indent=1, sort_keys=True).encode()
        write_bytes_atomic(tmp / MANIFEST, text, "dataset manifest", durable=True)
        if out.exists():
            old = parent / f".{out.name}.{os.getpid()}.old"
            os.replace(out, old)
            os.replace(tmp, out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, out)
    except OSError as exc:
        raise UsageError(f"cannot write dataset {out}: {exc.strerror or exc}") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return {"out": str(out), "records": len(records), "shards": len(shards)}


def check_dataset_out(out: Path, force: bool) -> None:
    """Refuse an ``out`` that is a file, a folder of other files, or a dataset (unless
    ``force``): checked before recordings are read, and again before writing."""
    from .dataset import MANIFEST

    if not out.exists():
        return
    if not out.is_dir():
        raise UsageError(f"--out {out} exists and is not a folder")
    if not any(out.iterdir()):
        return
    if not (out / MANIFEST).is_file():
        raise UsageError(f"--out {out} exists and holds files that are not a dataset")
    if not force:
        raise UsageError(f"--out {out} already holds a dataset; use --force to replace it")
