"""Size and position invariance of the signature, and the training-free identification rate.

Simulates the five thesis shapes over a grid of sizes (every parameter at the same fraction of
its range) and offsets of the object along O-O' (x) and along the fingers (z), computes each
grasp's signature and its DTW distances to the five theoretical patterns, and reports:

- the nearest-pattern identification rate, overall and per size and offset (thesis Table 2.2's
  analogue: the ranges where identification holds), printed and written to
  docs/signature_invariance.{json,md};
- the distance of each shape's signatures to every pattern (thesis Fig. 2.21) and the same for
  the modified shapes ovoid and hexagonal pyramid (Fig. 2.27), in docs/img/;
- the identification thresholds (integral rule: the mean of the hyperboloid's and cylinder's
  mean bulge, as the thesis set it, on whichever line, lower or upper, splits them best, or
  off if neither helps; correspondence: the largest distance of a correct match),
  written to tactile_bullet/data/identification.json for ``patterns.identify``.

The second training-free identifier, ``shape_fit.fit_shape`` (each family's sizes, offset and
rotation fitted to the absolute J3 and J1 + J2 angles), runs on the same grasps: its rate,
confusion and fitted-size errors (of the true family's fit) are a section of the same page.
``--identifier fit`` puts its names in the main tables instead (printed only: the thresholds and
ranges in identification.json are the DTW matcher's).

Usage: python tools/invariance.py [--workers 2] [--cache /tmp/invariance.json] [--quick]
[--correction none|position|dynamic] [--identifier dtw|fit] (about 1 min on 2 cores; --cache
reuses simulated angles between runs). ``--correction`` identifies each grasp on its signature
with the fingers that detector (thesis ch. 3) finds out of contact dropped; it prints only, and
writes nothing. ``--identifier fit`` fills the main tables with the shape fit's names (prints
only).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter, defaultdict
from multiprocessing import Pool
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tactile_bullet.objects.shapes import BUILTIN_SHAPES, THESIS_SHAPES  # noqa: E402
from tactile_bullet.perception.patterns import (  # noqa: E402
    INTEGRAL_PAIR,
    Thresholds,
    identify,
    size_matched_library,
)
from tactile_bullet.perception.signature import signature_from_angles  # noqa: E402

TABLE = {s.name: s for s in BUILTIN_SHAPES}
SIZE_FRACTIONS = (0.0, 0.25, 0.5, 0.75, 1.0)
OFFSETS_X = (-0.01, 0.0, 0.01)
OFFSETS_Z = (-0.01, 0.0, 0.01)
MODIFIED = ("ovoid", "hexagonal_pyramid")
HOLDS = 0.9
"""Identification rate from which a size or offset counts as inside the valid range."""


def sized(name: str, t: float) -> dict[str, float] | None:
    """Every parameter at fraction t of its range; None when the combination is invalid."""
    spec = TABLE[name]
    params = {k: p.min + t * (p.max - p.min) for k, p in spec.params.items()}
    try:
        return spec.resolve(params)
    except ValueError:
        return None


def grasp_job(job: tuple) -> dict:
    """One grasp (run in a worker): its final FCI angles or why it failed."""
    from tactile_bullet.perception.temporal import DETECTORS, detect
    from tactile_bullet.records import Pose
    from tactile_bullet.sim.grasp import simulate_grasp

    name, t, params, offset = job
    out = {"shape": name, "t": t, "params": params, "offset": list(offset)}
    try:
        rec = simulate_grasp(TABLE[name], params, Pose(offset))
    except ValueError as exc:  # a pose the scene refuses (object inside the open hand)
        out["error"] = str(exc)
        return out
    out["angles"] = rec.fci_angles().tolist()
    out["keep"] = {m: detect(rec, m).contact_mask.tolist() for m in DETECTORS}
    out["flags"] = list(rec.flags)
    out["fingers"] = list(rec.fingers_in_contact)
    return out


def jobs(quick: bool) -> list[tuple]:
    fractions = (0.0, 0.5, 1.0) if quick else SIZE_FRACTIONS
    todo = []
    for name in (*THESIS_SHAPES, *MODIFIED):
        offsets = [(x, 0.0, z) for x in OFFSETS_X for z in OFFSETS_Z]
        if name in MODIFIED or quick:
            offsets = [(0.0, 0.0, 0.0)]
        for t in fractions:
            params = sized(name, t)
            if params is not None:
                todo.extend((name, t, params, off) for off in offsets)
    return todo


def simulate(todo: list[tuple], workers: int, cache: Path | None) -> list[dict]:
    key = lambda j: json.dumps([j[0], j[1], j[3]])  # noqa: E731
    done: dict[str, dict] = {}
    if cache is not None and cache.is_file():
        for row in json.loads(cache.read_text()):
            if "angles" in row and "keep" not in row:  # cached before the detectors ran
                continue
            done[json.dumps([row["shape"], row["t"], row["offset"]])] = row
    missing = [j for j in todo if key((j[0], j[1], j[2], list(j[3]))) not in done]
    if missing:
        start = time.perf_counter()
        with Pool(workers) as pool:
            for row in pool.imap(grasp_job, missing, chunksize=2):
                done[json.dumps([row["shape"], row["t"], row["offset"]])] = row
        rate = len(missing) / (time.perf_counter() - start)
        print(f"simulated {len(missing)} grasps at {rate:.1f} grasps/s ({workers} workers)")
    rows = [done[key((j[0], j[1], j[2], list(j[3])))] for j in todo]
    if cache is not None:
        cache.write_text(json.dumps(rows))
    return rows


def signature_and_library(row: dict, correction: str, lib):
    """The row's signature and the patterns to compare it with, after ``correction``."""
    from tactile_bullet.perception.temporal import corrected_library, corrected_signature

    angles = np.array(row["angles"])
    keep = np.asarray(row["keep"][correction] if correction != "none" else [True] * 4)
    if correction == "none" or keep.all() or keep.sum() < 2:
        return signature_from_angles(angles), lib
    return corrected_signature(angles, keep), corrected_library(keep)


