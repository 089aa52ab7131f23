"""How much slower one session runs when the machine's cores are all busy: the ceiling that the
machine itself puts on a study's scaling (docs/spec.md §10), measured beside the scaling runs of
``python -m psmat.bench study --scaling``.

A study's sessions are independent, so with no serial part and no tail its efficiency from n₁
to n workers would be the ratio of one session's time when n₁ processes run at once to its time
when n do. On a machine whose cores slow down under load (a shared host, hyperthread siblings,
a lower all-core clock, shared caches and memory bandwidth), that ratio is below 1 and no code
can beat it. The probe measures it with the study's own work: for each worker count n, n
processes of a fresh pool each process the study's first session (the same file, through
:func:`psmat.study.process_trial`, nothing written) — once to load their imports and caches,
then again, timed in each process (their malloc set as the study pool's workers set it,
:mod:`psmat._malloc`). The median of those n wall times is one session's time at
n; each process's CPU time is kept too. The probe checks that the n timed sessions ran at once
(each began before any ended); otherwise its figure is flagged.
"""

from __future__ import annotations

import multiprocessing as mp
import statistics
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .study_task import SessionArgs, timed_one

__all__ = ["probe_load", "format_probe"]


def _at_once(args: SessionArgs, n: int, keep: bool = True) -> dict[str, Any]:
    """``n`` processes, each processing ``args`` once untimed then once timed, all at the same time;
    their allocator set as in the study's pool (:func:`psmat._malloc.keep_freed_memory`), or with
    ``keep`` False as the environment leaves it."""
    from .._malloc import keep_freed_memory

    with mp.get_context("spawn").Pool(n, initializer=keep_freed_memory if keep else None) as pool:
        pool.map(timed_one, [args] * n, chunksize=1)  # imports, caches: not timed
        runs = pool.map(timed_one, [args] * n, chunksize=1)
        pool.close()
        pool.join()
    starts, ends = [r[0] for r in runs], [r[1] for r in runs]
    return {"processes": n, "wall_s": statistics.median(r[2] for r in runs),
            "cpu_s": statistics.median(r[3] for r in runs),
            "page_faults": statistics.median(r[5] for r in runs), "system_s": statistics.median(r[6] for r in runs),
            "distinct_processes": len({r[4] for r in runs}), "overlapped": max(starts) < min(ends)}


def probe_load(args: SessionArgs, counts: Sequence[int]) -> dict[str, Any]:
    """One session's time with each count of processes running it at once.

    Parameters
    ----------
    args : SessionArgs
        The session (:func:`psmat.bench.study_task.session_args`).
    counts : sequence of int
        Process counts, the first the reference.

    Returns
    -------
    dict
        ``session`` (its file), ``runs`` (per count: ``processes``, median ``wall_s``, ``cpu_s``,
        ``system_s`` of one session, s, and its minor ``page_faults``; ``distinct_processes``;
        ``overlapped``: every timed session began before any ended), ``ceiling`` (per count: the
        first count's wall time over this count's, the efficiency a perfectly parallel study could
        reach on this machine) and ``default_malloc``: the largest count once more, its processes'
        allocator as the environment leaves it (glibc's adaptive thresholds unless ``MALLOC_``
        variables are set): what the pool's setting saves under that load.
    """
    runs = [_at_once(args, n) for n in counts]
    ref = runs[0]["wall_s"]
    return {"session": args[0], "runs": runs, "ceiling": {r["processes"]: ref / r["wall_s"] for r in runs},
            "default_malloc": _at_once(args, max(counts), keep=False)}


def format_probe(p: dict[str, Any]) -> list[str]:
    """The probe's lines: one session's time at each count and the ceiling it sets, and the largest
    count with the allocator's defaults."""
    first = p["runs"][0]["processes"]
    lines = [f"the machine under load: one session ({Path(p['session']).name}) processed by n processes at "
             f"once, the median of their times (s), not part of the runs:"]
    for r in p["runs"]:
        n = r["processes"]
        lines.append(f"  {n:>3} at once: {r['wall_s']:.2f} s wall, {r['cpu_s']:.2f} s CPU; ceiling on efficiency "
                     f"against {first}: {p['ceiling'][n]:.2f}{_flag(r)}{_faults(r)}")
    d = p.get("default_malloc")
    if d is not None:
        mine = next(r for r in p["runs"] if r["processes"] == d["processes"])
        lines.append(f"  {d['processes']:>3} at once, the allocator as the environment leaves it (not the pool's "
                     f"psmat._malloc setting): {d['wall_s']:.2f} s wall, {d['cpu_s']:.2f} s CPU, "
                     f"{d['wall_s'] / mine['wall_s']:.2f} times the time with it{_flag(d)}{_faults(d)}")
    return lines


def _flag(r: dict[str, Any]) -> str:
    return "" if r["overlapped"] and r["distinct_processes"] == r["processes"] else \
        "  (not all at once: this count's figure does not measure the load)"


def _faults(r: dict[str, Any]) -> str:
    """The page faults and system time of one session, where measured (a probe of this version)."""
    if r.get("page_faults") is None or r["page_faults"] < 0:
        return ""
    return f" [{r['page_faults']:.0f} page faults, {r['system_s']:.2f} s system]"
