"""Many shape fits at once (perception/fit_batch.py): split over forked workers, every fit is
the one this process would compute, kept in the fit cache, and bad input fails before any
worker starts."""

from __future__ import annotations

import os
import signal
import sys
import threading

import numpy as np
import pytest

from tactile_bullet.errors import UsageError
from tactile_bullet.perception import fit_batch, fit_cache, shape_fit
from tactile_bullet.perception.shape_model import active_calibration

FAMILIES = ("cylinder", "sphere", "torus", "cone", "hyperboloid")


def _angles(n: int, seed: int = 3) -> list[np.ndarray]:
    """Model angles of random thesis-shape sizes and poses, with 1 deg of noise."""
    rng = np.random.default_rng(seed)
    table = {s.name: s for s in shape_fit.BUILTIN_SHAPES}
    out = []
    while len(out) < n:
        spec = table[FAMILIES[len(out) % len(FAMILIES)]]
        sizes = {k: rng.uniform(p.min, p.max) for k, p in spec.params.items()}
        try:
            pred = shape_fit.predicted_angles(
                spec.name, sizes, tuple(rng.uniform(-0.01, 0.01, 2)),
                rotation_deg=rng.uniform(-20, 20),
            )  # fmt: skip
        except UsageError:  # sizes that make no such solid
            continue
        pred = pred + rng.normal(0.0, np.radians(1.0), pred.shape)
        out.append(np.stack([pred[0], 0.5 * pred[1], 0.5 * pred[1]]))
    return out


def _summaries(fits) -> list:
    return [(f.shape, [(n, x.score, x.params, x.offset, x.rotation_deg) for n, x in
                       f.fits.items()]) for f in fits]  # fmt: skip


@pytest.fixture()
def fresh_cache(monkeypatch):
    monkeypatch.setattr(fit_cache, "_FITS", type(fit_cache._FITS)())
    monkeypatch.setattr(fit_cache, "_NAMES", type(fit_cache._NAMES)())


FORKS = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="fit_many forks on Linux")


@FORKS
def test_fits_split_over_workers_equal_the_fits_made_here(fresh_cache):
    angles = _angles(fit_batch.MIN_PARALLEL + 8)
    assert fit_batch.can_fork(), "one thread, not a daemon: fit_many forks here"
    parallel = fit_batch.fit_many(angles, FAMILIES, workers=2)
    fit_cache._FITS.clear()
    here = [shape_fit.fit_shape(a, FAMILIES) for a in angles]
    assert _summaries(parallel) == _summaries(here)


def test_fits_made_by_workers_are_kept_for_the_next_ask(fresh_cache):
    angles = _angles(fit_batch.MIN_PARALLEL)
    fits = fit_batch.fit_many(angles, FAMILIES, workers=2)
    cal = active_calibration()
    for a, fit in zip(angles, fits, strict=True):
        assert fit_cache.cached_fit(a, FAMILIES, cal) is fit
        assert shape_fit.fit_shape(a, FAMILIES) is fit  # read back, not fitted again


def test_a_threaded_process_fits_here_and_gets_the_same_answers(fresh_cache):
    angles = _angles(fit_batch.MIN_PARALLEL)
    expected = _summaries(fit_batch.fit_many(angles, FAMILIES, workers=1))
    fit_cache._FITS.clear()
    got = {}

    def run():
        got["fits"] = fit_batch.fit_many(angles, FAMILIES, workers=2)

    stop = threading.Event()
    idle = threading.Thread(target=stop.wait)  # a second thread: forking is not safe
    idle.start()
    try:
        assert not fit_batch.can_fork()
        run()
    finally:
        stop.set()
        idle.join()
    assert _summaries(got["fits"]) == expected


def test_bad_angles_fail_before_any_fit(fresh_cache):
    angles = _angles(fit_batch.MIN_PARALLEL)
    angles[-1] = np.full((3, 4), np.nan)
    with pytest.raises(UsageError, match="NaN"):
        fit_batch.fit_many(angles, FAMILIES, workers=2)
    assert len(fit_cache._FITS) == 0


def test_an_unknown_family_is_a_usage_error(fresh_cache):
    with pytest.raises(UsageError, match="no model of shape 'prism'"):
        fit_batch.fit_many(_angles(fit_batch.MIN_PARALLEL), ("sphere", "prism"), workers=2)


_PARENT = os.getpid()


def _dying_chunk(rows):
    """A worker's task that kills its worker (as the kernel's out-of-memory killer would)."""
    if os.getpid() != _PARENT:
        os.kill(os.getpid(), signal.SIGKILL)
    return [shape_fit.fit_shape(a, FAMILIES) for a in rows]


@FORKS
def test_a_worker_that_dies_leaves_its_fits_to_this_process(fresh_cache, monkeypatch):
    angles = _angles(fit_batch.MIN_PARALLEL + 16)
    expected = _summaries(fit_batch.fit_many(angles, FAMILIES, workers=1))
    fit_cache._FITS.clear()
    monkeypatch.setattr(fit_batch, "_fit_chunk", _dying_chunk)
    assert _summaries(fit_batch.fit_many(angles, FAMILIES, workers=2)) == expected


@FORKS
@pytest.mark.parametrize("workers", [1, 2])
def test_the_cross_checks_names_are_the_families_the_whole_fit_names(fresh_cache, workers):
    """fit_names skips the sizes where the grid decides the family: the names must be those of
    the whole fits, on grasps the grid decides and on grasps it leaves open (both occur)."""
    angles = _angles(fit_batch.MIN_PARALLEL + 8)
    names = fit_batch.fit_names(angles, FAMILIES, workers=workers)
    cal = active_calibration()
    on_grid = [fit_cache.cached_fit(a, FAMILIES, cal) is None for a in angles]
    assert 0 < sum(on_grid) < len(angles), "both branches exercised"
    fit_cache._FITS.clear()
    assert names == [shape_fit.fit_shape(a, FAMILIES).shape for a in angles]


def test_a_family_decided_on_the_grid_is_not_kept_as_a_whole_fit(fresh_cache):
    """grasp's shape-fit block reads the fit's sizes after the cross-check: a name decided on
    the grid must not stand in for them."""
    cal = active_calibration()
    for a in _angles(12):
        found = shape_fit.name_or_fit(a, FAMILIES)
        if isinstance(found, str):
            assert fit_cache.cached_fit(a, FAMILIES, cal) is None
            assert fit_cache.cached_answer(a, FAMILIES, cal) == found
            whole = shape_fit.fit_shape(a, FAMILIES)
            assert whole.shape == found and whole.params  # the sizes, computed now
            assert shape_fit.name_or_fit(a, FAMILIES) is whole  # and read back after
            return
    pytest.fail("no grasp of 12 was decided on the grid")
