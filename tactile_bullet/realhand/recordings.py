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
controller moves the tendon (sim/grasp.py): J0's travel goes to J2 first, then to J1 once J2 is at
its limit, so J2 = min(J0, pi/2) and J1 = J0 - J2. Its limit: where the middle phalanx stopped
on the object before its limit (J2 blocked by contact), the real J2 is smaller and J1 larger
than this split says. The FCI's proximal and whole-finger rows (J3 and J3 + J0, the two
signature lines) are exact either way; only the middle row is an estimate. Where a hand
publishes J1, J2 and J0, J1 and J2 are used. The wrist may be absent (the simulated wrist is
welded at 0); every other joint must be there: a missing or unknown joint is an error naming it.

Grasps in one recording are cut:

1. by a marker the user names: a topic (``std_msgs/String`` holding ``start`` / ``end`` or a
   JSON object ``{"event": "start"|"end", "shape": label, "object": mark}``, or
   ``std_msgs/Bool``, true while
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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..files import input_path
from ..records import ControllerSettings, GraspRecord, Pose
from .bags import read_bag
from .calibration import Calibration
from .joints import JointSamples
from .names import DEFAULT_TOPIC, UNKNOWN_SHAPE
from .segment import GAP_S, segment_by_silence
from .tables import read_table

# --- samples -> records -------------------------------------------------------------------------


def _ranges(samples: JointSamples, gap_s: float) -> list[tuple[int, int, str | None]]:
    """(start, end, label) inclusive sample ranges of the grasps."""
    if samples.row_groups is not None:
        out, keys = [], samples.row_groups
        k = 0
        n = len(keys)
        ended: set = set()  # marks of grasps another grasp's mark has followed
        last = None
        while k < n:
            if keys[k] == 0:
                k += 1
                continue
            if keys[k] in ended:  # 1, 2, 1: grasp 1 cannot resume once grasp 2 began
                raise UsageError(
                    f"{samples.source}: the marker's grasp {_mark(keys[k])} returns at data row "
                    f"{k + 1} after grasp {_mark(last)} began: a grasp's rows must be one run "
                    "(a mark may come back after rows of 0, not after another grasp)"
                )
            if last is not None and last != keys[k]:
                ended.add(last)
            j = k
            while j + 1 < n and keys[j + 1] == keys[k]:
                j += 1
            out.append((k, j, None))
            last = keys[k]
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


def _mark(key) -> str:
    """A marker value as the file holds it (a whole number without its ``.0``)."""
    value = key.item() if hasattr(key, "item") else key
    return str(int(value)) if isinstance(value, float) and value.is_integer() else str(value)


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
    object: str | None = None
    """The object the recording marks the grasp as made on (its ``object`` column), or None."""


def grasps_from_samples(
    samples: JointSamples, shape: str | None = None, gap_s: float = GAP_S
) -> list[RecordedGrasp]:
    out = []
    for k, (lo, hi, label) in enumerate(_ranges(samples, gap_s)):
        if samples.labels and label is None and shape is None:  # --shape overrides them
            label = _one_of(samples, samples.labels, lo, hi, k, "shape", "labelled")
        record = record_from_samples(
            samples.time[lo : hi + 1],
            samples.angles[lo : hi + 1],
            samples.efforts[lo : hi + 1],
            shape or label,
            samples.has_efforts,
        )
        out.append(
            RecordedGrasp(
                record, samples.source, k, float(samples.time[lo]), float(samples.time[hi]),
                _one_of(samples, samples.objects, lo, hi, k, "object", "of objects"),
            )
        )
    if shape is None:
        _check_objects(samples.source, out)
    return out


def _one_of(samples: JointSamples, column: Sequence, lo: int, hi: int, k: int, name: str,
            spans: str) -> str | None:  # fmt: skip
    """The one value (a shape label, an object mark) a grasp's rows of ``column`` carry, None
    where they carry none; a UsageError where they carry two (the column disagrees with the
    grasps found)."""
    if not column:
        return None
    found = sorted({v for v in column[lo : hi + 1] if v})
    if len(found) > 1:
        raise UsageError(
            f"{samples.source}: grasp {k + 1} ({float(samples.time[lo]):.2f}-"
            f"{float(samples.time[hi]):.2f} s) spans rows {spans} {', '.join(found)}: the "
            f"{name} column disagrees with the grasps found (mark each grasp's rows, or cut the "
            "grasps with a marker column)"
        )
    return found[0] if found else None


def _check_objects(source: str, grasps: Sequence[RecordedGrasp]) -> None:
    """A UsageError where grasps the recording marks as one object carry two shape labels:
    one object has one shape, so its marks (or its labels) are wrong, and fusing its grasps
    would outvote one label with the other."""
    labels: dict[str, dict[str, int]] = {}
    for g in grasps:
        if g.object is not None and g.record.shape != UNKNOWN_SHAPE:
            labels.setdefault(g.object, {}).setdefault(g.record.shape, g.index)
    for name, found in labels.items():
        if len(found) > 1:
            which = ", ".join(f"{s} (grasp {i + 1})" for s, i in found.items())
            raise UsageError(f"{source}: grasps marked as object {name!r} are labelled {which}: "
                             "one object has one shape, so its object marks or its shape labels "
                             "are wrong")  # fmt: skip


def read_samples(
    path: str | Path,
    topic: str = DEFAULT_TOPIC,
    marker: str | None = None,
    calibration: Calibration | None = None,
    prefix: str | None = None,
) -> JointSamples:
    """A recording of any supported kind, by its suffix (a folder is a ROS 2 bag); one hand's
    samples (``prefix`` "rh" picks one where the file holds two)."""
    path = input_path(path, "recording", folder=True)
    suffix = path.suffix.lower()
    if suffix in (".csv", ".parquet", ".pq"):
        return read_table(path, marker, calibration, prefix=prefix)
    if suffix in (".bag", ".db3", ".mcap") or path.is_dir():
        if path.is_dir() and not (path / "metadata.yaml").is_file():
            raise UsageError(f"{path} is a folder but not a ROS 2 bag (no metadata.yaml)")
        return read_bag(path, topic, marker, calibration, prefix)
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
    prefix: str | None = None,
) -> list[RecordedGrasp]:
    """Every grasp in one recording file, in time order; an error when it holds none."""
    samples = read_samples(path, topic, marker, calibration, prefix)
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


