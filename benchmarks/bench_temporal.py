"""Early grasp end (ControllerSettings.early_stop): physics steps saved, and accuracy kept.

Simulates an evenly spaced sample of a sweep preset's grasps twice, with the default controller
and with ``early_stop=True``, and prints the steps per grasp of each, the share saved, how many
grasps changed at all, and the largest change of a final FCI angle on a finger in contact.
``--demo`` also runs the demo's protocol (signature + SVM, test sizes and offsets never seen in
training; ``workflow.demo``'s draws, first round) with both controllers and prints both
accuracies. Also times the dynamic detector fed row by row (the controller's hot path).

    python benchmarks/bench_temporal.py --preset thesis --grasps 60
    python benchmarks/bench_temporal.py --preset temporal --grasps 60
    python benchmarks/bench_temporal.py --preset thesis --grasps 0 --demo --workers 2

Steps are deterministic; wall times on a shared machine are not (ratios only).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from multiprocessing import Pool

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.hand import LONG_FINGERS
from tactile_bullet.records import ControllerSettings, Pose


def pair(job: tuple):
    """(default record, early-stop record) of one grasp, or None if the pose is refused."""
    from tactile_bullet.errors import UsageError
    from tactile_bullet.sim.grasp import simulate_grasp

    shape, params, offset, rotation, ctl, seed = job
    pose = Pose(offset, rotation)
    try:
        base = simulate_grasp(shape, params, pose, ctl, seed)
        early = simulate_grasp(shape, params, pose, replace(ctl, early_stop=True), seed)
    except UsageError:
        return None
    return base, early


def run_pairs(jobs: list[tuple], workers: int) -> list[tuple]:
    if workers > 1:
        with Pool(workers) as pool:
            out = pool.map(pair, jobs, chunksize=1)
    else:
        out = [pair(j) for j in jobs]
    return [p for p in out if p is not None]


def steps_report(pairs: list[tuple]) -> dict:
    base = np.array([b.steps for b, _ in pairs])
    early = np.array([e.steps for _, e in pairs])
    changed = [not np.array_equal(b.final_angles, e.final_angles) for b, e in pairs]
    kept = []
    for b, e in pairs:
        mask = np.array([f in b.fingers_in_contact for f in LONG_FINGERS])
        diff = np.abs(b.fci_angles() - e.fci_angles())[:, mask]
        kept.append(float(np.degrees(diff.max())) if diff.size else 0.0)
    return {
        "grasps": len(pairs),
        "steps_default": float(base.mean()),
        "steps_early_stop": float(early.mean()),
        "saved": float(1.0 - early.sum() / base.sum()),
        "grasps_changed": int(sum(changed)),
        "grasps_with_non_contact_finger": int(
            sum(any(f not in b.fingers_in_contact for f in LONG_FINGERS) for b, _ in pairs)
        ),
        "max_change_on_touching_fingers_deg": max(kept) if kept else 0.0,
    }


def preset_jobs(name: str, n: int) -> list[tuple]:
    from tactile_bullet.datasets.presets import preset

    tasks = preset(name).tasks()
    if n <= 0:
        return []
    picks = np.linspace(0, len(tasks) - 1, min(n, len(tasks))).round().astype(int)
    return [
        (t.shape, t.params, t.pose.offset, t.pose.rotation, t.controller, t.seed)
        for t in (tasks[i] for i in picks)
    ]


def demo_jobs(seed: int, train_per_shape: int, test_per_shape: int) -> tuple[list, list]:
    from tactile_bullet.experiments import workflow as wf

    rng = np.random.default_rng(seed)
    out = []
    for per, fractions, offsets in (
        (train_per_shape, wf.TRAIN_FRACTIONS, wf.TRAIN_OFFSETS),
        (test_per_shape, wf.TEST_FRACTIONS, wf.TEST_OFFSETS),
    ):
        specs = [s for name in wf.DEMO_SHAPES for s in wf.draw_specs(name, per, fractions,
                                                                     offsets, rng)]  # fmt: skip
        out.append([(s.shape, s.params, s.pose.offset, 0.0, ControllerSettings(), s.seed)
                    for s in specs])  # fmt: skip
    return out[0], out[1]


def demo_accuracy(train_pairs, test_pairs) -> dict:
    from tactile_bullet.experiments.workflow import evaluate, train

    out = {}
    for k, label in enumerate(("default", "early_stop")):
        tr = [p[k] for p in train_pairs if "no_contact" not in p[k].flags]
        te = [p[k] for p in test_pairs if "no_contact" not in p[k].flags]
        out[label] = evaluate(train(tr, "signature", "svm"), te)["accuracy"]
    out["test_grasps"] = len(test_pairs)
    return out


def detector_speed(rows: int = 20000) -> float:
    """Microseconds per row of the online dynamic detector (random rising columns)."""
    from tactile_bullet.perception.temporal import DynamicDetector

    rng = np.random.default_rng(0)
    g = np.cumsum(rng.uniform(0, 2, size=(rows, 4)), axis=0)
    det = DynamicDetector()
    start = time.perf_counter()
    for i, row in enumerate(g):
        det.push(row, i / 60.0)
    return 1e6 * (time.perf_counter() - start) / rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="thesis", help="sweep preset to sample (thesis, temporal)")
    ap.add_argument("--grasps", type=int, default=60, help="grasps sampled from the preset")
    ap.add_argument("--demo", action="store_true", help="also the demo protocol's accuracy")
    ap.add_argument("--seed", type=int, default=0, help="demo draws")
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args()
    provenance()

    print(f"dynamic detector: {detector_speed():.1f} us per row of G")
    jobs = preset_jobs(args.preset, args.grasps)
    if jobs:
        start = time.perf_counter()
        rep = steps_report(run_pairs(jobs, args.workers))
        print(
            f"{args.preset} preset, {rep['grasps']} grasps: {rep['steps_default']:.0f} -> "
            f"{rep['steps_early_stop']:.0f} steps per grasp ({100 * rep['saved']:.1f}% saved); "
            f"{rep['grasps_with_non_contact_finger']} grasps have a finger off the object, "
            f"{rep['grasps_changed']} changed; largest final-angle change on a touching finger "
            f"{rep['max_change_on_touching_fingers_deg']:.2f} deg "
            f"({time.perf_counter() - start:.0f} s)"
        )
    if args.demo:
        train_jobs, test_jobs = demo_jobs(args.seed, 24, 12)
        train_pairs = run_pairs(train_jobs, args.workers)
        test_pairs = run_pairs(test_jobs, args.workers)
        rep = steps_report(train_pairs + test_pairs)
        acc = demo_accuracy(train_pairs, test_pairs)
        print(
            f"demo protocol (seed {args.seed}, {len(train_pairs)} train / {acc['test_grasps']} "
            f"test): signature + svm {100 * acc['default']:.1f}% default, "
            f"{100 * acc['early_stop']:.1f}% early stop; steps {rep['steps_default']:.0f} -> "
            f"{rep['steps_early_stop']:.0f} ({100 * rep['saved']:.1f}% saved, "
            f"{rep['grasps_changed']} grasps changed)"
        )


if __name__ == "__main__":
    main()
