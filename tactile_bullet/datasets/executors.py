"""Where grasp tasks run: local worker processes, or a Dask distributed cluster.

Both take the same task list and hand back ``(task_index, outcome)`` pairs as they finish;
the outcome is either the record's ``(metadata, arrays)`` or an error string. Records are
deterministic per task, so where a task ran never changes what it produced.

Local workers each build their own PyBullet client per grasp (clients cannot cross
processes). A worker that dies, even by a segfault, breaks a ``ProcessPoolExecutor``; the run
then re-runs the tasks that were in flight one at a time in a fresh single-worker pool, so the
task that kills its worker is found, retried once, and recorded as failed, while the others
complete.

An interrupt (Ctrl-C, or SIGTERM, which the CLI turns into the same exception) or a consumer
that stops reading terminates the workers at once instead of waiting for their grasps, so
nothing of the run outlives it; the dataset is then finished with ``--resume``.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from ..errors import UsageError
from .sweeps import GraspTask

Outcome = tuple[dict, dict] | str
CRASH_ENV = "TACTILE_BULLET_TEST_CRASH_TASK"
"""Test hook: a worker running the task with this index kills itself with SIGSEGV."""

PREFETCH = 1
"""Tasks queued beyond one per worker, so a worker that finishes a grasp starts the next at
once instead of waiting for this process to take its result and hand it another (a MuJoCo
grasp is ~45 ms: the round trip was a tenth of it). Each is one more suspect to re-run alone
when a worker dies."""

MAX_ATTEMPTS = 2
"""A task whose worker died is retried once, then recorded as failed."""


def run_task(task: GraspTask) -> Outcome:
    """Simulate one task in this process: the record's (metadata, arrays) or an error."""
    if os.environ.get(CRASH_ENV) == str(task.index):
        os.kill(os.getpid(), signal.SIGSEGV)
    from ..sim.grasp import simulate_grasp

    try:
        record = simulate_grasp(task.target(), task.params, task.pose, task.controller, task.seed)
    except Exception as exc:  # noqa: BLE001 - a failed grasp is data, not a crash of the run
        return f"{type(exc).__name__}: {exc}"
    return record.metadata(), record.arrays()


def _context(engines: frozenset[str] = frozenset(), meshes: bool = False):
    """fork where the platform has it and this process runs no other Python thread: each
    worker starts as a copy of this process, with the simulator, the engines and the plugins
    it has already imported (:func:`_preload`), in milliseconds instead of the ~1.2-2 s a
    fresh interpreter takes to import them (issue 30: that start was ``generate --workers 1``'s
    whole overhead on MuJoCo). Otherwise forkserver, whose server imports the simulator once
    without inheriting this process's state, or spawn where there is neither."""
    methods = multiprocessing.get_all_start_methods()
    if "fork" in methods and threading.active_count() == 1:
        _preload(engines, meshes)
        return multiprocessing.get_context("fork")
    if "forkserver" not in methods:
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(
        ["tactile_bullet.sim.grasp", "tactile_bullet.datasets.executors"]
    )
    return context


def _preload(engines: frozenset[str], meshes: bool) -> None:
    """Import, in this process, what every worker's first grasp would import: the simulator,
    the plugins' registrations (a plugin may import trimesh and scipy: ~1.5 s), the modules
    of the ``engines`` the tasks name, and trimesh where a task's object is built as a mesh
    (``meshes``: the first MuJoCo cone of a process took 0.8-2.2 s, all of it importing
    trimesh), so that forked workers share them."""
    import importlib

    from ..plugins import load_plugins
    from ..sim import grasp  # noqa: F401

    load_plugins()
    for name in sorted(engines & {"bullet", "mujoco"}):
        with contextlib.suppress(ImportError):  # the worker reports it, as it always did
            importlib.import_module(f"tactile_bullet.sim.engines.{name}")
            if name == "bullet":
                from ..sim.scene import import_pybullet

                import_pybullet()  # without its banner
            else:
                importlib.import_module("mujoco")
    if meshes:
        with contextlib.suppress(ImportError):
            importlib.import_module("trimesh")