def analyse(rows: list[dict], correction: str = "none") -> dict:
    """Distances, nearest patterns and both thresholds from the simulated grasps.

    Integral rule: for each line, the threshold is the mean of the hyperboloid's and the
    cylinder's mean bulge (the thesis' rule); the line kept is the one that gets the most of
    those two shapes right, "none" (rule off) if neither beats the nearest pattern alone.
    """
    lib = size_matched_library()
    graspable = [r for r in rows if "angles" in r]
    sigs, libs = {}, {}
    for k, row in enumerate(graspable):
        sig, libs[k] = signature_and_library(row, correction, lib)
        plain = identify(sig, libs[k], Thresholds(integral_line="none"))
        row["distances"] = plain.distances
        row["nearest"] = plain.nearest
        sigs[k] = sig
    pair = [k for k, r in enumerate(graspable) if r["shape"] in INTEGRAL_PAIR]
    options = {}
    for line in ("upper", "lower", "none"):
        if line == "none":
            cut = 0.0
        else:
            means = [
                np.mean(
                    [getattr(sigs[k], f"bulge_{line}") for k in pair if graspable[k]["shape"] == n]
                )  # fmt: skip
                for n in INTEGRAL_PAIR
            ]
            cut = float(np.mean(means))
        th = Thresholds(integral=cut, integral_line=line)
        right = sum(identify(sigs[k], libs[k], th).name == graspable[k]["shape"] for k in pair)
        options[line] = (right, cut)
    line = max(options, key=lambda n: options[n][0])  # first best: upper, lower, then none
    th = Thresholds(integral=options[line][1], integral_line=line)
    for k, row in enumerate(graspable):
        row["identified"] = identify(sigs[k], libs[k], th).name
    correct = [
        r["distances"][r["shape"]]
        for r in graspable
        if r["shape"] in THESIS_SHAPES and r["identified"] == r["shape"]
    ]
    return {
        "integral_threshold": th.integral,
        "integral_line": line,
        "integral_options": {
            n: {"pair_right": v[0], "threshold": v[1]} for n, v in options.items()
        },
        "pair_grasps": len(pair),
        "correspondence_threshold": float(np.max(correct)) if correct else float("inf"),
    }


