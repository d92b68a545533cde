"""Write the default identifier (package data) from a robustness matrix's winner.

Reads the matrix's ``robustness.json`` (``tactile-bullet benchmark --protocol robustness
--out OUT``), trains the method it names as the default on the same training sets (read from
the matrix's cache, so the shipped model is the one the matrix scored), calibrates its doubt
and novelty, and writes ``tactile_bullet/data/default_model.npz`` with
``default_model.json`` beside it (the method, its figures in every column, the matrix's
command and the model's sha256, which the package checks before using it), and
``default_training.npz``: the training grasps' features and labels, without a noise-aware
training's noisy copies (``adapt``'s ``default-shifted`` way refits on them for every fold;
a knn keeps them itself, an svm does not).

With ``--pool OUT4,OUT5,...`` (other replicate runs' --out folders) the default is chosen
by the same rule on the runs' columns pooled with this one's (``robustness.pooled``: every
column's grasps of all the runs), as docs/robustness.md's pooled rule declares; it is still
trained on ``--matrix``'s training sets, which every replicate shares.

The default carries its second opinion (``learn/second_opinion.py``: an svm on
``robust-coupled-joints`` trained on the same grasps). ``--add-second-opinion --cache DIR``
gives the shipped default one without choosing or training it again: the training grasps
read from DIR must be the ones it was trained on (their features equal to
``default_training.npz``'s), else nothing is written.

Usage: python tools/make_default_model.py --matrix OUT [--pool OUT,...] [--cache OUT/data]
       [--no-write]
       python tools/make_default_model.py --add-second-opinion --cache OUT/data
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tactile_bullet.experiments import robustness as R  # noqa: E402
from tactile_bullet.learn.default import META_FILE, MODEL_FILE, TRAINING_FILE  # noqa: E402
from tactile_bullet.learn.models import save_model  # noqa: E402
from tactile_bullet.learn.second_opinion import SecondOpinion  # noqa: E402

DATA = ROOT / "tactile_bullet" / "data"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--matrix", help="the matrix's --out folder")
    ap.add_argument("--add-second-opinion", action="store_true",
                    help="give the shipped default its second opinion (needs --cache)")
    ap.add_argument("--cache", help="its grasp cache (default MATRIX/data)")
    ap.add_argument("--no-write", action="store_true", help="train and report, write nothing")
    ap.add_argument("--pool", default="", help="other replicate runs' folders to pool with it")
    args = ap.parse_args()
    if args.add_second_opinion:
        if not args.cache:
            sys.exit("--add-second-opinion reads the default's training grasps from --cache")
        add_second_opinion(Path(args.cache), args.no_write)
        return
    if not args.matrix:
        sys.exit("give --matrix (or --add-second-opinion)")
    matrix = Path(args.matrix)
    doc = json.loads((matrix / "robustness.json").read_text())
    best = doc["default"]
    runs = [doc] + [json.loads((Path(p) / "robustness.json").read_text())
                    for p in args.pool.split(",") if p]  # fmt: skip
    replicates = sorted(int(d["config"].get("replicate", 0)) for d in runs)
    if len(runs) > 1:
        if len(set(replicates)) != len(runs) or {d["config"]["scale"] for d in runs} != {"full"}:
            sys.exit("pool distinct full-scale replicate runs")
        pooled = R.pooled([d["rows"] for d in runs])
        best = R.winner(pooled)
        doc = {**doc, "rows": pooled}
    if best is None:
        sys.exit("the matrix names no default (no eligible method)")
    scale = doc["config"]["scale"]
    if scale != "full":
        sys.exit(f"the default is chosen at full scale; this matrix is {scale!r}")
    cache = Path(args.cache) if args.cache else matrix / "data"
    records = R.training_records(cache, scale, best["training"], int(doc["config"]["seed"]))
    row = next(r for r in doc["rows"] if r["method"] == best["method"]
               and r["training"] == best["training"])  # fmt: skip
    commit = _commit()
    info = {"default": {"method": best["method"], "training": best["training"]}}
    model = R.fit_model(best["descriptor"], best["params"], best["classifier"], records, info)
    model.second = SecondOpinion.fit(records, [str(r.shape) for r in records])
    print(f"{best['method']} ({best['training']}) on {len(records)} grasps; worst column "
          f"{100 * best['score']:.1f}%, mean {100 * best['mean']:.1f}%")
    print(f"doubt: {model.info['doubt'].get('margin')}, novelty threshold "
          f"{model.novelty.threshold:.3f}")
    if args.no_write:
        return
    path = save_model(DATA / MODEL_FILE, model)
    training = DATA / TRAINING_FILE
    # the grasps themselves: a noise-aware training's noisy copies left out
    grasps = R.training_records(cache, scale, best["training"], noisy=False)
    with open(training, "wb") as fh:
        np.savez_compressed(fh, features=np.asarray(model.features(grasps), dtype=float),
                            labels=np.array([str(r.shape) for r in grasps]))  # fmt: skip
    replicate = int(doc["config"].get("replicate", 0))
    meta = {
        "method": best["method"], "descriptor": best["descriptor"], "params": best["params"],
        "classifier": best["classifier"], "training": best["training"],
        "train_records": len(records), "score": best["score"], "mean": best["mean"],
        "columns": {k: v.get("accuracy") for k, v in row["columns"].items()},
        "out_of_family_unknown": row["columns"].get(R.OUT_OF_FAMILY, {}).get("unknown"),
        "matrix": "tactile-bullet benchmark --protocol robustness --scale full "
                  "--other-hand menagerie=M.xml,gymnasium=G.xml"
                  + (f" --replicate {replicate}" if replicate else "") + " --out OUT",
        "training_sha256": hashlib.sha256(training.read_bytes()).hexdigest(),
        "replicate": replicate,
        **({"pooled_replicates": replicates} if len(runs) > 1 else {}),
        "second_opinion": {"descriptor": model.second.descriptor,
                           "classifier": model.second.classifier},
        "generated_by": "tools/make_default_model.py", "commit": commit,
        "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
    }  # fmt: skip
    (DATA / META_FILE).write_text(json.dumps(meta, indent=2) + "\n")
    print(f"wrote {path} ({path.stat().st_size / 1024:.0f} KiB) and {DATA / META_FILE}")


def _commit() -> str:
    return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True).stdout.strip()  # fmt: skip


def add_second_opinion(cache: Path, no_write: bool) -> None:
    """The shipped default, unchanged but for the second opinion fitted on its own training
    grasps (checked against ``default_training.npz`` first)."""
    from tactile_bullet.learn.default import default_meta, default_model

    meta = default_meta()
    model = default_model()
    grasps = R.training_records(cache, "full", meta["training"], noisy=False)
    with np.load(DATA / TRAINING_FILE) as kept:
        same = kept["features"].shape == (len(grasps), kept["features"].shape[1]) and np.allclose(
            model.features(grasps), kept["features"], rtol=0, atol=1e-12)
    if not same:
        sys.exit(f"{cache} does not hold the default's training grasps (their features differ "
                 f"from {TRAINING_FILE}'s)")
    records = R.training_records(cache, "full", meta["training"])
    model.second = SecondOpinion.fit(records, [str(r.shape) for r in records])
    print(f"second opinion: {model.second.descriptor} + {model.second.classifier} on "
          f"{len(records)} training rows (the default's, checked)")
    if no_write:
        return
    path = save_model(DATA / MODEL_FILE, model)
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    meta = {**meta, "second_opinion": {"descriptor": model.second.descriptor,
                                       "classifier": model.second.classifier},
            "commit": _commit(), "sha256": digest}  # fmt: skip
    (DATA / META_FILE).write_text(json.dumps(meta, indent=2) + "\n")
    print(f"wrote {path} ({path.stat().st_size / 1024:.0f} KiB) and {DATA / META_FILE}")


if __name__ == "__main__":
    main()
