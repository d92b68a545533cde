"""Many grasps' shape fits at once, on every core this process may use.

``evaluate`` and ``train`` fit every grasp once as the answers' second opinion (the doubt
cross-check) or as the classifier itself, one after another: 90% of an ``evaluate`` of a
162-grasp set was these fits, on one core of two. The fits are independent and deterministic,
so they are split across forked worker processes and come back equal to the ones this process
would compute; each is kept in :mod:`.shape_fit`'s in-memory cache, so the code that asks for
them one by one afterwards (``predict`` then ``predict_proba``, the calibration's folds) reads
them back instead of fitting again.

:func:`on_cores` splits any such batch the same way (the contact check's verdicts, a
decision's simulated grasps). Workers are only forked where that is safe and worth it: on
Linux, from a process running no other thread and not itself a pool's daemon worker, for at
least :data:`MIN_PARALLEL` fits not already cached. Elsewhere the fits run here, as before.
"""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Callable, Sequence

import numpy as np

from ..console import tick
from .family_fit import ShapeFit, measured_features
from .fit_cache import cached_answer, cached_fit, keep_fit, keep_name
from .shape_fit import fit_shape, name_or_fit
from .shape_model import Calibration, active_calibration

MIN_PARALLEL = 32
"""Fewest uncached fits worth forking for: a fit is ~20 ms, forking a worker a few ms, and a
short batch split in two gains less than that."""

CHUNK = 16
"""Fits per task handed to a worker: small enough that progress moves every ~0.3 s and the
last tasks of the two workers end close together."""

_JOB: tuple[tuple[str, ...], Calibration, Callable] | None = None
"""The families, coefficients and function of the batch being fitted, set before the workers
fork (they inherit it, so the grids and the coefficients are not pickled per task)."""


