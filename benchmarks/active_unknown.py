"""The fused ``unknown`` with each grasp's contacts judged against the fused family
(``fusion.UNKNOWN_AGAINST_FUSED``) and against the family each grasp named alone (the
rule before it), on the ``active`` protocol's objects, and the verdict of the rule declared
before seed 7 (docs/exploration.md).

The switch changes no grasp and no pose (the posterior and the planner never read
``unknown``), so the ``planned`` strategy is run once, with the switch on, on every column
(the ``out-of-family`` one included), and the old rule is scored on the same grasps by fusing
each grasp's own flag again (``active_fusion.py``'s ``distinct`` rule, which must give back the
run's fused shapes: checked). Per column: the objects whose fused answer is unknown after 1, 2
and 3 grasps and where the stopping rule stops, and the objects right with the stopping rule
(out of family: right where unknown), old -> new.

    python benchmarks/active_unknown.py [--scale full] [--seed 7] \\
        [--other-hand menagerie=M.xml --other-hand gymnasium=G.xml] [--columns ...] \\
        [--json OUT.json]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from _report import provenance  # first: this checkout ahead of an installed copy
from active_fusion import RULES, fused_after_each

from tactile_bullet.experiments import fusion
from tactile_bullet.experiments.active import GRASPS, OUT_OF_FAMILY, columns, is_right, score_column
from tactile_bullet.experiments.fusion import settled
from tactile_bullet.learn.default import default_model

TOLERANCE = 4
"""Out-of-family objects the rule may lose per count (5% of the full scale's 80)."""


def old_rule(row: dict) -> dict:
    """The row's grasps fused with each grasp's own ``unknown`` (the rule before the switch):
    per object, unknown after each count, and right and unknown where the stopping rule
    stops; and each count's fused shape, to check against the run's."""
    unknown, stop_right, stop_unknown, shapes = [], [], [], []
    for made in row["made"]:
        fused = fused_after_each(made, RULES["distinct"])
        unknown.append([bool(f["unknown"]) for f in fused])
        shapes.append([f["shape"] for f in fused])
        stop = next((k for k, f in enumerate(fused) if settled(f)), len(fused) - 1)
        stop_right.append(is_right(fused[stop], made["truth"]))
        stop_unknown.append(bool(fused[stop]["unknown"]))
    return {"unknown": unknown, "stop_right": stop_right, "stop_unknown": stop_unknown,
            "shapes": shapes}  # fmt: skip


def counts(arm: dict) -> dict:
    """Objects unknown after each count and at the stop, and right at the stop."""
    return {"unknown": [sum(u[k] for u in arm["unknown"]) for k in range(GRASPS)],
            "stop_unknown": sum(arm["stop_unknown"]), "stop_right": sum(arm["stop_right"])}


def verdict(table: dict[str, dict[str, dict]]) -> tuple[bool, list[str]]:
    """The declared rule on ``{column: {"old": counts, "new": counts}}``."""
    inside = [c for c in table if c != OUT_OF_FAMILY]
    fell = sum(table[c]["old"]["unknown"][k] - table[c]["new"]["unknown"][k]
               for c in inside for k in (1, 2))  # fmt: skip
    checks = [f"(a) in-family objects unknown after 2 and 3 grasps, summed: {-fell:+d} "
              "(needs <= -1)"]  # fmt: skip
    ok = fell >= 1
    stop = sum(table[c]["new"]["stop_right"] - table[c]["old"]["stop_right"] for c in inside)
    oof = table.get(OUT_OF_FAMILY)
    if oof is not None:
        lost = [oof["old"]["unknown"][k] - oof["new"]["unknown"][k] for k in (1, 2)]
        checks.append(f"(b) out-of-family objects no longer unknown after 2 / 3 grasps: "
                      f"{lost[0]} / {lost[1]} (at most {TOLERANCE} each)")  # fmt: skip
        ok &= max(lost) <= TOLERANCE
        oof_stop = oof["new"]["stop_right"] - oof["old"]["stop_right"]
    else:
        checks.append("(b) no out-of-family column: not judged")
        ok, oof_stop = False, 0
    checks.append(f"(c) right with the stopping rule: in family {stop:+d} (must not fall), out "
                  f"of family {oof_stop:+d} (at most {TOLERANCE} fewer)")  # fmt: skip
    ok &= stop >= 0 and oof_stop >= -TOLERANCE
    return bool(ok), checks


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scale", default="full", help="the protocol's scale (tiny, quick, full)")
    ap.add_argument("--seed", type=int, default=7, help="the protocol's --seed")
    ap.add_argument("--other-hand", action="append", default=[], metavar="NAME=FILE")
    ap.add_argument("--columns", help="columns, comma-separated (default: every one)")
    ap.add_argument("--json", help="write every row and the verdict here as well")
    args = ap.parse_args(argv)
    provenance(argv)
    hands = dict(h.split("=", 1) for h in args.other_hand)
    model = default_model()
    fusion.UNKNOWN_AGAINST_FUSED = True
    table: dict[str, dict[str, dict]] = {}
    rows: dict[str, dict] = {}
    with tempfile.TemporaryDirectory() as tmp:
        cols = columns(args.scale, hands, args.seed, Path(tmp))
        for name in args.columns.split(",") if args.columns else list(cols):
            controller, objects = cols[name]
            started = time.perf_counter()
            row, _ = score_column(objects, controller, model, "planned", args.seed)
            row = json.loads(json.dumps(row))  # as active.json keeps it
            old = old_rule(row)
            if old["shapes"] != row["shapes"]:
                raise SystemExit(f"{name}: the grasps fused again give other shapes than the "
                                 "run's; stopping")  # fmt: skip
            table[name] = {"old": counts(old), "new": counts(row)}
            rows[name] = row
            o, n = table[name]["old"], table[name]["new"]
            print(f"{name:13s} objects {row['objects']:3d}  unknown after 1/2/3 grasps "
                  f"{'/'.join(map(str, o['unknown']))} -> {'/'.join(map(str, n['unknown']))}; "
                  f"at the stop {o['stop_unknown']} -> {n['stop_unknown']}; right with "
                  f"stopping {o['stop_right']} -> {n['stop_right']} "
                  f"({time.perf_counter() - started:.0f} s)", flush=True)  # fmt: skip
    kept, checks = verdict(table)
    print("\n".join(checks))
    print("declared rule:", "kept" if kept else "reverted")
    if args.json:
        Path(args.json).write_text(json.dumps({"seed": args.seed, "scale": args.scale,
                                               "table": table, "rows": rows, "kept": kept},
                                              indent=1))  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
