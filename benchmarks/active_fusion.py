"""Other ways of fusing the ``active`` protocol's grasps, scored offline on a run's own grasps.

An ``active`` run (``tactile-bullet benchmark --protocol active --out OUT``) keeps, for every
object and next-pose strategy, each grasp's pose and own answer (``rows[].made``). This script
first finds the rule the run fused with (``product`` before the eighth session's change,
``distinct`` after it), which must give back the run's own ``right`` table on every row (it
stops otherwise; the ``+simulated`` rows, fused by simulation, and the ``out-of-family`` rows,
right where unknown, are left out), then fuses the
grasps by each rule and prints the share of objects right after 1, 2 and 3 grasps per column
and strategy, and with the stopping rule. The alternatives are written here, not in the
package: a rule picked from these figures is picked on these objects, and a run on other
objects (another ``--seed``) is what judges it.

Rules: ``product`` (the grasps' smoothed probabilities multiplied, every grasp counted),
``distinct`` (the same over each distinct grasp once, a repeated pose left out: the rule
declared before seed 5 in docs/exploration.md), ``vote`` (each grasp's named shape counts one,
ties broken by the summed probabilities: two unsure misreads outvote one sure right read, or
the other way round, by count alone) and ``surest`` (the answer of the grasp whose best
probability is highest, alone). Then, per strategy, the in-family objects by the kind of move
their second grasp made (turn, shift, repeat) and what it gained; last, per row, how many
objects' second, third, ... grasp was made at a pose already grasped.

Usage: python benchmarks/active_fusion.py OUT [OUT ...]
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from _report import provenance  # first: this checkout ahead of an installed copy

from tactile_bullet.experiments.active import is_right
from tactile_bullet.experiments.fusion import fused_answer, probabilities, settled


def _product(model, answers: Sequence[dict]) -> dict:
    return fused_answer(model, answers)


def _surest(model, answers: Sequence[dict]) -> dict:
    rows = [probabilities(model, a) for a in answers]
    sure = int(np.argmax([r.max() for r in rows]))
    return fused_answer(model, [answers[sure]])


def _vote(model, answers: Sequence[dict]) -> dict:
    classes = list(model.classes)
    counts = np.zeros(len(classes))
    summed = np.zeros(len(classes))
    for a in answers:
        p = probabilities(model, a)
        counts[int(np.argmax(p))] += 1
        summed += p
    best = classes[int(np.lexsort((-summed, -counts))[0])]
    return {
        "shape": best,
        "ambiguous": None if counts.max() * 2 > len(answers) else [best],
        "unknown": sum(bool(a.get("unknown")) for a in answers) * 2 >= len(answers),
    }


def _distinct(model, answers: Sequence[dict]) -> dict:
    """The product over each distinct grasp once (``exploration.FUSE_REPEATS`` off): a grasp
    at a pose already grasped is the same grasp in simulation (each object's grasps share a
    seed), so it is left out; ``grasps`` still counts every grasp made."""
    seen, keep = [], []
    for a in answers:
        if a["pose"] not in seen:
            seen.append(a["pose"])
            keep.append(a)
    return fused_answer(model, keep) | {"grasps": len(answers)}


RULES: dict[str, Callable] = {"product": _product, "distinct": _distinct, "vote": _vote,
                              "surest": _surest}  # fmt: skip


def _answers(made: dict) -> list[dict]:
    return [{"shape": g["shape"], "probabilities": g["probabilities"], "unknown": g["unknown"],
             "ambiguous": g["ambiguous"], "renamed_from": g.get("renamed_from"),
             "pose": g["pose"]} for g in made["grasps"]]  # fmt: skip


def fused_after_each(made: dict, rule: Callable) -> list[dict]:
    """One object's grasps (a row's ``made`` entry) fused by ``rule`` after 1, 2, ... of them."""
    answers = _answers(made)
    model = SimpleNamespace(classes=list(answers[0]["probabilities"] or {}))
    return [rule(model, answers[: k + 1]) for k in range(len(answers))]


def score(row: dict, rule: Callable) -> tuple[list[float], float, list[list[bool]]]:
    """(share right after each count, share right with the stopping rule, per object right
    after each count) of one row's grasps fused by ``rule``."""
    after, stopped, right = [], [], []
    for made in row["made"]:
        fused = fused_after_each(made, rule)
        right.append([is_right(f, made["truth"]) for f in fused])
        stop = next((k for k, f in enumerate(fused) if settled(f)), len(fused) - 1)
        stopped.append(is_right(fused[stop], made["truth"]))
    after = np.mean(np.array(right, float), axis=0).tolist()
    return after, float(np.mean(stopped)), right


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__.strip().splitlines()[-1])
        return 2
    provenance()
    for out in argv:
        doc = json.loads((Path(out) / "active.json").read_text())
        # a +simulated row fused its later grasps by simulation, not by their own answers
        rows = [r for r in doc["rows"] if "made" in r and "+" not in r["strategy"]]
        # an object of no family is right where the fused answer is unknown, which since seed
        # 7 judges each grasp's contacts against the fused family: the grasps' own answers
        # cannot give it back (benchmarks/active_unknown.py scores that column)
        rows = [r for r in rows if all(m["truth"] is not None for m in r["made"])]
        if not rows:
            print(f"{out}: no grasps kept (a run written before rows kept them)")
            continue
        own = next((name for name in ("product", "distinct")
                    if all(score(row, RULES[name])[2] == [[bool(v) for v in r]
                                                           for r in row["right"]]
                           for row in rows)), None)  # fmt: skip
        if own is None:
            print(f"{out}: neither the product nor the distinct rule gives back the run's own "
                  "table; stopping")  # fmt: skip
            return 1
        print(f"{out} (seed {doc['config'].get('seed')}): the run fused by the {own} rule "
              f"(reproduced on {len(rows)} rows)")  # fmt: skip
        print("column          strategy            rule      objects  1 grasp 2 grasps "
              "3 grasps stopping")  # fmt: skip
        for row in rows:
            for name, rule in RULES.items():
                after, stop, _ = score(row, rule)
                cells = " ".join(f"{100 * v:7.1f}" for v in after)
                print(f"{row['column']:15s} {row['strategy']:19s} {name:9s} "
                      f"{len(row['made']):7d} {cells} {100 * stop:8.1f}")  # fmt: skip
        print("in-family objects by the second grasp's move (n, right after 2 minus after 1):")
        for strategy in sorted({r["strategy"] for r in rows}):
            found = second_moves([r for r in rows if r["strategy"] == strategy])
            print(f"{strategy:19s} " + ", ".join(f"{kind} n={n} {gain:+d}"
                                                 for kind, (n, gain) in found.items()))
        print("objects whose grasp k was made at a pose grasped before (k = 2, 3, ...):")
        for row in rows:
            print(f"{row['column']:15s} {row['strategy']:19s} "
                  + " ".join(str(n) for n in repeats(row)))  # fmt: skip
    return 0


