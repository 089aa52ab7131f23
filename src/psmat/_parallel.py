"""Independent tasks on the cores of this machine, results in the order they finish.

One home for the process pool of :func:`psmat.study.run_study` and
:func:`psmat.posture.load_posture_study`: joblib's loky processes (not threads: most
of a task is Python that the GIL would serialise), one task per process at a time; one
worker, or one task, runs in this process. The workers end with this process, even when it is
killed outright (:func:`psmat._orphans.exit_with_parent`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import TypeVar

__all__ = ["map_unordered"]

T = TypeVar("T")
R = TypeVar("R")


def map_unordered(fn: Callable[[T], R], items: Sequence[T], workers: int | None = None) -> Iterator[R]:
    """``fn(item)`` for each item, yielded as each finishes.

    Parameters
    ----------
    fn : callable
        A module-level function (it travels to the worker processes by pickle).
    items : sequence
        The tasks' arguments.
    workers : int, optional
        Processes (default: every core); at most one per item; 1 runs in this process.
    """
    if not items:
        return
    import os

    from joblib import Parallel, cpu_count, delayed, parallel_config

    from ._orphans import exit_with_parent

    n = min(workers or cpu_count(), len(items))
    if n <= 1:
        yield from map(fn, items)
        return
    # the pool is made inside the configuration, its results read outside it (no setting held across yields)
    with parallel_config(backend="loky", initializer=exit_with_parent, initargs=(os.getpid(),)):
        results = Parallel(n_jobs=n, return_as="generator_unordered")(delayed(fn)(t) for t in items)
    yield from results