def _our_environment() -> dict[str, str | None]:
    """The TACTILE_BULLET_* variables as they are now in this process. A forkserver keeps
    the environment it started with, so each pool hands its workers the current values."""
    names = {n for n in os.environ if n.startswith("TACTILE_BULLET_")} | {CRASH_ENV}
    return {n: os.environ.get(n) for n in names}


PARENT_ONLY_FDS: set[int] = set()
"""File descriptors a forked worker closes at once: the dataset's writer lock (``generate``
adds it while it holds it). A flock is dropped when the last descriptor of its open file
closes, so a worker's inherited copy would keep a killed run's lock and block its --resume."""


def _set_environment(values: dict[str, str | None], close: tuple[int, ...] = ()) -> None:
    """A worker's start: this run's TACTILE_BULLET_* variables, the default signal handlers (a
    forked worker would otherwise run the CLI's SIGTERM handler, not die of it) and, forked,
    the parent's descriptors in ``close`` closed."""
    for fd in close:
        with contextlib.suppress(OSError):
            os.close(fd)
    with contextlib.suppress(ValueError):  # not the main thread: leave them
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.default_int_handler)
    for name, value in values.items():
        if value is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = value


@contextlib.contextmanager
def _pool(
    workers: int, engines: frozenset[str] = frozenset(), meshes: bool = False
) -> Iterator[ProcessPoolExecutor]:
    """A pool whose workers are terminated, not waited for, when the block is left by an
    exception (an interrupt, or GeneratorExit when the consumer stops): their grasps would
    otherwise run to the end, and a killed parent would leave them running."""
    context = _context(engines, meshes)
    close = tuple(sorted(PARENT_ONLY_FDS)) if context.get_start_method() == "fork" else ()
    pool = ProcessPoolExecutor(
        workers, mp_context=context, initializer=_set_environment,
        initargs=(_our_environment(), close),
    )  # fmt: skip
    try:
        yield pool
    except BrokenProcessPool:
        raise  # the workers are gone already; the caller isolates the suspects
    except BaseException:
        _stop_workers(pool)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _stop_workers(pool: ProcessPoolExecutor, grace: float = 5.0) -> None:
    """Terminate a pool's worker processes now (SIGTERM, then SIGKILL after ``grace``
    seconds), so that shutting the pool down does not wait for their tasks."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    for process in processes:
        with contextlib.suppress(OSError, ValueError):
            process.terminate()
    for process in processes:
        with contextlib.suppress(OSError, ValueError, AssertionError):
            process.join(grace)
            if process.is_alive():
                process.kill()
                process.join(grace)


def run_local(
    tasks: Sequence[GraspTask], workers: int = 1, task_fn: Callable = run_task
) -> Iterator[tuple[int, Outcome]]:
    """Run tasks on ``workers`` local processes, yielding results as they complete."""
    pending = list(tasks)
    engines, meshes = _engines(pending), _meshes(pending)
    attempts: dict[int, int] = {}
    suspects: list[GraspTask] = []
    while pending or suspects:
        if suspects:  # isolate: one task per pool until each suspect is cleared or convicted
            task = suspects.pop(0)
            attempts[task.index] = attempts.get(task.index, 0) + 1
            with _pool(1, engines, meshes) as pool:
                try:
                    outcome = pool.submit(task_fn, task).result()
                except BrokenProcessPool:
                    if attempts[task.index] >= MAX_ATTEMPTS:
                        yield task.index, "worker process died (twice) running this task"
                    else:
                        suspects.append(task)
                    continue
            yield task.index, outcome
            continue
        in_flight, pending = yield from _run_pool(pending, workers, task_fn, engines, meshes)
        suspects.extend(in_flight)


def _engines(tasks) -> frozenset[str]:
    """The engines ``tasks`` run on (what a forked worker should find imported)."""
    names = {str(getattr(getattr(t, "controller", None), "engine", "")) for t in tasks}
    return frozenset(names - {""})


def _meshes(tasks) -> bool:
    """Whether any of ``tasks`` may build its object with trimesh: a mesh file (processed on
    first use) or a plugin's shape. The built-in shapes' pieces, on either engine, are made
    from their profiles without it."""
    from ..objects.shapes import BUILTIN_SHAPES

    builtin = {s.name for s in BUILTIN_SHAPES}
    return any(
        getattr(t, "mesh", None) is not None or getattr(t, "shape", "sphere") not in builtin
        for t in tasks
    )


def _run_pool(tasks, workers, task_fn, engines=frozenset(), meshes=False):
    """Run ``tasks`` with at most ``workers + PREFETCH`` in flight (so few are suspects when a
    worker dies). Returns (tasks in flight when a worker died, tasks not started yet)."""
    queue = list(tasks)
    in_flight: dict[Future, GraspTask] = {}
    try:
        with _pool(workers, engines, meshes) as pool:
            while queue or in_flight:
                while queue and len(in_flight) < workers + PREFETCH:
                    # submit before taking the task off the queue: a pool that broke since the
                    # last wait raises here, and the task must stay queued, not vanish
                    future = pool.submit(task_fn, queue[0])
                    in_flight[future] = queue.pop(0)
                done, _ = wait(in_flight, return_when=FIRST_COMPLETED)
                for future in done:
                    outcome = future.result()  # BrokenProcessPool if a worker died
                    yield in_flight.pop(future).index, outcome
    except BrokenProcessPool:
        return list(in_flight.values()), queue
    return [], []


def connect_dask(address: str, timeout: float = 5.0):
    """A client of the Dask scheduler at ``address``, or a UsageError within ``timeout``
    seconds; called before anything is written, so a wrong address leaves no trace."""
    try:
        from distributed import Client
    except ImportError:
        raise UsageError(
            "--cluster needs dask.distributed: pip install 'tactile-bullet[cluster]'"
        ) from None
    try:
        return Client(address, timeout=timeout)
    except (OSError, TimeoutError, ValueError) as exc:
        raise UsageError(f"cannot reach the Dask scheduler at {address} ({exc})") from None


def _engine_versions() -> dict[str, str]:
    from .shards import ENGINE_PACKAGES, software_versions

    found = software_versions()
    return {p: found[p] for p in ENGINE_PACKAGES.values()}


def check_worker_engines(client) -> None:
    """A UsageError (the client closed) where a Dask worker runs another version of PyBullet
    or MuJoCo than this machine, whose versions the manifest records: its grasps would be
    another simulator's under the same dataset. Checked before anything is written."""
    here = _engine_versions()
    try:
        found = client.run(_engine_versions)
    except Exception as exc:  # noqa: BLE001 - any worker-side failure: say which, stop
        client.close()
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise UsageError(f"cannot read the Dask workers' engine versions ({first})") from None
    for worker, versions in sorted(found.items()):
        for package, version in sorted(versions.items()):
            if version != here.get(package):
                client.close()
                raise UsageError(
                    f"Dask worker {worker} has {package} {version}, this machine "
                    f"{here.get(package)}: install the same engine versions on every machine"
                )


def run_dask(
    tasks: Sequence[GraspTask], client, task_fn: Callable = run_task
) -> Iterator[tuple[int, Outcome]]:
    """Run tasks on a Dask cluster through ``client`` (closed at the end); the scheduler
    re-runs the tasks of a worker that dies (its ``allowed-failures`` decides how often)."""
    from distributed import as_completed

    try:
        futures = client.map(task_fn, list(tasks), pure=False)
        index = {f.key: t.index for f, t in zip(futures, tasks, strict=True)}
        for future in as_completed(futures):
            try:
                outcome = future.result()
            except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker: the task failed
                outcome = f"{type(exc).__name__}: {exc}"
            yield index[future.key], outcome
    finally:
        client.close()
