"""Latency of the streaming identifier: ``Identifier.update`` per joint-state message and
``Identifier.result`` while a grasp closes and once it is over.

Trains signature + svm on part of a dataset (or loads ``--model``), then replays held-out
grasps message by message as a real hand publishes them (prefixed names, positions, efforts),
followed by 0.3 s of the held pose at 100 Hz, the way a hand keeps publishing. ``result`` is
timed every ``--result-every`` messages (each call after a new message, so never a cached
answer) and once per grasp when it is over. Targets: update <= 0.1 ms, result <= 5 ms
(medians). Also checks that the streamed answer equals ``identify`` on the whole record.

    python benchmarks/bench_streaming.py --data DIR [--grasps 20] [--threads 1]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

UPDATE_TARGET_MS = 0.1
RESULT_TARGET_MS = 5.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="dataset with time series (generate)")
    parser.add_argument("--model", help="a trained model (default: train signature + svm)")
    parser.add_argument("--grasps", type=int, default=20, help="grasps replayed")
    parser.add_argument("--no-cross-check", action="store_true",
                        help="answer from the margin only (no shape fit at the grasp's end)")
    parser.add_argument("--result-every", type=int, default=10, help="messages between results")
    parser.add_argument("--threads", type=int, default=0, help="BLAS/OpenMP threads (0: default)")
    args = parser.parse_args()
    provenance()

    from tactile_bullet import Identifier
    from tactile_bullet.experiments import workflow
    from tactile_bullet.hand import JOINT_NAMES
    from tactile_bullet.learn.models import load_model

    records = workflow.records_from(args.data)
    step = max(1, len(records) // args.grasps)
    test_idx = set(range(0, len(records), step)[: args.grasps])
    test = [records[i] for i in sorted(test_idx)]
    if args.model:
        model = load_model(args.model)
    else:
        train = [r for i, r in enumerate(records) if i not in test_idx]
        model = workflow.train(train, "signature", "svm")
    limiter = None
    if args.threads:
        from threadpoolctl import threadpool_limits

        limiter = threadpool_limits(args.threads)
    ident = Identifier.load(model, cross_check=not args.no_cross_check)
    names = ["rh_" + n for n in JOINT_NAMES]
    updates, closing, over, over_cpu = [], [], [], []
    agree, t0 = 0, 0.0
    for rec in test:
        for k, (t, q, e) in enumerate(zip(rec.time, rec.angles, rec.efforts, strict=True)):
            start = time.perf_counter()
            ident.update(t0 + t, names, q, e)
            updates.append(time.perf_counter() - start)
            if k % args.result_every == args.result_every - 1:
                start = time.perf_counter()
                ident.result()
                closing.append(time.perf_counter() - start)
        end = t0 + rec.time[-1]
        for k in range(1, 31):
            start = time.perf_counter()
            ident.update(end + k / 100, names, rec.angles[-1], rec.efforts[-1])
            updates.append(time.perf_counter() - start)
        start, cpu = time.perf_counter(), time.process_time()
        doc = ident.result()
        over.append(time.perf_counter() - start)
        over_cpu.append(time.process_time() - cpu)
        agree += doc["grasp_over"] and doc["shape"] == workflow.identify(model, rec)["shape"]
        t0 = end + 2.0
    if limiter is not None:
        limiter.restore_original_limits()

    def ms(values, q=50):
        return 1000.0 * float(np.percentile(values, q))

    threads = args.threads or "default"
    print(f"{len(test)} grasps replayed, {len(updates)} messages; model "
          f"{model.descriptor} + {model.classifier}; threads: {threads}")  # fmt: skip
    print(f"update:            median {ms(updates):.4f} ms  p95 {ms(updates, 95):.4f} ms  "
          f"(target <= {UPDATE_TARGET_MS} ms)")  # fmt: skip
    print(f"result (closing):  median {ms(closing):.2f} ms  p95 {ms(closing, 95):.2f} ms")
    print(f"result (over):     median {ms(over):.2f} ms  p95 {ms(over, 95):.2f} ms  "
          f"(target <= {RESULT_TARGET_MS} ms)")  # fmt: skip
    print(f"result (over), CPU time of the process: median {ms(over_cpu):.2f} ms "
          "(wall time swells on a busy machine)")  # fmt: skip
    print(f"streamed answer == identify on the whole record: {agree}/{len(test)}")


if __name__ == "__main__":
    main()
