"""The project's benchmarks and the experiments behind the figures the docs quote.

Each ``benchmarks/NAME.py`` is a script: its docstring says what it measures and how to run it
(``python benchmarks/NAME.py ...``), and it prints, before its figures, the command, the commit
and the date (``_report.provenance``). ``python -m benchmarks`` runs the fast ones (no dataset
needed, seconds each) and lists the others with what they need; ``python -m benchmarks
--list`` prints the catalogue. Maintainer scripts that write package data or models are in
``tools/``, not here.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

FOLDER = Path(__file__).resolve().parent

FAST: dict[str, tuple[str, ...]] = {
    "bench_signature": (),
    "bench_robust": (),
    "object_overfill": (),
    "profile_grasp": ("--engine", "bullet,mujoco", "--repeat", "1"),
    "bench_mesh": (),
    "bench_grasp": ("--repeat", "1"),
    "engine_difference": ("--per-shape", "8"),
    "bench_predict": ("--overhead-only",),
    "bench_fit_batch": ("--grasps", "64", "--repeat", "1"),
    "bench_revolution": ("--grasps", "100"),
    "bench_decision": ("--repeat", "1"),
    "bench_mujoco_cache": ("3",),
}
"""Benchmarks that need no dataset and finish in well under a minute on two cores, with the
arguments ``python -m benchmarks`` runs them with."""

NEEDS: dict[str, str] = {
    "pooled_matrix": "two or more full-scale robustness matrix runs' --out folders (each "
    "`benchmark --protocol robustness --scale full --replicate K`)",
    "unknown_by_rule": "a robustness matrix's cache (--cache DIR/data, --replicate K) or a "
    "labelled dataset (--data DIR); seconds",
    "axis_residual_figure": "a robustness matrix's cache (--cache DIR/data) with its training "
    "and out-of-family sets; seconds",
    "cylinder_cone_fit": "no dataset; simulates four cylinders (seconds)",
    "active_flips": "no dataset; explores the active protocol's objects (about 2 minutes for "
    "border and unseen-poses at full scale)",
    "active_fusion": "an `active` run's --out folder written since its rows keep each grasp "
    "(`tactile-bullet benchmark --protocol active --out DIR`); seconds",
    "active_pooled": "two or more `active` runs' --out folders, one seed each, written "
    "since rows keep each object's answers (`tactile-bullet benchmark --protocol active "
    "--seed K --out DIR`); seconds",
    "active_switch": "no dataset; explores the active protocol's objects twice, with a "
    "declared planner rule off and on (about 10 minutes at full scale with both other hands)",
    "active_unknown": "no dataset; explores the active protocol's objects once with the "
    "seed 7 unknown rule, the old rule scored on the same grasps (about 6 minutes at full scale "
    "with both other hands)",
    "unknown_rescue": "a full-scale robustness matrix's cache (--cache DIR/data, --replicate "
    "K); seconds",
    "bench_cross_check": "labelled datasets (`tactile-bullet generate --preset modified` or "
    "thesis, a robustness matrix's sets); seconds to a minute each",
    "own_hand_cross_check": "labelled datasets (--data, repeatable; a robustness matrix's "
    "robust-mujoco-test-rK set for the tenth replicate's judgement); seconds each",
    "torus_rule_design": "two or more full-scale robustness matrix runs' --out folders with "
    "their caches; about a minute",
    "torus_sphere_figure": "no dataset; simulates a MuJoCo torus and a Bullet ovoid and writes "
    "a picture (matplotlib; seconds)",
    "novelty_sizes": "a full-scale robustness matrix's cache (--cache DIR/data, --replicate "
    "K); a minute",
    "novelty_alternatives": "a full-scale robustness matrix's cache (--cache DIR/data), minutes",
    "cross_check_tolerance": "a full-scale robustness matrix's cache (--cache DIR/data, "
    "--replicate K); a few minutes",
    "second_opinion": "a full-scale robustness matrix's cache (--cache DIR/data, "
    "--replicate K); a few minutes",
    "out_of_family_mujoco": "a full-scale robustness matrix's cache (--cache DIR/data, "
    "--replicate K); simulates its two out-of-family sets in MuJoCo (about a minute)",
    "shape_fit_equivalence": "git (it loads the shape fit of --ref, default adcd9c0, beside this "
    "one); --data DIR adds a simulated set (e.g. generate --preset thesis), minutes",
    "closure_by_hand": "a full-scale robustness matrix's cache (`tactile-bullet benchmark "
    "--protocol robustness --other-hand ... --out DIR`, then --cache DIR/data)",
    "known_grasps": "a full-scale robustness matrix with both hands written by others "
    "(`tactile-bullet benchmark --protocol robustness --other-hand ... --out DIR`)",
    "adapt_hands": "a full-scale robustness matrix's cache with both hands written by others "
    "(`tactile-bullet benchmark --protocol robustness --other-hand ... --out DIR`, then "
    "--cache DIR/data)",
    "bench_accuracy": "no dataset; simulates the demo's protocol, minutes per seed",
    "bench_big_inputs": "no dataset; writes a ~440 MB recording and a 1.3M-triangle mesh, "
    "minutes and GBs of memory",
    "bench_coupling": "the sets of `tactile-bullet benchmark --protocol coupling-shift "
    "--training clean,randomized --out DIR` (--data DIR/data)",
    "bench_generate": "no dataset; builds a 100k-grasp dataset in a temporary folder (minutes)",
    "bench_generate_engines": "no dataset; simulates a 26-grasp sweep 3 times on each engine "
    "(about a minute)",
    "bench_recordings": "a dataset with time series (`tactile-bullet generate`)",
    "bench_streaming": "a dataset with time series (`tactile-bullet generate`)",
    "bench_temporal": "no dataset; simulates --grasps of a preset twice (~1.5 min for 60)",
    "bench_time_series": "the thesis preset (`tactile-bullet generate --preset thesis`)",
    "calibration_residuals": "a simulated set of another hand (benchmarks/other_hand_sets.py)",
    "doubt_report": "a `tactile-bullet benchmark` run's benchmark.json",
    "finger_points_figure": "sets of the same objects made by several hands "
    "(benchmarks/other_hand_sets.py --hand independent)",
    "first_per_shape": "any dataset or record folder (writes a new record folder)",
    "hand_calibration": "a set made by another hand (benchmarks/other_hand_sets.py)",
    "hand_difference": "a set made by another hand (benchmarks/other_hand_sets.py)",
    "other_hand_sets": "no dataset; simulates 120 grasps a hand (~1 min) into --out, the sets "
    "the hand benchmarks read; --hand independent needs a `convert-hand` model",
    "rotation_end_to_end": "no dataset; simulates rotated grasps, ~30 s a size on two cores",
    "tour_time": "no dataset; runs the README tour in a fresh folder (~8 min on 2 cores)",
    "sequential_experiment": "a dataset (--data DIR) or --synthetic; the `sequential` command",
    "signature_limits": "the full-scale sets a `tactile-bullet benchmark` run caches (--cache)",
    "transfer_table": "the sets a `tactile-bullet benchmark` run caches (--cache)",
}
"""What each of the other benchmarks needs before it can run."""


@dataclass(frozen=True)
class Benchmark:
    """One script of the catalogue: its name, what it measures (its docstring's first
    sentence) and its usage lines (the docstring's ``python benchmarks/NAME.py`` lines)."""

    name: str
    path: Path
    summary: str
    usage: tuple[str, ...]

    @property
    def fast(self) -> bool:
        return self.name in FAST


def catalogue() -> list[Benchmark]:
    """Every benchmark script in this folder, by name."""
    out = []
    for path in sorted(FOLDER.glob("*.py")):
        if path.name.startswith("_"):
            continue
        doc = ast.get_docstring(ast.parse(path.read_text())) or ""
        summary = " ".join(doc.split("\n\n")[0].split())
        usage = tuple(_usage_lines(doc, path.name))
        out.append(Benchmark(path.stem, path, summary, usage))
    return out


def _usage_lines(doc: str, script: str):
    """The docstring's commands that run ``script``, each joined with its continuation lines
    (a line ending in a backslash, or an indented line of options under a ``Usage:`` line)."""
    lines = doc.splitlines()
    i = 0
    while i < len(lines):
        text = lines[i].strip().removeprefix("Usage:").strip()
        i += 1
        if not text.startswith(f"python benchmarks/{script}"):
            continue
        parts = [text]
        while i < len(lines) and (
            parts[-1].endswith("\\") or lines[i].strip().startswith(("[", "--"))
        ):
            parts[-1] = parts[-1].removesuffix("\\").rstrip()
            parts.append(lines[i].strip())
            i += 1
        yield " ".join(p for p in parts if p).split("  #")[0].split("   (")[0].strip()
