"""What every benchmark prints beside its figures: the command that produced them, the commit
it ran on and when, so a figure the docs quote can be traced and run again.

Importing this module also puts the checkout on ``sys.path`` ahead of any installed copy, so
``python benchmarks/x.py`` measures this checkout's ``tactile_bullet`` (and a benchmark finds
its neighbours, e.g. ``transfer_table``). Every benchmark imports it before the package.
"""

from __future__ import annotations

import shlex
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from datetime import UTC, datetime
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
"""The repository root: ``benchmarks/``'s parent."""

for folder in (Path(__file__).resolve().parent, REPO):
    if str(folder) not in sys.path[:2]:
        sys.path.insert(0, str(folder))


def commit() -> str:
    """The checkout's short commit, ``+dirty`` when tracked files differ from it; ``unknown``
    outside a git checkout."""

    def git(*args: str) -> str:
        done = subprocess.run(["git", "-C", str(REPO), *args], capture_output=True, text=True,
                              timeout=10)  # fmt: skip
        if done.returncode:
            raise OSError(done.stderr.strip())
        return done.stdout.strip()

    try:
        sha = git("rev-parse", "--short", "HEAD")
        dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return "unknown (not a git checkout)"
    return f"{sha}+dirty" if dirty else sha


def command(argv: Sequence[str] | None = None) -> str:
    """``python benchmarks/NAME.py ARGS`` as this process was started (``argv``: sys.argv)."""
    argv = list(sys.argv if argv is None else argv)
    script = Path(argv[0]).resolve()
    try:
        name = script.relative_to(REPO).as_posix()
    except ValueError:
        name = str(script)
    return shlex.join(["python", name, *argv[1:]])


def versions() -> str:
    """The engines', numpy's and Python's versions, as a dataset's manifest records them: an
    engine's new release changes its physics and its speed, so a figure names the one it
    was measured with (read from package metadata: no engine is imported)."""
    from tactile_bullet.datasets.shards import software_versions

    found = software_versions()
    return ", ".join(f"{k} {found[k]}" for k in ("pybullet", "mujoco", "numpy", "python"))


def provenance(argv: Sequence[str] | None = None) -> None:
    """Print the command, the commit, the date (UTC) and the versions that shape the figures,
    one line each, before the figures."""
    now = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    print(f"command: {command(argv)}")
    print(f"commit: {commit()}")
    print(f"date: {now}")
    print(f"versions: {versions()}", flush=True)


def save_figure(fig, out: str | Path) -> None:
    """Lay ``fig`` out, write it to ``out`` (PNG, 110 dpi, the docs' pictures' resolution) and
    say where."""
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


def timings(fn: Callable[[], object], repeat: int) -> list[float]:
    """Seconds each of ``repeat`` calls of ``fn`` took, in order (the benchmarks take the best
    or the median of them)."""
    out = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        out.append(time.perf_counter() - start)
    return out


def matrix_set(cache: str | Path, name: str, replicate: int = 0) -> list:
    """The records of a full-scale robustness matrix's set ``name`` (``test``, ``mujoco-test``,
    ``out-of-family``, ...) in its cache folder, the run's ``--replicate`` draw."""
    from tactile_bullet.datasets.dataset import read_records

    tag = f"-r{replicate}" if replicate else ""
    return read_records(Path(cache) / f"robust-{name}{tag}").records


def matrix_column(cache: str | Path, column, replicate: int = 0, seed: int = 0) -> list:
    """One column's test records (a ``robustness_sets.Column``) from a matrix's cache, read as
    the matrix reads them (noise, a hand's CSV, J0 only)."""
    from tactile_bullet.experiments.robustness_sets import read_column

    return read_column(column, {s: matrix_set(cache, s, replicate) for s in column.sets}, seed)


def doubt_cell(key: str, flags, right) -> tuple[int, int, bool, str]:
    """A column's doubt as issue 27 counts it: the wrong and the right answers ``flags`` marks
    (``right``: which answers are right), whether at least 80% of its wrong answers are flagged
    at most 5% of its right ones, and the cell ``key: wrong w/n, right r/n`` printed."""
    w, r = int((flags & ~right).sum()), int((flags & right).sum())
    nw, nr = int((~right).sum()), int(right.sum())
    ok = (nw == 0 or w >= 0.8 * nw) and r <= 0.05 * nr
    return w, r, ok, f"{key}: wrong {w}/{nw}, right {r}/{nr}{' (target met)' if ok else ''}"