def usable_cores() -> int:
    """Cores this process may run on (its affinity where the platform says, else all)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
        return os.cpu_count() or 1


def can_fork() -> bool:
    """Linux only: on macOS a forked child of a process that has used the system's numerical
    libraries can crash, and Windows has no fork."""
    import multiprocessing

    return (
        sys.platform.startswith("linux")
        and "fork" in multiprocessing.get_all_start_methods()
        and threading.active_count() == 1
        and not multiprocessing.current_process().daemon
    )


_TASK: Callable[[list[int]], list] | None = None
"""The task :func:`on_cores` is splitting, set before the workers fork (they inherit it, so
its inputs are not pickled)."""


def _run_task(index: list[int]) -> list:
    return _TASK(index)


def on_cores(task: Callable[[list[int]], list], n: int, least: int, chunk: int) -> list:
    """``task(range(n))``: its n results computed ``chunk`` at a time on forked workers, one
    per usable core, where that is safe (:func:`can_fork`) and worth it (``n`` at least
    ``least``), else here in one call. A chunk a dead worker (killed, out of memory) left
    undone is computed here. The contact check's verdicts and a decision's simulated grasps
    are split so."""
    global _TASK
    workers = min(usable_cores(), -(-n // chunk))
    if n < least or workers < 2 or not can_fork():
        return task(list(range(n)))
    import multiprocessing  # here: a single answer does not import them
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    chunks = [list(range(k, min(k + chunk, n))) for k in range(0, n, chunk)]
    out: list = [None] * n
    done = [False] * n
    _TASK = task
    pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"))
    try:
        for part, found in zip(chunks, pool.map(_run_task, chunks), strict=True):
            for i, value in zip(part, found, strict=True):
                out[i], done[i] = value, True
    except BrokenProcessPool:
        pass
    finally:
        _TASK = None
        pool.shutdown(wait=True, cancel_futures=True)
    todo = [i for i in range(n) if not done[i]]
    for i, value in zip(todo, task(todo) if todo else [], strict=True):
        out[i] = value
    return out


def _fit_chunk(rows: np.ndarray) -> list:
    families, cal, compute = _JOB
    return [compute(a, families, cal) for a in rows]


def fit_many(
    angles: Sequence,
    families: Sequence[str],
    calibration: Calibration | None = None,
    desc: str = "shape fits",
    workers: int | None = None,
) -> list[ShapeFit]:
    """:func:`.shape_fit.fit_shape` of each (3, 4) final angles in ``angles``, in order, the
    uncached ones split over ``workers`` processes (default: :func:`usable_cores`). Every fit
    is equal to the one ``fit_shape`` gives in this process, and is cached as it would be.
    Progress is reported as ``desc``."""
    return _batch(angles, families, calibration, desc, workers, cached_fit, fit_shape)


def fit_answers(
    angles: Sequence,
    families: Sequence[str],
    calibration: Calibration | None = None,
    desc: str = "shape fits",
    workers: int | None = None,
) -> list[str | ShapeFit]:
    """For each (3, 4) final angles, in order, the family :func:`.shape_fit.fit_shape` names
    where the grid decides it, else the whole fit (:func:`.shape_fit.name_or_fit`): a fit's
    sizes only computed where the grid leaves the family open. What the doubt's cross-check
    reads (the whole fits' scores too: ``learn/doubt.CROSS_CHECK_TOLERANCE``)."""
    return _batch(angles, families, calibration, desc, workers, cached_answer, name_or_fit)


def fit_names(
    angles: Sequence,
    families: Sequence[str],
    calibration: Calibration | None = None,
    desc: str = "shape fits",
    workers: int | None = None,
) -> list[str]:
    """The family :func:`.shape_fit.fit_shape` names for each (3, 4) final angles, in order,
    as :func:`fit_many` gives them (the names of :func:`fit_answers`)."""
    found = fit_answers(angles, families, calibration, desc, workers)
    return [f if isinstance(f, str) else f.shape for f in found]


def _keep(features, names, cal, found):
    """Keep a worker's answer in this process's caches, as computing it here would have."""
    if isinstance(found, str):
        return keep_name(features, names, cal, found, features=True)
    return keep_fit(features, names, cal, found, features=True)


def _batch(angles, families, calibration, desc, workers, lookup, compute) -> list:
    """``compute(angles, families, cal)`` of each of ``angles`` not found by ``lookup``,
    the uncached ones split over forked workers (see :func:`fit_many`)."""
    global _JOB
    names = tuple(dict.fromkeys(str(f) for f in families))
    cal = active_calibration() if calibration is None else calibration
    rows = [np.asarray(a, dtype=float) for a in angles]
    # bad angles fail here, in this process, as fit_shape would; each row's features once
    features = [measured_features(a) for a in rows]
    out: list = [lookup(f, names, cal, features=True) for f in features]
    todo = [i for i, found in enumerate(out) if found is None]
    workers = usable_cores() if workers is None else workers
    workers = min(workers, -(-len(todo) // CHUNK))
    done = len(rows) - len(todo)
    if len(todo) >= MIN_PARALLEL and workers > 1 and can_fork():
        import multiprocessing  # here: a single answer (grasp, identify) does not import them
        from concurrent.futures import ProcessPoolExecutor
        from concurrent.futures.process import BrokenProcessPool

        first = todo.pop(0)  # fitted here first: the grids are built before the fork
        out[first] = compute(rows[first], names, cal)
        done += 1
        chunks = [todo[k : k + CHUNK] for k in range(0, len(todo), CHUNK)]
        _JOB = (names, cal, compute)
        pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"))
        try:
            results = pool.map(_fit_chunk, [np.stack([rows[i] for i in c]) for c in chunks])
            for chunk, found in zip(chunks, results, strict=True):
                for i, value in zip(chunk, found, strict=True):
                    out[i] = _keep(features[i], names, cal, value)
                done += len(chunk)
                tick(desc, done, len(rows))
        except BrokenProcessPool:  # a worker died (killed, out of memory): the rest here
            pass
        finally:
            _JOB = None
            pool.shutdown(wait=True, cancel_futures=True)
        todo = [i for i in todo if out[i] is None]
    for i in todo:
        out[i] = compute(rows[i], names, cal)
        done += 1
        tick(desc, done, len(rows))
    return out
