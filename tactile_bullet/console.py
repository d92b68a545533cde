"""What a person sees while work runs: one JSON document on stdout, progress on stderr.

Shared by the CLI and the library's long loops (``experiments.workflow``, ``datasets``), so it
lives below both. Progress goes to stderr only, so ``--json`` output on stdout stays one
document.
"""

from __future__ import annotations

import contextlib
import json
import sys
import time
from collections.abc import Iterable, Iterator
from typing import Any

PROGRESS_EVERY_S = 5.0
"""Plain progress lines come at most this often (s); work shorter than this prints none.
``TACTILE_BULLET_PROGRESS_EVERY`` (seconds) overrides it (the tests set 0: every step)."""


def progress_every() -> float:
    import os

    try:
        return float(os.environ.get("TACTILE_BULLET_PROGRESS_EVERY", PROGRESS_EVERY_S))
    except ValueError:
        return PROGRESS_EVERY_S


def duration(seconds: float) -> str:
    """``"42 s"``, ``"3 min 05 s"``, ``"1 h 02 min"``: a time left or taken."""
    s = max(0, int(round(seconds)))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


def progress_line(desc: str, done: int, total: int | None, elapsed: float,
                  unit: str = "") -> str:  # fmt: skip
    """``desc: done/total (pct), rate/s, elapsed, time left``: one plain progress line."""
    rate = done / elapsed if elapsed > 0 else 0.0
    per = f" {unit}" if unit else ""
    speed = f"{rate:.2f}{per}/s" if rate < 10 else f"{rate:.0f}{per}/s"
    if total:
        left = duration((total - done) / rate) if rate > 0 else "unknown"
        return (f"{desc}: {done}/{total} ({100.0 * done / total:.0f}%), {speed}, "
                f"{duration(elapsed)} elapsed, {left} left")  # fmt: skip
    return f"{desc}: {done}, {speed}, {duration(elapsed)} elapsed"


def emit_json(doc: Any) -> None:
    """Print one JSON document on stdout (the ``--json`` contract)."""
    json.dump(json_ready(doc), sys.stdout, indent=2)
    sys.stdout.write("\n")


_TINY = sys.float_info.min
"""The smallest normal float: below it (subnormals such as 1.5e-323, a simulator's rounding
noise around 0) a number is written as 0.0."""


def json_ready(value: Any) -> Any:
    """``value`` as plain JSON types (numpy scalars and arrays, tuples and paths converted as
    :func:`tactile_bullet.files.json_value` does), with subnormal floats written as 0.0: a
    reader should never meet ``1.5e-323`` for an angle that is zero."""
    from .files import json_value

    if isinstance(value, float):
        return 0.0 if value != 0.0 and abs(value) < _TINY else value
    if isinstance(value, dict):
        return {k: json_ready(v) for k, v in value.items()}
    if isinstance(value, list):
        return [json_ready(v) for v in value]
    if value is None or isinstance(value, str | int | bool):
        return value
    import numpy as np

    if isinstance(value, np.ndarray) and value.dtype.kind == "f":
        value = np.where(np.abs(value) < _TINY, 0.0, value)
    return json_ready(json_value(value))


def show_progress(json_mode: bool) -> bool:
    """Progress bars for a person watching: stderr a terminal (with --json too: the bar is on
    stderr, the document alone on stdout)."""
    return sys.stderr.isatty()


def log_lines(json_mode: bool) -> bool:
    """Progress on stderr (done/total, rate, time left): always without --json; under --json
    only where stderr is a terminal, so ``--json 2>log`` in a script stays quiet
    (docs/cli.md)."""
    return not json_mode or sys.stderr.isatty()


class _Lines:
    """Rate-limited ``desc: done/total (pct), rate, elapsed, time left`` lines on stderr,
    per ``desc``."""

    def __init__(self) -> None:
        self.start: dict[str, float] = {}
        self.last: dict[str, float] = {}
        self.done: dict[str, int] = {}

    def __call__(self, desc: str, done: int, total: int | None) -> None:
        now = time.monotonic()
        if desc not in self.start or done < self.done.get(desc, 0):  # a new loop of that name
            self.start[desc] = self.last[desc] = now
        self.done[desc] = done
        if now - self.last[desc] < progress_every() or done == 0:
            return
        self.last[desc] = now
        print(progress_line(desc, done, total, now - self.start[desc]), file=sys.stderr,
              flush=True)  # fmt: skip


_reporter: _Lines | None = None


@contextlib.contextmanager
def reporting(enabled: bool) -> Iterator[None]:
    """While active (and ``enabled``), :func:`tick` prints progress lines: the CLI turns it on
    where :func:`log_lines` says a person or a log should see them, so loops deep in the
    library (a classifier's epochs, an experiment's steps) report without knowing who runs
    them; library callers see nothing unless they ask."""
    global _reporter
    previous = _reporter
    _reporter = _Lines() if enabled else None
    try:
        yield
    finally:
        _reporter = previous


def tick(desc: str, done: int, total: int | None = None) -> None:
    """``done`` of ``total`` steps of the loop ``desc`` are finished (see :func:`reporting`)."""
    if _reporter is not None:
        _reporter(desc, done, total)


def _ticking(iterable: Iterable, total: int | None, desc: str) -> Iterator:
    for done, item in enumerate(iterable, 1):
        yield item
        tick(desc, done, total)


def progress(iterable: Iterable, total: int | None, desc: str, enabled: bool) -> Iterable:
    """A tqdm bar where ``enabled`` (a person at a terminal); otherwise plain lines while
    :func:`reporting` is on (a log, CI), so long loops are never silent."""
    if not enabled:
        return _ticking(iterable, total, desc) if _reporter is not None else iterable
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc=desc, unit="grasp", file=sys.stderr)  # rate, left


def start(desc: str, total: int | None = None) -> None:
    """A loop ``desc`` of ``total`` steps begins (its clock starts; :func:`tick` reports)."""
    tick(desc, 0, total)


def plural(n: int, noun: str, plural: str | None = None) -> str:
    """``"1 shard"``, ``"3 shards"``: a number with its noun in the right number (``plural``
    where adding "s" is wrong, e.g. ``plural(n, "class", "classes")``)."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"