def second_moves(rows: Sequence[dict]) -> dict[str, tuple[int, int]]:
    """Over ``rows``' objects: per kind of move from the first pose to the second (``turn``
    about the palm normal, ``shift`` along or across O-O', ``repeat``), how many objects were
    moved so and how many more were right after 2 grasps than after 1 (the figures the
    declaration before seed 8 was designed on, docs/exploration.md)."""
    found = {"turn": [0, 0], "shift": [0, 0], "repeat": [0, 0]}
    for row in rows:
        for made, right in zip(row["made"], row["right"], strict=True):
            first, second = made["grasps"][0]["pose"], made["grasps"][1]["pose"]
            if abs(second["rotation_deg"] - first["rotation_deg"]) > 1e-6:
                kind = "turn"
            elif second["offset"] != first["offset"]:
                kind = "shift"
            else:
                kind = "repeat"
            found[kind][0] += 1
            found[kind][1] += int(right[1]) - int(right[0])
    return {k: (n, gain) for k, (n, gain) in found.items()}


def repeats(row: dict) -> list[int]:
    """Per grasp after the first, how many of a row's objects were grasped there at a pose
    they had been grasped at before (the same grasp again, in simulation)."""
    counts = [0] * (max(len(m["grasps"]) for m in row["made"]) - 1)
    for made in row["made"]:
        poses = [g["pose"] for g in made["grasps"]]
        for k in range(1, len(poses)):
            counts[k - 1] += poses[k] in poses[:k]
    return counts


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