def fit_rows(rows: list[dict]) -> float:
    """Shape-fit identification of every graspable thesis-shape row (``fit_identified``,
    ``fit_params``: the true family's fitted sizes); returns the median seconds per grasp."""
    from tactile_bullet.perception.shape_fit import fit_shape

    times = []
    for row in rows:
        if "angles" not in row or row["shape"] not in THESIS_SHAPES:
            continue
        start = time.perf_counter()
        fit = fit_shape(np.array(row["angles"]))
        times.append(time.perf_counter() - start)
        row["fit_identified"] = fit.shape
        row["fit_params"] = fit.fits[row["shape"]].params
    return float(np.median(times)) if times else float("nan")


def size_errors(rows: list[dict]) -> dict:
    """Per shape and size parameter: mean absolute (mm) and mean relative error of the true
    family's fitted size."""
    out = {}
    for name in THESIS_SHAPES:
        mine = [r for r in rows if r["shape"] == name and "fit_params" in r]
        if not mine:
            continue
        out[name] = {
            k: {
                "mean_abs_mm": float(
                    np.mean([abs(r["fit_params"][k] - r["params"][k]) for r in mine]) * 1000
                ),
                "mean_rel": float(
                    np.mean(
                        [abs(r["fit_params"][k] - r["params"][k]) / r["params"][k] for r in mine]
                    )
                ),  # fmt: skip
            }
            for k in TABLE[name].params
        }
    return out


def fit_markdown(report: dict) -> str:
    """The shape-fit section of the page."""
    fit = report["shape_fit"]
    lines = [
        "",
        "## Second identifier: size and position fit to the absolute angles",
        "",
        "`shape_fit.fit_shape` (classifier `shape-fit` on the `raw-joints` or "
        "`robust-joints` descriptor; `grasp --json` block `shape_fit`) keeps the scale the "
        "signature's normalisation removes. For each family it searches the sizes and the "
        "object's pose (offset along O-O' within +-20 mm and along the fingers within +-15 mm, "
        "rotation about the palm normal within +-30 deg, with a 15 deg Gaussian prior) "
        "whose predicted J3 and J1 + J2 "
        "per long finger best match the measured ones: each finger closes as Algorithm 1 "
        "closes it, a chain of the URDF's capsules turning joint by joint until it meets the "
        "object's section (theta = s / r(x) played out on the hand's own knuckles), and a "
        "finger with nothing under it closes to its limits, so a far finger is predicted "
        "rather than corrupting the fit. A per-finger linear correction of that geometry "
        "(and the weights of each angle, the robust loss and the penalty per size parameter) "
        "comes from `tools/shape_fit_calibration.py` on thesis-preset grasps that are not on "
        "this grid (`tactile_bullet/data/shape_fit.json`). The family with the lowest "
        "penalised score is the answer. A turned object's section in each finger's plane is "
        "measured where it is widest (on a steep profile, a torus near its ends, that point "
        "moves away from the axis). The calibration uses unrotated grasps only: "
        "`python tools/shape_fit_calibration.py --data DIR --no-write` prints both "
        "identifiers' rates on a thesis-preset dataset's rotated grasps (none are on this "
        "grid), per rotation.",
        "",
        f"It names {fit['overall_rate']:.1%} of the same {report['grasps']} "
        f"grasps (the DTW matcher above: {fit['dtw_rate']:.1%}); median "
        f"{fit['median_ms']:.1f} ms per grasp in this run (a shared machine: see "
        "`benchmarks/bench_signature.py` for the ratio to DTW). Per shape, rate and by size "
        "fraction (0 .. 1):",
        "",
        "| shape | rate | by size fraction (0 .. 1) |",
        "|---|---|---|",
    ]
    for name, v in fit["shapes"].items():
        sizes = " ".join(
            f"{s['rate']:.0%}" if s["n"] else "-" for s in v["by_size_fraction"].values()
        )
        lines.append(f"| {name} | {v['rate']:.0%} | {sizes} |")
    lines += ["", "Confusion (rows: true shape, columns: identified by the fit):", ""]
    for name, row in fit["confusion"].items():
        lines.append(f"- {name}: {row}")
    lines += [
        "",
        "Fitted size error of the true family's fit (mean absolute, mean relative). The "
        "hyperboloid's profile fixes its waist and its curvature, not end radius and length "
        "apart, and the fingers (within +-43 mm of the centre) never reach the end of most "
        "cylinders and cones, so those lengths are barely observed:",
        "",
        "| shape | parameter | mean abs error | mean relative error |",
        "|---|---|---|---|",
    ]
    for name, params in fit["size_errors"].items():
        for k, v in params.items():
            lines.append(f"| {name} | {k} | {v['mean_abs_mm']:.1f} mm | {v['mean_rel']:.0%} |")
    return "\n".join(lines) + "\n"


