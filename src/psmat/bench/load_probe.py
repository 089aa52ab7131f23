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


def _at_once(args: SessionArgs, n: int) -> dict[str, Any]:
    """``n`` processes, each processing ``args`` once untimed then once timed, all at the same time;
    their allocator set as in the study's pool (:func:`psmat._malloc.keep_freed_memory`)."""
    from .._malloc import keep_freed_memory

    with mp.get_context("spawn").Pool(n, initializer=keep_freed_memory) as pool:
        pool.map(timed_one, [args] * n, chunksize=1)  # imports, caches: not timed
        runs = pool.map(timed_one, [args] * n, chunksize=1)
        pool.close()
        pool.join()
    starts, ends = [r[0] for r in runs], [r[1] for r in runs]
    return {"processes": n, "wall_s": statistics.median(r[2] for r in runs),
            "cpu_s": statistics.median(r[3] for r in runs),
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
        ``session`` (its file), ``runs`` (per count: ``processes``, median ``wall_s`` and ``cpu_s``
        of one session, s; ``distinct_processes``; ``overlapped``: every timed session began before
        any ended) and ``ceiling`` (per count: the first count's wall time over this count's, the
        efficiency a perfectly parallel study could reach on this machine).
    """
    runs = [_at_once(args, n) for n in counts]
    ref = runs[0]["wall_s"]
    return {"session": args[0], "runs": runs, "ceiling": {r["processes"]: ref / r["wall_s"] for r in runs}}


def format_probe(p: dict[str, Any]) -> list[str]:
    """The probe's lines: one session's time at each count and the ceiling it sets."""
    first = p["runs"][0]["processes"]
    lines = [f"the machine under load: one session ({Path(p['session']).name}) processed by n processes at "
             f"once, the median of their times (s), not part of the runs:"]
    for r in p["runs"]:
        n = r["processes"]
        flag = "" if r["overlapped"] and r["distinct_processes"] == n else \
            "  (not all at once: this count's figure does not measure the load)"
        lines.append(f"  {n:>3} at once: {r['wall_s']:.2f} s wall, {r['cpu_s']:.2f} s CPU; ceiling on efficiency "
                     f"against {first}: {p['ceiling'][n]:.2f}{flag}")
    return lines