ANSWER_CHUNK = 64
"""Grasps of a recording answered in one batch (descriptor, classifier, second opinion)."""


def _answer_chunk(model, records: Sequence[GraspRecord]) -> tuple[list, list, list]:
    """(names, probability rows, doubts) of ``records``, features computed once."""
    from ..learn.doubt import doubts

    features = model.features(records)
    shapes, proba, was = model.answers(records, features)
    if proba is None:  # a classifier without probabilities: its answer, certain
        classes = [str(c) for c in model.classes]
        proba = np.array([[float(c == s) for c in classes] for s in shapes])
    found = doubts(model, records, shapes, proba, features=features, renamed_from=was)
    return list(shapes), list(proba), found


def identify_grasps(model, grasps: Sequence[RecordedGrasp]) -> list[dict]:
    """The model's answer for every grasp of a recording, features computed in one batch:
    ``{"index", "file", "start_s", "end_s", "samples", "label", "object", "shape",
    "probabilities", "margin", "ambiguous", "cross_check", "unknown", "novelty"}`` (``label``
    the file's or the user's, None when unknown; ``object`` the recording's object mark, None
    where unmarked; the rest as in ``workflow.identify``)."""
    records = [g.record for g in grasps]
    if not records:
        return []
    from ..console import start, tick

    start("identify: grasps answered", len(records))
    shapes, proba, found = [], [], []
    for at in range(0, len(records), ANSWER_CHUNK):  # a long recording says how far it is
        part = records[at : at + ANSWER_CHUNK]
        names, probs, doubt = _answer_chunk(model, part)
        shapes += names
        proba += probs
        found += doubt
        tick("identify: grasps answered", at + len(part), len(records))
    classes = [str(c) for c in model.classes]
    out = []
    for g, shape, row, doubt in zip(grasps, shapes, proba, found, strict=True):
        out.append(
            {
                "index": g.index,
                "file": g.file,
                "start_s": g.start_s,
                "end_s": g.end_s,
                "samples": int(g.record.time.size),
                "label": None if g.record.shape == UNKNOWN_SHAPE else g.record.shape,
                "object": g.object,
                "shape": str(shape),
                "probabilities": {c: float(p) for c, p in zip(classes, row, strict=True)},
                **doubt,
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
    """Write records as a dataset folder (manifest + checksummed shards, the datasets/
    format) that ``train``, ``evaluate``, ``compare`` and ``identify`` read like a simulated
    one.
    ``origin`` (JSON) says where the records came from; the manifest keeps it as its
    ``config.sweep`` (named "import"), with seed 0, since no sweep generated them.

    Built in a temporary folder beside ``out`` and renamed into place, so a failure leaves
    nothing; an existing ``out`` is refused unless ``force`` (and even then only an empty
    folder or a dataset holding nothing but this project's files is replaced)."""
    import hashlib
    import os
    import shutil

    from ..datasets.shards import FORMAT, MANIFEST, encode_shard, software_versions
    from ..files import write_bytes_atomic

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
    from ..datasets.shards import MANIFEST, foreign_in_dataset
    from ..files import refuse_special

    refuse_special(out, "--out")
    if not out.exists():
        return
    if not out.is_dir():
        raise UsageError(f"--out {out} exists and is not a folder")
    if not any(out.iterdir()):
        return
    if not (out / MANIFEST).is_file():
        raise UsageError(f"--out {out} exists and holds files that are not a dataset")
    foreign = foreign_in_dataset(out)
    if foreign:
        raise UsageError(
            f"--out {out} holds {foreign}, which this project did not write: not replacing "
            "the folder (move it away or choose another folder)"
        )
    if not force:
        raise UsageError(f"--out {out} already holds a dataset; use --force to replace it")


def fused_objects(model, answers: Sequence[Mapping]) -> list[dict]:
    """One fused answer per object the recording marks (grasps sharing an ``object`` mark):
    ``{"object", "grasps": [index, ...], "shape", "posterior", "ambiguous", "unknown"}``
    (``experiments/fusion.py``), in order of first grasp; [] where none is
    marked."""
    from ..experiments.fusion import fused_answer

    groups: dict[str, list[Mapping]] = {}
    for a in answers:
        if a.get("object") is not None:
            groups.setdefault(str(a["object"]), []).append(a)
    out = []
    for name, members in groups.items():
        fused = fused_answer(model, members)
        out.append({"object": name, "grasps": [int(a["index"]) for a in members],
                    "shape": fused["shape"], "posterior": fused["posterior"],
                    "ambiguous": fused["ambiguous"], "unknown": fused["unknown"]})  # fmt: skip
    return out
