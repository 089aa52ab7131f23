"""What a worker process loads before its first task of a study run (docs/spec.md §12).

A study's tasks run in worker processes that must first import the processing chain (NumPy,
SciPy, h5py and psmat's chain, about 1.1 s on the 2-core machine) and, for the figures,
matplotlib's figure and Agg canvas (about 0.3 s more). A process pays each once, and when it
pays them decides whether anyone waits:

* psmat's own pool starts its processes before this process looks for the sessions
  (:mod:`psmat.study` (``_run.py``)): each runs :func:`warm` as its first task, so the imports,
  matplotlib's included, pass while the sessions are found; on a lent 16-core machine finding them
  took 2.46 s, longer than the processes' start, and each of the 7 figures was drawn by a process
  that imported matplotlib at that moment, on the run's critical path;
* a Dask cluster's workers are already running, but import on their first task:
  :func:`psmat.study._cluster.warm_cluster` sends :func:`warm` to each of them first. In a
  16-worker LocalCluster run of the thesis-size study the first session started 1.21 s after the
  sessions were found and keyed; on the 2-core machine (4 volunteers, 20 s trials, 2 workers)
  0.93 s.

On the 2-core machine this gains nothing and loses nothing (a run's processes have no idle core to
import on while the sessions are found): 4 volunteers, 20 s trials, 2 workers, the code before and
after alternating, wall time of the run (s): on the pool 9.77, 11.45, 11.75 before and 9.91, 10.29,
10.85 after; on a 2-worker LocalCluster 11.36, 9.84, 12.07 before and 11.33, 10.09, 12.00 after. What
it should save on 16 cores (the first session's 1.21 s, and matplotlib's 0.3 s before the figures)
has not been measured yet.

Nothing here changes a result: the same modules are imported by the first task otherwise.
"""

from __future__ import annotations

import os

__all__ = ["warm"]


def warm() -> int:
    """Import a study task's modules and matplotlib's figure and Agg canvas in this process; its pid.

    Returns
    -------
    int
        This process's id (a plain number, as a cluster's answers must be).
    """
    from . import _task  # noqa: F401 - the session chain (the package's import brings the other tasks' modules)
    from ._figures import load_canvas

    load_canvas()
    return os.getpid()
