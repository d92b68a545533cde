"""Chapter 3's experiment on a set of grasps: detectors against the recorded contacts, decision
time saved, SVM_pos / SVM_dyn against the uncorrected SVM, DTW distances of corrected
signatures (thesis Figs 3.3, 3.6/3.9, 3.7/3.10, 3.12/3.13, 3.14), as a JSON summary and PNGs.

``tactile-bullet temporal`` is a thin layer over :func:`run_experiment`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..console import plural
from ..errors import UsageError
from ..perception.temporal import DETECTORS, contact_truth, detect, finger_areas, g_of, gbin
from ..realhand.names import UNKNOWN_SHAPE

CENTRED_MM = 10.0
"""An object moved at most this far along O-O' counts as centred (the thesis preset's range)."""

FIGURES = (
    "g_gbin.png",
    "detectors.png",
    "decision_time_saved.png",
    "confusion_svm_position_centred.png",
    "confusion_svm_position_off_centre.png",
    "confusion_svm_dynamic_centred.png",
    "confusion_svm_dynamic_off_centre.png",
    "dtw_distances.png",
)
SUMMARY = "temporal.json"


def output_paths(out: str | os.PathLike) -> list[Path]:
    """Every file :func:`run_experiment` writes into ``out``."""
    return [Path(out) / name for name in (*FIGURES, SUMMARY)]


def check_outputs(out: str | os.PathLike, force: bool) -> Path:
    """The output folder, created; a UsageError (before any work) if it holds one of our files
    and ``force`` is off, or, with it, a file this project did not write there
    (``files.existing_outputs``)."""
    from ..files import existing_outputs
    from .reports import report_dir

    existing_outputs(out, (*FIGURES, SUMMARY), "--out folder", force)
    return report_dir(out)


def detector_scores(records: Sequence) -> dict[str, Any]:
    """Per detector: per-finger agreement with the records' contacts, the counts behind Figs
    3.6/3.9 (detected non-contact, measured non-contact, and the right ones of each), and per
    grasp the time each decided every finger."""
    measured = has_contact_truth(records)
    out: dict[str, Any] = {"grasps": len(records), "fingers": 4 * len(records)}
    out["contact_truth"] = measured
    times = {}
    if not measured:  # a real hand's recording: what the detectors say, judged against nothing
        out["measured_non_contact"] = None
        for method in DETECTORS:
            dets = [detect(r, method) for r in records]
            pred = np.array([d.contact_mask for d in dets])
            times[method] = np.array([d.decided_at_s for d in dets])
            out[method] = {"agreement": None, "detected_non_contact": int((~pred).sum())}
            out[method].update(dict.fromkeys(_JUDGED))
        saved = times["position"] - times["dynamic"]
        out["decision_saved_s"] = {"all": _stats(saved), "grasps_with_non_contact_finger": None}
        out["_saved"], out["_with_miss"] = saved, np.zeros(len(records), bool)
        return out
    truth = np.array([contact_truth(r) for r in records])
    out["measured_non_contact"] = int((~truth).sum())
    for method in DETECTORS:
        dets = [detect(r, method) for r in records]
        pred = np.array([d.contact_mask for d in dets])
        times[method] = np.array([d.decided_at_s for d in dets])
        out[method] = {
            "agreement": float((pred == truth).mean()),
            "detected_non_contact": int((~pred).sum()),
            "detected_right": int((~pred & ~truth).sum()),
            "measured_found": int((~pred & ~truth).sum()),
            "false_non_contact": int((~pred & truth).sum()),
            "missed_non_contact": int((pred & ~truth).sum()),
        }
    saved = times["position"] - times["dynamic"]
    with_miss = ~truth.all(axis=1)
    out["decision_saved_s"] = {
        "all": _stats(saved),
        "grasps_with_non_contact_finger": _stats(saved[with_miss]),
    }
    out["_saved"] = saved
    out["_with_miss"] = with_miss
    return out


_JUDGED = ("detected_right", "measured_found", "false_non_contact", "missed_non_contact")
"""Detector counts that need the measured contacts (null without them)."""


def has_contact_truth(records: Sequence) -> bool:
    """Whether the records carry measured contacts to judge the detectors by: simulated
    grasps do; a real hand's recordings (``source`` "recorded") have no contact sensing, so
    their empty contact lists mean unknown, not "every finger off the object"."""
    return all(getattr(r, "source", "simulated") == "simulated" for r in records)


def _stats(values: np.ndarray) -> dict[str, float]:
    if values.size == 0:
        return {"n": 0}
    return {
        "n": int(values.size),
        "median": float(np.median(values)),
        "mean": float(values.mean()),
        "share_over_0_5_s": float((values > 0.5).mean()),
        "share_over_0": float((values > 0).mean()),
    }


def centred(record) -> bool:
    return abs(record.pose.offset[0]) * 1000.0 <= CENTRED_MM + 1e-9


def svm_scores(records: Sequence, seeds: Sequence[int] = (0, 1, 2), test_fraction: float = 0.3):
    """SVM, SVM_pos and SVM_dyn (signature + svm, ``correction`` none / position / dynamic) on
    the same held-out splits: accuracy overall, on centred and on off-centre objects, and the
    first split's confusion matrices. Each ``mean`` is over the held-out grasps of every split
    together (``n`` of them; ``per_split`` each split's own, where it held any): a split whose
    test grasps are all centred adds to ``all`` and ``centred`` only, so a mean over splits
    could put ``all`` below both of its parts, which a pooled one cannot."""
    from ..console import tick
    from .reports import class_order, confusion_matrix
    from .training import labels_of, predict, split, train

    scores: dict[str, Any] = {}
    matrices: dict[str, Any] = {}
    for c, correction in enumerate(("none", "position", "dynamic")):
        acc = {"all": [], "centred": [], "off_centre": []}
        hits = {key: [0, 0] for key in acc}  # right answers, held-out grasps
        for k, seed in enumerate(seeds):
            tick("SVM, SVM_pos, SVM_dyn splits trained", c * len(seeds) + k, 3 * len(seeds))
            tr, te = split(records, test_fraction, seed)
            model = train(tr, "signature", "svm", None, {"correction": correction})
            y, p = labels_of(te), predict(model, te)
            mid = np.array([centred(r) for r in te])
            for key, mask in (("all", np.ones(len(y), bool)), ("centred", mid),
                              ("off_centre", ~mid)):  # fmt: skip
                if mask.any():
                    acc[key].append(float(np.mean(p[mask] == y[mask])))
                    hits[key][0] += int(np.sum(p[mask] == y[mask]))
                    hits[key][1] += int(mask.sum())
                if k == 0 and correction != "none":
                    classes = class_order([str(c) for c in model.classes], y)
                    cm = confusion_matrix(y[mask], p[mask], classes)
                    matrices[f"{correction}_{key}"] = (np.asarray(cm).tolist(), classes)
        scores[correction] = {
            k: {"mean": hits[k][0] / hits[k][1], "n": hits[k][1], "per_split": v} if v else None
            for k, v in acc.items()
        }
    scores["held_out_fraction"] = test_fraction
    scores["splits"] = list(seeds)
    return scores, matrices


def dtw_scores(records: Sequence, correction: str = "dynamic") -> dict[str, Any]:
    """DTW distances of raw and corrected signatures to their own pattern and to the others
    (Fig 3.14), and the training-free identification rate of each."""
    from ..perception.patterns import closest_in_size, signature_distance, size_matched_library
    from ..perception.temporal import corrected_signature, identify_masked

    lib = size_matched_library()
    out: dict[str, Any] = {}
    dropped = np.array([not detect(r, correction).contact_mask.all() for r in records])
    from ..console import tick

    for label, method in (("raw", "none"), ("corrected", correction)):
        own, other, right = [], [], []
        for i, r in enumerate(records):
            tick(f"DTW distances ({label} signatures)", i, len(records))
            keep = np.ones(4, bool) if method == "none" else detect(r, method).contact_mask
            ident, keep = identify_masked(r.fci_angles(), keep)
            # an unlabelled recording is neither right nor wrong
            right.append(None if r.shape == UNKNOWN_SHAPE else ident.name == r.shape)
            sig = corrected_signature(r.fci_angles(), keep)
            use = lib
            if r.shape not in use:
                continue
            for name, family in use.items():
                d = signature_distance(sig, closest_in_size(sig, family))
                (own if name == r.shape else other).append(d)
        labelled = np.array([v is not None for v in right], dtype=bool)
        right = np.array([bool(v) for v in right], dtype=bool)
        out[label] = {
            "identified": float(np.mean(right[labelled])) if labelled.any() else None,
            "identified_where_a_finger_was_dropped": (
                float(np.mean(right[dropped & labelled])) if (dropped & labelled).any() else None
            ),
            "own_median": float(np.median(own)) if own else None,
            "other_median": float(np.median(other)) if other else None,
            "_own": own,
            "_other": other,
        }
    out["correction"] = correction
    out["grasps_with_a_finger_dropped"] = int(dropped.sum())
    return out


def run_experiment(
    records: Sequence, out: str | os.PathLike, force: bool = False, example: int | None = None
) -> dict[str, Any]:
    """Every figure and the JSON summary of chapter 3 for ``records`` into ``out``."""
    from ..perception.temporal import record_series
    from . import figures_temporal as figs
    from .reports import write_json

    folder = check_outputs(out, force)
    records = list(records)
    if not records:
        raise UsageError("no grasp records to analyse")
    for r in records:
        record_series(r)  # every record needs its time series: refuse before the work
    det = detector_scores(records)
    saved, with_miss = det.pop("_saved"), det.pop("_with_miss")
    if example is None:
        missing = np.flatnonzero(with_miss)
        example = int(missing[0]) if missing.size else 0
    if not 0 <= example < len(records):
        raise UsageError(f"--example must be from 0 to {len(records) - 1}, got {example}")
    rec = records[example]
    image = g_of(rec)
    binary = gbin(image)
    figs.plot_g_gbin(image, binary, finger_areas(image, binary), rec, folder / FIGURES[0])
    figs.plot_detectors(det, folder / FIGURES[1])
    figs.plot_saved(saved, with_miss, folder / FIGURES[2])
    doc: dict[str, Any] = {"records": len(records), "example_record": example, "detectors": det}
    shapes = {r.shape for r in records}
    if len(shapes) >= 2 and len(records) >= 4 * len(shapes):
        svm, matrices = svm_scores(records)
        doc["svm"] = svm
        for key, (cm, classes) in matrices.items():
            method, where = key.split("_", 1)
            name = f"confusion_svm_{method}_{where}.png"
            figs.plot_confusion_matrix(cm, classes, folder / name, f"SVM_{method[:3]}, {where}")
    else:
        doc["svm"] = None
    dtw = dtw_scores(records)
    figs.plot_dtw(dtw, folder / FIGURES[-1])
    doc["dtw"] = {k: ({kk: vv for kk, vv in v.items() if not kk.startswith("_")}
                      if isinstance(v, dict) else v) for k, v in dtw.items()}  # fmt: skip
    doc["outputs"] = [str(p) for p in output_paths(folder) if p.exists() or p.name == SUMMARY]
    write_json(folder / SUMMARY, doc)
    return doc


def summary_text(doc: dict[str, Any]) -> str:
    """What ``tactile-bullet temporal`` prints without --json."""
    det = doc["detectors"]
    if not det.get("contact_truth", True):
        lines = [
            f"{plural(doc['records'], 'grasp')}, {plural(det['fingers'], 'finger')}: recorded "
            "grasps carry no contact truth, so the detectors' output is shown without an "
            "agreement figure",
        ]
        lines += [f"  {m:8s}: {plural(det[m]['detected_non_contact'], 'finger')} flagged out "
                  "of contact" for m in DETECTORS]  # fmt: skip
    else:
        lines = [
            f"{plural(doc['records'], 'grasp')}, {plural(det['fingers'], 'finger')}, "
            f"{det['measured_non_contact']} of them out of contact at the end",
        ]
    for m in DETECTORS if det.get("contact_truth", True) else ():
        d = det[m]
        lines.append(
            f"  {m:8s}: {100 * d['agreement']:.1f}% per-finger agreement with the contacts "
            f"({d['detected_non_contact']} flagged, {d['false_non_contact']} wrongly; "
            f"{d['missed_non_contact']} missed)"
        )
    s = det["decision_saved_s"]["grasps_with_non_contact_finger"] or {}
    if s.get("n"):
        lines.append(
            f"  dynamic decides {s['median']:.2f} s earlier (median over {s['n']} grasps with a "
            f"finger off the object; {100 * s['share_over_0_5_s']:.0f}% save > 0.5 s)"
        )
    if doc.get("svm"):
        for c, label in (("none", "SVM"), ("position", "SVM_pos"), ("dynamic", "SVM_dyn")):
            v = doc["svm"][c]
            parts = [f"{k} {100 * v[k]['mean']:.1f}%" for k in ("all", "centred", "off_centre")
                     if v.get(k)]  # fmt: skip
            lines.append(f"  {label:8s}: " + ", ".join(parts))
    d = doc["dtw"]
    if d["raw"]["identified"] is not None:  # None: no grasp is labelled with its shape
        lines.append(
            f"  training-free DTW: {100 * d['raw']['identified']:.1f}% raw, "
            f"{100 * d['corrected']['identified']:.1f}% corrected ({d['correction']})"
        )
    folder = str(Path(doc["outputs"][0]).parent) if doc["outputs"] else "?"
    lines.append(f"wrote {plural(len(doc['outputs']), 'file')} to {folder}/ (figures and "
                 f"{SUMMARY})")  # fmt: skip
    return "\n".join(lines) + "\n"