def rate(rows: list[dict]) -> tuple[float, int]:
    got = [r for r in rows if "identified" in r]
    if not got:
        return float("nan"), 0
    return float(np.mean([r["identified"] == r["shape"] for r in got])), len(got)


def ranges(rows: list[dict]) -> dict:
    """Per shape: identification rate per size fraction and per offset, and the valid ranges."""
    out = {}
    for name in THESIS_SHAPES:
        mine = [r for r in rows if r["shape"] == name]
        spec = TABLE[name]
        by_size = {}
        for t in sorted({r["t"] for r in mine}):
            rt, n = rate([r for r in mine if r["t"] == t])
            by_size[t] = {"rate": rt, "n": n, "params": sized(name, t)}
        by_offset = {}
        for off in sorted({tuple(r["offset"]) for r in mine}):
            rt, n = rate([r for r in mine if tuple(r["offset"]) == off])
            by_offset[",".join(f"{v * 1000:+.0f}" for v in off)] = {"rate": rt, "n": n}
        good = [t for t, v in by_size.items() if v["n"] and v["rate"] >= HOLDS]
        valid_params = (
            {k: [sized(name, min(good))[k], sized(name, max(good))[k]] for k in spec.params}
            if good
            else None
        )
        failed = sum(1 for r in mine if "angles" not in r)
        out[name] = {
            "rate": rate(mine)[0],
            "grasps": len(mine) - failed,
            "refused_poses": failed,
            "by_size_fraction": by_size,
            "by_offset_mm": by_offset,
            "sizes_where_identification_holds": valid_params,
        }
    return out


def confusion(rows: list[dict]) -> dict[str, dict[str, int]]:
    table: dict[str, Counter] = defaultdict(Counter)
    for r in rows:
        if "identified" in r:
            table[r["shape"]][r["identified"]] += 1
    return {k: dict(v) for k, v in table.items()}


