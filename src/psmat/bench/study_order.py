"""The order of a study's sessions, replayed: when the last session would end on N workers handed
the sessions in each order, each session taking the time it took in a run just measured (its
``results/session_timings.csv``). The workers take the next session as each becomes free, as the
run's pool does (one task at a time per process); start-up and the work after the sessions are
left out, so the figures compare orders, not runs.

Orders: the largest file first (the order before :mod:`psmat.study` (``_order.py``)), the most
expected work first (the run's order now), the longest first with the measured times known (what
no run can know beforehand), and the even split (all the time over N: a bound no order passes).
"""

from __future__ import annotations

import csv
import heapq
from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["finish", "replay_orders", "format_orders"]


def finish(times: Sequence[float], workers: int) -> float:
    """When the last of ``times`` (s, in the order handed out) ends on ``workers`` workers that each
    take the next one as they become free."""
    free = [0.0] * workers
    for t in times:
        heapq.heappush(free, heapq.heappop(free) + t)
    return max(free)


def replay_orders(root: str | Path, counts: Sequence[int] = (2, 4, 8, 16)) -> dict[str, Any] | None:
    """The four orders' finish (s) for each worker count, from the sessions ``root``'s last run
    computed; None when it computed none."""
    from ..study import find_study, most_work_first

    root = Path(root)
    with open(root / "results" / "session_timings.csv", newline="") as fh:
        took = {r["stem"]: float(r["wall_s"]) for r in csv.DictReader(fh) if r["result"] == "computed"}
    if not took:
        return None
    items = [i for i in find_study(root).items if i.stem in took]
    orders = {
        "largest file first": sorted(items, key=lambda i: i.session.stat().st_size, reverse=True),
        "most work first": most_work_first(items, {i.stem: i.circuit for i in items}),
        "longest first (times known)": sorted(items, key=lambda i: took[i.stem], reverse=True),
    }
    rows = []
    for n in counts:
        row: dict[str, float] = {name: finish([took[i.stem] for i in order], n) for name, order in orders.items()}
        row["even split (bound)"] = sum(took.values()) / n
        rows.append({"workers": n, **row})
    return {"sessions": len(took), "rows": rows}


def format_orders(r: dict[str, Any]) -> list[str]:
    """:func:`replay_orders`' figures as lines of a table."""
    names = [k for k in r["rows"][0] if k != "workers"]
    lines = [f"order of the sessions, replayed on this run's {r['sessions']} session times "
             "(s until the last one ends; start-up and the work after them left out):",
             f"  {'workers':>7}" + "".join(f"{n:>{len(n) + 3}}" for n in names)]
    lines += [f"  {row['workers']:>7}" + "".join(f"{row[n]:>{len(n) + 3}.2f}" for n in names) for row in r["rows"]]
    return lines
