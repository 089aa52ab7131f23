"""A global conductance factor from a known load (eq. 3.3 generalised; docs/spec.md §4).

The thesis scaled its large mat by the body weight of the volunteer on it (§3.2.2, eq. 3.3):
one factor ``f`` on every cell's conductance so that the mean total force over the trial is
the weight. Here the load is any known one — calibration masses on a plate, a person of
known weight standing still — and the per-cell gains of an equilibration, when there are
some, are applied first:

    mean over the settled frames of  Σ_ij M(s · k_ij · g_ij)(t) · A  =  W

``M`` the inverse sensor model run over the whole recording, ``A`` the cell area, ``W`` the
load. ``s`` is solved by :func:`psmat.balance.scale_factor`, the one root finder of eq. 3.3.
The whole load must stand on the mat; a load partly off it gives a ``s`` too large.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from .. import _checks
from ..balance import scale_factor
from ..sensor import MPICreep
from ._window import recording_cells, settled_frames

__all__ = ["known_load"]


def known_load(g: ArrayLike, dt_s: float | ArrayLike, load_n: float, cell_area_cm2: float,
               gains: ArrayLike | None = None, sensor: MPICreep | None = None, *,
               settle_s: float = 3.0) -> float:
    """The global factor ``s`` of eq. 3.3 generalised (module docstring).

    Parameters
    ----------
    g : (T, R, C)
        Cell conductances of the recording (S), after IECM and the unloaded leakage removed;
        NaN frames are missing. It starts with the mat at rest.
    dt_s : float or (T,)
        Frame period(s) (s).
    load_n : float
        The known load W (N): masses × 9.80665 m/s², or a person's weight.
    cell_area_cm2 : float
        Cell area A (cm²).
    gains : (R, C), optional
        Per-cell gains of an equilibration (:func:`psmat.pressure.equilibrate`), applied first.
    sensor : MPICreep, optional
        The sensor model; default the thesis' (Table 2.11).
    settle_s : float
        Time after the load appears before frames enter the mean (s).

    Returns
    -------
    float
        ``s`` (dimensionless, > 0).

    Raises
    ------
    ValueError
        Bad shapes or values, no settled load, or no ``s`` that reaches the load (too few
        loaded cells: the inverse model saturates at its ``p_max``).
    """
    x = recording_cells(g, "g")
    w = _checks.positive("load_n", load_n)
    area = _checks.positive("cell_area_cm2", cell_area_cm2)
    if gains is not None:
        k = _checks.real_array(gains, "gains")
        if k.shape != x.shape[1:] or np.any(k <= 0):
            raise ValueError(f"gains must be {x.shape[1]}x{x.shape[2]} factors > 0, got shape {k.shape}")
        x = x * k
    usable, _, settled = settled_frames(x, dt_s, settle_s, "the known-load recording")
    mean_over = np.zeros(x.shape[0], bool)
    mean_over[np.flatnonzero(usable)[settled]] = True
    return scale_factor(x, dt_s, w, sensor, area, mean_over=mean_over)