def plot_distances(rows: list[dict], shapes, path: Path, title: str) -> None:
    """Per measured shape, the DTW distance of its signatures to each theoretical pattern."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    patterns = list(THESIS_SHAPES)
    fig, axes = plt.subplots(1, len(shapes), figsize=(2.6 * len(shapes), 2.8), sharey=True)
    axes = np.atleast_1d(axes)
    for ax, name in zip(axes, shapes, strict=True):
        data = [[r["distances"][p] for r in rows if r["shape"] == name and "distances" in r]
                for p in patterns]  # fmt: skip
        if data and data[0]:
            ax.boxplot(data, widths=0.6, showfliers=True, flierprops={"markersize": 2})
        ax.set_xticks(range(1, len(patterns) + 1), [p[:5] for p in patterns], rotation=60)
        ax.set_title(name.replace("_", " "), fontsize=9)
        ax.tick_params(labelsize=7)
    axes[0].set_ylabel("DTW distance to pattern", fontsize=8)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def markdown(report: dict) -> str:
    valid_shapes = ", ".join(report["shapes_with_valid_sizes"]) or "none"
    lines = [
        "# Signature invariance (generated by tools/invariance.py)",
        "",
        f"Nearest-pattern identification without training: {report['overall_rate']:.1%} of "
        f"{report['grasps']} grasps of the five thesis shapes over sizes (every parameter at "
        f"0, 25, 50, 75, 100% of its range) and offsets x, z in {{-10, 0, +10}} mm. Sizes "
        f"where a shape's rate reaches 90% exist for: {valid_shapes}.",
        f"Integral rule: {report['thresholds']['integral_line']} line, threshold "
        f"{report['thresholds']['integral_threshold']:.4f} (hyperboloid/cylinder grasps right "
        f"of {report['thresholds']['pair_grasps']}: "
        + ", ".join(
            f"{k} {v['pair_right']}" for k, v in report["thresholds"]["integral_options"].items()
        )
        + "); "
        f"correspondence threshold: {report['thresholds']['correspondence_threshold']:.2f}.",
        "",
        f"Inside the sizes where identification holds it names {report['rate_in_those_sizes']:.0%} "
        "of the grasps. Those sizes ship with the package (`tactile_bullet/data/"
        "identification.json`): `tactile-bullet shapes` prints them beside each parameter's "
        "valid range, and `grasp --json` says whether a grasp lies inside them "
        "(`signature.in_identification_range`). They are not written over the valid ranges: "
        "for the sphere and the cylinder they are a single size, and training needs the rest.",
        "",
        "| shape | rate | by size fraction (0 .. 1) | sizes where identification holds (>= 90%) |",
        "|---|---|---|---|",
    ]
    for name, v in report["shapes"].items():
        sizes = " ".join(
            f"{s['rate']:.0%}" if s["n"] else "-" for s in v["by_size_fraction"].values()
        )
        valid = v["sizes_where_identification_holds"]
        text = (
            ", ".join(f"{k} {lo * 1000:.0f}-{hi * 1000:.0f} mm" for k, (lo, hi) in valid.items())
            if valid
            else "none"
        )
        lines.append(f"| {name} | {v['rate']:.0%} | {sizes} | {text} |")
    lines += ["", "Rate by offset (x, y, z in mm):", ""]
    offsets = next(iter(report["shapes"].values()))["by_offset_mm"].keys()
    lines.append("| shape | " + " | ".join(offsets) + " |")
    lines.append("|---" * (len(offsets) + 1) + "|")
    for name, v in report["shapes"].items():
        cells = [
            f"{v['by_offset_mm'][o]['rate']:.0%}" if v["by_offset_mm"].get(o, {}).get("n") else "-"
            for o in offsets
        ]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines += ["", "Confusion (rows: true shape, columns: identified):", ""]
    for name, row in report["confusion"].items():
        lines.append(f"- {name}: {row}")
    lines += ["", "Modified shapes, mean DTW distance to each pattern:", ""]
    for name, d in report["modified_shapes"].items():
        lines.append(f"- {name}: " + ", ".join(f"{k} {v:.1f}" for k, v in d.items()))
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--cache", type=Path, default=None, help="JSON of simulated angles to reuse")
    ap.add_argument("--quick", action="store_true", help="3 sizes, centred only (smoke run)")
    ap.add_argument("--no-write", action="store_true", help="print only")
    ap.add_argument(
        "--correction", choices=("none", "position", "dynamic"), default="none",
        help="drop the fingers this detector finds out of contact (prints only)",
    )  # fmt: skip
    ap.add_argument(
        "--identifier", choices=("dtw", "fit"), default="dtw",
        help="whose names fill the main tables (fit: printed only)",
    )  # fmt: skip
    args = ap.parse_args()

    rows = simulate(jobs(args.quick), args.workers, args.cache)
    thresholds = analyse(rows, args.correction)
    thesis_rows = [r for r in rows if r["shape"] in THESIS_SHAPES]
    median_s = fit_rows(thesis_rows)
    dtw_rate = rate(thesis_rows)[0]
    for r in thesis_rows:
        r["dtw_identified"] = r.get("identified")
    fitted = [dict(r, identified=r["fit_identified"]) for r in thesis_rows if "fit_identified" in r]
    fit_report = {
        "overall_rate": rate(fitted)[0],
        "dtw_rate": dtw_rate,
        "median_ms": median_s * 1000,
        "shapes": ranges(fitted),
        "confusion": confusion(fitted),
        "size_errors": size_errors(thesis_rows),
    }
    if args.identifier == "fit":
        thesis_rows = fitted
        args.no_write = True
    shapes = ranges(thesis_rows)
    inside = [
        r
        for r in thesis_rows
        if (v := shapes[r["shape"]]["sizes_where_identification_holds"]) is not None
        and all(v[k][0] - 1e-12 <= r["params"][k] <= v[k][1] + 1e-12 for k in v)
    ]
    modified = {
        name: {
            p: float(
                np.mean(
                    [r["distances"][p] for r in rows if r["shape"] == name and "distances" in r]
                )
            )  # fmt: skip
            for p in THESIS_SHAPES
        }
        for name in MODIFIED
    }
    overall, n = rate(thesis_rows)
    report = {
        "overall_rate": overall,
        "grasps": n,
        "shapes_with_valid_sizes": [
            k for k, v in shapes.items() if v["sizes_where_identification_holds"]
        ],
        "rate_in_those_sizes": rate(inside)[0],
        "thresholds": thresholds,
        "shapes": shapes,
        "confusion": confusion(thesis_rows),
        "modified_shapes": modified,
        "modified_identified": confusion([r for r in rows if r["shape"] in MODIFIED]),
        "shape_fit": fit_report,
    }
    print(markdown(report) + fit_markdown(report))
    if args.correction != "none":
        dropped = sum(not all(r["keep"][args.correction]) for r in thesis_rows if "keep" in r)
        print(f"correction {args.correction}: fingers dropped in {dropped} of {n} grasps")
    if args.no_write or args.correction != "none":
        return
    (ROOT / "docs" / "img").mkdir(parents=True, exist_ok=True)
    (ROOT / "docs" / "signature_invariance.json").write_text(
        json.dumps(report, indent=2, default=float) + "\n"
    )
    (ROOT / "docs" / "signature_invariance.md").write_text(markdown(report) + fit_markdown(report))
    data = {
        "correspondence_threshold": thresholds["correspondence_threshold"],
        "integral_threshold": thresholds["integral_threshold"],
        "integral_line": thresholds["integral_line"],
        "generated_by": "tools/invariance.py",
        "grasps": n,
        "identification_ranges": {
            k: v["sizes_where_identification_holds"]
            for k, v in shapes.items()
            if v["sizes_where_identification_holds"]
        },
    }
    path = ROOT / "tactile_bullet" / "data" / "identification.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=2) + "\n")
    plot_distances(
        thesis_rows, THESIS_SHAPES, ROOT / "docs" / "img" / "signature_distances.png",
        "DTW distance of simulated signatures to each theoretical pattern",
    )  # fmt: skip
    plot_distances(
        rows, MODIFIED, ROOT / "docs" / "img" / "modified_shapes_distances.png",
        "Modified shapes against the five patterns",
    )  # fmt: skip
    example_figures(ROOT / "docs" / "img")
    print(f"wrote docs/signature_invariance.md, .json, {path.relative_to(ROOT)}, docs/img/*.png")


def example_figures(folder: Path) -> None:
    """The pattern gallery and one default-size grasp per thesis shape (Figs 2.13, 2.18)."""
    from tactile_bullet.experiments.figures_signature import plot_grasp_signature, plot_patterns
    from tactile_bullet.sim.grasp import simulate_grasp

    plot_patterns(folder / "signature_patterns.png")
    for name in ("cone", "sphere", "cylinder"):
        plot_grasp_signature(simulate_grasp(TABLE[name]), folder / f"signature_{name}.png")


if __name__ == "__main__":
    main()
