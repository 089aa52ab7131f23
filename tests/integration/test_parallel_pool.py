"""psmat._parallel: one pool of loky processes, kept between maps of different sizes and started ahead."""

from __future__ import annotations

import os
import sys
import time

import pytest

from psmat._parallel import map_unordered, start_pool


def _pid(_: object) -> int:
    time.sleep(0.2)  # long enough that every process of the pool gets a task
    return os.getpid()


@pytest.fixture
def sixteen_cores(monkeypatch: pytest.MonkeyPatch) -> None:
    """joblib believes this machine has 16 cores, and no thread limit is set in the environment:
    its default thread count for a pool's processes (cores // processes) then differs between a
    pool of 4 and one of 2, as it did on a 16-core machine between a study's 16 session processes
    and its 7 figure tasks."""
    import joblib._parallel_backends as backends

    monkeypatch.setattr(backends, "cpu_count", lambda *a, **k: 16)
    for var in backends.ParallelBackendBase.MAX_NUM_THREADS_VARS:
        monkeypatch.delenv(var, raising=False)


def _pool_pids() -> set[int]:
    """The processes of joblib's loky executor now."""
    from joblib.externals.loky import reusable_executor

    return {p.pid for p in reusable_executor._executor._processes.values()}


def test_a_smaller_map_reuses_the_processes_of_a_larger_one(sixteen_cores: None) -> None:
    first = set(map_unordered(_pid, range(4), 4))
    pool = _pool_pids()
    assert len(pool) == 4 and first <= pool and os.getpid() not in pool
    second = set(map_unordered(_pid, range(2), 2))
    # the same processes: no new start, no import again (which of them ran the tasks is the load's choice)
    assert second and second <= pool and _pool_pids() <= pool


def test_a_smaller_map_told_to_keep_the_pool_stops_none_of_its_processes(sixteen_cores: None) -> None:
    # a study's 7 figures after its 16 sessions: loky would stop 9 processes and wait for them
    first = set(map_unordered(_pid, range(4), 4))
    pool = _pool_pids()
    assert len(pool) == 4 and first <= pool
    ran = set(map_unordered(_pid, range(2), 4, keep_pool=True))
    assert ran and ran <= pool
    assert _pool_pids() == pool  # all four still there
    assert set(map_unordered(_pid, range(1), 4, keep_pool=True)) <= pool  # one item too: on the pool


def test_a_started_pool_is_the_one_the_map_uses(sixteen_cores: None) -> None:
    ready = start_pool(os.getpid, 3, 3)
    ready()
    started = _pool_pids()
    assert len(started) == 3
    ran = set(map_unordered(_pid, range(3), 3))
    assert ran and ran <= started  # which of them ran the tasks is the load's choice


def test_one_process_starts_nothing() -> None:
    assert start_pool(os.getpid, 5, 1)() is None
    assert start_pool(os.getpid, 1, 4)() is None
    assert list(map_unordered(_pid, [0], 4)) == [os.getpid()]


_ROUNDS = """
import resource
import numpy as np

def rounds(k=3):
    # k times: ten 8 MB arrays touched, then all freed; the page faults of each round
    out = []
    for _ in range(k):
        before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        arrays = [np.ones(1_000_000) for _ in range(10)]
        del arrays
        out.append(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
    return out
"""


def _fault_rounds(_: object) -> list[int]:
    scope: dict[str, object] = {}
    exec(_ROUNDS, scope)
    return scope["rounds"]()  # type: ignore[operator]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's allocator (psmat._malloc) on Linux only")
def test_a_pool_worker_reuses_the_memory_a_task_freed() -> None:
    import subprocess

    # a process that starts as Python does (the environment without glibc's MALLOC_ variables):
    # every round's arrays are mapped afresh, thousands of page faults each time
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    fresh = subprocess.run([sys.executable, "-c", _ROUNDS + "\nprint(rounds())"], env=env, capture_output=True,
                           text=True, check=True)
    plain = [int(v) for v in fresh.stdout.strip().strip("[]").split(",")]
    assert min(plain[1:]) > 1000, plain
    # a worker of the pool (psmat._malloc.keep_freed_memory at its start): after the first round
    # (whose faults depend on what the worker ran before) the freed memory is reused
    for worker in map_unordered(_fault_rounds, [0, 1], 2):
        assert max(worker[1:]) < 100, worker
