"""Independent tasks on the cores of this machine, results in the order they finish.

One home for the process pool of :func:`psmat.study.run_study` and
:func:`psmat.posture.load_posture_study`: joblib's loky processes (not threads: most
of a task is Python that the GIL would serialise), one task per process at a time; one
worker, or one task, runs in this process. The workers end with this process, even when it is
killed outright (:func:`psmat._orphans.exit_with_parent`), and keep the memory a task freed for
the next (:func:`psmat._malloc.keep_freed_memory`).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator, Sequence
from typing import TypeVar

__all__ = ["map_unordered", "start_pool", "pool_size"]

T = TypeVar("T")
R = TypeVar("R")


def map_unordered(fn: Callable[[T], R], items: Sequence[T], workers: int | None = None, *,
                  keep_pool: bool = False) -> Iterator[R]:
    """``fn(item)`` for each item, yielded as each finishes.

    Parameters
    ----------
    fn : callable
        A module-level function (it travels to the worker processes by pickle).
    items : sequence
        The tasks' arguments.
    workers : int, optional
        Processes (default: every core); at most one per item; 1 runs in this process.
    keep_pool : bool
        ``workers`` is the size of the pool an earlier map (or :func:`start_pool`) of this process
        started: fewer items than that run on the whole pool, its other processes idle. Without it
        such a map shrinks the pool to one process per item, and loky shrinks a pool by stopping
        processes and waiting until they have exited (a map of 3 items after a pool of 8: 1.7 s
        on the 2-core machine against 0.015 s for 8 items; a study's 7 figures after its 16
        session processes paid this on a 16-core machine).
    """
    if not items:
        return
    n = _processes(workers, len(items))
    if keep_pool and workers is not None and workers > 1:
        n = workers
    if n <= 1:
        yield from map(fn, items)
        return
    results = _parallel(n, fn, [(t,) for t in items])
    yield from results


def start_pool(fn: Callable[[], object], count: int, workers: int | None = None) -> Callable[[], None]:
    """Start, without waiting, the processes that :func:`map_unordered` with ``count`` items and
    ``workers`` will use: each runs ``fn()`` once (say, a function of the tasks' module, so that its
    imports are done); the pool is then reused by that map (joblib keeps its loky executor).

    Returns
    -------
    callable
        Waits until every process has run ``fn`` (call it before the map). Nothing is started,
        and it returns at once, where the map would run in this process.
    """
    n = _processes(workers, count)
    if n <= 1:
        return lambda: None
    started = _parallel(n, fn, [()] * n)
    return lambda: deque(started, maxlen=0)


def pool_size(workers: int | None, count: int) -> int:
    """The processes :func:`map_unordered` with ``count`` items and ``workers`` runs them on (1:
    in this process, no pool). A later map given this as its ``workers`` reuses those processes
    and starts none."""
    return max(1, _processes(workers, count))


def _processes(workers: int | None, count: int) -> int:
    from joblib import cpu_count

    return min(workers or cpu_count(), count)


def _parallel(n: int, fn: Callable[..., R], args: Sequence[tuple[object, ...]]) -> Iterator[R]:
    """``fn(*a)`` for each ``a`` on ``n`` loky processes, dispatched now, yielded as each finishes: the one
    configuration of the pool, so that every call finds the same executor.

    One thread for the numerical libraries in every process, whatever ``n``: a task is one core's
    work, and joblib's default (cores // n threads) would make the processes' environment depend
    on ``n``. loky keeps its processes only for the same environment: a later map of another size
    (a study's 7 figures after its sessions on 16 processes) would start a new pool and pay every
    import again (its start took 2.8 s on a lent 16-core machine) instead of resizing this one.
    """
    import os

    from joblib import Parallel, delayed, parallel_config

    # the pool is made inside the configuration, its results read outside it (no setting held across yields)
    with parallel_config(backend="loky", inner_max_num_threads=1, initializer=_start_worker,
                         initargs=(os.getpid(),)):
        return Parallel(n_jobs=n, return_as="generator_unordered")(delayed(fn)(*a) for a in args)


def _start_worker(parent: int) -> None:
    """Run in each worker process as it starts: it ends when ``parent`` does, and keeps freed memory."""
    from ._malloc import keep_freed_memory
    from ._orphans import exit_with_parent

    exit_with_parent(parent)
    keep_freed_memory()
