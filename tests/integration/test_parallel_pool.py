"""psmat._parallel: one pool of loky processes, kept between maps of different sizes and started ahead."""

from __future__ import annotations

import os
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
